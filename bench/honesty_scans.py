"""Stress scans of the adaptive method's error channel (issue 14, rounds 11 to 13).

Run: ``python bench/honesty_scans.py --scan random --seed 41 [--variant KEY=VALUE[,KEY=VALUE]]``
(``--scan normal | grazing | general | random``, ``--tols 1e-6,5e-7``, ``--texels N`` per random
family). Prints, per integrator variant (the default method always runs first) and tolerance, the
integrand evaluations, the texel-channels whose true error exceeds the reported one
("dishonest"), the worst ratio and its texel; then the worst texel-tolerances above 0.5 (at
tolerances below 1e-4) or above 1. Writes ``bench/out/honesty_scans_<scan>.json``.

The true error of a texel is |value - reference| less the reference's own estimate, the
reference being the method itself at tolerance 1e-11 (the same texel, the default keywords):
its agreement with the independent reference is what ``tests/integrate`` checks, and every
texel that a scan calls dishonest in docs/methods.md was confirmed against
``tests/reference/microfacet_ref.py`` (methods A and B) before it was called a miss.

The scans (docs/methods.md, eleventh and twelfth rounds), each at 7 tolerances 1e-2 .. 1e-7 by
default:

- ``normal``: 13 mu within 0.03 of 1 (1, 1 - 1e-9 .. 0.97) x 48 alpha (3e-4 .. 0.5): reflection
  (F = 1) and split-sum with GGX and Beckmann, dielectric GGX at 17 eta from 0.2 to 3 and
  Beckmann at 7 (28 families, 17 472 texels);
- ``grazing``: the same families at 10 mu from 0 to 0.1 x 48 alpha (3e-4 .. 2; 13 440 texels);
- ``general``: 12 mu from 0 to 1 x 40 alpha (3e-4 .. 2): reflection with Schlick 0.04, dielectric
  Fresnels 0.6, 1.5, 1.0001 and 0.9999, a conductor 0.2 + 3i, dielectric at eta within 2% of 1,
  split-sum; both distributions and shadowing modes (52 families, 24 960 texels);
- ``random``: 32 families (reflection with F = 1, Schlick 0.04, dielectric Fresnels 1.5 and 0.7,
  a conductor 0.2 + 3i; dielectric with eta < 1 and > 1 down to 1 -+ 1e-4; split-sum; both
  distributions and shadowing modes) x ``--texels`` (2000) texels drawn from ``--seed``: 30% with
  mu log-uniform in 1e-6 .. 0.1, the rest uniform in [0, 1] (the first five mu 0, 1, 1 - 1e-7,
  1e-8 and 0.5), alpha log-uniform in 5e-4 .. 2. The draws are those of the rounds' scans: a seed
  gives the texels docs/methods.md counted.
- ``core``: the four tables of ``bench/core.py`` (albedo 32^2 GGX and Beckmann, dielectric 16^3
  with eta > 1 and eta < 1; 10 240 texels), for what a variant costs and misses where the speed
  goals are measured (docs/methods.md, fourteenth round:
  ``--scan core --tols 1e-3 --variant outer_first_safety=1e-12`` and the like).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[1]
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from bench.common import DEFAULT_OUT, parse_variants  # noqa: E402
from bsdf_tab.integrate import integrate_texels  # noqa: E402

TOLS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 5e-7, 1e-7)
REFERENCE_TOL = 1e-11
SCANS = ("normal", "grazing", "general", "random", "core")


@dataclass(frozen=True)
class Family:
    """One integrand family: a mode, a distribution id, a shadowing id, Fresnel keywords, an eta
    (dielectric mode: one value for every texel, or None where the texels carry their own)."""

    mode: str
    dist: int
    shadowing: int = 1
    fresnel: dict = field(default_factory=dict)
    eta: float | None = None
    name: str | None = None  # a label of its own (the core scan's table names)

    def label(self) -> str:
        if self.name:
            return self.name
        parts = [self.mode, ("GGX", "Beckmann")[self.dist], ("separable", "correlated")[self.shadowing]]
        if self.fresnel:
            parts.append(json.dumps(self.fresnel, sort_keys=True))
        if self.eta is not None:
            parts.append(f"eta {self.eta:g}")
        return " ".join(parts)


@dataclass
class Texels:
    """A family's texels: flat float64 mu, alpha and eta (None outside dielectric mode)."""

    family: Family
    mu: np.ndarray
    alpha: np.ndarray
    eta: np.ndarray | None = None


