"""Workspace volume, GDI, SURI: exact references, convergence, determinism, validation."""

from __future__ import annotations

import contextlib
import math

import numpy as np
import pytest

from kinematics import MECHANISMS, get_mechanism, kernels
from kinematics.annuli import annuli_intersection_area, discs_intersection_area, lens_area
from kinematics.workspace import Evaluation, evaluate, membership
from tests.conftest import PAPER_DESIGNS

TABLE1 = dict(d=13.52484, h=13.88781, Qz=35.18892)


# ------------------------------------------------------- exact references
def test_lens_and_arc_routines_agree():
    rng = np.random.default_rng(0)
    for _ in range(50):
        r1, r2, d = rng.uniform(0.5, 3, 3)
        assert discs_intersection_area([[0, 0], [d, 0]], [r1, r2]) == pytest.approx(lens_area(r1, r2, d))


def test_annuli_area_matches_monte_carlo():
    centres = np.array([[0.0, 0.0], [150.0, -20.0], [20.0, 160.0]])
    points = np.random.default_rng(1).uniform(-200, 200, size=(1_000_000, 2))
    dist = np.linalg.norm(points[:, None, :] - centres, axis=2)
    mc = np.all((dist >= 80) & (dist <= 160), axis=1).mean() * 400**2
    exact = annuli_intersection_area(centres, 80.0, 160.0)
    assert abs(mc - exact) < 4 * math.sqrt(mc * 400**2 / 1e6)  # 4 sigma of the MC estimate


def test_rpr2_volume_equals_exact_area_at_default_resolution():
    m = get_mechanism("rpr2", **PAPER_DESIGNS["rpr2"])
    ev = evaluate(m, min_inverse_condition=0.0)
    assert ev.volume == pytest.approx(m.exact_area(), rel=1e-3)
    assert ev.volume_unit == "mm²"


@pytest.mark.parametrize("degrees", [15, 30, 45, 60])
def test_rpr3_constant_orientation_area_matches_annuli(degrees):
    m = get_mechanism("rpr3", **PAPER_DESIGNS["rpr3"])
    phi = math.radians(degrees)
    ev = evaluate(m, orientation=(phi, phi), min_inverse_condition=0.0)
    assert ev.volume == pytest.approx(m.exact_area(phi), rel=5e-3)
    assert ev.volume_unit == "mm²"


# -------------------------------------------------------------- H4 exact z
def test_h4_jacobian_does_not_depend_on_z():
    m = get_mechanism("h4", **TABLE1)
    poses = np.array([[3.0, -2.0, z, 0.3] for z in (-30.0, 0.0, 40.0)])
    jac = m.jacobian(poses)
    np.testing.assert_allclose(jac[0], jac[1])
    np.testing.assert_allclose(jac[0], jac[2])


def test_h4_exact_z_equals_brute_force_4d_grid():
    """The exact integration along z equals a plain 4-D midpoint grid in the limit."""
    m = get_mechanism("h4", **TABLE1)
    orient = m.default_orientation
    ev = evaluate(m, resolution=24, error_estimate=False)
    lo, hi = m.pose_bounds(orient)
    r = 24
    axes = [lo[j] + (hi[j] - lo[j]) / r * (np.arange(r) + 0.5) for j in range(4)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 4)
    inside, ic = membership(m, grid, orient, 0.01)
    cell = np.prod((hi - lo) / r)
    assert inside.sum() * cell == pytest.approx(ev.volume, rel=0.02)
    assert ic[inside].mean() == pytest.approx(ev.gdi, rel=0.02)


def test_h4_resolution_error_below_one_percent():
    m = get_mechanism("h4", **TABLE1)
    coarse = evaluate(m, error_estimate=False)
    fine = evaluate(m, resolution=4 * coarse.resolution, error_estimate=False)
    assert coarse.volume == pytest.approx(fine.volume, rel=0.01)
    assert coarse.gdi == pytest.approx(fine.gdi, rel=0.01)


def test_volume_and_gdi_converge():
    m = get_mechanism("rpr2", **PAPER_DESIGNS["rpr2"])
    exact = m.exact_area()

    # the midpoint rule on an indicator (the grid method takes the 2-RPR's V in closed form) is
    # not monotone in r (lattice effects): compare the worst error over a window of coarse and of
    # fine resolutions
    def worst(resolutions):
        return max(
            abs(
                evaluate(m, resolution=r, min_inverse_condition=0.0, error_estimate=False, method="midpoint").volume
                - exact
            )
            for r in resolutions
        )

    assert worst((320, 400, 480)) < worst((20, 25, 30)) / 10
    h4 = get_mechanism("h4", **TABLE1)
    ref = evaluate(h4, resolution=64, error_estimate=False)
    gdi_err = [
        max(abs(evaluate(h4, resolution=r, error_estimate=False).gdi - ref.gdi) for r in window)
        for window in ((4, 5, 6), (16, 18, 20))
    ]
    assert gdi_err[1] < gdi_err[0]


