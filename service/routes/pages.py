"""``GET /``: the HTML page for people: catalog, a form, the preview, max error, conventions.

Rendered on the server (no script needed to see the result): the form submits to ``/`` with
the same query parameters as ``GET /tables/{table}`` plus ``table``, ``channel``, ``slice``;
the page computes the table through the same cache and shows
``/tables/{table}/preview.png?...`` next to the table's max error and conventions.
"""

from __future__ import annotations

import json
from html import escape
from urllib.parse import urlencode

from fastapi import APIRouter, Request
from fastapi.responses import HTMLResponse

from bsdf_tab import __version__
from bsdf_tab.errors import SpecError
from bsdf_tab.spec import (
    AXIS_DEFAULTS,
    DISTRIBUTIONS,
    FRESNEL_TYPES,
    NODES,
    ROUGHNESS_SLOT,
    SHADOWINGS,
    SPACINGS,
    TABLE_KINDS,
    channel_names,
    kind_options,
)

from ..errors import ServiceError, from_spec_error, query_param_for
from ..page_template import PAGE
from ..params import FRESNEL_PARAMS, spec_from_query
from ..preview import check_preview
from ..dependencies import jobs_of, store_of

router = APIRouter(tags=["pages"])

_TEMPLATE = PAGE
DEFAULT_TABLE = "albedo"
PAGE_EXTRA = ("table", "channel", "slice", "slice_axis")
#: a kind whose default table is over this service's limits is shown at the first of these sizes per
#: axis that fits them and costs at most PAGE_COST_SECONDS predicted core-seconds (a page is a glance)
PAGE_SIZES = (16, 8, 4, 2)
PAGE_COST_SECONDS = 4.0


def _select(name: str, options, current: str | None, blank: str | None = None, attrs: str = "") -> str:
    opts = []
    if blank is not None:
        opts.append(f'<option value="">{escape(blank)}</option>')
    for o in options:
        sel = " selected" if o == current else ""
        opts.append(f'<option value="{escape(o)}"{sel}>{escape(o)}</option>')
    return f'<select name="{escape(name)}" id="f-{escape(name)}"{attrs}>{"".join(opts)}</select>'


def _input(name: str, value: str | None, placeholder: str = "") -> str:
    return (
        f'<input name="{escape(name)}" id="f-{escape(name)}" value="{escape(value or "")}"'
        f' placeholder="{escape(placeholder)}">'
    )


def _label(text: str, control: str) -> str:
    return f"      <label>{escape(text)} {control}</label>"


def _axis_names_for(kind: str, given: dict) -> list[str]:
    info = TABLE_KINDS[kind]
    slots = info["axes"]
    if info.get("parametrizations"):
        slots = info["parametrizations"].get(given.get("parametrization"), slots)
    rough = "roughness" if any(k == "roughness" or k.startswith("roughness_") for k in given) else "alpha"
    return [rough if n == ROUGHNESS_SLOT else n for n in slots]


def _kind_params(kind: str, q: dict) -> list[str]:
    info = TABLE_KINDS[kind]
    rows = []
    for name in info.get("params", ()):
        if name == "parametrization":
            rows.append(_label(name, _select(name, list(info.get("parametrizations", {})), q.get(name), "(default)")))
        elif name == "alpha":  # alpha or roughness: one field, alpha
            rows.append(_label("alpha", _input("alpha", q.get("alpha"), "material width (default)")))
    for name, decl in kind_options(kind).items():  # the keys the kind declares (sheen: sheen_shadowing)
        rows.append(_label(name, _select(name, list(decl["choices"]), q.get(name), f"{decl['default']} (default)")))
    return (["    <fieldset><legend>material</legend>"] + rows + ["    </fieldset>"]) if rows else []