def _grid(families, mus, alphas) -> list[Texels]:
    m, a = np.meshgrid(np.asarray(mus, float), np.asarray(alphas, float), indexing="ij")
    m, a = m.ravel(), a.ravel()
    return [Texels(f, m, a, None if f.eta is None else np.full(m.size, f.eta)) for f in families]


def _normal_families() -> list[Family]:
    return ([Family("dielectric", 0, eta=x) for x in (0.2, 0.25, 0.3, 0.4, 0.5, 0.667, 0.8, 0.9, 0.95, 0.99, 1.01,
                                                      1.05, 1.1, 1.3, 1.5, 2.0, 3.0)]
            + [Family("dielectric", 1, eta=x) for x in (0.25, 0.5, 0.667, 0.9, 1.1, 1.5, 3.0)]
            + [Family(mode, d) for mode in ("reflect", "dfg") for d in (0, 1)])


def scan_normal() -> list[Texels]:
    mus = [1.0, 1 - 1e-9, 1 - 1e-8, 1 - 1e-7, 1 - 3e-7, 1 - 1e-6, 1 - 3e-6, 0.99999, 1 - 3e-5, 0.9999, 0.999, 0.99, 0.97]
    return _grid(_normal_families(), mus, np.logspace(-3.5, -0.3, 48))


def scan_grazing() -> list[Texels]:
    mus = [0.0, 1e-9, 1e-7, 1e-5, 1e-4, 1e-3, 3e-3, 0.01, 0.03, 0.1]
    return _grid(_normal_families(), mus, np.logspace(-3.5, 0.3, 48))


def scan_general() -> list[Texels]:
    fams = []
    for sh in (0, 1):
        for d in (0, 1):
            fams += [Family("reflect", d, sh, fk) for fk in (
                {"ftype": 1, "fp0": 0.04}, {"ftype": 2, "fp0": 0.6}, {"ftype": 2, "fp0": 1.5},
                {"ftype": 3, "fp0": 0.2, "fp1": 3.0}, {"ftype": 2, "fp0": 1.0001}, {"ftype": 2, "fp0": 0.9999})]
            fams += [Family("dielectric", d, sh, eta=x) for x in (1.0001, 1.001, 0.999, 0.9999, 1.02, 0.98)]
        fams += [Family("dfg", 0, sh), Family("dfg", 1, sh)]
    mus = [0.0, 1e-6, 1e-4, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.9999, 1.0]
    return _grid(fams, mus, np.logspace(-3.5, 0.3, 40))


def random_families() -> list[tuple[Family, str | None]]:
    """The random scan's 32 families, each with its eta sampler ("lt", "gt" or None)."""
    fresnels = ({}, {"ftype": 1, "fp0": 0.04}, {"ftype": 2, "fp0": 1.5}, {"ftype": 2, "fp0": 0.7},
                {"ftype": 3, "fp0": 0.2, "fp1": 3.0})
    fams = [(Family("reflect", d, sh, fk), None) for d in (0, 1) for sh in (0, 1) for fk in fresnels]
    fams += [(Family("dielectric", d, sh), "lt") for d in (0, 1) for sh in (0, 1)]
    fams += [(Family("dielectric", d, sh), "gt") for d in (0, 1) for sh in (0, 1)]
    fams += [(Family("dfg", d, sh), None) for d in (0, 1) for sh in (0, 1)]
    return fams


