"""Tests of bsdf_tab.table.Table and the float32 EXR format (bsdf_tab.io.exr).

The independent truth for the file is OpenEXR itself: the header and pixels are read with
``OpenEXR.File`` directly and checked against the documented layout."""

import json
import os

import numpy as np
import OpenEXR
import pytest

from bsdf_tab import read_exr, write_exr
from bsdf_tab.io.exr import exr_bytes, read_exr_bytes
from bsdf_tab.spec import normalize_spec, resolve_axes
from bsdf_tab.table import Table

SPECS = {
    "1d": {"table": "albedo_avg", "axes": {"alpha": {"size": 7}}},
    "2d": {"table": "albedo", "axes": {"mu": [0.0, 1e-6, 0.3, 1.0], "roughness": {"size": 5, "nodes": "centers"}}},
    "3d": {"table": "dielectric", "axes": {"mu": {"size": 3}, "alpha": [0.1, 0.2], "eta": [0.5, 1.0, 1.5, 2.5]}},
}
CHANNELS = {"1d": ["E_avg"], "2d": ["E"], "3d": ["R", "T"]}


def make_table(key: str, seed: int = 0) -> Table:
    """A hand-built table with random, NaN-free float32 data and error channels."""
    spec = normalize_spec(SPECS[key])
    axes = resolve_axes(spec)
    shape = tuple(len(a) for a in axes.values())
    rng = np.random.default_rng(seed)
    channels = {}
    for name in CHANNELS[key]:
        channels[name] = rng.random(shape).astype(np.float32)
    for name in CHANNELS[key]:
        channels[name + "_err"] = (1e-7 * rng.random(shape)).astype(np.float32)
    meta = {
        "spec": spec,
        "conventions": {"frame": "n = +z, directions point away", "alpha": "roughness^2"},
        "method": "adaptive",
        "version": "0.0.test",
    }
    table = Table(axes, channels, meta)
    table.meta["max_error"] = table.max_error()
    return table


def assert_tables_equal(a: Table, b: Table) -> None:
    assert list(a.axes) == list(b.axes)
    for name in a.axes:
        assert b.axes[name].dtype == np.float64
        np.testing.assert_array_equal(a.axes[name], b.axes[name])
    assert list(a.channels) == list(b.channels)
    for name in a.channels:
        assert b.channels[name].dtype == np.float32
        assert b.channels[name].shape == a.shape
        np.testing.assert_array_equal(a.channels[name], b.channels[name])
    assert a.meta == b.meta


# --------------------------------------------------------------------------- Table


def test_table_properties():
    t = make_table("3d")
    assert t.shape == (3, 2, 4)
    assert t.value_channels == ["R", "T"]
    assert t.error_channels == ["R_err", "T_err"]
    assert t.kind == "dielectric"
    max_err = t.max_error()
    assert set(max_err) == {"R", "T"}
    assert max_err["R"] == float(t.channels["R_err"].max())
    assert 0 < max_err["T"] < 1e-7


def test_table_rejects_wrong_channel_shape():
    with pytest.raises(ValueError, match="shape"):
        Table({"mu": np.array([0.0, 1.0]), "alpha": np.array([0.1, 0.2, 0.3])}, {"E": np.zeros((3, 2))})


def test_table_rejects_bad_axes():
    with pytest.raises(ValueError):
        Table({}, {})
    with pytest.raises(ValueError):
        Table({"mu": np.zeros((2, 2))}, {})
    with pytest.raises(ValueError):
        Table({"mu": np.array([])}, {})


def test_npz_round_trip():
    t = make_table("3d")
    assert_tables_equal(t, Table.from_npz_bytes(t.to_npz_bytes()))


def test_json_dict():
    t = make_table("2d")
    d = json.loads(json.dumps(t.to_json_dict()))
    assert list(d["axes"]) == ["mu", "roughness"]
    assert d["axes"]["mu"] == [0.0, 1e-6, 0.3, 1.0]
    assert d["shape"] == [4, 5]
    assert np.array_equal(np.array(d["channels"]["E"], dtype=np.float32), t.channels["E"])
    assert d["meta"]["spec"]["table"] == "albedo"


def test_json_dict_non_finite_becomes_null():
    t = Table({"alpha": np.array([0.1, 0.2])}, {"E_avg": np.array([np.nan, 0.5], dtype=np.float32)})
    assert t.to_json_dict()["channels"]["E_avg"] == [None, 0.5]


# --------------------------------------------------------------------------- EXR round trip


@pytest.mark.parametrize("key", ["1d", "2d", "3d"])
def test_exr_round_trip_exact(tmp_path, key):
    t = make_table(key, seed=int(key[0]))
    path = tmp_path / f"{key}.exr"
    t.write_exr(path)
    back = read_exr(path)
    assert_tables_equal(t, back)
    assert back.meta["spec"] == normalize_spec(SPECS[key])


def test_exr_round_trip_float64_channels_become_float32(tmp_path):
    axes = {"alpha": np.array([0.1, 0.2, 0.3])}
    values = np.array([1 / 3, 2 / 3, 0.1], dtype=np.float64)
    write_exr(Table(axes, {"E_avg": values}, {}), tmp_path / "a.exr")
    back = read_exr(tmp_path / "a.exr")
    np.testing.assert_array_equal(back.channels["E_avg"], values.astype(np.float32))


def test_exr_axes_keep_full_float64_precision(tmp_path):
    axes = {"mu": np.array([0.1, 1 / 3, np.nextafter(0.5, 1.0)]), "alpha": np.array([1e-300, 0.7])}
    t = Table(axes, {"E": np.ones((3, 2), dtype=np.float32)}, {"spec": {}})
    t.write_exr(tmp_path / "p.exr")
    back = read_exr(tmp_path / "p.exr")
    assert back.axes["mu"].tolist() == axes["mu"].tolist()
    assert back.axes["alpha"].tolist() == axes["alpha"].tolist()


