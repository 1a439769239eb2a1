"""Scenes: parse, plan (minimal tables, verified error), bake with manifest, CLI, POST /scenes.

The planned tables are checked against direct ``tabulate`` at random points of each
material's ranges (explicit axes), read back the way a renderer would from the manifest alone
(``_renderer_lookup``: SciPy's grid interpolator in the decoded texel coordinate, written here
apart from ``scene.lookup``).
"""

from __future__ import annotations

import base64
import json

import numpy as np
import pytest

from bsdf_tab import cli
from bsdf_tab.api import tabulate
from bsdf_tab.errors import SpecError
from bsdf_tab.exr import read_exr
from bsdf_tab.scene import bake_scene, lookup, parse_scene, plan_scene

METALS = {
    "materials": [
        {"name": "gold", "type": "conductor", "eta": 0.18, "k": 3.42, "roughness": {"range": [0.3, 0.6]}},
        {"name": "copper", "type": "conductor", "ior": [0.27, 3.61], "roughness": 0.4},
    ]
}
MIXED = {
    "lookup": {"interpolation": "linear", "spacings": ["linear"]},
    "materials": [
        {"name": "plastic", "type": "schlick", "f0": 0.04, "alpha": {"range": [0.1, 0.4]}},
        {"name": "glass", "type": "dielectric", "eta": 1.5, "alpha": [0.2, 0.3], "distribution": "beckmann"},
    ],
}
NEAREST = {
    "lookup": {"interpolation": "nearest"},
    "materials": [
        {"name": "rough", "type": "schlick", "f0": 0.5, "roughness": {"range": [0.5, 0.9]}, "shadowing": "separable"}
    ],
}
TINY = {"materials": [{"name": "steel", "type": "conductor", "eta": 2.5, "k": 3.0, "alpha": 0.3}]}
GLASS3D = {"materials": [{"name": "g", "type": "dielectric", "eta": {"range": [1.3, 1.6]}, "alpha": {"range": [0.3, 0.5]}}]}
SCENES = [("metals", METALS, 2e-3), ("mixed", MIXED, 2e-3), ("nearest", NEAREST, 2e-2), ("glass3d", GLASS3D, 5e-3)]
SMALLER = [SCENES[0], SCENES[1], SCENES[3]]

_PLANS: dict = {}


def planned(name, scene, tol):
    if name not in _PLANS:
        _PLANS[name] = plan_scene(scene, tol)
    return _PLANS[name]


def _material_points(mat: dict, rng, n: int = 4) -> dict:
    """Random coordinates of a material: {axis: sorted values} in the table's units (before
    alpha = roughness^2 conversion, handled by the caller)."""
    def pick(v):
        if "range" in v:
            lo, hi = v["range"]
            return sorted(set(np.round(rng.uniform(lo, hi, n), 12).tolist()))
        return list(v["values"])

    out = {}
    for key in ("alpha", "roughness"):
        if key in mat:
            out[key] = pick(mat[key] if isinstance(mat[key], dict) else {"values": np.atleast_1d(mat[key]).tolist()})
    if mat["type"] == "dielectric":
        out["eta"] = pick({"values": np.atleast_1d(mat["eta"]).tolist()} if not isinstance(mat["eta"], dict) else mat["eta"])
    return out


