"""bsdf-tab: microfacet BSDF lookup tables computed with NVIDIA Warp kernels.

Public API: :func:`tabulate`, :class:`Table`, :func:`read_exr`, :func:`normalize_spec`,
:class:`SpecError`. The Warp device functions live in :mod:`bsdf_tab.model`.
"""

__version__ = "0.1.0"
