"""Bad input on the command line: one ``error:`` line naming the field and what is allowed, exit 2,
before any work and without a partial output file (new-user review of the command line)."""

from __future__ import annotations

import sys

import pandas as pd
import pytest

from pipeline.cli import evaluate_command, precheck_overrides
from pipeline.cli.commands import subcommand
from pipeline.config import register_configs

RPR2 = ["mechanism=rpr2", "design=[5,6]"]


def _one_line(capsys) -> str:
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("error:") and "\n" not in err and "Traceback" not in err, err
    return err


def test_an_unusable_parquet_path_is_refused_before_the_evaluation(tmp_path, capsys):
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    assert evaluate_command([*RPR2, "--parquet", str(not_a_folder / "x.parquet")]) == 2
    out = capsys.readouterr()
    assert out.out == "", "the table was computed before the path was checked"
    assert out.err.startswith("error: --parquet=") and "allowed" in out.err and out.err.count("\n") == 1


def test_an_unusable_report_path_is_refused_before_the_report(tmp_path, capsys):
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    assert subcommand(["report", str(tmp_path), "--out", str(not_a_folder / "r.html")]) == 2
    err = _one_line(capsys)
    assert err.startswith("error: --out=") and "allowed" in err
    assert subcommand(["report", str(tmp_path), f"--out={tmp_path}"]) == 2  # a folder, not a file
    assert "--out=" in _one_line(capsys)


@pytest.mark.parametrize(
    "argv, says, never",
    [
        # the design box's bound, not the mechanism parameter it feeds
        (
            ["mechanism.design.lower=[-1,0.01,0.35]", "+debug=fast"],
            ["mechanism.design.lower=", "d_ratio=-1", "allowed for d_ratio", "[0.01, 0.15]"],
            "mechanism.fixed",
        ),
        # another optimiser's key: which ones have it, and the nearest key of the chosen one
        (
            ["optimizer=cmaes", "optimizer.population=4", "+debug=fast"],
            ["not a key of cmaes", "optimizer=de", "did you mean optimizer.popsize?"],
            "did you mean optimizer.population",
        ),
        # a sweep's job that does not have the key: the job and the mechanism's own keys
        (
            ["-m", "mechanism=h4,rpr2", "mechanism.fixed.stroke=50", "+debug=fast"],
            ["job 1 (mechanism=rpr2", "mechanism.fixed.stroke is not a parameter of rpr2", "mechanism.fixed.q_max"],
            "To append",
        ),
        (["sample.n=nan", "+debug=fast"], ["sample.n=nan is invalid: allowed an integer in [1, 1000000]"], "merging"),
        (["evaluate.allow_coarse=maybe"], ["evaluate.allow_coarse=maybe is invalid: allowed true or false"], "merging"),
        (["objective.wd=0.5"], ["did you mean objective.w_d?"], "To append"),
        # a weight the objective ignores would be recorded as if it had been used
        (
            ["+experiment=h4_mixed", "objective=volume", "objective.w_d=0.3", "+debug=fast"],
            ["error: objective.w_d=0.3 is invalid: allowed 0 with objective=volume (only objective=mixed uses w_d)"],
            "Traceback",
        ),
        (
            ["evaluate.method=foo"],
            ["error: evaluate.method='foo' is invalid: allowed one of grid, midpoint"],
            "merging",
        ),
    ],
)
def test_a_run_s_bad_override_names_its_field(argv, says, never, capsys):
    register_configs()
    with pytest.raises(SystemExit) as exit_info:
        precheck_overrides(argv)
    assert exit_info.value.code == 2
    err = _one_line(capsys)
    assert all(s in err for s in says) and never not in err, err


def _refused(argv: list[str], capsys) -> str:
    register_configs()
    with pytest.raises(SystemExit) as exit_info:
        precheck_overrides(argv)
    assert exit_info.value.code == 2
    return _one_line(capsys)


