"""kinematics.polytope.clipped_cell: the cell's part where linear margins hold, against
independent numbers (inclusion-exclusion for one plane, Monte Carlo for several) and
properties that hold for any input (mirror symmetry, continuity, margins that miss)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from kinematics.polytope import clipped_cell, clipped_cell_moments


def half_space_in_cube(level: float, gradient: np.ndarray) -> float:
    """Volume of ``{u in [-1/2, 1/2]^d : level + gradient . u >= 0}`` by inclusion-exclusion,
    every gradient component non-zero: in ``t = u + 1/2`` flipped to ``c = |gradient| > 0``
    the part is ``{c . t >= B}``, the cube minus ``{c . t < B}``."""
    c = np.abs(gradient)
    d = c.size
    # level + g.u >= 0 with u_j = s_j (t_j - 1/2), s_j = sign(g_j):  c.t >= c.sum()/2 - level
    bound = c.sum() / 2 - level
    below = sum(
        (-1) ** sum(v) * max(bound - c @ np.array(v, dtype=float), 0.0) ** d
        for v in itertools.product((0, 1), repeat=d)
    ) / (math.factorial(d) * np.prod(c))
    return 1.0 - below


@pytest.mark.parametrize("d", [1, 2, 3])
def test_one_plane_agrees_with_inclusion_exclusion(d: int) -> None:
    rng = np.random.default_rng(d)
    gradient = rng.uniform(0.2, 3.0, (200, 1, d)) * rng.choice([-1.0, 1.0], (200, 1, d))
    level = rng.uniform(-1.0, 1.0, (200, 1)) * np.abs(gradient).sum(axis=2) / 2
    fraction, _ = clipped_cell(level, gradient)
    expected = [half_space_in_cube(level[i, 0], gradient[i, 0]) for i in range(200)]
    np.testing.assert_allclose(fraction, expected, atol=1e-12)
    assert 0.0 < fraction.min() < 0.2 and 0.8 < fraction.max() < 1.0  # the planes cut the cells, thin to full


@pytest.mark.parametrize("d", [2, 3])
def test_several_planes_agree_with_monte_carlo(d: int) -> None:
    rng = np.random.default_rng(10 + d)
    cells, margins, samples = 12, 4, 200_000
    gradient = rng.normal(0.0, 1.5, (cells, margins, d))
    level = rng.uniform(0.0, 0.8, (cells, margins))
    fraction, centroid = clipped_cell(level, gradient)
    points = rng.uniform(-0.5, 0.5, (samples, d))
    for i in range(cells):
        inside = (level[i] + points @ gradient[i].T >= 0).all(axis=1)
        share = inside.mean()
        error = 4.5 * math.sqrt(max(share * (1 - share), 1e-6) / samples)
        assert abs(fraction[i] - share) < error, (i, fraction[i], share)
        if inside.sum() > 1000:
            spread = 4.5 * points[inside].std(axis=0) / math.sqrt(inside.sum())
            assert np.all(np.abs(centroid[i] - points[inside].mean(axis=0)) < spread), i
    assert 0.0 < fraction.min() and fraction.max() < 0.9  # several planes cut every cell


def test_mirror_symmetry_flips_the_centroid() -> None:
    rng = np.random.default_rng(3)
    gradient = rng.normal(0.0, 2.0, (50, 3, 3))
    level = rng.uniform(-0.2, 0.8, (50, 3))
    fraction, centroid = clipped_cell(level, gradient)
    for axis in range(3):
        flipped = gradient.copy()
        flipped[:, :, axis] *= -1
        mirrored_fraction, mirrored = clipped_cell(level, flipped)
        np.testing.assert_allclose(mirrored_fraction, fraction, atol=1e-13)
        expected = centroid.copy()
        expected[:, axis] *= -1
        np.testing.assert_allclose(mirrored, expected, atol=1e-12)


def test_the_fraction_is_continuous_as_a_margin_sweeps_the_cell() -> None:
    """No step as the zero of a margin crosses the node, a face or a corner: along a fine sweep
    of the level every change is within the largest possible slope times the step."""
    gradient = np.array([[[1.0, 0.7, 0.3], [-0.4, 1.1, 0.0]]])
    levels = np.linspace(-1.2, 1.2, 4001)
    rows = np.repeat(gradient, levels.size, axis=0)
    level = np.column_stack([levels, np.full(levels.size, 0.3)])
    fraction, centroid = clipped_cell(level, rows)
    step = np.abs(np.diff(fraction)).max()
    # the fraction's derivative in the level is the cut's area over |gradient|: at most sqrt(3)/1.25
    assert step <= (levels[1] - levels[0]) * math.sqrt(3) / np.linalg.norm(gradient[0, 0]) + 1e-12
    assert np.all(np.diff(fraction) >= -1e-15)  # more level, more cell
    assert fraction[0] == 0.0 and 0.0 < fraction[-1] < 1.0  # the second margin still cuts
    full = fraction > 1e-3  # the centroid of an empty part is 0 by convention, of a sliver its corner
    assert np.abs(np.diff(centroid[full], axis=0)).max() < 0.01


def test_margins_that_miss_or_are_unknown_leave_the_cell_alone() -> None:
    level = np.array([[5.0, np.nan], [-5.0, 1.0], [0.2, np.nan], [0.2, 0.0]])
    gradient = np.array(
        [
            [[1.0, 1.0], [1.0, 0.0]],  # far above 0 across the cell; unknown
            [[1.0, 1.0], [0.0, 0.0]],  # below 0 across the cell: nothing
            [[1.0, 0.0], [1.0, 1.0]],  # one cut, one unknown
            [[1.0, 0.0], [np.nan, 1.0]],  # one cut, one with an unknown slope
        ]
    )
    fraction, centroid = clipped_cell(level, gradient)
    np.testing.assert_allclose(fraction, [1.0, 0.0, 0.7, 0.7], atol=1e-14)
    np.testing.assert_allclose(centroid[2:], [[0.15, 0.0], [0.15, 0.0]], atol=1e-14)


def test_shapes_are_checked() -> None:
    with pytest.raises(ValueError, match=r"level must be \(M, K\)"):
        clipped_cell(np.zeros((3, 2)), np.zeros((3, 1, 2)))
    with pytest.raises(ValueError, match="allowed 1, 2 or 3"):
        clipped_cell(np.zeros((3, 2)), np.zeros((3, 2, 4)))


@pytest.mark.parametrize("d", [1, 2, 3])
def test_one_cutting_margin_in_closed_form_agrees_with_the_clipper(d: int) -> None:
    """A cell cut by one margin takes the closed form (``kinematics.polytope._one_plane``); the
    same margin given twice goes through the clipper (which takes vertices on a plane as inside:
    before, the second clip made up crossings from their rounding and lost up to 6 % of a cell).
    Fractions and centroids agree, for nodes on either side of the plane, slopes down to 1.2e-3 of
    the largest (the closed form's limit, ``ONE_PLANE_RATIO``) and below it (the clipper in
    both), and with a second margin that misses the cell."""
    rng = np.random.default_rng(10 + d)
    n = 400
    gradient = rng.uniform(0.2, 3.0, (n, 1, d)) * rng.choice([-1.0, 1.0], (n, 1, d))
    largest = np.abs(gradient[:, 0, :]).max(axis=1)
    gradient[: n // 4, 0, 0] = np.sign(gradient[: n // 4, 0, 0]) * 1.2e-3 * largest[: n // 4]
    gradient[n // 4 : n // 2, 0, 0] *= 1e-5
    level = rng.uniform(-0.999, 0.999, (n, 1)) * np.abs(gradient).sum(axis=2) / 2
    one, one_centroid = clipped_cell(level, gradient)
    # a second margin that misses the cell: still one cutting margin, the closed form
    missing = np.concatenate([level, np.full((n, 1), 10.0)], axis=1)
    with_miss = clipped_cell(missing, np.concatenate([gradient, np.ones((n, 1, d))], axis=1))
    twice, twice_centroid = clipped_cell(np.repeat(level, 2, axis=1), np.repeat(gradient, 2, axis=1))
    np.testing.assert_allclose(one, twice, atol=1e-11)
    np.testing.assert_allclose(one[:, None] * one_centroid, twice[:, None] * twice_centroid, atol=1e-9)
    np.testing.assert_array_equal(with_miss[0], one)
    np.testing.assert_array_equal(with_miss[1], one_centroid)
    assert one.min() < 0.05 and one.max() > 0.95


def test_a_plane_through_the_node_and_a_tiny_corner_stay_finite_and_in_the_cell() -> None:
    """The closed form of one margin leaves two cases to the clipper: a plane through (next to) the
    node, whose slopes ``|g| / |a|`` overflowed (fraction NaN at ``a = 1e-200``), and, the node
    outside, a corner of under 1e-6 of the cell, whose ``1 - f`` lost its digits (centroid up to 49
    cells away)."""
    g = np.array([[[1.0, 1.0, 1.0]]])
    for a in (1e-200, -1e-310, 0.0):
        fraction, centroid = clipped_cell(np.array([[a]]), g)
        assert fraction[0] == pytest.approx(0.5) and np.all(np.abs(centroid) <= 0.5)
    fraction, centroid = clipped_cell(np.array([[-1.49999]]), g)  # the corner u = (1/2, 1/2, 1/2)
    assert 0.0 < fraction[0] < 1e-6 and np.all(np.abs(centroid) <= 0.5) and np.all(centroid > 0.49)


def test_the_new_face_s_pseudo_angle_sorts_as_atan2() -> None:
    """The clipper orders a new face's points by a pseudo-angle instead of ``atan2`` (cheaper); the
    order, and with it the face's first vertex (the fan's apex), must be atan2's: random vectors,
    the axes and the diagonals, both signs of each, the origin."""
    from kinematics.polytope import _pseudo_angle

    rng = np.random.default_rng(3)
    points = np.vstack(
        [
            rng.normal(size=(2000, 2)) * rng.choice([1e-8, 1.0, 1e8], (2000, 1)),
            [[1, 0], [0, 1], [-1, 0], [0, -1], [1, 1], [-1, 1], [-1, -1], [1, -1], [0, 0], [-1, 1e-300]],
        ]
    )
    pseudo = np.array([_pseudo_angle.py_func(x, y) for x, y in points])
    exact = np.arctan2(points[:, 1], points[:, 0])
    assert np.all((pseudo >= -2.0) & (pseudo <= 2.0))
    np.testing.assert_array_equal(np.argsort(pseudo, kind="stable"), np.argsort(exact, kind="stable"))


def _monte_carlo_variance(level, gradient, direction, rng, points=200_000):
    """The variance of ``direction . u`` over each cell's part, from its own uniform points, and
    the part's Monte Carlo fraction."""
    out = []
    for a, g, h in zip(level, gradient, direction):
        u = rng.random((points, g.shape[1])) - 0.5
        inside = (a + u @ g.T >= 0).all(axis=1)
        out.append((np.var(u[inside] @ h) if inside.sum() > 1 else 0.0, inside.mean()))
    return np.array(out)


