"""The exact check, the findings and the report of the doctor's 1-D and 3-D kinds (:mod:`.nd`).

As for 2-D LUTs (:mod:`.check`): the winner of :func:`bsdf_tab.doctor.nd.search_nd` is baked
exactly at the file's nodes (every node up to :data:`MAX_CHECK` per axis, else that many evenly
chosen), a mu = 0 node is tried against the clamps of :data:`bsdf_tab.doctor.storage.MU_CLAMPS`,
and the residual gives the error, where it is, the storage, the noise and a bias. Averages of
the dielectric are checked against the exact table averaged by :data:`.glass.AVG_RULE`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .fit import NODE_FORMULA, NODE_TYPES, even_indices
from .glass import AVG_RULE, Z_MAX, albedo_avg_exact_at, glass_avg_exact_at, glass_exact_at
from .nd import FILE_SPACING, KINDS_ND, NDHypothesis, claimed_axes as file_axes, predict, search_nd, to_file_order
from .claims import axis_orders
from .readers import LutImage
from .storage import BITS, MU_CLAMPS, drop_guesses, fit_findings, high_frequency, quantization, storage_rms

__all__ = ["MAX_CHECK", "NDReport", "check_nd"]

MAX_CHECK = {1: 16, 2: 8, 3: 8}
AXIS_LABELS = {1: ("axis",), 2: ("rows", "columns"), 3: ("slices", "rows", "columns")}
FLIP = {"slices": "Z flipped", "rows": "Y flipped", "columns": "X flipped", "axis": "reversed"}
MEANING_TEXT = {
    "E_avg": "albedo average E_avg = 2 int E(mu) mu dmu (F = 1)",
    "1-E_avg": "energy complement 1 - E_avg",
    "R": "reflected energy R", "T": "transmitted energy T", "R+T": "R + T",
    "1-(R+T)": "energy complement 1 - (R + T)", "1-R": "energy complement of the reflection 1 - R",
}
_SLOT = {"roughness": "rough", "alpha": "rough", "ior": "ior", "eta": "ior", "z": "ior", "mu": "mu", "cos": "mu",
         "nov": "mu", "ndotv": "mu"}


def _exact(kind: str, h: NDHypothesis, nodes: dict) -> dict:
    if kind == "albedo_avg":
        return {"E_avg": albedo_avg_exact_at(h.distribution, h.shadowing, nodes["rough"])}
    if kind == "dielectric_avg":
        return glass_avg_exact_at(h.shadowing, nodes["rough"], nodes["ior"])
    return glass_exact_at(h.shadowing, nodes["mu"], nodes["rough"], nodes["ior"])


@dataclass
class NDReport:
    """What the doctor found in a 1-D average or a 3-D (or 2-D averaged) dielectric table."""

    name: str
    file_format: str
    shape: list
    best: NDHypothesis
    alternatives: list
    channels: list
    active: list
    storage: str
    step: float
    transfer: str | None
    max_error: float
    mean_error: float
    worst: dict
    checked: list
    mu_clamp: float | None
    error_map: np.ndarray
    constants: dict
    findings: list = field(default_factory=list)
    noise: dict | None = None
    bias: float = 0.0
    interior: dict | None = None  # the errors off the end slices of a convention of their own

    def _axis(self, label: str, a, n: int) -> dict:
        values = a.axis_values(n)
        clamp = None
        if a.quantity == "mu" and self.mu_clamp is not None:
            values = np.where(values < 1e-9, self.mu_clamp, values)
            clamp = self.mu_clamp
        offset = NODE_TYPES[a.nodes][1]
        out = {"file_axis": label, "name": a.label, "size": n, "spacing": a.spacing, "coordinate": a.coordinate,
               "nodes": a.nodes, "offset_texels": offset or 0.0, "range": [float(values.min()), float(values.max())],
               "reversed": bool(a.reversed), "clamp": clamp}
        if a.quantity == "ior" and a.spacing not in ("openpbr", FILE_SPACING):
            out["clamp"] = {"x_max": Z_MAX, "ior_max": float((1 + Z_MAX**2) / (1 - Z_MAX**2))}
        return out

    def to_dict(self) -> dict:
        b = self.best
        labels = AXIS_LABELS[len(b.axes)]
        chans = {self.channels[c]: m for c, m in zip(self.active, b.meanings)}
        for name, value in self.constants.items():
            chans[name] = f"constant {value:.6g}"
        return {
            "file": self.name, "format": self.file_format, "shape": self.shape,
            "table": b.kind, "fitted": True, "quantity": "+".join(dict.fromkeys(b.meanings)),
            "distribution": b.distribution, "shadowing": b.shadowing, "eta": b.side,
            "axes": [self._axis(lab, a, n) for lab, a, n in zip(labels, b.axes, self.shape)],
            "channels": chans, "channel_meanings": {k: MEANING_TEXT.get(v, v) for k, v in chans.items()},
            "encoding": b.encoding, "storage": self.storage, "declared_transfer": self.transfer,
            "max_error": self.max_error, "mean_error": self.mean_error, "mean_signed_error": self.bias,
            "max_error_at": self.worst, "screening_error": b.score, "interior": self.interior,
            "checked_texels": {"per_axis": self.checked,
                               "against": "the best match baked exactly at the file's nodes"
                               + (f" ({AVG_RULE})" if b.kind == "dielectric_avg" else "")},
            "noise": self.noise, "alternatives": self.alternatives, "findings": list(self.findings),
        }

    def text(self) -> str:
        d = self.to_dict()
        eta = f", {d['eta']}" if d["eta"] else ""
        lines = [f"{d['file']}: {d['format']} {' x '.join(str(s) for s in d['shape'])}",
                 f"  best match: {d['table']} ({d['quantity']}), {d['distribution']}, {d['shadowing']} shadowing{eta}, "
                 f"{d['encoding']} values, stored {d['storage']}"]
        for a in d["axes"]:
            rev = ", reversed" if a["reversed"] else ""
            clamp = f", clamped at {a['clamp']:.3g}" if isinstance(a["clamp"], float) else ""
            lines.append(f"  {a['file_axis']:<8} {a['name']}: {a['coordinate']}, {a['nodes']} nodes, "
                         f"range [{a['range'][0]:.4g}, {a['range'][1]:.4g}]{rev}{clamp}")
        for ch, m in d["channel_meanings"].items():
            lines.append(f"  channel {ch}: {m}")
        w = d["max_error_at"]
        at = ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in w.items())
        lines.append(f"  max error {d['max_error']:.3g} at {at}; mean error {d['mean_error']:.3g} "
                     f"over {' x '.join(map(str, self.checked))} texels checked exactly")
        if d["alternatives"]:
            lines.append("  next best: " + "; ".join(f"{a['shadowing']} ({a['axes']}) {a['mean_error']:.3g}"
                                                     for a in d["alternatives"][:3]))
        lines.append("  findings:" if d["findings"] else "  findings: none")
        lines += [f"  - {x}" for x in d["findings"]]
        return "\n".join(lines)

    def write_heatmap(self, path) -> None:
        """A PNG of |file - best match| (3-D: the maximum over the slices; 1-D: a line)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        d = self.to_dict()
        fig, ax = plt.subplots(figsize=(5.2, 4.2), dpi=100)
        err = np.maximum(self.error_map, 1e-9)
        if err.ndim == 1:
            ax.semilogy(err, "o-")
            ax.set_xlabel(f"index ({d['axes'][0]['name']}: {d['axes'][0]['coordinate']})")
            ax.set_ylabel("|file - best match|")
        else:
            if err.ndim == 3:
                err = err.max(axis=0)
            im = ax.imshow(np.log10(err), origin="upper", aspect="auto", cmap="magma", interpolation="nearest")
            fig.colorbar(im, ax=ax, label="log10 |file - best match|" + (" (max over slices)" if len(d["axes"]) == 3 else ""))
            ax.set_xlabel(f"column ({d['axes'][-1]['name']}, checked nodes)")
            ax.set_ylabel(f"row ({d['axes'][-2]['name']}, checked nodes)")
        ax.set_title(f"{self.name}: {d['table']} {d['quantity']} {d['shadowing']}\n"
                     f"max {self.max_error:.2g}, mean {self.mean_error:.2g}", fontsize=9)
        fig.tight_layout()
        from ..io import atomic_path

        with atomic_path(path) as tmp:
            fig.savefig(str(tmp), format="png")
        plt.close(fig)


