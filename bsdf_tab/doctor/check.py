"""``check_lut``: read a LUT, identify it, check the winner exactly, and say what is wrong.

After :func:`bsdf_tab.doctor.fit.search` ranks the hypotheses, the best one is baked exactly
at the file's nodes (every node up to 16 per axis, else 16 evenly chosen nodes; the report
says how many texels were checked), and from the residual against that exact table:

- a clamped mu end: the node at mu = 0 fits mu = 1e-4 (Cycles), 7.96e-4 (theta <= 1.57, the
  LTC fit), 1e-3 or 1e-2 better than mu = 0 (exactly: the screening spline cannot tell them);
- storage: the file's own (8/10/16-bit UNORM, float16) or values on a 1/255, 1/1023 or
  1/65535 grid;
- noise: the texel-to-texel part of the residual (the residual minus its 3 x 3 neighbourhood
  mean) above what the storage explains, and how much larger it is at grazing (mu < 0.25);
- the file's claims (a bsdf-tab file's axes, or ``expect_axes``) against what was found:
  axes swapped, roughness mapped as alpha, a node convention other than the one claimed.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..lookup import fit_axis
from .exact import exact_at
from .fit import NODE_FORMULA, NODE_TYPES, Hypothesis, encodings, even_indices, search
from .claims import axis_orders, check_claimed, claimed_kind, identified_as
from .readers import LutImage, LutReadError, read_lut, read_lut_bytes
from .nd import claimed_axes as file_axes, search_nd
from .ndcheck import check_nd
from .report import Report
from .storage import BITS as _BITS
from .storage import MU_CLAMPS, drop_guesses, fit_findings, high_frequency as _hf, quantization as _quantization, storage_rms as _storage_rms

__all__ = ["MU_CLAMPS", "check_image", "check_lut", "check_lut_bytes"]

MAX_CHECK = 16


def _subsample(n: int) -> np.ndarray:
    return even_indices(n, MAX_CHECK)


def _claimed_axes(img: LutImage, expect_axes) -> list[dict] | None:
    """The file's (or the caller's) axes: name and, when values are known, their mapping."""
    if expect_axes:
        return [{"name": n} for n in expect_axes]
    axes = img.claims.get("axes")
    if isinstance(axes, dict):  # the texture formats' form: {name: values}
        axes = [[name, values] for name, values in axes.items()]
    if isinstance(axes, list) and len(axes) == 2 and all(isinstance(a, list) and len(a) == 2 for a in axes):
        out = []
        orders = axis_orders(img.claims, img.data.shape[:-1]) or [(None, None)] * 2
        for (name, values), (_, order) in zip(axes, orders):
            a = fit_axis(str(name), values if order != "decreasing" else list(values)[::-1])
            out.append({"name": name, "spacing": {"square": "sqrt"}.get(a.spacing, a.spacing) if a.kind == "uniform" else None,
                        "nodes": a.nodes if a.kind == "uniform" else None, "order": order})
        return out
    return None


def _axis_label(h) -> str:
    return "mu" if h.quantity == "mu" else h.name


#: a 2-D LUT whose best (mu, roughness) hypothesis scores above this is also tried as a
#: (ior, roughness) average of a dielectric
TRY_AVG_ABOVE = 4e-3


def check_image(img: LutImage, *, expect_axes=None, heatmap=None, name: str = "lut"):
    """Identify a LUT already read (see :func:`check_lut`): 2-D LUTs here, 1-D averages and 3-D
    dielectric tables (and 2-D ones the (mu, roughness) kinds do not fit) in :mod:`.ndcheck`."""
    claim = claimed_kind(img.claims)
    if claim is not None and not claim["fitted"]:  # a kind the doctor has no candidate for: never "identified"
        return check_claimed(img, claim, expect_axes=expect_axes, heatmap=heatmap, name=name)
    if not np.isfinite(img.data).all():  # infinite texels (a float16 overflow) are left out of the fit as NaN are
        img = replace(img, data=np.where(np.isfinite(img.data), img.data, np.nan),
                      infinite=img.infinite + int(np.isinf(img.data).sum()))
    data = img.data
    if data.ndim == 3 and data.shape[0] == 1:  # a 1-D texture stored as one row
        data = data[0]
    if min(data.shape[:-1]) < 4:
        size = " x ".join(str(n) for n in data.shape[:-1])
        raise LutReadError(f"a {size} LUT is too small to identify (at least 4 nodes per axis)")
    if not np.isfinite(data).any() or all(np.nanmax(data[..., c]) - np.nanmin(data[..., c]) <= 1e-6
                                          for c in range(data.shape[-1])):
        raise LutReadError("every channel is constant: nothing to identify")
    if expect_axes is not None and len(expect_axes) != data.ndim - 1:
        raise LutReadError(f"give {data.ndim - 1} axis names for this {data.ndim - 1}-D LUT, got {len(expect_axes)} "
                           f"({', '.join(map(str, expect_axes))})", "axes")
    if data.ndim != 3:
        kind = "albedo_avg" if data.ndim == 2 else "dielectric"
        report = check_nd(kind, img, data, expect_axes=expect_axes, heatmap=heatmap, name=name)
        return _against_claim(report, claim)
    report = _check_2d(img, expect_axes=expect_axes, heatmap=None, name=name)
    says_avg = claim is not None and claim["table"] == "dielectric_avg"
    if report.best.score > TRY_AVG_ABOVE or says_avg:
        spread = np.nanmax(data, axis=(0, 1)) - np.nanmin(data, axis=(0, 1))
        ranked = search_nd("dielectric_avg", data, [c for c in range(data.shape[2]) if spread[c] > 1e-6],
                           claimed=file_axes(img.claims, data.shape[:-1]))
        # the file's claim of an average decides a near tie; otherwise it must fit twice as well
        if ranked[0].score < (1.0 if says_avg else 0.5) * report.best.score:
            report = check_nd("dielectric_avg", img, data, expect_axes=expect_axes, heatmap=heatmap, name=name,
                              ranked=ranked)
            return _against_claim(report, claim)
    if heatmap is not None:
        report.write_heatmap(heatmap)
    return _against_claim(report, claim)


def _against_claim(report, claim):
    """Say so when a bsdf-tab file's claimed kind is not what its values fit (only where a
    candidate fits: otherwise the identified kind is no evidence)."""
    allowed = identified_as(claim)
    if allowed is None or any(f.startswith("no candidate fits well") for f in report.findings):
        return report
    found = report.to_dict()["table"]
    if found not in allowed:
        report.findings.append(f"the file says it is a `{claim['table']}` table, its values fit `{found}`: "
                               "the claims and the data disagree")
    return report


def _check_2d(img: LutImage, *, expect_axes=None, heatmap=None, name: str = "lut") -> Report:
    data = img.data
    H, W, C = data.shape
    if not np.isfinite(data).all():
        bad = int((~np.isfinite(data)).sum())
        nan_note = f"{bad} texels are NaN or infinite (ignored in the fit)"
    else:
        nan_note = None
    spread = np.nanmax(data, axis=(0, 1)) - np.nanmin(data, axis=(0, 1))
    active = [c for c in range(C) if spread[c] > 1e-6]
    if not active:
        raise LutReadError("every channel is constant: nothing to identify")
    ranked = search(data, active)
    best = ranked[0]
    alternatives = _alternatives(ranked)
    # ---- exact check at the file's nodes
    ri, ci = _subsample(H), _subsample(W)
    mu_h, ro_h = best.mu_axis, best.rough_axis
    mu_rows = best.rows.quantity == "mu"
    mu_idx, ro_idx = (ri, ci) if mu_rows else (ci, ri)
    mu_n, ro_n = (H, W) if mu_rows else (W, H)
    mu_vals = mu_h.values(mu_n)[mu_idx]
    al_vals = ro_h.values(ro_n)[ro_idx]
    zero = int(np.argmin(mu_vals))
    clamp_vals = list(MU_CLAMPS) if mu_vals[zero] < 1e-9 else []
    exact = exact_at(best.distribution, best.shadowing, np.concatenate([mu_vals, clamp_vals]), al_vals)
    enc = encodings(data)[best.encoding][np.ix_(ri, ci)]
    n_mu = len(mu_vals)

    def prediction(values: dict) -> dict:
        p = {"E": values["E"], "1-E": 1.0 - values["E"], "A": values["A"], "B": values["B"]}
        return p if mu_rows else {k: v.T for k, v in p.items()}

    def end_error(values: dict) -> float:
        p = prediction(values)
        line = (lambda a: a[zero, :]) if mu_rows else (lambda a: a[:, zero])
        return float(np.mean([np.nanmean(np.abs(line(enc[:, :, c]) - line(p[m])))
                              for c, m in zip(active, best.meanings)]))

    base = {k: v[:n_mu] for k, v in exact.items()}
    clamp = clamp_note = None
    if clamp_vals:  # the mu = 0 node: is it held at a clamp? (exact: the spline cannot tell 0 from 1e-4)
        err0, options = end_error(base), {}
        for k, cv in enumerate(clamp_vals):
            alt = {key: v.copy() for key, v in base.items()}
            for key in alt:
                alt[key][zero] = exact[key][n_mu + k]
            options[cv] = (end_error(alt), alt)
        cv = min(options, key=lambda v: options[v][0])
        if options[cv][0] < 0.5 * err0 and err0 - options[cv][0] > 1e-5:
            clamp, clamp_note, base = cv, MU_CLAMPS[cv], options[cv][1]
    pred = prediction(base)
    resid = np.stack([enc[:, :, c] - pred[m] for c, m in zip(active, best.meanings)], axis=-1)
    absr = np.abs(resid)
    worst = np.unravel_index(int(np.nanargmax(absr)), absr.shape)
    storage, step = _quantization(img, data)
    report = Report(
        name=name, file_format=img.format, shape=[H, W, C], best=best, alternatives=alternatives,
        channels=img.channels, active=active, storage=storage, step=step, transfer=img.transfer,
        max_error=float(np.nanmax(absr)), mean_error=float(np.nanmean(absr)),
        worst={"row": int(ri[worst[0]]), "column": int(ci[worst[1]]), "channel": img.channels[active[worst[2]]]},
        checked=[len(ri), len(ci)], mu_clamp=clamp, mu_clamp_note=clamp_note,
        error_map=np.nanmax(absr, axis=-1), rows_checked=ri, cols_checked=ci,
        constants={img.channels[c]: float(np.nanmean(data[:, :, c])) for c in range(C) if c not in active},
    )
    worst_mu = mu_h.values(mu_n)[ri[worst[0]] if mu_rows else ci[worst[1]]]
    worst_alpha = ro_h.values(ro_n)[ci[worst[1]] if mu_rows else ri[worst[0]]]
    report.worst.update(mu=float(worst_mu), alpha=float(worst_alpha))
    _findings(report, best, resid, mu_rows, mu_vals, step, _claimed_axes(img, expect_axes), nan_note, data,
              infinite=img.infinite)
    if heatmap is not None:
        report.write_heatmap(heatmap)
    return report


def _alternatives(ranked: list[Hypothesis]) -> list[dict]:
    """The best hypothesis of each other model and of the swapped orientation (how clear the win is)."""
    out, seen = [], {(ranked[0].distribution, ranked[0].shadowing, ranked[0].rows.quantity)}
    for h in ranked[1:]:
        key = (h.distribution, h.shadowing, h.rows.quantity)
        if key in seen:
            continue
        seen.add(key)
        out.append({"distribution": h.distribution, "shadowing": h.shadowing,
                    "rows": _axis_label(h.rows), "mean_error": h.score})
    return out[:6]


def _findings(report: Report, best: Hypothesis, resid: np.ndarray, mu_rows: bool, mu_vals: np.ndarray,
              step: float, claimed, nan_note, report_data: np.ndarray, infinite: int = 0) -> None:
    f = report.findings
    if nan_note:
        f.append(nan_note)
    fit_findings(f, report_data, infinite, best.score,
                 "an albedo, split-sum or multiscatter table of GGX or Beckmann")
    if best.shadowing == "schlick":
        f.append("shadowing: Schlick-GGX G1 = x / (x (1 - k) + k) with k = alpha / 2 (Karis' UE4 notes, "
                 "learnopengl.com, Godot), an approximation of Smith GGX that loses up to 0.28 in E at grazing angles; "
                 "checked against the doctor's own quadrature of it")
    if best.encoding == "srgb-decoded":
        f.append("decoded as sRGB: the values are the sRGB decode of the table (an *_SRGB texture format, or a "
                 "PNG/KTX2 sRGB tag honoured by the loader); read the LUT as linear data")
    elif best.encoding == "srgb":
        f.append("stored sRGB-encoded: the values are the sRGB encode of the table; decode them "
                 "(or sample through an *_SRGB format) before use")
    elif report.transfer == "srgb":
        f.append("the file declares sRGB but holds linear values: a loader that honours the tag decodes the LUT as "
                 "sRGB; mark it linear (KTX2 transfer function linear, no PNG sRGB/gAMA chunk)")
    slot = lambda n: "rough" if n in ("roughness", "alpha") else n  # noqa: E731
    for k, (label, h) in enumerate((("rows", best.rows), ("columns", best.cols))):
        what = "Y flipped" if label == "rows" else "X flipped"
        # the file's own claim of the axis' order (Godot's roughness rows run high to low on purpose)
        c = claimed[k] if claimed and len(claimed) == 2 else {}
        order = c.get("order") if slot(str(c.get("name"))) == slot(_axis_label(h)) else None
        if order == "decreasing" and not h.reversed:
            f.append(f"{what}: the file says the {label} run from {c['name']} high to low, the data runs low to high")
        elif h.reversed and order != "decreasing":
            extra = " (equivalently x = 1 - mu)" if h.quantity == "mu" and h.spacing == "linear" else ""
            f.append(f"{what}: the {label} run from {_axis_label(h)} high to low{extra}")
        offset = NODE_TYPES[h.nodes][1]
        if offset:
            size = "half a texel" if abs(offset) == 0.5 else "one texel"
            f.append(f"grid shifted by {size} along the {label} ({_axis_label(h)}): node i sits at "
                     f"{NODE_FORMULA[h.nodes]}, the ends clamped")
    if claimed:
        found = [_axis_label(best.rows), _axis_label(best.cols)]
        names = [str(c["name"]) for c in claimed]
        if [slot(n) for n in names] == [slot(n) for n in found[::-1]] and slot(found[0]) != slot(found[1]):
            f.append(f"axes swapped: the file says [{', '.join(names)}], the data is [{', '.join(found)}]")
            claimed = claimed[::-1]
        for label, h, c in (("rows", best.rows, claimed[0]), ("columns", best.cols, claimed[1])):
            cname = str(c["name"])
            if h.quantity == "rough" and cname in ("roughness", "alpha") and cname != h.name:
                f.append(f"roughness mapped as {h.name}: the file says the {label} are {cname}, "
                         f"the data follows {h.coordinate}")
            if c.get("spacing") and slot(cname) == slot(_axis_label(h)) and c["spacing"] != h.spacing \
                    and not (h.quantity == "mu" and h.spacing in ("sqrt(1-mu)", "theta")):
                f.append(f"spacing: the file says {c['spacing']} {cname} along the {label}, the data is "
                         f"{h.coordinate}")
            if (c.get("nodes") and slot(cname) == slot(_axis_label(h)) and c["nodes"] != h.nodes
                    and not NODE_TYPES[h.nodes][1]):
                f.append(f"grid offset along the {label}: the file says {c['nodes']}, the data sits at {h.nodes} "
                         "(half a texel for centres against endpoints)")
    if report.mu_clamp is not None:
        f.append(f"clamped end: the mu = 0 node holds mu = {report.mu_clamp_note}")
    bits = _BITS.get(report.storage)
    if bits:
        f.append(f"stored at {bits} bits: quantization step 1/{2**bits - 1} = {step:.2g} (up to {step / 2:.2g} per texel)")
    elif report.storage == "float16":
        f.append("stored as float16: rounding up to 2.4e-4 for values in [0.5, 1)")
    # noise: texel-to-texel residual above the storage's share
    hf = np.sqrt(np.nanmean(np.stack([_hf(resid[:, :, k]) ** 2 for k in range(resid.shape[2])]), axis=0))
    floor = max(3.0 * _storage_rms(report.storage, step, report_data), 3e-6)
    rms = float(np.sqrt(np.nanmean(hf**2)))
    if rms > floor:
        graze = mu_vals < 0.25
        grazing = (hf[graze, :] if mu_rows else hf[:, graze]) if graze.any() else hf
        rest = (hf[~graze, :] if mu_rows else hf[:, ~graze]) if (~graze).any() else hf
        g_rms, r_rms = float(np.sqrt(np.nanmean(grazing**2))), float(np.sqrt(np.nanmean(rest**2)))
        report.noise = {"rms": rms, "grazing_rms": g_rms, "rest_rms": r_rms}
        if g_rms > 1.5 * r_rms:
            f.append(f"NDF-sampled noise at grazing angles: Monte Carlo noise (texel-to-texel rms {rms:.2g}) "
                     f"{g_rms / max(r_rms, 1e-12):.1f} x larger at mu < 0.25 than elsewhere, as an estimator "
                     "sampling the NDF rather than the visible normals gives")
        else:
            f.append(f"Monte Carlo noise: texel-to-texel residual rms {rms:.2g}, even over the table")
    drop_guesses(f)


def check_lut(path, *, shape=None, array_values: str = "float", expect_axes=None, heatmap=None,
              array_name: str | None = None):
    """Identify the LUT file ``path``: what it is, how well it matches, and what is wrong with it.

    Parameters
    ----------
    path : str or os.PathLike
        EXR, KTX2, DDS, PNG, ``.npy``, an ``npy-channels`` sidecar ``S.meta.json``, or a C/C++/JS
        array file (bsdf-tab's own ``.h`` needs no ``shape``).
    shape : tuple of int, optional
        The shape of an array file's numbers (``(32, 32)``, ``(16, 16, 2)``).
    array_values : str
        How an array file's numbers are read: ``float``, ``half``, ``unorm8``, ``unorm16``.
    expect_axes : list of str, optional
        The axis names the user believes the file has, its first axis first (``["mu", "roughness"]``,
        ``["ior", "mu", "roughness"]``); a bsdf-tab file's own axes are used when not given.
    heatmap : str or os.PathLike, optional
        Write a PNG heatmap of |file - best match| there.
    array_name : str, optional
        In an array file that initializes several arrays, the one to read (``brdf_ggx``).

    Returns
    -------
    Report, NDReport or ClaimReport
        ``report.to_dict()`` is the JSON report; ``report.text()`` the human one (an
        :class:`~bsdf_tab.doctor.ndcheck.NDReport` for 1-D averages and 3-D / averaged glass; a
        :class:`~bsdf_tab.doctor.claims.ClaimReport`, ``"fitted": false``, for a bsdf-tab file whose
        claimed table kind the doctor does not fit).

    Raises
    ------
    SpecError
        An unreadable file (``param`` ``lut``), a bad ``shape``, ``array_values``, ``array_name``
        or ``axes``.
    """
    from pathlib import Path

    img = read_lut(path, shape=shape, array_values=array_values, array_name=array_name)
    return check_image(img, expect_axes=expect_axes, heatmap=heatmap, name=Path(path).name)


def check_lut_bytes(data: bytes, name: str = "lut", *, shape=None, array_values: str = "float",
                    expect_axes=None, heatmap=None, array_name: str | None = None):
    """:func:`check_lut` on a file's bytes (``name`` for formats known by their name only)."""
    img = read_lut_bytes(data, name, shape=shape, array_values=array_values, array_name=array_name)
    return check_image(img, expect_axes=expect_axes, heatmap=heatmap, name=name)
