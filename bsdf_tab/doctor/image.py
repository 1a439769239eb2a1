"""The image every LUT reader returns (:class:`LutImage`), the sRGB curves, the reader's error."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SpecError

__all__ = ["LutImage", "LutReadError", "as_image", "srgb_decode", "srgb_encode"]


@dataclass
class LutImage:
    """A LUT as read from a file."""

    data: np.ndarray  # (height, width, channels) float64
    format: str
    channels: list[str]
    storage: str = "float32"
    transfer: str | None = None  # what the file declares: "linear", "srgb" or None
    claims: dict = field(default_factory=dict)  # bsdf-tab metadata: axes, spec, meta
    infinite: int = 0  # infinite texels the doctor set to NaN before fitting (they count as out of range)


def srgb_decode(v: np.ndarray) -> np.ndarray:
    """The sRGB electro-optical transfer function (IEC 61966-2-1): encoded -> linear."""
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def srgb_encode(v: np.ndarray) -> np.ndarray:
    """The inverse of :func:`srgb_decode`: linear -> encoded."""
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1.0 / 2.4) - 0.055)


class LutReadError(SpecError):
    """A file that cannot be read as a LUT (``param`` is ``lut``)."""

    def __init__(self, message: str, param: str = "lut"):
        super().__init__(param, message)

    def __reduce__(self):
        return (type(self), (self.message, self.param))


def as_image(a: np.ndarray, fmt: str, names=None, channels_last: bool = False, **kw) -> LutImage:
    """Shape the values as (axes..., channels): 1-D (n,) -> (n, 1); 2-D (h, w) -> (h, w, 1) and
    (h, w, c <= 4) as is; 3-D (d, h, w) with w > 4 -> (d, h, w, 1) and (d, h, w, c <= 4) as is.
    ``channels_last``: the last index is the channel whatever its size (a texture's components:
    a 1-D texture is (n, c), a 2-D one (h, w, c))."""
    a = np.asarray(a, dtype=np.float64)
    if channels_last:
        if not 2 <= a.ndim <= 4:
            raise LutReadError(f"cannot read a {a.ndim - 1}-D texture as a LUT; expected 1 to 3 axes")
    elif a.ndim == 1:
        a = a[:, None]
    elif a.ndim == 2:
        a = a[:, :, None]
    elif a.ndim == 3 and a.shape[2] > 4:
        a = a[..., None]
    elif a.ndim == 4 and a.shape[3] > 4:
        raise LutReadError(f"a {a.shape} array has more than 4 channels (give (depth, height, width[, channels <= 4]))")
    elif a.ndim > 4:
        raise LutReadError(f"cannot read a {a.ndim}-D array as a LUT; expected 1 to 3 axes and up to 4 channels")
    names = list(names) if names else [str(i) for i in range(a.shape[-1])]
    return LutImage(a, fmt, names, **kw)


# ----------------------------------------------------------------------------- PNG
