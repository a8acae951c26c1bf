"""The papers' numerical examples (seeds 000, 001, 003, 004)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinematics import MECHANISMS, get_mechanism
from kinematics.h4 import BASE_READINGS, H4
from kinematics.rpr2 import RPR2
from kinematics.rpr3 import RPR3
from kinematics.tricept import Tricept

#: every reading of how the base follows the design reproduces eq. 25-27 at h = d = 6, Qz = 42
EQ26_POSE = np.array([[5.0, -5.0, -30.0, math.pi / 6]])


def test_registry_names():
    assert {"h4", "tricept", "rpr3", "rpr2"} <= set(MECHANISMS)  # plus any added mechanism module
    assert MECHANISMS["h4"] is H4 and MECHANISMS["tricept"] is Tricept
    assert MECHANISMS["rpr3"] is RPR3 and MECHANISMS["rpr2"] is RPR2


def test_unknown_mechanism_lists_names():
    with pytest.raises(ValueError, match="unknown mechanism 'stewart'.*h4.*rpr2.*rpr3.*tricept"):
        get_mechanism("stewart")


# ------------------------------------------------------------------- H4
@pytest.mark.parametrize("base", BASE_READINGS)
def test_h4_base_points_and_rods_eq25(base):
    m = H4(d=6, h=6, Qz=42, base=base)
    a = m.base_points(np.zeros(4))[0]
    np.testing.assert_array_equal(a, [[-48, -48, 0], [-48, 48, 0], [6, 48, 0], [48, -6, 0]])
    b = m.platform_points([[0, 0, -42, 0]])[0]
    np.testing.assert_array_equal(b, [[-6, -6, -42], [-6, 6, -42], [6, 6, -42], [6, -6, -42]])
    np.testing.assert_allclose(np.linalg.norm(b - a, axis=1), 42 * np.sqrt([3, 3, 2, 2]))


@pytest.mark.parametrize("base", BASE_READINGS)
def test_h4_inverse_eq26(base):
    q = H4(d=6, h=6, Qz=42, base=base).inverse(EQ26_POSE)[0]
    np.testing.assert_allclose(q[:3], [13.021, -7.488, 9.679], atol=5e-4)
    assert abs(q[3] - 15.77) < 5e-3


@pytest.mark.parametrize("base", BASE_READINGS)
def test_h4_forward_polynomial_roots_eq27(base):
    m = H4(d=6, h=6, Qz=42, base=base)
    poly = m.forward_polynomial(m.inverse(EQ26_POSE)[0])
    assert poly.shape == (9,)
    roots = np.roots(poly)
    paper = [
        -0.61309 + 0.56609j,
        -0.61309 - 0.56609j,
        0.073172 + 0.84245j,
        0.073172 - 0.84245j,
        0.028294 + 0.88575j,
        0.028294 - 0.88575j,
        0.267957,
        -2.8822,
    ]
    for p in paper:
        nearest = roots[np.argmin(np.abs(roots - p))]
        # 4 significant digits in the real and in the imaginary part
        assert abs(nearest.real - p.real) <= 5e-4 * abs(p.real)
        assert abs(nearest.imag - np.imag(p)) <= 5e-4 * abs(np.imag(p))
    assert np.sum(np.abs(roots.imag) < 1e-9) == 2


@pytest.mark.parametrize("base", BASE_READINGS)
def test_h4_forward_returns_both_real_poses_eq27(base):
    m = H4(d=6, h=6, Qz=42, base=base)
    sols = m.forward(m.inverse(EQ26_POSE)[0])
    assert sols.shape == (2, 4)
    np.testing.assert_allclose(sols[1], EQ26_POSE[0], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(sols[0], [3, -7.95, -14.58, -2.47], atol=0.01)


@pytest.mark.parametrize("base", BASE_READINGS)
def test_h4_tan_half_of_eq27_roots_gives_the_poses(base):
    m = H4(d=6, h=6, Qz=42, base=base)
    sols = m.forward(m.inverse(EQ26_POSE)[0])
    np.testing.assert_allclose(np.tan(sols[:, 3] / 2), [-2.8822, 0.267957], rtol=5e-5)


# -------------------------------------------------------------- Tricept
def test_tricept_leg1_closed_form_corrects_eq3():
    """Eq. 3 misses the -(2/sqrt3) a c S(theta) term; the geometry has it."""
    a, b, d = 250.0, 400.0, 100.0
    m = Tricept(a=a, b=b, d=d)
    rng = np.random.default_rng(3)
    poses = rng.uniform([400, -0.5, -0.5], [700, 0.5, 0.5], size=(50, 3))
    c, psi, th = poses.T
    q1_sq = (
        a**2 / 3
        + b**2 / 3
        + c**2
        + d**2
        - 2 / 3 * a * b * np.cos(th)
        + 2 * c * d * np.cos(th) * np.cos(psi)
        - 2 * b * d / np.sqrt(3) * np.cos(psi) * np.sin(th)
        - 2 * a * c / np.sqrt(3) * np.sin(th)
    )
    np.testing.assert_allclose(m.inverse(poses)[:, 0] ** 2, q1_sq, rtol=1e-12)


def test_tricept_platform_geometry_eq1_2():
    m = Tricept(a=300.0, b=450.0, d=50.0)
    pts = m.platform_points([[600.0, 0.0, 0.0]])[0]
    side = np.linalg.norm(pts[0] - pts[1])
    assert side == pytest.approx(300.0)
    np.testing.assert_allclose(pts[:, 2], 650.0)
    np.testing.assert_allclose(np.linalg.norm(m.base[0] - m.base[1]), 450.0)


def test_tricept_forward_solutions_come_in_mirror_pairs():
    m = Tricept(a=250.0, b=400.0, d=100.0)
    sols = m.forward(m.inverse([[550.0, 0.2, -0.1]])[0])
    assert len(sols) % 2 == 0 and len(sols) > 0
    assert np.sum(sols[:, 0] > 0) == np.sum(sols[:, 0] < 0)


def test_tricept_cone_angles_at_home():
    m = Tricept(a=250.0, b=400.0, d=100.0)
    base, plat = m.cone_angles([[600.0, 0.0, 0.0]])
    # leg from (400/sqrt3, 0, 0) to (250/sqrt3, 0, 700): both cones equal at home
    expect = math.atan2((400 - 250) / math.sqrt(3), 700)
    np.testing.assert_allclose(base, expect)
    np.testing.assert_allclose(plat, expect)


# ---------------------------------------------------------------- 3-RPR
THESIS_RPR3 = dict(base=[[0, 0], [200, 0], [0, 200]], platform=[[0, 0], [50, 0], [40, 40]], rho_min=80.0, rho_max=160.0)


def test_rpr3_thesis_example_two_modes():
    m = RPR3(**THESIS_RPR3)
    q = np.array([100.0, 120.0, 150.0])
    sols = m.forward(q)
    assert sols.shape == (2, 3)
    np.testing.assert_allclose(m.inverse(sols), [q, q], rtol=1e-12)
    # the thesis' "algebraic method" values, rounded to 2 decimals; its mode 2
    # (52.86, 84.95, -33.45) is itself off the constraints by 0.05 mm in the
    # legs, hence 0.1 mm / 0.05 deg
    np.testing.assert_allclose(sols[0, :2], [52.86, 84.95], atol=0.1)
    assert math.degrees(sols[0, 2]) == pytest.approx(-33.45, abs=0.05)
    np.testing.assert_allclose(sols[1, :2], [97.99, 19.91], atol=0.01)
    assert math.degrees(sols[1, 2]) == pytest.approx(85.01, abs=0.01)


def test_rpr3_polynomial_is_degree_six():
    m = RPR3(**THESIS_RPR3)
    rng = np.random.default_rng(0)
    for q in rng.uniform(80, 160, size=(20, 3)):
        poly = m.forward_polynomial(q)
        assert poly.shape == (7,)


def test_rpr3_forward_ga_reaches_a_mode():
    m = RPR3(**THESIS_RPR3)
    q = np.array([100.0, 120.0, 150.0])
    best = m.forward_ga(q, seed=0, generations=300)
    assert best.shape == (1, 3)
    modes = m.forward(q)
    # a GA solution is approximate (thesis: ~0.15 mm, ~1 deg off); it must be
    # near one of the exact modes and much better than a random guess
    dist = np.min(np.linalg.norm(modes[:, :2] - best[0, :2], axis=1))
    assert dist < 10.0
    assert np.abs(m.inverse(best)[0] - q).max() < 10.0
    np.testing.assert_array_equal(best, m.forward_ga(q, seed=0, generations=300))


# ---------------------------------------------------------------- 2-RPR
def test_rpr2_dh_and_algebraic_inverse_agree():
    m = RPR2(b=5.0, q_min=6.0, q_max=9.6)
    poses = np.random.default_rng(1).uniform([-6, -9], [11, 9], size=(500, 2))
    q_dh, theta = m.inverse_dh(poses)
    np.testing.assert_allclose(q_dh, m.inverse(poses), rtol=1e-12)
    # eq. 9: O_i + q_i (-sin theta_i, cos theta_i) is the end-effector point
    rebuilt = m.base + q_dh[..., None] * np.stack([-np.sin(theta), np.cos(theta)], axis=-1)
    np.testing.assert_allclose(rebuilt, np.broadcast_to(poses[:, None, :], rebuilt.shape), atol=1e-12)


def test_rpr2_forward_closed_form_both_branches():
    m = RPR2(b=5.0, q_min=6.0, q_max=9.6)
    sols = m.forward([7.0, 8.0])
    x = (49 + 25 - 64) / 10
    np.testing.assert_allclose(sols, [[x, -math.sqrt(49 - x**2)], [x, math.sqrt(49 - x**2)]])
    assert m.forward([1.0, 9.0]).shape == (0, 2)  # circles do not meet