def _alternatives(ranked: list) -> list[dict]:
    b = ranked[0]
    out, seen = [], {(b.shadowing, b.distribution, b.geometry())}
    for h in ranked[1:]:
        key = (h.shadowing, h.distribution, h.geometry())
        if key in seen:
            continue
        seen.add(key)
        out.append({"distribution": h.distribution, "shadowing": h.shadowing,
                    "axes": ", ".join(f"{a.label} {a.spacing}" for a in h.axes), "mean_error": h.score})
    return out[:6]


def claimed_axes(img: LutImage, expect_axes) -> list[str] | None:
    if expect_axes:
        return [str(n) for n in expect_axes]
    axes = img.claims.get("axes")
    if isinstance(axes, dict):
        return [str(n) for n in axes]
    if isinstance(axes, list) and all(isinstance(a, list) and len(a) == 2 for a in axes):
        return [str(a[0]) for a in axes]
    return None


def check_nd(kind: str, img: LutImage, data: np.ndarray, *, expect_axes=None, heatmap=None, name="lut",
             ranked=None) -> NDReport:
    """Identify ``data`` (axes..., channels) as a table of ``kind`` and check the winner exactly."""
    ndim = data.ndim - 1
    spread = np.nanmax(data.reshape(-1, data.shape[-1]), axis=0) - np.nanmin(data.reshape(-1, data.shape[-1]), axis=0)
    active = [c for c in range(data.shape[-1]) if spread[c] > 1e-6]
    if ranked is None:
        ranked = search_nd(kind, data, active, claimed=file_axes(img.claims, data.shape[:-1]))
    best = ranked[0]
    shape = data.shape[:-1]
    idx = [even_indices(n, MAX_CHECK[ndim]) for n in shape]
    nodes = {a.quantity: a.values(n)[i] for a, n, i in zip(best.axes, shape, idx)}
    if "ior" in nodes:
        nodes["ior"] = np.clip(nodes["ior"], 1e-3, 100.0)
    mu_zero = clamp = None
    clamps = []
    if "mu" in nodes and nodes["mu"].min() < 1e-9:
        mu_zero = int(np.argmin(nodes["mu"]))
        clamps = list(MU_CLAMPS)
    n_mu = len(nodes["mu"]) if "mu" in nodes else 0
    bake = dict(nodes)
    if clamps:
        bake["mu"] = np.concatenate([nodes["mu"], clamps])
    exact = _exact(kind, best, bake)
    from .fit import encodings

    enc = encodings(data)[best.encoding][np.ix_(*idx)]
    canon = KINDS_ND[kind][0]

    def residual(values):
        pred = to_file_order(kind, best.axes, predict(kind, values))
        return np.stack([enc[..., c] - pred[m] for c, m in zip(active, best.meanings)], axis=-1)

    if clamps:
        mu_ax = canon.index("mu")
        base = {k: np.take(v, range(n_mu), axis=mu_ax) for k, v in exact.items()}
        file_mu = best.by_quantity("mu")

        def end_error(values):  # the median: a slice of its own convention (Cycles' ior = 1) does not decide
            r = np.take(residual(values), [mu_zero], axis=file_mu)
            return float(np.nanmedian(np.abs(r)))

        err0, options = end_error(base), {}
        for k, cv in enumerate(clamps):
            alt = {}
            for key, v in base.items():
                v = v.copy()
                sl = [slice(None)] * v.ndim
                sl[mu_ax] = mu_zero
                src = [slice(None)] * v.ndim
                src[mu_ax] = n_mu + k
                v[tuple(sl)] = exact[key][tuple(src)]
                alt[key] = v
            options[cv] = (end_error(alt), alt)
        cv = min(options, key=lambda v: options[v][0])
        if options[cv][0] < 0.5 * err0 and err0 - options[cv][0] > 1e-5:
            clamp, base = cv, options[cv][1]
    else:
        base = exact
    resid = residual(base)
    odd, keep = _odd_ends(resid)
    inner = resid
    for ax, i in sorted(odd, key=lambda t: -t[1]):
        inner = np.delete(inner, i, axis=ax)
    absr = np.abs(resid)
    worst = np.unravel_index(int(np.nanargmax(absr)), absr.shape)
    storage, step = quantization(img, data)
    at = {lab: int(i[w]) for lab, i, w in zip(AXIS_LABELS[ndim], idx, worst[:-1])}
    at["channel"] = img.channels[active[worst[-1]]]
    for a, n, i, w in zip(best.axes, shape, idx, worst[:-1]):
        at[{"rough": "alpha", "ior": "eta"}.get(a.quantity, a.quantity)] = float(a.values(n)[i[w]])
    report = NDReport(
        name=name, file_format=img.format, shape=list(data.shape), best=best, alternatives=_alternatives(ranked),
        channels=img.channels, active=active, storage=storage, step=step, transfer=img.transfer,
        max_error=float(np.nanmax(absr)), mean_error=float(np.nanmean(absr)), worst=at,
        checked=[len(i) for i in idx], mu_clamp=clamp, error_map=np.nanmax(absr, axis=-1),
        constants={img.channels[c]: float(np.nanmean(data[..., c])) for c in range(data.shape[-1]) if c not in active},
        bias=float(np.nanmean(inner)),
    )
    if odd:
        report.interior = {"max_error": float(np.nanmax(np.abs(inner))), "mean_error": float(np.nanmean(np.abs(inner))),
                           "excluded": [_slice_text(best, ax, i, shape, idx, data, resid) for ax, i in odd]}
    _findings(report, best, inner, _drop(nodes, best, odd), idx, claimed_axes(img, expect_axes), data,
              axis_orders(img.claims, shape), img.infinite)
    for ax, i in odd:
        report.findings.append("an end slice follows a convention of its own: " + _slice_text(best, ax, i, shape, idx, data, resid)
                               + f"; elsewhere max {report.interior['max_error']:.2g}, mean {report.interior['mean_error']:.2g}")
    drop_guesses(report.findings)
    if heatmap is not None:
        report.write_heatmap(heatmap)
    return report


