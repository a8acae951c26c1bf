"""Every figure the project writes says what it shows: each axes has ink, axis labels with units
and a title (its own or the figure's). Figures are captured as they are saved, so what is checked
is what lands in the PNG."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

import pipeline.stages.plot as plot_module
from kinematics import MECHANISMS
from pipeline.config import MechanismConfig


@pytest.fixture
def saved(monkeypatch):
    figures: list[Figure] = []
    real = Figure.savefig

    def savefig(self, *args, **kwargs):
        figures.append(self)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return figures


def _has_unit(label: str) -> bool:
    return "[" in label and label.rstrip().endswith("]") or ("[" in label and "]" in label)


def check_figure(fig: Figure) -> None:
    suptitle = fig._suptitle.get_text() if fig._suptitle is not None else ""
    plots = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.axison]
    assert plots, "no axes"
    for ax in plots:
        ink = list(ax.lines) + list(ax.collections) + list(ax.images) + list(ax.patches)
        assert ink, f"empty axes: {ax.get_title()!r}"
        arrays = [c.get_array() for c in ax.collections if c.get_array() is not None]
        if arrays and not ax.lines:
            assert any(np.isfinite(np.ma.filled(a.astype(float), np.nan)).any() for a in arrays), "blank mesh"
        siblings = ax.get_shared_x_axes().get_siblings(ax)
        xlabel = ax.get_xlabel() or next((s.get_xlabel() for s in siblings if s.get_xlabel()), "")
        assert _has_unit(xlabel), f"x label without unit: {xlabel!r}"
        assert _has_unit(ax.get_ylabel()), f"y label without unit: {ax.get_ylabel()!r}"
        title = ax.get_title() or next((s.get_title() for s in siblings if s.get_title()), "") or suptitle
        assert len(title) > 8, f"no title saying what is plotted: {title!r}"
    for bar in [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]:
        assert _has_unit(bar.get_ylabel() or bar.get_xlabel()), "colour bar without a label and unit"


@pytest.mark.slow  # 120² slices per mechanism
@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_run_workspace_figures_state_the_design_volume(name, tmp_path, saved):
    config = MechanismConfig(name=name)
    mech = config.build(config.centre)
    plot_module.plot_workspace(
        mech,
        config.orientation_rad() or mech.default_orientation,
        0.01,
        None,
        tmp_path,
        f"{name}, test",
        design_volume="design's V = 1 u",
    )
    assert len(saved) == 2
    for fig in saved:
        check_figure(fig)
        assert "design's V = 1 u" in fig.axes[0].get_title()


def test_run_and_sweep_figures(tmp_path, saved):
    history = pd.DataFrame(
        {"generation": range(20), "best": np.linspace(0.1, 0.3, 20), "mean": np.linspace(0.05, 0.25, 20)}
    )
    plot_module.plot_convergence(
        history, tmp_path / "c.png", "ga convergence (h4, mixed)", "η [1]", reference=0.31, gap="3.23 % ± 0.05 %"
    )
    assert "gap 3.23 % ± 0.05 %" in saved[-1].axes[0].get_legend().get_texts()[-1].get_text()
    best = pd.DataFrame(
        {
            "objective": ["mixed"] * 6,
            "mechanism": ["h4"] * 6,
            "optimizer": ["ga"] * 6,
            "w_d": [0.0, 0.5, 1.0] * 2,
            "seed": [0, 0, 0, 0, 0, 0],
            "gdi": np.linspace(0.1, 0.4, 6),
            "suri": np.linspace(0.5, 0.2, 6),
            "objective_value": np.linspace(0.3, 0.2, 6),
            "objective_error": [0.01, 0.0, 0.02, 0.0, 0.0, 0.0],
        }
    )
    plot_module.plot_tradeoff(best, tmp_path / "t.png")
    assert "one seed per point" in saved[-1].axes[0].get_title()  # repeats of seed 0 are not seeds
    # η's error bars: the first run of each w_d (repeats of a seed count once), half-height its error
    (bars,) = [c for c in saved[-1].axes[0].collections if isinstance(c, LineCollection)]
    heights = sorted(round(float(abs(seg[1, 1] - seg[0, 1])) / 2, 9) for seg in bars.get_segments())
    assert heights == [0.0, 0.01, 0.02]
    plot_module.plot_front(
        pd.DataFrame({"volume": [1.0, 2.0], "gdi": [0.3, 0.2]}),
        ["volume", "gdi"],
        tmp_path / "f.png",
        "h4",
        units={"volume": "cm³·rad"},
    )
    assert saved[-1].axes[0].get_xlabel() == "V [cm³·rad]"
    for fig in saved:
        check_figure(fig)


@pytest.mark.slow  # three reproduction figures at their own resolutions
def test_reproduction_figures_that_stand_alone(saved):
    from pipeline.reproduction.delta import section_png
    from pipeline.reproduction.h4_figures import workspace_pngs
    from pipeline.reproduction.tricept import slices_png

    workspace_pngs(6.0, 6.0, 42.0, 145723.0)
    slices_png(250.0, 400.0, 100.0, 657.5)
    section_png(resolution=40)
    assert "145723 cm³·rad" in saved[0].axes[0].get_title()  # the design's V, not the slice's
    assert "657.5 mm·rad²" in saved[2]._suptitle.get_text()
    for fig in saved:
        check_figure(fig)


def test_report_convergence_has_one_panel_per_mechanism(saved):
    from pipeline.report.figures import convergence_figure

    best = pd.DataFrame(
        {
            "run_id": ["a", "b", "c"],
            "mechanism": ["h4", "h4", "rpr2"],
            "objective": ["mixed"] * 3,
            "objective_unit": ["1"] * 3,
            "w_d": [0.5, 0.5, 0.5],
            "optimizer": ["cmaes"] * 3,
            "seed": [0, 1, 0],
            "reference_value": [0.21, 0.21, np.nan],
        }
    )
    # a restart at generation 2 lowers the generation's best; the curve is the best so far
    history = pd.DataFrame(
        {
            "run_id": ["a"] * 4 + ["b"] * 4 + ["c"] * 4,
            "generation": list(range(4)) * 3,
            "best": [0.1, 0.2, 0.15, 0.2, 0.1, 0.19, 0.12, 0.2, 0.7, 0.8, 0.6, 0.8],
        }
    )
    convergence_figure(best, history)
    (fig,) = saved
    check_figure(fig)
    panels = [ax for ax in fig.axes if ax.axison]
    assert [ax.get_title().split(":")[0] for ax in panels] == ["h4", "rpr2"]
    h4_mean = panels[0].lines[0].get_ydata()
    assert list(h4_mean) == pytest.approx([0.1, 0.195, 0.195, 0.2])  # never decreases
    assert "dashed: reference" in panels[0].get_title() and "dashed" not in panels[1].get_title()


def test_tradeoff_keeps_optimisers_and_experiments_apart_in_rows_of_three(tmp_path, saved):
    """GA (h4_mixed), NSGA-II (h4_pareto) at w_d = 0.5 and CMA-ES (h4_design) at 0.8 are three
    studies of one seed each: three lines, never pooled as "2 seeds"; seven mechanisms are laid
    out in rows of at most three panels."""
    runs = pd.DataFrame(
        {
            "objective": ["mixed"] * 3,
            "mechanism": ["h4"] * 3,
            "optimizer": ["ga", "nsga2", "cmaes"],
            "experiment": ["h4_mixed", "h4_pareto", "h4_design"],
            "w_d": [0.5, 0.5, 0.8],
            "seed": [0, 0, 3],
            "gdi": [0.30, 0.33, 0.40],
            "suri": [0.10, 0.05, 0.02],
            "objective_value": [0.20, 0.19, 0.27],
        }
    )
    plot_module.plot_tradeoff(runs, tmp_path / "t.png")
    ax = saved[-1].axes[0]
    assert "one seed per point" in ax.get_title()
    eta = [line for line in ax.lines if line.get_linestyle() == ":"]
    assert sorted(tuple(line.get_xdata()) for line in eta) == [(0.5,), (0.5,), (0.8,)]  # nothing joined
    assert {tuple(line.get_ydata()) for line in eta} == {(0.20,), (0.19,), (0.27,)}  # nothing averaged
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"cmaes / h4_design (1 seed)", "ga / h4_mixed (1 seed)", "nsga2 / h4_pareto (1 seed)"} <= set(legend)
    seven = pd.concat([runs.assign(mechanism=f"m{k}") for k in range(7)], ignore_index=True)
    plot_module.plot_tradeoff(seven, tmp_path / "t7.png")
    fig = saved[-1]
    panels = [a for a in fig.axes if a.axison]
    assert len(panels) == 7
    columns = {round(a.get_position().x0, 3) for a in panels}
    assert len(columns) == 3  # rows of three, not one row of seven
    width, height = fig.get_size_inches()
    assert width < 2 * height  # 3 x 3 cells, not a 7:1 strip
    for figure in saved:
        check_figure(figure)


def assert_titles_fit(fig: Figure) -> None:
    """Every title and suptitle lies inside the figure and off every colour bar (once drawn)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    bars = [ax.get_window_extent(renderer) for ax in fig.axes if ax.get_label() == "<colorbar>"]
    texts = [ax.title for ax in fig.axes] + ([fig._suptitle] if fig._suptitle is not None else [])
    for text in texts:
        if not text.get_text():
            continue
        box = text.get_window_extent(renderer)
        assert page.x0 - 1 <= box.x0 and box.x1 <= page.x1 + 1, f"title cut off: {text.get_text()!r}"
        assert box.y1 <= page.y1 + 1, f"title cut off at the top: {text.get_text()!r}"
        for bar in bars:
            assert not box.overlaps(bar), f"title under the colour bar: {text.get_text()!r}"


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_run_figure_titles_fit_for_every_mechanism(name, tmp_path, saved, monkeypatch):
    """A Gough-Stewart slice names five fixed pose variables: the title must wrap, not run off the
    figure or under the colour bar (coarse slices: the titles are what is tested; convergence and
    Pareto titles: test_convergence_shows_the_polished_optimum)."""
    from pipeline.stages import slices

    monkeypatch.setattr(slices, "SLICE_RESOLUTION", 10)
    config = MechanismConfig(name=name)
    mech = config.build(config.centre)
    what = f"{plot_module.DEBUG_MARK}: {name}, mixed, w_d = 0.5, seed 0"  # a debug run's, the longest
    plot_module.plot_workspace(
        mech,
        config.orientation_rad() or mech.default_orientation,
        0.01,
        None,
        tmp_path,
        what,
        design_volume="design's V = 7.25346e+07 mm³",
    )
    assert len(saved) == 2
    assert "7.25346e+07 mm³" in saved[1].axes[0].get_title()  # whole, on one line
    for fig in saved:
        assert_titles_fit(fig)


