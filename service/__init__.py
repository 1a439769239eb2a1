"""bsdf-tab HTTP service: tables on request, computed once, cached.

Run it with ``bsdf-tab serve`` or ``uvicorn service.app:app``. The package
imports nothing heavy at import time (the CLI registers ``serve`` through
:mod:`service.cli`); the app lives in :mod:`service.app`.
"""
