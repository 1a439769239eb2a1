"""The one atomic write: a temporary in the same folder, fsync, os.replace; nothing partial."""

from __future__ import annotations

import os

import numpy as np
import pytest

import bsdf_tab.io as bio
from bsdf_tab.io import atomic
from bsdf_tab.table import Table


def names(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_write_bytes_creates_and_replaces_leaving_no_temporary(tmp_path):
    path = tmp_path / "a.bin"
    assert atomic.write_bytes(path, b"one") == path
    assert path.read_bytes() == b"one"
    atomic.write_bytes(path, b"two, longer")
    assert path.read_bytes() == b"two, longer"
    assert names(tmp_path) == ["a.bin"]


def test_text_is_written_as_given(tmp_path):
    atomic.write_text(tmp_path / "t.h", "a\r\nb\n\u00e9")
    assert (tmp_path / "t.h").read_bytes() == "a\r\nb\n\u00e9".encode("utf-8")


def test_writer_raising_midway_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "keep.npz"
    path.write_bytes(b"old content")
    with pytest.raises(RuntimeError, match="disk on fire"):
        with atomic.atomic_open(path) as fh:
            fh.write(b"half of the new")
            fh.flush()
            raise RuntimeError("disk on fire")
    assert path.read_bytes() == b"old content"
    assert names(tmp_path) == ["keep.npz"]


def test_writer_raising_midway_leaves_no_file_at_all(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with atomic.atomic_open(tmp_path / "new.json", "w") as fh:
            fh.write("{")
            raise KeyboardInterrupt
    assert names(tmp_path) == []


def test_the_temporary_is_hidden_unique_and_in_the_destination_folder(tmp_path):
    seen = []
    for _ in range(2):
        with atomic.atomic_path(tmp_path / "x.exr") as tmp:
            seen.append(tmp)
            tmp.write_bytes(b"x")
    for tmp in seen:
        assert tmp.parent == tmp_path
        assert tmp.name.startswith(".x.exr.") and tmp.name.endswith(atomic.TMP_SUFFIX)
    assert seen[0] != seen[1]
    assert names(tmp_path) == ["x.exr"]


def test_a_writer_that_creates_nothing_is_an_error(tmp_path):
    with pytest.raises(OSError, match="created no file"):
        with atomic.atomic_path(tmp_path / "x.exr"):
            pass
    assert names(tmp_path) == []


def test_the_data_and_the_rename_are_synced(tmp_path, monkeypatch):
    synced = []
    real = os.fsync

    def spy(fd):
        synced.append(os.path.realpath(f"/proc/self/fd/{fd}") if os.path.exists("/proc/self/fd") else fd)
        return real(fd)

    monkeypatch.setattr(os, "fsync", spy)
    atomic.write_bytes(tmp_path / "s.bin", b"data")
    assert len(synced) == 2
    if isinstance(synced[0], str):
        assert os.path.basename(synced[0]).startswith(".s.bin.")  # the file, before the rename
        assert synced[1] == os.path.realpath(tmp_path)  # then its folder


def test_missing_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        atomic.write_bytes(tmp_path / "no" / "x", b"")


def test_permissions_follow_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        atomic.write_bytes(tmp_path / "p.bin", b"")
    finally:
        os.umask(old)
    assert (tmp_path / "p.bin").stat().st_mode & 0o777 == 0o644


def test_exr_writer_failing_inside_openexr_leaves_nothing_partial(tmp_path, monkeypatch):
    """OpenEXR writes part of the file, then fails: the destination keeps its old bytes."""
    from bsdf_tab.io import exr

    class Failing:
        def __init__(self, header, pixels):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def write(self, name):
            with open(name, "wb") as fh:
                fh.write(b"\x76\x2f\x31\x01 partial")
            raise RuntimeError("simulated write failure")

    path = tmp_path / "t.exr"
    path.write_bytes(b"previous table")
    monkeypatch.setattr(exr.OpenEXR, "File", Failing)
    table = Table({"alpha": np.array([0.1, 0.2])}, {"E_avg": np.array([0.5, 0.6])}, {})
    with pytest.raises(OSError, match="simulated write failure"):
        bio.write(table, path)
    assert path.read_bytes() == b"previous table"
    assert names(tmp_path) == ["t.exr"]


def test_every_single_file_format_leaves_only_its_file(tmp_path):
    table = Table({"alpha": np.array([0.1, 0.2])}, {"E_avg": np.array([0.5, 0.6])}, {"spec": {}})
    for name in bio.names(single_file=True):
        folder = tmp_path / name
        folder.mkdir()
        bio.write(table, bio.output_path(folder, "t", name))
        assert names(folder) == ["t" + bio.get_format(name).suffix], name
