"""Tests of bsdf_tab.spec: validation, normalization, hashing, axis resolution."""

import json
import math

import numpy as np
import pytest

from bsdf_tab.errors import SpecError
from bsdf_tab.spec import (
    METHODS,
    TABLE_KINDS,
    alpha_values,
    channel_names,
    normalize_spec,
    resolve_axes,
    spec_hash,
    texel_count,
)

EXAMPLE = {
    "table": "albedo",
    "distribution": "ggx",
    "shadowing": "correlated",
    "fresnel": {"type": "one"},
    "axes": {"mu": [0.1, 0.5, 1.0], "alpha": [0.05, 0.3]},
}


def spec_error(spec) -> SpecError:
    with pytest.raises(SpecError) as info:
        normalize_spec(spec)
    return info.value


# --------------------------------------------------------------------------- errors


def test_spec_error_str_and_attributes():
    err = SpecError("fresnel.eta", "must be > 0")
    assert str(err) == "fresnel.eta: must be > 0"
    assert (err.param, err.message) == ("fresnel.eta", "must be > 0")
    assert isinstance(err, ValueError)
    assert str(SpecError(None, "bad")) == "bad"


# --------------------------------------------------------------------------- defaults


def test_defaults_filled_for_minimal_spec():
    n = normalize_spec({"table": "albedo"})
    assert n["distribution"] == "ggx"
    assert n["shadowing"] == "correlated"
    assert n["fresnel"] == {"type": "one"}
    assert n["method"] == "adaptive"
    assert n["tolerance"] == 5e-7
    assert list(n["axes"]) == ["mu", "alpha"]
    default = {"size": 32, "spacing": "linear", "nodes": "endpoints", "range": [0.0, 1.0], "clamp": None}
    assert n["axes"]["mu"] == default
    assert n["axes"]["alpha"] == default


def test_default_eta_axis_and_dielectric_fresnel():
    n = normalize_spec({"table": "dielectric"})
    assert list(n["axes"]) == ["mu", "alpha", "eta"]
    assert n["axes"]["eta"]["size"] == 16
    assert n["axes"]["eta"]["range"] == [1.01, 4.0]
    assert n["fresnel"] == {"type": "dielectric"}
    eta = resolve_axes(n)["eta"]
    assert eta[0] == 1.01 and eta[-1] == 4.0 and len(eta) == 16


def test_explicit_axes_normalized_to_values_as_floats():
    n = normalize_spec({"table": "albedo", "axes": {"mu": [0, 1], "alpha": [1]}})
    assert n["axes"]["mu"] == {"values": [0.0, 1.0]}
    assert all(type(v) is float for v in n["axes"]["mu"]["values"])


@pytest.mark.parametrize("kind", sorted(TABLE_KINDS))
def test_every_kind_normalizes_and_is_idempotent(kind):
    n = normalize_spec({"table": kind})
    assert normalize_spec(n) == n
    assert normalize_spec(json.dumps(n)) == n
    assert list(n["axes"]) == list(TABLE_KINDS[kind]["axes"])


def test_idempotent_with_every_axis_form():
    spec = {
        "table": "dfg",
        "axes": {
            "mu": {"size": 8, "spacing": "square", "nodes": "centers"},
            "roughness": {"size": 5, "clamp": [1e-4, 1]},
        },
        "tolerance": 1e-6,
    }
    n = normalize_spec(spec)
    assert normalize_spec(n) == n
    assert n["axes"]["roughness"]["clamp"] == [1e-4, 1.0]
    assert n is not spec and "distribution" not in spec  # input not modified


def test_normalize_does_not_mutate_input():
    spec = json.loads(json.dumps(EXAMPLE))
    normalize_spec(spec)
    assert spec == EXAMPLE


def test_fresnel_forms():
    assert normalize_spec({"table": "albedo", "fresnel": {"type": "schlick", "f0": 0.04}})["fresnel"] == {
        "type": "schlick",
        "f0": 0.04,
    }
    conductor = {"type": "conductor", "eta": 0.2, "k": 3}
    assert normalize_spec({"table": "albedo_avg", "fresnel": conductor})["fresnel"] == {
        "type": "conductor",
        "eta": 0.2,
        "k": 3.0,
    }
    assert normalize_spec({"table": "dielectric_avg", "fresnel": {"type": "dielectric"}})["fresnel"] == {
        "type": "dielectric"
    }
    assert normalize_spec({"table": "dfg", "fresnel": {"type": "one"}})["fresnel"] == {"type": "one"}


