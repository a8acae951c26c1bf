"""Gough–Stewart 6-UPS (kinematics/gough_stewart.py): round trips, Jacobian, batching, workspaces,
and an independent brute-force cross-check of the workspace volume."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from kinematics import MECHANISMS, get_mechanism
from kinematics.gough_stewart import (
    GoughStewart,
    angular_velocity_map,
    canonical_orientation,
    constant_orientation_workspace,
    orientation_workspace,
    rotation,
    workspace_6d,
)
from kinematics.workspace import evaluate

#: the design the docs and benchmarks use (mm, deg)
DESIGN = dict(r_base=400.0, r_platform=250.0, sep_base=30.0, sep_platform=30.0, height=700.0)
#: poses around the home pose, most of them reachable (mm, rad)
BOX = (np.array([-150.0, -150.0, 600.0, -0.4, -0.4, -0.4]), np.array([150.0, 150.0, 850.0, 0.4, 0.4, 0.4]))


@pytest.fixture(scope="module")
def mech() -> GoughStewart:
    return get_mechanism("gough_stewart", **DESIGN)


def poses(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(*BOX, size=(n, 6))


def test_registered_with_design_defaults():
    cls = MECHANISMS["gough_stewart"]
    assert cls is GoughStewart and cls.dof == 6
    centre = [0.5 * (v.lower + v.upper) for v in cls.design_variables]
    m = cls.from_design(centre, **cls.default_fixed)
    assert m.volume_unit() == "mm³" and m.volume_unit((-0.1, 0.1)) == "mm³·rad³"


def test_home_pose_legs_are_equal_and_match_the_geometry(mech):
    q = mech.inverse(mech.home_pose)[0]
    # leg 1: base joint at +15 deg on r_base, platform joint at 60 - 15 = 45 deg on r_platform
    b = 400.0 * np.array([math.cos(math.radians(15)), math.sin(math.radians(15)), 0.0])
    p = 250.0 * np.array([math.cos(math.radians(45)), math.sin(math.radians(45)), 700.0 / 250.0])
    assert q == pytest.approx(np.full(6, np.linalg.norm(p - b)), rel=1e-13)


def test_rotation_is_tilt_and_torsion():
    rng = np.random.default_rng(0)
    p = rng.uniform(-2.0, 2.0, size=(50, 6))
    rot = rotation(p)
    np.testing.assert_allclose(rot @ rot.transpose(0, 2, 1), np.broadcast_to(np.eye(3), rot.shape), atol=1e-13)
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=1e-13)
    # Bonev's T&T: R = Rz(phi) Ry(theta) Rz(sigma - phi) with w = theta (-sin phi, cos phi, 0)
    theta, phi, sigma = 0.7, 0.3, -0.4
    w = theta * np.array([-math.sin(phi), math.cos(phi)])

    def rz(a):
        return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])

    ry = np.array([[math.cos(theta), 0, math.sin(theta)], [0, 1, 0], [-math.sin(theta), 0, math.cos(theta)]])
    np.testing.assert_allclose(rotation([[0, 0, 0, w[0], w[1], sigma]])[0], rz(phi) @ ry @ rz(sigma - phi), atol=1e-14)


def test_angular_velocity_map_matches_finite_differences():
    p = np.random.default_rng(1).uniform(-1.5, 1.5, size=(30, 6))
    p[0, 3:5] = 0.0  # zero tilt: M = I
    m = angular_velocity_map(p)
    np.testing.assert_allclose(m[0], np.eye(3), atol=1e-15)
    h = 1e-6
    for j in range(3):
        dp = np.zeros_like(p)
        dp[:, 3 + j] = h
        r_dot = (rotation(p + dp) - rotation(p - dp)) / (2 * h)
        omega_hat = r_dot @ rotation(p).transpose(0, 2, 1)
        omega = np.stack([omega_hat[:, 2, 1], omega_hat[:, 0, 2], omega_hat[:, 1, 0]], axis=-1)
        np.testing.assert_allclose(omega, m[:, :, j], atol=1e-8)


def test_jacobian_matches_central_differences(mech):
    p = poses(300, seed=5)
    jac = mech.jacobian(p)
    step = 1e-6 * (1.0 + np.abs(p))
    fd = np.empty_like(jac)
    for j in range(6):
        dp = np.zeros_like(p)
        dp[:, j] = step[:, j]
        fd[:, :, j] = (mech.inverse(p + dp) - mech.inverse(p - dp)) / (2 * step[:, [j]])
    assert np.max(np.abs(fd - jac) / np.abs(jac).max(axis=(1, 2), keepdims=True)) < 1e-7
    # at zero tilt the pose Jacobian is the twist Jacobian
    flat = p.copy()
    flat[:, 3:5] = 0.0
    np.testing.assert_allclose(mech.jacobian(flat), mech.twist_jacobian(flat), atol=1e-12)


def check_round_trips(mech, p):
    for pose in p:
        q = mech.inverse(pose)[0]
        sols = mech.forward(q)
        assert len(sols) >= 1
        np.testing.assert_allclose(mech.inverse(sols), np.broadcast_to(q, sols.shape), rtol=1e-9)
        assert np.min(np.max(np.abs(sols - pose) / (1.0 + np.abs(pose)), axis=1)) < 1e-8
        # Newton from a nearby guess lands on the same pose
        guess = pose + np.array([20.0, -20.0, 15.0, 0.05, -0.05, 0.05])
        np.testing.assert_allclose(mech.forward_from(q, guess), pose, rtol=1e-9, atol=1e-9)


def test_inverse_forward_round_trip(mech):
    check_round_trips(mech, poses(4, seed=11))


@pytest.mark.slow
def test_inverse_forward_round_trip_many(mech):
    check_round_trips(mech, poses(200, seed=12))


def test_several_assembly_modes_including_the_mirror(mech):
    pose = np.array([30.0, -20.0, 720.0, 0.1, -0.05, 0.2])
    q = mech.inverse(pose)[0]
    modes = mech.assembly_modes(q)
    assert len(modes) >= 2
    np.testing.assert_allclose(mech.inverse(modes), np.broadcast_to(q, modes.shape), rtol=1e-9)
    # reflecting through the base plane keeps every leg length: the mirror pose is a mode
    assert (modes[:, 2] < 0).any() and (modes[:, 2] > 0).any()
    more = mech.assembly_modes(q, n_starts=1024, seed=3)
    assert len(more) >= len(modes) - 1  # more starts find (about) as many or more


def test_forward_from_far_guess_reports_failure_or_a_true_solution(mech):
    q = mech.inverse(mech.home_pose)[0]
    sol = mech.forward_from(q, [5000.0, 0.0, -3000.0, 3.0, 0.0, 3.0])
    assert np.isnan(sol).all() or np.allclose(mech.inverse(sol)[0], q, rtol=1e-9)


def test_canonical_orientation_keeps_the_rotation():
    p = np.random.default_rng(2).uniform(-5.0, 5.0, size=(40, 6))
    c = canonical_orientation(p)
    assert np.all(np.hypot(c[:, 3], c[:, 4]) <= math.pi + 1e-12)
    assert np.all((c[:, 5] > -math.pi) & (c[:, 5] <= math.pi))
    np.testing.assert_allclose(rotation(c), rotation(p), atol=1e-12)


def test_batch_equals_one_at_a_time(mech):
    p = poses(40, seed=2)
    p[::7] = np.nan
    q, jac, ic = mech.inverse(p), mech.jacobian(p), mech.inverse_condition(p)
    inside = mech.within_joint_limits(p)
    for k, pose in enumerate(p):
        np.testing.assert_array_equal(mech.inverse(pose[None])[0], q[k])
        np.testing.assert_array_equal(mech.jacobian(pose[None])[0], jac[k])
        np.testing.assert_array_equal(mech.inverse_condition(pose[None])[0], ic[k])
        assert mech.within_joint_limits(pose[None])[0] == inside[k]


def test_one_orientation_batch_equals_one_at_a_time(mech):
    """A grid at one orientation computes its rotation once: the same floats as pose by pose."""
    p = poses(30, seed=3)
    p[:, 3:] = [0.1, -0.2, 0.3]
    q, jac, ic = mech.inverse(p), mech.jacobian(p), mech.inverse_condition(p)
    base, plat = mech.cone_angles(p)
    for k, pose in enumerate(p):
        np.testing.assert_array_equal(mech.inverse(pose[None])[0], q[k])
        np.testing.assert_array_equal(mech.jacobian(pose[None])[0], jac[k])
        np.testing.assert_array_equal(mech.inverse_condition(pose[None])[0], ic[k])
        one = mech.cone_angles(pose[None])
        np.testing.assert_array_equal(one[0][0], base[k])
        np.testing.assert_array_equal(one[1][0], plat[k])


def test_unreachable_and_nan_without_warning(mech):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ic = mech.inverse_condition(np.vstack([np.full((1, 6), 1e6), np.full((1, 6), np.nan)]))
        fk = mech.forward(np.full(6, np.nan))
    assert np.isnan(ic[1]) and fk.shape == (0, 6)


def test_fichter_singularity_at_90_degrees_torsion():
    """Published: the semi-regular 6-6 platform is singular when the platform is turned by
    +-90 deg about the vertical from the central pose, at any height (Fichter, IJRR 5(2), 1986;
    Merlet, Parallel Robots, 2006, Sec. 6.x). Checked on random geometries."""
    rng = np.random.default_rng(7)
    for _ in range(5):
        m = GoughStewart(
            r_base=rng.uniform(200, 600),
            r_platform=rng.uniform(100, 400),
            sep_base=rng.uniform(5, 115),
            sep_platform=rng.uniform(5, 115),
            height=rng.uniform(300, 900),
            q_min=100.0,
            q_max=2000.0,
        )
        for z in (300.0, 800.0):
            for torsion in (math.pi / 2, -math.pi / 2):
                assert m.inverse_condition([[0, 0, z, 0, 0, torsion]])[0] < 1e-12
            # a crossing, not a touch: det J changes sign through 90 deg
            before, after = (np.linalg.det(m.jacobian([[0, 0, z, 0, 0, math.radians(a)]])[0]) for a in (85, 95))
            assert before * after < 0


@pytest.mark.parametrize(
    "name, value, field",
    [
        ("sep_base", 120.0, "'sep_base'"),
        ("sep_platform", 0.0, "'sep_platform'"),
        ("r_base", -1.0, "'r_base'"),
        ("cone_platform", 180.0, "'cone_platform'"),
        ("q_min", 950.0, "'q_min'"),
        ("cone_reference", "axis", "'cone_reference'"),
    ],
)
def test_bad_parameters_name_the_field(name, value, field):
    with pytest.raises(ValueError, match=field):
        GoughStewart(**{**DESIGN, name: value})


def test_pose_bounds_contain_every_reachable_pose(mech):
    """Reachable poses sampled in a box far larger than :meth:`pose_bounds` all fall inside it."""
    from kinematics.workspace import membership

    rng = np.random.default_rng(3)
    for orientation in ((0.0, 0.0), (-0.3, 0.3)):
        lo = np.array([-1500.0, -1500.0, -200.0, *[orientation[0]] * 3])
        hi = np.array([1500.0, 1500.0, 1800.0, *[orientation[1]] * 3])
        p = rng.uniform(lo, hi, size=(200_000, 6))
        inside, _ = membership(mech, p, orientation, 0.0)
        assert inside.sum() > 50
        blo, bhi = mech.pose_bounds(orientation)
        assert np.all(p[inside] >= blo) and np.all(p[inside] <= bhi)


def test_cone_limits_and_dexterity_shrink_the_workspace(mech):
    wide = evaluate(
        GoughStewart(**DESIGN, cone_base=80.0, cone_platform=80.0),
        resolution=16,
        min_inverse_condition=0.0,
        error_estimate=False,
    )
    tight = evaluate(mech, resolution=16, min_inverse_condition=0.0, error_estimate=False)
    assert 0 < tight.volume < wide.volume


def brute_force_volume(m: GoughStewart, tilt_x: float, tilt_y: float, torsion: float, n: int, seed: int) -> float:
    """Independent of the package's IK, limits and integrator: plain Monte-Carlo over a large box,
    each leg's length and cone angles from an explicitly composed rotation (scipy's Rotation)."""
    from scipy.spatial.transform import Rotation

    w = np.array([tilt_x, tilt_y, 0.0])
    rot = (Rotation.from_rotvec(w) * Rotation.from_euler("z", torsion)).as_matrix()
    lo, hi = np.array([-m.q_max, -m.q_max, 0.0]), np.array([m.q_max, m.q_max, m.q_max + m.r_platform])
    c = np.random.default_rng(seed).uniform(lo, hi, size=(n, 3))
    ok = np.ones(n, dtype=bool)
    for i in range(6):
        ang_b = math.radians(120 * (i // 2) + (1 if i % 2 else -1) * m.sep_base / 2)
        ang_p = math.radians(120 * (i // 2) + (60 - m.sep_platform / 2) * (1 if i % 2 else -1))
        b = m.r_base * np.array([math.cos(ang_b), math.sin(ang_b), 0.0])
        p = m.r_platform * np.array([math.cos(ang_p), math.sin(ang_p), 0.0])
        home = p + [0.0, 0.0, m.height] - b
        home /= np.linalg.norm(home)
        leg = c + rot @ p - b
        length = np.linalg.norm(leg, axis=1)
        unit = leg / length[:, None]
        ok &= (length >= m.q_min) & (length <= m.q_max)
        ok &= np.degrees(np.arccos(np.clip(unit @ home, -1, 1))) <= m.cone_base
        ok &= np.degrees(np.arccos(np.clip(unit @ (rot @ home), -1, 1))) <= m.cone_platform
    return float(np.prod(hi - lo) * ok.mean())


@pytest.mark.parametrize("angles", [(0.0, 0.0, 0.0), (0.15, -0.1, 0.3)])
def test_constant_orientation_volume_agrees_with_brute_force(mech, angles):
    """Grid evaluator vs the brute-force Monte-Carlo above (4e5 points: ~2 % standard error)."""
    ev = constant_orientation_workspace(mech, *angles, resolution=40, min_inverse_condition=0.0, error_estimate=False)
    brute = brute_force_volume(mech, *angles, n=400_000, seed=1)
    assert ev.volume_unit == "mm³"
    assert ev.volume == pytest.approx(brute, rel=0.06)


def test_orientation_workspace_at_home_position(mech):
    ev = orientation_workspace(mech, (0.0, 0.0, 700.0), (-0.6, 0.6), resolution=12, error_estimate=False)
    assert ev.volume_unit == "rad³"
    assert 0.0 < ev.suri < 1.0 and ev.volume == pytest.approx(ev.suri * 1.2**3)
    assert ev.n_inside < ev.n_samples  # the box is larger than the orientation workspace


def test_workspace_6d_interval_covers_a_fine_grid(mech):
    """QMC 6-D volume vs the grid evaluator on the same orientation box (8 nodes per axis is
    coarse: agreement within 10 %); the interval is narrow and contains the estimate."""
    orientation = (-0.12, 0.12)
    qmc = workspace_6d(mech, orientation, n_points=2**12, replicates=4, seed=0)
    lo, hi = qmc.volume_ci
    assert lo < qmc.volume < hi and (hi - lo) < 0.1 * qmc.volume
    assert qmc.unit == "mm³·rad³" and qmc.box_volume == pytest.approx(
        float(np.prod(np.subtract(qmc.box_upper, qmc.box_lower)))
    )
    grid = evaluate(mech, orientation=orientation, resolution=8, error_estimate=False)
    assert grid.volume_unit == "mm³·rad³"
    assert qmc.volume == pytest.approx(grid.volume, rel=0.1)
    assert 0 < qmc.gdi < 1 and qmc.gdi == pytest.approx(grid.gdi, rel=0.05)
    again = workspace_6d(mech, orientation, n_points=2**12, replicates=4, seed=0)
    assert again == qmc


def test_characteristic_length_changes_gdi_only(mech):
    a = evaluate(mech, resolution=16, length=100.0, error_estimate=False)
    b = evaluate(mech, resolution=16, length=400.0, error_estimate=False, min_inverse_condition=0.01)
    assert abs(a.gdi - b.gdi) > 1e-3
    assert mech.characteristic_length == 250.0


def test_default_evaluation_is_the_constant_orientation_workspace(mech):
    ev = evaluate(mech, error_estimate=False)
    assert ev.resolution == 26 and ev.n_samples == 26**3 and ev.volume_unit == "mm³"
    co = constant_orientation_workspace(mech, resolution=26, error_estimate=False)
    assert co.volume == pytest.approx(ev.volume, rel=1e-12) and co.gdi == pytest.approx(ev.gdi, rel=1e-12)


def test_compiled_newton_takes_the_numpy_steps(mech):
    from kinematics import kernels

    for pose in poses(3, seed=21):
        q = mech.inverse(pose)[0]
        fast = mech.assembly_modes(q, n_starts=128)
        with kernels.reference_kernels():
            reference = mech.assembly_modes(q, n_starts=128)
        assert fast.shape == reference.shape and len(fast) >= 2
        np.testing.assert_allclose(fast, reference, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("orientation", [(0.0, 0.0), (-0.3, 0.3)])
def test_compiled_membership_matches_the_numpy_path(mech, orientation):
    """The fused IK + limits + Jacobian kernel: same poses in and out, same 1/kappa (one
    orientation: the rotation computed once; a box: per pose)."""
    from kinematics import kernels
    from kinematics.workspace import membership

    lo, hi = mech.pose_bounds(orientation)
    p = lo + (hi - lo) * np.random.default_rng(5).random((20000, 6))
    assert mech.reachable_inverse_condition(p) is not None
    inside, ic = membership(mech, p, orientation, 0.0)
    with kernels.reference_kernels():
        assert mech.reachable_inverse_condition(p) is None
        ref_inside, ref_ic = membership(mech, p, orientation, 0.0)
    np.testing.assert_array_equal(inside, ref_inside)
    assert 100 < ref_inside.sum() < len(p) - 100
    np.testing.assert_allclose(ic[ref_inside], ref_ic[ref_inside], rtol=1e-12)