def _renderer_lookup(entry: dict, values: np.ndarray, points: dict, interpolation: str) -> np.ndarray:
    """Read ``values`` (a table channel) at the grid ``points`` ({axis: coordinates}) as a
    renderer does from the manifest entry: an ``index`` axis picks its listed value; an
    interpolated axis is linear or nearest in the texel coordinate t = (g(x) - g(lo)) /
    (g(hi) - g(lo)) with g = sqrt for ``square`` spacing and g(x) = x for ``linear``."""
    from scipy.interpolate import RegularGridInterpolator

    grid, query = [], []
    values = np.asarray(values, dtype=np.float64)
    for k, ax in enumerate(entry["axes"]):
        x = np.asarray(points[ax["name"]], dtype=np.float64)
        if ax["lookup"] == "index":
            idx = [ax["values"].index(v) if v in ax["values"] else int(np.argmin(np.abs(np.asarray(ax["values"]) - v)))
                   for v in x]
            assert np.allclose(np.asarray(ax["values"])[idx], x), (ax, x)
            values = np.take(values, idx, axis=k)
            grid.append(np.arange(len(idx), dtype=np.float64))
            query.append(np.arange(len(idx), dtype=np.float64))
            continue
        g = np.sqrt if ax["spacing"] == "square" else (lambda v: v)
        lo, hi = ax["range"]
        grid.append(np.linspace(0.0, ax["size"] - 1.0, ax["size"]))
        query.append((g(np.clip(x, lo, hi)) - g(lo)) / (g(hi) - g(lo)) * (ax["size"] - 1))
    mesh = np.meshgrid(*query, indexing="ij")
    interp = RegularGridInterpolator(grid, values, method=interpolation)
    return interp(np.stack([m.ravel() for m in mesh], axis=-1)).reshape(mesh[0].shape)


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
        pts = _material_points(mat, rng)
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
            return _renderer_lookup(entry, table.channels[ch], direct_axes, interp)

        for ch in entry["channels"]:
            err = np.abs(read(ch) - direct.channels[ch]) + direct.channels[ch + "_err"]
            assert err.max() <= tol, (name, mat["name"], ch, float(err.max()))
        if entry["table"] == "dfg":  # E = f0 A + B with the material's f0
            f0 = float(np.max(mat["f0"]))
            e_tab = f0 * read("A") + read("B")
            e_dir = f0 * direct.channels["A"] + direct.channels["B"]
            assert np.abs(e_tab - e_dir).max() <= tol
    # the plan's reported error is the verified one and below tol
    assert manifest["max_error"] <= tol
    assert all(t["max_error"] <= tol for t in manifest["tables"])


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
    got = _renderer_lookup(fixed_entry, fixed_table.channels["E"], points, "linear")
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
    mixed = planned("mixed", MIXED, 2e-3)
    glass = [t for t in mixed.tables if t.kind == "dielectric"][0]
    assert glass.shape[1:] == (2, 1)  # alpha {0.2, 0.3}, eta {1.5}: no interpolation there
    assert all(a.spacing == "linear" for t in mixed.tables for a in t.axes if a.mode == "interp")


def test_planner_is_deterministic():
    first = planned("metals", METALS, 2e-3).to_dict()
    again = plan_scene(METALS, 2e-3).to_dict()
    assert json.dumps(first, sort_keys=True) == json.dumps(again, sort_keys=True)


@pytest.mark.parametrize(
    "scene,param",
    [
        ({"materials": []}, "materials"),
        ({"materials": [{"type": "wood", "alpha": 0.1}]}, "materials[0].type"),
        ({"materials": [{"type": "conductor", "eta": 1.0, "alpha": 0.1}]}, "materials[0].k"),
        ({"materials": [{"type": "schlick", "f0": 2.0, "alpha": 0.1}]}, "materials[0].f0"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": -0.1}]}, "materials[0].alpha"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": {"range": [0.5, 0.2]}}]}, "materials[0].alpha.range"),
        ({"materials": [{"type": "dielectric", "eta": 0, "alpha": 0.1}]}, "materials[0].eta"),
        ({"materials": [{"type": "schlick", "f0": 0.04}]}, "materials[0].alpha"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.1, "colour": 1}]}, "materials[0].colour"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.1}], "lookup": {"interpolation": "cubic"}},
         "lookup.interpolation"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.1, "name": "a"},
                        {"type": "schlick", "f0": 0.04, "alpha": 0.2, "name": "a"}]}, "materials[1].name"),
    ],
)
def test_bad_scenes_name_the_parameter(scene, param):
    with pytest.raises(SpecError) as info:
        parse_scene(scene)
    assert info.value.param == param