# --------------------------------------------------------------------------- hashing


def test_hash_equal_under_defaults_and_key_order():
    explicit = dict(EXAMPLE, method="adaptive", tolerance=5e-7)
    reordered = {k: explicit[k] for k in reversed(list(explicit))}
    reordered["axes"] = {"alpha": [0.05, 0.3], "mu": [0.1, 0.5, 1]}
    minimal = {"table": "albedo", "axes": {"mu": [0.1, 0.5, 1.0], "alpha": [0.05, 0.3]}}
    h = spec_hash(EXAMPLE)
    assert len(h) == 64 and int(h, 16) >= 0
    assert spec_hash(reordered) == h
    assert spec_hash(minimal) == h
    assert spec_hash(json.dumps(minimal)) == h
    assert spec_hash(normalize_spec(minimal)) == h


def test_hash_of_default_axis_equals_its_explicit_resolution_dict():
    a = {"table": "albedo_avg"}
    b = {"table": "albedo_avg", "axes": {"alpha": {"size": 32, "range": [0, 1], "clamp": None}}}
    assert spec_hash(a) == spec_hash(b)


@pytest.mark.parametrize(
    "change",
    [
        {"distribution": "beckmann"},
        {"shadowing": "separable"},
        {"tolerance": 1e-6},
        {"axes": {"mu": [0.1, 0.5, 0.9], "alpha": [0.05, 0.3]}},
        {"axes": {"mu": [0.1, 0.5, 1.0], "roughness": [0.05, 0.3]}},
        {"fresnel": {"type": "schlick", "f0": 0.04}},
    ],
)
def test_hash_differs_when_the_table_differs(change):
    assert spec_hash(dict(EXAMPLE, **change)) != spec_hash(EXAMPLE)


# --------------------------------------------------------------------------- bad input

