"""The linear-margins rule's GDI: each band part's 1/kappa from its moments (the code) or its mean.

docs/accuracy.md, "Order": the GDI of the linear margins.

Run: ``python -m benchmarks.part_means tricept [--resolution R ...] [--points N] [--model M]`` (a
mechanism with margins and no exact axis). For the designs of ``python -m benchmarks.accuracy``
(the ladder's and the scan's) it prints the errors of V, GDI and eta, in % of the reference of
``benchmarks.accuracy`` (its rule at :data:`benchmarks.accuracy.REFERENCE_FACTOR` x the finer
default), of ``evaluate(method="margins")`` at each resolution (default: the grid method's
default), twice:

- **code**: :func:`kinematics.margin_cells.part_inverse_condition`, the mean of ``sqrt(margin +
  limit^2)`` over the part to second order in the linear dexterity margin's spread there (its
  mean and variance over the part, exact: :func:`kinematics.polytope.clipped_cell_moments`);
- **part mean**: the same run with each band part's 1/kappa the Monte Carlo mean of ``sqrt(margin
  + limit^2)`` over the part, that margin and the part the same linear models the code clips
  (``--points`` uniform points a cell, default 4,000, each cell its own, seed 0; a part holding
  fewer than 20 of them keeps the code's value). V is the same in both (the fractions do not
  change); the difference is the code's approximation of the mean alone. ``--model delta``:
  the second-order estimate from the Monte Carlo mean and variance instead (the code's formula
  on sampled moments).

A measurement of the rule against its own model, not of the model: its error against the
reference (the GDI's remaining bias) is the linear model's and the fractions'. Why the mean and not
the value at the centroid (the rule before, one square root a part): 1/kappa is concave along its
margin, so its value at the centroid is above its mean over the part, a positive bias of the GDI
(the Tricept's: up to +0.089 % at its default; with the means 0.049 %). Seeded; no page is
written.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.accuracy import (
    ERROR_TARGET,
    SCAN,
    SCAN_SEED,
    designs,
    quantities,
    random_designs,
    reference_evaluation,
)
from kinematics import MECHANISMS, margin_cells
from kinematics.workspace import evaluate

#: cells per block of the Monte Carlo means (block x points x margins floats at once)
BLOCK = 64
#: fewest sample points inside a part for its Monte Carlo mean
FEWEST = 20
#: the parts' 1/kappa models of :func:`monte_carlo_part_means`
MODELS = ("mean", "delta")


def monte_carlo_part_means(points: int, seed: int = 0, model: str = "mean"):
    """A replacement for :func:`kinematics.margin_cells.part_inverse_condition` (same signature)
    whose 1/kappa of a part is, from ``points`` uniform points of the cell (its own, ``seed``),
    the mean of the linear dexterity model's ``sqrt(m + limit^2)`` over the part (``model="mean"``), or its second-order (delta-method) estimate from the mean and variance of
    ``m + limit^2`` over the part, ``sqrt(E) - Var / (8 E^1.5)`` (``model="delta"``: what a rule
    needs from each part is then its first and second moments, which have closed forms)."""
    if model not in MODELS:
        raise ValueError(f"model={model!r} is invalid: allowed {', '.join(MODELS)}")
    code_values = margin_cells.part_inverse_condition

    def means(at, slope, centroid, variance, fallback, min_ic):
        out = code_values(at, slope, centroid, variance, fallback, min_ic)
        rng = np.random.default_rng(seed)
        # a margin with a non-finite level or slope does not cut the cell (as the clipper takes it)
        modelled = np.isfinite(at) & np.isfinite(slope).all(axis=2)
        level = np.where(modelled, at, np.inf)
        gradient = np.where(modelled[:, :, None], slope, 0.0)
        cells = np.nonzero(modelled[:, -1])[0]
        for start in range(0, cells.size, BLOCK):
            block = cells[start : start + BLOCK]
            # points of their own for every cell: one set for all cells made its sampling error
            # (the set's moments, a few % of the correction) the same in every cell, a bias
            u = rng.random((block.size, points, slope.shape[2])) - 0.5
            m = level[block, None, :] + np.einsum("mpd,mkd->mpk", u, gradient[block])  # (cells, points, K + 1)
            inside = (m >= 0.0).all(axis=2)
            count = inside.sum(axis=1)
            shifted = m[:, :, -1] + min_ic**2
            if model == "mean":
                mean = (np.sqrt(np.maximum(shifted, 0.0)) * inside).sum(axis=1) / np.maximum(count, 1)
            else:
                first = (shifted * inside).sum(axis=1) / np.maximum(count, 1)
                variance = ((shifted - first[:, None]) ** 2 * inside).sum(axis=1) / np.maximum(count, 1)
                first = np.maximum(first, min_ic**2)
                mean = np.maximum(np.sqrt(first) - variance / (8.0 * first**1.5), 0.0)
            out[block] = np.where(count >= FEWEST, mean, out[block])
        return out

    return means


def errors(
    mech, resolutions: list[int | None], points: int, model: str = "mean"
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per resolution, the errors (3: V, GDI, eta; fractions, signed) of the code and with the
    parts' Monte Carlo means (or ``model``), against the reference of ``benchmarks.accuracy``."""
    # the rule first: a mechanism it does not take is refused before the reference is computed
    codes = [quantities(evaluate(mech, resolution=r, method="margins", error_estimate=False)) for r in resolutions]
    reference = quantities(reference_evaluation(mech))
    rows = []
    for resolution, code in zip(resolutions, codes):
        code_values = margin_cells.part_inverse_condition
        try:
            margin_cells.part_inverse_condition = monte_carlo_part_means(points, model=model)
            mean = quantities(evaluate(mech, resolution=resolution, method="margins", error_estimate=False))
        finally:
            margin_cells.part_inverse_condition = code_values
        rows.append((code / reference - 1, mean / reference - 1))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mechanism")
    parser.add_argument("--resolution", type=int, nargs="*", default=[], help="nodes per axis (default: the grid's)")
    parser.add_argument("--points", type=int, default=4000, help="Monte Carlo points a cell (default 4000)")
    parser.add_argument(
        "--model", choices=MODELS, default="mean", help="the part's 1/kappa: its mean, or the delta method's estimate"
    )
    args = parser.parse_args()
    if args.mechanism not in MECHANISMS:
        parser.error(f"mechanism={args.mechanism!r} is invalid: allowed {', '.join(sorted(MECHANISMS))}")
    if args.points < FEWEST:
        parser.error(f"--points={args.points} is invalid: allowed an integer >= {FEWEST}")
    if any(r < 4 for r in args.resolution):
        parser.error(f"--resolution={args.resolution} is invalid: allowed integers >= 4")
    cases = designs(args.mechanism) + random_designs(args.mechanism, SCAN_SEED, SCAN, "scan")
    resolutions = args.resolution or [None]
    try:
        table = [errors(mech, resolutions, args.points, args.model) for _, mech in cases]
    except ValueError as exc:  # evaluate's one line (e.g. no margins, or an exact axis)
        raise SystemExit(f"{args.mechanism}: {exc}") from None
    print(f"{args.mechanism}: errors of V, GDI, eta against the 4x reference, % (method margins)")
    for k, resolution in enumerate(resolutions):
        label = "default" if resolution is None else str(resolution)
        print(f"\nresolution {label}: code | part {args.model} ({args.points} points a cell)")
        for (name, _), rows in zip(cases, table):
            code, mean = (" ".join(f"{100 * e:+.3f}" for e in row) for row in rows[k])
            print(f"  {name:10s} {code} | {mean}")
        for title, j in (("code", 0), (f"part {args.model}", 1)):
            worst = np.max([np.abs(rows[k][j]) for rows in table], axis=0)
            over = sum(bool(np.abs(rows[k][j]).max() > ERROR_TARGET) for rows in table)
            print(
                f"  {title:10s} max |error| V {100 * worst[0]:.3f} %, GDI {100 * worst[1]:.3f} %, "
                f"eta {100 * worst[2]:.3f} %; {over} of {len(table)} designs over {100 * ERROR_TARGET:g} %"
            )


if __name__ == "__main__":
    main()
