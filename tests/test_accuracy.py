"""Accuracy and continuity of the workspace integral (method "grid", docs/accuracy.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.accuracy import OPTIMA, best_known_design, optimum
from kinematics import MECHANISMS, get_mechanism
from kinematics.annuli import planar_legs_signed_inverse_condition
from kinematics.workspace import SECTION_NODES, SECTIONS, _cube_fraction, _multisect, default_resolution, evaluate
from tests.conftest import PAPER_DESIGNS

TARGET = 1e-3  # 0.1 %
W_D = 0.5


def random_design(name: str, seed: int):
    """A design drawn uniformly from the design box (seeded), with a non-empty workspace."""
    cls = MECHANISMS[name]
    rng = np.random.default_rng(seed)
    while True:
        x = np.array([rng.uniform(v.lower, v.upper) for v in cls.design_variables])
        mech = cls.from_design(x, **cls.default_fixed)
        if evaluate(mech, resolution=12, error_estimate=False, method="grid").volume > 0:
            return mech


# ------------------------------------------------------------ cut cells
@pytest.mark.parametrize("dims", [1, 2, 3])
def test_cut_cell_fraction_and_centroid_match_monte_carlo(dims):
    rng = np.random.default_rng(dims)
    slopes = rng.uniform(0.5, 6.0, size=(20, dims)) * (rng.uniform(size=(20, dims)) < 0.8)
    slopes[:, 0] = np.maximum(slopes[:, 0], 0.5)  # at least one crossing
    fraction, centroid = _cube_fraction(slopes)
    points = rng.uniform(-0.5, 0.5, size=(100_000, dims))
    for c, f, g in zip(slopes, fraction, centroid):
        # the node's side of the plane through the crossings u_j = 1 / c_j: c . u < 1
        side = points @ c < 1.0
        assert f == pytest.approx(side.mean(), abs=6e-3)
        if side.any():
            np.testing.assert_allclose(g, points[side].mean(axis=0), atol=8e-3)


def test_cut_cell_through_the_centre_is_half_from_either_side():
    """The continuity of the method: a boundary on a node gives that node's cell half, whatever
    the plane's direction."""
    fraction, centroid = _cube_fraction(np.array([[1e4, 0.0, 0.0], [1e4, 3.0, 0.7], [1e4, 1e4, 1e4]]))
    np.testing.assert_allclose(fraction, 0.5, atol=2e-4)


def reachable_sections_area(mech, resolution: int) -> float:
    """The 2-RPR's reachable area as the sum of its exact x-sections over the rows that
    ``evaluate`` takes (1.5 x ``resolution`` of them, a rectangle rule in y), before the closed form
    replaces it: the sections checked on their own."""
    lo, hi = mech.pose_bounds(mech.default_orientation)
    rows = int(math.ceil(SECTION_NODES[1] * resolution))
    step = (hi[1] - lo[1]) / rows
    poses = np.column_stack([np.zeros(rows), lo[1] + step * np.arange(rows)])
    reach = mech.exact_sections(poses, lo[0], (hi[0] - lo[0]) / resolution, 0.0)[1]
    return float(reach.sum()) * step


@pytest.mark.parametrize("seed", range(6))
def test_rpr2_sections_within_0p1_percent_of_the_exact_area(seed):
    """An independent reference: the two annuli's intersection in closed form
    (``RPR2.exact_area``), on random designs of the design box (thin crescents among them)."""
    m = random_design("rpr2", seed)
    assert reachable_sections_area(m, default_resolution(m)) == pytest.approx(m.exact_area(), rel=TARGET)
    ev = evaluate(m, min_inverse_condition=0.0, error_estimate=False)
    assert ev.volume == pytest.approx(m.exact_area(), rel=1e-12)  # no dexterity limit: the closed form


@pytest.mark.parametrize("label", ["paper", pytest.param("thin", marks=pytest.mark.slow)])
def test_rpr2_dexterous_area_within_0p1_percent_of_the_cell_grid(label):
    """The dexterous area (the closed form times the sections' dexterous share) and the GDI
    against the other method, the cut-cell grid at 4x the default (``return_samples`` takes the
    grid)."""
    m = (
        get_mechanism("rpr2", **PAPER_DESIGNS["rpr2"])
        if label == "paper"
        else MECHANISMS["rpr2"].from_design(np.array(THIN["rpr2"]))
    )
    ev = evaluate(m, error_estimate=False)
    grid = evaluate(m, resolution=4 * default_resolution(m), error_estimate=False, return_samples=True)
    assert ev.volume == pytest.approx(grid.volume, rel=TARGET)
    assert ev.gdi == pytest.approx(grid.gdi, rel=TARGET)