BAD = [
    ({"table": "albedoo"}, "table"),
    ({}, "table"),
    ({"table": 3}, "table"),
    ({"table": "albedo", "colour": 1}, "colour"),
    ({"table": "albedo", "distribution": "phongg"}, "distribution"),
    ({"table": "albedo", "shadowing": "height"}, "shadowing"),
    ({"table": "albedo", "method": "magic"}, "method"),
    ({"table": "albedo", "axes": {"eta": [1.5]}}, "axes.eta"),
    ({"table": "albedo_avg", "axes": {"mu": [0.5]}}, "axes.mu"),
    ({"table": "albedo", "axes": {"alpha": [-0.1, 0.5]}}, "axes.alpha"),
    ({"table": "albedo", "axes": {"alpha": [0.1, 4.5]}}, "axes.alpha"),
    ({"table": "albedo", "axes": {"roughness": [0.1, 2.5]}}, "axes.roughness"),
    ({"table": "albedo", "axes": {"mu": [0.5, 1.5]}}, "axes.mu"),
    ({"table": "dielectric", "axes": {"eta": [0.0, 1.5]}}, "axes.eta"),
    ({"table": "dielectric", "axes": {"eta": [-1.0]}}, "axes.eta"),
    ({"table": "dielectric", "axes": {"eta": [101.0]}}, "axes.eta"),
    ({"table": "albedo", "axes": {"alpha": [0.1, float("nan")]}}, "axes.alpha"),
    ({"table": "albedo", "axes": {"mu": [0.1, float("inf")]}}, "axes.mu"),
    ({"table": "albedo", "axes": {"mu": [True, 0.5]}}, "axes.mu"),
    ({"table": "albedo", "axes": {"mu": ["0.5"]}}, "axes.mu"),
    ({"table": "albedo", "axes": {"mu": []}}, "axes.mu"),
    ({"table": "albedo", "axes": {"mu": [0.5, 0.2]}}, "axes.mu"),
    ({"table": "albedo", "axes": {"mu": [0.2, 0.2]}}, "axes.mu"),
    ({"table": "albedo", "axes": {"mu": {"size": 5, "clamp": [0.0, 0.5]}}}, "axes.mu"),
    ({"table": "albedo", "axes": {"mu": {"size": 0}}}, "axes.mu.size"),
    ({"table": "albedo", "axes": {"mu": {"size": 4097}}}, "axes.mu.size"),
    ({"table": "albedo", "axes": {"mu": {"size": 4.0}}}, "axes.mu.size"),
    ({"table": "albedo", "axes": {"mu": {"size": True}}}, "axes.mu.size"),
    ({"table": "albedo", "axes": {"mu": {"spacing": "linear"}}}, "axes.mu.size"),
    ({"table": "albedo", "axes": {"mu": {"size": 4, "spacing": "log"}}}, "axes.mu.spacing"),
    ({"table": "albedo", "axes": {"mu": {"size": 4, "nodes": "middle"}}}, "axes.mu.nodes"),
    ({"table": "albedo", "axes": {"mu": {"size": 4, "range": [0.5]}}}, "axes.mu.range"),
    ({"table": "albedo", "axes": {"mu": {"size": 4, "range": [1, 0]}}}, "axes.mu.range"),
    ({"table": "albedo", "axes": {"mu": {"size": 4, "range": [0, float("nan")]}}}, "axes.mu.range"),
    ({"table": "albedo", "axes": {"mu": {"size": 4, "clamp": [0, float("inf")]}}}, "axes.mu.clamp"),
    ({"table": "albedo", "axes": {"mu": {"size": 4, "step": 1}}}, "axes.mu.step"),
    ({"table": "albedo", "axes": {"alpha": [0.1], "roughness": [0.1]}}, "axes"),
    ({"table": "albedo", "axes": [0.1]}, "axes"),
    ({"table": "albedo", "axes": {"mu": [0.5] * 4097}}, "axes.mu"),
    ({"table": "albedo", "fresnel": {"type": "glass"}}, "fresnel.type"),
    ({"table": "albedo", "fresnel": {"type": "schlick"}}, "fresnel.f0"),
    ({"table": "albedo", "fresnel": {"type": "schlick", "f0": 1.5}}, "fresnel.f0"),
    ({"table": "albedo", "fresnel": {"type": "dielectric", "eta": 0.0}}, "fresnel.eta"),
    ({"table": "albedo", "fresnel": {"type": "dielectric", "eta": -1.5}}, "fresnel.eta"),
    ({"table": "albedo", "fresnel": {"type": "dielectric", "eta": float("nan")}}, "fresnel.eta"),
    ({"table": "albedo", "fresnel": {"type": "dielectric", "eta": True}}, "fresnel.eta"),
    ({"table": "albedo", "fresnel": {"type": "conductor", "eta": 0.2, "k": -1}}, "fresnel.k"),
    ({"table": "albedo", "fresnel": {"type": "one", "f0": 0.04}}, "fresnel.f0"),
    ({"table": "dielectric", "fresnel": {"type": "dielectric", "eta": 1.5}}, "fresnel.eta"),
    ({"table": "dielectric", "fresnel": {"type": "one"}}, "fresnel.type"),
    ({"table": "dfg", "fresnel": {"type": "schlick", "f0": 0.04}}, "fresnel.type"),
    ({"table": "albedo", "tolerance": 0.0}, "tolerance"),
    ({"table": "albedo", "tolerance": 0.5}, "tolerance"),
    ({"table": "albedo", "tolerance": float("nan")}, "tolerance"),
    ({"table": "albedo", "tolerance": True}, "tolerance"),
    ({"table": "albedo", "tolerance": "1e-6"}, "tolerance"),
    ("{not json", None),
    ("[1, 2]", None),
    ([{"table": "albedo"}], None),
]


@pytest.mark.parametrize("spec,param", BAD, ids=[f"{i}-{p}" for i, (_, p) in enumerate(BAD)])
def test_bad_input_raises_spec_error_naming_param(spec, param):
    err = spec_error(spec)
    assert err.param == param
    assert err.message and "\n" not in str(err)