def test_bad_tolerance():
    with pytest.raises(SpecError) as info:
        plan_scene(TINY, 0.0)
    assert info.value.param == "tolerance"
    with pytest.raises(SpecError) as info:
        plan_scene(TINY)  # no --tol and no scene tolerance
    assert info.value.param == "tolerance"


def _run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_toml_scene_is_the_json_scene():
    from pathlib import Path

    from bsdf_tab.scene import load_scene_file

    root = Path(__file__).resolve().parents[1] / "examples"
    assert parse_scene(load_scene_file(root / "scene.toml")) == parse_scene(load_scene_file(root / "scene.json"))


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
    assert plan["fixed_max_error"] == plan["tables"][0]["fixed_alternative"]["max_error"] > 0
    code, out, err = _run(capsys, "bake", str(path), "--tol", "2e-3", "-o", str(tmp_path / "out"))
    assert code == 0, err
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["materials"]["steel"]["table"] == "ggx_correlated_albedo_1.exr"
    assert read_exr(tmp_path / "out" / "ggx_correlated_albedo_1.exr").channels["E"].shape[1] == 1


@pytest.mark.parametrize(
    "argv_tail,fragment",
    [
        (["--tol", "1e-3"], "materials[0].k"),
        (["--tol", "-1"], "tolerance"),
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


def test_service_post_scenes(tmp_path):
    pytest.importorskip("fastapi")
    from fastapi.testclient import TestClient

    from service.app import create_app
    from service.settings import Settings

    app = create_app(Settings(cache_dir=tmp_path / "cache", warmup=False, workers=2))
    with TestClient(app) as client:
        r = client.post("/scenes", params={"tol": "2e-3"}, json=TINY)
        assert r.status_code == 200, r.text
        body = r.json()
        assert body["plan"]["bytes"] < body["plan"]["fixed_bytes"]
        (name, item), = body["tables"].items()
        data = base64.b64decode(item["data"])
        assert len(data) == item["bytes"]
        (tmp_path / name).write_bytes(data)
        assert "E" in read_exr(tmp_path / name).channels
        bad = client.post("/scenes", params={"tol": "2e-3"}, json={"materials": [{"type": "x", "alpha": 0.1}]})
        assert bad.status_code == 400 and bad.json()["error"]["param"] == "materials[0].type"
        assert client.post("/scenes", params={"tol": "abc"}, json=TINY).status_code == 400
        assert client.post("/scenes", params={"bogus": "1"}, json=TINY).status_code == 400
        assert client.post("/scenes", json={"table": "albedo"}).status_code == 400
        notol = client.post("/scenes", json=TINY)
        assert notol.status_code == 400 and notol.json()["error"]["param"] == "tolerance"
        for tol in ("nan", "inf", "-inf", "0", "1e-9", "0.5"):
            r = client.post("/scenes", params={"tol": tol}, json=TINY)
            assert r.status_code == 400 and r.json()["error"]["param"] == "tol", (tol, r.text)


def test_service_scene_above_the_texel_limit_is_413_before_computing(tmp_path, monkeypatch):
    pytest.importorskip("fastapi")
    from fastapi.testclient import TestClient

    import bsdf_tab.api
    from service.app import create_app
    from service.settings import Settings

    computed = []
    real = bsdf_tab.api.tabulate
    monkeypatch.setattr(bsdf_tab.api, "tabulate", lambda spec, **kw: computed.append(spec) or real(spec, **kw))
    # a range of roughness needs more than 3 texels along mu x alpha: every candidate is too big
    scene = {"materials": [{"name": "m", "type": "conductor", "eta": 2.5, "k": 3.0, "alpha": {"range": [0.2, 0.6]}}]}
    with TestClient(create_app(Settings(cache_dir=tmp_path / "cache", warmup=False, workers=1, max_texels=3))) as client:
        r = client.post("/scenes", params={"tol": "1e-3"}, json=scene)
    assert r.status_code == 413, r.text
    err = r.json()["error"]
    assert err["param"] == "tolerance" and err["allowed"] == {"max_texels": 3} and "3 texels" in err["message"]
    assert computed == []  # skipped before anything was tabulated


def test_plan_within_a_texel_budget_is_still_verified():
    plan = plan_scene(TINY, 2e-3, max_texels=64)
    (t,) = plan.tables
    assert int(np.prod(t.shape)) <= 64 and plan.max_error <= 2e-3
    # the 32 x 32 comparison would exceed the budget itself: not computed, null in JSON
    assert np.isnan(t.fixed_error) and plan.to_dict()["fixed_max_error"] is None
    assert "not computed" in plan.text()
    with pytest.raises(SpecError) as exc:
        plan_scene(TINY, 1e-6, max_texels=4)
    assert exc.value.param == "tolerance" and type(exc.value).__name__ == "TexelLimitError"


def test_service_scene_answers_are_cached_with_etag(tmp_path, monkeypatch):
    pytest.importorskip("fastapi")
    from fastapi.testclient import TestClient

    import service.routes.scenes as scenes_route
    from service.app import create_app
    from service.settings import Settings

    calls = []
    real = scenes_route.plan_scene

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(scenes_route, "plan_scene", counting)
    app = create_app(Settings(cache_dir=tmp_path / "cache", warmup=False, workers=2))
    with TestClient(app) as client:
        first = client.post("/scenes", params={"tol": "2e-3"}, json=TINY)
        assert first.status_code == 200 and len(calls) == 1
        etag = first.headers["etag"]
        # the same scene spelled differently (key order, explicit defaults) is the same entry
        respelled = {"materials": [{"alpha": 0.3, "k": 3.0, "eta": 2.5, "type": "conductor", "name": "steel",
                                    "shadowing": "correlated", "distribution": "ggx"}]}
        again = client.post("/scenes", params={"tol": "2e-3"}, json=respelled)
        assert again.status_code == 200 and again.content == first.content and len(calls) == 1
        assert again.headers["etag"] == etag
        not_modified = client.post("/scenes", params={"tol": "2e-3"}, json=TINY, headers={"If-None-Match": etag})
        assert not_modified.status_code == 304 and not not_modified.content and len(calls) == 1
        other_tol = client.post("/scenes", params={"tol": "3e-3"}, json=TINY)
        assert other_tol.status_code == 200 and other_tol.headers["etag"] != etag and len(calls) == 2
    # a new app on the same cache folder serves the stored answer without planning
    with TestClient(create_app(Settings(cache_dir=tmp_path / "cache", warmup=False, workers=2))) as client:
        assert client.post("/scenes", params={"tol": "2e-3"}, json=TINY).content == first.content
    assert len(calls) == 2


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
        got = _renderer_lookup(entry, table.table.channels[ch], points, "linear")
        assert np.abs(got - direct.channels[ch]).max() <= 5e-3


@pytest.mark.parametrize("interpolation", ["linear", "nearest"])
def test_scene_lookup_matches_a_renderer_read(interpolation):
    """``scene.lookup`` (the planner's error check) reads tables as the manifest says."""
    plan = planned("glass3d", GLASS3D, 5e-3)
    (tp,) = plan.tables
    (entry,) = plan.to_dict()["tables"]
    rng = np.random.default_rng(3)
    points = {"mu": np.sort(rng.uniform(0, 1, 7)), "alpha": np.sort(rng.uniform(0.3, 0.5, 5)),
              "eta": np.sort(rng.uniform(1.3, 1.6, 4))}
    grids = np.meshgrid(*points.values(), indexing="ij")
    for ch in entry["channels"]:
        got = lookup(np.asarray(tp.table.channels[ch], dtype=np.float64), tp.axes, grids, interpolation)
        want = _renderer_lookup(entry, tp.table.channels[ch], points, interpolation)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