def test_convergence_shows_the_polished_optimum(tmp_path, saved):
    """The run reports η 0.274225 found by the polish step after the last generation (best so far
    0.2714): the run's figure and the report's panel both draw it, and the gap is taken from it."""
    from pipeline.report.figures import convergence_figure

    history = pd.DataFrame({"generation": range(4), "best": [0.26, 0.2714, 0.2626, 0.27], "mean": [0.2] * 4})
    plot_module.plot_convergence(
        history,
        tmp_path / "c.png",
        "cmaes convergence (h4)",
        "η [1]",
        reference=0.28,
        optimum=0.274225,
        found_by="polish",
        gap="2.06 % ± 0.1 %",
    )
    ax = saved[-1].axes[0]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "after polish: 0.274225" in legend
    what = "gough_stewart, mixed, w_d = 0.5, seed 0"  # the longest mechanism name: titles fit too
    plot_module.plot_convergence(history, tmp_path / "c2.png", f"cmaes convergence ({what})", "η [1]")
    front = pd.DataFrame({"gdi": [0.1, 0.2], "suri": [0.3, 0.1]})
    plot_module.plot_front(front, ["gdi", "suri"], tmp_path / "f.png", what)
    assert any("gap 2.06 % ± 0.1 %" in text for text in legend)  # the gap as recorded, with its error
    assert max(max(line.get_ydata()) for line in ax.lines) == pytest.approx(0.28)
    assert any(0.274225 in list(line.get_ydata()) for line in ax.lines)
    best = pd.DataFrame(
        {
            "run_id": ["a"],
            "mechanism": ["h4"],
            "objective": ["mixed"],
            "objective_unit": ["1"],
            "w_d": [0.8],
            "optimizer": ["cmaes"],
            "seed": [3],
            "objective_value": [0.274225],
            "found_by": ["polish"],
            "reference_value": [0.28],
            "reference_gap": [2.06e-2],
            "reference_gap_error": [3e-2],
        }
    )
    convergence_figure(best, history.assign(run_id="a"))
    panel = saved[-1].axes[0]
    texts = [t.get_text() for t in panel.get_legend().get_texts()]
    assert "after polish: 0.2742" in texts
    # a gap below its error bar is "within error", never a percentage finer than the objective
    assert "reference 0.28 (gap within error (< 3 %))" in texts
    for fig in saved:
        check_figure(fig)
        assert_titles_fit(fig)


