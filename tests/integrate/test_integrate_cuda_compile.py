"""Every module with kernels compiles for CUDA, also on a machine without a GPU.

The warp-lang wheel ships NVRTC: ``wp.compile_aot_module(..., arch=90, use_ptx=True)`` generates
the CUDA source of a module and compiles it to PTX for sm_90 without a driver. Code that only
compiles for the CPU (a construct NVRTC rejects) fails here instead of on the first GPU run.
The model is compiled through the kernels that use it. Each module compiles once (seconds to
half a minute), in a background process started at collection (tests/conftest.py) so that the
compiles overlap the rest of the suite; these tests run last and collect the results.
"""

import importlib
import re
from pathlib import Path

import pytest
import warp as wp

from bench.cuda_prebuild import kernel_modules

# every module of the package that defines a kernel (found in the source, so that a new kernel
# module is checked without editing this list; the rule bench/cuda_prebuild.py fills a GPU
# machine's kernel cache with); the model is compiled through them
KERNEL_MODULES = kernel_modules()
EXPECTED = {
    "bsdf_tab.integrate.adaptive",
    "bsdf_tab.integrate.grid",
    "bsdf_tab.integrate.montecarlo",
    "bsdf_tab.integrate.vndf_gl",
    "bsdf_tab.tables.bsdf",  # the bsdf table kernel (tables layer: imported, not owned here)
}


def test_the_known_kernel_modules_are_found():
    assert EXPECTED <= set(KERNEL_MODULES), KERNEL_MODULES


@pytest.mark.parametrize("ptx_module", KERNEL_MODULES)
def test_module_compiles_to_ptx(ptx_module, ptx_compiles, ptx_background):
    module = importlib.import_module(ptx_module)
    assert wp.get_module(ptx_module).kernels, f"{ptx_module} registers no kernels"
    # compiled by the session's background worker (tests/conftest.py), the same call in another
    # process: wp.compile_aot_module(module, arch=90, use_ptx=True, module_dir=...)
    result = ptx_compiles.result(module.__name__)
    assert result["ok"], ptx_background.failure_message(ptx_module, result)
    ptx = [Path(p) for p in result["paths"] if str(p).endswith(".ptx")]
    assert ptx, result["paths"]
    text = ptx[0].read_text()
    assert ".target sm_90" in text and ".entry" in text
    # forward kernels only: nothing of the package is differentiated, and adjoint code would
    # triple the compile (measured: 159 -> 54 CPU-s of PTX over the package's modules)
    entries = re.findall(r"\.entry\s+(\w+)", text)
    assert entries and not [e for e in entries if e.endswith("_backward")], entries


@pytest.mark.parametrize("module_name", KERNEL_MODULES)
def test_kernel_modules_generate_no_adjoint_code(module_name):
    # the option that keeps the CPU compile of an empty kernel cache at a third (106 -> 34 CPU-s)
    importlib.import_module(module_name)
    assert wp.get_module(module_name).options["enable_backward"] is False
