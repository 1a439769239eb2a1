"""Attaching to a Dask cluster: a ``Client``, a scheduler address, or ``local:N``.

``local:N`` starts a ``LocalCluster`` of N worker processes with one thread each on this
machine; ``tcp://host:port`` (or any address Dask accepts) attaches to a running scheduler
within a few seconds or fails with one line. Dask is imported only here and only when a
scheduler is asked for: without one, bsdf-tab needs no Dask.
"""

from __future__ import annotations

import logging
import re

__all__ = ["SchedulerError", "close", "connect", "dashboard_link", "parse_scheduler"]

_LOCAL = re.compile(r"^local(?::(\d+))?$")
CONNECT_TIMEOUT = "5s"


class SchedulerError(ValueError):
    """The scheduler argument is malformed, unreachable, or Dask is not installed (one line)."""


def parse_scheduler(scheduler: str) -> tuple[str, int | None]:
    """``("local", N)`` for ``local:N`` (N >= 1), else ``("address", None)``.

    Raises
    ------
    SchedulerError
        For an empty string, ``local:0`` or a string that is neither form.
    """
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise SchedulerError(f"scheduler: expected an address like tcp://host:8786 or local:N, got {scheduler!r}")
    m = _LOCAL.match(scheduler.strip())
    if m:
        n = int(m.group(1) or 2)
        if n < 1:
            raise SchedulerError(f"scheduler: local:N needs N >= 1 worker processes, got {scheduler!r}")
        return "local", n
    if "://" not in scheduler and ":" not in scheduler:
        raise SchedulerError(f"scheduler: expected an address like tcp://host:8786 or local:N, got {scheduler!r}")
    return "address", None


def _distributed():
    try:
        import distributed
    except ImportError:  # the optional dependency: pip install 'bsdf-tab[cluster]'
        raise SchedulerError("a scheduler needs Dask: pip install 'dask[distributed]'") from None
    return distributed


def connect(scheduler, *, warp_cache: str | None = None):
    """A ``distributed.Client`` for ``scheduler`` with the bsdf-tab worker plugin registered.

    Parameters
    ----------
    scheduler : distributed.Client or str
        A client (used as is), a scheduler address (``tcp://host:8786``) or ``local:N``.
    warp_cache : str, optional
        Warp kernel cache folder for the workers (``WARP_CACHE_PATH``); default: the workers'.

    Returns
    -------
    (client, owned) : (distributed.Client, bool)
        ``owned`` is True when this call created the client (and a local cluster): the
        caller closes it with :func:`close`.

    Raises
    ------
    SchedulerError
        If the address is malformed or no scheduler answers within a few seconds.
    """
    distributed = _distributed()
    from .worker import WarpWorker

    if isinstance(scheduler, distributed.Client):
        client, owned = scheduler, False
    else:
        kind, n = parse_scheduler(scheduler)
        if kind == "local":
            cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                               dashboard_address=":0", host="127.0.0.1",
                                               silence_logs=logging.ERROR)
            client = distributed.Client(cluster)
        else:
            try:
                client = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT)
            except (OSError, TimeoutError) as exc:
                raise SchedulerError(f"scheduler {scheduler}: not reachable ({type(exc).__name__}: {exc})") from None
        owned = True
    client.register_plugin(WarpWorker(warp_cache), name="bsdf-tab-warp")
    return client, owned


def close(client) -> None:
    """Close a client made by :func:`connect` (and its local cluster, if any)."""
    cluster = getattr(client, "cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


def dashboard_link(client) -> str | None:
    """The scheduler's dashboard URL, if it serves one."""
    try:
        return client.dashboard_link
    except (AttributeError, KeyError, ValueError):  # no dashboard (bokeh missing, or disabled)
        return None