def test_groups_of_runs_keep_experiments_apart(saved):
    """Two experiments with one optimiser at one w_d (e.g. h4_mixed and a study of its own) are
    two groups: two convergence lines and two rows of the seeds table, never each other's seeds."""
    from pipeline.report.figures import convergence_figure
    from pipeline.report.html import seeds_table

    best = pd.DataFrame(
        {
            "run_id": ["a", "b"],
            "mechanism": ["h4"] * 2,
            "objective": ["mixed"] * 2,
            "objective_unit": ["1"] * 2,
            "w_d": [0.5] * 2,
            "optimizer": ["ga"] * 2,
            "experiment": ["h4_mixed", "h4_own"],
            "seed": [0, 1],
            "objective_value": [0.19, 0.2],
        }
    )
    history = pd.DataFrame({"run_id": ["a", "a", "b", "b"], "generation": [0, 1] * 2, "best": [0.18, 0.19, 0.19, 0.2]})
    convergence_figure(best, history)
    legend = [t.get_text() for t in saved[-1].axes[0].get_legend().get_texts()]
    assert legend == ["ga / h4_mixed, w_d=0.5 (1 seed)", "ga / h4_own, w_d=0.5 (1 seed)"]
    table = seeds_table(best)
    assert table.count("<tr><td>h4</td>") == 2 and "<td>h4_own</td>" in table