def _form(kind: str, q: dict) -> str:
    change = " onchange=\"location.href='/?table='+encodeURIComponent(this.value)\""
    rows = ["    <fieldset><legend>table</legend>", _label("table", _select("table", list(TABLE_KINDS), kind, attrs=change))]
    rows.append(_label("distribution", _select("distribution", sorted(DISTRIBUTIONS), q.get("distribution"), "ggx (default)")))
    rows.append(_label("shadowing", _select("shadowing", sorted(SHADOWINGS), q.get("shadowing"), "correlated (default)")))
    rows.append(_label("tolerance", _input("tolerance", q.get("tolerance"), "5e-07 (default)")))
    rows.append("    </fieldset>")
    rows.extend(_kind_params(kind, q))
    if TABLE_KINDS[kind]["fresnel"] == "any":
        rows.append("    <fieldset><legend>Fresnel</legend>")
        rows.append(_label("type", _select("fresnel", sorted(FRESNEL_TYPES), q.get("fresnel"), "one (default)")))
        for p in FRESNEL_PARAMS:
            rows.append(_label(p, _input(f"fresnel_{p}", q.get(f"fresnel_{p}"), {"f0": "schlick", "eta": "dielectric/conductor", "k": "conductor"}.get(p, ""))))
        rows.append("    </fieldset>")
    for axis in _axis_names_for(kind, q):
        d = AXIS_DEFAULTS[axis]
        rows.append(f"    <fieldset><legend>axis {escape(axis)}</legend>")
        rows.append(_label("values", _input(axis, q.get(axis), "explicit, e.g. 0.1,0.5,1")))
        rows.append(_label("size", _input(f"{axis}_size", q.get(f"{axis}_size"), str(d["size"]))))
        rows.append(_label("spacing", _select(f"{axis}_spacing", list(SPACINGS), q.get(f"{axis}_spacing"), f"{d['spacing']} (default)")))
        rows.append(_label("nodes", _select(f"{axis}_nodes", list(NODES), q.get(f"{axis}_nodes"), f"{d['nodes']} (default)")))
        rows.append(_label("min", _input(f"{axis}_min", q.get(f"{axis}_min"), f"{d['range'][0]:g}")))
        rows.append(_label("max", _input(f"{axis}_max", q.get(f"{axis}_max"), f"{d['range'][1]:g}")))
        rows.append("    </fieldset>")
    rows.append("    <fieldset><legend>preview</legend>")
    rows.append(_label("channel", _select("channel", channel_names(kind, errors=True), q.get("channel"))))
    names = _axis_names_for(kind, q)
    if len(names) == 3:
        rows.append(_label("slice", _input("slice", q.get("slice"), f"index along {names[-1]} (middle)")))
    elif len(names) > 3:  # the held axes: all but the first two, each at its middle unless given
        held = names[2:]
        rows.append(_label("slice", _input("slice", q.get("slice"), ",".join(f"{h}=i" for h in held) + " (middle)")))
        rows.append(_label("slice_axis", _input("slice_axis", q.get("slice_axis"), ",".join(held))))
    rows.append("    </fieldset>")
    return "\n".join(rows)


def _catalog_rows() -> str:
    rows = []
    for kind, info in TABLE_KINDS.items():
        axes = ", ".join("alpha|roughness" if a == ROUGHNESS_SLOT else a for a in info["axes"])
        rows.append(
            f'    <tr><td><a href="/?table={escape(kind)}">{escape(kind)}</a></td><td>{escape(axes)}</td>'
            f"<td>{escape(', '.join(info['channels']))}</td><td>{escape(info['description'])}</td></tr>"
        )
    return "\n".join(rows)


def _dl(items: dict) -> str:
    out = []
    for k, v in items.items():
        text = v if isinstance(v, str) else json.dumps(v)
        out.append(f"<dt>{escape(str(k))}</dt><dd>{escape(text)}</dd>")
    return "<dl>" + "".join(out) + "</dl>"


def _result(kind: str, query: str, preview_query: str, info: dict) -> str:
    errors = info.get("max_error") or {}
    err_text = ", ".join(f"{k}: {v:.3g}" if v is not None else f"{k}: n/a" for k, v in errors.items()) or "n/a"
    method = info.get("method") or {}
    base = f"/tables/{kind}" + (f"?{query}" if query else "")
    sep = "&amp;" if query else "?"
    links = " ".join(
        f'<a href="{escape(base)}{sep}format={f}">{f.upper()}</a>' for f in ("exr", "npz", "npy", "json")
    ) + f' <a href="/tables/{escape(kind)}/info{escape("?" + query if query else "")}">info</a>'
    shape = " x ".join(f"{n} {a['size']}" for n, a in info.get("axes", {}).items())
    img_src = f"/tables/{kind}/preview.png" + (f"?{preview_query}" if preview_query else "")
    return f"""<section class="result" id="result">
  <figure style="margin:0"><img id="preview" src="{escape(img_src)}" alt="preview of the {escape(kind)} table" width="640" height="480"
    onload="this.dataset.loaded = this.naturalWidth + 'x' + this.naturalHeight" onerror="this.dataset.loaded = 'error'"></figure>
  <div>
    <h2>{escape(kind)}: {escape(shape)}</h2>
    <p>max error estimate: <span class="maxerr" id="max-error">{escape(err_text)}</span></p>
    <p>download: {links}</p>
    <h2>method</h2>
    {_dl({k: v for k, v in method.items()})}
  </div>
  <div class="wide" id="conventions">
    <h2>conventions</h2>
    {_dl(info.get("conventions") or {})}
  </div>
</section>"""


def _error_box(exc: ServiceError) -> str:
    where = exc.query_param or query_param_for(exc.param) or exc.param or "request"
    allowed = f"<p>allowed: <code>{escape(json.dumps(exc.allowed))}</code></p>" if exc.allowed is not None else ""
    return (
        f'<section class="error" id="error"><h2>Cannot show this table</h2>'
        f"<p><b>{escape(str(where))}</b>: {escape(exc.message)}</p>{allowed}</section>"
    )


_HTML_ERR = {"content": {"text/html": {}}}
_PAGE_RESPONSES = {
    200: {"description": "the page", "content": {"text/html": {}}},
    400: {"description": "invalid parameter: the page shows the error box naming it", **_HTML_ERR},
    404: {"description": "unknown table or job: the page shows the error box", **_HTML_ERR},
    413: {"description": "too many texels or too costly (the page says so and links to jobs)", **_HTML_ERR},
    503: {"description": "the compute queue is full, or the computation was cancelled / ran out of time", **_HTML_ERR},
}


