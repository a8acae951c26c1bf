"""The conformance harness (kinematics.testing): every built-in passes; each defect gets its line."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import MECHANISMS
from kinematics.base import DesignVariable
from kinematics.rpr2 import RPR2
from kinematics.rpr3 import RPR3
from kinematics.testing import assert_conforms, check_mechanism


@pytest.mark.parametrize("name", sorted(MECHANISMS.builtins))
def test_every_builtin_mechanism_conforms(name):
    assert check_mechanism(MECHANISMS.builtins[name]) == []


# ------------------------------------------------ deliberately broken mechanisms
# Each is the 2-RPR with one defect; the harness must name exactly that defect.
class WrongJacobianSign(RPR2):
    name = "broken_jacobian_sign"

    def _jacobian(self, poses):
        jac = super()._jacobian(poses)
        jac[:, :, 1] *= -1.0  # d q / d y with the wrong sign: 1/kappa is blind to it, FD is not
        return jac


class InertDesignVariable(RPR2):
    name = "broken_inert_variable"

    @classmethod
    def from_design(cls, design, **fixed):
        _, q_min = (float(v) for v in np.ravel(design))
        return cls(b=5.0, q_min=q_min, q_max=float(fixed.get("q_max", 9.6)))  # ignores the design's b


class FlatJacobian(RPR2):
    name = "broken_jacobian_shape"

    def _jacobian(self, poses):
        return super()._jacobian(poses).reshape(len(poses), 4)


def test_wrong_jacobian_sign_is_the_one_failure():
    failures = check_mechanism(WrongJacobianSign)
    assert len(failures) == 1, failures
    assert failures[0].startswith("jacobian: J differs from central differences of inverse() at 8 of 8 poses")
    assert "entry d0/dy" in failures[0] or "entry d1/dy" in failures[0]


def test_inert_design_variable_is_the_one_failure():
    failures = check_mechanism(InertDesignVariable)
    assert len(failures) == 1, failures
    assert failures[0].startswith("design-variables: 'b' moved to 25 % and 75 % of [1, 10] mm")
    assert failures[0].endswith("it does nothing")


def test_wrong_output_shape_is_the_one_failure():
    assert check_mechanism(FlatJacobian) == ["shapes: jacobian of 512 poses has shape (512, 4); expected (512, 2, 2)"]


def test_assert_conforms_lists_every_failure():
    with pytest.raises(AssertionError, match=r"WrongJacobianSign fails 1 conformance check\(s\):\njacobian: "):
        assert_conforms(WrongJacobianSign)
    assert_conforms(RPR2)


class NoUnit(RPR2):
    name = "broken_no_unit"
    design_variables = (DesignVariable("b", 1.0, 10.0, ""), DesignVariable("q_min", 3.0, 9.0, "mm"))


class EmptyBox(RPR2):
    name = "broken_box"
    design_variables = (DesignVariable("b", 1.0, 10.0, "mm"), DesignVariable("q_min", 9.0, 3.0, "mm"))


class BadName(RPR2):
    name = "two words"


@pytest.mark.parametrize(
    "cls, line",
    [
        (NoUnit, "attributes: design variable 'b' declares no unit"),
        (EmptyBox, "attributes: design variable 'q_min' needs finite lower < upper; got [9.0, 3.0]"),
        (BadName, "attributes: name must be an identifier string (the registry name); got 'two words'"),
    ],
)
def test_attribute_defects(cls, line):
    assert check_mechanism(cls) == [line]


class OneBranchForward(RPR2):
    name = "broken_forward"

    def _forward(self, q):
        return super()._forward(q)[-1:]  # drops the y > 0 branch


class SmallPoseBox(RPR2):
    name = "broken_pose_bounds"

    def pose_bounds(self, orientation):
        lo, hi = super().pose_bounds(orientation)
        return lo, np.array([hi[0], 0.5 * hi[1]])  # cuts off the top of the workspace


class BatchDependent(RPR2):
    name = "broken_batch"

    def _inverse(self, poses):
        return super()._inverse(poses) + 1e-3 * (len(poses) > 1)


class StaleCompiledKernel(RPR2):
    name = "broken_compiled"

    def _compiled_reachable_jacobian(self, poses, column_scale):
        # the compiled path forgot that q_max is a design parameter
        from kinematics.rpr2 import _rpr2_reachable_jacobians

        return _rpr2_reachable_jacobians(poses, self.b, self.q_min, 9.0, column_scale)


class MarginMissesALimit(RPR2):
    name = "broken_margins"

    def constraint_margins(self, poses):
        return super().constraint_margins(poses)[:, :2]  # q - q_min only: forgets q_max


class NotBuildableAtBound(RPR2):
    name = "broken_bound"

    def __init__(self, b, q_min, q_max):
        if b > 9.5:
            raise ValueError(f"b = {b} mm is too long")
        super().__init__(b, q_min, q_max)


@pytest.mark.parametrize(
    "cls, prefix",
    [
        (OneBranchForward, "ik-fk: forward(inverse(x)) does not contain x at "),
        (SmallPoseBox, "pose-bounds: "),
        (BatchDependent, "batch: inverse of pose 0 alone differs from row 0"),
        (StaleCompiledKernel, "workspace: the compiled path gives (V, GDI, SURI)"),
        (MarginMissesALimit, "margins: "),
        (
            NotBuildableAtBound,
            "build: design with 'b' at its upper bound 10 (others at the centre) does not build: "
            "ValueError: b = 10.0 mm is too long",
        ),
    ],
)
def test_each_check_catches_its_defect(cls, prefix):
    failures = check_mechanism(cls)
    assert any(line.startswith(prefix) for line in failures), failures
    assert all("\n" not in line for line in failures)


class CrashingForward(RPR2):
    name = "broken_crash"

    def _forward(self, q):
        raise ZeroDivisionError("oops")


def test_a_crash_is_a_line_not_a_traceback():
    assert check_mechanism(CrashingForward) == ["shapes: raised ZeroDivisionError: oops"]


def test_a_design_that_does_not_pickle():
    class Local(RPR2):  # defined in a function: pickle cannot find the class by name
        name = "broken_local"

    assert check_mechanism(Local) == [
        "build: the design does not pickle (worker processes need it): AttributeError: Can't pickle local "
        "object 'test_a_design_that_does_not_pickle.<locals>.Local'"
    ]


def test_not_a_mechanism():
    assert check_mechanism(dict) == ["attributes: <class 'dict'> is not a subclass of kinematics.base.Mechanism"]
    with pytest.raises(ValueError, match="n_poses must be an integer >= 1"):
        check_mechanism(RPR2, n_poses=0)


class NarrowExtent(RPR3):
    name = "broken_extent"

    def transverse_extent(self, angles):
        lower, upper = super().transverse_extent(angles)
        return lower, lower + 0.5 * (upper - lower)  # the upper half of each layer cut off


def test_an_extent_that_leaves_out_reachable_poses_is_a_failure():
    """The sections' rows span the stated extent: one that is too narrow loses workspace, and the
    harness names the extent first (the workspace check then sees the volume it lost)."""
    failures = check_mechanism(NarrowExtent)
    assert failures[0].startswith("transverse-extent: ") and "reachable poses lie outside" in failures[0]
    assert failures[1].startswith("workspace: the exact sections give")
    assert " y outside [" in failures[0]


class ExtentWithoutSections(RPR3):
    name = "extent_without_sections"
    section_axis = None  # the grid integrates it; a stated extent has no rows to span


def test_an_extent_without_exact_sections_is_a_failure():
    """A transverse extent is the span of the sections' rows: stated by a mechanism without exact
    sections, the harness says so (the layout check of ``kinematics.workspace.section_axes``)."""
    failures = check_mechanism(ExtentWithoutSections, n_poses=50)
    extent = [f for f in failures if f.startswith("transverse-extent: ")]
    assert extent == [
        "transverse-extent: stated, but extent_without_sections: exact sections need a section axis, one "
        "linear transverse axis and at most one angle (section_axis None, angular (False, False, True))"
    ]


class FixedByHand(RPR3):
    name = "fixed_by_hand"


# assigned after the class statement (in its body, fixed_parameters would derive default_fixed):
# default_fixed as a plug-in might set it by hand, its ranges declared nowhere
FixedByHand.fixed_parameters = ()


def test_a_fixed_parameter_without_its_range_is_a_failure(tmp_path):
    """A class that sets ``default_fixed`` by hand passes every kinematic check, but the pipeline
    refuses it (it takes each fixed parameter's default and range from ``fixed_parameters``): the
    harness says so first, and the pipeline's refusal (``mechanism=path``, as a user loads a class
    of their own) names the class's omission, not an override the user never made."""
    from pipeline.errors import ConfigError
    from tests.test_mechanism_path import _validated

    failures = check_mechanism(FixedByHand, n_poses=50)
    assert failures and failures[0].startswith("attributes: default_fixed [") and "FixedParameter" in failures[0]
    with pytest.raises(ConfigError) as info:
        _validated(["mechanism=path", "mechanism.name=tests.test_conformance:FixedByHand"], tmp_path)
    assert "FixedByHand.default_fixed has 'rho_min' but fixed_parameters declares no" in str(info.value)
    assert "mechanism.fixed." not in str(info.value)
