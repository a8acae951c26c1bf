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


CASES = (
    [(name, {}, {}) for name in sorted(PAPER_DESIGNS)]
    + [
        ("h4", {"ball_joint_limit": 65.0}, {}),  # joint limit inside the fused H4 kernel
        ("h4", {"homogenising": "rod"}, {"resolution": 16}),
        ("h4", {}, {"fixed": {"theta": 0.2}}),  # a slice: fused path with one angle
        ("h4", {"base": "tracking"}, {"min_inverse_condition": 0.0}),
        ("tricept", {}, {"method": "polar", "resolution": 12}),
        ("rpr3", {}, {"orientation": (0.5, 0.5)}),
    ]
    + [
        # the boundary-fraction grid: bisection, faces, sparse cut cells (compiled) against the numpy
        # reference of the same steps (small grids: the numpy kernels are slow)
        *[(name, {}, {"method": "grid", "resolution": 12}) for name in sorted(PAPER_DESIGNS)],
        ("rpr3", {}, {"method": "grid", "orientation": (0.5, 0.5), "resolution": 48}),
        ("h4", {}, {"method": "grid", "fixed": {"theta": 0.2}, "resolution": 16}),
        ("rpr2", {}, {"method": "grid", "resolution": 64, "min_inverse_condition": 0.0}),
    ]
)


@pytest.mark.parametrize(
    "name, extra, options", CASES, ids=[f"{n}-{'-'.join(e) or 'default'}-{'-'.join(o) or 'grid'}" for n, e, o in CASES]
)
def test_evaluation_matches_the_numpy_reference(name, extra, options):
    mech = get_mechanism(name, **{**PAPER_DESIGNS[name], **extra})
    fast, reference = both_paths(lambda: evaluate(mech, **options))
    assert fast.n_inside == reference.n_inside
    # The bound on the 1/kappa of one pose: both paths take the eigenvalues of J^T J (compiled:
    # Laguerre on the characteristic polynomial; numpy: eigvalsh / the closed forms), each
    # backward stable, with absolute errors O(eps * lambda_max); so lambda_min, and
    # 1/kappa = sqrt(lambda_min / lambda_max), carry a relative error O(eps * kappa^2). The GDI is
    # a weighted mean of positive 1/kappa over the same nodes (n_inside equal), so its relative
    # error is at most the largest nodal one, at kappa_max = 1 / inverse_condition_min. C = 1e3
    # covers the algorithms' dimension-dependent constants (measured: at most 111 on the paper
    # designs, numpy 2.4, numba 0.68); the same bound holds for 1/kappa's min and max.
    kappa_max = 1.0 / max(min(fast.inverse_condition_min, reference.inverse_condition_min), 1e-8)
    ic_rel = max(1e3 * np.finfo(float).eps * kappa_max**2, 1e-12)
    for field in FIELDS:
        a, b = getattr(fast, field), getattr(reference, field)
        # an error estimate is a difference of two integrals: rounding of the integrals, not of
        # it; and its second grid's bisection can put a probe within rounding of a reachability
        # boundary, where the two kernels may disagree on the side (seen once: H4 slice at
        # resolution 58, 1e-6 of V): that moves one crossing by 1/32 of a cell
        scale = getattr(reference, field.removesuffix("_error")) if field.endswith("_error") else 0.0
        rel = ic_rel if field.startswith(("gdi", "inverse_condition")) else 1e-12
        assert a == pytest.approx(b, rel=rel, abs=max(1e-5 * scale, 1e-300)), field


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
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pipeline",
            "+experiment=rpr2_mixed",
            "+debug=fast",
            f"paths.output_dir={tmp_path}",
            f"hydra.run.dir={tmp_path / 'run'}",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, kernels.KERNELS_ENV: "fortran"},
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == (
        "error: environment variable PM_DESIGN_KERNELS must be one of numba, numpy; got 'fortran'"
    )
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
    np.testing.assert_allclose(
        fast[~good & np.isfinite(reference)], reference[~good & np.isfinite(reference)], atol=1e-12
    )


FUSED = [
    ("rpr2", {}),
    ("rpr3", {}),
    ("delta", {}),
    ("delta", {"passive_limit": 20.0}),
    ("tricept", {}),
    ("tricept", {"cone_reference": "home", "tilt_limit": 25.0}),
    ("tricept", {"cone_joints": "platform"}),
    ("tricept", {"cone_joints": "none", "offset_side": -1}),
]


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


@pytest.mark.parametrize("n", [3, 4])
def test_blocked_batch_equals_one_matrix_at_a_time(n):
    """The 3 x 3 / 4 x 4 batch runs its Laguerre passes over blocks of matrices (finite ones
    gathered, the others set aside): each value must be the one of that matrix alone."""
    jac = random_matrices(n, 2 * kernels.BLOCK + 37, seed=10 + n)
    jac[::7, 1, 0] = np.nan
    jac[3::11, 0, 1] = np.inf
    jac[5] = 0.0
    jac[9] = 1e200  # finite entries whose squares overflow
    scale = np.linspace(1.0, 0.5, n)
    batch = kernels.inverse_condition_batch(jac, scale)
    alone = np.array([kernels.inverse_condition_batch(jac[k : k + 1], scale)[0] for k in range(len(jac))])
    np.testing.assert_array_equal(batch, alone)


