"""Compiled kernels (kinematics/kernels.py) against the numpy reference path."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kinematics import get_mechanism, kernels
from kinematics.conditioning import inverse_condition_number, inverse_condition_svd
from kinematics.workspace import _grid_axes, _grid_poses, evaluate
from tests.conftest import PAPER_DESIGNS

ROOT = Path(__file__).resolve().parents[1]
FIELDS = ("volume", "gdi", "inverse_condition_min", "inverse_condition_max", "volume_error", "gdi_error")


def both_paths(func):
    """``func()`` with the compiled kernels and with the numpy reference."""
    assert kernels.compiled()
    fast = func()
    with kernels.reference_kernels():
        assert not kernels.compiled()
        reference = func()
    return fast, reference


CASES = [(name, {}, {}) for name in sorted(PAPER_DESIGNS)] + [
    ("h4", {"ball_joint_limit": 65.0}, {}),                 # joint limit inside the fused H4 kernel
    ("h4", {"homogenising": "rod"}, {"resolution": 16}),
    ("h4", {}, {"fixed": {"theta": 0.2}}),                  # a slice: fused path with one angle
    ("h4", {"base": "tracking"}, {"min_inverse_condition": 0.0}),
    ("tricept", {}, {"method": "polar", "resolution": 12}),
    ("rpr3", {}, {"orientation": (0.5, 0.5)}),
]


@pytest.mark.parametrize("name, extra, options", CASES,
                         ids=[f"{n}-{'-'.join(e) or 'default'}-{'-'.join(o) or 'grid'}" for n, e, o in CASES])
def test_evaluation_matches_the_numpy_reference(name, extra, options):
    mech = get_mechanism(name, **{**PAPER_DESIGNS[name], **extra})
    fast, reference = both_paths(lambda: evaluate(mech, **options))
    assert fast.n_inside == reference.n_inside
    for field in FIELDS:
        a, b = getattr(fast, field), getattr(reference, field)
        assert a == pytest.approx(b, rel=1e-12, abs=1e-300), field


def random_matrices(n: int, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    jac = rng.normal(size=(count, n, n))
    # a spread of conditioning: scale one column down by up to 1e-4
    jac[:, :, 0] *= 10.0 ** rng.uniform(-4, 0, size=(count, 1))
    return jac


@pytest.mark.parametrize("n", [2, 3, 4])
def test_inverse_condition_matches_numpy_and_svd(n):
    jac = random_matrices(n, 4000, seed=n)
    jac[5] = np.nan
    jac[6, 1] = np.inf
    jac[7] = 0.0
    scale = np.linspace(1.0, 0.5, n)
    fast, reference = both_paths(lambda: inverse_condition_number(jac, scale))
    assert np.isnan(fast[5]) and np.isnan(reference[5])
    assert fast[6] == reference[6] == 0.0 and fast[7] == reference[7] == 0.0
    finite = np.isfinite(reference)
    np.testing.assert_allclose(fast[finite], reference[finite], rtol=1e-12, atol=1e-15)
    svd = inverse_condition_svd(jac[8:] * scale)
    good = svd > 1e-3
    np.testing.assert_allclose(fast[8:][good], svd[good], rtol=1e-7)


def test_h4_fused_columns_equal_interval_and_conditioning():
    mech = get_mechanism("h4", **PAPER_DESIGNS["h4"], ball_joint_limit=65.0)
    orientation = mech.default_orientation
    axes, _ = _grid_axes(mech, 20, orientation, {}, exact_axis=2)
    poses = _grid_poses(axes, 0, 20**3)
    lo, hi = mech.pose_bounds(orientation)
    lower, upper, ic = mech.exact_axis_columns(poses, lo[2], hi[2])
    with kernels.reference_kernels():
        assert mech.exact_axis_columns(poses, lo[2], hi[2]) is None
        _, ref_lower, ref_upper = mech.invariant_axis_interval(poses)
        ref_lower, ref_upper = np.maximum(ref_lower, lo[2]), np.minimum(ref_upper, hi[2])
        feasible = ref_upper - ref_lower > 0
        at = poses.copy()
        at[feasible, 2] = 0.5 * (ref_lower[feasible] + ref_upper[feasible])
        conditioned = feasible & mech.within_joint_limits(at)
        ref_ic = np.full(len(poses), np.nan)
        ref_ic[conditioned] = mech.inverse_condition(at[conditioned])
    np.testing.assert_array_equal(lower, ref_lower)
    np.testing.assert_array_equal(upper, ref_upper)
    np.testing.assert_array_equal(np.isnan(ic), np.isnan(ref_ic))
    assert 0 < conditioned.sum() < len(poses)  # the joint limit and the box both bite
    np.testing.assert_allclose(ic[conditioned], ref_ic[conditioned], rtol=1e-12)


def test_kernel_choice_from_the_environment(monkeypatch):
    monkeypatch.setenv(kernels.KERNELS_ENV, "numpy")
    assert not kernels.compiled()
    monkeypatch.setenv(kernels.KERNELS_ENV, "numba")
    assert kernels.compiled()
    monkeypatch.setenv(kernels.KERNELS_ENV, "fortran")
    with pytest.raises(ValueError, match="PM_DESIGN_KERNELS must be one of numba, numpy; got 'fortran'"):
        kernels.compiled()


def test_unknown_kernel_choice_is_one_line_before_any_work(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "pipeline", "+experiment=rpr2_mixed", "+debug=fast",
                           f"paths.output_dir={tmp_path}", f"hydra.run.dir={tmp_path / 'run'}"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120,
                          env={**os.environ, kernels.KERNELS_ENV: "fortran"})
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == ("error: environment variable PM_DESIGN_KERNELS must be one of "
                                   "numba, numpy; got 'fortran'")
    assert not (tmp_path / "run").exists()


def test_h4_compiled_inverse_condition_matches_the_numpy_path():
    mech = get_mechanism("h4", **PAPER_DESIGNS["h4"])
    rng = np.random.default_rng(3)
    lo, hi = mech.pose_bounds(mech.default_orientation)
    poses = lo + (hi - lo) * rng.random((20000, 4))
    fast, reference = both_paths(lambda: mech.inverse_condition(poses, length=7.5))
    np.testing.assert_array_equal(np.isnan(fast), np.isnan(reference))
    assert 1000 < np.isfinite(reference).sum() < len(poses)  # reachable and unreachable poses
    good = reference > 1e-3
    np.testing.assert_allclose(fast[good], reference[good], rtol=1e-10)
    np.testing.assert_allclose(fast[~good & np.isfinite(reference)], reference[~good & np.isfinite(reference)],
                               atol=1e-12)


FUSED = [("rpr2", {}), ("rpr3", {}), ("delta", {}), ("delta", {"passive_limit": 20.0}), ("tricept", {}),
         ("tricept", {"cone_reference": "home", "tilt_limit": 25.0}), ("tricept", {"cone_joints": "platform"}),
         ("tricept", {"cone_joints": "none", "offset_side": -1})]


@pytest.mark.parametrize("name, extra", FUSED, ids=[f"{n}-{'-'.join(e) or 'default'}" for n, e in FUSED])
def test_fused_membership_matches_the_numpy_path(name, extra):
    """Per pose: the compiled IK + limits + 1/kappa of ``reachable_inverse_condition``
    against the numpy membership test (same poses in and out, same 1/kappa)."""
    from kinematics.workspace import membership

    mech = get_mechanism(name, **{**PAPER_DESIGNS[name], **extra})
    orientation = mech.default_orientation
    lo, hi = mech.pose_bounds(orientation)
    poses = lo + (hi - lo) * np.random.default_rng(5).random((30000, mech.dof))
    fused = mech.reachable_inverse_condition(poses)
    assert fused is not None, "this mechanism should have a compiled kernel"
    (inside, ic), (ref_inside, ref_ic) = both_paths(lambda: membership(mech, poses, orientation, 0.0))
    with kernels.reference_kernels():
        assert mech.reachable_inverse_condition(poses) is None
    np.testing.assert_array_equal(inside, ref_inside)
    np.testing.assert_array_equal(np.isnan(ic), np.isnan(ref_ic))
    assert 300 < ref_inside.sum() < len(poses) - 300  # poses both in and out
    np.testing.assert_allclose(ic[ref_inside], ref_ic[ref_inside], rtol=1e-12, atol=1e-15)
