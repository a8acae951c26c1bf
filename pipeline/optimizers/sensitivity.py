"""Sensitivity probe at an optimum: which design variables are flat there, and over what interval.

A design on a plateau is a set, not a point (issue 12: H4 max volume is flat
along d under the "tracking" base reading; the Tricept volume is a
staircase). For each variable j, with the others held at the optimum, the
probe evaluates ``n_points`` evenly spaced values over the whole box plus
``x_j +- local_step * span_j``, all in one batch. The flat interval is the
run of probe values around ``x_j`` whose objective equals the optimum's
within ``rtol`` (relative); ``flat`` is True when it has non-zero width.
"""

from __future__ import annotations

import numpy as np

from pipeline.optimizers.base import Problem


def flat_intervals(
    problem: Problem,
    x: np.ndarray,
    f: float,
    names: list[str],
    *,
    n_points: int = 9,
    local_step: float = 0.01,
    rtol: float = 1e-9,
) -> dict[str, float | str]:
    """Flatness of each design variable at ``x`` (objective ``f``).

    Returns
    -------
    dict
        ``<name>_flat_lower``, ``<name>_flat_upper`` (design units: the
        interval of the probe values where the objective stays within ``rtol``
        of ``f``; both equal ``x_j`` when not flat) and ``flat_variables``
        (comma-separated names of the flat variables, "" if none).
    """
    x = np.asarray(x, dtype=float)
    span = problem.upper - problem.lower
    probes, owners = [], []
    for j in range(x.size):
        values = np.unique(
            np.concatenate(
                [
                    np.linspace(problem.lower[j], problem.upper[j], n_points),
                    np.clip(x[j] + np.array([-1.0, 1.0]) * local_step * span[j], problem.lower[j], problem.upper[j]),
                ]
            )
        )
        values = values[values != x[j]]
        for v in values:
            c = x.copy()
            c[j] = v
            probes.append(c)
            owners.append(j)
    probe_array = np.array(probes) if probes else np.empty((0, len(x)))
    objective = problem(probe_array) if probes else np.empty(0)
    owners_arr = np.array(owners)
    same = np.abs(objective - f) <= rtol * max(abs(f), 1e-300)
    out: dict[str, float | str] = {}
    flat = []
    for j, name in enumerate(names):
        mine = owners_arr == j
        vals = probe_array[mine, j]
        eq = same[mine]
        order = np.argsort(vals)
        vals, eq = vals[order], eq[order]
        lo = hi = x[j]
        above = vals > x[j]
        for v, e in zip(vals[above], eq[above]):
            if not e:
                break
            hi = v
        for v, e in zip(vals[~above][::-1], eq[~above][::-1]):
            if not e:
                break
            lo = v
        out[f"{name}_flat_lower"] = float(lo)
        out[f"{name}_flat_upper"] = float(hi)
        if hi > lo:
            flat.append(name)
    out["flat_variables"] = ",".join(flat)
    return out