@pytest.mark.slow
def test_rpr2_band_reaching_the_sections_ends():
    """A dexterity limit (0.3) whose non-dexterous part reaches the sections' ends, on a design
    whose dexterous area is small (b = 3.7 mm: 1.135 mm^2): V then carries the sections' own
    error (-0.14 % here), where V = closed form - non-dexterous band was +0.59 % off (its
    error is an offset of the whole reachable area's); against the cut-cell grid at 8x the
    default (converged to 0.001 %: sections at 8x agree to 6e-6)."""
    m = get_mechanism("rpr2", b=3.7, q_min=6.0, q_max=9.6)
    ev = evaluate(m, min_inverse_condition=0.3, error_estimate=False)
    grid = evaluate(
        m, min_inverse_condition=0.3, resolution=8 * default_resolution(m), error_estimate=False, return_samples=True
    )
    assert ev.volume == pytest.approx(grid.volume, rel=3e-3)
    assert ev.gdi == pytest.approx(grid.gdi, rel=TARGET)


def test_rpr2_nothing_dexterous_gives_zero():
    m = get_mechanism("rpr2", **PAPER_DESIGNS["rpr2"])
    ev = evaluate(m, min_inverse_condition=0.5)  # 1/kappa < 0.46 everywhere on this design
    assert (ev.volume, ev.gdi, ev.n_inside) == (0.0, 0.0, 0)


@pytest.mark.parametrize("name", ["rpr2", "rpr3"])
def test_sections_inverse_condition_matches_the_jacobian(name):
    """The sections' closed-form signed ``1/kappa`` (its absolute value) against the mechanism's
    conditioning of its Jacobian (the cell grid's path), at reachable poses of random designs:
    the two share no code; the sign is that of det J."""
    rng = np.random.default_rng(0)
    for seed in range(3):
        m = random_design(name, seed)
        lo, hi = m.pose_bounds(m.default_orientation)
        poses = rng.uniform(lo, hi, size=(20000, m.dof))
        ic = m.reachable_inverse_condition(poses)
        keep = np.flatnonzero(np.isfinite(ic))[:300]
        assert keep.size > 50  # thin crescents among the designs: 1-40 % of the box is reachable
        if name == "rpr2":
            centres, arms, scale = np.broadcast_to(m.base, (keep.size, 2, 2)), np.zeros((keep.size, 2, 2)), 0.0
        else:
            arms = m._rotated_platform(poses[keep, 2])
            centres, scale = m.base - arms, float(m.angular_scale()[2])
        signed = np.array(
            [
                planar_legs_signed_inverse_condition(
                    x,
                    y,
                    centres[k, :, 0].copy(),
                    centres[k, :, 1].copy(),
                    arms[k, :, 0].copy(),
                    arms[k, :, 1].copy(),
                    scale,
                )
                for k, (x, y) in enumerate(poses[keep, :2])
            ]
        )
        np.testing.assert_allclose(np.abs(signed), ic[keep], rtol=1e-9, atol=1e-13)
        jac = m._jacobian(poses[keep]) * m.angular_scale()
        assert np.all(np.sign(signed) == np.sign(np.linalg.det(jac)))


@pytest.mark.parametrize("degrees", [15, 45])
def test_rpr3_constant_orientation_area_to_1e3_at_half_the_default(degrees):
    m = get_mechanism("rpr3", **PAPER_DESIGNS["rpr3"])
    phi = math.radians(degrees)
    ev = evaluate(
        m, orientation=(phi, phi), min_inverse_condition=0.0, resolution=90, error_estimate=False, method="grid"
    )
    assert ev.volume == pytest.approx(m.exact_area(phi), rel=1e-3)


def test_multisection_finds_the_outermost_crossing_to_its_resolution():
    """The occupied box's search: rows with a boundary at ``edge`` (inside below it), and rows
    inside up to 0.3 with a second inside part beyond 0.6: the outermost crossing is reported."""
    rng = np.random.default_rng(0)
    edge = rng.uniform(0.05, 0.95, 50)

    def inside_of(poses):
        x, row = poses[:, 0], poses[:, 1].astype(int)
        return (np.where(row < 25, x < edge[row], (x < 0.3) | ((x > 0.6) & (x < edge[row] + 0.05))),)

    probe = np.column_stack([np.zeros(50), np.arange(50)])
    crossing = _multisect(inside_of, probe, np.zeros(50, dtype=int), np.zeros(50), np.ones(50), rounds=2)
    # the second part is seen when a first-round point (j / SECTIONS) falls in it
    seen = edge + 0.05 > np.ceil(0.6 * SECTIONS) / SECTIONS
    expected = np.where(np.arange(50) < 25, edge, np.where(seen, edge + 0.05, 0.3))
    assert np.abs(crossing - expected).max() <= 0.5 / SECTIONS**2 + 1e-12