def test_report_convergence_panels_take_their_own_units(saved):
    """One objective has a unit per mechanism: the volume of an H4 in cm³·rad, of a Tricept in
    mm·rad²; each panel's y axis is labelled with its own (the Tricept's read cm³·rad)."""
    from pipeline.report.figures import convergence_figure

    best = pd.DataFrame(
        {
            "run_id": ["a", "b"],
            "mechanism": ["h4", "tricept"],
            "objective": ["volume"] * 2,
            "objective_unit": ["cm³·rad", "mm·rad²"],
            "w_d": [0.0] * 2,
            "optimizer": ["cmaes"] * 2,
            "seed": [0] * 2,
        }
    )
    history = pd.DataFrame({"run_id": ["a", "a", "b", "b"], "generation": [0, 1] * 2, "best": [1.0, 2.0, 3.0, 4.0]})
    convergence_figure(best, history)
    (fig,) = saved
    check_figure(fig)
    panels = {ax.get_title().split(":")[0]: ax.get_ylabel() for ax in fig.axes if ax.axison}
    assert panels == {"h4": "V [cm³·rad]", "tricept": "V [mm·rad²]"}


def test_report_gallery_names_each_panel_s_own_slice(saved):
    """Each Tricept design is cut at its own median c: each panel names its own slice (every
    panel was titled with the first design's), and the figure's title names no single one."""
    import dataclasses

    from pipeline.report.figures import workspace_gallery
    from pipeline.stages.slices import workspace_slice

    config = MechanismConfig(name="tricept")
    designs = {"a": [0.9 * c for c in config.centre], "b": [1.1 * c for c in config.centre]}
    labels = {
        run_id: workspace_slice(config.build(x), config.build(x).default_orientation, 0.01, None).fixed_label
        for run_id, x in designs.items()
    }
    assert labels["a"] != labels["b"]
    rows = pd.DataFrame(
        [
            {"run_id": run_id, "mechanism": "tricept", "objective": "volume", "w_d": 0.0, "optimizer": "cmaes"}
            | {"seed": seed, "objective_value": 1.0 - seed}
            | dict(zip(config.design.names, x))
            for seed, (run_id, x) in enumerate(designs.items())
        ]
    )
    configs = {run_id: {"mechanism": dataclasses.asdict(config)} for run_id in designs}
    for kind in ("workspace", "inverse_condition"):
        workspace_gallery(rows, configs, kind)
        fig = saved[-1]
        check_figure(fig)
        assert_titles_fit(fig)  # a third line in each title
        titles = [ax.get_title().replace("\n", " ") for ax in fig.axes if ax.axison and ax.get_title()]
        assert len(titles) == 2
        for title, run_id in zip(titles, designs):
            assert f"slice {labels[run_id]}" in title, (title, labels[run_id])
        assert not any(label in fig._suptitle.get_text() for label in labels.values())
    # one common slice is named once, in the figure's title
    workspace_gallery(rows.iloc[:1], configs, "workspace")
    assert f"slice {labels['a']}" in saved[-1]._suptitle.get_text()
    assert "slice" not in saved[-1].axes[0].get_title()


