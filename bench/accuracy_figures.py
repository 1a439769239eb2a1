"""Figures of the accuracy benchmark (:mod:`bench.accuracy_sweep`): error against time and
samples (with the Pareto front and the peers), and per-method error heatmaps over (mu, alpha).
matplotlib is imported inside the functions (Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bench.common import pareto

COLORS = {
    "adaptive": "black", "grid": "tab:brown", "mc_cosine": "tab:red", "mc_dcos": "tab:orange",
    "mc_vndf": "tab:blue", "qmc_vndf": "tab:green", "vndf_gl": "tab:purple",
}


def chart(result: dict, path: Path, peers: list[dict] | None = None, mitsuba: dict | None = None) -> None:
    """Three panels: max error and mean error against time per 1000 texels (log-log, one curve
    per method, Pareto front dashed), and mean error against samples per texel with the peer
    tables as points. When the Mitsuba peer ran (``mitsuba["ran"]``), its points are a magenta
    diamond curve on all three panels, and our methods on the same (separable) cases are thin
    dotted curves in their colours; the Pareto front is the main sweep's only."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = result["summary"]
    floor = 1e-12
    fig, axes = plt.subplots(1, 3, figsize=(22, 6.2))
    for ax, key, title in ((axes[0], "max_abs_err", "worst texel"), (axes[1], "mean_abs_err", "mean over texels")):
        for method in dict.fromkeys(s["method"] for s in summary):
            pts = [s for s in summary if s["method"] == method]
            x = [s["time_per_1k_texels_s"] for s in pts]
            y = [max(s[key], floor) for s in pts]
            ax.plot(x, y, "o-", color=COLORS.get(method), label=method, ms=5)
            for s, xx, yy in zip(pts, x, y):
                if s["honesty"] < 0.999:
                    ax.plot(xx, yy, "x", color="red", ms=11, mew=2)
        front = pareto([(s["time_per_1k_texels_s"], s[key]) for s in summary])
        fx = [summary[k]["time_per_1k_texels_s"] for k in front]
        fy = [max(summary[k][key], floor) for k in front]
        ax.step(fx, fy, where="post", ls="--", color="gray", lw=1.2, label="Pareto front")
        ax.plot(fx, fy, "o", mfc="none", mec="gray", ms=12)
        if mitsuba and mitsuba.get("ran"):
            _mitsuba_curves(ax, mitsuba, "time_per_1k_texels_s", key, floor)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time per 1000 texels [s]")
        ax.set_ylabel(f"absolute error vs reference ({title})")
        ax.set_title(f"error vs time: {title}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].plot([], [], "x", color="red", ms=9, mew=2, label="honesty < 99.9%")
    axes[0].legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=3)
    ax = axes[2]
    for method in dict.fromkeys(s["method"] for s in summary):
        pts = [s for s in summary if s["method"] == method]
        ax.plot([s["evals_per_texel"] for s in pts], [max(s["mean_abs_err"], floor) for s in pts], "o-",
                color=COLORS.get(method), label=method, ms=5)
    if mitsuba and mitsuba.get("ran"):
        _mitsuba_curves(ax, mitsuba, "samples_per_texel", "mean_abs_err", floor)
    xmax = max(s["evals_per_texel"] for s in summary)
    for k, p in enumerate(peers or []):
        x = p["samples_per_texel"] or xmax * 4
        ax.plot(x, max(p["mean_abs_err"], floor), marker="*", ms=16,
                color=f"C{k + 6}", ls="none",
                label=f"{p['name']} (mean {p['mean_abs_err']:.1e}, max {p['max_abs_err']:.1e})"
                + ("" if p["samples_per_texel"] else " [samples unknown]"))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("integrand evaluations (samples) per texel")
    ax.set_ylabel("mean absolute error vs reference")
    ax.set_title("error vs samples, peer tables as stars")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    sub = "quick" if result.get("quick") else "full"
    fig.suptitle(f"bsdf-tab accuracy vs speed ({sub} sweep: {len(result['cases'])} cases x "
                 f"{len(result['axes']['mu']) * len(result['axes']['alpha'])} texels)", fontsize=12)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def _mitsuba_curves(ax, mitsuba: dict, xkey: str, ykey: str, floor: float) -> None:
    """Mitsuba's points (magenta diamonds) and our methods on the same cases (dotted)."""
    ncases = len(mitsuba.get("cases", []))
    pts = mitsuba["summary"]
    x = [s[xkey] for s in pts]
    y = [max(s[ykey], floor) for s in pts]
    ax.plot(x, y, "D-", color="magenta", ms=6, lw=1.6,
            label=f"Mitsuba 3 {mitsuba.get('variant')} ({ncases} separable cases)")
    for s, xx, yy in zip(pts, x, y):
        if s["honesty"] < 0.999:
            ax.plot(xx, yy, "x", color="red", ms=11, mew=2)
    same = mitsuba.get("same_cases", {}).get("summary", [])
    for method in dict.fromkeys(s["method"] for s in same):
        sel = [s for s in same if s["method"] == method]
        sx = [s["evals_per_texel"] if xkey == "samples_per_texel" else s[xkey] for s in sel]
        ax.plot(sx, [max(s[ykey], floor) for s in sel], ".:", color=COLORS.get(method), lw=1.0, ms=4,
                label=f"{method}, Mitsuba's cases")


def heatmaps(result: dict, path: Path) -> None:
    """Rows: methods (at their highest effort); columns: cases. Colour: log10 of the worst
    channel's absolute error over (mu, alpha); texels whose error channel lied are boxed red."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    maps, hmaps = result["_maps"], result["_honest_maps"]
    methods = list(maps)
    cases = [c["name"] for c in result["cases"]]
    mu, alpha = result["axes"]["mu"], result["axes"]["alpha"]
    fig, axes = plt.subplots(len(methods), len(cases), figsize=(2.6 * len(cases) + 1.5, 2.3 * len(methods) + 0.8),
                             squeeze=False)
    im = None
    for r, method in enumerate(methods):
        for c, case in enumerate(cases):
            ax = axes[r][c]
            err = np.log10(np.maximum(np.array(maps[method][case]), 1e-12))
            im = ax.imshow(err.T, origin="lower", cmap="viridis", vmin=-12, vmax=0, aspect="auto")
            bad = ~np.array(hmaps[method][case])
            for j, i in zip(*np.nonzero(bad)):
                ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="red", lw=1.5))
            ax.set_xticks(range(len(mu)))
            ax.set_xticklabels([f"{m:g}" for m in mu], rotation=90, fontsize=6)
            ax.set_yticks(range(len(alpha)))
            ax.set_yticklabels([f"{a:g}" for a in alpha], fontsize=6)
            if r == 0:
                ax.set_title(case, fontsize=8)
            if c == 0:
                eff = result["efforts"][method][-1]
                ax.set_ylabel(f"{method}@{eff:g}\nalpha", fontsize=8)
            if r == len(methods) - 1:
                ax.set_xlabel("mu", fontsize=7)
    fig.colorbar(im, ax=axes, shrink=0.6, label="log10 |error| (worst channel); red box: error channel too small")
    fig.suptitle("Where each method fails: error over (mu, alpha) at its highest effort", fontsize=12)
    fig.savefig(path, dpi=90)
    plt.close(fig)
