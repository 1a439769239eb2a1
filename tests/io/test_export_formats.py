"""Export formats: npy-channels round trip, C/C++ header compiled and read back, half-float EXR.

Independent truths: ``numpy.load`` for the .npy files, a C compiler for the header, OpenEXR
itself and numpy's IEEE float16 rounding for the half EXR."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import OpenEXR
import pytest

from bsdf_tab import read_exr
from bsdf_tab.io.c_header import c_identifier, header_text, write_header
from bsdf_tab.io.half_exr import to_half, write_half_exr
from bsdf_tab.io.npy_channels import read_npy_channels, write_npy_channels
from bsdf_tab.table import Table


def to_half_table(table):
    return to_half(table, Table)


def make_table(shape=(3, 4, 5), seed=1) -> Table:
    rng = np.random.default_rng(seed)
    names = ["ior", "mu", "roughness"][: len(shape)]
    axes = {n: np.sort(rng.uniform(0.01, 3.0, size=s)) for n, s in zip(names, shape)}
    axes[names[0]][0] = 1.00000002  # a value float32 cannot hold
    e = rng.uniform(0.0, 1.0, size=shape)
    e.flat[0], e.flat[1], e.flat[2], e.flat[3] = 1.0, 0.0, 1e-8, 0.999999
    err = rng.uniform(0.0, 1e-6, size=shape)
    t = rng.uniform(-2.0, 2.0, size=shape)
    channels = {"E": e, "E_err": err, "T": t, "T_err": np.full(shape, 3e-7)}
    meta = {"table": "test", "spec": {"table": "test"}, "conventions": {"note": "a */ inside a comment"},
            "version": "0.0.0"}
    return Table(axes, channels, meta)


# --------------------------------------------------------------------------- npy-channels


@pytest.mark.parametrize("stacked", [False, True])
def test_npy_round_trip(tmp_path, stacked):
    table = make_table()
    paths = write_npy_channels(table, tmp_path, "tab", stacked=stacked)
    assert all(p.exists() for p in paths)
    assert paths[-1] == tmp_path / "tab.meta.json"  # the sidecar comes last
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)  # no temporaries
    info = json.loads((tmp_path / "tab.meta.json").read_text())
    assert info["axis_order"] == ["ior", "mu", "roughness"] and info["channel_order"] == ["E", "E_err", "T", "T_err"]
    if stacked:
        data = np.load(tmp_path / "tab.npy")
        assert data.shape == (3, 4, 5, 4) and data.dtype == np.float32
        np.testing.assert_array_equal(data[..., 2], table.channels["T"].astype(np.float32))
    else:
        e = np.load(tmp_path / "tab.E.npy")
        assert e.shape == (3, 4, 5) and e.dtype == np.float32
        np.testing.assert_array_equal(e, table.channels["E"].astype(np.float32))
    np.testing.assert_array_equal(np.load(tmp_path / "tab.axis.ior.npy"), table.axes["ior"])  # float64, exact
    back = read_npy_channels(tmp_path, "tab", Table)
    assert list(back.axes) == list(table.axes) and back.meta == table.meta
    for name in table.channels:
        np.testing.assert_array_equal(back.channels[name], table.channels[name].astype(np.float32))


def test_npy_missing_folder(tmp_path):
    with pytest.raises(FileNotFoundError):
        write_npy_channels(make_table(), tmp_path / "nope", "tab")


# --------------------------------------------------------------------------- C header

COMPILERS = [c for c in ("cc", "g++") if shutil.which(c)]

PROGRAM = r"""
#include <stdio.h>
#include "tab.h"
int main(void) {
    int a, b, c;
    printf("%d %d %d %d %d\n", TAB_NDIM, TAB_SIZE_IOR, TAB_SIZE_MU, TAB_SIZE_ROUGHNESS, TAB_NUM_CHANNELS);
    for (a = 0; a < TAB_SIZE_IOR; ++a) printf("%.17g\n", tab_axis_ior[a]);
    for (a = 0; a < TAB_SIZE_IOR; ++a)
        for (b = 0; b < TAB_SIZE_MU; ++b)
            for (c = 0; c < TAB_SIZE_ROUGHNESS; ++c)
                printf("%.9g %.9g %.9g\n", tab_E[a][b][c], tab_T[a][b][c], tab_E_err[a][b][c]);
    return 0;
}
"""


@pytest.mark.skipif(not COMPILERS, reason="no C/C++ compiler")
@pytest.mark.parametrize("compiler", COMPILERS)
def test_header_compiles_and_values_round_trip(tmp_path, compiler):
    table = make_table()
    write_header(table, tmp_path / "tab.h", name="tab")
    src = tmp_path / "main.c"
    src.write_text(PROGRAM)
    exe = tmp_path / "main"
    flags = ["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror"] if compiler == "cc" else ["-x", "c++", "-Wall", "-Werror"]
    subprocess.run([compiler, *flags, str(src), "-o", str(exe)], check=True, capture_output=True, cwd=tmp_path)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split("\n")
    assert out[0].split() == ["3", "3", "4", "5", "4"]
    np.testing.assert_array_equal([float(x) for x in out[1:4]], table.axes["ior"])  # axes exact (double)
    rows = np.array([[float(x) for x in line.split()] for line in out[4:] if line.strip()])
    assert rows.shape == (60, 3)
    for k, name in enumerate(["E", "T", "E_err"]):
        want = table.channels[name].astype(np.float32).ravel()  # row-major [ior][mu][roughness]
        np.testing.assert_array_equal(rows[:, k].astype(np.float32), want)


def test_header_text_layout_and_comments():
    table = make_table((2, 3), seed=2)
    text = header_text(table, name="my-table.v2")
    assert "static const float my_table_v2_E[2][3] = {" in text
    assert "static const double my_table_v2_axis_ior[2]" in text
    assert "#define MY_TABLE_V2_SIZE_MU 3" in text
    assert "value = channel[i_ior][i_mu]" in text
    # comments never close early: the only "*/" ends the comment block and the include guard line
    body = text.split("\n */\n", 1)
    assert "*/" not in body[0]
    assert c_identifier("9lives") == "_9lives"


@pytest.mark.skipif("cc" not in COMPILERS, reason="no C compiler")
def test_header_with_non_finite_values_compiles(tmp_path):
    table = make_table((2, 2), seed=3)
    table.channels["T"][0, 0] = np.nan
    table.channels["T"][0, 1] = np.inf
    write_header(table, tmp_path / "nf.h", name="nf")
    (tmp_path / "m.c").write_text('#include <stdio.h>\n#include "nf.h"\nint main(void){printf("%d %d\\n", nf_T[0][0] != nf_T[0][0], nf_T[0][1] > 1e30f);return 0;}\n')
    subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "m.c", "-o", "m"], check=True, capture_output=True, cwd=tmp_path)
    out = subprocess.run([str(tmp_path / "m")], check=True, capture_output=True, text=True).stdout.split()
    assert out == ["1", "1"]


# --------------------------------------------------------------------------- half EXR


def test_half_exr_round_trip_error_bounded(tmp_path):
    table = make_table((4, 6, 5), seed=4)
    path = tmp_path / "tab.half.exr"
    reported = write_half_exr(table, path)
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        header = dict(exr.header())
        types = {n: np.array(c.pixels).dtype for n, c in exr.channels().items()}
    assert set(types.values()) == {np.dtype(np.float16)}  # HALF channels
    assert json.loads(header["bsdf_tab_half_error"]) == pytest.approx(reported)
    assert "float16" in header["bsdf_tab_layout"]
    back = read_exr(path)
    assert list(back.axes) == list(table.axes)
    np.testing.assert_array_equal(back.axes["ior"], table.axes["ior"])
    for name in ("E", "T"):
        x = table.channels[name]
        diff = np.abs(back.channels[name].astype(np.float64) - x)
        assert diff.max() <= reported[name]
        assert diff.max() == pytest.approx(reported[name], rel=1e-12)  # the max is attained
        # independent bound: half has 11 significant bits, rounding error <= 2^-11 |x| (normal range)
        assert (diff <= np.abs(x) * 2.0**-11 + 2.0**-25).all()
        # the stored error channel covers the original error plus the rounding
        stored_err = back.channels[name + "_err"].astype(np.float64)
        assert (stored_err >= table.channels[name + "_err"] + diff).all()
    assert back.meta["half_float"]["max_abs_rounding_error"] == pytest.approx(reported)
    assert reported["E"] > 1e-5  # random values in [0, 1] do lose digits in half


def test_half_rejects_out_of_range():
    table = make_table((2, 2), seed=5)
    table.channels["T"][0, 0] = 1e6
    with pytest.raises(ValueError, match="float16 range"):
        to_half_table(table)


def test_half_exact_values_have_zero_error():
    table = make_table((2, 2), seed=6)
    table.channels["E"][:] = np.array([[0.5, 0.25], [1.0, 0.0]])
    half, reported = to_half_table(table)
    assert reported["E"] == 0.0
    np.testing.assert_array_equal(half.channels["E_err"] >= table.channels["E_err"].astype(np.float16), True)


def test_half_exr_channels_are_numpy_float16_rounding(tmp_path):
    """The file (read by OpenEXR directly) holds numpy's IEEE round-to-nearest float16 of each
    value, and each error channel holds the smallest float16 >= original error + |float16(x) - x|."""
    table = make_table((3, 4, 5), seed=7)
    path = tmp_path / "r.half.exr"
    write_half_exr(table, path)
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        header = dict(exr.header())
        pixels = {n: np.array(c.pixels) for n, c in exr.channels().items()}
    reported = json.loads(header["bsdf_tab_half_error"])
    for name in ("E", "T"):
        x = table.channels[name]
        img = pixels[name].reshape(x.shape)  # 3-D: axis-0 slices stacked vertically
        np.testing.assert_array_equal(img, x.astype(np.float16))
        rounding = np.abs(x.astype(np.float16).astype(np.float64) - x)
        assert reported[name] == rounding.max()
        need = table.channels[name + "_err"] + rounding
        err = pixels[name + "_err"].reshape(x.shape)
        assert err.dtype == np.float16
        assert (err.astype(np.float64) >= need).all()  # a bound
        below = np.nextafter(err, np.float16(-np.inf)).astype(np.float64)
        assert (below < need).all()  # and the tightest half-float bound
    meta = json.loads(header["bsdf_tab_meta"])
    assert meta["max_error"]["E"] == float(pixels["E_err"].astype(np.float64).max())


def test_half_exr_written_atomically(tmp_path):
    table = make_table((2, 3), seed=8)
    table.channels["E"][0, 0] = 7e4  # beyond half
    (tmp_path / "keep.half.exr").write_bytes(b"old")
    with pytest.raises(ValueError, match="float16 range"):
        write_half_exr(table, tmp_path / "keep.half.exr")
    assert (tmp_path / "keep.half.exr").read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.half.exr"]