def test_tradeoff_keeps_apart_an_experiment_run_with_an_override(tmp_path, saved):
    """h4_mixed's seeds 0, 7, 11 (one study; seed 0 twice, a repeat) and h4_mixed again with another
    orientation (another study, another ``study_hash``) at w_d = 0.5: two lines, the study's η the
    mean of its three distinct seeds, the other's its own, never averaged together; the labels
    tell the two apart by their hashes' first digits (a new user's report mixed them)."""
    study, other = "48bd744ccf5e7f27", "33d895a1595e2f1f"
    runs = pd.DataFrame(
        {
            "objective": ["mixed"] * 5,
            "mechanism": ["h4"] * 5,
            "optimizer": ["ga"] * 5,
            "experiment": ["h4_mixed"] * 5,
            "w_d": [0.5] * 5,
            "seed": [0, 0, 7, 11, 0],
            "config_hash": ["a", "a", "b", "c", "d"],
            "study_hash": [study] * 4 + [other],
            "gdi": [0.30, 0.30, 0.31, 0.32, 0.40],
            "suri": [0.10] * 5,
            "objective_value": [0.20, 0.20, 0.19, 0.18, 0.237],
        }
    )
    plot_module.plot_tradeoff(runs, tmp_path / "t.png")
    ax = saved[-1].axes[0]
    eta = sorted(round(float(line.get_ydata()[0]), 9) for line in ax.lines if line.get_linestyle() == ":")
    assert eta == [0.19, 0.237]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"ga / h4_mixed [48bd74] (3 seeds)", "ga / h4_mixed [33d895] (1 seed)"} <= set(legend)
    assert not ax.get_title().startswith("DEBUG")
    check_figure(saved[-1])
    # debug runs (+debug presets) say so on the figure, not only in the config
    plot_module.plot_tradeoff(runs.assign(purpose="debug"), tmp_path / "d.png")
    assert saved[-1].axes[0].get_title().replace("\n", " ").startswith(plot_module.DEBUG_RUNS_MARK)
    check_figure(saved[-1])


