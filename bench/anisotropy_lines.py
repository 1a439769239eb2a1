"""Per-axis lookup error of ``albedo_aniso`` along lines, and the additive model of a table's error.

Run: ``python bench/anisotropy_lines.py [--domain MU_MIN,R_MIN[,A_MAX]] [--bases N]``.

Companion of ``bench/anisotropy_tables.py`` (same lookup coordinates: sqrt(mu), s with
phi_v = (pi/2)(1 - (1 - s)^2), roughness, t = log10(aspect)). For random base points in the domain
(a third pinned to its hard edges), E is computed by the kernel at 129 points uniform in one
coordinate with the others fixed; linear interpolation from every 2^k-th of them (n = 3 ... 65
nodes) against all 129 gives that axis's error e_k(n). A multilinear table's error is about the
sum of its axes' errors (checked against the tables measured by ``anisotropy_tables.py``); the
smallest (n_mu, n_phi, n_r, n_t) with sum e_k(n_k) under ``--tol`` is the predicted smallest
table. Writes ``bench/out/anisotropy_lines_<domain>.json``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "bench" / "out"
for p in (ROOT, ROOT / "bench"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

from anisotropy_tables import aniso_of_t, evaluate, phi_of_s, t_of_aniso  # noqa: E402
from bsdf_tab.api import quiet_warp  # noqa: E402

NL = 129
SIZES = (3, 5, 9, 17, 33, 65)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--domain", default="0.1,0.2", metavar="MU_MIN,R_MIN[,A_MAX]")
    ap.add_argument("--bases", type=int, default=36)
    ap.add_argument("--tol", type=float, default=1e-3)
    args = ap.parse_args(argv)
    quiet_warp()
    mu_min, r_min, a_max = (*(float(x) for x in args.domain.split(",")), 1.0)[:3]
    t_max = float(t_of_aniso(a_max))
    lo = np.array([math.sqrt(mu_min), 0.0, r_min, 0.0])
    hi = np.array([1.0, 1.0, 1.0, t_max])
    rng = np.random.default_rng(29)
    base = lo + (hi - lo) * rng.random((args.bases, 4))
    third = args.bases // 3
    base[:third, 0] = lo[0]  # grazing floor
    base[:third:2, 2] = r_min  # and the roughness floor
    base[third:2 * third, 3] = t_max  # the largest aspect
    c = np.linspace(0.0, 1.0, NL)
    errors = {}
    for k, name in enumerate(("mu", "phi_v", "roughness", "anisotropy")):
        P = np.repeat(base[:, None, :], NL, axis=1)
        P[:, :, k] = lo[k] + (hi[k] - lo[k]) * c[None, :]
        E, _ = evaluate(P[..., 0] ** 2, phi_of_s(P[..., 1]), P[..., 2], aniso_of_t(P[..., 3]))
        errors[name] = {}
        for n in SIZES:
            step = (NL - 1) // (n - 1)
            interp = np.array([np.interp(c, c[::step], row[::step]) for row in E])
            errors[name][n] = float(np.abs(interp - E).max())
        print(name, " ".join(f"{n}: {e:.1e}" for n, e in errors[name].items()), flush=True)
    best = None
    for sizes in itertools.product(SIZES, repeat=4):
        total = sum(errors[name][n] for name, n in zip(errors, sizes))
        texels = int(np.prod(sizes))
        if total < args.tol and (best is None or texels < best["texels"]):
            best = {"size": list(sizes), "texels": texels, "predicted_max_err": total}
    print(f"domain mu >= {mu_min:g}, roughness >= {r_min:g}, a <= {a_max:g}: predicted smallest under {args.tol:g}: {best}")
    model_master = sum(errors[name][n] for name, n in zip(errors, (9, 33, 17, 9)))
    print(f"additive model at (9, 33, 17, 9): {model_master:.2e} (compare anisotropy_tables.py's measured max)")
    OUT.mkdir(parents=True, exist_ok=True)
    tag = args.domain.replace(",", "_")
    (OUT / f"anisotropy_lines_{tag}.json").write_text(json.dumps(
        {"domain": [mu_min, r_min, a_max], "errors": errors, "best": best, "model_at_9_33_17_9": model_master}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