@pytest.mark.parametrize("d", [1, 2, 3])
@pytest.mark.parametrize("margins", [1, 2, 3])
def test_the_part_s_variance_agrees_with_monte_carlo_on_every_path(d: int, margins: int) -> None:
    """clipped_cell_moments' variance of a linear function over the part: whole cells, one margin
    in closed form (node inside and outside, the prism and inclusion-exclusion, axes of zero slope)
    and the clipper, against 200,000 points a cell (within 4 standard errors); its fraction and
    centroid are clipped_cell's to the bit."""
    rng = np.random.default_rng(10 * d + margins)
    n = 40
    level = rng.normal(0.0, 0.4, (n, margins))
    gradient = rng.normal(0.0, 1.0, (n, margins, d)) * rng.choice([0.05, 1.0, 4.0], (n, margins, 1))
    if d > 1:
        gradient[::5, :, 0] = 0.0
    direction = rng.normal(0.0, 1.0, (n, d))
    fraction, centroid, variance = clipped_cell_moments(level, gradient, direction)
    plain = clipped_cell(level, gradient)
    np.testing.assert_array_equal(fraction, plain[0])
    np.testing.assert_array_equal(centroid, plain[1])
    reference = _monte_carlo_variance(level, gradient, direction, rng)
    kept = reference[:, 1] > 0.02
    assert kept.sum() > 10
    standard_error = reference[kept, 0] * np.sqrt(2.0 / (reference[kept, 1] * 200_000)) + 1e-9
    assert np.all(np.abs(variance[kept] - reference[kept, 0]) < 4 * standard_error + 1e-3 * reference[kept, 0])


