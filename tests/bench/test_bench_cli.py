"""``bsdf-tab bench``: finds the checkout's bench/ scripts and runs them with the arguments
that follow the name; every failure before the run is one line (exit 2 through the CLI)."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bsdf_tab.cli import bench as cli_bench
from bsdf_tab.cli.common import CliError


def _args(name, *rest):
    return argparse.Namespace(benchmark=name, bench_args=list(rest), debug=False)


def _one_line_error(name, *rest, match):
    with pytest.raises(CliError) as info:
        cli_bench.run(_args(name, *rest))
    message = str(info.value)
    assert "\n" not in message and match in message, message
    return message


def test_parser_takes_the_name_and_passes_the_rest_through():
    parser = argparse.ArgumentParser()
    cli_bench.configure(parser)
    args = parser.parse_args(["accuracy", "--quick", "-o", "x", "--methods", "adaptive"])
    assert args.benchmark == "accuracy" and args.bench_args == ["--quick", "-o", "x", "--methods", "adaptive"]
    assert parser.parse_args([]).benchmark is None


def test_unknown_or_missing_benchmark_is_one_line():
    _one_line_error("nope", "--quick", match="unknown benchmark 'nope'")
    _one_line_error(None, match="choose a benchmark")


def test_outside_a_checkout_is_one_line(tmp_path, monkeypatch):
    monkeypatch.delenv(cli_bench.CHECKOUT_ENV, raising=False)
    monkeypatch.setattr(cli_bench, "PACKAGE_PARENT", tmp_path / "site-packages")
    monkeypatch.chdir(tmp_path)
    message = _one_line_error("accuracy", "--quick", match="bsdf-tab bench needs a source checkout: ")
    assert str(tmp_path) in message
    monkeypatch.setenv(cli_bench.CHECKOUT_ENV, str(tmp_path))
    _one_line_error("accuracy", match=cli_bench.CHECKOUT_ENV)
    assert not any(tmp_path.iterdir())


def test_the_checkout_is_found_from_the_current_folder(tmp_path, monkeypatch):
    (tmp_path / "bench").mkdir()
    (tmp_path / "bench" / "accuracy.py").write_text("")
    (tmp_path / "bsdf_tab").mkdir()
    (tmp_path / "deep" / "er").mkdir(parents=True)
    monkeypatch.delenv(cli_bench.CHECKOUT_ENV, raising=False)
    monkeypatch.setattr(cli_bench, "PACKAGE_PARENT", tmp_path / "elsewhere")
    assert cli_bench.find_checkout(tmp_path / "deep" / "er") == tmp_path.resolve()


def test_accuracy_help_and_bad_options_run_nothing(tmp_path, capsys):
    assert cli_bench.run(_args("accuracy", "--help")) == 0
    assert "usage: bsdf-tab bench accuracy" in capsys.readouterr().out
    with pytest.raises(ValueError, match="--methods"):
        cli_bench.run(_args("accuracy", "--quick", "-o", str(tmp_path), "--methods", "bogus"))
    assert cli_bench.run(_args("accuracy", "--bogus")) == 2  # argparse's own usage error
    assert not any(tmp_path.iterdir())


def test_through_the_command_line(capsys):
    from bsdf_tab.cli import main

    assert main(["bench", "nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bsdf-tab: error: unknown benchmark"), err


def test_building_the_parser_loads_no_benchmark_code(tmp_path):
    """``bsdf-tab --help`` builds every subcommand's parser: bench/ stays unimported."""
    code = ("import sys; from bsdf_tab.cli import build_parser; build_parser(); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('bench', 'tests')))")
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_every_registered_benchmark_takes_argv_and_prog():
    """`bsdf-tab bench NAME` calls the script's main(argv, prog=...): a main without prog failed
    as an internal error (core, versions, honesty ... until issue 14's eleventh session)."""
    import ast

    root = Path(__file__).resolve().parents[2] / "bench"
    for name, (script, _) in cli_bench.BENCHMARKS.items():
        tree = ast.parse((root / script).read_text(encoding="utf-8"))
        # a script may re-export main (bench/accuracy.py: from bench.accuracy_sweep import main)
        for node in tree.body:
            if isinstance(node, ast.ImportFrom) and any(a.name == "main" for a in node.names):
                tree = ast.parse((root / (node.module.split(".")[-1] + ".py")).read_text(encoding="utf-8"))
        mains = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "main"]
        assert len(mains) == 1, name
        params = [a.arg for a in mains[0].args.args + mains[0].args.kwonlyargs]
        assert params[:1] == ["argv"] and "prog" in params, (name, params)


def test_a_benchmark_usage_error_is_exit_2_under_its_cli_name(capsys):
    assert cli_bench.run(_args("gpu_launch", "--block-dims", "0")) == 2
    assert "bsdf-tab bench gpu_launch: error: --block-dims" in capsys.readouterr().err
