"""H4 4-DOF parallel manipulator (seed 000: Falahian, Daniali, Varedi 2012).

Frame and units
---------------
Base frame {A}: z vertical, the four actuators slide along z. Lengths in cm,
angles in rad. Pose ``(x, y, z, theta)``: position of the end-effector point B
(centre of the travelling plate) and its rotation about z.

Geometry (seed 000 eq. 13-16, generalised from the example eq. 25)
-------------------------------------------------------------------
* Platform ball joints: ``B_i = (P_i cos(theta) + x, P_i sin(theta) + y + Q_i, z)``
  with ``P = h * (-1, -1, 1, 1)`` and ``Q = d * (-1, 1, 1, -1)`` (eq. 13-14).
  ``C_1 = B + Rot(theta) (-h, 0, 0)`` carries B_1, B_2; ``C_2 = B + Rot(theta) (h, 0, 0)``
  carries B_3, B_4; the links C_i B_i = (0, Q_i, 0) only translate (eq. 29).
* Actuator carriages: ``A_i = (a_i, b_i, q_i)``. The paper gives base points and
  rod lengths only for its example (eq. 25): for h = d = 6, Qz = 42,
  ``A = (-48, -48), (-48, 48), (6, 48), (48, -6)`` and rods
  ``M = Qz * (sqrt 3, sqrt 3, sqrt 2, sqrt 2)``. How they follow a design is
  not stated; it is the reading ``base`` (every option reproduces eq. 25-27
  exactly at h = d = 6, Qz = 42):

  - ``"scaled"`` (default): eq. 25's base scaled with Qz,
    ``(a_i, b_i) = (Qz / 42) * A_i(eq. 25)``, rods ``M = Qz * (sqrt 3, sqrt 3,
    sqrt 2, sqrt 2)``. The base is a machine frame sized by Qz; the travelling
    plate (d, h) is designed inside it. d, h and Qz all change V and GDI.
  - ``"tracking"``: the base follows the plate, ``(a_i, b_i) = (P_i, Q_i) +
    Qz * o_i`` with ``o = (-1, -1), (-1, 1), (0, 1), (1, 0)``, so every rod
    drops exactly Qz at the home pose. Then Q_i (which carries d) cancels from
    ``A_iB_i``: **d has no effect on V or GDI** (it moves only V*). Kept to
    show why the first version's d was inert.
  - ``"fixed"``: eq. 25's base points and rods whatever the design; Qz only
    names the home height, so it has no effect on V or GDI.

  Why "scaled" is the default: it is the only reading of the three in which
  the paper's three design variables all act (the paper optimises all three
  and reports different values for each), and it keeps eq. 25's layout, whose
  proportions the paper gives, at every size.
* Ball-joint limit ``ball_joint_limit`` (deg, optional): the largest angle
  between a rod and the vertical; ``None`` (the paper states none) disables it.
* Homogenising length ``homogenising`` (Sec. 4.2 says only "the length of the
  first link"): ``"h"`` (default: |BC_i|, the lever arm of θ, so 1/κ does not
  depend on the plate's scale), ``"d"``, ``"rod"`` (M_1 = sqrt(3) Qz) or
  ``"none"`` (1 cm: the angular column left as printed in eq. 33). A number
  can still be given as the pipeline's ``mechanism.length``.
* Robot size ``v_star`` (Sec. 4.3: "the base area times the reach"):
  ``"prism_theta"`` (default: base area x z reach x θ range, so SURI is
  dimensionless for a 4-D volume in cm³·rad) or ``"prism"`` (base area x z
  reach, cm³, as printed; SURI then carries rad).
* Actuator range ``0 <= q_i <= stroke`` (Delta q, default 100 cm, see
  :attr:`H4.actuator_range`).
"""

from __future__ import annotations

import math

import numpy as np

from kinematics import kernels
from kinematics.algebra import real_tan_half_angles, trig_polynomial_in_tan_half
from kinematics.base import (
    DesignVariable,
    FixedParameter,
    Mechanism,
    check_positive,
    cosine_range,
    orientation_measure,
)
from kinematics.rows import row_all, row_max, row_min

