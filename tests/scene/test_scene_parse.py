"""bsdf_tab.scene.parse: scene files (JSON, TOML), validation naming the parameter, and the
domains taken from the table specs (bsdf_tab.spec), not a copy of them."""

from __future__ import annotations

from pathlib import Path

import pytest

from bsdf_tab import spec
from bsdf_tab.errors import SpecError
from bsdf_tab.scene import LOOKUP_TOL_RANGE, check_lookup_tol, is_scene, load_scene_file, parse_scene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _schlick(**kw):
    return {"materials": [dict({"type": "schlick", "f0": 0.04, "alpha": 0.1}, **kw)]}


@pytest.mark.parametrize(
    "scene,param",
    [
        ({"materials": []}, "materials"),
        ({"materials": [{"type": "wood", "alpha": 0.1}]}, "materials[0].type"),
        ({"materials": [{"type": "conductor", "eta": 1.0, "alpha": 0.1}]}, "materials[0].k"),
        ({"materials": [{"type": "conductor", "eta": 1.0, "k": -1.0, "alpha": 0.1}]}, "materials[0].k"),
        ({"materials": [{"type": "conductor", "ior": [0.0, 3.0], "alpha": 0.1}]}, "materials[0].ior"),
        ({"materials": [{"type": "conductor", "ior": [1.0, "x"], "alpha": 0.1}]}, "materials[0].ior"),
        ({"materials": [{"type": "schlick", "f0": 2.0, "alpha": 0.1}]}, "materials[0].f0"),
        ({"materials": [{"type": "schlick", "f0": [0.1, -0.1, 0.2], "alpha": 0.1}]}, "materials[0].f0"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": -0.1}]}, "materials[0].alpha"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": "rough"}]}, "materials[0].alpha"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": {"range": [0.5, 0.2]}}]}, "materials[0].alpha.range"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "roughness": {"range": [0.1, 2.5]}}]},
         "materials[0].roughness.range"),
        ({"materials": [{"type": "dielectric", "eta": 0, "alpha": 0.1}]}, "materials[0].eta"),
        ({"materials": [{"type": "dielectric", "eta": [1.5, float("nan")], "alpha": 0.1}]}, "materials[0].eta"),
        ({"materials": [{"type": "schlick", "f0": 0.04}]}, "materials[0].alpha"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.1, "roughness": 0.3}]}, "materials[0].alpha"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.1, "colour": 1}]}, "materials[0].colour"),
        (_schlick(distribution="phong"), "materials[0].distribution"),
        (_schlick(shadowing="none"), "materials[0].shadowing"),
        (dict(_schlick(), lookup={"interpolation": "cubic"}), "lookup.interpolation"),
        (dict(_schlick(), lookup={"spacings": ["log"]}), "lookup.spacings"),
        (dict(_schlick(), lookup={"wrap": True}), "lookup.wrap"),
        (dict(_schlick(), tolerance=0.5), "tolerance"),
        (dict(_schlick(), lookup_error=1e-3), "lookup_error"),
        ({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.1, "name": "a"},
                        {"type": "schlick", "f0": 0.04, "alpha": 0.2, "name": "a"}]}, "materials[1].name"),
    ],
)
def test_bad_scenes_name_the_parameter(scene, param):
    with pytest.raises(SpecError) as info:
        parse_scene(scene)
    assert info.value.param == param


@pytest.mark.parametrize("dist", sorted(spec.DISTRIBUTIONS))
@pytest.mark.parametrize("shadowing", sorted(spec.SHADOWINGS))
def test_every_spec_distribution_and_shadowing_is_a_scene_choice(dist, shadowing):
    (m,) = parse_scene(_schlick(distribution=dist, shadowing=shadowing))["materials"]
    assert (m["distribution"], m["shadowing"]) == (dist, shadowing)


@pytest.mark.parametrize("axis", ["alpha", "roughness"])
def test_roughness_domain_is_the_spec_axis_domain(axis):
    lo, hi, lo_inclusive = spec.AXIS_DOMAINS[axis]
    ok = parse_scene({"materials": [{"type": "schlick", "f0": 0.04, axis: [lo if lo_inclusive else hi, hi]}]})
    assert ok["materials"][0]["rough"]["values"][-1] == hi
    for bad in (hi * 1.001, lo - 1e-3):
        with pytest.raises(SpecError) as info:
            parse_scene({"materials": [{"type": "schlick", "f0": 0.04, axis: bad}]})
        assert info.value.param == f"materials[0].{axis}"
        with pytest.raises(SpecError):  # the table spec refuses the same value
            spec.normalize_spec({"table": "dfg", "axes": {axis: [bad]}})