def test_grid_method_has_its_own_node_budget():
    tricept = get_mechanism("tricept", **PAPER_DESIGNS["tricept"])
    assert default_resolution(tricept, method="midpoint") == 32 and default_resolution(tricept) == 28
    assert evaluate(tricept, error_estimate=False).method == "grid"  # the default
    assert evaluate(tricept, error_estimate=False).resolution == 28
    rpr3 = get_mechanism("rpr3", **PAPER_DESIGNS["rpr3"])  # no grid budget: the default one
    assert default_resolution(rpr3) == default_resolution(rpr3, method="midpoint") == 32


# --------------------------------------------------- default vs reference
#: design vectors (``from_design``, default fixed parameters) of the random designs of
#: benchmarks/accuracy.py's scan (seed 7) on which the default missed 0.1 % (each mechanism's
#: worst), mostly features thinner than a cell or sharp corners (docs/accuracy.md, "Order"), with
#: the error measured there; those that still miss are in KNOWN_MISSES
THIN = {
    "delta": [0.5563120532930336, 2.814984841745236],  # scan 0: V 0.20 %, workspace 5.7 % of its cylinder
    # scan 8: annuli 0.67 wide meeting at grazing angles, 0.18 % on the cell grid; exact sections now
    "rpr2": [6.599613064970464, 8.93376088609131],
    "rpr3": [259.41388575040924, 57.434796227497664],  # scan 3: V 0.56 %, a sliver of 9e-6 of the reference volume
    "tricept": [255.34973520744924, 499.10005668687853, 162.67914545847555],  # scan 5: V 0.11 %
}
#: measured misses of the 0.1 % target (benchmarks/accuracy.py); strict: they fail today, and a
#: cell rule that holds two boundaries per cell should turn them into passes
_THIN_CELL = "one plane per cell cannot hold a feature thinner than a cell (docs/accuracy.md)"
KNOWN_MISSES: dict[tuple[str, str], str] = {
    ("delta", "thin"): _THIN_CELL,
    ("tricept", "thin"): _THIN_CELL,
    ("rpr3", "thin"): "a sliver workspace: the (y, phi) rule across the exact x-sections resolves it to 0.6 %",
    # h4_max_volume's best known: GDI 0.101 % (0.080 % before this cell rule at 28^3; 0.087 % at 32 x 32 x 16)
    ("h4", "optimum 1"): "GDI 0.101 % at the design box's corner (docs/accuracy.md)",
}


def _cases():
    out = []
    for name in sorted(MECHANISMS):
        labels = ["paper", *(f"optimum {k}" for k in range(len(OPTIMA.get(name, [])))), "random", "thin"]
        for label in labels:
            if label == "thin" and name not in THIN:
                continue
            reason = KNOWN_MISSES.get((name, label))
            marks = [pytest.mark.slow] + (
                [pytest.mark.xfail(strict=True, raises=AssertionError, reason=reason)] if reason else []
            )
            out.append(pytest.param(name, label, marks=marks, id=f"{name}-{label.replace(' ', '')}"))
    return out


@pytest.mark.parametrize("name, label", _cases())
def test_default_resolution_within_0p1_percent_of_a_fine_reference(name, label):
    if label == "paper":
        mech = get_mechanism(name, **PAPER_DESIGNS[name])
    elif label.startswith("optimum"):
        mech = optimum(name, int(label.split()[1]))
    elif label == "thin":
        cls = MECHANISMS[name]
        mech = cls.from_design(np.array(THIN[name]), **cls.default_fixed)
    else:
        mech = random_design(name, seed=1)
    ev = evaluate(mech, error_estimate=False, method="grid")
    reference = default_resolution(mech)
    if label == "thin":  # the scan's reference (benchmarks/accuracy.py): 4x the finer of the two defaults
        reference = max(reference, default_resolution(mech, method="midpoint"))
    ref = evaluate(mech, resolution=4 * reference, error_estimate=False, method="grid")
    assert ev.volume == pytest.approx(ref.volume, rel=TARGET)
    assert ev.gdi == pytest.approx(ref.gdi, rel=TARGET)
    assert ev.mixed(W_D) == pytest.approx(ref.mixed(W_D), rel=TARGET)


