"""Start-up: what a command imports before it needs it (checked in fresh interpreters through
``sys.modules``), the lazy re-exports of ``bsdf_tab``, the garbage collector paused while a
command's modules load, and the service's warm-up in turns."""

from __future__ import annotations

import gc
import json
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("warp", "bsdf_tab.spec", "bsdf_tab.tables", "bsdf_tab.integrate", "bsdf_tab.api")


def _modules_after(code: str) -> dict:
    """Run ``code`` in a fresh interpreter; the loaded modules among HEAVY and numpy, and
    whatever the code stored in ``out``."""
    script = "import sys\n" + textwrap.dedent(code) + textwrap.dedent(f"""
        import json, sys
        print(json.dumps({{"loaded": [m for m in {HEAVY + ("numpy",)!r} if m in sys.modules],
                          "out": globals().get("out")}}))
    """)
    proc = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_import_of_the_package_and_the_cli_loads_no_table_code():
    got = _modules_after("import bsdf_tab, bsdf_tab.cli")
    assert got["loaded"] == [], got


def test_help_loads_neither_warp_nor_numpy():
    got = _modules_after("""
        import contextlib, io
        from bsdf_tab.cli import main
        with contextlib.redirect_stdout(io.StringIO()) as buf:
            code = main(["--help"])
        out = [code, buf.getvalue()]
    """)
    code, text = got["out"]
    assert code == 0 and got["loaded"] == [], got
    # every subcommand is still listed, with its help line
    for name in ("bake", "info", "presets", "plan", "bench", "check", "serve"):
        assert f"    {name}" in text, text


def test_a_subcommand_help_configures_that_subcommand_only():
    got = _modules_after("""
        import contextlib, io
        from bsdf_tab.cli import main
        with contextlib.redirect_stdout(io.StringIO()) as buf:
            code = main(["plan", "--help"])
        out = [code, buf.getvalue(), "importlib.metadata" in sys.modules]
    """)
    code, text, scanned = got["out"]
    assert code == 0 and "--tol" in text and "warp" not in got["loaded"], got
    assert not scanned  # a built-in command skips the entry-point scan (plugins never replace one)


def test_build_parser_still_configures_every_subcommand():
    from bsdf_tab.cli import build_parser

    args = build_parser().parse_args(["bake", "spec.json", "--format", "npz", "-o", "x.npz"])
    assert args.format == "npz" and args.spec == "spec.json"
    args = build_parser().parse_args(["plan", "scene.json", "--tol", "1e-3"])
    assert args.tol == 1e-3


def test_lazy_re_exports_resolve_to_the_defining_modules():
    got = _modules_after("""
        import bsdf_tab
        before = "bsdf_tab.api" in sys.modules
        from bsdf_tab import Table, SpecError, normalize_spec, spec_hash, resolve_axes, tabulate, iter_blocks, read_exr, write_exr
        import bsdf_tab.api, bsdf_tab.spec, bsdf_tab.table, bsdf_tab.errors
        same = [tabulate is bsdf_tab.api.tabulate, iter_blocks is bsdf_tab.api.iter_blocks,
                normalize_spec is bsdf_tab.spec.normalize_spec, spec_hash is bsdf_tab.spec.spec_hash,
                resolve_axes is bsdf_tab.spec.resolve_axes, Table is bsdf_tab.table.Table,
                read_exr is bsdf_tab.table.read_exr, write_exr is bsdf_tab.table.write_exr,
                SpecError is bsdf_tab.errors.SpecError]
        ns = {}
        exec("from bsdf_tab import *", ns)
        missing = [n for n in bsdf_tab.__all__ if n not in ns]
        out = [before, same, missing, sorted(set(bsdf_tab.__all__) - set(dir(bsdf_tab)))]
    """)
    before, same, missing, not_in_dir = got["out"]
    assert before is False and all(same) and missing == [] and not_in_dir == [], got


def test_submodules_are_attributes_of_a_bare_import_and_unknown_names_fail():
    got = _modules_after("""
        import bsdf_tab
        io_ok = hasattr(bsdf_tab.io, "write") and bsdf_tab.io is sys.modules["bsdf_tab.io"]
        try:
            bsdf_tab.no_such_thing
            unknown = "no error"
        except AttributeError as exc:
            unknown = str(exc)
        out = [io_ok, unknown]
    """)
    io_ok, unknown = got["out"]
    assert io_ok and "no_such_thing" in unknown, got


def test_preload_imports_with_the_collector_paused_then_restores_it(tmp_path):
    (tmp_path / "probe_module.py").write_text("import gc\nENABLED_DURING_IMPORT = gc.isenabled()\n")
    got = _modules_after(f"""
        import gc, sys
        sys.path.insert(0, {str(tmp_path)!r})
        from bsdf_tab.cli.main import preload
        frozen = gc.get_freeze_count()
        preload(["probe_module", "no_such_module_here", "json"])
        import probe_module
        out = [probe_module.ENABLED_DURING_IMPORT, gc.isenabled(), gc.get_freeze_count() > frozen]
    """)
    during, after, froze = got["out"]
    assert during is False and after is True and froze, got


def test_preload_leaves_a_disabled_collector_disabled():
    from bsdf_tab.cli.main import preload

    was = gc.isenabled()
    gc.disable()
    try:
        preload(["json"])
        assert not gc.isenabled()
    finally:
        if was:
            gc.enable()


def test_plan_command_names_what_it_imports():
    from bsdf_tab.cli.main import IMPORTS

    assert "bsdf_tab.scene" in IMPORTS["plan"] and "bsdf_tab.api" in IMPORTS["bake"]
    assert "service.app" in IMPORTS.get("serve", ("service.app",))


def test_service_warm_up_lets_a_request_in_between_kinds(tmp_path, monkeypatch):
    """With one compute slot, a request that arrives during the warm-up waits for the kind
    being warmed, not for every kind."""
    pytest.importorskip("fastapi")
    from fastapi.testclient import TestClient

    import service.warmup as warmup
    from service.app import create_app
    from service.settings import Settings

    warmed = []

    def slow_warm(kind, device=None, strict=False):
        time.sleep(0.25)
        warmed.append(kind)
        return True

    monkeypatch.setattr(warmup, "warm_kind", slow_warm)
    kinds = warmup.warm_kinds()
    assert len(kinds) >= 4
    app = create_app(Settings(cache_dir=tmp_path, warmup=True, workers=1, max_concurrent=1))
    with TestClient(app) as client:
        r = client.get("/tables/albedo?mu_size=3&alpha_size=3&format=json")
        done_at_answer = len(warmed)
        assert r.status_code == 200, r.text
    assert done_at_answer < len(kinds), (done_at_answer, kinds)
