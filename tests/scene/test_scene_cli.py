"""bsdf_tab.cli.plan: ``bsdf-tab plan SCENE`` and ``bsdf-tab bake SCENE -o DIR`` (one-line
errors, exit code 2; progress on stderr)."""

from __future__ import annotations

import json

import pytest
from scene_cases import TINY

from bsdf_tab.cli import main
from bsdf_tab.cli.plan import is_scene_file
from bsdf_tab import read_exr


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_is_scene_file(tmp_path):
    scene, spec, bad = tmp_path / "s.json", tmp_path / "t.json", tmp_path / "b.json"
    scene.write_text(json.dumps(TINY))
    spec.write_text(json.dumps({"table": "albedo"}))
    bad.write_text("{")
    assert is_scene_file(str(scene)) and is_scene_file(str(tmp_path / "any.toml"))
    assert not is_scene_file(str(spec)) and not is_scene_file(str(bad)) and not is_scene_file(str(tmp_path / "no.json"))


def test_cli_plans_a_toml_scene_and_reports_bad_toml(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_text('tolerance = 2e-3\n[[materials]]\nname = "steel"\ntype = "conductor"\n'
                    'eta = 2.5\nk = 3.0\nalpha = 0.3\n')
    code, out, err = _run(capsys, "plan", str(path), "-q")
    assert code == 0 and "steel" in out, err
    code, out, err = _run(capsys, "bake", str(path), "-q", "-o", str(tmp_path / "out"))
    assert code == 0 and (tmp_path / "out" / "manifest.json").is_file(), err
    path.write_text("materials = [\n")
    for argv in (["plan", str(path)], ["bake", str(path), "-o", str(tmp_path / "o2")]):
        code, out, err = _run(capsys, *argv)
        assert code == 2 and len(err.strip().splitlines()) == 1 and "invalid TOML" in err, err


def test_cli_plan_and_bake(tmp_path, capsys):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(TINY))
    code, out, err = _run(capsys, "plan", str(path), "--tol", "2e-3")
    assert code == 0, err
    assert "fixed" in out and "steel" in out and "fixed-size alternative:" in out
    # progress: one stderr line per verified candidate, the last one accepted
    progress = [line for line in err.splitlines() if line.startswith("ggx_correlated_albedo_1.exr:")]
    assert len(progress) >= 2 and "refine" in progress[0] and any("(ok;" in line for line in progress), err
    code, out, err = _run(capsys, "plan", str(path), "--tol", "2e-3", "--json", "-q")
    plan = json.loads(out)
    assert code == 0 and plan["tables"][0]["table"] == "albedo" and "lookup error" not in err
    assert plan["lookup_tol"] == 2e-3
    assert plan["fixed_max_error"] == plan["tables"][0]["fixed_alternative"]["max_error"] > 0
    code, out, err = _run(capsys, "bake", str(path), "--tol", "2e-3", "-o", str(tmp_path / "out"))
    assert code == 0, err
    assert "wrote 1 table(s)" in out
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["materials"]["steel"]["table"] == "ggx_correlated_albedo_1.exr"
    assert read_exr(tmp_path / "out" / "ggx_correlated_albedo_1.exr").channels["E"].shape[1] == 1


@pytest.mark.parametrize(
    "argv_tail,fragment",
    [
        (["--tol", "1e-3"], "materials[0].k"),
        (["--tol", "-1"], "tol"),
        (["--tol", "1e-3", "--workers", "0"], "--workers"),
    ],
)
def test_cli_errors_are_one_line(tmp_path, capsys, argv_tail, fragment):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"materials": [{"type": "conductor", "eta": 1.0, "alpha": 0.1}]}))
    good = tmp_path / "good.json"
    good.write_text(json.dumps(TINY))
    path = bad if fragment.startswith("materials") else good
    for cmd in (["plan", str(path)], ["bake", str(path), "-o", str(tmp_path / "o")]):
        code, out, err = _run(capsys, *cmd, *argv_tail)
        assert code == 2, err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and fragment in lines[0], err
    code, out, err = _run(capsys, "plan", str(tmp_path / "missing.json"), "--tol", "1e-3")
    assert code == 2 and len(err.strip().splitlines()) == 1
    code, out, err = _run(capsys, "bake", str(good), "--tol", "1e-3")  # no -o DIR
    assert code == 2 and "-o DIR" in err
