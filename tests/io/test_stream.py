"""The streaming writer: synthetic blocks in, the in-memory writer's file out.

Truths: the in-memory EXR writer's file as OpenEXR reads it (header and pixels) and its
bytes; the documented pixel layout applied to the table's own arrays; ``numpy.load`` of the
npz archives."""

from __future__ import annotations

import io
import json
import random

import numpy as np
import OpenEXR
import pytest

import bsdf_tab.io as bio
from bsdf_tab.io import stream
from bsdf_tab.table import Table

CHANNELS = ["f_r", "f_t", "f_r_err", "f_t_err"]


def make_table(shape=(5, 3, 4), seed=0) -> Table:
    rng = np.random.default_rng(seed)
    names = ["theta_i", "theta_o", "phi_d"][: len(shape)]
    axes = {n: np.sort(rng.uniform(0.0, 1.5, size=s)) for n, s in zip(names, shape)}
    axes[names[0]][0] = 1 / 3  # needs all float64 digits
    channels = {
        "f_r": rng.uniform(0.0, 50.0, size=shape),
        "f_t": rng.uniform(0.0, 2.0, size=shape),
        "f_r_err": rng.uniform(0.0, 1e-12, size=shape),
        "f_t_err": rng.uniform(0.0, 1e-13, size=shape),
    }
    channels["f_t"].flat[0] = 0.1  # not a float32 value
    meta = {"table": "bsdf", "spec": {"table": "bsdf", "alpha": 0.2}, "version": "0.0.test",
            "max_error": {"f_r": float(channels["f_r_err"].max()), "f_t": float(channels["f_t_err"].max())}}
    return Table(axes, channels, meta)


def slab_blocks(table: Table, slices: int, shuffle: bool = False):
    """(start texel, (4, nb, ...) values) over blocks of ``slices`` axis-0 slices."""
    shape = table.shape
    per = int(np.prod(shape[1:]))
    starts = list(range(0, shape[0], slices))
    if shuffle:
        random.Random(1).shuffle(starts)
    for s in starts:
        e = min(shape[0], s + slices)
        yield s * per, np.stack([table.channels[c][s:e] for c in CHANNELS])


def texel_blocks(table: Table, size: int):
    """(start texel, {channel: flat values}) over runs of ``size`` texels, not slice-aligned."""
    flat = {c: table.channels[c].reshape(-1) for c in CHANNELS}
    n = flat["f_r"].size
    for s in range(0, n, size):
        yield s, {c: v[s : s + size] for c, v in flat.items()}


def read_raw(path):
    with OpenEXR.File(str(path), separate_channels=True) as f:
        header = dict(f.header())
        pixels = {name: np.array(ch.pixels) for name, ch in f.channels().items()}
    return header, pixels


def comparable(header: dict) -> dict:
    return {k: (tuple(np.asarray(x).tolist() for x in v) if isinstance(v, tuple) else
                np.asarray(v).tolist() if isinstance(v, np.ndarray) else str(v)) for k, v in header.items()}


@pytest.mark.parametrize("shape", [(5, 3, 4), (6, 7), (9,)])
def test_streamed_exr_is_the_in_memory_file(tmp_path, shape):
    table = make_table(shape, seed=len(shape))
    bio.write(table, tmp_path / "memory.exr")
    blocks = slab_blocks(table, 2, shuffle=True) if len(shape) > 1 else texel_blocks(table, 4)
    meta = bio.write_blocks(tmp_path / "stream.exr", table.axes, CHANNELS, blocks, table.meta)
    assert meta == table.meta
    mem_header, mem_pixels = read_raw(tmp_path / "memory.exr")
    st_header, st_pixels = read_raw(tmp_path / "stream.exr")
    assert comparable(st_header) == comparable(mem_header)
    assert json.loads(st_header["bsdf_tab_channels"]) == CHANNELS
    assert set(st_pixels) == set(CHANNELS)
    height = int(np.prod(shape[:-1]))
    for name in CHANNELS:
        assert st_pixels[name].dtype == np.float32
        np.testing.assert_array_equal(st_pixels[name], mem_pixels[name])
        # the documented layout, from the table's own values
        np.testing.assert_array_equal(st_pixels[name],
                                      table.channels[name].astype(np.float32).reshape(height, shape[-1]))
    assert (tmp_path / "stream.exr").read_bytes() == (tmp_path / "memory.exr").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["memory.exr", "stream.exr"]  # no scratch left