@pytest.mark.parametrize("spelling", ["nan", ".nan", ".NaN", "-inf", ".inf", "-.inf"])
@pytest.mark.parametrize(
    "key, allowed",
    [
        ("mechanism.min_inverse_condition", "[0, 1)"),
        ("mechanism.length", "null or a finite number > 0"),
        ("evaluate.max_hours", "(0, 10000]"),
    ],
)
def test_every_spelling_of_nan_and_inf_names_the_field_and_its_range(key, allowed, spelling, capsys):
    # Hydra reads nan and inf as numbers, but YAML's .nan and .inf as text: both reach the field's range
    err = _refused([f"{key}={spelling}", "+debug=fast"], capsys)
    assert err.startswith(f"error: {key}=") and err.endswith(f"is invalid: allowed {allowed}"), err


@pytest.mark.parametrize(
    "argv, allowed",
    [
        (["mechanism.orientation=[.nan,10]"], "null or [lo, hi] in degrees"),
        (["mechanism.design.lower=[.nan,0.01,0.35]"], "finite numbers with lower < upper"),
        (["mechanism=rpr2", "mechanism.design.upper=[.inf,6]"], "finite numbers with lower < upper"),
        # a scalar where a list is due: OmegaConf's "Invalid value assigned", not "Value '...'"
        (["mechanism.orientation=.nan"], "null or [lo, hi] in degrees"),
        (["mechanism.orientation=3"], "null or [lo, hi] in degrees"),
        (["mechanism.design.lower=.nan"], "finite numbers with lower < upper"),
    ],
)
def test_a_list_with_yaml_s_nan_names_the_field_and_what_it_takes(argv, allowed, capsys):
    err = _refused([*argv, "+debug=fast"], capsys)
    key = argv[-1].split("=", 1)[0]
    assert err.startswith(f"error: {key}=") and allowed in err and "allowed a number" not in err, err


def test_mechanism_path_without_a_class_names_mechanism_name_and_what_it_takes(capsys):
    err = _refused(["mechanism=path", "+debug=fast"], capsys)
    assert err.startswith("error: mechanism.name is missing:"), err
    assert "mechanism.name=package.module:Class" in err and "mechanism=h4" not in err and "h4" in err, err
    assert "Structured config" not in err, err


def test_an_unknown_mechanism_option_says_what_path_needs(capsys):
    err = _refused(["mechanism=h5", "+debug=fast"], capsys)
    assert "allowed: delta," in err and "path (a Mechanism class of your own: also set mechanism.name=" in err, err


