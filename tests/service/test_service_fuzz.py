"""Fuzz the service from its own OpenAPI schema (hypothesis): no input may produce a 5xx.

Every operation in ``/openapi.json`` is exercised with generated query strings (schema-valid
values, edge numbers such as NaN / inf / 1e400 / -0, comma lists, arbitrary text and unknown
parameter names) and, for ``POST /tables``, generated JSON bodies near the spec schema and
arbitrary bytes. A tiny texel limit keeps every accepted table cheap. The number of cases is
bounded (``BSDF_TAB_FUZZ_EXAMPLES``, default 120 per operation).
"""

from __future__ import annotations

import json
import os

import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

from bsdf_tab.spec import TABLE_KINDS  # noqa: E402
from service.app import create_app  # noqa: E402
from service.settings import Settings  # noqa: E402

EXAMPLES = int(os.environ.get("BSDF_TAB_FUZZ_EXAMPLES", "80"))
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)

_APP = None


def client() -> TestClient:
    global _APP
    if _APP is None:
        import tempfile

        folder = tempfile.mkdtemp(prefix="bsdf-tab-fuzz-")
        _APP = TestClient(create_app(Settings(cache_dir=folder, warmup=False, max_texels=8, max_body_bytes=4096, workers=1)))
    return _APP


def _schema() -> dict:
    return client().get("/openapi.json").json()


EDGE_NUMBERS = ["0", "-0", "1", "0.5", "1e-300", "1e400", "-1e400", "nan", "NaN", "inf", "-inf", "1e308", "4", "10", "-1", "2.0000001", ""]
numbers = st.one_of(
    st.sampled_from(EDGE_NUMBERS),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**6, 10**6).map(str),
)
number_lists = st.lists(st.one_of(st.sampled_from(EDGE_NUMBERS), st.floats(-2, 5).map(repr)), max_size=5).map(",".join)
junk = st.text(max_size=12)


def _value(schema: dict):
    kind = schema.get("type")
    if "enum" in schema:
        return st.one_of(st.sampled_from(schema["enum"]), junk)
    if kind == "integer":
        lo, hi = schema.get("minimum", -5), min(schema.get("maximum", 10), 6)
        return st.one_of(st.integers(lo - 2, hi + 2).map(str), st.sampled_from(["1e3", "2.5", "99999999999999999999", "-"]), junk)
    if kind == "number":
        return st.one_of(numbers, junk)
    return st.one_of(number_lists, numbers, junk)


def _valid(schema: dict):
    """A schema-valid value (most cases should compute, not only fail validation)."""
    if "enum" in schema:
        return st.sampled_from(schema["enum"])
    if schema.get("type") == "integer":
        return st.sampled_from(["1", "2"])
    if schema.get("type") == "number":
        return st.sampled_from(["0.5", "1", "0.04", "1.5", "0.001"])
    return st.sampled_from(["0.5", "0.2,0.9", "0,1"])


def _query(params: list[dict]):
    query_params = [p for p in params if p.get("in") == "query"]
    wild = {p["name"]: _value(p.get("schema", {})) for p in query_params}
    valid = {p["name"]: _valid(p.get("schema", {})) for p in query_params}
    names = sorted(wild)
    unknown = st.lists(st.tuples(st.text(min_size=1, max_size=8), junk), max_size=1)

    @st.composite
    def build(draw):
        if not names:
            return draw(unknown)
        if draw(st.booleans()):  # schema-valid values only
            picked = draw(st.lists(st.sampled_from(names), max_size=3, unique=True))
            return [(n, draw(valid[n])) for n in picked]
        picked = draw(st.lists(st.sampled_from(names), max_size=6, unique=True))
        return [(n, draw(wild[n])) for n in picked] + draw(unknown)

    return build()


def _operations():
    ops = []
    for path, item in _schema()["paths"].items():
        for method, op in item.items():
            ops.append((path, method, op))
    return ops


tables = st.one_of(st.sampled_from(sorted(TABLE_KINDS)), st.sampled_from(["", "nope", "ALBEDO", "albedo ", "%00", "a.b", "é"]))


def check(response) -> None:
    assert response.status_code < 500, (response.status_code, response.text[:500])
    if response.status_code >= 400 and response.headers.get("content-type", "").startswith("application/json"):
        body = response.json()["error"]
        assert body["message"] and "param" in body


def _get_ops():
    """GET operations that take query parameters (the others get one plain call below)."""
    return [(path, op) for path, method, op in _operations() if method == "get" and op.get("parameters")]


def test_parameterless_operations_answer():
    for path, method, op in _operations():
        if method == "get" and not op.get("parameters"):
            r = client().get(path)
            assert r.status_code < 500 and (r.status_code == 200 or path == "/"), (path, r.status_code)


