"""Papers' numbers as data, an experiment declaring its own sweep, and the report step over a dataset."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hydra import compose, initialize_config_dir

from pipeline.config import CONFIG_DIR, register_configs
from pipeline.reproduction.paper_report import compare, report
from pipeline.reproduction.papers import load_paper, paper_names
from pipeline.reproduction.readings import H4_PAPER

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]


def test_paper_data_is_the_one_source_of_the_h4_tables():
    assert "seed000_h4" in paper_names()
    paper = load_paper("seed000_h4")
    assert paper["mechanism"] == "h4"
    assert [r["table"] for r in paper["rows"]] == list(H4_PAPER)
    assert H4_PAPER["Table 3 (w_d = 0.5)"] == dict(V=11304.0, gdi=0.0547, d=12.60003, h=9.06147, Qz=39.61105)
    for experiment in paper["experiments"].values():  # every objective has its experiment
        assert (CONFIG_DIR / "experiment" / f"{experiment}.yaml").exists()


def test_table3_experiment_declares_its_sweep():
    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        cfg = compose(config_name="config", overrides=["+experiment=h4_table3"], return_hydra_config=True)
    assert dict(cfg.hydra.sweeper.params) == {"objective.w_d": "0.25,0.5,0.75", "optimizer.seed": "0,1,2"}
    assert cfg.optimizer.name == "ga" and cfg.objective.name == "mixed" and cfg.mechanism.name == "h4"


def test_compare_groups_by_objective_w_d_and_optimiser():
    best = pd.DataFrame(
        {
            "mechanism": ["h4"] * 5 + ["tricept"],
            "objective": ["mixed"] * 4 + ["volume", "mixed"],
            "w_d": [0.5, 0.5, 0.5, 0.25, 0.0, 0.5],
            "optimizer": ["ga", "ga", "cmaes", "ga", "ga", "ga"],
            "volume": [100.0, 200.0, 300.0, 50.0, 70.0, 9.0],
            "gdi": [0.1, 0.3, 0.2, 0.4, 0.5, 0.9],
            "param_d_cm": [1.0, 3.0, 2.0, 4.0, 5.0, 6.0],
            "param_h_cm": [1.0] * 6,
            "param_Qz_cm": [40.0] * 6,
        }
    )
    rows = compare(best, load_paper("seed000_h4"))
    by = {(r[0], r[1], r[3]): r for r in rows}
    ga_v = by[("Table 3 (w_d = 0.5)", "ga", "V")]
    assert ga_v[2] == 2 and ga_v[4] == 11304.0
    assert ga_v[5] == f"{150.0:.4g} ± {np.std([100.0, 200.0], ddof=1):.2g}"
    assert ga_v[6] == f"{100 * (150.0 - 11304.0) / 11304.0:+.1f} %"
    assert by[("Table 3 (w_d = 0.5)", "cmaes", "d (cm)")][5] == "2"  # one run: no spread; d in cm (param_d_cm)
    assert by[("Table 1 (max V)", "ga", "gdi")][5] == "0.5"  # the volume objective, whatever w_d
    assert by[("Table 3 (w_d = 0.25)", "ga", "Qz (cm)")][5] == "40"
    assert ("Table 2 (max GDI)", "-", "-") in by  # no gdi runs: said so
    assert not any(r[1] == "ga" and r[3] == "gdi" and r[5] == "0.9" for r in rows)  # the Tricept row is not H4's

    assert by[("Table 3 (w_d = 0.5)", "ga", "gdi")][3] == "gdi"  # unitless: no unit


def test_compare_labels_a_design_variable_with_the_mechanism_s_unit():
    """A printed design quantity that is a design variable column (the Tricept's ``a``, not a
    ``param_<name>_<unit>`` column) takes its unit from the mechanism's design variables."""
    paper = {"mechanism": "tricept", "rows": [{"table": "T", "objective": "volume", "a": 250.0, "gdi": 0.5}]}
    best = pd.DataFrame(
        {
            "mechanism": ["tricept"] * 2,
            "objective": ["volume"] * 2,
            "w_d": [0.0] * 2,
            "optimizer": ["ga"] * 2,
            "volume": [1.0, 2.0],
            "gdi": [0.4, 0.6],
            "a": [240.0, 260.0],
        }
    )
    assert {r[3] for r in compare(best, paper)} == {"a (mm)", "gdi"}


