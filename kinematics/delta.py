"""Clavel's 3-DOF translational Delta robot (R. Clavel, EPFL thesis 1991; US patent 4,976,582).

Frame and units
---------------
Base frame: origin at the centre of the base, z up; the platform works below
the base plane (z < 0). Lengths in mm, actuator angles in rad. Pose
``(x, y, z)``: the centre of the travelling plate, which only translates
(each forearm is a spatial parallelogram).

Geometry (derived here; no seed paper covers the Delta)
-------------------------------------------------------
Leg i (i = 1, 2, 3) lies in the vertical plane at azimuth ``phi_i = 0, 120, 240 deg``
with radial unit vector ``e_i``:

* actuated revolute joint at ``R e_i`` on the base, arm of length ``la``
  rotated down by ``theta_i`` from the horizontal: elbow
  ``E_i = (R + la cos theta_i) e_i - la sin theta_i k``;
* platform joint at ``P + r e_i``; the forearm (parallelogram) of length ``lb``
  joins the elbow to it: ``|P + r e_i - E_i| = lb``.

In the leg's frame, with ``u = x_i - (R - r)`` (``x_i, y_i`` the pose rotated by
``-phi_i``): ``A cos theta + B sin theta = C`` with ``A = 2 la u``,
``B = -2 la z``, ``C = u^2 + y_i^2 + z^2 + la^2 - lb^2``. Inverse kinematics takes
the root with the elbow outward, ``theta = atan2(B, A) - arccos(C / sqrt(A^2 + B^2))``.
Forward kinematics is the intersection of the three spheres of radius ``lb``
about ``E_i - r e_i``: two points (the two assembly modes), found in closed form.
The Jacobian (``theta_dot = J x_dot``) is ``-grad_x F_i / (dF_i/dtheta_i)`` of the
closure ``F_i = |P + r e_i - E_i|^2 - lb^2``.

Limits: actuators ``theta_min <= theta_i <= theta_max`` (default -40 to 80 deg,
the range quoted for ABB's IRB 360 FlexPicker); the out-of-plane angle of each
forearm ``arcsin(y_i / lb)`` within ``passive_limit`` (ball joints of the
parallelogram, default 45 deg; 90 means no limit); the platform at or below
``z_max`` (default 0, the base plane), through the box of :meth:`Delta.pose_bounds`.

Design variables: ``r_ratio = r / R`` and ``forearm_ratio = lb / la`` at a
fixed base radius ``R`` and arm length ``la`` (200 mm each by default).
"""

from __future__ import annotations

import math

import numpy as np

from kinematics import kernels
from kinematics.base import DesignVariable, FixedParameter, Mechanism, check_positive, check_range

_AZIMUTH = np.radians([0.0, 120.0, 240.0])