def test_error_estimate_bounds_the_true_error():
    m = get_mechanism("h4", **TABLE1)
    ev = evaluate(m, resolution=12)
    ref = evaluate(m, resolution=64, error_estimate=False)
    assert 0 < ev.volume_error and abs(ev.volume - ref.volume) <= 3 * ev.volume_error


# --------------------------------------------------------- edge behaviour
def test_empty_workspace_gives_zero_not_nan():
    m = get_mechanism("rpr2", b=50.0, q_min=6.0, q_max=9.6)  # the annuli never meet
    ev = evaluate(m)
    assert (ev.volume, ev.gdi, ev.suri, ev.n_inside) == (0.0, 0.0, 0.0, 0)
    assert ev.mixed(0.5) == 0.0
    assert not math.isnan(ev.volume_error)


def test_singular_poses_leave_the_workspace():
    # q_min = 1 so that the singular base line y = 0 crosses the workspace
    m = get_mechanism("rpr2", b=5.0, q_min=1.0, q_max=9.6)
    ev = evaluate(m, resolution=101, return_samples=True)  # odd: a row of nodes on y = 0
    on_axis = np.abs(ev.samples[:, 1]) < 1e-9
    assert on_axis.any() and not ev.inside[on_axis].any()
    assert np.all(ev.inverse_conditions[ev.inside] > 0.01)
    assert ev.inverse_condition_min > 0.01
    # without the dexterity limit the singular line is inside (planar papers' workspace)
    ev0 = evaluate(m, resolution=101, min_inverse_condition=0.0, return_samples=True)
    assert ev0.inside[on_axis].any()
    np.testing.assert_array_equal(ev0.inverse_conditions[on_axis & ev0.inside], 0.0)


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_same_design_twice_gives_identical_floats(name):
    m = get_mechanism(name, **PAPER_DESIGNS[name])
    a = evaluate(m, resolution=8)
    b = evaluate(get_mechanism(name, **PAPER_DESIGNS[name]), resolution=8)
    assert a == b
    assert a.scalars() == b.scalars()


def test_suri_and_mixed_index():
    m = get_mechanism("h4", **TABLE1)
    ev = evaluate(m, resolution=12)
    assert ev.suri == pytest.approx(ev.volume / m.reference_volume(m.default_orientation))
    assert 0 < ev.suri < 1
    assert ev.mixed(0.25) == pytest.approx(0.25 * ev.gdi + 0.75 * ev.suri)
    assert ev.mixed(1.0) == ev.gdi and ev.mixed(0.0) == ev.suri
    with pytest.raises(ValueError, match=r"w_d must be in \[0, 1\]"):
        ev.mixed(1.5)


def test_tricept_polar_search_agrees_with_grid():
    m = get_mechanism("tricept", a=300.062, b=200.0, d=20.0)
    grid = evaluate(m, resolution=40, error_estimate=False)
    polar = evaluate(m, method="polar", resolution=24, error_estimate=False)
    assert polar.volume == pytest.approx(grid.volume, rel=0.02)
    assert polar.gdi == pytest.approx(grid.gdi, rel=0.02)


def test_tricept_cone_limit_shrinks_the_workspace():
    wide = evaluate(get_mechanism("tricept", **PAPER_DESIGNS["tricept"], cone=89.0), resolution=16)
    tight = evaluate(get_mechanism("tricept", **PAPER_DESIGNS["tricept"], cone=30.0), resolution=16)
    assert 0 < tight.volume < wide.volume


def test_samples_for_plots():
    m = get_mechanism("h4", **TABLE1)
    ev = evaluate(m, orientation=(0.0, 0.0), resolution=20, return_samples=True)
    assert ev.samples.shape == (ev.n_samples, 4)
    assert ev.inside.shape == ev.inverse_conditions.shape == (ev.n_samples,)
    assert ev.extent.shape == (ev.n_samples, 2)
    assert np.all(ev.samples[:, 3] == 0.0)
    assert np.all(ev.extent[ev.inside, 1] > ev.extent[ev.inside, 0])
    sl = evaluate(m, orientation=(0.0, 0.0), fixed={"z": -20.0}, resolution=20, return_samples=True)
    assert np.all(sl.samples[:, 2] == -20.0) and sl.volume_unit == "cm²"