def test_messages_say_what_is_allowed():
    msg = str(spec_error({"table": "x"}))
    assert "must be one of" in msg
    assert all(kind in msg for kind in ("albedo", "albedo_avg", "dfg", "dielectric", "dielectric_avg"))
    assert "must be > 0" in str(spec_error({"table": "albedo", "fresnel": {"type": "dielectric", "eta": 0}}))
    assert "finite" in str(spec_error({"table": "albedo", "axes": {"mu": [float("nan")]}}))
    assert "strictly increasing" in str(spec_error({"table": "albedo", "axes": {"mu": [0.5, 0.2]}}))
    unknown_axis = str(spec_error({"table": "albedo", "axes": {"eta": [1.5]}}))
    assert "mu" in unknown_axis and "alpha" in unknown_axis and "roughness" in unknown_axis
    assert "clamp" in str(spec_error({"table": "albedo", "axes": {"mu": {"size": 5, "clamp": [0.0, 0.5]}}}))


def test_nan_in_json_string_rejected():
    err = spec_error('{"table": "albedo", "axes": {"mu": [NaN]}}')
    assert err.param == "axes.mu"


def test_methods_set_is_extensible():
    METHODS.add("test-only-method")
    try:
        assert normalize_spec({"table": "albedo", "method": "test-only-method"})["method"] == "test-only-method"
    finally:
        METHODS.discard("test-only-method")
    assert spec_error({"table": "albedo", "method": "test-only-method"}).param == "method"


# --------------------------------------------------------------------------- axis resolution


def axes_of(axes, table="albedo"):
    return resolve_axes({"table": table, "axes": axes})


def test_linear_endpoints():
    mu = axes_of({"mu": {"size": 5}})["mu"]
    np.testing.assert_array_equal(mu, [0.0, 0.25, 0.5, 0.75, 1.0])
    assert mu.dtype == np.float64


def test_linear_endpoints_with_range_hits_ends_exactly():
    eta = resolve_axes({"table": "dielectric_avg", "axes": {"eta": {"size": 4, "range": [1.1, 2.0]}}})["eta"]
    np.testing.assert_allclose(eta, [1.1, 1.4, 1.7, 2.0], rtol=0, atol=1e-15)
    assert eta[0] == 1.1 and eta[-1] == 2.0


def test_linear_centers():
    mu = axes_of({"mu": {"size": 4, "nodes": "centers"}})["mu"]
    np.testing.assert_allclose(mu, [0.125, 0.375, 0.625, 0.875], rtol=0, atol=1e-15)


def test_size_one():
    assert axes_of({"mu": {"size": 1}})["mu"].tolist() == [0.0]
    assert axes_of({"mu": {"size": 1, "nodes": "centers"}})["mu"].tolist() == [0.5]


def test_square_spacing_endpoints_and_centers():
    mu = axes_of({"mu": {"size": 3, "spacing": "square"}})["mu"]
    np.testing.assert_allclose(mu, [0.0, 0.25, 1.0], rtol=0, atol=1e-15)
    mu = axes_of({"mu": {"size": 2, "spacing": "square", "nodes": "centers"}})["mu"]
    np.testing.assert_allclose(mu, [0.0625, 0.5625], rtol=0, atol=1e-15)
    # (sqrt(0.04) + (sqrt(0.64) - sqrt(0.04)) t)^2 with t = 0, 1/2, 1 -> 0.04, 0.25, 0.64
    mu = axes_of({"mu": {"size": 3, "spacing": "square", "range": [0.04, 0.64]}})["mu"]
    np.testing.assert_allclose(mu, [0.04, 0.25, 0.64], rtol=0, atol=1e-15)
    assert mu[0] == 0.04 and mu[-1] == 0.64


def test_clamp_cycles_style():
    a = axes_of({"alpha": {"size": 3, "clamp": [1e-4, 1.0]}})["alpha"]
    assert a.tolist() == [1e-4, 0.5, 1.0]


def test_explicit_values_exact():
    axes = axes_of({"mu": [0.1, 0.5, 1.0], "alpha": [0.05, 0.3]})
    assert list(axes) == ["mu", "alpha"]
    assert axes["mu"].tolist() == [0.1, 0.5, 1.0]
    assert axes["alpha"].tolist() == [0.05, 0.3]


def test_axis_order_follows_table_not_input():
    axes = resolve_axes({"table": "dielectric", "axes": {"eta": [1.5], "roughness": [0.5], "mu": [1.0]}})
    assert list(axes) == ["mu", "roughness", "eta"]


