"""Tricept 3-DOF parallel manipulator (seed 001: Hosseini & Daniali 2011).

Frame and units
---------------
Base frame {O(xyz)}, z normal to the base. Lengths in mm, angles in rad.
Pose ``(c, psi, theta)``: ``c`` is the length of the central passive
prismatic limb (the point ``c k`` on the z axis is the centre of its
universal joint's rotation), ``psi`` and ``theta`` the universal-joint angles
about x and y: ``R = R_y(theta) R_x(psi)`` (the matrix printed in eq. 1).

Geometry (seed 001 eq. 1-2, derived from the geometry)
------------------------------------------------------
* Platform joints: ``P_i = R (p_i + d k) + c k`` with
  ``p_1 = (a/sqrt3, 0, 0)``, ``p_2 = (-a/(2 sqrt3), a/2, 0)``, ``p_3 = (-a/(2 sqrt3), -a/2, 0)``
  (eq. 1): an equilateral triangle of side ``a`` (circumradius ``a/sqrt3``).
* Base joints: ``b_1 = (b/sqrt3, 0, 0)``, ``b_2 = (-b/(2 sqrt3), b/2, 0)``,
  ``b_3 = (-b/(2 sqrt3), -b/2, 0)`` (eq. 2), side ``b``.
* Leg lengths ``q_i = |P_i - b_i|``. Expanding gives, for leg 1,
  ``q_1^2 = a^2/3 + b^2/3 + c^2 + d^2 - (2/3) a b C(theta) + 2 c d C(theta) C(psi)
  - (2/sqrt3) b d C(psi) S(theta) - (2/sqrt3) a c S(theta)``; the OCR'd eq. 3
  drops the last term, and eq. 4-5 carry further sign/index typos, so the code
  computes ``|P_i - b_i|`` directly.
* Limits (Table 1): actuators ``q_min..q_max`` (400-750 mm), joint cone angle
  <= ``cone`` (60 deg) at base and platform joints.

Readings (choices the paper leaves open; each a constructor parameter)
----------------------------------------------------------------------
* ``cone_joints``: which joints the cone limit applies to, ``"both"``
  (default: Table 1 says "joint", the paper's legs have spherical joints at
  both ends), ``"base"``, ``"platform"`` or ``"none"``.
* ``cone_reference``: the axis a cone angle is measured from, ``"normal"``
  (default: the base normal k and the platform normal R k, the axis of a
  spherical joint mounted flat) or ``"home"`` (the leg's direction at the home
  pose c = (q_min + q_max)/2, ψ = θ = 0: a joint mounted along its leg).
* ``offset_side``: +1 (default, eq. 1: ``p_i + d k``, the platform above the
  U-joint centre) or -1 (``p_i - d k``, platform joints below it).
* ``tilt_limit``: the largest tilt of the central universal joint,
  ``arccos(cos ψ cos θ)`` (deg); ``None`` (default) means the orientation box alone.
* ``homogenising``: characteristic length of eq. 37, ``"arm"`` (default:
  sqrt(a²/3 + d²), the moment arm of eq. 31), ``"a"``, ``"d"`` or ``"none"`` (1 mm).
"""

from __future__ import annotations

import math

import numpy as np

from kinematics import kernels
from kinematics.algebra import (
    matrix_polynomial_eigenvalues,
    near_real,
    polynomial_roots,
    sample_angles,
    sylvester_matrix_polynomial,
    tan_half_to_angle,
    trig_coefficients,
    trig_to_tan_half,
)
from kinematics.base import (
    DesignVariable,
    FixedParameter,
    Mechanism,
    check_positive,
    check_range,
    orientation_measure,
)

_S3 = math.sqrt(3.0)


def _triangle(side: float) -> np.ndarray:
    """Vertices (3, 3) of the equilateral triangle of eq. 1-2, circumradius side/sqrt3."""
    r = side / _S3
    return np.array([[r, 0.0, 0.0], [-r / 2, side / 2, 0.0], [-r / 2, -side / 2, 0.0]])