@pytest.mark.parametrize("d", [2, 3])
def test_the_closed_form_variance_meets_the_clipper_s(d: int) -> None:
    """A cell passes from the one-margin closed form to the clipper where a second margin starts
    to cut it: with a second margin cutting a corner of 1e-4 along each axis, the two paths'
    variances differ by no more than that corner can move them (a few 1e-8 of the cell's spread),
    the continuity the GDI's parts need."""
    rng = np.random.default_rng(d)
    n = 500
    level = rng.normal(0.0, 0.4, (n, 1))
    gradient = rng.normal(0.0, 1.0, (n, 1, d)) * rng.choice([0.05, 1.0, 4.0, 10.0], (n, 1, 1))
    direction = rng.normal(0.0, 1.0, (n, d))
    one = clipped_cell_moments(level, gradient, direction)
    corner_level = np.full((n, 1), 0.5 * d - 1e-4)
    two = clipped_cell_moments(
        np.concatenate([level, corner_level], axis=1), np.concatenate([gradient, np.ones((n, 1, d))], axis=1), direction
    )
    cut = (one[0] > 1e-3) & (one[0] < 1 - 1e-3)
    spread = (direction**2).sum(axis=1) / 12
    assert cut.sum() > 200
    assert np.max(np.abs(one[2] - two[2])[cut] / spread[cut]) < 1e-6
    assert np.max(np.abs(one[2] - two[2])[cut] / spread[cut]) > 0  # the clipper did take them