_SIGN_P = np.array([-1.0, -1.0, 1.0, 1.0])
_SIGN_Q = np.array([-1.0, 1.0, 1.0, -1.0])
_OFFSETS = np.array([[-1.0, -1.0], [-1.0, 1.0], [0.0, 1.0], [1.0, 0.0]])
_FOLLOWING = np.array([1, 2, 3, 0])
_ROD_FACTOR = np.array([np.sqrt(3.0), np.sqrt(3.0), np.sqrt(2.0), np.sqrt(2.0)])
#: eq. 25's base points (cm) at Qz = 42 cm
_EQ25_BASE = np.array([[-48.0, -48.0], [-48.0, 48.0], [6.0, 48.0], [48.0, -6.0]])
_EQ25_QZ = 42.0
#: readings of how the base points and rods follow (d, h, Qz); see the module docstring
BASE_READINGS = ("scaled", "tracking", "fixed")
HOMOGENISING_READINGS = ("h", "d", "rod", "none")
V_STAR_READINGS = ("prism_theta", "prism")


class H4(Mechanism):
    """H4 robot with prismatic actuators along z (seed 000).

    Parameters
    ----------
    d : float
        Offset of the revolute joint from the ball joint (cm), > 0.
    h : float
        Offset of each ball joint from the centre of the travelling plate (cm), > 0.
    Qz : float
        Offset of {B} from {A} along z at the home pose; also sets the base
        points and rod lengths (cm), > 0.
    stroke : float
        Actuator motion range Delta q (cm), > 0. Default 100 cm: Table 2's
        d = 1.00008 cm at the bound d/Delta q = 0.01 implies Delta q = 100 cm.
    base : {"scaled", "tracking", "fixed"}
        How base points and rods follow the design (module docstring).
    ball_joint_limit : float, optional
        Largest rod-to-vertical angle (deg) in (0, 90); ``None``: no limit.
    homogenising : {"h", "d", "rod", "none"}
        Characteristic length of the angular Jacobian column (module docstring).
    v_star : {"prism_theta", "prism"}
        Definition of the robot size V* of SURI (module docstring).
    """

    name = "h4"
    dof = 4
    pose_names = ("x", "y", "z", "theta")
    angular = (False, False, False, True)
    length_unit = "cm"

    angle_params = ("ball_joint_limit",)
    fixed_parameters = (
        FixedParameter("stroke", 100.0, 1.0, 1000.0, "cm"),
        FixedParameter("base", "scaled", choices=BASE_READINGS),
        FixedParameter("ball_joint_limit", None, 1.0, 89.0, "deg", optional=True),
        FixedParameter("homogenising", "h", choices=HOMOGENISING_READINGS),
        FixedParameter("v_star", "prism_theta", choices=V_STAR_READINGS),
    )
    default_nodes = 24**3
    # V, GDI within 0.1 % on the designs of docs/accuracy.md, its random scan included: 30 x 30 x 15
    # over (x, y, theta). Why half the nodes along theta: the margins and 1/kappa vary slowly with
    # theta; against 28^3, as accurate (worst 0.086 % against 0.093 % on the ladder's designs,
    # 0.082 % against 0.084 % on the scan's) at 0.75x the cost, measured side by side
    grid_nodes = 30 * 30 * 15
    grid_axis_nodes = {"theta": 0.5}
    min_resolution = 12

    def __init__(
        self,
        d: float,
        h: float,
        Qz: float,
        stroke: float = 100.0,
        base: str = "scaled",
        ball_joint_limit: float | None = None,
        homogenising: str = "h",
        v_star: str = "prism_theta",
    ) -> None:
        owner = "H4"
        self.d = check_positive(owner, "d", d)
        self.h = check_positive(owner, "h", h)
        self.Qz = check_positive(owner, "Qz", Qz)
        self.stroke = check_positive(owner, "stroke", stroke)
        if base not in BASE_READINGS:
            raise ValueError(f"H4: parameter 'base' must be one of {', '.join(BASE_READINGS)}; got {base!r}")
        self.base = base
        if ball_joint_limit is not None:
            ball_joint_limit = check_positive(owner, "ball_joint_limit", ball_joint_limit)
            if ball_joint_limit >= 90.0:
                raise ValueError(
                    f"H4: parameter 'ball_joint_limit' must be in (0, 90) deg or None; got {ball_joint_limit!r}"
                )
        self.ball_joint_limit = ball_joint_limit
        for name, value, allowed in (
            ("homogenising", homogenising, HOMOGENISING_READINGS),
            ("v_star", v_star, V_STAR_READINGS),
        ):
            if value not in allowed:
                raise ValueError(f"H4: parameter '{name}' must be one of {', '.join(allowed)}; got {value!r}")
        self.homogenising = homogenising
        self.v_star = v_star
        self._params = {
            "d": self.d,
            "h": self.h,
            "Qz": self.Qz,
            "stroke": self.stroke,
            "base": self.base,
            "ball_joint_limit": self.ball_joint_limit,
            "homogenising": self.homogenising,
            "v_star": self.v_star,
        }
        self.P = self.h * _SIGN_P
        self.Q = self.d * _SIGN_Q
        if base == "tracking":
            points = np.stack([self.P, self.Q], axis=1) + self.Qz * _OFFSETS
            self.M = self.Qz * _ROD_FACTOR
        elif base == "scaled":
            points = _EQ25_BASE * (self.Qz / _EQ25_QZ)
            self.M = self.Qz * _ROD_FACTOR
        else:
            points = _EQ25_BASE.copy()
            self.M = _EQ25_QZ * _ROD_FACTOR
        self.a = points[:, 0].copy()
        self.b = points[:, 1].copy()

    design_variables = (
        DesignVariable("d_ratio", 0.01, 0.15, "d / stroke"),
        DesignVariable("h_ratio", 0.01, 0.15, "h / stroke"),
        DesignVariable("Qz_ratio", 0.35, 0.55, "Qz / stroke"),
    )

    @classmethod
    def from_design(cls, design: np.ndarray, **fixed: object) -> H4:
        """H4 of the scaled design vector ``(d, h, Qz) / stroke`` of seed 000 Sec. 4.4."""
        fixed = dict(fixed)
        stroke = float(fixed.pop("stroke", 100.0))
        d_ratio, h_ratio, qz_ratio = (float(v) for v in np.ravel(design))
        return cls(d=d_ratio * stroke, h=h_ratio * stroke, Qz=qz_ratio * stroke, stroke=stroke, **fixed)

    # ---------------------------------------------------------- properties
    @property
    def characteristic_length(self) -> float:
        """Length (cm) dividing the angular column of eq. 33 (reading ``homogenising``).

        Default ``h``: the lever arm of the rotation, |B C_i| (seed 000 Sec. 4.2).
        """
        return {"h": self.h, "d": self.d, "rod": float(self.M[0]), "none": 1.0}[self.homogenising]

    @property
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """``0 <= q_i <= stroke`` (cm)."""
        return np.zeros(4), np.full(4, self.stroke)

    @property
    def default_orientation(self) -> tuple[float, float]:
        """theta in [-pi/4, pi/4] rad: see :func:`kinematics.workspace.evaluate` notes."""
        return (-np.pi / 4, np.pi / 4)

    def pose_bounds(self, orientation: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Box of the workspace from the rods' reach (cm, rad).

        Each ball joint is within ``M_i`` of its carriage horizontally, so
        ``x + P_i cos(theta)`` is within ``a_i +- M_i`` (likewise y); the carriage
        moves in ``[0, stroke]`` and a rod drops at most ``M_i``, so
        ``-min(M) <= z <= stroke``.
        """
        lo, hi = float(orientation[0]), float(orientation[1])
        cmin, cmax = (float(v) for v in cosine_range(lo, hi))
        smin, smax = (float(v) for v in cosine_range(lo, hi, -np.pi / 2))
        # per leg on Python floats (four legs: numpy's per-call overhead would dominate)
        x_lo, x_hi, y_lo, y_hi = [], [], [], []
        for a, b, p, q, m in zip(self.a.tolist(), self.b.tolist(), self.P.tolist(), self.Q.tolist(), self.M.tolist()):
            px = (p * cmin, p * cmax)  # extremes of P_i cos(theta)
            py = (p * smin, p * smax)
            x_lo.append(a - m - max(px))
            x_hi.append(a + m - min(px))
            y_lo.append(b - q - m - max(py))
            y_hi.append(b - q + m - min(py))
        return (
            np.array([max(x_lo), max(y_lo), -float(self.M.min()), lo]),
            np.array([min(x_hi), min(y_hi), self.stroke, hi]),
        )

    def reference_volume(self, orientation: tuple[float, float]) -> float:
        """``V* = area(base) * z reach * theta range`` (cm^3 rad), seed 000 Sec. 4.3.

        Base area: the quadrilateral of the carriage axes (a_i, b_i); z reach:
        ``stroke + min(M)``, the height of :meth:`pose_bounds`. The paper's V* has
        no angular factor; multiplying by the theta range makes ``V/V*``
        dimensionless (the fraction of a prism of base x reach x rotation).
        """
        pts = np.column_stack([self.a, self.b])
        centre = pts.mean(axis=0)
        order = np.argsort(np.arctan2(*(pts - centre).T[::-1]))
        x, y = pts[order].T
        # shoelace formula; _FOLLOWING: each vertex's successor (np.roll by -1, without its overhead)
        area = 0.5 * abs(np.dot(x, y[_FOLLOWING]) - np.dot(y, x[_FOLLOWING]))
        angular = orientation_measure(orientation, 1) if self.v_star == "prism_theta" else 1.0
        return area * (self.stroke + self.M.min()) * angular

    def invariant_axis_interval(self, poses: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
        """z: ``q_i = z + s_i(x, y, theta)`` with ``s_i = sqrt(M_i^2 - dx_i^2 - dy_i^2)``
        (eq. 11) and a Jacobian independent of z (eq. 33), so the actuator range
        ``0 <= q_i <= stroke`` gives ``max_i(-s_i) <= z <= min_i(stroke - s_i)`` (cm)."""
        poses = self._check_poses(poses)
        dx, dy, _, _ = self._horizontal(poses)
        with np.errstate(invalid="ignore"):
            drop = np.sqrt(self.M**2 - dx**2 - dy**2)
        lower = -row_min(drop)
        upper = self.stroke - row_max(drop)
        reachable = row_all(np.isfinite(drop))
        return 2, np.where(reachable, lower, np.inf), np.where(reachable, upper, -np.inf)

    def _joint_reach(self) -> np.ndarray:
        """Largest horizontal reach ``M_i sin(limit)`` (cm, (4,)) of each rod within the ball-joint
        limit (:meth:`within_joint_limits`); +inf without a limit."""
        if self.ball_joint_limit is None:
            return np.full(4, np.inf)
        return self.M * np.sin(np.radians(self.ball_joint_limit))

    def _column_arguments(self, poses: np.ndarray, axis_lo: float, axis_hi: float) -> tuple:
        """The leading arguments of the column kernels (:func:`_h4_columns`, :func:`_h4_margins`):
        the poses, the cosines and sines of their theta, the geometry (cm) and the z box."""
        cos_theta, sin_theta = kernels.periodic_cos_sin(np.ascontiguousarray(poses[:, 3]))
        geometry = (self.a, self.b, self.P, self.Q, self.M, self.stroke)
        return (np.ascontiguousarray(poses), cos_theta, sin_theta, *geometry, float(axis_lo), float(axis_hi))

    def exact_axis_margins(self, poses: np.ndarray, axis_lo: float, axis_hi: float) -> np.ndarray:
        """Margins of an (x, y, theta) column (N, 28): its feasible z interval of eq. 11,
        ``max_j(-s_j) <= z <= min_i(stroke - s_i)`` clipped to ``[axis_lo, axis_hi]``
        (:meth:`invariant_axis_interval`), is non-empty exactly where every pair of its bounds
        is ordered: ``stroke - s_i + s_j`` (i != j), ``stroke - s_i - axis_lo`` and
        ``axis_hi + s_j`` (cm); then each rod's reach ``M_i^2 - dx_i^2 - dy_i^2`` (cm^2, eq. 11's
        radicand) and the ball-joint limit ``M_i sin(limit) - |(dx_i, dy_i)|`` (cm; +inf
        without a limit). Each is smooth (the interval's length, a min minus a max, is not);
        where a radicand is negative its root ``s_i`` is continued as ``-sqrt(-radicand)``, so
        the bounds stay continuous across the reach boundary."""
        poses = self._check_poses(poses)
        reach = self._joint_reach()
        if kernels.compiled():
            return _h4_margins(*self._column_arguments(poses, axis_lo, axis_hi), reach)
        dx, dy, _, _ = self._horizontal(poses)
        radicand = self.M**2 - dx**2 - dy**2
        drop = np.sign(radicand) * np.sqrt(np.abs(radicand))
        i, j = np.nonzero(~np.eye(4, dtype=bool))
        pairs = self.stroke - drop[:, i] + drop[:, j]
        joints = reach - np.hypot(dx, dy)
        return np.hstack([pairs, self.stroke - drop - axis_lo, axis_hi + drop, radicand, joints])

    def exact_axis_columns(
        self, poses: np.ndarray, axis_lo: float, axis_hi: float, length: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Compiled fused path of :meth:`invariant_axis_interval` + membership (z exact).

        Per (x, y, theta) pose, one pass: the feasible z interval of eq. 11
        clipped to ``[axis_lo, axis_hi]`` (cm), the ball-joint limit, and
        ``1/kappa`` of eq. 33's Jacobian homogenised by ``length`` (cm;
        default :attr:`characteristic_length`). Returns ``(lower, upper, ic)``,
        each (N,): ``ic`` is NaN where the interval is empty or a joint limit
        fails, as the numpy path gives. ``None`` when the compiled kernels are
        off (``PM_DESIGN_KERNELS=numpy``).
        """
        if not kernels.compiled():
            return None
        poses = self._check_poses(poses)
        lower, upper, jac, rows = _h4_columns(
            *self._column_arguments(poses, axis_lo, axis_hi), self.angular_scale(length), self._joint_reach()
        )
        ic = np.full(poses.shape[0], np.nan)
        ic[rows] = kernels.inverse_condition_batch(jac, np.ones(4))
        return lower, upper, ic

    def _compiled_jacobian(self, poses: np.ndarray, column_scale: np.ndarray) -> np.ndarray:
        """Eq. 33's Jacobian times ``diag(column_scale)``, compiled (see :func:`_h4_jacobians`)."""
        return _h4_jacobians(
            np.ascontiguousarray(poses),
            self.a,
            self.b,
            self.P,
            self.Q,
            self.M,
            np.ascontiguousarray(column_scale, dtype=float),
        )

    def within_joint_limits(self, poses: np.ndarray) -> np.ndarray:
        """Rod-to-vertical angle within ``ball_joint_limit`` (N,) bool; all True without a limit.

        The angle is ``arccos(|L_z| / M_i)`` with ``L_i = B_i - A_i``; it does not
        depend on z, so the exact z integration still holds.
        """
        poses = self._check_poses(poses)
        if self.ball_joint_limit is None:
            return np.ones(poses.shape[0], dtype=bool)
        dx, dy, _, _ = self._horizontal(poses)
        horizontal = np.hypot(dx, dy)  # |L_i| sin(angle) = horizontal reach
        return row_all(horizontal <= self._joint_reach())

    def base_points(self, q: np.ndarray) -> np.ndarray:
        """Carriage points ``A_i = (a_i, b_i, q_i)`` (eq. 13), shape (N, 4, 3), cm."""
        q = np.atleast_2d(q)
        out = np.empty(q.shape + (3,))
        out[..., 0] = self.a
        out[..., 1] = self.b
        out[..., 2] = q
        return out

    def platform_points(self, poses: np.ndarray) -> np.ndarray:
        """Ball joints ``B_i`` (eq. 13), shape (N, 4, 3), cm, base frame."""
        poses = self._check_poses(poses)
        return self._platform_points(poses)

    def _platform_points(self, poses: np.ndarray) -> np.ndarray:
        x, y, z, th = poses.T
        c, s = np.cos(th)[:, None], np.sin(th)[:, None]
        out = np.empty((poses.shape[0], 4, 3))
        out[..., 0] = self.P * c + x[:, None]
        out[..., 1] = self.P * s + y[:, None] + self.Q
        out[..., 2] = z[:, None]
        return out

    # ------------------------------------------------------------- kernels
    def _horizontal(self, poses: np.ndarray):
        """Horizontal components of A_i B_i and of B C_i, each (N, 4) (cm)."""
        x, y, _, th = poses.T
        c, s = np.cos(th)[:, None], np.sin(th)[:, None]
        bc_x = self.P * c
        bc_y = self.P * s
        dx = bc_x + x[:, None] - self.a
        dy = bc_y + y[:, None] + self.Q - self.b
        return dx, dy, bc_x, bc_y

    def _inverse(self, poses: np.ndarray) -> np.ndarray:
        """Eq. 11-12 on the branch of eq. 26: ``q_i = z + sqrt(M_i^2 - dx_i^2 - dy_i^2)``.

        (eq. 11 with ``d_i . z = z``; the '+' root puts the carriage above the
        ball joint, as in the example.) NaN where the root is imaginary.
        """
        dx, dy, _, _ = self._horizontal(poses)
        disc = self.M**2 - dx**2 - dy**2
        return poses[:, 2:3] + np.sqrt(np.where(disc >= 0, disc, np.nan))

    def _jacobian(self, poses: np.ndarray) -> np.ndarray:
        """``J = J_q^-1 J_x`` of eq. 32-34, derived from eq. 31.

        Row i: ``[L_x, L_y, L_z, (BC_i x L_i) . k] / L_z`` with ``L_i = B_i - A_i``.
        The OCR text prints ``(A_iB_i x BC_i) . k``; with ``A_iB_i = B_i - A_i``
        the velocity of B_i is ``v_B + theta_dot k x BC_i``, whose projection on
        L_i is ``theta_dot (BC_i x L_i) . k``, hence the order used here
        (verified against finite differences of :meth:`inverse`).
        """
        dx, dy, bc_x, bc_y = self._horizontal(poses)
        disc = self.M**2 - dx**2 - dy**2
        lz = -np.sqrt(np.where(disc >= 0, disc, np.nan))  # B_z - A_z <= 0
        ang = bc_x * dy - bc_y * dx
        jac = np.stack([dx, dy, lz, ang], axis=-1) / lz[..., None]
        jac[lz == 0] = np.inf  # rod horizontal: J_q singular (workspace boundary)
        return jac

    # ------------------------------------------------------ forward kinematics
    def _constraints(self, poses: np.ndarray, q: np.ndarray) -> np.ndarray:
        """``|B_i - A_i|^2 - M_i^2`` (eq. 15), shape (K, 4), cm^2."""
        dx, dy, _, _ = self._horizontal(poses)
        return dx**2 + dy**2 + (poses[:, 2:3] - q) ** 2 - self.M**2

    def _constraints_jacobian(self, poses: np.ndarray, q: np.ndarray) -> np.ndarray:
        dx, dy, bc_x, bc_y = self._horizontal(poses)
        lz = poses[:, 2:3] - q
        return 2.0 * np.stack([dx, dy, lz, bc_x * dy - bc_y * dx], axis=-1)

    def _linear_position(self, theta: np.ndarray, q: np.ndarray):
        """Cramer solution of the differences of eq. 16 for (x, y, z) at given theta.

        Returns numerators N (K, 3) and denominator D (K,) with ``(x, y, z) = N / D``.
        Rows used: chain 2 - chain 1, chain 4 - chain 3, chain 3 - chain 1.
        """
        c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
        gx = self.P * c - self.a  # (K, 4)
        gy = self.P * s + self.Q - self.b
        k = gx**2 + gy**2 + q**2 - self.M**2
        pairs = [(1, 0), (3, 2), (2, 0)]
        mat = np.stack(
            [
                np.stack(
                    [2 * (gx[:, j] - gx[:, i]), 2 * (gy[:, j] - gy[:, i]), np.full_like(theta, -2 * (q[j] - q[i]))],
                    axis=-1,
                )
                for j, i in pairs
            ],
            axis=1,
        )
        rhs = np.stack([-(k[:, j] - k[:, i]) for j, i in pairs], axis=1)
        den = np.linalg.det(mat)
        num = np.empty((theta.shape[0], 3))
        for col in range(3):
            m = mat.copy()
            m[:, :, col] = rhs
            num[:, col] = np.linalg.det(m)
        return num, den, gx, gy, k

    def forward_polynomial(self, q: np.ndarray) -> np.ndarray:
        """Coefficients of the degree-8 polynomial in ``T = tan(theta/2)`` (eq. 24).

        Eliminating (x, y, z) linearly from three differences of eq. 16 and
        substituting into eq. 16 for chain 1 gives a trigonometric polynomial
        of degree 4 in theta (eq. 22); eq. 23 turns it into eq. 24. The
        coefficients are built numerically (FFT of samples), not by symbolic
        expansion.

        Parameters
        ----------
        q : array_like, shape (4,)
            Actuator values (cm).

        Returns
        -------
        ndarray, shape (9,)
            Coefficients, highest degree first, scaled so the largest magnitude is 1.
        """
        q = self._check_actuators(q)

        def residual(theta: np.ndarray) -> np.ndarray:
            num, den, gx, gy, k = self._linear_position(theta, q)
            return (
                (num**2).sum(axis=1)
                + 2 * den * (num[:, 0] * gx[:, 0] + num[:, 1] * gy[:, 0])
                - 2 * den * num[:, 2] * q[0]
                + den**2 * k[:, 0]
            )

        poly = trig_polynomial_in_tan_half(residual, 4)
        return poly / np.max(np.abs(poly))

    def _forward(self, q: np.ndarray) -> np.ndarray:
        """All real poses for ``q``: real roots of eq. 24, then eq. 19-21, Newton-polished."""
        theta = real_tan_half_angles(self.forward_polynomial(q))
        if theta.size == 0:
            return np.empty((0, 4))
        num, den, *_ = self._linear_position(theta, q)
        return self._polish(np.column_stack([num / den[:, None], theta]), q, self.M**2)


@kernels.inline_jit
def _leg(x, y, c, s, a_i, b_i, P_i, Q_i, M_i):
    """Leg i at pose (x, y, theta) with ``c, s = cos, sin theta``: the horizontal components
    (dx, dy) of ``A_i B_i`` (cm) and ``M_i^2 - dx^2 - dy^2`` (cm^2, eq. 11's radicand),
    the same operations as ``H4._horizontal``."""
    dx = P_i * c + x - a_i
    dy = P_i * s + y + Q_i - b_i
    return dx, dy, M_i**2 - dx**2 - dy**2


@kernels.inline_jit
def _jacobian_row(jac, k, i, dx, dy, drop, P_i, c, s, column_scale):
    """Row i of eq. 33 times ``column_scale`` into ``jac[k]`` (``drop = -L_z`` >= 0, cm), the
    same operations as ``H4._jacobian``; +inf when the rod is horizontal (``L_z = 0``)."""
    lz = -drop
    if lz == 0.0:
        for j in range(4):
            jac[k, i, j] = np.inf
        return
    ang = P_i * c * dy - P_i * s * dx
    jac[k, i, 0] = dx / lz * column_scale[0]
    jac[k, i, 1] = dy / lz * column_scale[1]
    jac[k, i, 2] = lz / lz * column_scale[2]
    jac[k, i, 3] = ang / lz * column_scale[3]


@kernels.jit
def _h4_columns(poses, cos_theta, sin_theta, a, b, P, Q, M, stroke, axis_lo, axis_hi, column_scale, reach):
    """Kernel of :meth:`H4.exact_axis_columns`: eq. 11's z interval and eq. 33's Jacobian per pose
    (``cos_theta``, ``sin_theta``: of each pose's theta, :func:`kinematics.kernels.periodic_cos_sin`).

    Same operations, in the same order, as ``_horizontal``,
    ``invariant_axis_interval``, ``within_joint_limits`` and ``_jacobian``.
    Returns ``(lower, upper, jac, rows)``: ``jac`` (K, 4, 4) holds the
    homogenised Jacobians of the K poses to condition, whose indices are
    ``rows`` (K,), with +inf in a row whose rod is horizontal, the convention of
    :func:`kinematics.kernels.inverse_condition_batch` (called separately: a
    compiled function that calls into another module would not see that
    module's changes through numba's on-disk cache).
    """
    count = poses.shape[0]
    lower = np.empty(count)
    upper = np.empty(count)
    jac = np.empty((count, 4, 4))
    rows = np.empty(count, dtype=np.int64)
    k = 0
    dxs = np.empty(4)
    dys = np.empty(4)
    drops = np.empty(4)
    limited = np.isfinite(reach)
    for p in range(count):
        x, y, c, s = poses[p, 0], poses[p, 1], cos_theta[p], sin_theta[p]
        lo, hi = -np.inf, np.inf
        reachable = True
        within = True
        for i in range(4):
            dx, dy, disc = _leg(x, y, c, s, a[i], b[i], P[i], Q[i], M[i])
            if not disc >= 0.0:
                reachable = False
                break
            drop = math.sqrt(disc)
            lo = max(lo, -drop)
            hi = min(hi, stroke - drop)
            if limited[i] and not math.hypot(dx, dy) <= reach[i]:
                within = False
            dxs[i], dys[i], drops[i] = dx, dy, drop
        if not reachable:
            lower[p], upper[p] = np.inf, -np.inf
            continue
        lo, hi = max(lo, axis_lo), min(hi, axis_hi)
        lower[p], upper[p] = lo, hi
        if not (hi - lo > 0.0 and within):
            continue
        for i in range(4):
            _jacobian_row(jac, k, i, dxs[i], dys[i], drops[i], P[i], c, s, column_scale)
        rows[k] = p
        k += 1
    return lower, upper, jac[:k], rows[:k]


@kernels.jit
def _h4_jacobians(poses, a, b, P, Q, M, column_scale):
    """Eq. 33 per pose, the same operations as ``_horizontal`` and ``_jacobian``, times the column scale.

    NaN rows where a rod cannot reach (imaginary root of eq. 11), +inf in a
    row whose rod is horizontal (``L_z = 0``), as the numpy kernel.
    """
    count = poses.shape[0]
    jac = np.empty((count, 4, 4))
    for p in range(count):
        x, y, theta = poses[p, 0], poses[p, 1], poses[p, 3]
        c, s = math.cos(theta), math.sin(theta)
        for i in range(4):
            dx, dy, disc = _leg(x, y, c, s, a[i], b[i], P[i], Q[i], M[i])
            if not disc >= 0.0:
                for j in range(4):
                    jac[p, i, j] = np.nan
                continue
            _jacobian_row(jac, p, i, dx, dy, math.sqrt(disc), P[i], c, s, column_scale)
    return jac


@kernels.vector_jit
def _h4_margins(poses, cos_theta, sin_theta, a, b, P, Q, M, stroke, axis_lo, axis_hi, reach):
    """Kernel of :meth:`H4.exact_axis_margins` (the same operations, one pose at a time): per
    (x, y, theta) pose the 28 margins, (N, 28)."""
    count = poses.shape[0]
    out = np.empty((count, 28))
    drops = np.empty(4)
    for p in range(count):
        x, y, c, s = poses[p, 0], poses[p, 1], cos_theta[p], sin_theta[p]
        for i in range(4):
            dx, dy, radicand = _leg(x, y, c, s, a[i], b[i], P[i], Q[i], M[i])
            drops[i] = math.sqrt(radicand) if radicand >= 0.0 else -math.sqrt(-radicand)
            out[p, 20 + i] = radicand
            out[p, 24 + i] = reach[i] - math.hypot(dx, dy)
        k = 0
        for i in range(4):
            for j in range(4):
                if i != j:
                    out[p, k] = stroke - drops[i] + drops[j]
                    k += 1
        for i in range(4):
            out[p, 12 + i] = stroke - drops[i] - axis_lo
            out[p, 16 + i] = axis_hi + drops[i]
    return out