def test_exr_bytes_round_trip():
    t = make_table("3d")
    data = exr_bytes(t)
    assert data[:4] == b"\x76\x2f\x31\x01"
    assert_tables_equal(t, read_exr_bytes(data, Table))


def raw_exr(path):
    with OpenEXR.File(str(path), separate_channels=True) as f:
        header = dict(f.header())
        pixels = {name: np.array(ch.pixels) for name, ch in f.channels().items()}
    return header, pixels


def test_exr_header_attributes_are_json_strings(tmp_path):
    t = make_table("3d")
    t.write_exr(tmp_path / "h.exr")
    header, _ = raw_exr(tmp_path / "h.exr")
    for key in ("bsdf_tab_spec", "bsdf_tab_axes", "bsdf_tab_channels", "bsdf_tab_meta", "bsdf_tab_layout",
                "bsdf_tab_version"):
        assert isinstance(header[key], str), key
    # the standard attributes OpenEXR readers expect, as the header has always had them
    assert header["compression"] == OpenEXR.ZIP_COMPRESSION
    assert header["type"] == OpenEXR.scanlineimage
    assert isinstance(header["pixelAspectRatio"], float) and header["pixelAspectRatio"] == 1.0
    assert header["screenWindowCenter"].dtype == np.float32  # float attributes are 32-bit
    assert json.loads(header["bsdf_tab_channels"]) == ["R", "T", "R_err", "T_err"]
    assert json.loads(header["bsdf_tab_spec"]) == t.meta["spec"]
    assert json.loads(header["bsdf_tab_meta"]) == t.meta
    axes = json.loads(header["bsdf_tab_axes"])
    assert [name for name, _ in axes] == ["mu", "alpha", "eta"]
    assert axes[2][1] == [0.5, 1.0, 1.5, 2.5]
    assert header["bsdf_tab_version"] == "0.0.test"
    assert "stacked vertically" in header["bsdf_tab_layout"]
    assert "i_mu*2 + i_alpha" in header["bsdf_tab_layout"]


@pytest.mark.parametrize("key", ["1d", "2d", "3d"])
def test_exr_pixel_layout_matches_documentation(tmp_path, key):
    t = make_table(key)
    t.write_exr(tmp_path / "l.exr")
    header, pixels = raw_exr(tmp_path / "l.exr")
    assert set(pixels) == set(t.channels)
    for name, values in t.channels.items():
        img = pixels[name]
        assert img.dtype == np.float32
        if values.ndim == 1:
            assert img.shape == (1, len(values))
            for j in range(len(values)):
                assert img[0, j] == values[j]
        elif values.ndim == 2:
            assert img.shape == values.shape
            for i in range(values.shape[0]):
                for j in range(values.shape[1]):
                    assert img[i, j] == values[i, j]
        else:
            n0, n1, n2 = values.shape
            assert img.shape == (n0 * n1, n2)
            for i0 in range(n0):
                for i1 in range(n1):
                    for j in range(n2):
                        assert img[i0 * n1 + i1, j] == values[i0, i1, j]


def test_exr_channels_r_and_t_stay_separate(tmp_path):
    t = make_table("3d")
    t.write_exr(tmp_path / "rt.exr")
    back = read_exr(tmp_path / "rt.exr")
    assert {"R", "T"} <= set(back.channels)
    assert not np.array_equal(back.channels["R"], back.channels["T"])


# --------------------------------------------------------------------------- errors


def test_read_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        read_exr(tmp_path / "missing.exr")


def test_read_not_an_exr(tmp_path):
    path = tmp_path / "text.exr"
    path.write_text("hello")
    with pytest.raises(ValueError, match="not an OpenEXR file"):
        read_exr(path)


def test_read_foreign_exr(tmp_path):
    path = tmp_path / "plain.exr"
    rgb = np.zeros((2, 3), dtype=np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"R": rgb, "G": rgb, "B": rgb}) as f:
        f.write(str(path))
    with pytest.raises(ValueError, match="not a bsdf-tab table"):
        read_exr(path)


def test_write_into_missing_folder(tmp_path):
    with pytest.raises(FileNotFoundError):
        make_table("1d").write_exr(tmp_path / "no" / "such" / "dir.exr")


def test_write_leaves_no_temp_files(tmp_path):
    make_table("2d").write_exr(tmp_path / "x.exr")
    assert [p.name for p in tmp_path.iterdir()] == ["x.exr"]


def test_write_without_channels_is_refused(tmp_path):
    with pytest.raises(ValueError, match="without channels"):
        Table({"alpha": np.array([0.1])}, {}, {}).write_exr(tmp_path / "e.exr")
    assert not any(tmp_path.iterdir())


def test_version_attribute_falls_back_to_the_package_version(tmp_path):
    from bsdf_tab.version import __version__

    Table({"alpha": np.array([0.1, 0.2])}, {"E_avg": np.array([0.5, 0.25])}, {}).write_exr(tmp_path / "v.exr")
    header, _ = raw_exr(tmp_path / "v.exr")
    assert header["bsdf_tab_version"] == __version__ and __version__


def test_written_file_is_readable_by_others_under_default_umask(tmp_path):
    old = os.umask(0o022)
    try:
        make_table("1d").write_exr(tmp_path / "x.exr")
    finally:
        os.umask(old)
    assert (tmp_path / "x.exr").stat().st_mode & 0o777 == 0o644