# ------------------------------------------------------------ continuity
#: where :func:`eta_along_a_line` walks: a documented optimum (design vector) and the variable
#: walked (one inside its bounds); the Delta has none documented: the middle of its design box
LINES = {
    "h4": (best_known_design("h4_mixed"), 0),  # d_ratio
    "tricept": (list(OPTIMA["tricept"][1].values()), 2),  # a max-volume optimum of the cell count; d
    "rpr3": (OPTIMA["rpr3"][0], 1),  # rpr3_mixed's best known; platform_side
    "rpr2": (OPTIMA["rpr2"][0], 0),  # the trade-off's w_d = 0.5 optimum; b
}


def eta_along_a_line(name: str, method: str, points: int = 15) -> np.ndarray:
    """eta (w_d = 0.5) along one design variable, steps of 0.05 % of its range, through a
    documented optimum (:data:`LINES`) or the middle of the design box."""
    cls = MECHANISMS[name]
    lo = np.array([v.lower for v in cls.design_variables])
    hi = np.array([v.upper for v in cls.design_variables])
    centre, j = (np.array(LINES[name][0]), LINES[name][1]) if name in LINES else (0.5 * (lo + hi), 0)
    out = []
    for k in range(points):
        x = centre.copy()
        x[j] += (k - points // 2) * 5e-4 * (hi[j] - lo[j])
        out.append(evaluate(cls.from_design(x, **cls.default_fixed), method=method, error_estimate=False).mixed(W_D))
    return np.array(out)


def has_a_step(eta: np.ndarray) -> bool:
    """A change between neighbouring points larger than twice the typical one (the median), with
    a floor of 1e-5 of eta for a flat stretch."""
    change = np.abs(np.diff(eta))
    return bool(change.max() > 2.0 * np.median(change) + 1e-5 * np.abs(eta).mean())


#: measured misses of the continuity test, strict: they fail today
STEP_MISSES = {
    # the regenerated h4_mixed best known (DE + polish) sits on a spike of 1.3e-5 of eta: one cut
    # cell's crossing along theta lies on its node (distance 0), its (c - 1)^4 weight takes that
    # axis alone, and that axis's crossing value (1/kappa 0.16) disagrees with the y axis's (0.05)
    "h4": "a spike of 1.3e-5 of eta at the h4_mixed best known itself (docs/accuracy.md)",
}


def _known_misses(names: tuple[str, ...], misses: dict[str, str]) -> list:
    """``names`` as parameters, those in ``misses`` strict xfails with its reason."""
    return [
        pytest.param(
            name,
            marks=[pytest.mark.xfail(strict=True, raises=AssertionError, reason=misses[name])]
            if name in misses
            else [],
        )
        for name in names
    ]


@pytest.mark.slow
@pytest.mark.parametrize("name", _known_misses(("h4", "tricept", "delta", "rpr2", "rpr3"), STEP_MISSES))
def test_eta_along_a_line_has_no_steps(name):
    assert not has_a_step(eta_along_a_line(name, "grid"))


#: where the old count's changes along the line are all irregular (median 15 ppm of eta along H4's),
#: so that none stands out as a step: the statistic of has_a_step cannot tell
OLD_COUNT_MISSES = {"h4": "the old count's changes along this line are all irregular (median 15 ppm)"}


@pytest.mark.slow
@pytest.mark.parametrize("name", _known_misses(("h4", "tricept", "delta", "rpr3"), OLD_COUNT_MISSES))
def test_the_cell_centre_count_has_steps(name):
    """The test above can fail: on the old count it does (2-RPR's 400 x 400 count is smooth enough)."""
    assert has_a_step(eta_along_a_line(name, "midpoint"))


# ------------------------------------------------------------ error bars
@pytest.mark.slow
def test_every_evaluation_carries_its_error_estimate():
    mech = optimum("tricept", 1)
    ev = evaluate(mech, method="grid")
    assert ev.volume_error > 0 and ev.gdi_error > 0
    assert ev.mixed_error(W_D) == pytest.approx(W_D * ev.gdi_error + (1 - W_D) * ev.volume_error / ev.reference_volume)
    ref = evaluate(mech, resolution=4 * ev.resolution, error_estimate=False, method="grid")
    assert abs(ev.volume - ref.volume) <= 3 * ev.volume_error
    with pytest.raises(ValueError, match="w_d must be in"):
        ev.mixed_error(1.5)


@pytest.mark.parametrize("degrees", [15, 45])
def test_rpr3_exact_sections_integrate_to_the_exact_area(degrees):
    """Exact x-sections (the 3-RPR path of method "grid") at constant orientation, no dexterity limit."""
    m = random_design("rpr3", seed=1)
    phi = math.radians(degrees)
    ev = evaluate(m, orientation=(phi, phi), min_inverse_condition=0.0, error_estimate=False, method="grid")
    assert ev.volume == pytest.approx(m.exact_area(phi), rel=5e-4)
