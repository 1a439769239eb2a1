"""What a bsdf-tab file says it is (its ``bsdf_tab_*`` claims), and the report of a file whose
claimed table kind the doctor cannot fit.

The doctor fits albedo, albedo averages, split-sum (dfg) and GGX dielectric tables
(:data:`FITTED_KINDS`). A file whose claims name another kind (``bsdf``, ``kulla_conty``,
``ltc``, ``sheen_albedo``, ``albedo_aniso``, ...) or a model the candidates do not cover (an
albedo with a Fresnel other than 1, Beckmann glass) is not "identified" as the closest
candidate: :func:`check_claimed` reports the claimed kind and checks what can be checked without
a model (the shape against the claimed axes, the channels, the value ranges, NaN texels, the
storage's clipping), and says plainly that the values are not fitted.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .readers import LutImage, LutReadError
from .storage import BITS

__all__ = ["FITTED_KINDS", "ClaimReport", "axis_orders", "check_claimed", "claimed_kind"]

#: the table kinds (``spec["table"]``) the doctor fits, and the models it has candidates for
FITTED_KINDS = {
    "albedo": ("ggx", "beckmann"),
    "albedo_avg": ("ggx", "beckmann"),
    "dfg": ("ggx", "beckmann"),
    "dielectric": ("ggx",),
    "dielectric_avg": ("ggx",),
}
#: what the doctor reports as ``table`` for each claimed kind it fits
IDENTIFIED_AS = {"albedo": ("albedo",), "albedo_avg": ("albedo_avg",), "dfg": ("dfg",),
                 "dielectric": ("dielectric",), "dielectric_avg": ("dielectric_avg",)}
FITTED_TEXT = "albedo, albedo_avg, dfg (and its multiscatter form), and GGX dielectric / dielectric_avg tables"

#: channels whose values lie in [0, 1] (energies, albedos), and channels that are >= 0
UNIT_CHANNELS = {"E", "E_avg", "R", "T", "R_avg", "T_avg", "A", "B", "horizon"}
NONNEG_CHANNELS = {"f_r", "f_t", "C", "fit_l1", "fit_l1_clipped", "magnitude", "magnitude_fresnel"}
RANGE_TOL = 1e-3
#: a clamp error (the writer's ``meta["storage"]["channels"][X]["clamp_error"]``) worth naming: not
#: the rounding of a value that is 1 up to float64's last digit
CLAMP_NOTED = 1e-6


def _spec(claims: dict) -> dict:
    spec = claims.get("spec") if isinstance(claims, dict) else None
    if isinstance(spec, dict):
        return spec
    meta = claims.get("meta") if isinstance(claims, dict) else None
    return meta.get("spec") if isinstance(meta, dict) and isinstance(meta.get("spec"), dict) else {}


def claimed_kind(claims: dict) -> dict | None:
    """The table kind a bsdf-tab file's claims name, and whether the doctor fits it.

    Returns None for a file without claims (a foreign file), else ``{"table", "preset",
    "distribution", "shadowing", "fresnel", "fitted", "why"}``: ``fitted`` False with ``why``
    for a kind (or a model) the doctor has no candidate for. A preset's kind is its sources'.
    """
    spec = _spec(claims)
    meta = claims.get("meta") if isinstance(claims, dict) and isinstance(claims.get("meta"), dict) else {}
    table = spec.get("table") if isinstance(spec.get("table"), str) else None
    if table is None and isinstance(meta.get("table"), str) and not meta.get("preset"):
        table = meta["table"]
    if table is None:
        return None
    preset, sources = None, [spec]
    if table.startswith("preset:"):
        preset = table[len("preset:"):]
        sources = [s for s in spec.get("sources", []) if isinstance(s, dict) and isinstance(s.get("table"), str)]
        if not sources:
            return {"table": table, "preset": preset, "distribution": None, "shadowing": None, "fresnel": None,
                    "fitted": False, "why": f"the preset {preset!r} names no source table"}
    kinds = list(dict.fromkeys(s["table"] for s in sources))
    first = sources[0]
    out = {"table": kinds[0] if len(kinds) == 1 else "+".join(kinds), "preset": preset,
           "distribution": first.get("distribution"), "shadowing": first.get("shadowing"),
           "fresnel": first.get("fresnel"), "fitted": True, "why": None}
    for s in sources:
        kind = s["table"]
        if kind not in FITTED_KINDS:
            out.update(fitted=False, why=f"the doctor has no candidate for `{kind}` tables (it fits {FITTED_TEXT})")
            break
        dist = s.get("distribution")
        if dist is not None and dist not in FITTED_KINDS[kind]:
            out.update(fitted=False, why=f"the doctor has no {dist} candidate for `{kind}` tables "
                                         f"(only {', '.join(FITTED_KINDS[kind])})")
            break
        fresnel = s.get("fresnel")
        ftype = fresnel.get("type") if isinstance(fresnel, dict) else fresnel
        if kind in ("albedo", "albedo_avg") and ftype not in (None, "one"):
            out.update(fitted=False, why=f"the doctor's `{kind}` candidates have F = 1, the file's Fresnel is {ftype}")
            break
    return out


def identified_as(claim: dict) -> tuple | None:
    """The ``table`` values of the doctor's report that agree with a fitted claim (None: a preset,
    whose textures rearrange their sources' channels, is not compared)."""
    if claim is None or not claim["fitted"] or claim["preset"]:
        return None
    return IDENTIFIED_AS.get(claim["table"])


