"""Exceptions raised by bsdf-tab.

The one error type users meet most is :class:`SpecError`: a table spec that
cannot be computed as written. It names the offending parameter with a dotted
path (``"axes.mu"``, ``"fresnel.eta"``) so that the CLI, the HTTP service and
Python callers can all point at the exact place to fix.
"""

from __future__ import annotations

__all__ = ["NonFiniteTableError", "SpecError", "TexelLimitError"]


class SpecError(ValueError):
    """An invalid table spec.

    Parameters
    ----------
    param : str or None
        Dotted path of the offending parameter, for example ``"axes.mu"``,
        ``"fresnel.eta"`` or ``"table"``; ``None`` when the spec as a whole
        is wrong (not a JSON object, bad JSON).
    message : str
        What is wrong and what is allowed, for example
        ``"must be one of albedo, albedo_avg, dfg"``.

    Examples
    --------
    >>> str(SpecError("fresnel.eta", "must be > 0"))
    'fresnel.eta: must be > 0'
    """

    def __init__(self, param: str | None, message: str) -> None:
        self.param = param
        self.message = message
        super().__init__(self.__str__())

    def __str__(self) -> str:
        if self.param is None:
            return self.message
        return f"{self.param}: {self.message}"

    def __reduce__(self):
        return (type(self), (self.param, self.message))


class TexelLimitError(SpecError):
    """A valid request whose table would exceed a texel limit (the service answers 413).

    ``limit`` is the texel limit that was hit.
    """

    def __init__(self, param: str | None, message: str, limit: int | None = None) -> None:
        self.limit = limit
        super().__init__(param, message)

    def __reduce__(self):
        return (type(self), (self.param, self.message, self.limit))


class NonFiniteTableError(RuntimeError):
    """A computed table holds NaN or infinite values: an internal error, never bad input.

    :mod:`bsdf_tab.api` raises it instead of returning (or streaming to a writer) such a
    table; the CLI reports it as an internal error (exit code 1), the service as a 500.
    """