def _tiny_axes(table: str) -> list[tuple[str, str]]:
    """One value per axis (mid default range), so that many cases pass the tiny texel limit."""
    from bsdf_tab.spec import AXIS_DEFAULTS

    if table not in TABLE_KINDS:
        return []
    out = []
    for a in TABLE_KINDS[table]["axes"]:
        lo, hi = AXIS_DEFAULTS[a]["range"]
        out.append((a, repr(0.5 * (lo + hi))))
    return out


@pytest.mark.parametrize("path", [p for p, _ in _get_ops()])
def test_fuzz_get_operations(path):
    op = dict(_get_ops())[path]
    statuses = []

    @FUZZ
    @given(table=tables, query=_query(op.get("parameters", [])), tiny=st.booleans())
    def run(table, query, tiny):
        url = path.replace("{table}", table) if "{table}" in path else path
        if tiny:  # fuzzed values given for an axis replace the tiny one
            fuzzed = {n for n, _ in query}
            query = [item for item in _tiny_axes(table) if item[0] not in fuzzed] + query
        r = client().get(url, params=query)
        statuses.append(r.status_code)
        check(r)

    run()
    if "{table}" in path:  # keyed paths (/tables/by-key/{key}) have their own fuzz below
        assert statuses.count(200) >= 2, sorted(set(statuses))  # the fuzz does reach computations


def _spec_like():
    axis = st.one_of(
        st.lists(st.one_of(st.floats(-1, 5), st.sampled_from([float("nan"), float("inf"), 0, 1, 1e300])), max_size=4),
        st.fixed_dictionaries(
            {},
            optional={
                "size": st.one_of(st.integers(-1, 4), st.just(10**30), st.floats(0, 3)),
                "spacing": st.sampled_from(["linear", "square", "log", 3]),
                "nodes": st.sampled_from(["endpoints", "centers", None]),
                "range": st.lists(st.floats(-2, 5), max_size=3),
                "clamp": st.one_of(st.none(), st.lists(st.floats(-1, 2), max_size=3)),
                "values": st.lists(st.floats(0, 1), max_size=3),
            },
        ),
        st.integers(),
        st.text(max_size=3),
    )
    axes = st.dictionaries(st.sampled_from(["mu", "alpha", "roughness", "eta", "x"]), axis, max_size=3)
    fresnel = st.one_of(
        st.sampled_from(["one", "schlick", "bogus"]),
        st.fixed_dictionaries(
            {},
            optional={
                "type": st.sampled_from(["one", "schlick", "dielectric", "conductor", "x"]),
                "f0": st.one_of(st.floats(allow_nan=True), st.text(max_size=2)),
                "eta": st.floats(allow_nan=True, allow_infinity=True),
                "k": st.floats(allow_nan=True, allow_infinity=True),
            },
        ),
        st.none(),
    )
    return st.fixed_dictionaries(
        {"table": st.one_of(st.sampled_from(sorted(TABLE_KINDS)), st.text(max_size=4), st.integers())},
        optional={
            "distribution": st.sampled_from(["ggx", "beckmann", "phong", None]),
            "shadowing": st.sampled_from(["correlated", "separable", 1]),
            "fresnel": fresnel,
            "axes": st.one_of(axes, st.lists(st.integers(), max_size=2)),
            "tolerance": st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=3)),
            "method": st.sampled_from(["adaptive", "mc"]),
            "extra": st.integers(),
        },
    )


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
    lambda children: st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=5), children, max_size=3),
    max_leaves=10,
)


@FUZZ
@given(
    body=st.one_of(
        _spec_like().map(lambda d: json.dumps(d).encode()),
        json_values.map(lambda v: json.dumps(v).encode()),
        st.binary(max_size=64),
    ),
    fmt=st.one_of(st.none(), st.sampled_from(["exr", "npz", "npy", "json", "xml", ""])),
    accept=st.one_of(st.none(), st.sampled_from(["*/*", "text/html", "application/json;q=0", "image/*;q=abc", ""])),
)
def test_fuzz_post_tables(body, fmt, accept):
    headers = {"Content-Type": "application/json"}
    if accept is not None:
        headers["Accept"] = accept
    params = {"format": fmt} if fmt is not None else None
    check(client().post("/tables", content=body, params=params, headers=headers))