def _odd_ends(resid: np.ndarray):
    """End slices (the first or last checked node of an axis) whose residual is a step: over 10 x
    the neighbouring slice's and the others' and above 1e-3, a convention of the file's own
    there (Cycles' ior = 1 slice, OpenPBR's roughness 0); a residual that grows toward the end
    (a bias at grazing angles) is not one. Returns [(axis, index)], and the mask of the others."""
    a = np.nanmax(np.abs(resid), axis=-1)
    keep = np.ones(a.shape, dtype=bool)
    odd = []
    for ax in range(a.ndim):
        n = a.shape[ax]
        if n < 4:
            continue
        rest = np.take(a, range(1, n - 1), axis=ax)
        for i, nb in ((0, 1), (n - 1, n - 2)):
            end = np.take(a, [i], axis=ax)
            near = float(np.nanmean(np.take(a, [nb], axis=ax)))
            if (np.nanmean(end) > 10 * max(float(np.nanmean(rest)), near, 1e-6)
                    and np.nanmax(end) > 1e-3):
                odd.append((ax, i))
                sl = [slice(None)] * a.ndim
                sl[ax] = i
                keep[tuple(sl)] = False
    return odd, keep


def _slice_text(best: NDHypothesis, ax: int, i: int, shape, idx, data, resid) -> str:
    a = best.axes[ax]
    lab = AXIS_LABELS[len(best.axes)][ax]
    node = int(idx[ax][i])
    value = float(a.axis_values(shape[ax])[node])
    r = np.take(resid, [i], axis=ax)
    v = np.take(data, [node], axis=ax)
    return (f"the {lab} node {node} ({a.label} = {value:.6g}) is off by up to {np.nanmax(np.abs(r)):.2g} "
            f"(mean {np.nanmean(r):+.2g}; the file holds {np.nanmin(v):.4g} .. {np.nanmax(v):.4g} there)")