def test_streamed_exr_in_many_small_chunks(tmp_path, monkeypatch):
    monkeypatch.setattr(stream, "CHUNK_BYTES", 100)  # a few scanlines per writePixels call
    table = make_table((7, 5, 6), seed=3)
    bio.write(table, tmp_path / "memory.exr")
    bio.write_blocks(tmp_path / "stream.exr", table.axes, CHANNELS, texel_blocks(table, 11), table.meta)
    assert (tmp_path / "stream.exr").read_bytes() == (tmp_path / "memory.exr").read_bytes()


@pytest.mark.parametrize("chunk", [None, 64])
def test_streamed_npz_holds_the_in_memory_archive(tmp_path, monkeypatch, chunk):
    if chunk:
        monkeypatch.setattr(stream, "CHUNK_BYTES", chunk)
    table = make_table((4, 3, 5), seed=4)
    bio.write_blocks(tmp_path / "s.npz", table.axes, CHANNELS, slab_blocks(table, 3), table.meta)
    memory = np.load(io.BytesIO(bio.to_bytes(table, "npz")), allow_pickle=False)
    streamed = np.load(tmp_path / "s.npz", allow_pickle=False)
    assert streamed.files == memory.files
    for key in memory.files:
        assert streamed[key].dtype == memory[key].dtype, key
        np.testing.assert_array_equal(streamed[key], memory[key])
    for name in CHANNELS:  # and the table's own float64 values
        np.testing.assert_array_equal(streamed[f"channel/{name}"], table.channels[name])
    assert json.loads(str(streamed["meta"])) == table.meta
    back = bio.read(tmp_path / "s.npz", factory=Table)
    assert back.axes["theta_i"][0] == 1 / 3


def test_metadata_may_depend_on_the_values(tmp_path):
    table = make_table((4, 2, 3), seed=5)
    seen = {"blocks": 0, "meta_calls": 0}
    running_max = {"f_r": 0.0}

    def blocks():
        for start, values in slab_blocks(table, 1):
            seen["blocks"] += 1
            running_max["f_r"] = max(running_max["f_r"], float(values[2].max()))
            yield start, values

    def meta():
        seen["meta_calls"] += 1
        assert seen["blocks"] == 4  # called after the last block
        return {"spec": {"table": "bsdf"}, "max_error": dict(running_max)}

    written = bio.write_blocks(tmp_path / "m.exr", table.axes, CHANNELS, blocks(), meta)
    assert seen["meta_calls"] == 1
    header, _ = read_raw(tmp_path / "m.exr")
    assert json.loads(header["bsdf_tab_meta"]) == written
    assert written["max_error"]["f_r"] == float(table.channels["f_r_err"].max())


