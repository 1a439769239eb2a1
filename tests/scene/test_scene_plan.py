"""bsdf_tab.scene.plan and .manifest: the planned tables meet the lookup tolerance, checked
independently: the baked EXR tables are read back through the manifest alone (SciPy, in
scene_cases) and compared with the float64 reference (tests/reference) or with direct
tabulations at 1e-7 at random points of each material's ranges."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scene_cases import GLASS3D, METALS, MIXED, SCENES, TINY, material_points, planned, renderer_lookup

import bsdf_tab.api
from bsdf_tab.api import tabulate
from bsdf_tab.errors import SpecError
from bsdf_tab import read_exr
from bsdf_tab.scene import bake_scene, plan_scene
from tests.reference import microfacet_ref as ref

SMALLER = [SCENES[0], SCENES[1], SCENES[3]]


@pytest.mark.parametrize("name,scene,tol", SCENES, ids=[s[0] for s in SCENES])
def test_baked_tables_meet_tol_at_random_points(name, scene, tol, tmp_path):
    plan = planned(name, scene, tol)
    bake_scene(plan, tmp_path)
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    interp = manifest["interpolation"]
    entries = {t["file"]: t for t in manifest["tables"]}
    rng = np.random.default_rng(7)
    for mat in scene["materials"]:
        info = manifest["materials"][mat["name"]]
        entry = entries[info["table"]]
        table = read_exr(tmp_path / info["table"])
        pts = material_points(mat, rng)
        mu = sorted(set(np.round(rng.uniform(0.0, 1.0, 9), 12).tolist()) | {0.0, 1.0})
        direct_axes = {"mu": mu}
        for ax in entry["axes"][1:]:
            if ax["name"] in pts:
                direct_axes[ax["name"]] = pts[ax["name"]]
            else:  # table axis alpha, material given as roughness
                direct_axes[ax["name"]] = sorted({r * r for r in pts["roughness"]})
        spec = dict(entry["spec"], axes=direct_axes, tolerance=1e-7)
        direct = tabulate(spec)

        def read(ch):
            return renderer_lookup(entry, table.channels[ch], direct_axes, interp)

        for ch in entry["channels"]:
            err = np.abs(read(ch) - direct.channels[ch]) + direct.channels[ch + "_err"]
            assert err.max() <= tol, (name, mat["name"], ch, float(err.max()))
        if entry["table"] == "dfg":  # E = f0 A + B with the material's f0
            f0 = float(np.max(mat["f0"]))
            e_tab = f0 * read("A") + read("B")
            e_dir = f0 * direct.channels["A"] + direct.channels["B"]
            assert np.abs(e_tab - e_dir).max() <= tol
    # the plan's reported error is the verified one and below the lookup tolerance
    assert manifest["lookup_tol"] == tol and "tolerance" not in manifest
    assert manifest["max_error"] <= tol
    assert all(t["max_error"] <= tol for t in manifest["tables"])
    assert all(t["integration_tolerance"] == t["spec"]["tolerance"] == tol / 20 for t in manifest["tables"])


def test_gold_table_meets_tol_against_the_float64_reference(tmp_path):
    """The interpolated gold albedo table, read as a renderer does, within tol of the
    independent reference (its quadrature B) at random (mu, roughness) points."""
    tol = 2e-3
    plan = planned("metals", METALS, tol)
    bake_scene(plan, tmp_path)
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    file = manifest["materials"]["gold"]["table"]
    (entry,) = [t for t in manifest["tables"] if t["file"] == file]
    assert [a["name"] for a in entry["axes"]] == ["mu", "roughness"] and entry["axes"][1]["lookup"] == "interpolate"
    table = read_exr(tmp_path / file)
    rng = np.random.default_rng(5)
    mu, rough = np.sort(rng.uniform(0.02, 1.0, 4)), np.sort(rng.uniform(0.3, 0.6, 3))
    got = renderer_lookup(entry, table.channels["E"], {"mu": mu, "roughness": rough}, "linear")
    fres = ("conductor", 0.18, 3.42)
    want = np.array([[ref.albedo(float(m), float(r) ** 2, "ggx", "correlated", fres, methods="B").value for r in rough]
                     for m in mu])
    assert np.abs(got - want).max() <= tol, float(np.abs(got - want).max())


@pytest.mark.parametrize("name,scene,tol", SMALLER, ids=[s[0] for s in SMALLER])
def test_plan_smaller_than_fixed_alternative(name, scene, tol):
    plan = planned(name, scene, tol)
    assert plan.bytes < plan.fixed_bytes
    text = plan.text()
    assert "fixed" in text and str(plan.bytes) in text


def test_fixed_alternative_error_matches_an_independent_check():
    """The plan's fixed-size error, recomputed from the manifest alone: the 32 x 32 table read
    at the refined grid of the planned table (its nodes and every cell midpoint)."""
    plan = planned("metals", METALS, 2e-3)
    entry = plan.to_dict()["tables"][0]  # gold: mu x roughness range
    fixed = entry["fixed_alternative"]
    assert fixed["shape"] == [32, 32] and [a["name"] for a in fixed["axes"]] == ["mu", "roughness"]
    fixed_axes = {a["name"]: {"size": a["size"], "spacing": "linear", "nodes": "endpoints", "range": a["range"]}
                  for a in fixed["axes"]}
    assert fixed_axes["mu"]["range"] == [0.0, 1.0] and fixed_axes["roughness"]["range"] == [0.0, 1.0]
    fixed_table = tabulate(dict(entry["spec"], axes=fixed_axes, tolerance=1e-7))
    points = {}
    for a in entry["axes"]:
        g, ginv = (np.sqrt, np.square) if a["spacing"] == "square" else ((lambda v: v), (lambda v: v))
        lo, hi = a["range"]
        points[a["name"]] = ginv(np.linspace(g(lo), g(hi), 2 * a["size"] - 1))
    direct = tabulate(dict(entry["spec"], axes={k: v.tolist() for k, v in points.items()}, tolerance=1e-7))
    fixed_entry = {"axes": [dict(a, lookup="interp", spacing="linear") for a in fixed["axes"]]}
    got = renderer_lookup(fixed_entry, fixed_table.channels["E"], points, "linear")
    independent = float(np.abs(got - direct.channels["E"]).max())
    # the plan integrated at tol/20 = 1e-4 per texel; here at 1e-7
    assert abs(independent - fixed["max_error"]) <= 2.5e-4, (independent, fixed["max_error"])
    assert fixed["max_error"] > 2e-3 > entry["max_error"]  # the fixed table misses the tolerance here


def test_planner_merges_drops_and_restricts():
    plan = planned("metals", METALS, 2e-3)
    # one table per conductor IOR, the single roughness of copper a 1-value axis
    assert [t.kind for t in plan.tables] == ["albedo", "albedo"]
    gold, copper = plan.tables
    assert gold.axes[1].mode == "interp" and tuple(gold.axes[1].range) == (0.3, 0.6)
    assert copper.axes[1].mode == "discrete" and copper.axes[1].values == [0.4]
    assert gold.fresnel == {"type": "conductor", "eta": 0.18, "k": 3.42}
    mixed = planned("mixed", MIXED, 2e-3)
    glass = [t for t in mixed.tables if t.kind == "dielectric"][0]
    assert glass.shape[1:] == (2, 1)  # alpha {0.2, 0.3}, eta {1.5}: no interpolation there
    assert all(a.spacing == "linear" for t in mixed.tables for a in t.axes if a.mode == "interp")
    g3 = planned("glass3d", GLASS3D, 5e-3)
    assert [a.mode for a in g3.tables[0].axes] == ["interp", "interp", "interp"]


def test_planner_is_deterministic():
    first = planned("metals", METALS, 2e-3).to_dict()
    again = plan_scene(METALS, 2e-3).to_dict()
    assert json.dumps(first, sort_keys=True) == json.dumps(again, sort_keys=True)


def test_every_table_goes_through_api_tabulate(monkeypatch):
    """The one path: each computation of the planner is a bsdf_tab.api.tabulate call (memoized)."""
    calls = []
    real = bsdf_tab.api.tabulate
    monkeypatch.setattr(bsdf_tab.api, "tabulate", lambda spec, **kw: calls.append(spec) or real(spec, **kw))
    plan = plan_scene(TINY, 2e-2)
    assert calls and plan.tabulate_calls == len(calls)
    assert len({json.dumps(s, sort_keys=True) for s in calls}) == len(calls)  # nothing computed twice


def test_bad_lookup_tol():
    with pytest.raises(SpecError) as info:
        plan_scene(TINY, 0.0)
    assert info.value.param == "tol"
    with pytest.raises(SpecError) as info:
        plan_scene(TINY)  # no tol and no scene tolerance
    assert info.value.param == "tol"
    with pytest.raises(SpecError) as info:
        plan_scene(dict(TINY, tolerance=1.0))
    assert info.value.param == "tolerance"  # the scene's own key


def test_scene_tolerance_is_the_default_lookup_tol():
    plan = plan_scene(dict(TINY, tolerance=2e-2))
    assert plan.lookup_tol == 2e-2 and plan.to_dict()["lookup_tol"] == 2e-2
    assert plan.tables[0].integration_tol == 2e-2 / 20


def test_plan_within_a_texel_budget_is_still_verified():
    plan = plan_scene(TINY, 2e-3, max_texels=64)
    (t,) = plan.tables
    assert int(np.prod(t.shape)) <= 64 and plan.max_error <= 2e-3
    # the 32 x 32 comparison would exceed the budget itself: not computed, null in JSON
    assert np.isnan(t.fixed_error) and plan.to_dict()["fixed_max_error"] is None
    assert "not computed" in plan.text()
    with pytest.raises(SpecError) as exc:
        plan_scene(TINY, 1e-6, max_texels=4)
    assert exc.value.param == "tol" and type(exc.value).__name__ == "TexelLimitError"


def test_mixed_alpha_and_roughness_share_an_alpha_axis():
    scene = {
        "lookup": {"spacings": ["sqrt"]},
        "materials": [
            {"name": "a", "type": "schlick", "f0": 0.04, "alpha": 0.1},
            {"name": "r", "type": "schlick", "f0": 0.04, "roughness": 0.5},
        ],
    }
    plan = plan_scene(scene, 5e-3)
    (table,) = plan.tables
    assert table.axes[1].name == "alpha" and table.axes[1].values == [0.1, 0.25]
    assert table.axes[0].spacing == "square"
    man = plan.to_dict()["materials"]
    assert man["a"]["coords"]["alpha"]["index"] == [0]
    assert man["r"]["coords"]["alpha"] == {"values": [0.25], "index": [1]} and "roughness^2" in man["r"]["note"]
    points = {"mu": [0.0, 0.37, 1.0], "alpha": [0.1, 0.25]}
    direct = tabulate(dict(table.spec(), axes=points, tolerance=1e-7))
    (entry,) = plan.to_dict()["tables"]
    for ch in ("A", "B"):
        got = renderer_lookup(entry, table.table.channels[ch], points, "linear")
        assert np.abs(got - direct.channels[ch]).max() <= 5e-3


def test_bake_refuses_a_file_as_the_folder(tmp_path):
    plan = planned("metals", METALS, 2e-3)
    (tmp_path / "f").write_text("x")
    with pytest.raises(SpecError) as info:
        bake_scene(plan, tmp_path / "f")
    assert info.value.param == "output"