def _job_box(job: dict) -> str:
    done, total = job["progress"]["done"], job["progress"]["total"]
    pct = f"{100.0 * done / total:.0f}%" if total else "-"
    eta = "" if job["eta_seconds"] is None else f", about {job['eta_seconds']:g} s left"
    result = (f'<p>result: <a href="{escape(job["result"])}">{escape(job["result"])}</a></p>'
              if job.get("result") else "")
    error = f"<p>error: {escape(job['error'])}</p>" if job.get("error") else ""
    return (f'<section class="result" id="job" data-status="{escape(job["status"])}"><div>'
            f'<h2>job {escape(job["id"])}: {escape(job["status"])}</h2>'
            f'<p><progress id="job-progress" max="{max(total, 1)}" value="{done}"></progress> '
            f'{done} / {total} ({pct}){escape(eta)}</p>{result}{error}</div></section>')


@router.get("/", response_class=HTMLResponse, summary="HTML page: catalog, form, preview; ?job=ID shows a job's progress",
            responses=_PAGE_RESPONSES)
async def index(request: Request) -> HTMLResponse:
    items = [(k, v) for k, v in request.query_params.multi_items() if v.strip() != ""]
    q = dict(items)
    kind = q.get("table", DEFAULT_TABLE)
    status = 200
    repeated = sorted({k for k, _ in items if sum(1 for x, _ in items if x == k) > 1})
    if repeated:  # which one was meant is a guess (the API routes refuse it too)
        result = _error_box(ServiceError(400, "invalid_parameter", f"{repeated[0][:60]!r} is given more than once",
                                         param=repeated[0][:60]))
        kind, status = kind if kind in TABLE_KINDS else DEFAULT_TABLE, 400
    elif "job" in q:  # a job's progress, refreshed by the browser until it is finished
        try:
            job = await jobs_of(request).view(q["job"])
            result = _job_box(job)
            if job["status"] in ("queued", "running"):
                result = '<meta http-equiv="refresh" content="2">' + result
        except ServiceError as exc:
            result, status = _error_box(exc), exc.status
        kind = DEFAULT_TABLE
    elif kind not in TABLE_KINDS:
        result = _error_box(ServiceError(404, "unknown_table", f"unknown table {kind[:60]!r}", param="table",
                                         allowed=list(TABLE_KINDS)))
        kind, status = DEFAULT_TABLE, 404
    else:
        try:
            result = await _render_result(request, kind, items)
        except ServiceError as exc:
            result, status = _error_box(exc), exc.status
        except SpecError as exc:
            err = from_spec_error(exc)
            result, status = _error_box(err), err.status
    html = _TEMPLATE.safe_substitute(
        title=escape(kind),
        version=escape(__version__),
        form=_form(kind, q),
        result=result,
        catalog=_catalog_rows(),
        max_texels=str(request.app.state.settings.max_texels),
    )
    return HTMLResponse(html, status_code=status)


async def _render_result(request: Request, kind: str, items: list[tuple[str, str]]) -> str:
    spec_items = [(k, v) for k, v in items if k not in PAGE_EXTRA]
    spec, _ = spec_from_query(kind, spec_items)
    extra = {k: v for k, v in items if k in PAGE_EXTRA}
    store = store_of(request)
    note = ""
    try:
        prep = store.prepare(spec)
    except ServiceError as exc:  # the catalog links to every kind: fit a default table to the limits
        prep, spec_items, note = _fitted(store, kind, spec_items, exc)
    check_preview(prep.axes, channel_names(kind, errors=True), extra.get("channel"), extra.get("slice_axis"),
                  extra.get("slice"))
    info = json.loads(await store.variant(prep, "info", client=request.is_disconnected))
    query = urlencode(spec_items)
    preview_query = urlencode(spec_items + [(k, extra[k]) for k in ("channel", "slice", "slice_axis") if k in extra])
    return note + _result(kind, query, preview_query, info)


def _fitted(store, kind: str, spec_items: list, exc: ServiceError):
    """(prepared, items, note) of ``kind``'s table at the first of :data:`PAGE_SIZES` that fits this
    service's limits, where ``exc`` refused the default table (413) and no axis was given; else ``exc``."""
    axes = _axis_names_for(kind, dict(spec_items))
    if exc.status != 413 or any(k == a or k.startswith(f"{a}_") for k, _ in spec_items for a in axes):
        raise exc
    for n in PAGE_SIZES:
        items = spec_items + [(f"{a}_size", str(n)) for a in axes]
        try:
            prep = store.prepare(spec_from_query(kind, items)[0],
                                 max_cost=min(PAGE_COST_SECONDS, store.settings.max_cost_seconds))
        except ServiceError as again:
            if again.status != 413:
                raise
            continue
        note = (f'<section class="note" id="fitted"><p>The default {escape(kind)} table is over this service\'s '
                f"limits ({escape(exc.message)}); shown here at {n} nodes per axis. Ask for more in the form, or "
                "as a job (POST /jobs).</p></section>")
        return prep, items, note
    raise exc