def test_table3_multirun_then_report(tmp_path):
    """The experiment's own sweep (3 w_d x 3 seeds, tiny sizes) and the report read back from the dataset."""
    out = tmp_path / "out"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pipeline",
            "-m",
            "+experiment=h4_table3",
            "+debug=fast",
            "optimizer.generations=2",
            "optimizer.population=6",
            f"paths.output_dir={out}",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    best = pd.read_parquet(out / "dataset" / "best")
    assert sorted(zip(best["w_d"], best["seed"])) == [(w, s) for w in (0.25, 0.5, 0.75) for s in (0, 1, 2)]
    report_file = tmp_path / "table3.md"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pipeline.reproduction.paper_report",
            str(out / "dataset"),
            "--paper",
            "seed000_h4",
            "--out",
            str(report_file),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    text = report_file.read_text()
    half = best[np.isclose(best["w_d"], 0.5)]
    mean_gdi = half["gdi"].mean()
    assert f"| Table 3 (w_d = 0.5) | ga | 3 | gdi | 0.0547 | {mean_gdi:.4g} ± {half['gdi'].std(ddof=1):.2g} |" in text
    assert "| Table 1 (max V) | - | 0 | - | - | no runs in the dataset | - |" in text


@pytest.mark.parametrize(
    "args, field",
    [
        (["{dataset}", "--paper", "seed999"], "--paper='seed999' is invalid: allowed seed000_h4"),
        (["{missing}", "--paper", "seed000_h4"], "dataset="),
    ],
)
def test_report_refusals_are_one_line(args, field, tmp_path):
    dataset = tmp_path / "dataset"
    (dataset / "best").mkdir(parents=True)
    values = {"dataset": dataset, "missing": tmp_path / "nope"}
    proc = subprocess.run(
        [sys.executable, "-m", "pipeline.reproduction.paper_report", *[a.format(**values) for a in args]],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and field in lines[0], proc.stderr


def test_report_leaves_out_debug_runs_counts_a_repeat_once_and_keeps_studies_apart(tmp_path):
    """What a new user's dataset mixed into Table 3: a +debug run, a repeat of seed 0, h4_mixed run
    again with another orientation (another study, its V in cm³), and a Tricept run whose design
    variable ``d`` is a column empty on the H4's rows. The report: the study's two distinct seeds,
    the other study on its own line, V with its unit, the H4's d from ``param_d_cm``."""
    study, other = "48bd744ccf5e7f27", "33d895a1595e2f1f"
    best = pd.DataFrame(
        {
            "run_id": [f"r{k}" for k in range(6)],
            "mechanism": ["h4"] * 5 + ["tricept"],
            "objective": ["mixed"] * 6,
            "w_d": [0.5] * 6,
            "optimizer": ["ga"] * 6,
            "seed": [0, 0, 7, 0, 0, 0],
            "config_hash": ["a", "a", "b", "c", "d", "e"],
            "study_hash": [study, study, study, other, "f" * 16, "e" * 16],
            "purpose": ["study", "study", "study", "study", "debug", "study"],
            "volume": [100.0, 100.0, 200.0, 5000.0, 1.0, 9.0],
            "volume_unit": ["cm³·rad", "cm³·rad", "cm³·rad", "cm³", "cm³·rad", "mm·rad²"],
            "gdi": [0.05, 0.05, 0.07, 0.2, 0.9, 0.5],
            "param_d_cm": [10.0, 10.0, 14.0, 12.0, 1.0, np.nan],
            "param_h_cm": [9.0] * 5 + [np.nan],
            "param_Qz_cm": [40.0] * 5 + [np.nan],
            "d": [np.nan] * 5 + [100.0],
        }
    )
    dataset = tmp_path / "dataset"
    for table, frame in (("best", best), ("runs", pd.DataFrame({"run_id": best["run_id"], "source": ""}))):
        (dataset / table).mkdir(parents=True)
        frame.to_parquet(dataset / table / "part.parquet")
    text = report(dataset, "seed000_h4")
    assert (
        f"| Table 3 (w_d = 0.5) | ga [48bd74] | 2 | V (cm³·rad) | 11304 | {150.0:.4g} ± {50.0 * 2**0.5:.2g} |" in text
    )
    assert "| Table 3 (w_d = 0.5) | ga [48bd74] | 2 | d (cm) | 12.6 | 12 ± 2.8 |" in text
    assert "| Table 3 (w_d = 0.5) | ga [48bd74] | 2 | h (cm) | " in text and "| Qz (cm) | " in text
    assert "| Table 3 (w_d = 0.5) | ga [33d895] | 1 | V (cm³) | 11304 | 5000 |" in text
    assert "0.9" not in text and "Debug runs only" not in text  # the debug run left out, and not a smoke test
    smoke = best.assign(purpose="debug")
    smoke.to_parquet(dataset / "best" / "part.parquet")
    assert "**Debug runs only**" in report(dataset, "seed000_h4")
