"""The adaptive method's inner phi integrals one by one: does the first stage under-report?

    python bench/inner_honesty.py                      # seed 3, 6000 samples per family, safety 1 and 4
    python bench/inner_honesty.py --safety 1,2,4,10 --samples 2000 --out bench/out/inner_honesty.json

Issue 14's fourth round accepts an inner G7 with the error ``first_safety`` x |G7 - I5| (the
two-stage rule, :func:`bsdf_tab.integrate.quadrature.first_stage`). A texel's honesty is measured
by ``bench/accuracy_honesty.py``; this script looks one level down, at single inner integrals
(one theta_m, the integral over phi of the integrand, split at the closed-form cuts), where the
outer level cannot catch a miss. For random samples of four integrand families (reflection GGX
correlated F = 1; reflection Beckmann separable with a dielectric Fresnel of eta 0.6; dielectric
GGX correlated eta < 1; dielectric Beckmann separable eta > 1; mu and alpha log-uniform, a third
of mu grazing, theta_m near the outer breakpoints, near the lobe or uniform; the inner tolerance
log-uniform in [1e-7, 3e-2] pi) it runs the inner integral with the first stage at each
``--safety``, with K15 only at the same tolerance, and with K15 at 1e-14 (the reference), and
counts the samples whose reported error is below the true one with the first stage but not with
K15 only. The first stage's run includes the second stage (``--second-safety``: its factor on
|G7 - I9|, issue 14 round 11; 0 for the first stage alone). Counts are deterministic for a seed; times are not reported.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import warp as wp

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bsdf_tab.integrate.inner import inner_integral  # noqa: E402
from bsdf_tab.integrate.adaptive import SECOND_SAFETY  # noqa: E402
from bsdf_tab.integrate.integrand import MODE_DIELECTRIC, MODE_REFLECT, make_texel  # noqa: E402

wp.config.quiet = True
wp.set_module_options({"enable_backward": False})

#: (name, mode, distribution, shadowing, Fresnel type, its parameter, eta sampler)
FAMILIES = [
    ("reflect GGX correlated, F = 1", MODE_REFLECT, 0, 1, 0, 0.0, "one"),
    ("reflect Beckmann separable, dielectric Fresnel eta 0.6", MODE_REFLECT, 1, 0, 2, 0.6, "one"),
    ("dielectric GGX correlated, eta < 1", MODE_DIELECTRIC, 0, 1, 0, 0.0, "below"),
    ("dielectric Beckmann separable, eta > 1", MODE_DIELECTRIC, 1, 0, 0, 0.0, "above"),
]


@wp.kernel
def inner_kernel(mu: wp.array(dtype=wp.float64), alpha: wp.array(dtype=wp.float64), eta: wp.array(dtype=wp.float64),
                 theta_m: wp.array(dtype=wp.float64), tol: wp.array(dtype=wp.float64), mode: int, dist: int,
                 shadowing: int, ftype: int, fparam: wp.float64, inner_first: int, safety: wp.float64,
                 second: wp.float64, max_rules: int, inner_map: int, out: wp.array2d(dtype=wp.float64)):
    k = wp.tid()
    p = make_texel(mode, dist, shadowing, ftype, fparam, wp.float64(0.0), mu[k], alpha[k], eta[k])
    # the method's inner settings (adaptive.integrate_texels defaults), the first stage switchable
    p.err_model = 1
    p.err_model_inner = 2
    p.err_safety = wp.float64(1.0)
    p.err_power = wp.float64(3.0)
    p.inner_first = inner_first
    p.first_safety = safety
    p.second_safety = second
    p.first_share = wp.float64(1.0)
    p.bound_share = wp.float64(0.0)
    p.inner_map = inner_map
    cm = wp.cos(theta_m[k])
    sm = wp.sin(theta_m[k])
    r, e, used, used_ref = inner_integral(p, cm, sm, sm / cm, tol[k], max_rules)
    out[k, 0] = r[0]
    out[k, 1] = r[1]
    out[k, 2] = e[0]
    out[k, 3] = e[1]
    out[k, 4] = wp.float64(used)


def samples(rng: np.random.Generator, n: int, eta_kind: str, reflect: bool) -> dict:
    mu = np.exp(rng.uniform(np.log(1e-4), 0.0, n))
    mu[: n // 3] = np.exp(rng.uniform(np.log(1e-4), np.log(0.15), n // 3))
    alpha = np.exp(rng.uniform(np.log(1e-3), 0.0, n))
    eta = {"below": lambda: 1.0 / rng.uniform(1.05, 2.5, n), "above": lambda: rng.uniform(1.05, 2.5, n),
           "one": lambda: np.ones(n)}[eta_kind]()
    theta_i = np.arccos(mu)
    where = rng.integers(0, 4, n)
    theta = np.where(where == 0, 0.5 * (np.pi / 2 - theta_i) * np.exp(rng.normal(0, 0.05, n)),
                     np.where(where == 1, (np.pi / 2 - theta_i) * np.exp(rng.normal(0, 0.05, n)),
                              np.where(where == 2, np.arctan(alpha * np.exp(rng.normal(0, 1, n))),
                                       rng.uniform(0, np.pi / 2, n))))
    theta = np.clip(theta, 1e-6, np.pi / 2 - 1e-6)
    if reflect:  # above (pi/2 + theta_i) / 2 every reflected direction is below the horizon
        theta = np.minimum(theta, 0.5 * (np.pi / 2 + theta_i) - 1e-9)
    tol = np.exp(rng.uniform(np.log(1e-7), np.log(3e-2), n)) * np.pi
    return {"mu": mu, "alpha": alpha, "eta": eta, "theta_m": theta, "tol": tol}


def run(family: tuple, s: dict, tol: np.ndarray, inner_first: int, safety: float, max_rules: int,
        inner_map: int = 1, second: float = 0.0) -> np.ndarray:
    _, mode, dist, shadowing, ftype, fparam, _ = family
    arr = {k: wp.array(v, dtype=wp.float64, device="cpu") for k, v in s.items() if k != "tol"}
    out = wp.zeros((tol.size, 5), dtype=wp.float64, device="cpu")
    wp.launch(inner_kernel, dim=tol.size, device="cpu",
              inputs=[arr["mu"], arr["alpha"], arr["eta"], arr["theta_m"], wp.array(tol, dtype=wp.float64, device="cpu"),
                      mode, dist, shadowing, ftype, fparam, inner_first, safety, second, max_rules, inner_map, out])
    return out.numpy()


def _safeties(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"comma-separated numbers expected, got {text!r}") from None
    if not all(np.isfinite(v) and v > 0 for v in values):
        raise argparse.ArgumentTypeError(f"every first_safety must be a positive number, got {text!r}")
    return values


def _samples(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"an integer expected, got {text!r}") from None
    if n < 3:
        raise argparse.ArgumentTypeError(f"at least 3 samples per family, got {n}")
    return n


def main(argv=None, prog=None) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--samples", type=_samples, default=6000, help="inner integrals per family")
    ap.add_argument("--safety", type=_safeties, default="1,4", help="first_safety values, comma-separated (the method's is 8)")
    ap.add_argument("--inner-map", type=int, choices=(0, 1, 2), default=1,
                    help="the pieces' end map (adaptive.integrate_texels' inner_map; 1, the default below 1e-3)")
    ap.add_argument("--second-safety", type=float, default=SECOND_SAFETY,
                    help=f"the second stage's factor on |G7 - I9| (0: off; {SECOND_SAFETY:g} is the default)")
    ap.add_argument("--out", default=str(ROOT / "bench" / "out" / "inner_honesty.json"))
    args = ap.parse_args(argv)
    safeties = args.safety
    rng = np.random.default_rng(args.seed)
    rows = []
    print("| family | first_safety | under-reported only with the first stage (ch 0 / ch 1) | worst true / reported | inner rule applications / K15 only |")
    print("|---|---|---|---|---|")
    for fam in FAMILIES:
        s = samples(rng, args.samples, fam[6], fam[1] == MODE_REFLECT)
        ref = run(fam, s, np.full(args.samples, 1e-14), 0, 1.0, 2000, 0)
        k15 = run(fam, s, s["tol"], 0, 1.0, 50, args.inner_map)
        for safety in safeties:
            two = run(fam, s, s["tol"], 5, safety, 50, args.inner_map, args.second_safety)
            counts, worst, under_all = [], 0.0, []
            for ch in (0, 1):
                # true error beyond the reference's own estimate, over the reported one
                err_two = np.abs(two[:, ch] - ref[:, ch]) - ref[:, 2 + ch]
                err_k15 = np.abs(k15[:, ch] - ref[:, ch]) - ref[:, 2 + ch]
                r_two = err_two / np.maximum(two[:, 2 + ch], 1e-300)  # reported errors are floored > 0
                r_k15 = err_k15 / np.maximum(k15[:, 2 + ch], 1e-300)
                new = (r_two > 1) & (r_k15 <= 1)
                counts.append(int(new.sum()))
                under_all.append(int((r_two > 1).sum()))
                worst = max(worst, float(np.max(np.where(new, r_two, 0.0))))
            ratio = float(two[:, 4].sum() / max(k15[:, 4].sum(), 1.0))
            rows.append({"family": fam[0], "first_safety": safety, "second_safety": args.second_safety,
                         "inner_map": args.inner_map, "under_reported": counts,
                         "under_reported_all": under_all, "worst_ratio": worst,
                         "rule_applications_vs_k15": ratio, "samples": args.samples})
            print(f"| {fam[0]} | {safety:g} | {counts[0]} / {counts[1]} (all: {under_all[0]} / {under_all[1]}) | {worst:.3g} | {ratio:.3f} |")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"seed": args.seed, "samples": args.samples, "rows": rows}, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