def test_a_repeat_is_the_same_config_not_the_same_seed_number():
    """Repeats (equal ``config_hash``) count once; two runs of seed 0 under different configs are
    both kept; a table without ``config_hash`` falls back to (keys, seed)."""
    best = pd.DataFrame({"seed": [0, 0, 0], "w_d": [0.5] * 3, "config_hash": ["a", "a", "b"]})
    assert list(plot_module.distinct_seeds(best, ["w_d"]).index) == [0, 2]
    assert list(plot_module.distinct_seeds(best.drop(columns="config_hash"), ["w_d"]).index) == [0]
    assert plot_module.study_labels([("ga", "abcdef12"), ("ga", "12345678"), ("cmaes", "abcdef12")]) == [
        "ga [abcdef]",
        "ga [123456]",
        "cmaes",
    ]


def test_an_optimum_beaten_by_another_w_d_s_design_is_marked_and_reported(tmp_path, saved):
    """A user's Gough-Stewart sweep: at w_d = 0.25 CMA-ES stopped in another basin, and the design
    it found at w_d = 0 scored 0.53 % more there. eta is linear in w_d for a fixed design, so the
    stored GDI and SURI score every optimum at every w_d: the run is listed, ringed in the
    trade-off and named in the report; a sweep whose optima each win at their own w_d has none."""
    from pipeline.report.html import beaten_note

    runs = pd.DataFrame(
        {
            "objective": ["mixed"] * 3,
            "mechanism": ["gough_stewart"] * 3,
            "optimizer": ["cmaes"] * 3,
            "w_d": [0.0, 0.25, 0.5],
            "seed": [0, 0, 0],
            "run_id": ["a", "b", "c"],
            "gdi": [0.20, 0.16, 0.34],
            "suri": [0.13, 0.08, 0.02],
            "objective_error": [1e-4, 7.8e-5, 1e-4],
        }
    )
    runs["objective_value"] = runs["w_d"] * runs["gdi"] + (1 - runs["w_d"]) * runs["suri"]
    beaten = plot_module.beaten_optima(runs)
    assert beaten[["w_d", "other_w_d"]].values.tolist() == [[0.25, 0.0]]
    assert beaten["other_value"].iloc[0] == pytest.approx(0.25 * 0.20 + 0.75 * 0.13)
    assert beaten["gap"].iloc[0] == pytest.approx((0.25 * 0.20 + 0.75 * 0.13) / 0.10 - 1)
    note = beaten_note(runs)
    assert "1 optimum beaten" in note and "w_d = 0.25 (seed 0)" in note and "found at w_d = 0 (seed 0)" in note
    plot_module.plot_tradeoff(runs, tmp_path / "t.png")
    ax = saved[-1].axes[0]
    rings = [line for line in ax.lines if line.get_markeredgecolor() == "red"]
    assert len(rings) == 1 and list(rings[0].get_xdata()) == [0.25]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "η beaten by another w_d's design" in legend
    check_figure(saved[-1])
    # each optimum the best at its own w_d: nothing beaten; a gap within the runs' error: nothing either
    fair = runs.assign(gdi=[0.20, 0.22, 0.34], suri=[0.13, 0.13, 0.02])
    fair["objective_value"] = fair["w_d"] * fair["gdi"] + (1 - fair["w_d"]) * fair["suri"]
    assert plot_module.beaten_optima(fair).empty and beaten_note(fair) == ""
    close = runs.assign(objective_error=[1e-4, 0.05, 1e-4])  # the gap, 0.0475, within its error
    assert plot_module.beaten_optima(close).empty
