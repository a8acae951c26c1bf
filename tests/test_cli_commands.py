"""The command line's subcommands (evaluate, aggregate, report), ``--help`` and did-you-mean."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import pandas as pd
import pytest

from kinematics import get_mechanism
from kinematics.workspace import evaluate
from pipeline.cli import evaluate_command, precheck_overrides, print_help
from pipeline.config import CONFIG_DIR, register_configs
from pipeline.store.dataset import read_dataset

ROOT = Path(__file__).resolve().parents[1]


def test_evaluate_one_design_prints_a_table_and_writes_parquet(tmp_path, capsys):
    out = tmp_path / "design.parquet"
    code = evaluate_command(
        [
            "mechanism=tricept",
            "a=250",
            "b=400",
            "d=100",
            "evaluate.resolution=16",
            "evaluate.allow_coarse=true",
            "objective.w_d=0.3",
            "--parquet",
            str(out),
        ]
    )
    printed = capsys.readouterr().out
    assert code == 0, printed
    row = pd.read_parquet(out).iloc[0]
    # the same numbers as the evaluator called directly on that design, grid and (default) method
    assert row["method"] == "grid" and row["resolution"] == 16
    ev = evaluate(
        get_mechanism("tricept", a=250.0, b=400.0, d=100.0), resolution=16, method="grid", error_estimate=False
    )
    assert row["volume"] == pytest.approx(ev.volume, rel=1e-12)
    assert row["gdi"] == pytest.approx(ev.gdi, rel=1e-12)
    assert row["eta"] == pytest.approx(0.3 * row["gdi"] + 0.7 * row["suri"])
    assert row["volume_unit"] == "mm·rad²" and "param_a" not in row.index and "param_q_min_mm" in row.index
    assert "volume" in printed and "mm·rad²" in printed and "eta" in printed


@pytest.mark.parametrize(
    "argv, message",
    [
        (["mechanism=tricpt", "a=250", "b=400", "d=100"], "did you mean tricept?"),
        (["mechanism=tricept", "a=250", "b=400"], "d is missing"),
        (["mechanism=tricept", "a=900", "b=400", "d=100"], "a=900.0 is invalid"),
        (["mechanism=rpr2", "design=[1,2,3]"], "design="),
    ],
)
def test_evaluate_refuses_bad_input_in_one_line(argv, message, capsys):
    assert evaluate_command(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and err.startswith("error:") and "\n" not in err


@pytest.mark.parametrize(
    "override, hint",
    [
        ("objective.wd=0.5", "did you mean objective.w_d?"),  # Hydra alone advises "+objective.wd"
        ("+objective.wd=0.5", "did you mean objective.w_d?"),
        ("mechanism=tricpt", "did you mean tricept?"),
        ("+experiment=h4_mxed", "did you mean h4_mixed?"),
    ],
)
def test_unknown_keys_and_names_get_a_did_you_mean(override, hint, capsys):
    register_configs()
    with pytest.raises(SystemExit) as exit_info:
        precheck_overrides([override])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert hint in err and "\n" not in err, err


def test_help_names_every_experiment_with_one_line(capsys):
    print_help()
    text = capsys.readouterr().out
    for path in sorted((CONFIG_DIR / "experiment").glob("*.yaml")):
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(path.stem + " "))
        assert len(line.split(None, 1)[1]) > 15, line  # says what it is
    for command in ("evaluate", "aggregate", "report"):
        assert f"pm-design {command}" in text


@pytest.mark.slow
def test_console_help_and_subcommands_run_before_hydra(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "pipeline", "--help"], capture_output=True, text=True, cwd=tmp_path, timeout=120
    )
    assert proc.returncode == 0 and "h4_table3" in proc.stdout, proc.stderr
    proc = subprocess.run(
        [sys.executable, "-m", "pipeline", "report", "nowhere"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,
    )
    assert proc.returncode == 2 and proc.stderr.startswith("error: source='nowhere'"), proc.stderr


def test_no_vendored_wheels():
    assert not list(ROOT.glob("*.whl")) and not list(ROOT.glob("*/*.whl"))


def test_read_dataset_refuses_unknown_tables(tmp_path):
    from pipeline.errors import ConfigError

    with pytest.raises(ConfigError, match="table='bset' is invalid"):
        read_dataset(tmp_path, "bset")
    with pytest.raises(ConfigError, match="no best table"):
        read_dataset(tmp_path)


def test_help_lists_the_experiments_of_plug_in_packages(tmp_path, monkeypatch, capsys):
    """As a run finds them: Hydra's search path, with the packages' ``pm_design.configs`` entry points."""
    from hydra_plugins.pm_design import external_configs
    from tests.test_external_mechanism import EXAMPLE, write_distribution_record

    write_distribution_record(tmp_path)  # what pip install examples/five_bar records
    monkeypatch.syspath_prepend(str(EXAMPLE / "src"))
    monkeypatch.syspath_prepend(str(tmp_path))
    external_configs._search_paths.cache_clear()  # the search path of this process, without the package
    try:
        print_help()
    finally:
        external_configs._search_paths.cache_clear()
    text = capsys.readouterr().out
    line = next(ln for ln in text.splitlines() if ln.strip().startswith("five_bar_mixed "))
    assert "five-bar" in line  # its own summary line, read from the package
    assert any(ln.strip().startswith("h4_mixed ") for ln in text.splitlines())


def test_read_dataset_says_so_when_its_purposes_leave_no_row(tmp_path):
    """A dataset of ``+debug`` runs only read with the default purposes: an empty frame, and one
    warning naming the purposes left out and how to keep them (an empty frame alone reads as
    "nothing ran")."""
    (tmp_path / "best").mkdir()
    pd.DataFrame({"run_id": ["a", "b"], "purpose": ["debug", "debug"], "eta": [0.1, 0.2]}).to_parquet(
        tmp_path / "best" / "a.parquet"
    )
    with pytest.warns(
        UserWarning, match=r"all 2 rows of best are debug runs, left out by purposes=\('study', 'benchmark'\)"
    ):
        assert read_dataset(tmp_path).empty
    assert len(read_dataset(tmp_path, purposes=None)) == 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # rows kept: no warning
        assert len(read_dataset(tmp_path, purposes=("debug",))) == 2
