"""The sheen shadowing choice as a spec key (``sheen_shadowing``) through the CLI: a spec file with
the key bakes that choice (values against the SciPy reference of test_sheen_albedo), a bad value is
one line naming the key and exit code 2, and the older spelling ``parametrization`` still works."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bsdf_tab import read_exr
from bsdf_tab.cli.main import main
from tests.sheen.test_sheen_albedo import E_ref


@pytest.mark.parametrize("key", ["sheen_shadowing", "parametrization"])
def test_cli_bakes_the_chosen_shadowing(tmp_path, key, capsys):
    spec = {"table": "sheen_albedo", key: "exact", "axes": {"mu": [0.4], "roughness": [0.6]}}
    path = tmp_path / "sheen.json"
    path.write_text(json.dumps(spec))
    out = tmp_path / "sheen.exr"
    assert main(["bake", str(path), "-o", str(out), "-q"]) == 0
    t = read_exr(out)
    assert t.meta["spec"]["sheen_shadowing"] == "exact"
    ref = E_ref(0.4, 0.36, "exact")
    assert abs(float(np.asarray(t.channels["E"]).ravel()[0]) - ref) < 2e-6  # float32 storage


def test_cli_bad_value_is_one_line_naming_the_key(tmp_path, capsys):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"table": "sheen_albedo", "sheen_shadowing": "smith"}))
    assert main(["bake", str(path), "-o", str(tmp_path / "x.exr"), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert "sheen_shadowing" in err and "Traceback" not in err and len(err.splitlines()) == 1
    path.write_text(json.dumps({"table": "albedo", "sheen_shadowing": "exact"}))
    assert main(["bake", str(path), "-o", str(tmp_path / "x.exr"), "-q"]) == 2
    assert "sheen_shadowing" in capsys.readouterr().err