PERIODIC = [
    ("h4", {}),
    ("h4", {"ball_joint_limit": 65.0}),
    ("tricept", {}),
    ("tricept", {"cone_reference": "home", "tilt_limit": 25.0}),
    ("rpr3", {}),
]


@pytest.mark.parametrize("name, extra", PERIODIC, ids=[f"{n}-{'-'.join(e) or 'default'}" for n, e in PERIODIC])
def test_grid_kernels_equal_one_pose_at_a_time(name, extra):
    """The compiled kernels reuse the trigonometry of the pose one grid period back when its
    angles are the same numbers: on a grid, on the same poses shuffled, and one pose at a time,
    every value must be identical."""
    mech = get_mechanism(name, **{**PAPER_DESIGNS[name], **extra})
    orientation = mech.default_orientation
    exact = 2 if name == "h4" else None
    axes, _ = _grid_axes(mech, 12, orientation, {}, exact_axis=exact)
    grid = _grid_poses(axes, 0, int(np.prod([len(a) for a in axes])))
    order = np.random.default_rng(0).permutation(len(grid))
    if name == "h4":
        lo, hi = mech.pose_bounds(orientation)

        def run(poses):
            return np.column_stack(mech.exact_axis_columns(poses, lo[2], hi[2]))
    else:

        def run(poses):
            return mech.reachable_inverse_condition(poses)

    on_grid = run(grid)
    assert np.isfinite(on_grid).any() and np.isnan(on_grid).any()
    np.testing.assert_array_equal(run(grid[order]), on_grid[order])
    np.testing.assert_array_equal(np.concatenate([run(grid[k : k + 1]) for k in range(len(grid))]), on_grid)


def test_cone_test_without_arc_cosine_is_the_arc_cosine_test():
    """Tricept's joint-cone test compares cosines away from the boundary: within a few ulps of it,
    and at random, the answer is that of ``arccos(clip(cosine)) <= cone``."""
    import math

    from kinematics.tricept import _cone_cosine, _within_cone

    rng = np.random.default_rng(0)
    for cone in (1e-3, 0.3, math.radians(60.0), 1.5, math.pi / 2, 3.0, math.pi, math.inf):
        edge = math.cos(cone) if cone < math.pi else -1.0
        near = edge + np.concatenate(
            [np.arange(-40, 41) * np.spacing(max(abs(edge), 1e-300)), [-1.1e-12, -0.9e-12, 0.9e-12, 1.1e-12]]
        )
        for cosine in np.concatenate([near, rng.uniform(-1.0000001, 1.0000001, 2000)]):
            expected = math.acos(min(max(cosine, -1.0), 1.0)) <= cone
            assert _within_cone(float(cosine), cone, _cone_cosine(cone)) == expected, (cone, cosine)


_CACHE_PROBE = """
import importlib, pkgutil
import numba
import numpy as np
import kinematics
from kinematics import MECHANISMS
from kinematics.workspace import evaluate

for name, cls in sorted(MECHANISMS.builtins.items()):
    lo = np.array([v.lower for v in cls.design_variables])
    hi = np.array([v.upper for v in cls.design_variables])
    evaluate(cls.from_design(0.5 * (lo + hi), **cls.default_fixed), resolution=cls.min_resolution)
loaded, compiled = 0, []
for info in pkgutil.iter_modules(kinematics.__path__):
    module = importlib.import_module(f"kinematics.{info.name}")
    for obj in vars(module).values():
        if isinstance(obj, numba.core.dispatcher.Dispatcher) and obj.__module__ == module.__name__:
            hits = sum(obj.stats.cache_hits.values())
            loaded += hits
            if len(obj.overloads) > hits:  # compiled here, not read from the cache
                compiled.append(f"{module.__name__}.{obj.__name__}")
print(loaded, " ".join(compiled) or "-")
"""


@pytest.mark.slow
def test_a_second_process_loads_every_kernel_from_the_disk_cache():
    """Each built-in's evaluation in a fresh process compiles nothing once a first process has
    (a kernel whose compiled code holds a run-time address, e.g. of a function passed as an
    argument, is never cached: every process would pay its compilation again)."""
    for _ in range(2):  # the first may compile (a cold cache), the second must not
        out = subprocess.run([sys.executable, "-c", _CACHE_PROBE], capture_output=True, text=True, check=True)
    loaded, compiled = out.stdout.split(maxsplit=1)
    assert int(loaded) >= 10 and compiled.strip() == "-", out.stdout + out.stderr
