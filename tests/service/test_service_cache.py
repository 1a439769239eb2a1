"""Service cache: checksummed entries, corruption -> recompute (never served), atomic writes, LRU cap."""

from __future__ import annotations

import os
import threading

import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

import service.compute  # noqa: E402
from bsdf_tab.table import Table  # noqa: E402
from service.app import create_app  # noqa: E402
from service.cache import MAGIC, DiskCache, table_key  # noqa: E402
from service.settings import Settings  # noqa: E402


# ------------------------------------------------------------------ DiskCache


def test_roundtrip_and_file_format(tmp_path):
    c = DiskCache(tmp_path, 10_000)
    assert c.get("a.exr") is None
    c.put("a.exr", b"hello")
    assert c.get("a.exr") == b"hello"
    raw = (tmp_path / "a.exr").read_bytes()
    assert raw.startswith(MAGIC) and raw.endswith(b"\nhello")
    assert c.summary()["entries"] == 1 and c.stats["hits"] == 1 and c.stats["misses"] == 1


@pytest.mark.parametrize(
    "damage",
    [
        lambda b: b[:-1],  # truncated payload
        lambda b: b[:10],  # truncated header
        lambda b: b[:-2] + bytes([b[-2] ^ 1]) + b[-1:],  # one bit flipped
        lambda b: b"",  # empty file
        lambda b: b"PK\x03\x04 something else",  # a foreign file
        lambda b: b + b"x",  # trailing garbage
    ],
)
def test_corrupt_entry_is_a_miss_and_removed(tmp_path, damage):
    c = DiskCache(tmp_path, 10_000)
    c.put("k.npz", b"payload-bytes" * 10)
    path = tmp_path / "k.npz"
    path.write_bytes(damage(path.read_bytes()))
    assert c.get("k.npz") is None
    assert not path.exists()
    assert c.stats["corrupt"] == 1 and "k.npz" not in c


def test_writes_are_atomic_and_stale_temporaries_cleaned(tmp_path):
    (tmp_path / ".x.npz.123.abc.tmp").write_bytes(b"half a write")
    c = DiskCache(tmp_path, 10_000)
    c.put("x.npz", b"1" * 100)
    assert sorted(os.listdir(tmp_path)) == ["x.npz"]  # the stale temporary is gone, no new ones

    # readers racing a writer only ever see complete entries
    stop = threading.Event()
    seen = set()

    def reader():
        while not stop.is_set():
            v = c.get("x.npz")
            if v is not None:
                seen.add(v)

    t = threading.Thread(target=reader)
    t.start()
    for i in range(60):
        c.put("x.npz", bytes([48 + i % 2]) * 5000)
    stop.set()
    t.join()
    assert seen <= {b"1" * 100, b"0" * 5000, b"1" * 5000}


def test_lru_eviction_under_the_cap(tmp_path):
    entry = len(MAGIC) + 64 + 1 + 3 + 1 + 1 + 1 + 100  # header (digest, length, name) + 100-byte payload
    c = DiskCache(tmp_path, 3 * entry)
    for name in ("a", "b", "c"):
        c.put(name, name.encode() * 100)
    assert c.get("a") is not None  # a is now the most recently used
    c.put("d", b"d" * 100)  # evicts b, the least recently used
    assert "b" not in c and not (tmp_path / "b").exists()
    assert {"a", "c", "d"} <= set(os.listdir(tmp_path))
    assert c.total_bytes <= 3 * entry and c.stats["evictions"] == 1
    # a new instance rebuilds the index (order from the files' mtimes) and keeps the cap
    os.utime(tmp_path / "c", (1, 1))
    c2 = DiskCache(tmp_path, 3 * entry)
    assert len(c2) == 3 and c2.total_bytes == 3 * entry
    c2.put("e", b"e" * 100)
    assert "c" not in c2 and "a" in c2


def test_entry_larger_than_the_cap_is_not_stored(tmp_path):
    c = DiskCache(tmp_path, 50)
    c.put("big", b"x" * 100)
    assert c.get("big") is None and len(c) == 0


def test_bad_names_are_refused(tmp_path):
    c = DiskCache(tmp_path, 1000)
    for name in ("../x", "a/b", "", ".hidden"):
        with pytest.raises(ValueError):
            c.put(name, b"x")