def _claimed_axis_list(claims: dict) -> list | None:
    axes = claims.get("axes") if isinstance(claims, dict) else None
    if isinstance(axes, dict):
        axes = [[name, values] for name, values in axes.items()]
    if not isinstance(axes, list) or not all(isinstance(a, (list, tuple)) and len(a) == 2 for a in axes):
        return None
    out = []
    for name, values in axes:
        try:
            v = np.asarray(values, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            return None
        out.append((str(name), v))
    return out


def axis_orders(claims: dict, shape) -> list | None:
    """Per file axis, ``(name, "increasing" | "decreasing" | None)`` as the claimed axis values
    run (Godot's roughness rows run high to low on purpose), or None without usable claims."""
    axes = _claimed_axis_list(claims)
    if axes is None or len(axes) != len(shape):
        return None
    out = []
    for (name, v), n in zip(axes, shape):
        order = None
        if v.size == n and n > 1 and np.isfinite(v).all():
            d = np.diff(v)
            order = "increasing" if (d > 0).all() else "decreasing" if (d < 0).all() else None
        out.append((name, order))
    return out


@dataclass
class ClaimReport:
    """The report on a file whose claimed table kind the doctor does not fit (``fitted`` False)."""

    name: str
    file_format: str
    shape: list
    claim: dict
    axes: list
    channels: dict
    values: dict
    storage: str
    transfer: str | None
    checked: list
    findings: list = field(default_factory=list)
    data: np.ndarray | None = None

    def to_dict(self) -> dict:
        c = self.claim
        return {
            "file": self.name, "format": self.file_format, "shape": self.shape,
            "table": c["table"], "fitted": False, "preset": c["preset"],
            "distribution": None, "shadowing": None, "encoding": None,
            "claimed": {"table": c["table"], "preset": c["preset"], "distribution": c["distribution"],
                        "shadowing": c["shadowing"], "fresnel": c["fresnel"]},
            "not_fitted": c["why"],
            "axes": self.axes, "channels": self.channels, "values": self.values,
            "storage": self.storage, "declared_transfer": self.transfer,
            "max_error": None, "mean_error": None, "checked": list(self.checked),
            "findings": list(self.findings),
        }

    def text(self) -> str:
        d = self.to_dict()
        c = d["claimed"]
        preset = f" (preset {c['preset']})" if c["preset"] else ""
        model = ", ".join(str(x) for x in (c["distribution"], c["shadowing"] and f"{c['shadowing']} shadowing") if x)
        lines = [f"{d['file']}: {d['format']} {' x '.join(str(s) for s in d['shape'])}",
                 f"  claimed: {d['table']}{preset}{', ' + model if model else ''}; stored {d['storage']}; "
                 "NOT FITTED (a kind the doctor has no candidate for)"]
        for a in d["axes"]:
            rng = f", range [{a['range'][0]:.4g}, {a['range'][1]:.4g}]" if a["range"] else ""
            order = ", decreasing" if a["reversed"] else ""
            lines.append(f"  {a['file_axis']:<8} {a['name']}: {a['size']} nodes{rng}{order} (as the file claims)")
        for ch, meaning in d["channels"].items():
            v = d["values"].get(ch)
            rng = (f", values {v['min']:.4g} .. {v['max']:.4g}"
                   if v and v["min"] is not None and not meaning.startswith("padding") else "")
            lines.append(f"  channel {ch}: {meaning}{rng}")
        lines += [f"  checked: {x}" for x in d["checked"]]
        lines.append("  findings:" if d["findings"] else "  findings: none")
        lines += [f"  - {x}" for x in d["findings"]]
        return "\n".join(lines)

    def write_heatmap(self, path) -> None:
        """A PNG of the file's values (not an error map: nothing was fitted), first channel, in the
        file's image layout (3-D: the axis-0 slices stacked vertically; 1-D: a line)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        v = self.data[..., 0] if self.data is not None else np.zeros((1, 1))
        fig, ax = plt.subplots(figsize=(5.2, 4.2), dpi=100)
        if v.ndim == 1:
            ax.plot(v, "o-")
            ax.set_xlabel("index")
        else:
            img = v.reshape(-1, v.shape[-1])
            im = ax.imshow(img, origin="upper", aspect="auto", cmap="viridis", interpolation="nearest")
            fig.colorbar(im, ax=ax, label=f"channel {next(iter(self.channels), '0')} (file values)")
        ax.set_title(f"{self.name}: claimed {self.claim['table']}\nvalues, not fitted (no error map)", fontsize=9)
        fig.tight_layout()
        from ..io import atomic_path

        with atomic_path(path) as tmp:
            fig.savefig(str(tmp), format="png")
        plt.close(fig)


AXIS_LABELS = {1: ("axis",), 2: ("rows", "columns"), 3: ("slices", "rows", "columns")}


def check_claimed(img: LutImage, claim: dict, *, expect_axes=None, heatmap=None, name: str = "lut") -> ClaimReport:
    """Report on ``img``, whose claims name a table kind the doctor does not fit (``claim`` from
    :func:`claimed_kind`): the claimed kind, and the checks that need no model."""
    data = img.data
    shape = list(data.shape[:-1])
    ndim, nch = len(shape), data.shape[-1]
    if ndim not in AXIS_LABELS:
        raise LutReadError(f"cannot read a {ndim}-D array as a LUT; expected 1 to 3 axes")
    if expect_axes is not None and len(expect_axes) != ndim:
        raise LutReadError(f"give {ndim} axis names for this {ndim}-D LUT, got {len(expect_axes)} "
                           f"({', '.join(map(str, expect_axes))})", "axes")
    findings, checked = [], []
    claims = img.claims
    spec_axes = _spec(claims).get("axes") if isinstance(_spec(claims).get("axes"), dict) else {}
    # ---- the shape against the claimed axes
    axes_claim = _claimed_axis_list(claims)
    axes = []
    if axes_claim is None:
        checked.append("no axes claimed: the shape is not checked")
        axes = [{"file_axis": lab, "name": None, "size": n, "spacing": None, "nodes": None, "range": None,
                 "reversed": False, "clamp": None} for lab, n in zip(AXIS_LABELS[ndim], shape)]
    else:
        sizes = [v.size for _, v in axes_claim]
        desc = ", ".join(f"{n} ({s})" for (n, _), s in zip(axes_claim, sizes))
        if sizes == shape:
            checked.append(f"shape: {' x '.join(map(str, shape))} texels, as the claimed axes {desc}")
        elif int(np.prod(sizes)) == int(np.prod(shape)):
            findings.append(f"shape: the file holds {' x '.join(map(str, shape))} texels where its claimed axes {desc} "
                            "give the same number in another layout: read as laid out, not as claimed")
        else:
            findings.append(f"shape: the file holds {' x '.join(map(str, shape))} texels; its claimed axes {desc} "
                            f"give {int(np.prod(sizes))}")
        for (aname, v) in axes_claim:
            sa = spec_axes.get(aname) if isinstance(spec_axes.get(aname), dict) else {}
            if isinstance(sa.get("size"), int) and sa["size"] != v.size:
                findings.append(f"axis {aname}: the spec says {sa['size']} nodes, the file's axis values are {v.size}")
            if not np.isfinite(v).all():
                findings.append(f"axis {aname}: the claimed values are not all finite")
            elif v.size > 1 and not ((np.diff(v) > 0).all() or (np.diff(v) < 0).all()):
                findings.append(f"axis {aname}: the claimed values are not monotonic")
        if len(axes_claim) == ndim:
            for lab, (aname, v), n in zip(AXIS_LABELS[ndim], axes_claim, shape):
                sa = spec_axes.get(aname) if isinstance(spec_axes.get(aname), dict) else {}
                finite = v[np.isfinite(v)]
                axes.append({"file_axis": lab, "name": aname, "size": n, "spacing": sa.get("spacing"),
                             "nodes": sa.get("nodes"),
                             "range": [float(finite.min()), float(finite.max())] if finite.size else None,
                             "reversed": bool(v.size > 1 and (np.diff(v) < 0).all()), "clamp": sa.get("clamp")})
        else:
            axes = [{"file_axis": lab, "name": None, "size": n, "spacing": None, "nodes": None, "range": None,
                     "reversed": False, "clamp": None} for lab, n in zip(AXIS_LABELS[ndim], shape)]
    if expect_axes is not None and axes_claim is not None and len(axes_claim) == ndim:
        said = [str(n) for n, _ in axes_claim]
        if [str(x) for x in expect_axes] != said:
            findings.append(f"axes: you gave [{', '.join(map(str, expect_axes))}], the file says [{', '.join(said)}]")
    # ---- the channels
    names = claims.get("channels") if isinstance(claims.get("channels"), list) else None
    names = [str(n) for n in names if not str(n).endswith("_err")] if names else None
    channels, values = {}, {}
    flat = data.reshape(-1, nch)
    for k in range(nch):
        col = flat[:, k]
        finite = col[np.isfinite(col)]
        values[img.channels[k]] = {"min": float(finite.min()) if finite.size else None,
                                   "max": float(finite.max()) if finite.size else None,
                                   "mean": float(finite.mean()) if finite.size else None,
                                   "nonfinite": int(col.size - finite.size)}
    if names is None:
        checked.append("no channels claimed: the channels are not named")
        channels = {img.channels[k]: "not claimed" for k in range(nch)}
    else:
        for k in range(nch):
            ch = img.channels[k]
            if k < len(names):
                channels[ch] = names[k]
                continue
            v = values[ch]
            const = v["min"] is not None and v["max"] - v["min"] <= 1e-6
            channels[ch] = f"padding (constant {v['min']:.6g})" if const else "not claimed"
            if not const:
                findings.append(f"channel {ch}: the claims name {len(names)} channels, this extra one is not constant "
                                f"({v['min']:.4g} .. {v['max']:.4g})")
        if len(names) > nch:
            findings.append(f"channels: the claims name {len(names)} ({', '.join(names)}), the file stores {nch}")
        else:
            checked.append(f"channels: {', '.join(names)} in the first {len(names)} of {nch} stored")
    # ---- values: NaN, ranges, clipping
    nan, inf = int(np.isnan(data).sum()), int(np.isinf(data).sum())
    if nan:
        findings.append(f"{nan} texels are NaN")
    if inf:
        why = " (beyond float16's largest value, 65504: overflowed)" if img.storage == "float16" else ""
        findings.append(f"{inf} texels are infinite{why}")
    meta = claims.get("meta") if isinstance(claims.get("meta"), dict) else {}
    store = meta.get("storage") if isinstance(meta.get("storage"), dict) else {}
    per_channel = store.get("channels") if isinstance(store.get("channels"), dict) else {}
    bits = BITS.get(img.storage)
    for ch, meaning in channels.items():
        v = values[ch]
        if v["min"] is None or meaning.startswith(("padding", "not claimed")):
            continue
        if meaning in UNIT_CHANNELS and (v["min"] < -RANGE_TOL or v["max"] > 1 + RANGE_TOL):
            findings.append(f"channel {ch} ({meaning}): values {v['min']:.4g} .. {v['max']:.4g}, outside [0, 1] "
                            "where an energy lies")
        elif meaning in NONNEG_CHANNELS and v["min"] < -RANGE_TOL:
            findings.append(f"channel {ch} ({meaning}): negative values (down to {v['min']:.4g})")
        info = per_channel.get(meaning) if isinstance(per_channel.get(meaning), dict) else {}
        clamp = info.get("clamp_error")
        if isinstance(clamp, (int, float)) and clamp > CLAMP_NOTED:
            top = info.get("max")
            top_text = f" (the table's values reach {top:.4g})" if isinstance(top, (int, float)) else ""
            findings.append(f"clipped: channel {ch} ({meaning}) was clamped to the storage's range{top_text}; "
                            f"the file's metadata puts the clamp error at {clamp:.3g}")
        elif bits and meaning not in UNIT_CHANNELS:
            col = flat[:, list(channels).index(ch)]
            top = int((col >= 1.0).sum())
            if top:
                findings.append(f"channel {ch} ({meaning}): {top} texels at 1.0, the top of unorm{bits}: "
                                "values above 1 would be clipped there")
    checked.append("value ranges per channel (see values); no model: the values themselves are not checked")
    report = ClaimReport(name=name, file_format=img.format, shape=list(data.shape), claim=claim, axes=axes,
                         channels=channels, values=values, storage=img.storage, transfer=img.transfer,
                         checked=checked, data=data)
    report.findings = [f"not fitted: the file says it is a `{claim['table']}` table"
                       + (f" (preset {claim['preset']})" if claim["preset"] else "")
                       + f"; {claim['why']}: its values are not checked against a model"] + findings
    if heatmap is not None:
        report.write_heatmap(heatmap)
    return report
