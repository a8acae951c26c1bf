"""Planar 2-RPR (RPRPR) parallel mechanism (seed 004: Abdullah, Yaacob, Basah 2014).

Frame and units
---------------
Base frame with origin at the first base joint O_1 = (0, 0) and x axis through
the second, O_2 = (b, 0). Lengths in mm. Pose ``(x, y)``: the end-effector point
P where both legs meet. Actuators: leg lengths ``q_1, q_2`` in ``q_min..q_max``
(paper: 6-9.6 mm, b = 5 mm).
"""

from __future__ import annotations

import math

import numpy as np

from kinematics import kernels
from kinematics.annuli import annuli_x_sections, two_annuli_area
from kinematics.base import DesignVariable, FixedParameter, Mechanism, check_positive, check_range


class RPR2(Mechanism):
    """Planar 2-RPR with actuated prismatic legs (seed 004).

    Parameters
    ----------
    b : float
        Distance between the two base joints (mm), > 0.
    q_min, q_max : float
        Leg length range (mm), ``0 < q_min < q_max``.
    """

    name = "rpr2"
    dof = 2
    pose_names = ("x", "y")
    angular = (False, False)
    length_unit = "mm"

    def __init__(self, b: float, q_min: float, q_max: float) -> None:
        owner = "RPR2"
        self.b = check_positive(owner, "b", b)
        self.q_min, self.q_max = check_range(owner, "q_min", q_min, "q_max", q_max)
        self._params = {"b": self.b, "q_min": self.q_min, "q_max": self.q_max}
        #: base joints O_1, O_2 (mm), shape (2, 2)
        self.base = np.array([[0.0, 0.0], [self.b, 0.0]])

    fixed_parameters = (FixedParameter("q_max", 9.6, 1.0, 1000.0, "mm"),)
    default_nodes = 400**2
    min_resolution = 64

    design_variables = (
        DesignVariable("b", 1.0, 10.0, "mm"),
        DesignVariable("q_min", 3.0, 9.0, "mm"),
    )

    @classmethod
    def from_design(cls, design: np.ndarray, **fixed: object) -> RPR2:
        """``(b, q_min)`` with ``q_max`` fixed (default 9.6 mm, the paper's)."""
        fixed = dict(fixed)
        b, q_min = (float(v) for v in np.ravel(design))
        return cls(b=b, q_min=q_min, q_max=float(fixed.pop("q_max", 9.6)), **fixed)

    @property
    def default_orientation(self) -> tuple[float, float]:
        """No angular pose variable; (0, 0) is a placeholder."""
        return (0.0, 0.0)

    def pose_bounds(self, orientation: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Box of the workspace: P within ``q_max`` of both base joints (mm)."""
        return (np.array([self.b - self.q_max, -self.q_max]), np.array([self.q_max, self.q_max]))

    def reference_volume(self, orientation: tuple[float, float]) -> float:
        """``V* = pi (q_max^2 - q_min^2)`` (mm^2): one leg's annulus, so ``V/V* <= 1``."""
        return math.pi * (self.q_max**2 - self.q_min**2)

    def exact_area(self) -> float:
        """Exact workspace area (mm^2), no dexterity limit: two annuli ``q_min..q_max``
        around O_1 and O_2, by the closed-form lens areas (:func:`~kinematics.annuli.two_annuli_area`)."""
        return two_annuli_area(self.b, self.q_min, self.q_max)

    #: the pose variable integrated in closed form by :meth:`exact_sections` (x)
    section_axis = 0

    def exact_sections(
        self, poses: np.ndarray, origin: float, step: float, min_inverse_condition: float, length: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """Workspace sections along x at given y, exact in their ends.

        At fixed y leg i gives ``q_min^2 <= (x - O_ix)^2 + y^2 <= q_max^2`` (eq. 1-2): the
        intersection of two annuli around O_1, O_2, at most three intervals of x, in closed form
        (:func:`~kinematics.annuli.annuli_x_sections`, which also integrates ``1/kappa`` of the
        Jacobian of eq. 1-2 along them, signed: ``sign(det J) / kappa``).

        Returns what :meth:`~kinematics.base.Mechanism.exact_sections` states (lengths in mm).

        Parameters
        ----------
        poses : ndarray, shape (N, 2)
            Rows ``(x, y)`` (mm); the x column is ignored.
        origin, step : float
            Sample nodes of ``1/kappa`` along x (mm), ``step > 0``.
        min_inverse_condition : float
            Dexterity limit on ``1/kappa`` (0: none).
        length : float, optional
            Unused: the 2-RPR's Jacobian has no angular column.
        """
        poses = self._check_poses(poses)
        if not step > 0:
            raise ValueError(f"RPR2.exact_sections: step must be > 0 (mm); got {step!r}")
        zeros = np.zeros((len(poses), 2))  # no angular column: the legs' arms do not enter
        return annuli_x_sections(
            np.ascontiguousarray(poses[:, 1]),
            np.ascontiguousarray(np.broadcast_to(self.base[:, 0], zeros.shape)),
            np.ascontiguousarray(np.broadcast_to(self.base[:, 1], zeros.shape)),
            zeros,
            zeros,
            self.q_min,
            self.q_max,
            0.0,
            float(origin),
            float(step),
            float(min_inverse_condition),
        )

    def exact_volume(self, orientation: tuple[float, float]) -> float:
        """:meth:`exact_area` (mm^2): the 2-RPR has no orientation."""
        return self.exact_area()

    @property
    def characteristic_length(self) -> float:
        """``b`` (mm); unused: the 2-RPR has no angular pose variable."""
        return self.b

    @property
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """``q_min <= q_i <= q_max`` (mm)."""
        return np.full(2, self.q_min), np.full(2, self.q_max)

    def constraint_margins(self, poses: np.ndarray) -> np.ndarray:
        """``q_i - q_min`` and ``q_max - q_i`` (N, 4), mm (eq. 1-2): the only reachability
        constraints (every pose has real leg lengths)."""
        return self._actuator_margins(self._check_poses(poses))

    # ------------------------------------------------------------- kernels
    def _inverse(self, poses: np.ndarray) -> np.ndarray:
        """Algebraic model, eq. 1-2: ``q_1 = sqrt(x^2 + y^2)``, ``q_2 = sqrt((b - x)^2 + y^2)``."""
        x, y = poses[:, 0], poses[:, 1]
        return np.column_stack([np.sqrt(x**2 + y**2), np.sqrt((self.b - x) ** 2 + y**2)])

    def inverse_dh(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """DH-derived model, eq. 5-11: leg lengths and passive base-joint angles.

        Each leg is ``T^1 = Trans(O_i) Rot_z(theta_i) T_prismatic(q_i)`` (eq. 7), whose
        position column is ``O_i + q_i (-sin theta_i, cos theta_i)`` (eq. 9). The
        passive angle follows from eq. 11, ``theta_i = atan2(-(x - O_ix), y - O_iy)``,
        and the leg length is the projection of ``P - O_i`` on the leg axis of
        eq. 9 (equal to eq. 10's square root).

        Parameters
        ----------
        poses : array_like, shape (N, 2)

        Returns
        -------
        q : ndarray, shape (N, 2)
            Leg lengths (mm).
        theta : ndarray, shape (N, 2)
            Passive base-joint angles (rad), measured as in eq. 11.
        """
        poses = self._check_poses(poses)
        rel = poses[:, None, :] - self.base  # (N, 2, 2): P - O_i
        theta = np.arctan2(-rel[..., 0], rel[..., 1])
        q = -rel[..., 0] * np.sin(theta) + rel[..., 1] * np.cos(theta)
        return q, theta

    def _jacobian(self, poses: np.ndarray) -> np.ndarray:
        """Rows ``(P - O_i)^T / q_i``: the derivative of eq. 1-2."""
        rel = poses[:, None, :] - self.base
        q = np.linalg.norm(rel, axis=-1)
        jac = rel / q[..., None]
        jac[q == 0] = np.inf
        return jac

    def _compiled_reachable_jacobian(self, poses: np.ndarray, column_scale: np.ndarray) -> np.ndarray:
        """Eq. 1-2 and their Jacobian, compiled, NaN rows outside ``q_min..q_max``
        (see :func:`_rpr2_reachable_jacobians`)."""
        return _rpr2_reachable_jacobians(poses, self.b, self.q_min, self.q_max, column_scale)

    def _forward(self, q: np.ndarray) -> np.ndarray:
        """Closed form eq. 3-4, both branches ``y = +-sqrt(q_1^2 - x^2)``."""
        x = (q[0] ** 2 + self.b**2 - q[1] ** 2) / (2.0 * self.b)
        y2 = q[0] ** 2 - x**2
        if y2 < 0:
            return np.empty((0, 2))
        y = np.sqrt(y2)
        if y == 0:
            return np.array([[x, 0.0]])
        return np.array([[x, y], [x, -y]])


@kernels.jit
def _rpr2_reachable_jacobians(poses, b, q_min, q_max, column_scale):
    """Per pose (N, 2) of (x, y) (mm): leg lengths of eq. 1-2, the range test
    ``q_min <= q_i <= q_max`` and the Jacobian rows ``(P - O_i)^T / q_i``
    (as :meth:`RPR2._jacobian`) times ``column_scale``. Returns (N, 2, 2); rows
    of NaN where a leg is out of range (``q_min > 0``, so no division by zero)."""
    count = poses.shape[0]
    out = np.empty((count, 2, 2))
    for p in range(count):
        x, y = poses[p, 0], poses[p, 1]
        q1 = math.sqrt(x * x + y * y)
        q2 = math.sqrt((b - x) * (b - x) + y * y)
        if not (q_min <= q1 <= q_max and q_min <= q2 <= q_max):
            out[p, :, :] = np.nan
            continue
        out[p, 0, 0] = x / q1 * column_scale[0]
        out[p, 0, 1] = y / q1 * column_scale[1]
        out[p, 1, 0] = (x - b) / q2 * column_scale[0]
        out[p, 1, 1] = y / q2 * column_scale[1]
    return out
