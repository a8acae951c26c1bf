"""The reproduction document, one module per paper over the experiments that reproduce it.

:func:`write_document` runs, in order, :mod:`.h4` and :mod:`.h4_figures` (seed 000), :mod:`.tricept`
(seed 001), :mod:`.readings_study`, :mod:`.rpr3` (seed 003), :mod:`.rpr2`
(seed 004), :mod:`.delta` (a published Delta result) and :mod:`.extensions`. Each paper table or figure is an
experiment that declares its own sweep; :class:`.driver.Reproduction` runs
those sweeps into one dataset, and the sections read it back. Driven by
``python -m pipeline.reproduction``.
"""

from __future__ import annotations

from pathlib import Path

from pipeline.reproduction import delta, extensions, h4, h4_figures, readings_plan, readings_study, rpr2, rpr3, tricept
from pipeline.reproduction.driver import Reproduction


def write_document(out: Path, output_dir: Path) -> Reproduction:
    """Run every section into a new :class:`Reproduction` (studies cached under ``output_dir``)."""
    r = Reproduction(out, output_dir)
    # every experiment and the readings study's checks as one batch (the checks and the longest
    # jobs first): two cores stay busy to its very end
    readings = readings_plan.plan(r)
    r.run_experiments(
        [(name, ()) for name in ("tricept_table2", *h4.TABLE_EXPERIMENTS, "h4_fig8", "h4_pareto", "mixed_tradeoff")]
        + readings.requests,
        readings.tasks,
    )
    h4.h4_kinematics(r)
    frames, best_runs = h4.h4_tables(r)
    h4_figures.h4_figures(r, frames, best_runs)
    sweep = h4_figures.h4_sweep(r)
    tricept.tricept(r)
    readings_study.readings_study(r, readings, frames, sweep)
    rpr3.rpr3(r)
    rpr2.rpr2(r)
    delta.delta(r)
    extensions.extensions(r, sweep, best_runs)
    return r