def leftovers(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.mark.parametrize("suffix", [".exr", ".npz"])
@pytest.mark.parametrize("case, fragment", [
    ("gap", "no block gave texels 12..23"),
    ("overlap", "overlap"),
    ("channels", "first axis must be the 4 channels"),
    ("outside", "outside the table"),
    ("missing channel", "no values for channel"),
])
def test_bad_blocks_write_nothing(tmp_path, suffix, case, fragment):
    table = make_table((4, 3, 4), seed=6)
    blocks = list(slab_blocks(table, 1))
    if case == "gap":
        del blocks[1]
    elif case == "overlap":
        blocks.append(blocks[0])
    elif case == "channels":
        blocks[2] = (blocks[2][0], blocks[2][1][:3])
    elif case == "outside":
        blocks[3] = (40, blocks[3][1])
    else:
        blocks = [(s, {c: v[k] for k, c in enumerate(CHANNELS[:3])}) for s, v in blocks]
    (tmp_path / f"old{suffix}").write_bytes(b"previous")
    with pytest.raises(ValueError, match=fragment):
        bio.write_blocks(tmp_path / f"old{suffix}", table.axes, CHANNELS, blocks, table.meta)
    assert (tmp_path / f"old{suffix}").read_bytes() == b"previous"
    assert leftovers(tmp_path) == [f"old{suffix}"]


def test_a_failing_computation_leaves_nothing(tmp_path):
    table = make_table((4, 3, 4), seed=7)

    def blocks():
        yield from list(slab_blocks(table, 1))[:2]
        raise RuntimeError("the device went away")

    with pytest.raises(RuntimeError, match="device went away"):
        bio.write_blocks(tmp_path / "t.exr", table.axes, CHANNELS, blocks(), table.meta)
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("target, fmt, fragment", [
    ("t.half.exr", None, "half-exr cannot be written block by block"),
    ("t.json", None, "json cannot be written block by block"),
    ("t.exr", "h", "h cannot be written block by block"),
    ("t.tiff", None, "'.tiff'"),
])
def test_only_exr_and_npz_stream(tmp_path, target, fmt, fragment):
    table = make_table((2, 2, 2))
    with pytest.raises(bio.FormatError, match=fragment):
        bio.write_blocks(tmp_path / target, table.axes, CHANNELS, slab_blocks(table, 1), table.meta, fmt=fmt)
    assert leftovers(tmp_path) == []
    assert bio.can_stream("exr") and bio.can_stream("x.npz") and not bio.can_stream("x.half.exr")


def test_missing_folder(tmp_path):
    table = make_table((2, 2, 2))
    with pytest.raises(FileNotFoundError, match="does not exist"):
        bio.write_blocks(tmp_path / "no" / "t.exr", table.axes, CHANNELS, slab_blocks(table, 1), table.meta)


def test_write_stream_takes_slabs_of_channel_dicts(tmp_path):
    """The shape of bsdf_tab.api.iter_blocks' stream: (start slice, end slice, {name: slab}), meta()."""
    table = make_table((5, 2, 3), seed=8)

    class Slabs:
        axes = table.axes
        channel_names = CHANNELS
        done = False

        def __iter__(self):
            for s in range(0, 5, 2):
                yield s, min(5, s + 2), {c: table.channels[c][s : s + 2] for c in CHANNELS}
            self.done = True

        def meta(self):
            assert self.done
            return table.meta

    result = bio.write_stream(Slabs(), tmp_path / "w.exr")
    assert isinstance(result, bio.StreamedTable)
    assert result.kind == "bsdf" and result.shape == (5, 2, 3)
    assert result.max_error() == table.meta["max_error"]
    # the stream measured the float32 rounding, as numpy does it (what `bake` prints for an EXR)
    report = result.meta["storage"]
    assert report["encoding"] == "float32" and report["format"] == "exr"
    for c in ("f_r", "f_t"):
        x = table.channels[c]
        rounding = np.abs(x.astype(np.float32).astype(np.float64) - x)
        assert report["channels"][c]["storage_error"] == rounding.max() > 0
        assert report["channels"][c]["total_error"] == (rounding + table.channels[c + "_err"]).max()
        assert report["channels"][c]["integration_error"] == table.channels[c + "_err"].max()
        assert (report["channels"][c]["min"], report["channels"][c]["max"]) == (x.min(), x.max())
    # byte for byte the file the in-memory path writes (bake adds the same report there)
    memory = Table(table.axes, table.channels, {**table.meta, "storage": report})
    bio.write(memory, tmp_path / "memory.exr")
    assert (tmp_path / "w.exr").read_bytes() == (tmp_path / "memory.exr").read_bytes()
    assert Table.read(tmp_path / "w.exr").meta["storage"] == report
