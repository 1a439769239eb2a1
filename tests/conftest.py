"""Session-wide hooks of the suite.

The PTX compile check (tests/integrate/test_integrate_cuda_compile.py) is ~100 s of NVRTC on one
core. Right after collection, the modules that the selected tests name (their ``ptx_module``
parameter) are handed to one background worker (tests/integrate/ptx_background.py, at a lower
priority), so the compiles overlap the rest of the suite on the core it leaves idle; those tests
run last and collect the results through the ``ptx_compiles`` fixture (bounded waits; a failed,
crashed or hung compile fails its own test with the compiler's message). The worker is killed by
its PID when the session ends.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parent / "integrate" / "ptx_background.py"
_NAME = "bsdf_tab_tests_ptx_background"  # loaded by path: not a package, no sys.path changes


def _load_background():
    module = sys.modules.get(_NAME)
    if module is None:
        spec = importlib.util.spec_from_file_location(_NAME, _PATH)
        module = importlib.util.module_from_spec(spec)
        sys.modules[_NAME] = module
        spec.loader.exec_module(module)
    return module


ptx_background_module = _load_background()
_JOB = pytest.StashKey()


def _ptx_items(items):
    return [it for it in items if "ptx_compiles" in getattr(it, "fixturenames", ())]


def pytest_collection_modifyitems(session, config, items):
    # the tests that wait for the background compiles go last, so the compiles have the whole
    # run to overlap (they depend on no other test and no other test on them)
    ptx = _ptx_items(items)
    if ptx:
        keep = [it for it in items if it not in ptx]
        items[:] = keep + ptx


def pytest_collection_finish(session):
    names = []
    for item in _ptx_items(session.items):
        name = getattr(getattr(item, "callspec", None), "params", {}).get("ptx_module")
        if name is not None and name not in names:
            names.append(name)
    if names and not session.config.option.collectonly:
        job = ptx_background_module.BackgroundCompiles(names)
        job.start()
        session.config.stash[_JOB] = job


def pytest_sessionfinish(session):
    job = session.config.stash.get(_JOB, None)
    if job is not None:
        job.stop()
        del session.config.stash[_JOB]


@pytest.fixture(scope="session")
def ptx_compiles(request):
    """The session's background PTX compiles (started here if collection did not start them)."""
    job = request.config.stash.get(_JOB, None)
    if job is None:
        job = ptx_background_module.BackgroundCompiles()
        request.config.stash[_JOB] = job
    return job


@pytest.fixture(scope="session")
def ptx_background():
    """The background-compile module itself (its own tests drive it with small modules)."""
    return ptx_background_module