def test_roughness_to_alpha():
    axes = axes_of({"roughness": {"size": 3}})
    assert "roughness" in axes and "alpha" not in axes
    np.testing.assert_allclose(alpha_values(axes), [0.0, 0.25, 1.0], rtol=0, atol=1e-15)
    direct = axes_of({"alpha": [0.01, 0.2]})
    assert alpha_values(direct).tolist() == [0.01, 0.2]
    with pytest.raises(KeyError):
        alpha_values({"mu": np.array([0.5])})


def test_texel_count():
    assert texel_count({"table": "albedo"}) == 32 * 32
    assert texel_count({"table": "dielectric"}) == 32 * 32 * 16
    assert texel_count({"table": "albedo_avg", "axes": {"alpha": [0.1, 0.2, 0.3]}}) == 3
    spec = {"table": "dielectric_avg", "axes": {"alpha": {"size": 7}, "eta": [1.5, 2.0]}}
    assert texel_count(normalize_spec(spec)) == 14


def test_channel_names():
    assert channel_names("dielectric") == ["R", "T"]
    assert channel_names("albedo", errors=True) == ["E", "E_err"]
    with pytest.raises(SpecError):
        channel_names("nope")


def test_resolved_values_within_domain_for_defaults():
    for kind in TABLE_KINDS:
        for name, values in resolve_axes({"table": kind}).items():
            assert np.all(np.diff(values) > 0), (kind, name)
            assert all(math.isfinite(v) for v in values)


# --------------------------------------------------------------------------- kind keys (declared by a kind)


def test_kind_keys_declared_validated_defaulted():
    """Every key a kind declares: each choice accepted and kept, the default filled in (so it is in
    the hash), a bad value names the key, and every other kind rejects it naming it."""
    from bsdf_tab.spec import KIND_OPTIONS

    assert KIND_OPTIONS, "no kind declares a key (the sheen kinds declare sheen_shadowing)"
    for kind, keys in KIND_OPTIONS.items():
        for name, decl in keys.items():
            assert normalize_spec({"table": kind})[name] == decl["default"]
            hashes = set()
            for value in decl["choices"]:
                n = normalize_spec({"table": kind, name: value})
                assert n[name] == value and normalize_spec(n) == n
                hashes.add(spec_hash(n))
            assert len(hashes) == len(decl["choices"])  # the cache key tells the choices apart
            assert spec_error({"table": kind, name: "no-such-choice"}).param == name
            assert spec_error({"table": kind, name: 3}).param == name
            for other in TABLE_KINDS:
                if name not in KIND_OPTIONS.get(other, {}):
                    assert spec_error({"table": other, name: decl["default"]}).param == name


def test_sheen_shadowing_key_and_its_older_spelling():
    new = normalize_spec({"table": "sheen_albedo", "sheen_shadowing": "exact"})
    old = normalize_spec({"table": "sheen_albedo", "parametrization": "exact"})
    assert new == old and "parametrization" not in new and spec_hash(new) == spec_hash(old)
    assert spec_hash(new) != spec_hash({"table": "sheen_albedo"})  # default fitted
    assert normalize_spec({"table": "sheen_albedo"})["sheen_shadowing"] == "fitted"
    assert spec_error({"table": "sheen_albedo", "parametrization": "smith"}).param == "parametrization"
    err = spec_error({"table": "sheen_albedo_avg", "parametrization": "exact", "sheen_shadowing": "fitted"})
    assert err.param == "parametrization" and "sheen_shadowing" in str(err)
    # agreeing spellings are fine; other kinds keep their own parametrization
    assert normalize_spec({"table": "sheen_albedo", "parametrization": "exact", "sheen_shadowing": "exact"}) == new
    assert normalize_spec({"table": "bsdf", "parametrization": "half_diff"})["parametrization"] == "half_diff"
    assert spec_error({"table": "albedo", "parametrization": "exact"}).param == "parametrization"