def scan_random(seed: int, n: int = 2000) -> list[Texels]:
    """The random scan's texels from ``seed``: the draws, in their order, of rounds 11 and 12."""
    if n < 5:
        raise ValueError(f"--texels must be at least 5 (the fixed mu), got {n}")
    rng = np.random.default_rng(seed)
    out = []
    for fam, ek in random_families():
        mu = np.where(rng.random(n) < 0.3, 10 ** rng.uniform(-6, -1, n), rng.uniform(0, 1, n))
        mu[:5] = [0.0, 1.0, 1 - 1e-7, 1e-8, 0.5]
        alpha = 10 ** rng.uniform(-3.3, np.log10(2.0), n)
        eta = None
        if ek == "lt":
            eta = 1.0 / (1.0 + 10 ** rng.uniform(-4, np.log10(3.0), n))
        elif ek == "gt":
            eta = 1.0 + 10 ** rng.uniform(-4, np.log10(3.0), n)
        out.append(Texels(fam, mu, alpha, eta))
    return out


def scan_core() -> list[Texels]:
    """The texels of ``bench/core.py``'s four tables (their axes from a bake at tolerance 1e-2)."""
    import bsdf_tab
    from bench import core

    out = []
    for name, spec, mode in core.CASES:
        kw = core.integrator_keywords(spec)
        table = bsdf_tab.tabulate(dict(spec, tolerance=1e-2))
        mu, alpha, eta, _ = core.flat_texels(table, mode)
        fresnel = {k: kw[k] for k in ("ftype", "fp0", "fp1") if kw.get(k)}
        out.append(Texels(Family(mode, kw["dist"], kw["shadowing"], fresnel, name=name), mu, alpha,
                          eta if mode == "dielectric" else None))
    return out


def texels_of(scan: str, seed: int = 1, n: int = 2000) -> list[Texels]:
    if scan == "random":
        return scan_random(seed, n)
    return {"normal": scan_normal, "grazing": scan_grazing, "general": scan_general, "core": scan_core}[scan]()


def _integrate(t: Texels, tol: float, variant: dict, cost: bool):
    f = t.family
    return integrate_texels(f.mode, t.mu, t.alpha, t.eta, dist=f.dist, shadowing=f.shadowing, tol=tol,
                            return_cost=cost, **f.fresnel, **variant)


def run(texels: list[Texels], tols, variants, progress=print) -> list[dict]:
    """Rows (one per variant and tolerance): evaluations, texel-channels, dishonest, the worst
    ratio (|value - reference| - reference estimate) / reported error, and every texel-tolerance
    whose ratio is above 0.5 (``cases``: ratio, family, tolerance, mu, alpha, eta, channel, the
    true error and the reported one)."""
    acc = {(i, tol): {"variant": v, "tol": tol, "evaluations": 0, "texels": 0, "texel_channels": 0, "dishonest": 0,
                      "worst": 0.0, "worst_family": None, "families": {}, "cases": []}
           for i, v in enumerate(variants) for tol in tols}
    for t in texels:
        ref, ref_err = _integrate(t, REFERENCE_TOL, {}, False)
        # a channel that is 0 in the reference and the run (reflection's second channel) has no
        # error to report: it is counted, never a miss
        for i, v in enumerate(variants):
            for tol in tols:
                val, err, cost = _integrate(t, tol, v, True)
                true = np.abs(val - ref) - ref_err
                ratio = np.where(true > 0.0, true / np.maximum(err, 1e-300), 0.0)
                row = acc[(i, tol)]
                row["evaluations"] += int(cost.sum())
                row["texels"] += int(cost.size)
                row["texel_channels"] += int(ratio.size)
                row["dishonest"] += int(np.count_nonzero(ratio > 1.0))
                fam = row["families"].setdefault(t.family.label(), {"evaluations": 0, "texels": 0, "dishonest": 0})
                fam["evaluations"] += int(cost.sum())
                fam["texels"] += int(cost.size)
                fam["dishonest"] += int(np.count_nonzero(ratio > 1.0))
                k = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
                if ratio[k] > row["worst"]:
                    row["worst"], row["worst_family"] = float(ratio[k]), t.family.label()
                for k, c in zip(*np.nonzero(ratio > 0.5)):
                    row["cases"].append({
                        "ratio": float(ratio[k, c]), "family": t.family.label(), "tol": tol,
                        "mu": float(t.mu[k]), "alpha": float(t.alpha[k]),
                        "eta": None if t.eta is None else float(t.eta[k]), "channel": int(c),
                        "true_error": float(true[k, c]), "reported": float(err[k, c])})
        progress(f"  {t.family.label()}: {t.mu.size} texels")
    return list(acc.values())


