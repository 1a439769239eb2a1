"""HTTP service: every endpoint and every error, through FastAPI's TestClient (tiny tables)."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from bsdf_tab import Table, normalize_spec, spec_hash, __version__  # noqa: E402
from bsdf_tab.table import Table  # noqa: E402
from service.app import create_app  # noqa: E402
from service.settings import Settings  # noqa: E402

SMALL = "mu=0.2,0.6,1&alpha_size=3"
SMALL_SPEC = {"table": "albedo", "axes": {"mu": [0.2, 0.6, 1.0], "alpha": {"size": 3}}}


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    settings = Settings(
        cache_dir=tmp_path_factory.mktemp("svc-cache"), warmup=False, max_texels=64, max_body_bytes=2048, workers=2
    )
    with TestClient(create_app(settings)) as c:
        yield c


def err(r, status, param=None, query_param=None):
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/json")
    body = r.json()["error"]
    assert body["status"] == status and body["message"]
    if param is not None:
        assert body["param"] == param, body
    if query_param is not None:
        assert body.get("query_param") == query_param, body
    return body


# ------------------------------------------------------------------ catalog, health, docs


def test_healthz(client):
    r = client.get("/healthz")
    assert r.status_code == 200
    h = r.json()
    assert h["status"] == "ok" and h["version"] == __version__
    assert {"computations", "computing", "queued", "cache"} <= set(h)
    assert r.headers["cache-control"] == "no-store"


def test_catalog_lists_tables_params_ranges_defaults_limits(client):
    cat = client.get("/tables").json()
    assert {"albedo", "albedo_avg", "dielectric", "dielectric_avg", "dfg"} <= set(cat["tables"])
    albedo = cat["tables"]["albedo"]
    assert [a["name"] for a in albedo["axes"]] == ["mu", "alpha"]
    mu = albedo["axes"][0]
    assert mu["domain"]["min"] == 0.0 and mu["domain"]["max"] == 1.0
    assert mu["default"]["size"] == 32
    assert albedo["channels"] == ["E"] and albedo["error_channels"] == ["E_err"]
    assert cat["parameters"]["distribution"]["enum"] == ["beckmann", "ggx"]
    assert cat["parameters"]["tolerance"]["default"] > 0
    assert cat["limits"]["max_texels"] == 64
    assert cat["tables"]["dielectric"]["fresnel"]["types"] == ["dielectric"]


def test_openapi_and_docs(client):
    schema = client.get("/openapi.json").json()
    params = {p["name"] for p in schema["paths"]["/tables/{table}"]["get"]["parameters"]}
    assert {"table", "mu", "mu_size", "alpha_spacing", "fresnel", "fresnel_f0", "format"} <= params
    assert "requestBody" in schema["paths"]["/tables"]["post"]
    docs = client.get("/docs")
    assert docs.status_code == 200 and "swagger" in docs.text.lower()


# ------------------------------------------------------------------ tables


def test_get_table_exr_by_default(client):
    r = client.get(f"/tables/albedo?{SMALL}")
    assert r.status_code == 200
    assert r.headers["content-type"] == "image/x-exr"
    assert int(r.headers["content-length"]) == len(r.content)
    assert r.content[:4] == b"\x76\x2f\x31\x01"
    table = Table.from_bytes(r.content, "exr")
    assert table.shape == (3, 3)
    np.testing.assert_array_equal(table.axes["mu"], [0.2, 0.6, 1.0])
    assert 0.0 < float(table.channels["E"].min()) and float(table.channels["E"].max()) <= 1.0 + 1e-6
    key = f"v{__version__}-{spec_hash(normalize_spec(SMALL_SPEC))}"
    assert r.headers["etag"] == f'"{key}.exr"'
    assert "max-age" in r.headers["cache-control"] and "public" in r.headers["cache-control"]
    assert r.headers["vary"] == "Accept"
    assert r.headers["x-bsdf-tab-axes"] == "mu,alpha"


@pytest.mark.parametrize(
    "how, fmt, ctype",
    [
        ("format=npz", "npz", "application/x-npz"),
        ("format=npy", "npy", "application/x-npy"),
        ("format=json", "json", "application/json"),
        ("accept:application/json", "json", "application/json"),
        ("accept:application/x-npz", "npz", "application/x-npz"),
        ("accept:application/x-npy;q=0.9, image/x-exr;q=0.5", "npy", "application/x-npy"),
        ("accept:text/html, */*;q=0.1", "exr", "image/x-exr"),
    ],
)
def test_formats_by_query_or_accept(client, how, fmt, ctype):
    if how.startswith("accept:"):
        r = client.get(f"/tables/albedo?{SMALL}", headers={"Accept": how[7:]})
    else:
        r = client.get(f"/tables/albedo?{SMALL}&{how}")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == ctype
    assert r.headers["etag"].endswith(f'.{fmt}"')
    if fmt == "npz":
        t = Table.from_npz_bytes(r.content)
        assert t.shape == (3, 3) and t.meta["spec"]["table"] == "albedo"
    elif fmt == "npy":
        arr = np.load(io.BytesIO(r.content), allow_pickle=False)
        assert arr.shape == (3, 3) and arr.dtype.names == ("E", "E_err")
    elif fmt == "json":
        d = r.json()
        assert d["shape"] == [3, 3] and d["axes"]["mu"] == [0.2, 0.6, 1.0] and "E" in d["channels"]
        assert d["meta"]["conventions"]["distribution"] == "ggx"


def test_formats_agree(client):
    exr = Table.from_bytes(client.get(f"/tables/albedo?{SMALL}").content, "exr")
    npz = Table.from_npz_bytes(client.get(f"/tables/albedo?{SMALL}&format=npz").content)
    js = client.get(f"/tables/albedo?{SMALL}&format=json").json()
    np.testing.assert_array_equal(exr.channels["E"], npz.channels["E"].astype(np.float32))
    np.testing.assert_array_equal(np.asarray(js["channels"]["E"]), npz.channels["E"])


def test_post_spec_equals_get_query(client):
    r_get = client.get(f"/tables/albedo?{SMALL}&format=npz")
    r_post = client.post("/tables?format=npz", json=SMALL_SPEC)
    assert r_post.status_code == 200
    assert r_post.content == r_get.content
    assert r_post.headers["etag"] == r_get.headers["etag"]
    # spelling differences (defaults given, key order) are the same table
    spelled = {"axes": {"alpha": {"size": 3, "spacing": "linear"}, "mu": [0.2, 0.6, 1]}, "distribution": "ggx", "table": "albedo"}
    assert client.post("/tables?format=npz", json=spelled).headers["etag"] == r_get.headers["etag"]


def test_query_scheme_resolution_and_fresnel(client):
    r = client.get(
        "/tables/albedo?mu_size=3&mu_spacing=square&mu_nodes=centers&mu_min=0.1&mu_max=0.9"
        "&roughness=0.3,0.7&fresnel=conductor&fresnel_eta=0.2&fresnel_k=3&distribution=beckmann"
        "&shadowing=separable&tolerance=1e-5&format=json"
    )
    assert r.status_code == 200, r.text
    spec = r.json()["meta"]["spec"]
    assert spec["axes"]["mu"] == {"size": 3, "spacing": "square", "nodes": "centers", "range": [0.1, 0.9], "clamp": None}
    assert spec["axes"]["roughness"] == {"values": [0.3, 0.7]}
    assert spec["fresnel"] == {"type": "conductor", "eta": 0.2, "k": 3.0}
    assert spec["distribution"] == "beckmann" and spec["shadowing"] == "separable" and spec["tolerance"] == 1e-5


def test_other_table_kinds(client):
    for url, shape in [
        ("/tables/albedo_avg?alpha=0.1,0.5", [2]),
        ("/tables/dielectric?mu=0.5,1&alpha=0.3&eta=0.8,1.5", [2, 1, 2]),
        ("/tables/dielectric_avg?alpha=0.3&eta=1.5", [1, 1]),
        ("/tables/dfg?mu_size=2&roughness_size=2&roughness_nodes=centers", [2, 2]),
    ]:
        r = client.get(url + "&format=json")
        assert r.status_code == 200, (url, r.text)
        assert r.json()["shape"] == shape


def test_etag_if_none_match_304(client):
    r = client.get(f"/tables/albedo?{SMALL}")
    etag = r.headers["etag"]
    for inm in (etag, f"W/{etag}", f'"other", {etag}', "*"):
        r304 = client.get(f"/tables/albedo?{SMALL}", headers={"If-None-Match": inm})
        assert r304.status_code == 304, inm
        assert r304.content == b""
        assert r304.headers["etag"] == etag
    assert client.get(f"/tables/albedo?{SMALL}", headers={"If-None-Match": '"nope"'}).status_code == 200


def test_head(client):
    r = client.head(f"/tables/albedo?{SMALL}")
    assert r.status_code == 200 and r.headers["content-type"] == "image/x-exr"


def test_info_and_preview(client):
    info = client.get(f"/tables/albedo/info?{SMALL}")
    assert info.status_code == 200 and info.headers["etag"].endswith('.info"')
    d = info.json()
    assert d["shape"] == [3, 3] and set(d["max_error"]) == {"E"} and d["conventions"]["frame"]
    png = client.get(f"/tables/albedo/preview.png?{SMALL}")
    assert png.status_code == 200 and png.headers["content-type"] == "image/png"
    assert png.content[:8] == b"\x89PNG\r\n\x1a\n"
    err_png = client.get(f"/tables/albedo/preview.png?{SMALL}&channel=E_err")
    assert err_png.status_code == 200 and err_png.content != png.content
    cube = "mu=0.5,1&alpha=0.3,0.6&eta=0.8,1.5"
    s0 = client.get(f"/tables/dielectric/preview.png?{cube}&channel=T&slice=0")
    s1 = client.get(f"/tables/dielectric/preview.png?{cube}&channel=T&slice=1")
    s_mu = client.get(f"/tables/dielectric/preview.png?{cube}&slice_axis=mu&slice=-1")
    assert s0.status_code == s1.status_code == s_mu.status_code == 200
    assert s0.content != s1.content
    assert client.get("/tables/albedo_avg/preview.png?alpha=0.1,0.5").status_code == 200


def test_page(client):
    r = client.get("/?table=albedo&mu=0.2,0.6,1&alpha_size=3&mu_size=")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    html = r.text
    assert 'id="preview"' in html and "/tables/albedo/preview.png?mu=0.2%2C0.6%2C1&amp;alpha_size=3" in html
    assert 'id="max-error"' in html and "conventions" in html and "Walter" in html
    for kind in ("albedo_avg", "dielectric", "dfg"):
        assert f'href="/?table={kind}"' in html  # the catalog
    page3 = client.get("/?table=dielectric&mu=0.5,1&alpha=0.3&eta=1.5&slice=0&channel=T")
    assert page3.status_code == 200 and "slice=0" in page3.text
    bad = client.get("/?table=albedo&mu=0.5,0.2")
    assert bad.status_code == 400 and 'id="error"' in bad.text and "strictly increasing" in bad.text
    assert client.get("/?table=nope").status_code == 404
    # the catalog links to every kind: a default table over the limits (32 x 32 > 64 texels) is
    # shown at the first page size that fits (8 x 8), and the page says so
    fitted = client.get("/?table=albedo")
    assert fitted.status_code == 200 and 'id="fitted"' in fitted.text and "at 8 nodes per axis" in fitted.text
    assert "albedo: mu 8 x alpha 8" in fitted.text and "mu_size=8&amp;alpha_size=8" in fitted.text
    big = client.get("/?table=albedo&mu_size=32&alpha_size=32")  # asked for: refused, not shrunk
    assert big.status_code == 413 and "texels" in big.text and 'id="fitted"' not in big.text
    twice = client.get("/?table=albedo&table=dfg")  # the API routes refuse repeats; so does the page
    assert twice.status_code == 400 and "given more than once" in twice.text


# ------------------------------------------------------------------ errors


@pytest.mark.parametrize(
    "url, status, param, query_param",
    [
        ("/tables/nope", 404, "table", "table"),
        ("/tables/albedo?colour=red", 400, "colour", "colour"),
        ("/tables/albedo?mu=0.1&mu=0.2", 400, "mu", "mu"),
        ("/tables/albedo?alpha=-0.1", 400, "axes.alpha", "alpha"),
        ("/tables/albedo?alpha_min=-1&alpha_size=2", 400, "axes.alpha.range", "alpha_min,alpha_max"),
        ("/tables/albedo?mu_max=1e308", 400, "axes.mu.range", "mu_min,mu_max"),  # the range, not a node
        ("/tables/albedo?mu_size=4&mu_max=2", 400, "axes.mu.range", "mu_min,mu_max"),
        ("/tables/albedo?fresnel=dielectric&fresnel_eta=0", 400, "fresnel.eta", "fresnel_eta"),
        ("/tables/albedo?fresnel=dielectric&fresnel_eta=-2", 400, "fresnel.eta", "fresnel_eta"),
        ("/tables/dielectric?eta=0,1.5&mu=1&alpha=0.5", 400, "axes.eta", "eta"),
        ("/tables/albedo?mu=nan", 400, "axes.mu", "mu"),
        ("/tables/albedo?mu=0.5,inf", 400, "axes.mu", "mu"),
        ("/tables/albedo?tolerance=nan", 400, "tolerance", "tolerance"),
        ("/tables/albedo?fresnel=schlick&fresnel_f0=inf", 400, "fresnel.f0", "fresnel_f0"),
        ("/tables/albedo?mu=", 400, "mu", "mu"),
        ("/tables/albedo?mu=0.5,0.2", 400, "axes.mu", "mu"),
        ("/tables/albedo?mu=0.5,0.5", 400, "axes.mu", "mu"),
        ("/tables/albedo?mu=abc", 400, "mu", "mu"),
        ("/tables/albedo?mu_size=2.5", 400, "mu_size", "mu_size"),
        ("/tables/albedo?mu_size=0", 400, "axes.mu.size", "mu_size"),
        ("/tables/albedo?mu_spacing=log&mu_size=2", 400, "axes.mu.spacing", "mu_spacing"),
        ("/tables/albedo?mu_min=0.9&mu_max=0.1&mu_size=2", 400, "axes.mu.range", "mu_min,mu_max"),
        ("/tables/albedo?mu=0.5&mu_size=3", 400, "mu_size", "mu_size"),
        ("/tables/albedo?eta=1.5", 400, "axes.eta", "eta"),
        ("/tables/albedo?alpha=0.5&roughness=0.5", 400, "axes", None),
        ("/tables/albedo?distribution=phong", 400, "distribution", "distribution"),
        ("/tables/dfg?fresnel=schlick&fresnel_f0=0.04", 400, "fresnel.type", "fresnel"),
        ("/tables/albedo?fresnel=schlick", 400, "fresnel.f0", "fresnel_f0"),
        ("/tables/albedo?mu_size=100&alpha_size=100", 413, "axes", None),
        ("/tables/albedo?format=tiff", 406, "format", "format"),
        ("/tables/albedo/info?format=json", 400, "format", "format"),
        ("/tables/albedo/preview.png?mu=0.5&alpha=0.5&channel=Q", 400, "channel", "channel"),
        ("/tables/albedo/preview.png?mu=0.5&alpha=0.5&slice=0", 400, "slice", "slice"),
        ("/tables/dielectric/preview.png?mu=0.5&alpha=0.5&eta=1.5&slice=3", 400, "slice", "slice"),
        ("/tables/dielectric/preview.png?mu=0.5&alpha=0.5&eta=1.5&slice_axis=k", 400, "slice_axis", "slice_axis"),
        (f"/tables/albedo?mu=1{'0' * 400}", 400, "axes.mu", "mu"),
    ],
)
def test_bad_query_names_the_parameter(client, url, status, param, query_param):
    err(client.get(url), status, param, query_param)


def test_accept_not_acceptable(client):
    body = err(client.get(f"/tables/albedo?{SMALL}", headers={"Accept": "text/html"}), 406, "Accept")
    assert "image/x-exr" in body["allowed"]


@pytest.mark.parametrize(
    "body, status, param",
    [
        ({"table": "albedo", "axes": {"alpha": [-0.5]}}, 400, "axes.alpha"),
        ({"table": "albedo", "colour": 1}, 400, "colour"),
        ({"table": "nope"}, 404, "table"),
        ({"axes": {}}, 400, "table"),
        ({"table": "albedo", "axes": {"mu": []}}, 400, "axes.mu"),
        ({"table": "albedo", "axes": {"mu": {"size": 64}, "alpha": {"size": 64}}}, 413, "axes"),
        ([1, 2], 400, "body"),
        (None, 400, "body"),
        ('"albedo"', 400, "body"),  # a JSON string
        ('{"table": "albedo", "axes": {"mu": [1' + "0" * 400 + "]}}", 400, None),  # int too big for a float
    ],
)
def test_bad_post_body(client, body, status, param):
    raw = body.encode() if isinstance(body, str) else json.dumps(body).encode()
    err(client.post("/tables", content=raw, headers={"Content-Type": "application/json"}), status, param)


def test_post_malformed_and_large_bodies(client):
    err(client.post("/tables", content=b"{not json"), 400, "body")
    err(client.post("/tables", content=b""), 400, "body")
    err(client.post("/tables", content=b"[" * 100000 + b"]" * 100000), 413, "body")
    err(client.post("/tables", content=b"[" * 1900), 400, "body")  # deep nesting, under the cap
    err(client.post("/tables", content=b'{"table": "albedo", "tolerance": NaN}'), 400, "tolerance")
    err(client.post("/tables", content=b"\xff\xfe"), 400, "body")
    err(client.post("/tables?format=xml", json=SMALL_SPEC), 406, "format")
    err(client.post("/tables?mu=1", json=SMALL_SPEC), 400, "mu")


def test_unknown_route_and_method_are_json(client):
    err(client.get("/nope"), 404)
    err(client.delete("/tables"), 405)


def test_cli_serve_is_registered(capsys):
    # through the bsdf_tab.commands entry point: the library never imports the service
    from bsdf_tab.cli import main

    assert main(["serve", "--help"]) == 0
    assert "--cache-dir" in capsys.readouterr().out


def test_get_takes_effort_for_fixed_effort_methods(client):
    q = "mu=0.5,1&alpha=0.5&method=vndf_gl&effort=64"
    r = client.get(f"/tables/albedo?{q}&format=npz")
    assert r.status_code == 200, r.text
    spec = {"table": "albedo", "axes": {"mu": [0.5, 1.0], "alpha": [0.5]}, "method": "vndf_gl", "effort": 64}
    same = client.post("/tables?format=npz", json=spec)
    assert same.status_code == 200 and same.headers["etag"] == r.headers["etag"]
    other = client.get("/tables/albedo?mu=0.5,1&alpha=0.5&method=vndf_gl&effort=256&format=npz")
    assert other.status_code == 200 and other.headers["etag"] != r.headers["etag"]
    info = client.get(f"/tables/albedo/info?{q}").json()
    assert info["spec"]["effort"] == 64, info["spec"]
    err(client.get("/tables/albedo?mu=1&alpha=0.5&effort=64"), 400, "effort", "effort")  # adaptive: no effort
    err(client.get("/tables/albedo?mu=1&alpha=0.5&method=vndf_gl&effort=abc"), 400, "effort", "effort")
    err(client.get("/tables/albedo?mu=1&alpha=0.5&method=vndf_gl&effort=2"), 400, "effort", "effort")


@pytest.mark.parametrize("value", ["--1", "+-1", "\u00b2", "1_0", "\u0661", "0x1", " 1 1"])
def test_strict_slice_and_integer_parsing(client, value):
    """Issue 12: slice=--1 was a 500; every integer parameter takes plain ASCII digits only."""
    r = client.get("/tables/dielectric/preview.png", params={"mu": "0.5", "alpha": "0.3", "eta": "1.2,1.5", "slice": value})
    err(r, 400, param="slice")
    page = client.get("/", params={"table": "dielectric", "mu": "0.5", "alpha": "0.3", "eta": "1.2,1.5", "slice": value})
    assert page.status_code == 400 and 'id="error"' in page.text
    err(client.get("/tables/albedo", params={"mu_size": value}), 400, query_param="mu_size")
    err(client.get("/tables/albedo", params={"mu": value}), 400, query_param="mu")


# ------------------------------------------------------------------ a kind's own keys (sheen_shadowing)


def test_sheen_shadowing_key_query_catalog_cache_meta(client):
    from bsdf_tab.tables.sheen import SHEEN_SHADOWINGS

    cat = client.get("/tables").json()
    key = cat["tables"]["sheen_albedo"]["keys"]["sheen_shadowing"]
    assert key["enum"] == list(SHEEN_SHADOWINGS) and key["default"] == "fitted" and key["query_param"] == "sheen_shadowing"
    assert "keys" not in cat["tables"]["albedo"]
    q = "mu=0.3,1&roughness=0.5"
    values, etags = {}, {}
    for mode in SHEEN_SHADOWINGS:
        r = client.get(f"/tables/sheen_albedo?{q}&sheen_shadowing={mode}&format=json")
        assert r.status_code == 200, r.text
        values[mode] = json.dumps(r.json()["channels"]["E"])
        etags[mode] = r.headers["etag"]
        info = client.get(f"/tables/sheen_albedo/info?{q}&sheen_shadowing={mode}").json()
        assert info["spec"]["sheen_shadowing"] == mode
    assert len(set(values.values())) == len(set(etags.values())) == 3  # three cache keys, three tables
    # the default, and the older spelling: the same cache key as the key itself
    assert client.get(f"/tables/sheen_albedo?{q}&format=json").headers["etag"] == etags["fitted"]
    old = client.get(f"/tables/sheen_albedo?{q}&parametrization=exact&format=json")
    assert old.status_code == 200 and old.headers["etag"] == etags["exact"]
    post = client.post("/tables?format=json", json={"table": "sheen_albedo", "sheen_shadowing": "ashikhmin",
                                                     "axes": {"mu": [0.3, 1.0], "roughness": [0.5]}})
    assert post.status_code == 200 and post.headers["etag"] == etags["ashikhmin"]
    # bad values and the wrong kind: 400 naming the key
    err(client.get(f"/tables/sheen_albedo?{q}&sheen_shadowing=smith"), 400, "sheen_shadowing", "sheen_shadowing")
    # the output's conventions name the shadowing that was used
    assert info["conventions"]["shadowing"] == "ashikhmin" and "Neubelt" in info["conventions"]["shadowing_definition"]
    err(client.get(f"/tables/sheen_albedo?{q}&sheen_shadowing=exact&sheen_shadowing=fitted"), 400, "sheen_shadowing")
    err(client.get(f"/tables/sheen_albedo?{q}&parametrization=smith"), 400, "parametrization")
    err(client.get(f"/tables/albedo?{SMALL}&sheen_shadowing=exact"), 400, "sheen_shadowing")
    err(client.post("/tables", json={"table": "sheen_albedo", "sheen_shadowing": 1}), 400, "sheen_shadowing")
    page = client.get(f"/?table=sheen_albedo&{q}&sheen_shadowing=exact")
    assert page.status_code == 200 and 'id="f-sheen_shadowing"' in page.text
    assert '<option value="exact" selected>' in page.text


# ------------------------------------------------------------------ previews of 3-D and 4-D tables


def _aniso_test_table():
    axes = {"mu": np.array([0.1, 0.5, 1.0]), "phi_v": np.array([0.0, 0.7, 1.5]), "alpha": np.array([0.1, 0.3, 0.6, 0.9]),
            "anisotropy": np.array([0.0, 0.5, 1.0])}
    shape = tuple(len(v) for v in axes.values())
    # every texel distinct: value = its flat index (so any wrong slice draws different colours)
    E = np.arange(np.prod(shape), dtype=np.float64).reshape(shape) ** 1.5
    return Table(axes, {"E": E, "E_err": 1e-7 * E}, {"spec": {"table": "albedo_aniso", "distribution": "ggx",
                                                              "shadowing": "correlated"}})


def test_preview_slice_4d_unit():
    from service.errors import ServiceError
    from service.preview import check_preview, draw_png, render_png

    t = _aniso_test_table()
    chans = ["E", "E_err"]
    # default: the first two shown, the others at their middle
    p = check_preview(t.axes, chans, None, None, None)
    assert p.held == (("alpha", 2), ("anisotropy", 1)) and p.variant == "png-E-alpha2-anisotropy1"
    assert check_preview(t.axes, chans, None, None, "alpha=0,anisotropy=-1").held == (("alpha", 0), ("anisotropy", 2))
    assert check_preview(t.axes, chans, None, None, "anisotropy=0").held == (("alpha", 2), ("anisotropy", 0))
    assert check_preview(t.axes, chans, None, "mu,anisotropy", "mu=2").held == (("mu", 2), ("anisotropy", 1))
    for sa, idx, param in [(None, "3", "slice"), (None, "alpha=9", "slice"), (None, "k=1", "slice"),
                           ("alpha", None, "slice_axis"), ("mu,mu", None, "slice_axis"),
                           ("alpha,anisotropy", "mu=1", "slice"), (None, "alpha=1,alpha=2", "slice"),
                           (None, "alpha=x", "slice")]:
        with pytest.raises(ServiceError) as info:
            check_preview(t.axes, chans, None, sa, idx)
        assert info.value.status == 400 and info.value.param == param, (sa, idx, info.value)
    # the image of a chosen slice is the drawing of that slice of the table (indexed here, apart)
    for sa, idx, (shown, sl, caption) in [
        (None, "alpha=1,anisotropy=2", (["mu", "phi_v"], np.s_[:, :, 1, 2],
                                        "alpha = 0.3 (index 1 of 4), anisotropy = 1 (index 2 of 3)")),
        ("mu,phi_v", "mu=0,phi_v=2", (["alpha", "anisotropy"], np.s_[0, 2, :, :],
                                     "mu = 0.1 (index 0 of 3), phi_v = 1.5 (index 2 of 3)")),
        (None, None, (["mu", "phi_v"], np.s_[:, :, 2, 1], "alpha = 0.6 (index 2 of 4), anisotropy = 0.5 (index 1 of 3)")),
    ]:
        p = check_preview(t.axes, chans, "E", sa, idx)
        title = f"albedo_aniso E  (ggx, correlated)\n{caption}"
        want = draw_png([t.axes[n] for n in shown], shown, t.channels["E"][sl], "E", title)
        assert render_png(t, p) == want, (sa, idx)
    others = {render_png(t, check_preview(t.axes, chans, "E", None, f"alpha={i},anisotropy={j}"))
              for i in range(4) for j in range(3)}
    assert len(others) == 12  # every slice draws differently (the old preview drew index 0 for all)


def test_preview_slice_4d_http(client):
    q = "mu=0.3,1&phi_v=0,1.5&alpha=0.2,0.5&anisotropy=0,0.5,1"
    t = Table.from_npz_bytes(client.get(f"/tables/albedo_aniso?{q}&format=npz").content)
    from service.preview import draw_png

    for idx, sl, caption in [("alpha=0,anisotropy=2", np.s_[:, :, 0, 2], "alpha = 0.2 (index 0 of 2), anisotropy = 1 (index 2 of 3)"),
                             (None, np.s_[:, :, 1, 1], "alpha = 0.5 (index 1 of 2), anisotropy = 0.5 (index 1 of 3)")]:
        r = client.get(f"/tables/albedo_aniso/preview.png?{q}" + (f"&slice={idx}" if idx else ""))
        assert r.status_code == 200 and r.headers["content-type"] == "image/png"
        want = draw_png([t.axes["mu"], t.axes["phi_v"]], ["mu", "phi_v"], np.asarray(t.channels["E"], dtype=np.float64)[sl],
                        "E", f"albedo_aniso E  (ggx, correlated)\n{caption}")
        assert r.content == want
    err(client.get(f"/tables/albedo_aniso/preview.png?{q}&slice=1"), 400, "slice")
    err(client.get(f"/tables/albedo_aniso/preview.png?{q}&slice=alpha=5"), 400, "slice")
    err(client.get(f"/tables/albedo_aniso/preview.png?{q}&slice_axis=alpha"), 400, "slice_axis")
    page = client.get(f"/?table=albedo_aniso&{q}&slice=alpha%3D0,anisotropy%3D2")
    assert page.status_code == 200 and "slice=alpha%3D0%2Canisotropy%3D2" in page.text


def test_a_fitted_page_table_stays_within_a_lower_cost_limit(tmp_path):
    """The review: the page priced its fitted table against its own 4 core-s, not the service's
    lower limit, so its preview link then answered 413."""
    import html
    import re

    settings = Settings(cache_dir=tmp_path, warmup=False, workers=2, max_cost_seconds=0.5)
    with TestClient(create_app(settings)) as c:
        assert c.get("/tables/dielectric").status_code == 413  # the default table is over this limit
        page = c.get("/?table=dielectric")
        assert page.status_code == 200 and 'id="fitted"' in page.text
        src = html.unescape(re.search(r'<img id="preview" src="([^"]+)"', page.text).group(1))
        assert c.get(src).status_code == 200, src
