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


# --------------------------------------------------------------------------- the plan's imports

#: Modules the ``plan`` path never needs: the fixed-effort integration methods, the table kinds
#: with kernels of their own and the device models no isotropic table integrates with (they load
#: on first use).
PLAN_UNUSED = ("bsdf_tab.integrate.grid", "bsdf_tab.integrate.montecarlo", "bsdf_tab.integrate.vndf_gl",
               "bsdf_tab.tables.bsdf", "bsdf_tab.tables.ltc", "bsdf_tab.tables.sheen", "bsdf_tab.tables.aniso",
               "bsdf_tab.ltc", "bsdf_tab.model.charlie", "bsdf_tab.model.ltc", "bsdf_tab.model.multiscatter",
               "bsdf_tab.model.bsdf", "tomllib")


def test_plan_command_does_not_import_the_unused_methods_and_models(tmp_path):
    """A whole ``bsdf-tab plan`` (a small scene: one Schlick material, one interpolated axis)
    runs without loading them; the table code it needs is loaded (the check can fail)."""
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"materials": [
        {"name": "p", "type": "schlick", "f0": 0.04, "alpha": {"range": [0.2, 0.3]}}]}))
    got = _modules_after(f"""
        import contextlib, io
        from bsdf_tab.cli import main
        with contextlib.redirect_stdout(io.StringIO()) as buf:
            code = main(["plan", {str(scene)!r}, "--tol", "1e-2", "--json", "-q"])
        out = [code, json.loads(buf.getvalue())["tables"][0]["table"],
               [m for m in {PLAN_UNUSED!r} if m in sys.modules],
               [m for m in ("bsdf_tab.integrate.adaptive", "bsdf_tab.model.fresnel") if m in sys.modules]]
    """.replace("json.loads", "__import__('json').loads"))
    code, kind, unused, used = got["out"]
    assert code == 0 and kind == "dfg", got
    assert unused == [], unused
    assert len(used) == 2 and "warp" in got["loaded"], got


def test_the_method_registry_knows_every_method_before_loading_it():
    got = _modules_after("""
        import bsdf_tab.integrate as integrate
        names = list(integrate.METHODS)
        before = [m for m in ("bsdf_tab.integrate.grid", "bsdf_tab.integrate.montecarlo",
                              "bsdf_tab.integrate.vndf_gl") if m in sys.modules]
        known = ["mc_vndf" in integrate.METHODS, "no_such" in integrate.METHODS, len(integrate.METHODS)]
        fn = integrate.get_method("mc_vndf")
        import bsdf_tab.integrate.montecarlo as mc
        import bsdf_tab.integrate.grid as grid, bsdf_tab.integrate.vndf_gl as gl
        registered = {"adaptive": integrate.integrate_texels, **grid.METHODS, **mc.METHODS, **gl.METHODS}
        same = all(integrate.METHODS[k] is v for k, v in registered.items())
        try:
            integrate.get_method("no_such")
            unknown = "no error"
        except ValueError as exc:
            unknown = str(exc)
        out = [names, sorted(registered), before, known, fn is mc.METHODS["mc_vndf"], same, unknown]
    """)
    names, registered, before, known, fn_ok, same, unknown = got["out"]
    assert names[0] == "adaptive" and sorted(names) == registered, got  # every module's methods, no more
    assert before == [] and known == [True, False, len(registered)], got
    assert fn_ok and same and "no_such" in unknown and "vndf_gl" in unknown, got


def test_a_method_replaced_before_its_module_loads_stays_replaced():
    got = _modules_after("""
        import bsdf_tab.integrate as integrate
        integrate.METHODS["grid"] = len
        a = integrate.METHODS["grid"] is len
        b = integrate.get_method("grid") is len
        import bsdf_tab.integrate.grid as grid
        c = integrate.METHODS["grid"] is len and grid.METHODS["grid"] is not len
        out = [a, b, c]
    """)
    assert got["out"] == [True, True, True], got


