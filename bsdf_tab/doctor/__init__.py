"""The LUT doctor: identify a lookup table someone has, and say what is wrong with it.

``docs/lut-doctor.md`` describes the method and the report::

    from bsdf_tab.doctor import check_lut
    report = check_lut("dfg.png")                # EXR, KTX2, DDS, PNG, .npy, C/C++/JS arrays
    report.to_dict()["table"], report.findings   # 'dfg', ['decoded as sRGB: ...']

Modules: :mod:`.readers` (the file formats, from their specifications), :mod:`.exact` (exact
candidate tables, baked through :func:`bsdf_tab.api.tabulate` and cached), :mod:`.schlick`
(the Schlick-GGX candidate, by the doctor's own quadrature), :mod:`.fit` (the 2-D hypotheses and
the search), :mod:`.check` (the exact check, the findings), :mod:`.report`; for 1-D averages and
3-D glass tables :mod:`.glass` (candidates), :mod:`.nd` (hypotheses, search), :mod:`.ndcheck`
(check, findings, :class:`NDReport`); :mod:`.storage` (what both share); :mod:`.claims` (what a
bsdf-tab file claims to be, and :class:`ClaimReport` for claimed kinds the doctor does not fit).
The command line is ``bsdf-tab check`` (:mod:`bsdf_tab.cli.check`), the service ``POST /check``.
"""

from __future__ import annotations

from .check import MU_CLAMPS, check_image, check_lut, check_lut_bytes
from .claims import FITTED_KINDS, ClaimReport, claimed_kind
from .exact import CACHE_ENV, MODELS, cache_dir
from .readers import ARRAY_VALUES, LutImage, LutReadError, read_lut, read_lut_bytes, srgb_decode, srgb_encode
from .ndcheck import NDReport
from .report import Report, table_kind

__all__ = ["ARRAY_VALUES", "CACHE_ENV", "ClaimReport", "FITTED_KINDS", "LutImage", "LutReadError", "MODELS", "MU_CLAMPS", "NDReport", "Report", "cache_dir",
           "check_image", "check_lut", "check_lut_bytes", "claimed_kind", "read_lut", "read_lut_bytes", "srgb_decode", "srgb_encode",
           "table_kind"]
