"""Models you can defend: every design variable acts, and the papers' open choices are named readings."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import MECHANISMS, get_mechanism
from kinematics.h4 import BASE_READINGS
from kinematics.workspace import evaluate


def _evaluate_design(cls, design: np.ndarray, **fixed) -> tuple[float, float, float]:
    mech = cls.from_design(design, **{**cls.default_fixed, **fixed})
    ev = evaluate(mech, error_estimate=False)
    return ev.volume, ev.gdi, ev.mixed(0.5)


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_no_design_variable_is_inert(name):
    """Each variable moved across its box (others at the centre) changes V, GDI or eta by > 1 %."""
    cls = MECHANISMS[name]
    lower = np.array([v.lower for v in cls.design_variables])
    upper = np.array([v.upper for v in cls.design_variables])
    centre = 0.5 * (lower + upper)
    for j, var in enumerate(cls.design_variables):
        values = []
        for fraction in (0.1, 0.5, 0.9):
            design = centre.copy()
            design[j] = lower[j] + fraction * (upper[j] - lower[j])
            values.append(_evaluate_design(cls, design))
        values = np.array(values)  # (3 positions, (V, GDI, eta))
        change = np.max(np.abs(values - values[1]), axis=0) / np.maximum(np.abs(values[1]), 1e-12)
        assert change.max() > 0.01, f"{name}: {var.name} changes V, GDI, eta by {change} only"


def test_h4_tracking_base_makes_d_inert_which_is_why_it_is_not_the_default():
    """The first version's reading: Q_i cancels from A_iB_i, so V and GDI ignore d."""
    results = {
        d: evaluate(get_mechanism("h4", d=d, h=5.0, Qz=40.0, base="tracking"), error_estimate=False)
        for d in (1.0, 5.0, 15.0)
    }
    assert len({round(r.volume, 6) for r in results.values()}) == 1
    assert len({round(r.gdi, 9) for r in results.values()}) == 1
    scaled = [evaluate(get_mechanism("h4", d=d, h=5.0, Qz=40.0), error_estimate=False).volume for d in (1.0, 15.0)]
    assert abs(scaled[1] / scaled[0] - 1) > 0.1


@pytest.mark.parametrize("base", BASE_READINGS)
def test_h4_readings_agree_with_each_other_at_the_eq25_design(base):
    ref = evaluate(get_mechanism("h4", d=6.0, h=6.0, Qz=42.0), error_estimate=False)
    ev = evaluate(get_mechanism("h4", d=6.0, h=6.0, Qz=42.0, base=base), error_estimate=False)
    assert ev.volume == pytest.approx(ref.volume, rel=1e-12) and ev.gdi == pytest.approx(ref.gdi, rel=1e-12)


def test_h4_ball_joint_limit_and_homogenising_readings_act():
    base = evaluate(get_mechanism("h4", d=6.0, h=6.0, Qz=42.0), error_estimate=False)
    limited = evaluate(get_mechanism("h4", d=6.0, h=6.0, Qz=42.0, ball_joint_limit=70.0), error_estimate=False)
    assert 0 < limited.volume < base.volume
    gdis = {
        h: evaluate(get_mechanism("h4", d=6.0, h=6.0, Qz=42.0, homogenising=h), error_estimate=False).gdi
        for h in ("h", "rod", "none")
    }
    values = sorted(gdis.values())
    assert values[0] > 0 and all(b / a > 1.1 for a, b in zip(values, values[1:]))  # each reading acts
    prism = get_mechanism("h4", d=6.0, h=6.0, Qz=42.0, v_star="prism")
    theta = get_mechanism("h4", d=6.0, h=6.0, Qz=42.0)
    orientation = (-np.pi / 4, np.pi / 4)
    assert theta.reference_volume(orientation) == pytest.approx(prism.reference_volume(orientation) * np.pi / 2)


def test_tricept_readings_act_and_keep_the_kinematics():
    designs = dict(a=200.0, b=300.062, d=20.0)
    default = evaluate(get_mechanism("tricept", **designs), error_estimate=False)
    for reading in ({"cone_reference": "home"}, {"cone_joints": "none"}, {"offset_side": -1}, {"tilt_limit": 30.0}):
        ev = evaluate(get_mechanism("tricept", **designs, **reading), error_estimate=False)
        assert abs(ev.volume / default.volume - 1) > 0.05, reading
    below = get_mechanism("tricept", a=250.0, b=400.0, d=100.0, offset_side=-1)
    pose = np.array([[600.0, 0.2, -0.1]])
    sols = below.forward(below.inverse(pose)[0])
    assert np.min(np.abs(sols - pose).max(axis=1)) < 1e-8  # IK∘FK round trip under the reading
    with pytest.raises(ValueError, match="offset_side"):
        get_mechanism("tricept", **designs, offset_side=0)


@pytest.mark.parametrize("name", sorted(MECHANISMS.builtins))
def test_documented_fixed_defaults_apply_when_omitted(name):
    """The library API fills every omitted fixed parameter with its documented default (the
    Gough-Stewart's ``r_base=400`` raised a TypeError): ``from_design`` of the design variables
    alone, and ``get_mechanism`` of the constructor's other parameters, build the same mechanism
    as with the defaults given explicitly; a value given still wins."""
    from tests.conftest import POSE_BOXES, random_poses

    cls = MECHANISMS[name]
    centre = [0.5 * (v.lower + v.upper) for v in cls.design_variables]
    explicit = cls.from_design(centre, **cls.default_fixed)
    poses = random_poses(name, 50, seed=3)
    assert len(POSE_BOXES[name][0]) == cls.dof
    for built in (
        cls.from_design(centre),
        get_mechanism(name, **{k: v for k, v in explicit.params().items() if k not in cls.default_fixed}),
    ):
        assert repr(built) == repr(explicit)
        np.testing.assert_array_equal(built.inverse(poses), explicit.inverse(poses))
    # a value the caller gives is kept (the last non-zero numeric fixed parameter, moved by 5 %:
    # the first ones are lower limits whose upper partner a move to mid-range would pass)
    numeric = [p for p in cls.fixed_parameters if not p.choices and isinstance(p.default, float) and p.default]
    numeric = numeric[-1]
    other = 1.05 * numeric.default
    assert numeric.accepts(other)
    assert cls.from_design(centre, **{numeric.name: other}).params() != explicit.params()
    assert (
        cls.from_design(centre, **{numeric.name: other}).params()
        == cls.from_design(centre, **{**cls.default_fixed, numeric.name: other}).params()
    )


def test_gough_stewart_library_api_takes_r_base_400_by_default():
    """The user's calls: no TypeError, r_base is the documented 400 mm."""
    by_name = get_mechanism("gough_stewart", r_platform=250, sep_base=30, sep_platform=30, height=700)
    by_design = MECHANISMS["gough_stewart"].from_design([250, 30, 30, 700])
    assert by_name.params()["r_base"] == by_design.params()["r_base"] == 400.0
    assert by_name.params() == by_design.params()