class Tricept(Mechanism):
    """Tricept with three SPS legs and a central passive PU limb (seed 001).

    Parameters
    ----------
    a : float
        Side of the moving platform's joint triangle (mm), > 0.
    b : float
        Side of the base joint triangle (mm), > 0.
    d : float
        Offset of the platform from the universal-joint centre along the
        platform normal (the "upper part of the passive link") (mm), > 0.
    q_min, q_max : float
        Actuator (leg length) range (mm), ``0 < q_min < q_max``; Table 1: 400-750.
    cone : float
        Largest joint cone angle (deg), in (0, 180); Table 1: 60.
    cone_joints, cone_reference, offset_side, tilt_limit, homogenising
        Readings of the paper (module docstring).
    """

    name = "tricept"
    dof = 3
    pose_names = ("c", "psi", "theta")
    angular = (False, True, True)
    length_unit = "mm"

    def __init__(
        self,
        a: float,
        b: float,
        d: float,
        q_min: float = 400.0,
        q_max: float = 750.0,
        cone: float = 60.0,
        cone_joints: str = "both",
        cone_reference: str = "normal",
        offset_side: int = 1,
        tilt_limit: float | None = None,
        homogenising: str = "arm",
    ) -> None:
        owner = "Tricept"
        self.a = check_positive(owner, "a", a)
        self.b = check_positive(owner, "b", b)
        self.d = check_positive(owner, "d", d)
        self.q_min, self.q_max = check_range(owner, "q_min", q_min, "q_max", q_max)
        cone_v = check_positive(owner, "cone", cone)
        if cone_v >= 180.0:
            raise ValueError(f"Tricept: parameter 'cone' must be in (0, 180) degrees; got {cone!r}")
        self.cone = cone_v
        for name, value, allowed in (
            ("cone_joints", cone_joints, ("both", "base", "platform", "none")),
            ("cone_reference", cone_reference, ("normal", "home")),
            ("offset_side", offset_side, (1, -1)),
            ("homogenising", homogenising, ("arm", "a", "d", "none")),
        ):
            if value not in allowed:
                raise ValueError(
                    f"Tricept: parameter '{name}' must be one of {', '.join(map(str, allowed))}; got {value!r}"
                )
        if tilt_limit is not None:
            tilt_limit = check_positive(owner, "tilt_limit", tilt_limit)
        self.cone_joints, self.cone_reference = cone_joints, cone_reference
        self.offset_side, self.tilt_limit, self.homogenising = int(offset_side), tilt_limit, homogenising
        self._params = {
            "a": self.a,
            "b": self.b,
            "d": self.d,
            "q_min": self.q_min,
            "q_max": self.q_max,
            "cone": self.cone,
            "cone_joints": cone_joints,
            "cone_reference": cone_reference,
            "offset_side": self.offset_side,
            "tilt_limit": tilt_limit,
            "homogenising": homogenising,
        }
        self.p = _triangle(self.a)
        self.p[:, 2] = self.offset_side * self.d  # p_i +- d k, in the platform frame
        self.base = _triangle(self.b)
        home = self.p.copy()
        home[:, 2] += 0.5 * (self.q_min + self.q_max)
        legs = home - self.base
        #: unit leg directions at the home pose (3, 3), the "home" cone reference
        self._home_axes = legs / np.linalg.norm(legs, axis=1, keepdims=True)

    angle_params = ("cone", "tilt_limit")
    unitless_params = ("offset_side",)
    fixed_parameters = (
        FixedParameter("q_min", 400.0, 10.0, 10000.0, "mm"),
        FixedParameter("q_max", 750.0, 10.0, 10000.0, "mm"),
        FixedParameter("cone", 60.0, 1.0, 179.0, "deg"),
        FixedParameter("cone_joints", "both", choices=("both", "base", "platform", "none")),
        FixedParameter("cone_reference", "normal", choices=("normal", "home")),
        FixedParameter("offset_side", 1, choices=(1, -1)),
        FixedParameter("tilt_limit", None, 1.0, 90.0, "deg", optional=True),
        FixedParameter("homogenising", "arm", choices=("arm", "a", "d", "none")),
    )
    default_nodes = 32**3
    # linear margins at 20^3 nodes: V, GDI and eta within 0.1 % on the ladder's and the scan's designs
    # of docs/accuracy.md and 12 more random ones (at most 0.082 %, the V of one; the GDI 0.05 %
    # with the parts' means of 1/kappa, 0.089 % at their centroids; at 19^3 and 18^3 too, V 0.090 %
    # and 0.089 %, not adopted: it would move tricept_max_volume's objective); one plane per cell needed
    # 28^3 and missed a scan design. Continuous where a slab thinner than a cell empties (the
    # planes stepped there, along b)
    cell_rule = "margins"
    grid_nodes = 20**3
    min_resolution = 16

    design_variables = (
        DesignVariable("a", 200.0, 300.0, "mm"),
        DesignVariable("b", 300.0, 500.0, "mm"),
        DesignVariable("d", 20.0, 200.0, "mm"),
    )

    @property
    def default_orientation(self) -> tuple[float, float]:
        """psi, theta in [-pi/2, pi/2] rad: a universal joint's usable range;
        the cone limit (Table 1) bounds the workspace well inside it."""
        return (-np.pi / 2, np.pi / 2)

    def plot_slice(self, orientation: tuple[float, float]) -> tuple[dict[str, float], tuple[int, int], str]:
        """The (psi, theta) plane at the median c of the workspace (seed 001 Fig. 3)."""
        from kinematics.workspace import evaluate  # workspace imports this module's base

        coarse = evaluate(self, orientation=orientation, resolution=16, return_samples=True, error_estimate=False)
        levels = coarse.samples[coarse.inside, 0]
        lo, hi = self.pose_bounds(orientation)
        c = float(np.median(levels)) if levels.size else 0.5 * float(lo[0] + hi[0])
        return {"c": c}, (1, 2), f"c = {c:.0f} mm"

    def pose_bounds(self, orientation: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Box of the (upper, c > 0) workspace (mm, rad).

        A platform joint lies within ``R = sqrt(a^2/3 + d^2)`` of ``c k`` and a base
        joint at ``b/sqrt3`` from the axis, so a leg of length ``>= q_min`` needs a
        height ``>= sqrt(q_min^2 - (b/sqrt3 + R)^2)`` and one ``<= q_max`` allows at
        most ``q_max``; c is within R of the joint height.
        """
        reach = self.characteristic_length
        floor = math.sqrt(max(0.0, self.q_min**2 - (self.b / _S3 + reach) ** 2))
        lo, hi = float(orientation[0]), float(orientation[1])
        return (np.array([max(0.0, floor - reach), lo, lo]), np.array([self.q_max + reach, hi, hi]))

    def reference_volume(self, orientation: tuple[float, float]) -> float:
        """``V* = (q_max - q_min) * (psi range) * (theta range)`` (mm rad^2).

        The Tricept analogue of seed 000's "base area x z reach": its pose has
        one length, whose reach is the actuator stroke.
        """
        return (self.q_max - self.q_min) * orientation_measure(orientation, 2)

    def within_joint_limits(self, poses: np.ndarray) -> np.ndarray:
        """Joint cone angles <= ``cone`` (Table 1) at the joints of ``cone_joints``, and the
        central joint's tilt <= ``tilt_limit`` (deg) when set."""
        poses = self._check_poses(poses)
        ok = np.ones(poses.shape[0], dtype=bool)
        if self.cone_joints != "none":
            base, plat = self.cone_angles(poses)
            limit = self.cone_limit
            if self.cone_joints in ("both", "base"):
                ok &= np.all(base <= limit, axis=1)
            if self.cone_joints in ("both", "platform"):
                ok &= np.all(plat <= limit, axis=1)
        if self.tilt_limit is not None:
            tilt = np.arccos(np.clip(np.cos(poses[:, 1]) * np.cos(poses[:, 2]), -1.0, 1.0))
            ok &= tilt <= math.radians(self.tilt_limit)
        return ok

    @property
    def characteristic_length(self) -> float:
        """Length (mm) dividing the angular columns of eq. 37 (reading ``homogenising``).

        Default ``"arm"``: ``sqrt(a^2/3 + d^2)``, the distance from the U-joint
        centre to a platform joint, i.e. the moment arm ``|R (a_i + d)|`` of eq.
        31, so the angular columns divided by it are the leg speed per unit
        speed of the platform joints.
        """
        return {"arm": math.sqrt(self.a**2 / 3.0 + self.d**2), "a": self.a, "d": self.d, "none": 1.0}[self.homogenising]

    @property
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """``q_min <= q_i <= q_max`` (mm)."""
        return np.full(3, self.q_min), np.full(3, self.q_max)

    @property
    def cone_limit(self) -> float:
        """Largest joint cone angle (rad)."""
        return math.radians(self.cone)

    # ----------------------------------------------------------- geometry
    @staticmethod
    def _rotation(psi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """``R = R_y(theta) R_x(psi)`` (eq. 1), shape (N, 3, 3)."""
        cp, sp, ct, st = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta)
        zero = np.zeros_like(psi)
        return np.stack(
            [
                np.stack([ct, sp * st, cp * st], axis=-1),
                np.stack([zero, cp, -sp], axis=-1),
                np.stack([-st, ct * sp, ct * cp], axis=-1),
            ],
            axis=-2,
        )

    def _arms(self, poses: np.ndarray) -> np.ndarray:
        """``r_i = R (p_i + d k)`` (N, 3, 3), mm, base-frame orientation."""
        rot = self._rotation(poses[:, 1], poses[:, 2])
        return (rot @ self.p.T).transpose(0, 2, 1)  # matmul: ~2.5x einsum's speed here

    def platform_points(self, poses: np.ndarray) -> np.ndarray:
        """Platform joints ``P_i`` (eq. 1), shape (N, 3, 3), mm, base frame."""
        poses = self._check_poses(poses)
        pts = self._arms(poses)
        pts[..., 2] += poses[:, 0:1]
        return pts

    def cone_angles(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint cone angles (rad) of the legs (seed 001 Sec. 4.2, Table 1).

        Reading ``cone_reference="normal"``: the base joint's angle is between
        the leg and the base normal ``k``, the platform joint's between the leg
        and the platform normal ``R k``. ``"home"``: both against the leg's
        home direction (base frame at the base, carried by R at the platform).

        Returns
        -------
        base, platform : ndarray, each shape (N, 3)
        """
        poses = self._check_poses(poses)
        legs = self.platform_points(poses) - self.base
        unit = legs / np.linalg.norm(legs, axis=-1, keepdims=True)
        rot = self._rotation(poses[:, 1], poses[:, 2])
        if self.cone_reference == "normal":
            base = np.arccos(np.clip(unit[..., 2], -1.0, 1.0))
            plat = np.arccos(np.clip(np.einsum("nki,ni->nk", unit, rot[:, :, 2]), -1.0, 1.0))
        else:
            base = np.arccos(np.clip(np.einsum("nki,ki->nk", unit, self._home_axes), -1.0, 1.0))
            moved = np.einsum("nij,kj->nki", rot, self._home_axes)
            plat = np.arccos(np.clip(np.einsum("nki,nki->nk", unit, moved), -1.0, 1.0))
        return base, plat

    def _kernel_arguments(self, poses: np.ndarray) -> tuple:
        """The leading arguments of the compiled leg kernels (:func:`_tricept_reachable_jacobians`,
        :func:`_tricept_margins`): the poses, the cosines and sines of psi and theta, the
        platform and base joints and the home leg axes (mm), the leg range (mm)."""
        cos_psi, sin_psi = kernels.periodic_cos_sin(np.ascontiguousarray(poses[:, 1]))
        cos_theta, sin_theta = kernels.periodic_cos_sin(np.ascontiguousarray(poses[:, 2]))
        joints = (self.p, self.base, self._home_axes)
        return (
            np.ascontiguousarray(poses),
            cos_psi,
            sin_psi,
            cos_theta,
            sin_theta,
            *(np.ascontiguousarray(a) for a in joints),
            self.q_min,
            self.q_max,
        )

    def constraint_margins(self, poses: np.ndarray) -> np.ndarray:
        """Margins of the actuator range and :meth:`within_joint_limits` (N, K): ``q_i - q_min``,
        ``q_max - q_i`` (mm, eq. 1-5), ``cos(angle) - cos(cone)`` of each limited joint's cone
        angle (:meth:`cone_angles`; >= 0 exactly where the angle is within the limit) and
        ``cos(tilt) - cos(tilt_limit)`` of the central joint; legs are always real. The legs
        are computed once (this runs on every grid edge the workspace boundary crosses)."""
        poses = self._check_poses(poses)
        if kernels.compiled():
            return _tricept_margins(
                *self._kernel_arguments(poses),
                math.cos(self.cone_limit),
                self.cone_joints in ("both", "base"),
                self.cone_joints in ("both", "platform"),
                self.cone_reference == "home",
                math.cos(math.radians(self.tilt_limit)) if self.tilt_limit is not None else np.nan,
            )
        rot = self._rotation(poses[:, 1], poses[:, 2])
        legs = (rot @ self.p.T).transpose(0, 2, 1) - self.base
        legs[..., 2] += poses[:, 0:1]
        q = np.sqrt(np.einsum("nki,nki->nk", legs, legs))
        parts = [q - self.q_min, self.q_max - q]
        if self.cone_joints != "none":
            unit = legs / q[..., None]
            if self.cone_reference == "normal":
                base, plat = unit[..., 2], np.einsum("nki,ni->nk", unit, rot[:, :, 2])
            else:
                base = np.einsum("nki,ki->nk", unit, self._home_axes)
                plat = np.einsum("nki,nki->nk", unit, np.einsum("nij,kj->nki", rot, self._home_axes))
            limit = math.cos(self.cone_limit)
            if self.cone_joints in ("both", "base"):
                parts.append(base - limit)
            if self.cone_joints in ("both", "platform"):
                parts.append(plat - limit)
        if self.tilt_limit is not None:
            parts.append((np.cos(poses[:, 1]) * np.cos(poses[:, 2]) - math.cos(math.radians(self.tilt_limit)))[:, None])
        return np.hstack(parts)

    # ------------------------------------------------------------- kernels
    def _inverse(self, poses: np.ndarray) -> np.ndarray:
        """Leg lengths ``q_i = |R (p_i + d k) + c k - b_i|`` (eq. 1-5, from the geometry)."""
        legs = self._arms(poses) - self.base
        legs[..., 2] += poses[:, 0:1]
        return np.linalg.norm(legs, axis=-1)

    def _jacobian(self, poses: np.ndarray) -> np.ndarray:
        """``J`` with ``q_dot = J (c_dot, psi_dot, theta_dot)`` (eq. 31-36).

        Eq. 31: ``q_dot_i = n_i . (c_dot k + omega x r_i)`` with ``n_i`` the leg's
        unit vector and ``r_i = R (a_i + d)``. For ``R = R_y(theta) R_x(psi)`` the
        angular velocity is ``omega = psi_dot R_y(theta) i + theta_dot j``, so the
        row is ``[n_z, (r x n) . (cos theta, 0, -sin theta), (r x n)_y]``. Eq. 32-33
        print ``(R(a_i + d) x n_i)_x`` for the psi column, which holds only at
        theta = 0. This ``J`` is the paper's ``J_x`` (eq. 33, ``J_q = I``), i.e. the
        inverse of its eq. 36 ``J``.
        """
        arms = self._arms(poses)
        legs = arms - self.base
        legs[..., 2] += poses[:, 0:1]
        unit = legs / np.linalg.norm(legs, axis=-1, keepdims=True)
        moment = np.cross(arms, unit)
        th = poses[:, 2:3]
        psi_col = moment[..., 0] * np.cos(th) - moment[..., 2] * np.sin(th)
        return np.stack([unit[..., 2], psi_col, moment[..., 1]], axis=-1)

    def _compiled_reachable_jacobian(self, poses: np.ndarray, column_scale: np.ndarray) -> np.ndarray:
        """Eq. 1-5, the joint cone and tilt limits of :meth:`within_joint_limits` and eq. 31-36's
        ``J``, compiled (see :func:`_tricept_reachable_jacobians`)."""
        cone = self.cone_limit
        tilt = math.radians(self.tilt_limit) if self.tilt_limit is not None else np.inf
        return _tricept_reachable_jacobians(
            *self._kernel_arguments(poses),
            cone if self.cone_joints in ("both", "base") else np.inf,
            cone if self.cone_joints in ("both", "platform") else np.inf,
            self.cone_reference == "home",
            tilt,
            column_scale,
        )

    # --------------------------------------------------- forward kinematics
    def _eliminants(self, psi: np.ndarray, theta: np.ndarray, q: np.ndarray, scale: float):
        """``G_j = Res_c(E_1, E_1 - E_j)`` for j = 2, 3 on a (psi, theta) grid.

        ``E_i = c^2 + 2 c u_i + w_i - q_i^2`` with ``u_i = (r_i)_z`` and
        ``w_i = |r_i - b_i|^2`` (leg i squared, lengths divided by ``scale``).
        ``E_1 - E_j = m c + n`` is linear in c, so
        ``Res_c = n^2 - 2 u_1 n m + (w_1 - q_1^2) m^2``: a trig polynomial of
        degree 3 in each angle.
        """
        poses = np.column_stack([np.zeros(psi.size), psi.ravel(), theta.ravel()])
        arms = self._arms(poses) / scale
        u = arms[..., 2]
        w = ((arms - self.base / scale) ** 2).sum(axis=-1)
        qs = (q / scale) ** 2
        out = []
        for j in (1, 2):
            m = 2.0 * (u[:, 0] - u[:, j])
            n = (w[:, 0] - w[:, j]) - (qs[0] - qs[j])
            out.append((n**2 - 2 * u[:, 0] * n * m + (w[:, 0] - qs[0]) * m**2).reshape(psi.shape))
        return out

    def _forward(self, q: np.ndarray) -> np.ndarray:
        """All real poses: Sylvester elimination of psi, QZ for theta, Newton polish.

        Replaces the route of eq. 6-27 (whose coefficients eq. 13-21 carry
        typos and keep ``c`` inside M_i, N_i, L_i although it is unknown): we
        eliminate c exactly (``G_2``, ``G_3`` above), then psi with a Sylvester
        matrix in ``t_2 = tan(psi/2)``, and solve the resulting polynomial
        eigenvalue problem in ``t_1 = tan(theta/2)`` (eq. 6-11). Solutions come in
        mirror pairs through the base plane (c and -c).
        """
        scale = max(self.a, self.b, self.d, float(np.max(q)))
        ang = sample_angles(3)
        psi, theta = np.meshgrid(ang, ang, indexing="ij")
        polys = []
        for g in self._eliminants(psi, theta, q, scale):
            coef = trig_coefficients(trig_coefficients(g, 3, axis=0), 3, axis=1)
            poly = np.real(trig_to_tan_half(trig_to_tan_half(coef, axis=0), axis=1))
            polys.append(poly.T)  # index [theta power, psi power]
        f, g = polys
        f = f / np.max(np.abs(f))
        g = g / np.max(np.abs(g))
        t1 = near_real(matrix_polynomial_eigenvalues(sylvester_matrix_polynomial(f, g)), 1e-3)
        starts = []
        for t in t1:
            coeffs_psi = np.array([np.polyval(f[::-1, j], t) for j in range(f.shape[1])])
            for t2 in near_real(polynomial_roots(coeffs_psi[::-1]), 1e-3):
                th, ps = tan_half_to_angle(t), tan_half_to_angle(t2)
                arms = self._arms(np.array([[0.0, ps, th]]))[0]
                u1 = arms[0, 2]
                w1 = ((arms[0] - self.base[0]) ** 2).sum()
                disc = u1**2 - w1 + q[0] ** 2
                root = math.sqrt(max(disc, 0.0))
                starts.extend([[-u1 + root, ps, th], [-u1 - root, ps, th]])
        if not starts:
            return np.empty((0, 3))
        return self._polish(np.array(starts), q, q**2)


@kernels.inline_jit
def _cone_cosine(cone):
    """``cos(cone)`` for a cone half-angle (rad); -2 when the cone admits every direction (>= pi)."""
    return math.cos(cone) if cone < math.pi else -2.0


@kernels.inline_jit
def _within_cone(cosine, cone, cone_cosine):
    """``arccos(cosine) <= cone`` (the numpy path's test of a joint cone or of the central joint's
    tilt, clipped to [-1, 1]); ``cone_cosine`` is :func:`_cone_cosine`. Away from the boundary the answer is the comparison of the cosines
    (arccos decreases; 1e-12 is far above the rounding of either side), so the arc cosine is
    computed only within 1e-12 of it: the same answer, without ~15 ns a joint."""
    if cosine > cone_cosine + 1e-12:
        return True
    if cosine < cone_cosine - 1e-12:
        return False
    return math.acos(min(max(cosine, -1.0), 1.0)) <= cone


@kernels.inline_jit
def _tricept_rotation(rot, cp, sp, ct, st):
    """``R = R_y(theta) R_x(psi)`` (eq. 1) into ``rot`` (3, 3), from the cosines and sines."""
    rot[0, 0], rot[0, 1], rot[0, 2] = ct, sp * st, cp * st
    rot[1, 0], rot[1, 1], rot[1, 2] = 0.0, cp, -sp
    rot[2, 0], rot[2, 1], rot[2, 2] = -st, ct * sp, ct * cp


@kernels.inline_jit
def _tricept_leg(rot, platform, base, home_axes, home_reference, c, i):
    """Leg i at rotation ``rot`` and elevation ``c`` (mm): the arm ``R p_i`` (mm), the leg's length
    ``q_i`` (eq. 1-5) and unit vector, and the cosines of its base and platform cone angles
    (:meth:`Tricept.cone_angles`, the normals or the home leg axes): the same operations as the
    numpy methods."""
    ax = rot[0, 0] * platform[i, 0] + rot[0, 1] * platform[i, 1] + rot[0, 2] * platform[i, 2]
    ay = rot[1, 0] * platform[i, 0] + rot[1, 1] * platform[i, 1] + rot[1, 2] * platform[i, 2]
    az = rot[2, 0] * platform[i, 0] + rot[2, 1] * platform[i, 1] + rot[2, 2] * platform[i, 2]
    lx, ly, lz = ax - base[i, 0], ay - base[i, 1], az - base[i, 2] + c
    q = math.sqrt(lx * lx + ly * ly + lz * lz)
    inverse = 1.0 / q if q > 0.0 else 0.0
    nx, ny, nz = lx * inverse, ly * inverse, lz * inverse
    if home_reference:
        hx, hy, hz = home_axes[i, 0], home_axes[i, 1], home_axes[i, 2]
        base_cos = nx * hx + ny * hy + nz * hz
        mx = rot[0, 0] * hx + rot[0, 1] * hy + rot[0, 2] * hz
        my = rot[1, 0] * hx + rot[1, 1] * hy + rot[1, 2] * hz
        mz = rot[2, 0] * hx + rot[2, 1] * hy + rot[2, 2] * hz
        platform_cos = nx * mx + ny * my + nz * mz
    else:
        base_cos = nz
        platform_cos = nx * rot[0, 2] + ny * rot[1, 2] + nz * rot[2, 2]
    return ax, ay, az, q, nx, ny, nz, base_cos, platform_cos


@kernels.jit
def _tricept_reachable_jacobians(
    poses,
    cos_psi,
    sin_psi,
    cos_theta,
    sin_theta,
    platform,
    base,
    home_axes,
    q_min,
    q_max,
    base_cone,
    platform_cone,
    home_reference,
    tilt_limit,
    column_scale,
):
    """Per pose (N, 3) of (c, psi, theta) (mm, rad; the cosines and sines of psi and theta from
    :func:`kinematics.kernels.periodic_cos_sin`): ``R = R_y(theta) R_x(psi)`` (eq. 1),
    legs ``R p_i + c k - b_i`` and their lengths (eq. 1-5) within ``q_min..q_max``,
    the joint cone angles (rad) within ``base_cone`` / ``platform_cone`` (inf: not
    limited) against the normals or, with ``home_reference``, the home leg axes
    (:meth:`Tricept.cone_angles`), the central joint's tilt within ``tilt_limit``
    (rad, inf: none), and the rows ``[n_z, (r x n) . (cos theta, 0, -sin theta),
    (r x n)_y]`` of :meth:`Tricept._jacobian` times ``column_scale``. Returns
    (N, 3, 3); rows of NaN where the pose is out. Same operation order as the
    numpy methods."""
    count = poses.shape[0]
    out = np.empty((count, 3, 3))
    rot = np.empty((3, 3))
    base_cone_cos, platform_cone_cos = _cone_cosine(base_cone), _cone_cosine(platform_cone)
    tilt_cos = _cone_cosine(tilt_limit)
    for p in range(count):
        c = poses[p, 0]
        cp, sp, ct, st = cos_psi[p], sin_psi[p], cos_theta[p], sin_theta[p]
        ok = _within_cone(cp * ct, tilt_limit, tilt_cos)  # the central joint's tilt
        _tricept_rotation(rot, cp, sp, ct, st)
        for i in range(3):
            if not ok:
                break
            ax, ay, az, q, nx, ny, nz, base_cos, platform_cos = _tricept_leg(
                rot, platform, base, home_axes, home_reference, c, i
            )
            if not (q_min <= q <= q_max):
                ok = False
                break
            if not (
                _within_cone(base_cos, base_cone, base_cone_cos)
                and _within_cone(platform_cos, platform_cone, platform_cone_cos)
            ):
                ok = False
                break
            # moment r x n of eq. 31
            mom_x = ay * nz - az * ny
            mom_y = az * nx - ax * nz
            mom_z = ax * ny - ay * nx
            out[p, i, 0] = nz * column_scale[0]
            out[p, i, 1] = (mom_x * ct - mom_z * st) * column_scale[1]
            out[p, i, 2] = mom_y * column_scale[2]
        if not ok:
            out[p, :, :] = np.nan
    return out


@kernels.vector_jit
def _tricept_margins(
    poses,
    cos_psi,
    sin_psi,
    cos_theta,
    sin_theta,
    platform,
    base,
    home_axes,
    q_min,
    q_max,
    cone_cos,
    base_limited,
    platform_limited,
    home_reference,
    tilt_cos,
):
    """Kernel of :meth:`Tricept.constraint_margins` (the same operations, one pose at a time):
    per pose (c, psi, theta) the leg range margins (mm), then the cone margins of the limited
    joints (base, then platform) and the tilt margin (``tilt_cos`` NaN: no tilt limit)."""
    count = poses.shape[0]
    columns = 6 + 3 * (int(base_limited) + int(platform_limited)) + int(not np.isnan(tilt_cos))
    out = np.empty((count, columns))
    rot = np.empty((3, 3))
    for p in range(count):
        c = poses[p, 0]
        cp, sp, ct, st = cos_psi[p], sin_psi[p], cos_theta[p], sin_theta[p]
        _tricept_rotation(rot, cp, sp, ct, st)
        for i in range(3):
            _, _, _, q, _, _, _, base_cos, platform_cos = _tricept_leg(
                rot, platform, base, home_axes, home_reference, c, i
            )
            out[p, i] = q - q_min
            out[p, 3 + i] = q_max - q
            k = 6
            if base_limited:
                out[p, k + i] = base_cos - cone_cos
                k += 3
            if platform_limited:
                out[p, k + i] = platform_cos - cone_cos
        if not np.isnan(tilt_cos):
            out[p, columns - 1] = cp * ct - tilt_cos
    return out