def test_serve_refuses_a_cache_dir_that_is_a_file(tmp_path, capsys):
    from bsdf_tab import cli

    blocker = tmp_path / "not-a-folder"
    blocker.write_text("x")
    code = cli.main(["serve", "--cache-dir", str(blocker), "--no-warmup", "--port", "1"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--cache-dir" in err[0] and "not a folder" in err[0], err
    with pytest.raises(ValueError, match="not a folder"):
        DiskCache(blocker, 1000).check_folder()
    DiskCache(tmp_path / "new" / "deep", 1000).check_folder()  # created on demand
    assert (tmp_path / "new" / "deep").is_dir()


def test_healthz_does_not_scan_or_fail_on_the_cache_folder(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with TestClient(create_app(Settings(cache_dir=blocker, warmup=False, workers=1))) as client:
        r = client.get("/healthz")
    assert r.status_code == 200 and r.json()["cache"]["entries"] is None
    c = DiskCache(tmp_path / "c", 1000)
    assert c.summary()["entries"] is None  # no scan before first use
    c.put("a.exr", b"x")
    assert c.summary()["entries"] == 1


def test_key_includes_version():
    assert table_key("ab" * 32, "0.1.0") != table_key("ab" * 32, "0.2.0")
    assert table_key("ab" * 32, "1.0+local/x").startswith("v1.0+local_x-")


# ------------------------------------------------------------------ through the app


@pytest.fixture()
def counted(monkeypatch):
    calls = []
    real = service.compute.tabulate

    def counting(spec, **kw):
        calls.append(spec)
        return real(spec, **kw)

    monkeypatch.setattr(service.compute, "tabulate", counting)
    return calls


def test_corrupt_cache_file_is_recomputed_never_served(tmp_path, counted):
    # no memory LRU: every request reads the disk entry
    settings = Settings(cache_dir=tmp_path, warmup=False, workers=1, memory_cache_bytes=0)
    url = "/tables/albedo?mu=0.3,0.9&alpha=0.2,0.6"
    with TestClient(create_app(settings)) as client:
        first = client.get(url)
        assert first.status_code == 200 and len(counted) == 1
        key = first.headers["x-bsdf-tab-key"]
        exr_file, master_file = tmp_path / f"{key}.exr", tmp_path / f"{key}.npz"
        assert exr_file.exists() and master_file.exists()

        # a damaged derived entry is re-derived from the master: no computation
        data = bytearray(exr_file.read_bytes())
        data[-20] ^= 0xFF
        exr_file.write_bytes(bytes(data))
        again = client.get(url)
        assert again.status_code == 200 and again.content == first.content
        assert len(counted) == 1

        # both entries truncated: recomputed, identical bytes, cache repaired
        for f in (exr_file, master_file):
            f.write_bytes(f.read_bytes()[: len(f.read_bytes()) // 2])
        third = client.get(url)
        assert third.status_code == 200 and third.content == first.content
        assert len(counted) == 2
        Table.from_bytes(third.content, "exr")  # a valid EXR
        assert client.get("/healthz").json()["cache"]["corrupt"] == 3  # exr, then exr + master
    # a fresh process on the same folder serves the repaired entry without computing
    with TestClient(create_app(settings)) as client:
        assert client.get(url).content == first.content
        assert len(counted) == 2


def test_size_cap_evicts_through_the_app(tmp_path, counted):
    settings = Settings(cache_dir=tmp_path, cache_max_bytes=12_000, warmup=False, workers=1)
    with TestClient(create_app(settings)) as client:
        for a in (0.1, 0.2, 0.3, 0.4, 0.5):
            assert client.get(f"/tables/albedo?mu=0.5,1&alpha={a}").status_code == 200
        total = sum(f.stat().st_size for f in tmp_path.iterdir() if f.is_file())  # locks/ holds empty lock files
        assert total <= 12_000
        assert client.get("/healthz").json()["cache"]["evictions"] > 0
        # an evicted table is simply computed again
        assert client.get("/tables/albedo?mu=0.5,1&alpha=0.1").status_code == 200


def test_entries_are_bound_to_their_key_and_validated(tmp_path, counted):
    """Table B's file copied onto A's name, or a valid header over a payload that is not a table:
    deleted, counted, recomputed; never served and never a 500 (issue 12)."""
    from service.cache import _encode

    settings = Settings(cache_dir=tmp_path, warmup=False, workers=1, memory_cache_bytes=0)
    url_a, url_b = "/tables/albedo?mu=0.3,0.9&alpha=0.2", "/tables/albedo?mu=0.3,0.9&alpha=0.7"
    with TestClient(create_app(settings)) as client:
        a, b = client.get(url_a), client.get(url_b)
        key_a, key_b = a.headers["x-bsdf-tab-key"], b.headers["x-bsdf-tab-key"]
        assert len(counted) == 2
        for variant in ("exr", "npz"):  # B's intact file under A's name
            (tmp_path / f"{key_a}.{variant}").write_bytes((tmp_path / f"{key_b}.{variant}").read_bytes())
        again = client.get(url_a)
        assert again.status_code == 200 and again.content == a.content and len(counted) == 3
        assert client.get("/healthz").json()["cache"]["corrupt"] == 2
        # a correct header (checksum and name) over a payload that is not what the variant says
        for variant, junk in (("npz", b"PK\x03\x04 not a table"), ("exr", b"not an exr"), ("json", b"[1, 2"),
                              ("info", b"{}x")):
            (tmp_path / f"{key_a}.{variant}").write_bytes(_encode(junk, f"{key_a}.{variant}"))
        for fmt in ("npz", "exr", "json"):
            r = client.get(url_a + f"&format={fmt}")
            assert r.status_code == 200, r.text
        assert client.get(url_a + "&format=exr").content == a.content
        assert client.get(f"/tables/albedo/info?mu=0.3,0.9&alpha=0.2").status_code == 200
        # an npz of another table with a correct header under A's name: the spec hash decides
        (tmp_path / f"{key_a}.npz").write_bytes(_encode(client.get(url_b + "&format=npz").content, f"{key_a}.npz"))
        (tmp_path / f"{key_a}.exr").unlink()
        assert client.get(url_a).content == a.content
        health = client.get("/healthz").json()["cache"]
        assert health["invalid"] >= 4


# ------------------------------------------------------------------ KeyLock


def test_key_lock_excludes_and_leaves_no_file_behind(tmp_path):
    c = DiskCache(tmp_path, 10_000)
    a, b = c.key_lock("k.exr"), c.key_lock("k.exr")
    assert a.try_acquire()
    assert not b.try_acquire()  # held by another open file description
    a.release()
    assert not (tmp_path / "locks" / "k.exr.lock").exists()  # pruned on release
    assert b.try_acquire()
    b.release()
    assert list((tmp_path / "locks").iterdir()) == []


def test_key_lock_left_by_a_crashed_holder_is_taken_and_removed(tmp_path):
    c = DiskCache(tmp_path, 10_000)
    stale = tmp_path / "locks" / "k.exr.lock"
    stale.parent.mkdir(parents=True)
    stale.write_bytes(b"")  # a holder killed before release: its flock died with it
    lock = c.key_lock("k.exr")
    assert lock.try_acquire()
    lock.release()
    assert not stale.exists()


def test_key_lock_stays_exclusive_when_holders_unlink_on_release(tmp_path):
    """Many threads take and release one key; never two holders at once.

    Each KeyLock opens its own file description, so flock excludes threads of one process as it
    does processes. Without the inode check in try_acquire, a thread that opened the file just
    before its holder unlinked it would lock the dead inode while another thread locks the new
    file: two holders (this test then sees ``inside`` > 1).
    """
    c = DiskCache(tmp_path, 10_000)
    inside, worst, acquired = [0], [0], [0]
    guard = threading.Lock()

    def worker():
        for _ in range(400):  # bounded
            lock = c.key_lock("k.exr")
            if not lock.try_acquire():
                continue
            with guard:
                inside[0] += 1
                worst[0] = max(worst[0], inside[0])
                acquired[0] += 1
            os.sched_yield()
            with guard:
                inside[0] -= 1
            lock.release()

    threads = [threading.Thread(target=worker) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    assert worst[0] == 1
    assert acquired[0] > 0
    assert not (tmp_path / "locks" / "k.exr.lock").exists()