def test_kind_keys_one_generic_path(monkeypatch):
    """A new kind declaring its own key gets validation with no change in spec.py."""
    import bsdf_tab.spec as spec_mod

    fake = dict(TABLE_KINDS["albedo"])
    fake["keys"] = {"weave": {"choices": ("plain", "twill"), "default": "plain", "description": "test"}}
    kinds = dict(TABLE_KINDS, fake_kind=fake)
    options = dict(spec_mod.KIND_OPTIONS, fake_kind=fake["keys"])
    monkeypatch.setattr(spec_mod, "TABLE_KINDS", kinds)
    monkeypatch.setattr(spec_mod, "KIND_OPTIONS", options)
    monkeypatch.setattr(spec_mod, "KIND_OPTION_KEYS", tuple(sorted(set(spec_mod.KIND_OPTION_KEYS) | {"weave"})))
    assert spec_mod.normalize_spec({"table": "fake_kind"})["weave"] == "plain"
    assert spec_mod.normalize_spec({"table": "fake_kind", "weave": "twill"})["weave"] == "twill"
    with pytest.raises(SpecError) as info:
        spec_mod.normalize_spec({"table": "fake_kind", "weave": "satin"})
    assert info.value.param == "weave"
    with pytest.raises(SpecError) as info:
        spec_mod.normalize_spec({"table": "albedo", "weave": "plain"})
    assert info.value.param == "weave" and "fake_kind" in str(info.value)


@pytest.mark.parametrize("axis, param", [
    ({"size": 4, "range": [0.0, 2.0]}, "axes.mu.range"),  # a resolution: its range is what was given
    ({"size": 3, "range": [-1.0, 1.0]}, "axes.mu.range"),
    ([0.5, 2.0], "axes.mu"),  # explicit values: the values
])
def test_nodes_outside_the_domain_name_what_was_given(axis, param):
    with pytest.raises(SpecError) as info:
        resolve_axes(normalize_spec({"table": "albedo", "axes": {"mu": axis}}))
    assert info.value.param == param
    if param.endswith("range"):
        assert repr(axis["range"]) in info.value.message and "[0, 1]" in info.value.message


# --------------------------------------------------------------------------- fixed-rule kinds (audit M1)

FIXED_RULE_KINDS = ("sheen_albedo", "sheen_albedo_avg", "albedo_aniso")


@pytest.mark.parametrize("kind", FIXED_RULE_KINDS)
def test_fixed_rule_kinds_ignore_tolerance_and_do_not_fork_the_hash(kind):
    """gauss_kronrod is a fixed G7-K15 rule: a tolerance does not change the table, so it must not
    change the spec (nor its hash: one cache entry per table) nor echo a target the rule never met."""
    plain = normalize_spec({"table": kind})
    assert plain["method"] == "gauss_kronrod"
    for tol in (1e-2, 1e-11):
        given = normalize_spec({"table": kind, "tolerance": tol})
        # the ignored value is never echoed: the spec holds the default placeholder or no tolerance at all
        assert given == plain and given.get("tolerance", 5e-7) == 5e-7
        assert spec_hash({"table": kind, "tolerance": tol}) == spec_hash({"table": kind})
    assert normalize_spec(plain) == plain  # idempotent
    # still range-checked: a query valid for one kind is valid for all, and a bad one is refused
    assert spec_error({"table": kind, "tolerance": 0.5}).param == "tolerance"


def test_adaptive_tolerance_is_part_of_the_spec():
    a = normalize_spec({"table": "albedo", "tolerance": 1e-3})
    assert a["tolerance"] == 1e-3
    assert spec_hash({"table": "albedo", "tolerance": 1e-3}) != spec_hash({"table": "albedo"})


@pytest.mark.parametrize("kind", FIXED_RULE_KINDS)
def test_effort_on_a_fixed_rule_gives_correct_advice(kind):
    err = spec_error({"table": kind, "effort": 64})
    assert err.param == "effort"
    assert "give tolerance" not in err.message  # the old advice: tolerance does nothing for these kinds
    assert "fixed" in err.message and "_err" in err.message
    assert len(str(err).splitlines()) == 1


def test_effort_advice_for_adaptive_and_point():
    assert "give tolerance" in spec_error({"table": "albedo", "effort": 64}).message
    msg = spec_error({"table": "bsdf", "effort": 64}).message
    assert "give tolerance" not in msg and "point" in msg