def test_lazy_model_names_resolve_to_their_modules():
    got = _modules_after("""
        import bsdf_tab.model as model
        before = [m for m in ("bsdf_tab.model.charlie", "bsdf_tab.model.ltc") if m in sys.modules]
        from bsdf_tab.model import charlie_D, ltc_eval, brdf, kc_C, ggx_aniso_D, GGX, fresnel
        import bsdf_tab.model.charlie, bsdf_tab.model.ltc, bsdf_tab.model.bsdf, bsdf_tab.model.multiscatter
        same = [charlie_D is bsdf_tab.model.charlie.charlie_D, ltc_eval is bsdf_tab.model.ltc.ltc_eval,
                brdf is bsdf_tab.model.bsdf.brdf, kc_C is bsdf_tab.model.multiscatter.kc_C]
        ns = {}
        exec("from bsdf_tab.model import *", ns)
        missing = [n for n in model.__all__ if n not in ns]
        try:
            model.no_such_function
            unknown = "no error"
        except AttributeError as exc:
            unknown = str(exc)
        out = [before, same, missing, "charlie" in model.__all__ and "charlie_D" in dir(model), unknown]
    """)
    before, same, missing, listed, unknown = got["out"]
    assert before == [] and all(same) and missing == [] and listed, got
    assert "no_such_function" in unknown, got


def test_deferred_kind_functions_are_the_modules_functions():
    got = _modules_after("""
        import pickle
        from bsdf_tab.tables import CATALOG, KINDS
        from bsdf_tab.tables.kinds import Deferred
        deferred = sorted(k for k, info in KINDS.items() if isinstance(info["compute"], Deferred))
        before = [m for m in ("bsdf_tab.tables.sheen", "bsdf_tab.tables.bsdf") if m in sys.modules]
        import bsdf_tab.tables.aniso as aniso, bsdf_tab.tables.bsdf as bsdf, bsdf_tab.tables.ltc as ltc
        import bsdf_tab.tables.sheen as sheen
        same = [KINDS["bsdf"]["compute"].resolve() is bsdf.compute, KINDS["bsdf"]["blocks"].resolve() is bsdf.blocks,
                KINDS["ltc"]["compute"].resolve() is ltc.compute, KINDS["albedo_aniso"]["compute"].resolve() is aniso.compute,
                KINDS["sheen_albedo"]["compute"].resolve() is sheen.compute,
                KINDS["sheen_albedo_avg"]["compute"].resolve() is sheen.compute_avg,
                pickle.loads(pickle.dumps(KINDS["sheen_albedo"]["compute"])).resolve() is sheen.compute]
        out = [deferred, before, same, list(CATALOG["ltc"]["channels"]) == list(ltc.CHANNELS),
               list(CATALOG["sheen_albedo"]["keys"]["sheen_shadowing"]["choices"]) == list(sheen.SHEEN_SHADOWINGS)]
    """)
    deferred, before, same, ltc_channels, sheen_choices = got["out"]
    assert deferred == ["albedo_aniso", "bsdf", "ltc", "sheen_albedo", "sheen_albedo_avg"], got
    assert before == [] and all(same) and ltc_channels and sheen_choices, got


def test_warmup_prepares_the_landing_page_table(tmp_path, monkeypatch):
    """The audit: GET / without a query computed its default table in the compute queue, so the
    landing page waited behind any running computation. The warm-up now computes it once; the
    page is then a cache hit."""
    pytest.importorskip("fastapi")
    from fastapi.testclient import TestClient

    import service.warmup as warmup
    from service.app import create_app
    from service.settings import Settings

    monkeypatch.setattr(warmup, "warm_kind", lambda kind, device=None, strict=False: True)
    app = create_app(Settings(cache_dir=tmp_path, warmup=True, workers=1))
    with TestClient(app) as client:
        store = app.state.store
        prep = store.prepare({"table": "albedo"})
        for _ in range(400):  # bounded: 20 s
            if store.cached(prep, "info") is not None:
                break
            time.sleep(0.05)
        assert store.cached(prep, "info") is not None
        computed = store.computations
        page = client.get("/")
        assert page.status_code == 200 and "albedo: mu 32 x alpha 32" in page.text
        assert store.computations == computed == 1  # the page computed nothing
