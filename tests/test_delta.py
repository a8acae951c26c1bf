"""Delta robot (kinematics/delta.py): IK∘FK, both assembly modes, Jacobian vs finite differences,
vectorised == one at a time, limits, and the pipeline end to end."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import get_mechanism
from kinematics.workspace import evaluate

DESIGN = dict(R=200.0, r=50.0, la=200.0, lb=400.0)


def poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-150, 150, n), rng.uniform(-150, 150, n), rng.uniform(-480, -250, n)])


def test_home_pose_by_hand():
    """Centre at z = -300 mm: u = -150, A = -60000, B = 120000, C = -7500 -> theta = 23.36 deg for every leg."""
    q = get_mechanism("delta", **DESIGN).inverse([[0.0, 0.0, -300.0]])[0]
    np.testing.assert_allclose(np.degrees(q), 23.3604, atol=1e-4)


def test_inverse_forward_round_trip_and_both_assembly_modes():
    delta = get_mechanism("delta", **DESIGN)
    x = poses(300, 1)
    q = delta.inverse(x)
    ok = np.all(np.isfinite(q), axis=1)
    assert ok.sum() > 250
    for pose, qi in zip(x[ok], q[ok]):
        modes = delta.assembly_modes(qi)
        assert modes.shape == (2, 3) and modes[0, 2] < modes[1, 2]
        np.testing.assert_allclose(modes[0], pose, atol=1e-8)  # the working mode is the lower one
        # both modes satisfy the three sphere constraints
        assert np.max(np.abs(delta._constraints(modes, qi))) < 1e-6
        sols = delta.forward(qi)
        assert np.min(np.abs(sols - pose).max(axis=1)) < 1e-8


def test_jacobian_matches_finite_differences():
    delta = get_mechanism("delta", **DESIGN)
    x = poses(50, 2)
    x = x[np.all(np.isfinite(delta.inverse(x)), axis=1)]
    jac = delta.jacobian(x)
    eps = 1e-5
    fd = np.stack([(delta.inverse(x + eps * e) - delta.inverse(x - eps * e)) / (2 * eps) for e in np.eye(3)],
                  axis=-1)
    assert np.max(np.abs(jac - fd)) < 1e-7


def test_vectorised_equals_one_at_a_time():
    delta = get_mechanism("delta", **DESIGN)
    x = poses(40, 3)
    q_all, j_all, ic_all = delta.inverse(x), delta.jacobian(x), delta.inverse_condition(x)
    for k in range(len(x)):
        np.testing.assert_array_equal(delta.inverse(x[k]), q_all[k:k + 1])
        np.testing.assert_array_equal(delta.jacobian(x[k]), j_all[k:k + 1])
        np.testing.assert_array_equal(delta.inverse_condition(x[k]), ic_all[k:k + 1])


def test_limits_and_workspace():
    delta = get_mechanism("delta", **DESIGN)
    wide = get_mechanism("delta", **DESIGN, passive_limit=80.0, theta_min=-80.0, theta_max=100.0)
    ev, ev_wide = evaluate(delta, error_estimate=False), evaluate(wide, error_estimate=False)
    assert 0 < ev.volume < ev_wide.volume and ev.volume_unit == "mm³"
    assert 0 < ev.gdi <= 1 and 0 < ev.suri < 1
    with pytest.raises(ValueError, match="'r'"):
        get_mechanism("delta", R=100.0, r=150.0, la=200.0, lb=400.0)
