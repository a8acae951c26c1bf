"""Properties that hold for any input: round trips, Jacobians, batching, validation."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from kinematics import get_mechanism
from kinematics.testing import central_differences
from tests.conftest import PAPER_DESIGNS, random_poses

N_ROUND_TRIP = 1000


def _reachable(m, poses):
    q = m.inverse(poses)
    keep = np.isfinite(q).all(axis=1)
    # exclude poses within 1e-6 of a singularity, where FK is ill-conditioned
    keep &= m.inverse_condition(poses) > 1e-6
    return poses[keep], q[keep]


#: the Tricept's forward kinematics (a polynomial eigenvalue problem per pose) takes ~40 s for the
#: round trips: its case runs in the slow tier; the other mechanisms' in the default one
@pytest.mark.parametrize(
    "name", [pytest.param(n, marks=pytest.mark.slow) if n == "tricept" else n for n in sorted(PAPER_DESIGNS)]
)
def test_inverse_forward_round_trip(name):
    m = get_mechanism(name, **PAPER_DESIGNS[name])
    poses, qs = _reachable(m, random_poses(name, 5 * N_ROUND_TRIP, seed=11))
    poses, qs = poses[:N_ROUND_TRIP], qs[:N_ROUND_TRIP]
    assert len(poses) == N_ROUND_TRIP
    angular = np.asarray(m.angular)
    misses = []
    for pose, q in zip(poses, qs):
        sols = m.forward(q)
        diff = sols - pose
        diff[:, angular] = np.angle(np.exp(1j * diff[:, angular]))  # angles modulo 2 pi
        rel = np.max(np.abs(diff) / (1.0 + np.abs(pose)), axis=1) if len(sols) else np.array([np.inf])
        if rel.min() >= 1e-8:
            misses.append((pose, rel.min()))
        # every returned pose is a true solution
        np.testing.assert_allclose(m.inverse(sols), np.broadcast_to(q, sols.shape), rtol=1e-8)
    assert not misses, f"{len(misses)} poses not recovered, e.g. {misses[:3]}"


@pytest.mark.parametrize("name", sorted(PAPER_DESIGNS))
def test_jacobian_matches_central_differences(name):
    m = get_mechanism(name, **PAPER_DESIGNS[name])
    poses, _ = _reachable(m, random_poses(name, 400, seed=5))
    poses = poses[m.inverse_condition(poses) > 1e-3][:200]
    jac = m.jacobian(poses)
    fd = central_differences(m, poses)
    scale = np.abs(jac).max(axis=(1, 2), keepdims=True)
    assert np.max(np.abs(fd - jac) / scale) < 1e-6


def test_batch_equals_one_at_a_time(mechanism):
    poses = random_poses(mechanism.name, 60, seed=2)
    poses[::7] = np.nan
    q = mechanism.inverse(poses)
    jac = mechanism.jacobian(poses)
    ic = mechanism.inverse_condition(poses)
    for k, pose in enumerate(poses):
        np.testing.assert_array_equal(mechanism.inverse(pose[None])[0], q[k])
        np.testing.assert_array_equal(mechanism.jacobian(pose[None])[0], jac[k])
        np.testing.assert_array_equal(mechanism.inverse_condition(pose[None])[0], ic[k])


def test_single_pose_returns_a_batch(mechanism):
    pose = random_poses(mechanism.name, 1, seed=0)[0]
    assert mechanism.inverse(pose).shape == (1, mechanism.dof)
    assert mechanism.jacobian(pose).shape == (1, mechanism.dof, mechanism.dof)
    assert mechanism.inverse_condition(pose).shape == (1,)


def test_wrong_shape_names_expected_shape(mechanism):
    with pytest.raises(ValueError, match=rf"shape \(N, {mechanism.dof}\)"):
        mechanism.inverse(np.zeros((3, mechanism.dof + 1)))
    with pytest.raises(ValueError, match=rf"shape \({mechanism.dof},\)"):
        mechanism.forward(np.zeros(mechanism.dof + 1))


def test_unreachable_and_nan_give_nan_without_warning(mechanism):
    far = np.full((2, mechanism.dof), 1e6)
    nan = np.full((1, mechanism.dof), np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ic = mechanism.inverse_condition(np.vstack([far, nan]))
        q_nan = mechanism.inverse(nan)
        fk = mechanism.forward(np.full(mechanism.dof, np.nan))
    assert np.isnan(q_nan).all()
    assert np.isnan(ic[2])
    assert fk.shape == (0, mechanism.dof)


def test_h4_unreachable_pose_is_nan_row():
    m = get_mechanism("h4", **PAPER_DESIGNS["h4"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        q = m.inverse([[500.0, 0.0, -40.0, 0.0], [0.0, 0.0, -42.0, 0.0]])
        ic = m.inverse_condition([[500.0, 0.0, -40.0, 0.0]])
    assert np.isnan(q[0]).all() and np.isfinite(q[1]).all()
    assert np.isnan(ic[0])


def test_inverse_condition_bounds_and_singularities():
    m = get_mechanism("rpr2", **PAPER_DESIGNS["rpr2"])
    # on the base line the two legs are collinear: J singular, 1/kappa = 0
    assert m.inverse_condition([[2.0, 0.0]])[0] == pytest.approx(0.0, abs=1e-12)
    # above the midpoint at height b/2 the legs are orthogonal: isotropic
    assert m.inverse_condition([[2.5, 2.5]])[0] == pytest.approx(1.0)
    h4 = get_mechanism("h4", **PAPER_DESIGNS["h4"])
    ic = h4.inverse_condition(random_poses("h4", 2000, seed=1))
    ok = ic[np.isfinite(ic)]
    assert ok.size > 100 and ok.min() >= 0.0 and ok.max() <= 1.0


def test_h4_inverse_condition_zero_on_ik_boundary():
    m = get_mechanism("h4", **PAPER_DESIGNS["h4"])
    # move along x until rod 4's horizontal projection equals its length
    # (A_4 = (48, -6), B_4 = (6 + x, -6)): x = 42 + 42 sqrt2 - 42 -> |dx| = M_4
    x = 42.0 - 42.0 * np.sqrt(2.0)
    pose = np.array([[x, 0.0, -42.0, 0.0]])
    assert m.inverse(pose)[0, 3] == pytest.approx(-42.0)
    assert m.inverse_condition(pose)[0] == 0.0


def test_length_changes_inverse_condition_only_for_angular_mechanisms():
    rpr2 = get_mechanism("rpr2", **PAPER_DESIGNS["rpr2"])
    poses = random_poses("rpr2", 20, seed=3)
    np.testing.assert_array_equal(
        rpr2.inverse_condition(poses, length=1.0), rpr2.inverse_condition(poses, length=100.0)
    )
    h4 = get_mechanism("h4", **PAPER_DESIGNS["h4"])
    poses = random_poses("h4", 20, seed=3)
    a, b = h4.inverse_condition(poses, length=1.0), h4.inverse_condition(poses, length=50.0)
    assert np.nanmax(np.abs(a - b)) > 1e-3
    with pytest.raises(ValueError, match="length"):
        h4.inverse_condition(poses, length=-1.0)


@pytest.mark.parametrize(
    "name, params, field",
    [
        ("h4", dict(d=-1.0, h=6.0, Qz=42.0), "'d'"),
        ("h4", dict(d=6.0, h=float("nan"), Qz=42.0), "'h'"),
        ("h4", dict(d=6.0, h=6.0, Qz=42.0, stroke=0.0), "'stroke'"),
        ("tricept", dict(a=250.0, b=400.0, d=100.0, q_min=800.0, q_max=750.0), "'q_min'"),
        ("tricept", dict(a=250.0, b=-4.0, d=100.0), "'b'"),
        ("tricept", dict(a=250.0, b=400.0, d=100.0, cone=200.0), "'cone'"),
        ("rpr3", dict(base=[[0, 0], [1, 0]], platform=[[0, 0], [1, 0], [0, 1]], rho_min=1.0, rho_max=2.0), "'base'"),
        (
            "rpr3",
            dict(base=[[0, 0], [1, 0], [0, 1]], platform=[[1, 0], [1, 0], [0, 1]], rho_min=1.0, rho_max=2.0),
            "'platform'",
        ),
        (
            "rpr3",
            dict(base=[[0, 0], [1, 0], [0, 1]], platform=[[0, 0], [1, 0], [0, 1]], rho_min=3.0, rho_max=2.0),
            "'rho_min'",
        ),
        ("rpr2", dict(b=5.0, q_min=6.0, q_max=float("inf")), "'q_max'"),
        ("rpr2", dict(q_min=6.0, q_max=9.6), "b"),  # a design variable left out (a fixed one takes its default)
    ],
)
def test_bad_parameters_name_the_field(name, params, field):
    with pytest.raises(ValueError, match=field):
        get_mechanism(name, **params)


def test_fast_inverse_condition_matches_svd():
    from kinematics.conditioning import inverse_condition_number, inverse_condition_svd

    rng = np.random.default_rng(4)
    for n in (2, 3, 4):
        u, _, vt = np.linalg.svd(rng.normal(size=(3000, n, n)))
        s = np.sort(10 ** rng.uniform(-5, 0, size=(3000, n)), axis=1)[:, ::-1]
        jac = np.einsum("nij,nj,njk->nik", u, s, vt) * 10 ** rng.uniform(-3, 3, size=(3000, 1, 1))
        fast, ref = inverse_condition_number(jac), inverse_condition_svd(jac)
        assert np.max(np.abs(fast - ref)) < 1e-3
        big = ref > 1e-3
        assert np.max(np.abs(fast[big] - ref[big]) / ref[big]) < 1e-4
