"""Service settings: environment variables ``BSDF_TAB_*`` with sensible defaults.

=============================  ==========================================  =====================
variable                       meaning                                     default
=============================  ==========================================  =====================
``BSDF_TAB_CACHE_DIR``         folder of the table cache (local disk)      ``$XDG_CACHE_HOME/bsdf-tab/service``
``BSDF_TAB_CACHE_MAX_BYTES``   size cap of the cache (LRU eviction)        1 GiB
``BSDF_TAB_MAX_TEXELS``        largest table served (more -> 413)          262144 (64^3)
``BSDF_TAB_MAX_BODY_BYTES``    largest POST body (more -> 413)             65536
``BSDF_TAB_MAX_CONCURRENT``    computations running at a time              1
``BSDF_TAB_MAX_CONCURRENT_JOBS``  jobs running at a time, in a lane of     1
                               their own (never in the slots above)
``BSDF_TAB_MAX_QUEUED``        distinct computations waiting (more -> 503)  32
``BSDF_TAB_WORKERS``           CPU threads of one computation              all cores
``BSDF_TAB_DEVICE``            Warp device (``cpu``, ``cuda:0``)           Warp's default
``BSDF_TAB_CACHE_MAX_AGE``     ``Cache-Control: max-age`` of tables (s)    31536000
``BSDF_TAB_WARMUP``            compile the Warp kernels at start-up        true
``BSDF_TAB_HOST`` / ``_PORT``  where ``bsdf-tab serve`` listens            127.0.0.1 / 8000
``BSDF_TAB_MAX_COST_SECONDS``  predicted core-seconds of a synchronous     60
                               request (more -> 413: use a job)
``BSDF_TAB_MAX_JOB_COST_SECONDS``  the same for ``POST /jobs``             86400
``BSDF_TAB_COST_SCALE``        multiplies the cost model (other hardware)  1.0
``BSDF_TAB_MAX_COMPUTE_SECONDS``  wall-clock limit of one synchronous      300
                               computation (then cancelled, 503)
``BSDF_TAB_JOB_MAX_SECONDS``   wall-clock limit of one job                 86400
``BSDF_TAB_MEMORY_CACHE_BYTES``  in-memory LRU of served entries           64 MiB
``BSDF_TAB_HEADER_TIMEOUT``    seconds to receive a request's headers      10
``BSDF_TAB_BODY_TIMEOUT``      seconds to receive a request's body (408)   30
``BSDF_TAB_SCHEDULER``         a Dask scheduler (``tcp://host:8786`` or     in-process threads
                               ``local:N``): tables, scenes and jobs are
                               computed there (503 naming it if it is
                               unreachable)
=============================  ==========================================  =====================
"""

from __future__ import annotations

import os
from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict

__all__ = ["Settings", "default_cache_dir"]


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/bsdf-tab/service`` (``~/.cache/bsdf-tab/service``)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "bsdf-tab" / "service"


class Settings(BaseSettings):
    """Settings of one service instance (see the module docstring for the variables)."""

    model_config = SettingsConfigDict(env_prefix="BSDF_TAB_", extra="ignore")

    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    cache_dir: Path = Field(default_factory=default_cache_dir)
    cache_max_bytes: int = Field(1 << 30, ge=0)
    max_texels: int = Field(64**3, ge=1)
    max_body_bytes: int = Field(64 * 1024, ge=64)
    max_concurrent: int = Field(1, ge=1)
    max_concurrent_jobs: int = Field(1, ge=1)
    max_queued: int = Field(32, ge=0)
    workers: int | None = Field(None, ge=1)
    device: str | None = None
    cache_max_age: int = Field(31536000, ge=0)
    warmup: bool = True
    max_cost_seconds: float = Field(60.0, gt=0)
    max_job_cost_seconds: float = Field(86400.0, gt=0)
    cost_scale: float = Field(1.0, gt=0)
    max_compute_seconds: float = Field(300.0, gt=0)
    job_max_seconds: float = Field(86400.0, gt=0)
    memory_cache_bytes: int = Field(64 << 20, ge=0)
    header_timeout: float = Field(10.0, gt=0)
    body_timeout: float = Field(30.0, gt=0)
    scheduler: str | None = None  # BSDF_TAB_SCHEDULER: computations go to this Dask cluster