def _print(rows, scan):
    print(f"\n{'variant':<36} {'tol':>7} {'evaluations':>14} {'per texel':>9} {'dishonest':>9} {'worst':>6}  worst family")
    for r in rows:
        print(f"{json.dumps(r['variant']):<36} {r['tol']:>7.0e} {r['evaluations']:>14} "
              f"{r['evaluations'] / max(r['texels'], 1):>9.1f} {r['dishonest']:>9} "
              f"{r['worst']:>6.2f}  {r['worst_family'] or '-'}")
    if len(rows[0]["families"]) <= 8:  # a few families (the core scan): each on its own line
        print("\nper family: evaluations per texel (dishonest texel-channels)")
        for r in rows:
            print(f"{json.dumps(r['variant']):<36} {r['tol']:>7.0e}  " + "; ".join(
                f"{k} {f['evaluations'] / max(f['texels'], 1):.1f} ({f['dishonest']})" for k, f in r["families"].items()))
    for r in rows:
        shown = sorted((c for c in r["cases"] if c["ratio"] > 1.0 or c["tol"] < 1e-4),
                       key=lambda c: -c["ratio"])[:6]
        for c in shown:
            print(f"    {json.dumps(r['variant'])} {r['tol']:.0e}: {c['ratio']:.2f}x  {c['family']}  mu {c['mu']:.6g} "
                  f"alpha {c['alpha']:.6g}" + ("" if c["eta"] is None else f" eta {c['eta']:.6g}")
                  + f"  channel {c['channel']}  true {c['true_error']:.2e} reported {c['reported']:.2e}")


def main(argv=None, prog=None) -> int:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n")[0])
    parser.add_argument("--scan", default="random", help="normal, grazing, general, random (default) or core")
    parser.add_argument("--seed", type=int, default=41, help="the random scan's seed (default 41)")
    parser.add_argument("--texels", type=int, default=2000, help="texels per random family (default 2000)")
    parser.add_argument("--tols", default=",".join(f"{t:g}" for t in TOLS))
    parser.add_argument("--variant", action="append", default=[], metavar="KEY=VALUE[,KEY=VALUE]",
                        help="integrator keywords (repeatable; the default method always runs first)")
    parser.add_argument("--out", default=str(DEFAULT_OUT))
    args = parser.parse_args(argv)
    name = prog or "honesty_scans.py"
    if args.scan not in SCANS:
        print(f"{name}: error: --scan must be one of {', '.join(SCANS)}, got {args.scan!r}", file=sys.stderr)
        return 2
    try:
        tols = [float(t) for t in args.tols.split(",")]
        if not all(np.isfinite(t) and t > 0.0 for t in tols):
            raise ValueError("tolerances must be finite and > 0")
        variants = [{}] + parse_variants(args.variant)
        texels = texels_of(args.scan, args.seed, args.texels)
    except ValueError as exc:
        print(f"{name}: error: bad --tols, --variant or --texels ({exc})", file=sys.stderr)
        return 2
    n = sum(t.mu.size for t in texels)
    print(f"scan {args.scan}" + (f" (seed {args.seed})" if args.scan == "random" else "")
          + f": {len(texels)} families, {n} texels, {len(tols)} tolerances, reference: the method at {REFERENCE_TOL:g}",
          flush=True)
    t0 = time.perf_counter()
    try:
        rows = run(texels, tols, variants, progress=lambda s: print(s, flush=True))
    except (ValueError, TypeError) as exc:  # an integrator keyword unknown or out of its domain
        print(f"{name}: error: bad --variant ({exc})", file=sys.stderr)
        return 2
    _print(rows, args.scan)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"honesty_scans_{args.scan}.json"
    path.write_text(json.dumps({"scan": args.scan, "seed": args.seed if args.scan == "random" else None,
                                "texels": n, "reference_tol": REFERENCE_TOL, "seconds": time.perf_counter() - t0,
                                "rows": rows}, indent=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