def test_design_vector_mapping():
    h4 = MECHANISMS["h4"].from_design([0.1352484, 0.1388781, 0.3518892])
    assert (h4.d, h4.h, h4.Qz, h4.stroke) == pytest.approx((13.52484, 13.88781, 35.18892, 100.0))
    tri = MECHANISMS["tricept"].from_design([250.0, 400.0, 100.0])
    assert (tri.a, tri.b, tri.d) == (250.0, 400.0, 100.0)
    rpr3 = MECHANISMS["rpr3"].from_design([200.0, 50.0], rho_min=80.0, rho_max=160.0)
    np.testing.assert_array_equal(rpr3.platform, [[0, 0], [50, 0], [40, 40]])
    np.testing.assert_array_equal(rpr3.base, [[0, 0], [200, 0], [0, 200]])
    rpr2 = MECHANISMS["rpr2"].from_design([5.0, 6.0])
    assert (rpr2.b, rpr2.q_min, rpr2.q_max) == (5.0, 6.0, 9.6)
    for cls in MECHANISMS.values():
        assert all(v.lower < v.upper for v in cls.design_variables)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(resolution=0), "resolution must be an integer >= 1"),
        (dict(resolution=2.5), "resolution must be an integer >= 1"),
        (dict(orientation=(1.0, 0.0)), "orientation"),
        (dict(orientation=(0.0, float("nan"))), "orientation"),
        (dict(min_inverse_condition=1.5), r"min_inverse_condition must be in \[0, 1\)"),
        (dict(method="monte-carlo"), "method must be one of"),
        (dict(fixed={"w": 1.0}), "unknown pose variables"),
    ],
)
def test_bad_options_raise_one_line_errors(kwargs, match):
    m = get_mechanism("h4", **TABLE1)
    with pytest.raises(ValueError, match=match):
        evaluate(m, **kwargs)


def test_polar_only_for_tricept_like_mechanisms():
    with pytest.raises(ValueError, match="method 'polar' needs one length and two angles"):
        evaluate(get_mechanism("rpr3", **PAPER_DESIGNS["rpr3"]), method="polar")


def test_evaluation_is_a_frozen_dataclass():
    ev = evaluate(get_mechanism("rpr2", **PAPER_DESIGNS["rpr2"]), resolution=20)
    assert isinstance(ev, Evaluation)
    with pytest.raises(AttributeError):
        ev.volume = 1.0


@pytest.mark.parametrize("chunk", [7, 1000, 50_000])
def test_chunked_grid_equals_one_chunk(monkeypatch, chunk):
    """Chunks (whole leading-axis rows, or index ranges when a row is too long) cover the
    grid in order, and the integral does not depend on the chunk size."""
    import kinematics.workspace as ws

    mech = get_mechanism("rpr3", **PAPER_DESIGNS["rpr3"])
    axes, _ = ws._grid_axes(mech, 20, mech.default_orientation, {})
    whole = ws._grid_poses(axes, 0, 20**3)
    reference = evaluate(mech, resolution=20, error_estimate=False)
    monkeypatch.setattr(ws, "CHUNK", chunk)
    bounds = ws._chunk_bounds(axes)
    assert bounds[0][0] == 0 and bounds[-1][1] == 20**3
    assert all(a[1] == b[0] for a, b in zip(bounds, bounds[1:]))
    np.testing.assert_array_equal(np.vstack([ws._grid_poses(axes, *b) for b in bounds]), whole)
    chunked = evaluate(mech, resolution=20, error_estimate=False)
    assert chunked.n_inside == reference.n_inside
    assert chunked.volume == pytest.approx(reference.volume, rel=1e-12)
    assert chunked.gdi == pytest.approx(reference.gdi, rel=1e-12)


@pytest.mark.parametrize("compiled", [False, True])
def test_a_crossing_next_to_a_margin_that_is_zero_at_the_inside_end(compiled):
    """The margin g(s) = -4 s (s - 1/2) along an edge (0 at the inside node, positive at the look
    s = 1/4, negative outside) crosses at 1/2; a root formula dividing g(0) by a difference that is
    also 0 there lost it and took the line through the last two samples (1/3)."""
    from kinematics import workspace

    def margin(s):
        return -4.0 * s * (s - 0.5)

    reach = np.array([[margin(0.0)], [margin(1.0)]])  # (2 n, K): inside ends, then outside ends
    ok = np.ones(1)  # a dexterity margin positive everywhere
    with contextlib.nullcontext() if compiled else kernels.reference_kernels():
        roots = workspace._margin_roots(reach, np.array([[margin(0.25)]]), ok, ok, ok, np.array([0]), np.array([0.25]))
        first, which = workspace._first_root(roots, np.array([0.25]))
    assert first[0] == pytest.approx(0.5, abs=1e-15) and which[0] == 0


