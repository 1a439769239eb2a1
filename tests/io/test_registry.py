"""The format registry: one name, endings and media type per format; clear errors; round trips.

The expected mapping is written out here (the documented contract), not read from the code."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

import bsdf_tab.io as bio
from bsdf_tab.errors import SpecError
from bsdf_tab.table import Table

#: name -> (file name endings, media type): the contract in bsdf_tab/io/__init__.py
EXPECTED = {
    "exr": ((".exr",), "image/x-exr"),
    "half-exr": ((".half.exr",), "image/x-exr"),
    "npz": ((".npz",), "application/x-npz"),
    "npy": ((".npy",), "application/x-npy"),
    "npy-channels": ((".meta.json",), None),
    "json": ((".json",), "application/json"),
    "h": ((".h",), "text/x-c"),
    "ktx2": ((".ktx2",), "image/ktx2"),
    "dds": ((".dds",), "image/vnd-ms.dds"),
    "png": ((".png",), "image/png"),
}
READABLE = ["exr", "half-exr", "npz", "npy-channels", "json"]  # lossless round trips
TEXTURES_READABLE = ["ktx2", "png"]  # read back as stored (quantized): tests/io/test_texture_formats.py


def make_table(seed: int = 0) -> Table:
    rng = np.random.default_rng(seed)
    axes = {"mu": np.array([0.1, 1 / 3, 1.0]), "alpha": np.array([1e-3, 0.5])}
    channels = {
        "E": rng.random((3, 2)).astype(np.float32),
        "E_err": (1e-6 * rng.random((3, 2))).astype(np.float32),
    }
    return Table(axes, channels, {"spec": {"table": "albedo"}, "version": "0.0.test", "note": [1, "two"]})


def test_names_endings_and_media_types():
    assert bio.names() == list(EXPECTED)
    for name, (suffixes, media) in EXPECTED.items():
        f = bio.get_format(name)
        assert f.name == name and f.suffixes == suffixes and f.media_type == media
    assert bio.names(readable=True) == READABLE + TEXTURES_READABLE
    assert bio.names(single_file=False) == ["npy-channels"]


@pytest.mark.parametrize(
    "path, name",
    [
        ("lut.exr", "exr"),
        ("LUT.EXR", "exr"),
        ("out/lut.half.exr", "half-exr"),
        ("lut.Half.Exr", "half-exr"),
        ("lut.npz", "npz"),
        ("lut.npy", "npy"),
        ("cycles_E.meta.json", "npy-channels"),
        ("lut.json", "json"),
        ("lut.h", "h"),
        ("my.table.v2.h", "h"),
    ],
)
def test_format_for_a_path_takes_the_longest_ending(path, name):
    assert bio.format_for(path).name == name
    from pathlib import Path

    assert bio.format_for(Path(path)).name == name


def test_format_for_a_name():
    for name in EXPECTED:
        assert bio.format_for(name).name == name


@pytest.mark.parametrize("bad, param, fragments", [
    ("lut.xyz", "path", ["lut.xyz", "'.xyz'", ".exr", ".half.exr", ".h"]),
    ("lut.tar.gz", "path", ["'.gz'", ".npz"]),
    ("xml", "format", ["'xml'", "exr", "npy-channels"]),
])
def test_unknown_ending_or_name_is_a_clear_error(bad, param, fragments):
    with pytest.raises(SpecError) as info:
        bio.format_for(bad)
    assert isinstance(info.value, bio.FormatError) and isinstance(info.value, ValueError)
    assert info.value.param == param
    assert "\n" not in str(info.value)
    for fragment in fragments:
        assert fragment in str(info.value)


def test_write_with_unknown_ending_writes_nothing(tmp_path):
    with pytest.raises(bio.FormatError, match="'.tiff'"):
        bio.write(make_table(), tmp_path / "lut.tiff")
    with pytest.raises(bio.FormatError, match="'tga'"):
        bio.write(make_table(), tmp_path / "lut.exr", fmt="tga")
    assert not any(tmp_path.iterdir())


def test_write_only_formats_say_so():
    for name in ("npy", "h"):
        with pytest.raises(bio.FormatError, match=f"{name} files cannot be read back"):
            bio.from_bytes(b"", name)
    with pytest.raises(bio.FormatError, match="several files"):
        bio.to_bytes(make_table(), "npy-channels")


def test_media_type_lookup_and_accept_aliases():
    assert bio.format_for_media("image/x-exr").name == "exr"  # shared with half-exr: exr wins
    assert bio.format_for_media("Application/X-NPY").name == "npy"
    assert bio.format_for_media("text/html") is None
    served = ("exr", "npz", "npy", "json")
    assert bio.media_types(served) == {n: EXPECTED[n][1] for n in served}
    assert bio.accept_types(served) == {
        "image/x-exr": "exr", "image/exr": "exr", "image/aces": "exr",
        "application/x-npz": "npz", "application/zip": "npz",
        "application/x-npy": "npy",
        "application/json": "json", "text/json": "json",
    }
    with pytest.raises(bio.FormatError, match="npy-channels has no media type"):
        bio.media_types(["npy-channels"])


def test_the_service_takes_its_names_and_media_types_from_the_registry():
    from service import params

    assert set(params.FORMATS) <= set(bio.names())
    for name in params.FORMATS:
        assert params.MEDIA_TYPES[name] == EXPECTED[name][1]


@pytest.mark.parametrize("name", READABLE)
def test_round_trip_through_the_registry(tmp_path, name):
    table = make_table(1)
    path = bio.output_path(tmp_path, "lut", name)
    assert path.name == "lut" + EXPECTED[name][0][0]
    written = bio.write(table, path)
    assert written[0].exists() and path.exists()
    back = bio.read(path, factory=Table)
    assert isinstance(back, Table)
    assert list(back.axes) == list(table.axes)
    for n in table.axes:
        assert back.axes[n].tolist() == table.axes[n].tolist()  # float64, exact
    assert list(back.channels) == list(table.channels)
    for n, values in table.channels.items():
        if name == "half-exr" and n == "E":
            np.testing.assert_array_equal(back.channels[n], values.astype(np.float16))
        elif name == "half-exr":  # the error channel grew by the rounding
            assert (back.channels[n] >= values).all()
        else:
            np.testing.assert_array_equal(back.channels[n], values)
    if name == "half-exr":
        assert back.meta["half_float"]["max_abs_rounding_error"]["E"] > 0
    else:
        assert back.meta == table.meta
    parts = bio.read(path)
    assert isinstance(parts, bio.TableParts) and list(parts.channels) == list(table.channels)


@pytest.mark.parametrize("name", ["exr", "half-exr", "npz", "json"])
def test_bytes_round_trip(name):
    table = make_table(2)
    data = bio.to_bytes(table, name)
    back = bio.from_bytes(data, name, factory=Table)
    assert list(back.channels) == list(table.channels)
    tol = 2.0**-11 if name == "half-exr" else 0.0
    np.testing.assert_allclose(back.channels["E"], table.channels["E"], rtol=tol, atol=0)


def test_to_bytes_is_what_write_puts_in_the_file(tmp_path):
    table = make_table(3)
    for name in ("npz", "npy", "json"):
        path = bio.output_path(tmp_path, "t", name)
        bio.write(table, path)
        if name == "npz":  # zip members carry a timestamp: compare what numpy reads
            a, b = np.load(path), np.load(io.BytesIO(bio.to_bytes(table, name)))
            assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files)
        else:
            assert path.read_bytes() == bio.to_bytes(table, name)


def test_as_stored_is_the_half_table_only_for_half_exr():
    table = make_table(4)
    assert bio.as_stored(table, "exr") is table
    half = bio.as_stored(table, "half-exr", factory=Table)
    assert half.channels["E"].dtype == np.float16
    np.testing.assert_array_equal(half.channels["E"], table.channels["E"].astype(np.float16))
    assert half.max_error()["E"] >= table.max_error()["E"]


def test_npy_is_one_structured_array_for_plain_numpy(tmp_path):
    table = make_table(5)
    bio.write(table, tmp_path / "lut.npy")
    arr = np.load(tmp_path / "lut.npy", allow_pickle=False)
    assert arr.shape == (3, 2)
    assert arr.dtype.names == ("E", "E_err")
    assert all(arr.dtype[n] == np.dtype("<f8") for n in arr.dtype.names)
    np.testing.assert_array_equal(arr["E"], table.channels["E"])
    np.testing.assert_array_equal(arr["E_err"], table.channels["E_err"])
    assert [p.name for p in tmp_path.iterdir()] == ["lut.npy"]


def test_json_is_strict_and_non_finite_becomes_null(tmp_path):
    axes = {"alpha": np.array([0.1, 0.2, 0.3])}
    table = Table(axes, {"E_avg": np.array([np.nan, 0.5, np.inf]), "E_avg_err": np.array([1e-9, 2e-9, 3e-9])},
                  {"max_error": {"E_avg": float("nan")}, "spec": {"table": "albedo_avg"}})
    bio.write(table, tmp_path / "t.json")
    text = (tmp_path / "t.json").read_text()
    doc = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    assert doc["channels"]["E_avg"] == [None, 0.5, None]
    assert doc["axes"] == {"alpha": [0.1, 0.2, 0.3]} and doc["shape"] == [3]
    assert doc["meta"]["max_error"] == {"E_avg": None}
    back = bio.read(tmp_path / "t.json", factory=Table)
    assert np.isnan(back.channels["E_avg"][0]) and back.channels["E_avg"][1] == 0.5
    assert back.channels["E_avg_err"].tolist() == [1e-9, 2e-9, 3e-9]


@pytest.mark.parametrize("name, data, fragment", [
    ("npz", b"not a zip", "not a bsdf-tab npz archive"),
    ("json", b"{", "not valid JSON"),
    ("json", b"[1, 2]", "not a bsdf-tab table"),
    ("exr", b"not an exr", "not an OpenEXR file"),
])
def test_reading_foreign_data_is_a_clear_error(name, data, fragment):
    with pytest.raises(ValueError, match=fragment):
        bio.from_bytes(data, name)


def test_write_into_a_missing_folder(tmp_path):
    for name in bio.names():
        with pytest.raises(FileNotFoundError, match="does not exist"):
            bio.write(make_table(), bio.output_path(tmp_path / "missing", "t", name))


def test_npy_channels_by_stem_or_sidecar(tmp_path):
    table = make_table(6)
    written = bio.write(table, tmp_path / "cycles_E", fmt="npy-channels")
    assert [p.name for p in written] == ["cycles_E.E.npy", "cycles_E.E_err.npy", "cycles_E.axis.mu.npy",
                                         "cycles_E.axis.alpha.npy", "cycles_E.meta.json"]
    e = np.load(tmp_path / "cycles_E.E.npy", allow_pickle=False)  # plain numpy, one array per channel
    assert e.dtype == np.float32 and e.shape == (3, 2)
    np.testing.assert_array_equal(e, table.channels["E"])
    back = bio.read(tmp_path / "cycles_E.meta.json", factory=Table)
    assert back.meta == table.meta and back.axes["mu"].tolist() == table.axes["mu"].tolist()
    (tmp_path / "cycles_E.E_err.npy").unlink()
    with pytest.raises(FileNotFoundError):
        bio.read(tmp_path / "cycles_E.meta.json")


def test_constants_for_option_choices():
    assert bio.FILE_FORMATS == tuple(EXPECTED)
    assert bio.ENDINGS == tuple(e for suffixes, _ in EXPECTED.values() for e in suffixes)


def test_table_methods_delegate_to_the_registry(tmp_path):
    table = make_table(7)
    assert table.write(tmp_path / "t.npz") == [tmp_path / "t.npz"]
    back = Table.read(tmp_path / "t.npz")
    assert isinstance(back, Table) and back.meta == table.meta
    np.testing.assert_array_equal(Table.from_bytes(table.to_bytes("json"), "json").channels["E"], table.channels["E"])
    assert table.as_stored("npz") is table
    half = table.as_stored("half-exr")
    assert isinstance(half, Table) and half.channels["E"].dtype == np.float16
