"""Polish: a bounded compass search from the best design that lands on active bounds.

Why: the optima of these studies lie on faces, edges or corners of the design
box (issue 12). Population methods approach a bound but rarely land on it.
This step evaluates, per iteration and as one parallel batch, the moves
``x +- step * span_j`` of every variable (clipped to the box, so a step past a
bound lands exactly on it) and the snap of every variable within
``snap_fraction`` of a bound onto that bound (one at a time and all at once).
It takes the best strict improvement, else halves the step, until the step
falls below ``min_step`` or the budget is spent. Deterministic; any optimiser
can end with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.optimizers.base import Problem


@dataclass
class PolishResult:
    """``x``, ``fun`` after polishing; ``improvement`` = fun - start value; evaluations spent."""

    x: np.ndarray
    fun: float
    improvement: float
    n_evaluations: int


def _candidates(x: np.ndarray, lower: np.ndarray, upper: np.ndarray, step: float, snap_fraction: float) -> np.ndarray:
    span = upper - lower
    moves = []
    for j in range(x.size):
        for sign in (1.0, -1.0):
            c = x.copy()
            c[j] = np.clip(x[j] + sign * step * span[j], lower[j], upper[j])
            moves.append(c)
    near_low = (x - lower) <= snap_fraction * span
    near_high = (upper - x) <= snap_fraction * span
    target = np.where(near_low, lower, np.where(near_high, upper, x))
    for j in np.nonzero(target != x)[0]:
        c = x.copy()
        c[j] = target[j]
        moves.append(c)
    moves.append(target)
    out = np.unique(np.array(moves), axis=0)
    return out[np.any(out != x, axis=1)]


def polish(
    problem: Problem,
    x0: np.ndarray,
    f0: float,
    *,
    max_evaluations: int = 150,
    initial_step: float = 0.05,
    min_step: float = 1e-4,
    snap_fraction: float = 0.05,
) -> PolishResult:
    """Maximise ``problem`` locally from ``x0`` (objective ``f0``) within the box.

    Parameters
    ----------
    problem : Problem
        Batch objective and box (design units).
    x0 : ndarray, shape (n,)
    f0 : float
        Objective at ``x0`` (not re-evaluated).
    max_evaluations : int
        Budget; a batch that would exceed it is not evaluated.
    initial_step, min_step : float
        Step as a fraction of each variable's range.
    snap_fraction : float
        Variables within this fraction of a bound are also tried on the bound.
    """
    x = np.clip(np.asarray(x0, dtype=float), problem.lower, problem.upper)
    f = float(f0)
    step = float(initial_step)
    spent = 0
    while step >= min_step:
        cands = _candidates(x, problem.lower, problem.upper, step, snap_fraction)
        if cands.shape[0] == 0 or spent + cands.shape[0] > max_evaluations:
            break
        values = problem(cands)
        spent += cands.shape[0]
        k = int(np.argmax(values))
        if values[k] > f:
            x, f = cands[k].copy(), float(values[k])
        else:
            step *= 0.5
    return PolishResult(x=x, fun=f, improvement=f - float(f0), n_evaluations=spent)