def _drop(nodes: dict, best: NDHypothesis, odd) -> dict:
    out = dict(nodes)
    for ax, i in odd:
        q = best.axes[ax].quantity
        out[q] = np.delete(out[q], i)
    return out


def _findings(report: NDReport, best: NDHypothesis, resid: np.ndarray, nodes: dict, idx, claimed, data,
              orders=None, infinite: int = 0) -> None:
    f = report.findings
    labels = AXIS_LABELS[len(best.axes)]
    if not np.isfinite(data).all():
        f.append(f"{int((~np.isfinite(data)).sum())} texels are NaN or infinite (ignored in the fit)")
    fit_findings(f, data, infinite, best.score, "an albedo average or a GGX dielectric R / T table")
    if best.encoding == "srgb-decoded":
        f.append("decoded as sRGB: the values are the sRGB decode of the table (an *_SRGB texture format, or a "
                 "PNG/KTX2 sRGB tag honoured by the loader); read the LUT as linear data")
    elif best.encoding == "srgb":
        f.append("stored sRGB-encoded: the values are the sRGB encode of the table; decode them before use")
    elif report.transfer == "srgb":
        f.append("the file declares sRGB but holds linear values: a loader that honours the tag decodes the LUT as sRGB")
    for k, (lab, a) in enumerate(zip(labels, best.axes)):
        # the file's own claim of the axis' order, where it names the same quantity: a decreasing
        # axis the file says is decreasing is no flip
        cname, order = orders[k] if orders and len(orders) == len(best.axes) else (None, None)
        if cname is None or _SLOT.get(str(cname).lower(), str(cname).lower()) != a.quantity:
            order = None
        reversed_ = a.reversed
        if a.spacing == FILE_SPACING and a.given is not None and len(a.given) > 1:
            reversed_ = a.given[-1] < a.given[0]  # the file's own values, as they run
        if order == "decreasing" and not reversed_:
            f.append(f"{FLIP[lab]}: the file says the {lab} run from {cname} high to low, the data runs low to high")
        elif reversed_ and order != "decreasing":
            f.append(f"{FLIP[lab]}: the {lab} run from {a.label} high to low")
        off = NODE_TYPES[a.nodes][1]
        if off:
            size = "half a texel" if abs(off) == 0.5 else "one texel"
            f.append(f"grid shifted by {size} along the {lab} ({a.label}): node i sits at "
                     f"{NODE_FORMULA[a.nodes]}, the ends clamped")
    if claimed and len(claimed) == len(best.axes):
        found = [a.label for a in best.axes]
        slots = [_SLOT.get(n.lower(), n.lower()) for n in claimed]
        have = [a.quantity for a in best.axes]
        if sorted(slots) == sorted(have) and slots != have:
            f.append(f"axes swapped: the file says [{', '.join(claimed)}], the data is [{', '.join(found)}]")
        for lab, a in zip(labels, best.axes):
            cname = next((n for n, s in zip(claimed, slots) if s == a.quantity), None)
            if a.quantity == "rough" and cname in ("roughness", "alpha") and cname != a.name:
                f.append(f"roughness mapped as {a.name}: the file says {cname}, the data along the {lab} follows "
                         f"{a.coordinate}")
    if report.mu_clamp is not None:
        f.append(f"clamped end: the mu = 0 node holds mu = {MU_CLAMPS[report.mu_clamp]}")
    bits = BITS.get(report.storage)
    if bits:
        f.append(f"stored at {bits} bits: quantization step 1/{2**bits - 1} = {report.step:.2g} "
                 f"(up to {report.step / 2:.2g} per texel)")
    elif report.storage == "float16":
        f.append("stored as float16: rounding up to 2.4e-4 for values in [0.5, 1)")
    floor = max(3.0 * storage_rms(report.storage, report.step, data), 3e-6)
    # a bias: the file above (or below) the exact model on average, well beyond its storage and noise
    if abs(report.bias) > max(10 * floor, 2e-3):
        sign = "above" if report.bias > 0 else "below"
        mu_ax = best.by_quantity("mu")
        where = ""
        if mu_ax is not None:
            per_mu = np.nanmean(np.moveaxis(resid, mu_ax, 0).reshape(resid.shape[mu_ax], -1), axis=1)
            k = int(np.argmax(np.abs(per_mu)))
            where = f", most at mu = {nodes['mu'][k]:.3g} (mean {per_mu[k]:+.3g} there)"
        f.append(f"biased: the values lie {sign} the exact model by {report.bias:+.3g} on average{where}")
    if min(resid.shape[:-1]) >= 3:
        hf = np.sqrt(np.nanmean(np.stack([high_frequency(resid[..., k]) ** 2 for k in range(resid.shape[-1])]), axis=0))
        rms = float(np.sqrt(np.nanmean(hf**2)))
        if rms > floor:
            report.noise = {"rms": rms}
            if any(x.startswith("biased") for x in f):  # a bias that varies from node to node looks the same
                f.append(f"uneven residual: texel-to-texel rms {rms:.2g} (the bias varies from node to node; "
                         "Monte Carlo noise would look the same)")
            else:
                f.append(f"Monte Carlo noise: texel-to-texel residual rms {rms:.2g}")