def test_dielectric_eta_domain_is_the_spec_axis_domain():
    lo, hi, lo_inclusive = spec.AXIS_DOMAINS["eta"]
    assert not lo_inclusive
    assert parse_scene({"materials": [{"type": "dielectric", "alpha": 0.1, "eta": hi}]})["materials"][0]["eta_axis"] == {
        "values": [hi]}
    for bad in (lo, hi * 1.001):
        with pytest.raises(SpecError) as info:
            parse_scene({"materials": [{"type": "dielectric", "alpha": 0.1, "eta": {"range": [1.2, bad]}}]})
        assert info.value.param == "materials[0].eta.range"


def test_conductor_ior_is_checked_as_a_spec_fresnel():
    """eta > 0 and k >= 0, as the spec's conductor Fresnel; a large but valid IOR is accepted."""
    m = {"type": "conductor", "eta": 150.0, "k": 0.0, "alpha": 0.2}
    (got,) = parse_scene({"materials": [m]})["materials"]
    assert (got["eta"], got["k"]) == (150.0, 0.0)
    spec.normalize_spec({"table": "albedo", "fresnel": {"type": "conductor", "eta": 150.0, "k": 0.0}})
    with pytest.raises(SpecError) as info:
        parse_scene({"materials": [dict(m, eta=-1.0)]})
    assert info.value.param == "materials[0].eta"


def test_normalized_scene():
    sc = parse_scene({
        "tolerance": 2e-3,
        "lookup": {"spacings": ["sqrt", "linear", "square"]},
        "materials": [
            {"name": "g", "type": "dielectric", "eta": [1.5, 1.2, 1.5], "roughness": {"range": [0.2, 0.4]}},
            {"type": "conductor", "ior": [0.27, 3.61], "alpha": 0.3},
        ],
    })
    assert sc["lookup_tol"] == 2e-3 and "tolerance" not in sc  # the lookup tolerance has its own name
    assert sc["lookup"] == {"interpolation": "linear", "spacings": ["square", "linear"]}
    g, c = sc["materials"]
    assert g["eta_axis"] == {"values": [1.2, 1.5]} and g["rough_name"] == "roughness"
    assert g["rough"] == {"range": [0.2, 0.4]}
    assert c["name"] == "materials[1]" and (c["eta"], c["k"]) == (0.27, 3.61)
    assert (c["distribution"], c["shadowing"]) == ("ggx", "correlated")


def test_lookup_tol_bounds():
    lo, hi = LOOKUP_TOL_RANGE
    assert check_lookup_tol(lo) == lo and check_lookup_tol(hi) == hi
    for bad in (lo / 2, hi * 2, float("nan"), float("inf"), "1e-3", True):
        with pytest.raises(SpecError) as info:
            check_lookup_tol(bad, "tol")
        assert info.value.param == "tol"


def test_toml_scene_is_the_json_scene():
    assert parse_scene(load_scene_file(EXAMPLES / "scene.toml")) == parse_scene(load_scene_file(EXAMPLES / "scene.json"))
    aniso = parse_scene(load_scene_file(EXAMPLES / "scene_aniso.toml"))
    assert aniso == parse_scene(load_scene_file(EXAMPLES / "scene_aniso.json"))
    brushed = aniso["materials"][0]
    assert brushed["type"] == "anisotropic" and brushed["aniso_axis"] == {"values": [0.6]}
    assert brushed["rough"] == {"values": [0.5]} and brushed["distribution"] == "ggx"


def test_scene_files_errors_are_one_line(tmp_path):
    for name, text, fragment in [("s.toml", "materials = [\n", "invalid TOML"), ("s.json", "{", "invalid JSON")]:
        path = tmp_path / name
        path.write_text(text)
        with pytest.raises(SpecError) as info:
            load_scene_file(path)
        assert fragment in str(info.value) and str(path) in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(SpecError) as info:
        load_scene_file(tmp_path / "missing.json")
    assert "not found" in str(info.value)


def test_is_scene():
    assert is_scene({"materials": []}) and not is_scene({"table": "albedo"}) and not is_scene([1])
