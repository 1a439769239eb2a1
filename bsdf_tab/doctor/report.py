"""The doctor's report: the best match, its error and where, the findings; JSON, text and a heatmap."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .fit import NODE_TYPES, AxisHyp, Hypothesis

__all__ = ["MEANING_TEXT", "Report", "table_kind"]

MEANING_TEXT = {
    "E": "directional albedo E (F = 1)",
    "1-E": "energy complement 1 - E",
    "A": "split-sum scale A: specular = f0 A + B",
    "B": "split-sum bias B",
}


def table_kind(meanings) -> str:
    """The table a set of channel meanings makes (``albedo``, ``dfg``, ``dfg_multiscatter``, ...)."""
    s = set(meanings)
    if s == {"E"}:
        return "albedo"
    if s == {"1-E"}:
        return "albedo_complement"
    if s == {"A", "B"}:
        return "dfg"
    if s == {"B", "E"}:
        return "dfg_multiscatter"
    if s == {"A"} or s == {"B"}:
        return "dfg"
    return "mixed"


@dataclass
class Report:
    """What :func:`bsdf_tab.doctor.check_lut` found (``to_dict()`` is the ``--json`` object)."""

    name: str
    file_format: str
    shape: list
    best: Hypothesis
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
    mu_clamp_note: str | None
    error_map: np.ndarray
    rows_checked: np.ndarray
    cols_checked: np.ndarray
    constants: dict
    findings: list = field(default_factory=list)
    noise: dict | None = None

    def _axis(self, label: str, h: AxisHyp, n: int) -> dict:
        values = h.axis_values(n)
        if h.quantity == "mu" and self.mu_clamp is not None:
            mu_c = self.mu_clamp
            values = np.where(values < 1e-9, mu_c, values)
        offset = NODE_TYPES[h.nodes][1]
        return {
            "file_axis": label,
            "name": "mu" if h.quantity == "mu" else h.name,
            "size": n,
            "spacing": h.spacing,
            "coordinate": h.coordinate,
            "nodes": h.nodes,
            "offset_texels": offset or 0.0,
            "range": [float(values.min()), float(values.max())],
            "reversed": bool(h.reversed),
            "clamp": self.mu_clamp if h.quantity == "mu" else None,  # node values held at >= clamp
        }

    def to_dict(self) -> dict:
        """The report as one JSON-serializable object."""
        b = self.best
        H, W = self.shape[0], self.shape[1]
        chans = {self.channels[c]: m for c, m in zip(self.active, b.meanings)}
        for name, value in self.constants.items():
            chans[name] = f"constant {value:.6g}"
        return {
            "file": self.name,
            "format": self.file_format,
            "shape": self.shape,
            "table": table_kind(b.meanings),
            "fitted": True,
            "distribution": b.distribution,
            "shadowing": b.shadowing,
            "axes": [self._axis("rows", b.rows, H), self._axis("columns", b.cols, W)],
            "channels": chans,
            "channel_meanings": {k: MEANING_TEXT.get(v, v) for k, v in chans.items()},
            "encoding": b.encoding,
            "storage": self.storage,
            "declared_transfer": self.transfer,
            "max_error": self.max_error,
            "mean_error": self.mean_error,
            "max_error_at": self.worst,
            "screening_error": b.score,
            "checked_texels": {"rows": self.checked[0], "columns": self.checked[1],
                               "against": "the best match baked exactly at the file's nodes"},
            "noise": self.noise,
            "alternatives": self.alternatives,
            "findings": list(self.findings),
        }

    def text(self) -> str:
        """The report for a terminal."""
        d = self.to_dict()
        lines = [f"{d['file']}: {d['format']} {' x '.join(str(s) for s in d['shape'])}",
                 f"  best match: {d['table']}, {d['distribution']}, {d['shadowing']} shadowing, "
                 f"{d['encoding']} values, stored {d['storage']}"]
        for a in d["axes"]:
            rev = ", reversed" if a["reversed"] else ""
            clamp = f", clamped at {a['clamp']:.3g}" if a["clamp"] else ""
            lines.append(f"  {a['file_axis']:<8} {a['name']}: {a['coordinate']}, {a['nodes']} nodes, "
                         f"range [{a['range'][0]:.4g}, {a['range'][1]:.4g}]{rev}{clamp}")
        for ch, m in d["channel_meanings"].items():
            lines.append(f"  channel {ch}: {m}")
        w = d["max_error_at"]
        lines.append(f"  max error {d['max_error']:.3g} at row {w['row']}, column {w['column']} (channel {w['channel']}, "
                     f"mu {w['mu']:.4g}, alpha {w['alpha']:.4g}); mean error {d['mean_error']:.3g} "
                     f"over {self.checked[0]} x {self.checked[1]} texels checked exactly")
        if d["alternatives"]:
            alt = "; ".join(f"{a['distribution']} {a['shadowing']} (rows {a['rows']}) {a['mean_error']:.3g}"
                            for a in d["alternatives"][:3])
            lines.append(f"  next best: {alt}")
        if d["findings"]:
            lines.append("  findings:")
            lines += [f"  - {x}" for x in d["findings"]]
        else:
            lines.append("  findings: none")
        return "\n".join(lines)

    def write_heatmap(self, path) -> None:
        """A PNG of |file - best match| over the texels checked (rows down, as in the file)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        d = self.to_dict()
        fig, ax = plt.subplots(figsize=(5.2, 4.2), dpi=100)
        err = np.maximum(self.error_map, 1e-9)
        im = ax.imshow(np.log10(err), origin="upper", aspect="auto", cmap="magma",
                       extent=(-0.5, self.shape[1] - 0.5, self.shape[0] - 0.5, -0.5), interpolation="nearest")
        fig.colorbar(im, ax=ax, label="log10 |file - best match|")
        ax.set_xlabel(f"column ({d['axes'][1]['name']}: {d['axes'][1]['coordinate']})")
        ax.set_ylabel(f"row ({d['axes'][0]['name']}: {d['axes'][0]['coordinate']})")
        ax.set_title(f"{self.name}: {d['table']} {d['distribution']} {d['shadowing']}\n"
                     f"max {self.max_error:.2g}, mean {self.mean_error:.2g}", fontsize=9)
        fig.tight_layout()
        from ..io import atomic_path

        with atomic_path(path) as tmp:
            fig.savefig(str(tmp), format="png")
        plt.close(fig)
