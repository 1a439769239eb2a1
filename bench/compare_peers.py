"""Compare bsdf-tab's engine presets with the tables the engines ship.

Run: ``python bench/compare_peers.py [--device cpu] [--only NAME ...] [--reuse]`` (or
``bsdf-tab bench compare_peers ...``).

For every preset that has a peer table in the anchors folder (``../shared/anchors`` relative
to the repository root, or ``$BSDF_TAB_ANCHORS``), bakes the preset at full size, loads the
peer's array, checks that the axes agree with the peer's axis files, and reports:

- max and mean |ours - theirs| over all texels, and where the max is (axis values);
- the mean and max signed difference theirs - ours (a bias shows here, e.g. Cycles'
  ``ggx_glass_inv_E``);
- the same max / mean over the *interior*: texels off the nodes where the peer uses a
  convention of its own (Cycles glass: the ior ~ 1 slice; OpenPBR: roughness 0, cos 0 and
  its two ior = 1 slices);
- for tables with a mu axis, the interior max |difference| at each mu node (a grazing-angle bias shows);
- our largest error estimate, for scale.

Prints a table and writes ``bench/out/compare_peers.json``. Our baked tables are cached in
``bench/out/presets/*.npz`` (``--reuse`` reads them instead of recomputing). Skips cleanly
(exit 0) when the anchors folder is absent. Peer data is only read, never copied into the repo.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "bench" / "out"
if str(ROOT) not in sys.path:  # the checkout's bsdf_tab, as for bench/accuracy.py
    sys.path.insert(0, str(ROOT))

from bsdf_tab.presets import PRESETS, build_preset  # noqa: E402
from bsdf_tab.table import Table  # noqa: E402


def anchors_dir() -> Path:
    return Path(os.environ.get("BSDF_TAB_ANCHORS") or (ROOT.parent / "shared" / "anchors"))


def interior_mask(name: str, shape: tuple[int, ...], axes: list[str]) -> np.ndarray:
    """Texels off the nodes where the peer follows a convention of its own."""
    mask = np.ones(shape, dtype=bool)

    def drop(axis: str, index: int) -> None:
        if axis in axes:
            sl = [slice(None)] * len(shape)
            sl[axes.index(axis)] = index
            mask[tuple(sl)] = False

    if name.startswith("cycles-ggx-glass"):
        drop("ior", 0)  # ior = 1.00000002: Cycles ~1 (interface invisible), ours the microfacet limit
    if name.startswith("openpbr-"):
        drop("roughness", 0)  # OpenPBR: 0 there (no loss)
        drop("cos", 0)  # OpenPBR: not the mu -> 0 limit
        if "ior" in axes:  # OpenPBR's two ior = 1 slices differ from each other: not exactly eta = 1
            drop("ior", 15)
            drop("ior", 16)
    return mask


def where(table: Table, index: tuple[int, ...]) -> dict:
    return {n: float(a[i]) for (n, a), i in zip(table.axes.items(), index)}


def compare(name: str, table: Table, theirs: np.ndarray, anchors: Path) -> dict:
    preset = PRESETS[name]
    channel = table.value_channels[0]
    ours = np.asarray(table.channels[channel], dtype=np.float64)
    err = np.asarray(table.channels[channel + "_err"], dtype=np.float64)
    if ours.shape != theirs.shape:
        return {"preset": name, "error": f"shape {ours.shape} != peer {theirs.shape}"}
    axis_check = {}
    for axis, rel in preset.anchor_axes.items():
        path = anchors / rel
        if path.exists():
            axis_check[axis] = float(np.max(np.abs(np.load(path) - table.axes[axis])))
    diff = ours - theirs
    absd = np.abs(diff)
    imax = np.unravel_index(int(np.argmax(absd)), absd.shape)
    signed = theirs - ours
    ibias = np.unravel_index(int(np.argmax(signed)), signed.shape)
    mask = interior_mask(name, ours.shape, list(table.axes))
    inner = absd[mask]
    imax_in = np.unravel_index(int(np.argmax(np.where(mask, absd, -1.0))), absd.shape)
    return {
        "preset": name,
        "peer": preset.peer,
        "anchor": preset.anchor,
        "channel": channel,
        "shape": list(ours.shape),
        "axis_order": list(table.axes),
        "axis_max_abs_diff": axis_check,
        "max_abs_diff": float(absd.max()),
        "mean_abs_diff": float(absd.mean()),
        "max_at": {**where(table, imax), "ours": float(ours[imax]), "theirs": float(theirs[imax])},
        "mean_signed_theirs_minus_ours": float(signed.mean()),
        "max_signed_theirs_minus_ours": float(signed.max()),
        "max_signed_at": {**where(table, ibias), "ours": float(ours[ibias]), "theirs": float(theirs[ibias])},
        "interior_texels": int(mask.sum()),
        "interior_max_abs_diff": float(inner.max()) if inner.size else None,
        "interior_mean_abs_diff": float(inner.mean()) if inner.size else None,
        "interior_max_at": {**where(table, imax_in), "ours": float(ours[imax_in]), "theirs": float(theirs[imax_in])},
        "fraction_above_1e-3": float((absd > 1e-3).mean()),
        "max_abs_diff_by_mu": (
            [float(x) for x in np.moveaxis(np.where(mask, absd, 0.0), list(table.axes).index("mu"), 0)
             .reshape(absd.shape[list(table.axes).index("mu")], -1).max(axis=1)]
            if "mu" in table.axes else None
        ),
        "max_abs_diff_mu_above_first": (
            float(np.moveaxis(np.where(mask, absd, 0.0), list(table.axes).index("mu"), 0)[1:].max())
            if "mu" in table.axes else None
        ),
        "our_max_error_estimate": float(err.max()),
    }


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Parse ``argv`` (default: ``sys.argv[1:]``; ``prog``: the name in the usage line), bake,
    compare and report. ``bsdf-tab bench compare_peers`` calls it."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--only", nargs="*", default=None, help="preset names (default: all with a peer table)")
    parser.add_argument("--reuse", action="store_true", help="reuse bench/out/presets/*.npz")
    args = parser.parse_args(argv)

    anchors = anchors_dir()
    if not anchors.is_dir():
        print(f"compare_peers: no anchors folder at {anchors} (set BSDF_TAB_ANCHORS); skipping")
        return 0
    names = [n for n, p in PRESETS.items() if p.anchor and (args.only is None or n in args.only)]
    cache_dir = OUT / "presets"
    cache_dir.mkdir(parents=True, exist_ok=True)
    results, skipped = [], []
    for name in names:
        preset = PRESETS[name]
        anchor = anchors / preset.anchor
        if not anchor.exists():
            skipped.append({"preset": name, "reason": f"{preset.anchor} not in the anchors"})
            continue
        cached = cache_dir / f"{name}.npz"
        t0 = time.perf_counter()
        if args.reuse and cached.exists():
            table = Table.from_npz_bytes(cached.read_bytes())
        else:
            table = build_preset(name, device=args.device, workers=args.workers)
            cached.write_bytes(table.to_npz_bytes())
        seconds = time.perf_counter() - t0
        row = compare(name, table, np.load(anchor).astype(np.float64), anchors)
        row["seconds"] = seconds
        results.append(row)
        print(
            f"{name:<30} max {row['max_abs_diff']:.2e}  mean {row['mean_abs_diff']:.2e}  "
            f"interior max {row['interior_max_abs_diff']:.2e} mean {row['interior_mean_abs_diff']:.2e}  "
            f"bias(theirs-ours) mean {row['mean_signed_theirs_minus_ours']:+.2e} max {row['max_signed_theirs_minus_ours']:+.3f}  "
            f"({seconds:.0f} s)",
            flush=True,
        )
    for name, preset in PRESETS.items():
        if not preset.anchor and (args.only is None or name in args.only):
            skipped.append({"preset": name, "reason": "no peer table in the anchors (conventions only)"})

    print()
    header = "| preset | shape | max abs diff (at) | mean abs diff | interior max / mean | max theirs - ours | our max err |"
    print(header)
    print("|" + "---|" * 7)
    for r in results:
        at = ", ".join(f"{k} {v:.4g}" for k, v in r["max_at"].items())
        print(
            f"| {r['preset']} | {'x'.join(map(str, r['shape']))} | {r['max_abs_diff']:.2e} ({at}) | "
            f"{r['mean_abs_diff']:.2e} | {r['interior_max_abs_diff']:.2e} / {r['interior_mean_abs_diff']:.2e} | "
            f"{r['max_signed_theirs_minus_ours']:+.3f} | {r['our_max_error_estimate']:.1e} |"
        )
    for s in skipped:
        print(f"skipped {s['preset']}: {s['reason']}")
    OUT.mkdir(parents=True, exist_ok=True)
    report = {
        "anchors": str(anchors),
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "results": results,
        "skipped": skipped,
    }
    (OUT / "compare_peers.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    print(f"wrote {OUT / 'compare_peers.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
