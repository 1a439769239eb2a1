"""Material libraries: parsing into specs (errors name the library parameter), and the bake."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from bsdf_tab import cli, read_exr
from bsdf_tab.errors import SpecError
from bsdf_tab.library import library_specs

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "library.toml"

SMALL = """
[library]
mu = 3
roughness = 2

[[library.materials]]
name = "gold"
type = "conductor"
wavelengths_nm = [650, 450]
ior = [[0.166, 3.15], [1.50, 1.88]]

[[library.materials]]
name = "glass"
type = "dielectric"
eta = 1.5

[[library.materials]]
name = "plastic"
type = "schlick"
f0 = 0.04
distribution = "beckmann"
"""


def test_example_library_has_40_materials_and_valid_specs():
    lib = tomllib.loads(EXAMPLE.read_text())
    specs = library_specs(lib)
    assert len(lib["library"]["materials"]) >= 40
    kinds = {s["table"] for _, s in specs}
    assert kinds == {"albedo", "dielectric", "dielectric_avg"}
    gold = [s for p, s in specs if p.startswith("gold/")]
    assert [s["fresnel"]["type"] for s in gold] == ["conductor"] * 3  # three wavelengths


def test_small_library_specs():
    specs = dict(library_specs(tomllib.loads(SMALL)))
    assert sorted(specs) == ["glass/dielectric.exr", "glass/dielectric_avg.exr", "gold/albedo_450nm.exr",
                             "gold/albedo_650nm.exr", "plastic/albedo.exr"]
    assert specs["gold/albedo_650nm.exr"]["fresnel"] == {"type": "conductor", "eta": 0.166, "k": 3.15}
    assert specs["glass/dielectric.exr"]["axes"]["eta"] == {"values": [1 / 1.5, 1.5]}  # entering and leaving
    assert specs["plastic/albedo.exr"]["distribution"] == "beckmann"


@pytest.mark.parametrize("patch,param", [
    (("type = \"schlick\"", "type = \"wood\""), "library.materials[2].type"),
    (("f0 = 0.04", "f0 = 1.5"), "library.materials[2].f0"),
    (("ior = [[0.166, 3.15], [1.50, 1.88]]", "ior = [[0.166, -3.15], [1.50, 1.88]]"), "library.materials[0].ior[0]"),
    (("wavelengths_nm = [650, 450]", "wavelengths_nm = [650]"), "library.materials[0].wavelengths_nm"),
    # one file name for two tables: the second would overwrite the first (an audit's find)
    (("wavelengths_nm = [650, 450]", "wavelengths_nm = [550, 550]"), "library.materials[0].wavelengths_nm"),
    (("wavelengths_nm = [650, 450]", "wavelengths_nm = [550, 550.0000001]"), "library.materials[0].wavelengths_nm"),
    (("eta = 1.5", "eta = 1.0"), "library.materials[1].eta"),
    (("name = \"glass\"", "name = \"gold\""), "library.materials[1].name"),
    (("mu = 3", "mu = 1"), "library.mu"),
    (("mu = 3", "colour = 3"), "library.colour"),
])
def test_errors_name_the_library_parameter(patch, param):
    with pytest.raises(SpecError) as info:
        library_specs(tomllib.loads(SMALL.replace(*patch)))
    assert info.value.param == param


def test_bake_library_and_resume(tmp_path, capsys):
    path = tmp_path / "lib.toml"
    path.write_text(SMALL)
    out = tmp_path / "out"
    assert cli.main(["bake", str(path), "-o", str(out), "-q", "--device", "cpu"]) == 0
    t = read_exr(out / "gold" / "albedo_650nm.exr")
    assert t.shape == (3, 2) and t.meta["spec"]["fresnel"]["type"] == "conductor"
    # mu = 1, roughness 0 (a mirror): E = F(1) = |(n - 1 + ik) / (n + 1 + ik)|^2, the exact conductor Fresnel
    n, k = 0.166, 3.15
    assert t.channels["E"][2, 0] == pytest.approx(((n - 1) ** 2 + k * k) / ((n + 1) ** 2 + k * k), abs=1e-6)
    assert "storage" in t.meta
    g = read_exr(out / "glass" / "dielectric.exr")
    np.testing.assert_allclose(g.channels["R"][:, 0] + g.channels["T"][:, 0], 1.0, atol=1e-6)  # mirror: R + T = 1
    capsys.readouterr()
    before = (out / "plastic" / "albedo.exr").stat().st_mtime_ns
    assert cli.main(["bake", str(path), "-o", str(out), "-q", "--resume"]) == 0
    assert "5 of 5 tables exist, skipped" in capsys.readouterr().err
    assert (out / "plastic" / "albedo.exr").stat().st_mtime_ns == before


def test_library_cli_errors_are_one_line(tmp_path, capsys):
    path = tmp_path / "lib.toml"
    path.write_text(SMALL.replace("f0 = 0.04", "f0 = -1"))
    assert cli.main(["bake", str(path), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "library.materials[2].f0" in err[0]
    path.write_text(SMALL)
    assert cli.main(["bake", str(path), "--format", "npz", "-o", str(tmp_path / "o")]) == 2
    assert "library" in capsys.readouterr().err


@pytest.mark.parametrize("eta", [1e-3, 0.0099, 100.5, 1.0, -2.0])
def test_dielectric_eta_is_checked_in_the_users_terms(eta):
    """eta = 1e-3 used to fail on the library's own 1/eta axis node ("got 1000.0")."""
    with pytest.raises(SpecError) as info:
        library_specs(tomllib.loads(SMALL.replace("eta = 1.5", f"eta = {eta!r}")))
    err = info.value
    assert err.param == "library.materials[1].eta"
    assert "[0.01, 100]" in err.message and repr(float(eta)) in err.message
    assert "1000" not in err.message and len(str(err).splitlines()) == 1


@pytest.mark.parametrize("eta", [0.01, 100.0, 0.5])
def test_dielectric_eta_range_ends_are_accepted(eta):
    specs = dict(library_specs(tomllib.loads(SMALL.replace("eta = 1.5", f"eta = {eta!r}"))))
    values = specs["glass/dielectric.exr"]["axes"]["eta"]["values"]
    assert values == sorted([eta, 1.0 / eta])