def test_the_time_budget_names_the_bound_the_resolution_and_what_passes(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    # the default resolution of h4 (the user set none): the bound the user set is named first
    err = _refused(["evaluate.max_hours=0.001"], capsys)
    assert err.startswith("error: evaluate.max_hours=0.001 is invalid: the run at evaluate.resolution="), err
    assert "(the default of h4, method grid)" in err and "parallel.n_jobs=2" in err, err
    assert "evaluate.resolution <= " in err and "evaluate.allow_coarse=true" in err, err
    # each change the message allows passes the check
    hours = err.split("allowed: evaluate.max_hours >= ", 1)[1].split(",", 1)[0]
    precheck_overrides([f"evaluate.max_hours={hours}"])
    err = _refused(["evaluate.resolution=39", "evaluate.max_hours=0.05"], capsys)
    assert err.startswith("error: evaluate.max_hours=0.05 is invalid: the run at evaluate.resolution=39 is"), err
    top = err.split("evaluate.resolution <= ", 1)[1].split(",", 1)[0]
    assert "allow_coarse" not in err, err
    precheck_overrides([f"evaluate.resolution={top}", "evaluate.max_hours=0.05"])
    assert "is estimated at" in _refused([f"evaluate.resolution={int(top) + 1}", "evaluate.max_hours=0.05"], capsys)


@pytest.mark.parametrize(
    "argv, says",
    [
        (["mechanism=h4", "d_ration=0.06", "h_ratio=0.1", "Qz_ratio=0.4"], ["d_ration is not a design variable of h4"]),
        (["mechanism=h4", "d_ratio=0.06", "h_ratio=0.1", "Qz_ratio=0.4", "+dd=3"], ["d_ratio=... h_ratio=..."]),
        (["mechanism=h5", "d_ratio=0.06"], ["mechanism=h5 is invalid: allowed delta", "path with mechanism.name="]),
        ([*RPR2, "objective.w_d=2"], ["error: objective.w_d=2.0 is invalid: allowed [0, 1]"]),
        (["mechanism=rpr2", "b=x", "q_min=6"], ["b='x' is invalid: allowed a number in [1, 10] mm"]),
        ([*RPR2, "sample.n=nan"], ["error: sample.n=nan is invalid: allowed an integer"]),
        ([*RPR2, "mechanism.fixed.stroke=50"], ["mechanism.fixed.stroke is not a parameter of rpr2"]),
        ([*RPR2, "evaluate.method=foo"], ["error: evaluate.method='foo' is invalid: allowed one of grid, midpoint"]),
    ],
)
def test_evaluate_s_errors_are_the_plain_one_liner_of_their_field(argv, says, capsys):
    register_configs()
    assert evaluate_command(argv) == 2
    err = _one_line(capsys)
    assert all(s in err for s in says), err
    assert "design is invalid" not in err and "allowed numbers" not in err and "+" not in err.split(":")[1], err


def test_evaluate_takes_a_class_by_its_path_like_a_run(capsys):
    register_configs()
    assert evaluate_command(["mechanism=path", "mechanism.name=kinematics.rpr2:RPR2", "design=[5,6]"]) == 0
    by_path = capsys.readouterr().out.splitlines()
    assert evaluate_command(RPR2) == 0
    by_name = capsys.readouterr().out.splitlines()
    assert by_path[0].split() == ["mechanism", "kinematics.rpr2:RPR2"]  # as a run's rows name it
    assert by_path[1:] == by_name[1:] and any(ln.startswith("volume ") for ln in by_name)


def test_a_module_in_the_working_folder_is_explained_for_the_console_script(tmp_path, monkeypatch, capsys):
    (tmp_path / "my_cli_mech.py").write_text("from kinematics.rpr2 import RPR2 as MyBar\n")
    monkeypatch.chdir(tmp_path)
    # as under the pm-design console script: the working folder is not on sys.path
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", ".", str(tmp_path))])
    register_configs()
    assert evaluate_command(["mechanism=path", "mechanism.name=my_cli_mech:MyBar", "design=[5,6]"]) == 2
    err = _one_line(capsys)
    assert "mechanism.name='my_cli_mech:MyBar'" in err and "python -m pipeline" in err and "pip install" in err


@pytest.mark.parametrize("method", ["grid", "midpoint"])
def test_evaluate_records_its_integration_method(method, tmp_path, capsys):
    """``pm-design evaluate`` takes ``evaluate.method`` (default grid) and records it beside the resolution."""
    from kinematics import MECHANISMS
    from kinematics.workspace import default_resolution, evaluate

    out = tmp_path / "design.parquet"
    given = [] if method == "grid" else [f"evaluate.method={method}"]
    assert evaluate_command([*RPR2, *given, "--parquet", str(out)]) == 0
    assert any(line.split() == ["method", method] for line in capsys.readouterr().out.splitlines())
    row = pd.read_parquet(out).iloc[0]
    rpr2 = MECHANISMS["rpr2"]
    mech = rpr2.from_design([5.0, 6.0], **rpr2.default_fixed)
    assert row["method"] == method and row["resolution"] == default_resolution(mech, None, None, method)
    ev = evaluate(mech, resolution=int(row["resolution"]), method=method, error_estimate=False)
    assert (row["volume"], row["gdi"]) == (ev.volume, ev.gdi)


def test_evaluate_s_parquet_has_the_dataset_s_integer_columns(tmp_path, capsys):
    out = tmp_path / "design.parquet"
    assert evaluate_command([*RPR2, "--parquet", str(out)]) == 0
    table = pd.read_parquet(out)
    for column in ("n_samples", "n_inside", "resolution"):
        assert table[column].dtype == "int64", (column, table[column].dtype)


def test_the_node_budget_allows_the_resolution_that_fills_it_exactly(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    # 64000 = (20 x 2)^3 refined nodes: 20 passes, though 64000 ** (1 / 3) / 2 is 19.999... in floating point
    budget = ["evaluate.max_nodes=64000", "evaluate.refine_factor=2", "+debug=fast"]
    precheck_overrides([*budget, "mechanism=tricept", "evaluate.resolution=20"])
    err = _refused([*budget, "mechanism=tricept", "evaluate.resolution=21"], capsys)
    assert "allowed <= 20 for tricept" in err, err
    # H4 takes half the nodes along theta: 50 x 50 x 25 = 62500 <= 64000 < 52 x 52 x 26 refined nodes
    precheck_overrides([*budget, "evaluate.resolution=25"])
    err = _refused([*budget, "evaluate.resolution=26"], capsys)
    assert "allowed <= 25 for h4" in err, err


def test_the_time_budget_counts_the_reference_optimum_s_evaluations(tmp_path, monkeypatch, capsys):
    from pipeline.optimizers.reference import expected_evaluations

    monkeypatch.chdir(tmp_path)
    bound = ["evaluate.resolution=39", "evaluate.max_hours=0.01"]
    alone = _refused([*bound, "optimizer.reference=false"], capsys)
    with_reference = _refused([*bound, "optimizer.reference=true"], capsys)
    spent = int(alone.split("h (", 1)[1].split(" evaluations", 1)[0])
    reference = expected_evaluations(3)
    nodes = 39 * 39 * 20  # h4's theta: half the nodes, rounded up
    assert (
        f"h ({spent + reference} evaluations of {nodes:.3g} nodes, {reference} of them the reference" in with_reference
    )
    assert "optimizer.reference=false" in with_reference and "optimizer.reference=false" not in alone


def test_the_time_budget_counts_the_workers_the_machine_has(tmp_path, monkeypatch, capsys):
    """More parallel.n_jobs than cores run on the cores (pipeline.evaluation.pool.worker_count):
    asking for more does not pass the time budget, and the message does not suggest it."""
    from joblib import cpu_count

    monkeypatch.chdir(tmp_path)
    cores = max(1, int(cpu_count()))
    bound = ["evaluate.resolution=39", "evaluate.max_hours=0.05"]
    err = _refused([*bound, f"parallel.n_jobs={cores + 62}"], capsys)
    assert f"x {cores} workers of parallel.n_jobs={cores + 62}" in err and "more parallel.n_jobs" not in err, err
    assert _refused(bound, capsys).split(" h (", 1)[0] == err.split(" h (", 1)[0]  # the same estimate
    # as many jobs as cores: one more would be capped too, so it is not suggested
    assert "more parallel.n_jobs" not in _refused([*bound, f"parallel.n_jobs={cores}"], capsys)
    if cores > 1:
        assert "more parallel.n_jobs" in _refused([*bound, "parallel.n_jobs=1"], capsys)


def test_another_objective_on_a_mixed_experiment_takes_its_own_w_d():
    """``+experiment=h4_mixed objective=volume``: the experiment leaves w_d to its objective option
    (volume: 0), so switching the objective needs no second override."""
    from pipeline.config import validate
    from tests.test_config_sources import _compose

    assert validate(_compose(["+experiment=h4_mixed", "objective=volume"])).objective.w_d == 0.0
    assert validate(_compose(["+experiment=h4_max_gdi"])).objective.w_d == 1.0


def test_a_default_resolution_over_the_node_budget_is_named_as_the_default_with_its_fixes(capsys):
    """The user set no evaluate.resolution: the message says whose default it is (mechanism,
    orientation, method) and lists settings that pass, each of which does."""
    from pipeline.cli.evaluate import _compose_evaluate, evaluate_overrides
    from pipeline.config import validate

    register_configs()
    argv = [
        "mechanism=gough_stewart",
        "r_platform=250",
        "sep_base=30",
        "sep_platform=30",
        "height=700",
        "mechanism.orientation=[-5,5]",
    ]
    assert evaluate_command(argv) == 2
    err = _one_line(capsys)
    # the resolution the user never typed (5 when this was reported) is the mechanism's default
    assert err.startswith(
        "error: evaluate.resolution=5 (not set: the default of gough_stewart at mechanism.orientation=[-5, 5], "
        "method grid) is invalid: allowed <= "
    ), err
    fixes = err.rsplit("; allowed: ", 1)[1].split(", or ")
    assert fixes[0].startswith("evaluate.max_nodes=") and "mechanism.orientation=null" in fixes[-1], fixes
    assert any(f.startswith("evaluate.resolution=") and "evaluate.allow_coarse=true" in f for f in fixes), fixes
    for fix in fixes:  # each named setting passes the check
        given = [w for w in fix.replace(" with ", " ").split() if "=" in w]
        validate(_compose_evaluate(evaluate_overrides([*argv, *given])[2]))
    # a resolution the user did set is named as theirs, as before
    assert evaluate_command([*argv, "evaluate.resolution=5", "evaluate.allow_coarse=true"]) == 2
    err = _one_line(capsys)
    assert err.startswith("error: evaluate.resolution=5 is invalid: allowed <= "), err
    assert "for gough_stewart (6 sampled axes" in err, err
    assert "default" not in err, err


@pytest.mark.parametrize("key, mode", [("hydra.run.dir", []), ("hydra.sweep.dir", ["-m", "objective.w_d=0,1"])])
def test_an_unusable_run_or_sweep_dir_is_refused_before_hydra(key, mode, tmp_path, capsys):
    """A folder under a regular file (root writes anywhere else): the same one line for the
    sweep's folder as for a run's, not the OSError of the sweeper's mkdir (exit 1)."""
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    err = _refused([*mode, "+experiment=rpr2_mixed", "+debug=fast", f"{key}={not_a_folder / 'sw'}"], capsys)
    assert err.startswith(f"error: {key}='{not_a_folder / 'sw'}' is invalid: ") and err.endswith(
        "allowed: a writable directory"
    ), err
    assert [p.name for p in tmp_path.iterdir()] == ["file"]


def test_the_sweeper_refuses_an_unusable_sweep_dir_before_any_job(tmp_path, capsys):
    """Launches that bypass the command line's precheck (the reproduction's) meet the same check
    in the sweeper, before it composes a job or creates the folder."""
    from omegaconf import OmegaConf

    from pipeline.sweeps.sweeper import CheckedSweeper

    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    sweeper = CheckedSweeper()
    sweeper.config = OmegaConf.create({"hydra": {"sweep": {"dir": str(not_a_folder / "sw")}}})
    with pytest.raises(SystemExit) as exit_info:
        sweeper.sweep(["objective.w_d=0,1"])
    assert exit_info.value.code == 2
    err = _one_line(capsys)
    assert err.startswith("error: hydra.sweep.dir=") and "allowed: a writable directory" in err, err


@pytest.mark.parametrize("typed", ["mechanism.fixed.q_max=1000", "+mechanism.fixed.q_max=1000"])
def test_a_fixed_parameter_shared_by_a_sweep_over_mechanisms_is_told_to_use_plus_plus(typed, tmp_path, capsys):
    """Hydra's advice for either spelling is the other, which fails too; ++ is what works."""
    sweep = ["-m", "mechanism=rpr2,gough_stewart", "+debug=fast", f"hydra.sweep.dir={tmp_path / 'sw'}"]
    err = _refused([*sweep, typed], capsys)
    assert err.startswith(f"error: {typed} is invalid in a sweep over mechanism: "), err
    assert "allowed: ++mechanism.fixed.q_max=1000" in err and "To append" not in err, err
    precheck_overrides([*sweep, "++mechanism.fixed.q_max=1000"])  # the advice passes


def test_plus_plus_on_a_swept_mechanism_without_the_key_names_the_mechanism_and_the_key():
    """++ adds the key to every job's mechanism: the job whose mechanism lacks it (h4 has no
    q_max) is refused by the check the sweeper runs on every job, in one line."""
    from pipeline.cli.precheck import _compose
    from pipeline.config import validate
    from pipeline.errors import ConfigError

    register_configs()
    with pytest.raises(ConfigError) as refused:
        validate(_compose(["mechanism=h4", "++mechanism.fixed.q_max=1000", "+debug=fast"]))
    message = str(refused.value)
    assert message.startswith("mechanism.fixed.q_max=1000 is invalid: allowed keys ") and message.endswith("for h4")
    assert "\n" not in message