@pytest.mark.parametrize("name", sorted(PAPER_DESIGNS))
def test_grid_nodes_counts_what_an_evaluation_samples(name):
    """The node count the pipeline's budgets use (grid_nodes) is the grid's, per-axis factors
    included (H4: half the nodes along theta), and the default fills the mechanism's budget."""
    from kinematics.workspace import default_resolution, grid_nodes

    mech = get_mechanism(name, **PAPER_DESIGNS[name])
    if name in ("rpr2", "rpr3"):  # exact sections: no grid under method "grid"
        method = "midpoint"
    else:
        method = "grid"
    res = default_resolution(mech, method=method)
    ev = evaluate(mech, method=method, error_estimate=False)
    assert ev.resolution == res and ev.n_samples == grid_nodes(mech, res, method=method)
    budget = (mech.grid_nodes or mech.default_nodes) if method == "grid" else mech.default_nodes
    assert grid_nodes(mech, res, method=method) <= budget < grid_nodes(mech, res + 1, method=method)
    if name == "h4":
        assert (res, ev.n_samples) == (30, 30 * 30 * 15)


@pytest.mark.parametrize("centre_inside", [False, True])
def test_a_cut_cell_s_integrand_is_continuous_where_two_crossings_are_as_near(centre_inside):
    """A cut cell whose crossings along x and y are about as near: swapping which one is nearer
    changes its value by no more than the distances do (taking the nearest crossing's axis alone
    jumped between two different values)."""
    from kinematics import workspace as ws

    shape = (3, 3, 3)
    strides = np.array([9, 3, 1], dtype=np.int64)
    sizes = np.array(shape, dtype=np.int64)
    inside = np.ones(27, dtype=bool)
    p = 13  # the centre node
    inside[p] = centre_inside
    f0 = np.ones(27)
    f1 = np.linspace(0.1, 0.9, 27)  # a different 1/kappa at every node
    f1[p] = 0.5 if centre_inside else 0.0
    crossing_values = np.array([[1.0, 0.2], [1.0, 0.7], [0.0, 0.0]])  # x and y crossings differ
    toward = np.array([1.0, -1.0, 1.0])
    scratch = np.empty(3), np.empty(4), np.empty(4), np.empty(3, dtype=np.int64), np.empty(3)

    def value(dx, dy):
        slopes = np.array([1.0 / dx, 1.0 / dy, 0.0])
        near = int(np.argmax(slopes))
        return np.array(
            ws._cut_cell_value(inside, f0, f1, p, slopes, near, toward, crossing_values, strides, sizes, *scratch)
        )

    x_nearer, y_nearer = value(0.3, 0.3 + 1e-9), value(0.3 + 1e-9, 0.3)
    assert np.abs(x_nearer - y_nearer).max() < 1e-6
    assert np.abs(value(0.1, 0.3) - value(0.3, 0.1)).max() > 1e-3  # the two crossings do differ


@pytest.mark.parametrize("name", ["rpr2", "rpr3"])
def test_the_counters_of_exact_sections_are_the_rule_s_points_and_those_inside(name):
    """Under exact sections (2-RPR, 3-RPR) ``n_samples`` counts the rule's sample points (one per
    node spacing along each row) and ``n_inside`` those in the dexterous workspace, so that their
    ratio is the filled share of what the rows span, as a grid's is of the box: for the 2-RPR
    (rows over the pose box) V over the box; for the 3-RPR (each layer's rows over its reachable
    y extent) the layers' mean of their dexterous area over the extent's rectangle. (They counted
    the Jacobians evaluated and the rows met: a share of a few per cent.)"""
    m = get_mechanism(name, **PAPER_DESIGNS[name])
    ev = evaluate(m, error_estimate=False)
    assert 0 < ev.n_inside < ev.n_samples
    share = ev.n_inside / ev.n_samples
    lo, hi = m.pose_bounds(ev.orientation)
    if name == "rpr2":
        expected = ev.volume / float(np.prod(np.subtract(hi, lo)))
    else:
        # the default orientations are all reachable (the layers span them); each layer's area at
        # constant orientation over the rectangle of its y extent times the x range, averaged
        assert np.isfinite(m.transverse_extent(np.array(ev.orientation))).all()
        n = 12
        phis = ev.orientation[0] + (np.arange(n) + 0.5) * (ev.orientation[1] - ev.orientation[0]) / n
        low, high = m.transverse_extent(phis)
        areas = [evaluate(m, orientation=(p, p), error_estimate=False).volume for p in phis]
        expected = float(np.mean(np.array(areas) / ((high - low) * (hi[0] - lo[0]))))
    assert share == pytest.approx(expected, rel=0.03)
