"""The figures of docs/reproduction.md that are drawn from the studies' results (H4 Fig. 8,
the extensions' trade-off and Pareto front) and from the 2-RPR / 3-RPR models say what they show:
each axes has ink, axis labels with units and a title (tests/test_figure_content.py's check).

The section functions are called on a stand-in for :class:`~pipeline.reproduction.driver.Reproduction`
whose studies are small synthetic tables; the figure is captured as it is saved, so what is
checked is what lands in the PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

import pipeline.reproduction.rpr3 as rpr3_section
from kinematics import get_mechanism
from pipeline.reproduction.extensions import extensions
from pipeline.reproduction.h4_figures import h4_sweep
from pipeline.reproduction.rpr2 import rpr2
from tests.test_figure_content import check_figure

W_D = np.linspace(0.0, 1.0, 5)


class FiguresDrawn(Exception):
    """Raised once the figures a test asks for are saved: the rest of the section (tables,
    re-evaluations at 4x the resolution) is not this test's concern."""


@pytest.fixture
def capture(monkeypatch):
    """``capture(n)``: a list that receives every saved figure; the n-th save stops the section."""
    figures: list[Figure] = []
    real = Figure.savefig

    def start(stop_after: int) -> list[Figure]:
        def savefig(self, *args, **kwargs):
            real(self, *args, **kwargs)
            figures.append(self)
            if len(figures) == stop_after:
                raise FiguresDrawn

        monkeypatch.setattr(Figure, "savefig", savefig)
        return figures

    return start


class StandIn:
    """The part of ``Reproduction`` the sections use before their figures are saved."""

    def __init__(self, figures: Path) -> None:
        self.figures = figures
        self.figures.mkdir(parents=True, exist_ok=True)

    def experiment(self, name: str) -> pd.DataFrame:
        mechanisms = {"h4_fig8": ["h4"], "h4_pareto": ["h4"], "mixed_tradeoff": ["tricept", "rpr3", "rpr2"]}[name]
        return pd.DataFrame(
            [
                {
                    "mechanism": mech,
                    "w_d": w,
                    "gdi": 0.2 + 0.1 * w,
                    "suri": 0.6 - 0.3 * w,
                    "objective_value": 0.5 - 0.1 * w,
                    "volume": 1e5 * (1.0 - 0.6 * w),
                    "run_id": f"{mech}-{i}",
                }
                for mech in mechanisms
                for i, w in enumerate(W_D)
            ]
        )

    def table(self, table: str, run_ids: list[str]) -> pd.DataFrame:
        suri = np.linspace(0.1, 0.6, 12)
        return pd.DataFrame({"gdi": 0.35 - 0.3 * suri**2, "suri": suri})

    def memo(self, func):
        return func


def test_h4_fig8_tradeoff(tmp_path, capture):
    saved = capture(1)
    with pytest.raises(FiguresDrawn):
        h4_sweep(StandIn(tmp_path))
    check_figure(saved[0])
    assert (tmp_path / "h4_fig8_tradeoff.png").stat().st_size > 0


def test_extension_tradeoff_and_pareto_front(tmp_path, capture):
    saved = capture(2)
    r = StandIn(tmp_path)
    with pytest.raises(FiguresDrawn):
        extensions(r, r.experiment("h4_fig8"), {})
    assert len(saved) == 2
    assert len([ax for ax in saved[0].axes if ax.axison]) == 3  # one panel per mechanism
    for fig in saved:
        check_figure(fig)


@pytest.mark.slow  # the 2-RPR workspace at 600², the 3-RPR one at 240² and four orientations
def test_planar_workspace_figures(tmp_path, capture, monkeypatch):
    thesis = get_mechanism("rpr3", **rpr3_section.THESIS)
    # the thesis' binary GA (thousands of generations) is not what is tested here
    monkeypatch.setattr(rpr3_section, "thesis_forward_ga", lambda q, seed, generations: thesis.forward(q)[0])
    saved = capture(1)
    with pytest.raises(FiguresDrawn):
        rpr2(StandIn(tmp_path))
    saved = capture(2)
    with pytest.raises(FiguresDrawn):
        rpr3_section.rpr3(StandIn(tmp_path))
    assert len(saved) == 2
    for fig in saved:
        check_figure(fig)
