"""What the doctor's 2-D and N-D checks share: the mu clamps, the storage a file's values show,
its rounding rms, and the texel-to-texel part of a residual."""

from __future__ import annotations

import math

import numpy as np

from .readers import LutImage

__all__ = ["BITS", "MU_CLAMPS", "NO_FIT", "drop_guesses", "fit_findings", "high_frequency", "out_of_unit", "quantization",
           "storage_rms"]

#: Candidate clamps of the mu = 0 end (the search tries each): value -> where it comes from.
MU_CLAMPS = {1e-4: "1e-4 (the clamp of Cycles and EEVEE)", math.cos(1.57): "cos(1.57) = 7.96e-4 (theta clamped to 1.57)",
             1e-3: "1e-3", 1e-2: "1e-2"}
BITS = {"unorm8": 8, "unorm10": 10, "unorm16": 16}


def quantization(img: LutImage, data: np.ndarray) -> tuple[str, float]:
    """The storage (``unorm8`` ...) and its step, from the file or from the values' grid."""
    if img.storage in BITS:
        return img.storage, 1.0 / (2 ** BITS[img.storage] - 1)
    finite = data[np.isfinite(data)]
    for name, bits in BITS.items():
        scale = 2**bits - 1
        if finite.size and np.abs(finite * scale - np.round(finite * scale)).max() < 1e-3 and img.storage != "float16":
            return name, 1.0 / scale
    if img.storage == "float16" or (finite.size and np.array_equal(finite.astype(np.float16).astype(np.float64), finite)):
        return "float16", 0.0
    return img.storage, 0.0


def storage_rms(storage: str, step: float, data: np.ndarray) -> float:
    """The rms rounding error the storage alone puts in the texels (uniform rounding: step / sqrt(12))."""
    if storage == "float16":
        finite = data[np.isfinite(data)]
        ulp = np.spacing(np.abs(finite).astype(np.float16)).astype(np.float64)
        return float(np.sqrt(np.mean(ulp**2) / 12.0)) if finite.size else 0.0
    return step / math.sqrt(12.0)


def high_frequency(r: np.ndarray) -> np.ndarray:
    """Residual minus the mean of its neighbours (the 8 of a 2-D texel, the 2 per axis otherwise):
    the texel-to-texel part."""
    pad = np.pad(r, 1, mode="edge")
    if r.ndim == 2:
        H, W = r.shape
        acc = sum(pad[1 + dy:1 + dy + H, 1 + dx:1 + dx + W] for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx)
        return r - acc / 8.0
    acc = np.zeros_like(r)
    for ax in range(r.ndim):
        for d in (0, 2):
            sl = [slice(1, 1 + n) for n in r.shape]
            sl[ax] = slice(d, d + r.shape[ax])
            acc = acc + pad[tuple(sl)]
    return r - acc / (2 * r.ndim)


#: the best mean screening error above which no candidate is taken to fit
NO_FIT = 0.02
_KEPT_WITHOUT_FIT = ("no candidate fits well", "stored at", "stored as float16", "left out: ", "values outside [0, 1]")
#: how far outside [0, 1] a value may lie (noise, rounding) before it is no energy
UNIT_SLACK = 0.05


def fit_findings(findings: list, data: np.ndarray, infinite: int, score: float, what: str) -> None:
    """Append the values-outside-[0, 1] finding and, when no candidate fits (mean error above 0.02, or
    values far outside), the line saying so; ``what`` names the kinds the doctor tried."""
    outside, decisive = out_of_unit(data, infinite)
    if outside:
        findings.append(outside)
    if score > 0.02 or decisive:
        findings.append(f"no candidate fits well (best mean error {score:.3g}"
                        f"{'; values far outside [0, 1]' if decisive else ''}): this may not be {what}")


def out_of_unit(data: np.ndarray, infinite: int = 0) -> tuple[str | None, bool]:
    """Every kind the doctor fits (albedos, split-sum terms, R and T, their complements) lies in
    [0, 1]. Returns (the finding on values outside it, or None; whether they rule every candidate
    out: over 1 % of the values). ``infinite``: texels that were infinite (already NaN in
    ``data``), counted as outside."""
    finite = data[np.isfinite(data)]
    bad = (finite < -UNIT_SLACK) | (finite > 1.0 + UNIT_SLACK)
    n, total = int(bad.sum()) + infinite, finite.size + infinite
    if not n:
        return None, False
    lo = float(finite.min()) if finite.size else math.nan
    hi = math.inf if infinite else float(finite.max()) if finite.size else math.nan
    decisive = n > 0.01 * total
    text = (f"values outside [0, 1]: {n} of {total} (from {lo:.4g} to {hi:.4g}), where every table kind the "
            "doctor fits (albedos, split-sum terms, R and T) lies in [0, 1]")
    return text, decisive


def drop_guesses(findings: list) -> None:
    """When no candidate fits, keep only what does not depend on the fit (the storage, NaN texels):
    flips, shifts, encodings and noise of a table of another kind would be guesses."""
    if not any(x.startswith("no candidate fits well") for x in findings):
        return
    kept = [x for x in findings if x.startswith(_KEPT_WITHOUT_FIT) or "NaN" in x]
    if len(kept) < len(findings):
        kept.append(f"left out: {len(findings) - len(kept)} findings about axes, encoding and noise, which "
                    "would describe the closest candidate rather than this table")
    findings[:] = kept
