"""Honesty and evaluation counts of the adaptive method on 1634 reference texels (issue 14).

Run: ``python bench/accuracy_honesty.py [--tols 1e-3,5e-7] [--variant KEY=VALUE[,KEY=VALUE]]``
(``--quick``: the sweep grid only; ``--device cuda:0`` on a GPU). Prints, per integrator variant and tolerance, the mean and
max integrand evaluations per texel (the kernel's own counters: exact, independent of load), the
worst ratio (|true error| - reference bound) / reported error, the number of texel-channels
above 1 ("dishonest") and the max true error; writes ``bench/out/accuracy_honesty.json``.

The texels: the accuracy sweep's grid (:mod:`bench.accuracy_sweep`, 7 cases x 110); a held-out
set of 100 random texels (GGX and Beckmann x albedo correlated / separable, dielectric
correlated eta > 1, eta < 1, separable eta < 1; mu half uniform, half log-uniform in [1e-4, 1],
alpha log-uniform in [1e-3, 1], eta uniform in [1.01, 4] or its reciprocal; seed 20261201); 164
reflection texels with every Fresnel type and dfg texels (seeds of
``tests/integrate/test_integrate_accuracy.py``, plus 6 per combination from seed + 50000); and
the 600 texels of that file's larger-sample honesty test. References: the independent
``tests/reference/microfacet_ref.py`` (method B for the sweep and the larger sample, A and B
for the others), cached under ``bench/out/cache``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import pickle
import sys
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[1]
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from bench.accuracy_sweep import ALPHA_FULL, MU_FULL  # noqa: E402
from tests.reference.sampling import fresnel_spec, sample_texels  # noqa: E402
from bench.common import (  # noqa: E402
    CASES, DEFAULT_OUT, device_arg, distribution_id, parse_variants, reference_module, shadowing_id,
)

DISTS = ("ggx", "beckmann")
SHADS = ("separable", "correlated")
FRESNEL_IDS = {"one": 0, "schlick": 1, "dielectric": 2, "conductor": 3}


def texel_sets(quick: bool):
    """[(label, mode, kwargs for integrate_texels, mu, alpha, eta, reference recipe)]."""
    sets = []
    mg, ag = np.meshgrid(np.array(MU_FULL), np.array(ALPHA_FULL), indexing="ij")
    for case in CASES:
        kw = {"dist": distribution_id(case.dist), "shadowing": shadowing_id(case.shadowing)}
        eta = np.full(mg.size, case.eta or 1.0)
        sets.append((f"sweep {case.name}", case.mode, kw, mg.ravel(), ag.ravel(), eta,
                     (case.mode, case.dist, case.shadowing, ("one",), "B")))
    if quick:
        return sets
    rng = np.random.default_rng(20261201)
    for dist in DISTS:
        for shad, mode, side in (("correlated", "reflect", None), ("separable", "reflect", None),
                                 ("correlated", "dielectric", ">1"), ("correlated", "dielectric", "<1"),
                                 ("separable", "dielectric", "<1")):
            mu = np.concatenate([rng.uniform(1e-4, 1.0, 5), 10 ** rng.uniform(-4, 0, 5)])
            alpha = 10 ** rng.uniform(-3, 0, 10)
            eta = np.ones(10)
            if side:
                eta = rng.uniform(1.01, 4.0, 10)
                eta = 1.0 / eta if side == "<1" else eta
            kw = {"dist": distribution_id(dist), "shadowing": shadowing_id(shad)}
            sets.append((f"held-out {dist} {shad} {mode} {side or ''}", mode, kw, mu, alpha, eta,
                         (mode, dist, shad, ("one",), "B")))
    for fname in FRESNEL_IDS:
        for d, dist in enumerate(DISTS):
            for s, shad in enumerate(SHADS):
                seed = 1000 + 100 * d + 10 * s + FRESNEL_IDS[fname]
                spec, p0, p1 = fresnel_spec(fname, np.random.default_rng(seed + 7))
                kw = {"dist": distribution_id(dist), "shadowing": shadowing_id(shad), "ftype": FRESNEL_IDS[fname],
                      "fp0": p0, "fp1": p1}
                for sd, n in ((seed, 2), (seed + 50000, 6)):
                    mu, alpha, _ = sample_texels(sd, n)
                    sets.append((f"test reflect {fname} {dist} {shad}", "reflect", kw, mu, alpha, np.ones(n),
                                 ("reflect", dist, shad, spec, "AB")))
    for d, dist in enumerate(DISTS):
        for s, shad in enumerate(SHADS):
            seed = 3000 + 100 * d + 10 * s
            kw = {"dist": distribution_id(dist), "shadowing": shadowing_id(shad)}
            for sd, n in ((seed, 3), (seed + 50000, 6)):
                mu, alpha, _ = sample_texels(sd, n)
                sets.append((f"test dfg {dist} {shad}", "dfg", kw, mu, alpha, np.ones(n), ("dfg", dist, shad, None, "AB")))
            seed = 4000 + 100 * d + 10 * s
            mu, alpha, _ = sample_texels(seed, 50)
            sets.append((f"larger sample E {dist} {shad}", "reflect", kw, mu, alpha, np.ones(50),
                         ("reflect", dist, shad, ("one",), "B")))
            for side in (">1", "<1"):
                mu, alpha, eta = sample_texels(seed + (side == "<1") + 1, 50, eta=side)
                sets.append((f"larger sample RT {dist} {shad} {side}", "dielectric", kw, mu, alpha, eta,
                             ("dielectric", dist, shad, ("one",), "B")))
    return sets


def references(recipe, mu, alpha, eta, cache: Path):
    """(values, bounds), each (N, 2), from the independent reference (cached)."""
    key = hashlib.sha256(json.dumps([list(map(str, recipe)), mu.tolist(), alpha.tolist(), eta.tolist(),
                                     "honesty/v1"]).encode()).hexdigest()[:16]
    path = cache / f"honesty_{key}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    ref = reference_module()
    mode, dist, shad, fres, methods = recipe
    v, e = np.zeros((mu.size, 2)), np.zeros((mu.size, 2))
    for k in range(mu.size):
        m, a, t = float(mu[k]), float(alpha[k]), float(eta[k])
        if mode == "reflect":
            r = ref.albedo(m, a, dist, shad, fres, methods=methods)
            v[k, 0], e[k, 0] = r.value, r.err
        elif mode == "dfg":
            r = ref.dfg(m, a, dist, shad)
            v[k], e[k] = (r[0].value, r[1].value), (r[0].err, r[1].err)
        else:
            r = ref.dielectric(m, a, t, dist, shad, methods=methods)
            v[k], e[k] = (r[0].value, r[1].value), (r[0].err, r[1].err)
    cache.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps((v, e)))
    return v, e


def run(tols, variants, quick=False, out_dir: Path = DEFAULT_OUT, workers=None, device=None):
    from bsdf_tab.integrate.adaptive import integrate_texels

    sets = texel_sets(quick)
    refs = [references(s[6], s[3], s[4], s[5], out_dir / "cache") for s in sets]
    rows = []
    for var in variants:
        for tol in tols:
            evals, worst, bad, maxerr, worst_set = [], 0.0, 0, 0.0, ""
            for (label, mode, kw, mu, alpha, eta, _), (rv, re) in zip(sets, refs):
                v, e, c = integrate_texels(mode, mu, alpha, eta, tol=tol, return_cost=True, workers=workers,
                                           device=device, **kw, **var)
                ch = 1 if mode == "reflect" else 2
                err = np.abs(v[:, :ch] - rv[:, :ch])
                ratio = (err - re[:, :ch]) / np.maximum(e[:, :ch], 1e-300)  # reported errors are >= 1e-10
                evals.append(c)
                bad += int((~(ratio <= 1.0)).sum())  # a nan value (or bound) is dishonest too
                maxerr = max(maxerr, float(err.max()) if np.isfinite(err).all() else np.inf)
                if ratio.max() > worst:
                    worst, worst_set = float(ratio.max()), label
            c = np.concatenate(evals)
            rows.append({"variant": var, "tol": tol, "texels": int(c.size), "evals_mean": float(c.mean()),
                         "evals_max": int(c.max()), "worst_ratio": worst, "worst_in": worst_set,
                         "dishonest": bad, "max_true_error": maxerr})
            r = rows[-1]
            print(f"{json.dumps(var):40s} tol {tol:<8g} texels {r['texels']}  evals mean {r['evals_mean']:7.0f} "
                  f"max {r['evals_max']:6d}  worst {worst:.2f} ({worst_set})  dishonest {bad}  max err {maxerr:.2g}",
                  flush=True)
    return rows


def main(argv=None, prog=None) -> int:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n")[0])
    parser.add_argument("--tols", default="1e-2,1e-3,1e-4,1e-5,1e-6,5e-7,1e-7")
    parser.add_argument("--variant", action="append", default=[], metavar="KEY=VALUE[,KEY=VALUE]",
                        help="integrator keywords (repeatable; the default method always runs first)")
    parser.add_argument("--quick", action="store_true", help="the sweep grid only (770 texels)")
    parser.add_argument("--out", default=str(DEFAULT_OUT))
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--device", default=None, help="Warp device, e.g. cuda:0 (default: cpu)")
    args = parser.parse_args(argv)
    try:
        tols = [float(t) for t in args.tols.split(",")]
        variants = [{}] + parse_variants(args.variant)
    except ValueError as exc:
        print(f"accuracy_honesty.py: error: bad --tols or --variant ({exc})", file=sys.stderr)
        return 2
    device_arg(parser, args.device or "cpu")
    out = Path(args.out)
    rows = run(tols, variants, args.quick, out, args.workers, args.device or "cpu")
    out.mkdir(parents=True, exist_ok=True)
    (out / "accuracy_honesty.json").write_text(json.dumps({"rows": rows}, indent=1))
    print(f"wrote {out / 'accuracy_honesty.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