class Delta(Mechanism):
    """Delta robot with three revolute actuators and parallelogram forearms.

    Parameters
    ----------
    R, r : float
        Base and platform radii (mm), ``0 < r < R``.
    la, lb : float
        Arm and forearm lengths (mm), > 0.
    theta_min, theta_max : float
        Actuator range (deg, below the horizontal positive).
    passive_limit : float
        Largest out-of-plane angle of a forearm (deg), in (0, 90]; 90 is no limit.
    z_max : float
        Highest platform height (mm), in (-(la + lb), 0]: a clearance below the
        base (e.g. -300 mm in Briot et al. 2008, see ``docs/reproduction.md``).
    """

    name = "delta"
    dof = 3
    pose_names = ("x", "y", "z")
    angular = (False, False, False)
    length_unit = "mm"
    angle_params = ("theta_min", "theta_max", "passive_limit")
    fixed_parameters = (
        FixedParameter("R", 200.0, 10.0, 10000.0, "mm"),
        FixedParameter("la", 200.0, 10.0, 10000.0, "mm"),
        FixedParameter("theta_min", -40.0, -179.0, 179.0, "deg"),
        FixedParameter("theta_max", 80.0, -179.0, 179.0, "deg"),
        FixedParameter("passive_limit", 45.0, 1.0, 90.0, "deg"),
        FixedParameter("z_max", 0.0, -100000.0, 0.0, "mm"),
    )
    default_nodes = 32**3
    grid_nodes = 26**3  # V, GDI within 0.1 % on the ladder designs of docs/accuracy.md (its random scan: not on all)
    min_resolution = 16

    design_variables = (
        DesignVariable("r_ratio", 0.15, 0.8, "r / R"),
        DesignVariable("forearm_ratio", 1.2, 3.0, "lb / la"),
    )

    def __init__(
        self,
        R: float,
        r: float,
        la: float,
        lb: float,
        theta_min: float = -40.0,
        theta_max: float = 80.0,
        passive_limit: float = 45.0,
        z_max: float = 0.0,
    ) -> None:
        owner = "Delta"
        self.r, self.R = check_range(owner, "r", r, "R", R)
        self.la = check_positive(owner, "la", la)
        self.lb = check_positive(owner, "lb", lb)
        try:
            lo, hi, top = float(theta_min), float(theta_max), float(z_max)
        except (TypeError, ValueError):
            raise ValueError(
                f"Delta: parameters 'theta_min', 'theta_max' (deg) and 'z_max' (mm) must be numbers; "
                f"got {theta_min!r}, {theta_max!r}, {z_max!r}"
            ) from None
        if not (math.isfinite(lo) and math.isfinite(hi) and -180 < lo < hi < 180):
            raise ValueError(
                f"Delta: parameters 'theta_min' < 'theta_max' must lie in (-180, 180) deg; "
                f"got {theta_min!r}, {theta_max!r}"
            )
        self.theta_min, self.theta_max = lo, hi
        self.passive_limit = check_positive(owner, "passive_limit", passive_limit)
        if self.passive_limit > 90:
            raise ValueError(f"Delta: parameter 'passive_limit' must be in (0, 90] deg; got {passive_limit!r}")
        self.z_max = top
        if not -(self.la + self.lb) < top <= 0.0:
            raise ValueError(
                f"Delta: parameter 'z_max' must be in ({-(self.la + self.lb):g}, 0] mm "
                f"(-(la + lb) to the base plane); got {z_max!r}"
            )
        self._params = {
            "R": self.R,
            "r": self.r,
            "la": self.la,
            "lb": self.lb,
            "theta_min": lo,
            "theta_max": hi,
            "passive_limit": self.passive_limit,
            "z_max": self.z_max,
        }
        self._cos, self._sin = np.cos(_AZIMUTH), np.sin(_AZIMUTH)

    @classmethod
    def from_design(cls, design: np.ndarray, **fixed: object) -> Delta:
        """``(r / R, lb / la)`` at the fixed ``R`` and ``la`` (mm)."""
        fixed = dict(fixed)
        r_ratio, forearm_ratio = (float(v) for v in np.ravel(design))
        R, la = float(fixed.pop("R", 200.0)), float(fixed.pop("la", 200.0))
        return cls(R=R, r=r_ratio * R, la=la, lb=forearm_ratio * la, **fixed)

    # ---------------------------------------------------------- properties
    @property
    def characteristic_length(self) -> float:
        """``lb`` (mm); the Delta's pose has no angular variable, so nothing is divided by it."""
        return self.lb

    @property
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """``theta_min <= theta_i <= theta_max`` (rad)."""
        return np.full(3, math.radians(self.theta_min)), np.full(3, math.radians(self.theta_max))

    @property
    def default_orientation(self) -> tuple[float, float]:
        """No angular pose variable; (0, 0) is a placeholder."""
        return (0.0, 0.0)

    def pose_bounds(self, orientation: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Box of the workspace (mm): within ``R - r + la + lb`` of the axis, from ``-(la + lb)`` up
        to ``z_max``."""
        reach = self.R - self.r + self.la + self.lb
        return np.array([-reach, -reach, -(self.la + self.lb)]), np.array([reach, reach, self.z_max])

    def reference_volume(self, orientation: tuple[float, float]) -> float:
        """``V* = pi (R - r + la + lb)^2 (la + lb + z_max)`` (mm^3): the cylinder inscribing
        :meth:`pose_bounds`."""
        return math.pi * (self.R - self.r + self.la + self.lb) ** 2 * (self.la + self.lb + self.z_max)

    def plot_slice(self, orientation: tuple[float, float]) -> tuple[dict[str, float], tuple[int, int], str]:
        """The horizontal (x, y) plane at the median height of the workspace."""
        from kinematics.workspace import evaluate  # workspace imports this module's base

        coarse = evaluate(self, resolution=16, return_samples=True, error_estimate=False)
        heights = coarse.samples[coarse.inside, 2]
        z = float(np.median(heights)) if heights.size else -0.5 * (self.la + self.lb)
        return {"z": z}, (0, 1), f"z = {z:.0f} mm"

    def within_joint_limits(self, poses: np.ndarray) -> np.ndarray:
        """Every forearm's out-of-plane angle ``arcsin(|y_i| / lb)`` within ``passive_limit`` (N,) bool."""
        poses = self._check_poses(poses)
        _, y_leg, _ = self._leg_frame(poses)
        return np.all(np.abs(y_leg) <= self.lb * math.sin(math.radians(self.passive_limit)), axis=1)

    def constraint_margins(self, poses: np.ndarray) -> np.ndarray:
        """Margins of reachability (N, 15): ``rho_i - c_i`` and ``rho_i + c_i`` (mm^2; the
        elbow closes, ``|c_i| <= rho_i``, in the terms of :meth:`_inverse`), the actuator
        range ``theta_i - theta_min``, ``theta_max - theta_i`` (rad; NaN where the leg cannot
        close) and the forearm limit ``lb sin(passive_limit) - |y_i|`` (mm)."""
        poses = self._check_poses(poses)
        side = self.lb * math.sin(math.radians(self.passive_limit))
        if kernels.compiled():
            lo, hi = math.radians(self.theta_min), math.radians(self.theta_max)
            return _delta_margins(
                np.ascontiguousarray(poses), self._cos, self._sin, self.R - self.r, self.la, self.lb, lo, hi, side
            )
        u, y_leg, z = self._leg_frame(poses)
        rho = np.hypot(2.0 * self.la * u, 2.0 * self.la * z)
        c = u**2 + y_leg**2 + z**2 + self.la**2 - self.lb**2
        return np.hstack([rho - c, rho + c, self._actuator_margins(poses), side - np.abs(y_leg)])

    # ------------------------------------------------------------- kernels
    def _leg_frame(self, poses: np.ndarray):
        """``u = x_i - (R - r)``, ``y_i`` (each (N, 3)) and z (N, 1), mm."""
        x, y, z = poses[:, 0:1], poses[:, 1:2], poses[:, 2:3]
        x_leg = self._cos * x + self._sin * y
        y_leg = -self._sin * x + self._cos * y
        return x_leg - (self.R - self.r), y_leg, z

    def _inverse(self, poses: np.ndarray) -> np.ndarray:
        """Elbow-out actuator angles (rad), NaN where a leg cannot reach."""
        u, y_leg, z = self._leg_frame(poses)
        a = 2.0 * self.la * u
        b = -2.0 * self.la * z
        c = u**2 + y_leg**2 + z**2 + self.la**2 - self.lb**2
        rho = np.hypot(a, b)
        ratio = np.where(rho > 0, c / np.where(rho > 0, rho, 1.0), np.nan)
        theta = np.arctan2(b, a) - np.arccos(np.where(np.abs(ratio) <= 1.0, ratio, np.nan))
        return (theta + np.pi) % (2 * np.pi) - np.pi

    def _closure(self, poses: np.ndarray, q: np.ndarray):
        """Forearm vector in the leg frame (3 arrays (N, 3)) for actuator angles q (N, 3) or (3,)."""
        u, y_leg, z = self._leg_frame(poses)
        cq, sq = np.cos(q), np.sin(q)
        return u - self.la * cq, y_leg, z + self.la * sq, cq, sq

    def _jacobian(self, poses: np.ndarray) -> np.ndarray:
        """``J`` (N, 3, 3), ``theta_dot = J x_dot`` (rad/mm), from ``F_i = |forearm|^2 - lb^2``."""
        q = self._inverse(poses)
        fx, fy, fz, cq, sq = self._closure(poses, q)
        u, _, z = self._leg_frame(poses)
        d_theta = 2.0 * self.la * (u * sq + z * cq)  # dF_i / dtheta_i
        grad = np.stack(
            [2.0 * (fx * self._cos - fy * self._sin), 2.0 * (fx * self._sin + fy * self._cos), 2.0 * fz], axis=-1
        )  # dF_i / d(x, y, z), base frame
        with np.errstate(divide="ignore", invalid="ignore"):
            return -grad / d_theta[..., None]

    def _compiled_reachable_jacobian(self, poses: np.ndarray, column_scale: np.ndarray) -> np.ndarray:
        """IK, actuator range, forearm limit and ``J`` of :meth:`_jacobian`, compiled
        (see :func:`_delta_reachable_jacobians`)."""
        lo, hi = math.radians(self.theta_min), math.radians(self.theta_max)
        return _delta_reachable_jacobians(
            poses,
            self._cos,
            self._sin,
            self.R - self.r,
            self.la,
            self.lb,
            lo,
            hi,
            self.lb * math.sin(math.radians(self.passive_limit)),
            column_scale,
        )

    def _constraints(self, poses: np.ndarray, q: np.ndarray) -> np.ndarray:
        """``|forearm_i|^2 - lb^2`` (mm^2), zero at a solution for ``q``."""
        fx, fy, fz, _, _ = self._closure(poses, q)
        return fx**2 + fy**2 + fz**2 - self.lb**2

    def _constraints_jacobian(self, poses: np.ndarray, q: np.ndarray) -> np.ndarray:
        fx, fy, fz, _, _ = self._closure(poses, q)
        return np.stack(
            [2.0 * (fx * self._cos - fy * self._sin), 2.0 * (fx * self._sin + fy * self._cos), 2.0 * fz], axis=-1
        )

    def sphere_centres(self, q: np.ndarray) -> np.ndarray:
        """Centres ``E_i - r e_i`` (3, 3) of the spheres of radius ``lb`` the platform centre lies on (mm)."""
        q = self._check_actuators(q)
        radial = self.R - self.r + self.la * np.cos(q)
        return np.column_stack([radial * self._cos, radial * self._sin, -self.la * np.sin(q)])

    def assembly_modes(self, q: np.ndarray) -> np.ndarray:
        """Both intersections (k <= 2, 3) of the three spheres, lowest z first (mm); not filtered by branch."""
        s = self.sphere_centres(q)
        normal = np.cross(s[1] - s[0], s[2] - s[0])
        rows = np.array([s[1] - s[0], s[2] - s[0]]) * 2.0
        rhs = np.array([s[1] @ s[1] - s[0] @ s[0], s[2] @ s[2] - s[0] @ s[0]])
        p0 = np.linalg.lstsq(rows, rhs, rcond=None)[0]  # the point of the line nearest the origin
        n = normal / np.linalg.norm(normal)
        d = p0 - s[0]
        b, c = 2.0 * (n @ d), d @ d - self.lb**2
        disc = b * b - 4.0 * c
        if disc < 0:
            return np.empty((0, 3))
        roots = np.array([(-b - math.sqrt(disc)) / 2.0, (-b + math.sqrt(disc)) / 2.0])
        points = p0 + roots[:, None] * n
        return points[np.argsort(points[:, 2])]

    def _forward(self, q: np.ndarray) -> np.ndarray:
        """The three-sphere intersection (exact); :meth:`forward` keeps the elbow-out branch."""
        return self.assembly_modes(q)


@kernels.inline_jit
def _delta_leg(x, y, z, cos_az, sin_az, offset, la, lb):
    """Leg i (azimuth ``cos_az``, ``sin_az``) at (x, y, z) (mm), in its own frame: ``y_i``, ``u``
    and the terms ``A cos theta + B sin theta = C`` of :meth:`Delta._inverse` (mm, mm^2) with
    ``rho = |(A, B)|``; the same operations as :meth:`Delta._leg_frame` and ``_inverse``."""
    x_leg = cos_az * x + sin_az * y
    y_leg = -sin_az * x + cos_az * y
    u = x_leg - offset
    a = 2.0 * la * u
    b = -2.0 * la * z
    c = u * u + y_leg * y_leg + z * z + la * la - lb * lb
    return y_leg, u, a, b, c, math.hypot(a, b)


@kernels.inline_jit
def _closure_ratio(c, rho):
    """``C / rho`` of :meth:`Delta._inverse` (NaN where ``rho = 0``): the leg closes where its
    absolute value is at most 1."""
    return c / rho if rho > 0.0 else np.nan


@kernels.inline_jit
def _elbow_out(a, b, ratio):
    """The elbow-out actuator angle (rad, in [-pi, pi)) of :meth:`Delta._inverse` from the leg's
    ``A``, ``B`` (mm^2) and :func:`_closure_ratio`; NaN where the leg cannot close
    (``|C| > rho``)."""
    if not abs(ratio) <= 1.0:
        return np.nan
    shifted = math.atan2(b, a) - math.acos(ratio) + math.pi
    # fmod is exact, so an angle already in [0, 2 pi) is its own remainder: the wrap of
    # _inverse without the cost of the floor modulo for nearly every angle
    if not 0.0 <= shifted < 2.0 * math.pi:
        shifted = shifted % (2.0 * math.pi)
    return shifted - math.pi


@kernels.jit
def _delta_reachable_jacobians(poses, cos_az, sin_az, offset, la, lb, theta_lo, theta_hi, max_side, column_scale):
    """Per pose (N, 3) of (x, y, z) (mm), leg by leg in its own frame (azimuth
    ``cos_az``, ``sin_az``; ``offset = R - r``): the elbow-out angle of
    :meth:`Delta._inverse`, the range ``theta_lo..theta_hi`` (rad), the forearm
    limit ``|y_i| <= max_side`` (:meth:`Delta.within_joint_limits`) and the
    row ``-grad F_i / (dF_i / dtheta_i)`` of :meth:`Delta._jacobian` times
    ``column_scale``. Returns (N, 3, 3) (rad/mm); rows of NaN where the pose is
    out (no IK, out of range or past the forearm limit)."""
    count = poses.shape[0]
    out = np.empty((count, 3, 3))
    legs = np.empty((3, 6))  # y_i, u, A, B, C / rho and theta of each leg
    for p in range(count):
        x, y, z = poses[p, 0], poses[p, 1], poses[p, 2]
        # the tests without trigonometry first, on every leg: most poses of a grid fail one
        # (the leg cannot close, or the forearm limit), and then no angle is needed
        out_of_reach = False
        for i in range(3):
            y_leg, u, a, b, c, rho = _delta_leg(x, y, z, cos_az[i], sin_az[i], offset, la, lb)
            ratio = _closure_ratio(c, rho)
            if not (abs(ratio) <= 1.0 and abs(y_leg) <= max_side):
                out_of_reach = True
                break
            legs[i, 0], legs[i, 1], legs[i, 2], legs[i, 3], legs[i, 4] = y_leg, u, a, b, ratio
        if not out_of_reach:
            for i in range(3):
                theta = _elbow_out(legs[i, 2], legs[i, 3], legs[i, 4])
                if not (theta_lo <= theta <= theta_hi):
                    out_of_reach = True
                    break
                legs[i, 5] = theta
        if out_of_reach:
            out[p, :, :] = np.nan
            continue
        for i in range(3):
            y_leg, u, theta = legs[i, 0], legs[i, 1], legs[i, 5]
            cq, sq = math.cos(theta), math.sin(theta)
            fx = u - la * cq
            fz = z + la * sq
            d_theta = 2.0 * la * (u * sq + z * cq)
            grads = (2.0 * (fx * cos_az[i] - y_leg * sin_az[i]), 2.0 * (fx * sin_az[i] + y_leg * cos_az[i]), 2.0 * fz)
            for j in range(3):
                g = -grads[j]
                if d_theta != 0.0:
                    out[p, i, j] = g / d_theta * column_scale[j]
                else:  # singular leg: +-inf (0 / 0: NaN), as numpy divides
                    out[p, i, j] = (np.nan if g == 0.0 else math.copysign(np.inf, g)) * column_scale[j]
    return out


@kernels.vector_jit
def _delta_margins(poses, cos_az, sin_az, offset, la, lb, theta_lo, theta_hi, max_side):
    """Kernel of :meth:`Delta.constraint_margins` (the same operations, one pose at a time):
    per pose (x, y, z) (mm) the 15 margins, leg by leg in its own frame (:func:`_delta_leg`)."""
    count = poses.shape[0]
    out = np.empty((count, 15))
    for p in range(count):
        x, y, z = poses[p, 0], poses[p, 1], poses[p, 2]
        for i in range(3):
            y_leg, _, a, b, c, rho = _delta_leg(x, y, z, cos_az[i], sin_az[i], offset, la, lb)
            theta = _elbow_out(a, b, _closure_ratio(c, rho))
            out[p, i] = rho - c
            out[p, 3 + i] = rho + c
            out[p, 6 + i] = theta - theta_lo
            out[p, 9 + i] = theta_hi - theta
            out[p, 12 + i] = max_side - abs(y_leg)
    return out
