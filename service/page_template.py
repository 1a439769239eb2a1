"""The HTML of ``GET /`` (a :class:`string.Template`; kept in Python so installs need no package data)."""

from string import Template

PAGE = Template(
    r"""<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>bsdf-tab: $title</title>
<style>
  body { font: 14px/1.45 system-ui, -apple-system, "DejaVu Sans", sans-serif; margin: 0; color: #1d2330; background: #f6f7f9; }
  header { background: #1d2330; color: #fff; padding: 10px 20px; display: flex; gap: 20px; align-items: baseline; }
  header h1 { font-size: 18px; margin: 0; }
  header a { color: #9cc3ff; }
  main { padding: 16px 20px; display: grid; grid-template-columns: 320px 1fr; gap: 20px; align-items: start; }
  section { background: #fff; border: 1px solid #dde1e8; border-radius: 6px; padding: 12px 16px; }
  h2 { font-size: 15px; margin: 0 0 8px; }
  form fieldset { border: 1px solid #e3e6ec; border-radius: 4px; margin: 0 0 8px; padding: 6px 8px; }
  form legend { font-weight: 600; font-size: 12px; }
  form label { display: grid; grid-template-columns: 90px 1fr; gap: 6px; align-items: center; margin: 3px 0; font-size: 12px; }
  form input, form select { font: inherit; font-size: 12px; padding: 2px 4px; min-width: 0; }
  button { font: inherit; padding: 4px 14px; }
  .result { display: grid; grid-template-columns: minmax(300px, 640px) minmax(240px, 1fr); gap: 16px; align-items: start; }
  .result img { width: 100%; height: auto; border: 1px solid #e3e6ec; }
  dl { display: grid; grid-template-columns: max-content 1fr; gap: 2px 10px; margin: 0; font-size: 12px; }
  dt { font-weight: 600; } dd { margin: 0; word-break: break-word; }
  table.catalog { border-collapse: collapse; width: 100%; font-size: 12px; }
  table.catalog td, table.catalog th { border-bottom: 1px solid #e3e6ec; text-align: left; padding: 3px 6px; vertical-align: top; }
  .error { background: #fff0f0; border-color: #e5a0a0; }
  .maxerr { font-size: 16px; font-weight: 600; }
  code { font-size: 12px; background: #f0f2f5; padding: 1px 3px; border-radius: 3px; }
  .wide { grid-column: 1 / -1; }
</style>
</head>
<body>
<header>
  <h1>bsdf-tab</h1><span>microfacet BSDF lookup tables, v$version</span>
  <a href="/docs">API docs</a><a href="/tables">catalog (JSON)</a><a href="/healthz">health</a>
</header>
<main>
<section>
  <h2>Pick a table</h2>
  <form method="get" action="/" id="table-form">
$form
    <button type="submit">Show</button>
  </form>
</section>
<div>
$result
<section class="wide" style="margin-top:16px">
  <h2>Catalog</h2>
  <table class="catalog">
    <tr><th>table</th><th>axes</th><th>channels</th><th>description</th></tr>
$catalog
  </table>
  <p>Any table by URL: <code>GET /tables/{table}?mu_size=32&amp;alpha=0.1,0.5,1&amp;format=exr|npz|npy|json</code>,
     or <code>POST /tables</code> with a spec JSON body. Limit: $max_texels texels per table.</p>
</section>
</div>
</main>
</body>
</html>
"""
)