def _scene_like():
    number = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0, 1, 0.3, 1.5, -1, 1e300]),
                       st.text(max_size=3))
    values = st.one_of(number, st.lists(number, max_size=3),
                       st.fixed_dictionaries({"range": st.lists(number, max_size=3)}), json_values)
    material = st.fixed_dictionaries(
        {"type": st.one_of(st.sampled_from(["conductor", "dielectric", "schlick"]), json_values)},
        optional={
            "name": st.one_of(st.text(max_size=4), st.integers()),
            "distribution": st.sampled_from(["ggx", "beckmann", "phong"]),
            "shadowing": st.sampled_from(["correlated", "separable", 1]),
            "alpha": values, "roughness": values, "eta": values, "k": number,
            "ior": st.lists(number, max_size=3), "f0": st.one_of(number, st.lists(number, max_size=4)),
            "extra": st.integers(),
        },
    )
    lookup = st.one_of(json_values, st.fixed_dictionaries({}, optional={
        "interpolation": st.sampled_from(["linear", "nearest", "cubic", 3]),
        "spacings": st.one_of(st.lists(st.sampled_from(["linear", "square", "sqrt", "log"]), max_size=3), json_values)}))
    return st.fixed_dictionaries(
        {"materials": st.one_of(st.lists(material, max_size=3), json_values)},
        optional={"lookup": lookup, "tolerance": number, "name": json_values, "x": st.integers()},
    )


TINY_SCENE = {"tolerance": 0.05, "materials": [{"name": "steel", "type": "conductor", "eta": 2.5, "k": 3.0, "alpha": 0.3}]}


@settings(FUZZ, max_examples=max(EXAMPLES // 2, 10))
@given(
    body=st.one_of(
        st.just(json.dumps(TINY_SCENE).encode()),  # a valid scene: only the query is fuzzed
        _scene_like().map(lambda d: json.dumps(d).encode()),
        json_values.map(lambda v: json.dumps(v).encode()),
        st.binary(max_size=64),
    ),
    tol=st.one_of(st.none(), st.sampled_from(["1e-2", "0.05", "1e-5"] + EDGE_NUMBERS), numbers, junk),
)
def test_fuzz_post_scenes(body, tol):
    params = {"tol": tol} if tol is not None else None
    r = client().post("/scenes", content=body, params=params, headers={"Content-Type": "application/json"})
    SCENE_STATUSES.add(r.status_code)
    check(r)


SCENE_STATUSES: set = set()


def test_fuzz_post_scenes_reached_the_planner():
    if not SCENE_STATUSES:
        test_fuzz_post_scenes()
    assert {200, 413} & SCENE_STATUSES, SCENE_STATUSES  # valid scenes were planned, not only rejected


# ------------------------------------------------------------------ jobs and keyed results (issue 12)

JOB_STATUSES: set = set()


@settings(FUZZ, max_examples=max(EXAMPLES // 2, 10))
@given(
    body=st.one_of(
        st.just({"spec": {"table": "albedo", "axes": {"mu": [0.5], "alpha": [0.25, 0.5]}}}),  # valid: runs
        st.just({"scene": TINY_SCENE, "tol": 0.05}),
        _spec_like().map(lambda d: {"spec": d}),
        _scene_like().map(lambda d: {"scene": d}),
        st.tuples(st.just(TINY_SCENE), st.one_of(numbers, junk, json_values)).map(lambda t: {"scene": t[0], "tol": t[1]}),
        st.dictionaries(st.sampled_from(["spec", "scene", "tol", "x"]), json_values, max_size=3),
        json_values,
    ).map(lambda v: json.dumps(v).encode()) | st.binary(max_size=64),
    query=st.one_of(st.none(), st.just({"x": "1"})),
)
def test_fuzz_post_jobs(body, query):
    r = client().post("/jobs", content=body, params=query, headers={"Content-Type": "application/json"})
    JOB_STATUSES.add(r.status_code)
    check(r)
    if r.status_code == 202:
        job = r.json()
        assert r.headers["location"] == f"/jobs/{job['id']}"
        check(client().get(f"/jobs/{job['id']}"))


ids = st.one_of(st.text(max_size=70), st.sampled_from(["0" * 32, "f" * 32, "v0-" + "0" * 64, "x.scene", "%2e%2e", "a" * 300]),
                st.binary(max_size=40).map(lambda b: b.hex()))


@FUZZ
@given(ident=ids, method=st.sampled_from(["get", "delete"]),
       path=st.sampled_from(["/jobs/{}", "/tables/by-key/{}", "/scenes/by-key/{}"]))
def test_fuzz_job_ids_and_keys(ident, method, path):
    from urllib.parse import quote

    url = path.format(quote(ident, safe=""))
    r = getattr(client(), method)(url)
    check(r)


def test_fuzz_post_jobs_reached_the_runner():
    if not JOB_STATUSES:
        test_fuzz_post_jobs()
    assert 202 in JOB_STATUSES and 400 in JOB_STATUSES, JOB_STATUSES
