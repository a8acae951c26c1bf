"""Gough–Stewart platform, 6-UPS (six extensible legs; issue 24).

Frame and units
---------------
Base frame: origin at the centre of the base joint circle, z normal to the
base, up; the platform works above the base (z > 0, the upper assembly
modes). Lengths in mm, angles in rad (degrees only for the constructor's
angles, as the other mechanisms' limits).

Pose ``(x, y, z, tilt_x, tilt_y, torsion)``: ``c = (x, y, z)`` is the centre of
the platform joint circle, and the orientation is Bonev's tilt-and-torsion
(Bonev & Ryu, Mech. Mach. Theory 36, 2001) written with the tilt as a
horizontal rotation vector::

    R = Exp([w]x) R_z(torsion),   w = (tilt_x, tilt_y, 0)

i.e. a torsion about the platform normal, then a tilt by ``|w|`` about the
horizontal axis ``w/|w|``. Bonev's azimuth phi and tilt theta are
``w = theta (-sin phi, cos phi, 0)``. The tilt-vector form has no singularity
at zero tilt, so an orientation box ``[lo, hi]^3`` (the workspace module's
one range for every angle) is a square of tilt vectors times a torsion
interval. Near the home pose ``tilt_x``, ``tilt_y``, ``torsion`` are the
rotations about x, y, z.

Geometry (the usual semi-regular hexagons)
------------------------------------------
Base joints on a circle of radius ``r_base`` in pairs centred at 0, 120,
240 deg, the two joints of a pair ``sep_base`` apart; platform joints on a
circle of radius ``r_platform`` in pairs centred at 60, 180, 300 deg,
``sep_platform`` apart. Leg ``2k`` joins the base joint at
``120k - sep_base/2`` to the platform joint at ``120k - 60 + sep_platform/2``,
leg ``2k + 1`` joins ``120k + sep_base/2`` to ``120k + 60 - sep_platform/2``
(each base pair reaches the two neighbouring platform pairs: the classic
6-6 layout, a 3-3 octahedron when both separations tend to 0).

* Inverse kinematics: ``L_i = c + R p_i - b_i``, ``q_i = |L_i|``,
  ``u_i = L_i / q_i`` (Merlet, *Parallel Robots*, 2nd ed., 2006, Sec. 4.1).
* Jacobian: ``q_dot_i = u_i . c_dot + ((R p_i) x u_i) . omega`` (the rows
  ``[u_i^T, (R p_i x u_i)^T]`` of the inverse kinematic Jacobian in twist form,
  Merlet Sec. 5.2, :meth:`GoughStewart.twist_jacobian`), and
  ``omega = J_l(w) (w_dot) + (Exp(w) k) torsion_dot`` with ``J_l`` the left
  Jacobian of SO(3), so :meth:`~kinematics.base.Mechanism.jacobian` is
  ``d q / d pose`` in the pose coordinates above (the base's convention;
  at zero tilt the two are equal).
* Forward kinematics: Newton from a guess (:meth:`GoughStewart.forward_from`);
  :meth:`GoughStewart.assembly_modes` runs Newton from a deterministic set of
  starts (home pose, its mirror, a scrambled Sobol set over the pose box) to
  collect several assembly modes; :meth:`~kinematics.base.Mechanism.forward`
  does the same from 66 starts. A general 6-6 platform has up to 40 (Dietmaier 1998):
  multi-start Newton finds the ones whose basins the starts meet, not a
  certified complete set.
* Limits: leg lengths ``q_min..q_max``; passive-joint cone angles (angle between
  the leg and the joint's axis) ``<= cone_base`` at the base (universal
  joints) and ``<= cone_platform`` at the platform (spherical joints). The
  joint axes are, with ``cone_reference="home"`` (default), the leg directions
  at the home pose ``(0, 0, height, 0, 0, 0)`` (joints mounted along their leg,
  the way hexapods are built to centre the joint range), or with
  ``"normal"`` the base normal and the platform normal. Leg-leg collisions are
  not modelled.

Workspaces (see ``docs/gough_stewart.md``)
-----------------------------------------
* The pipeline-facing default, ``default_orientation = (0, 0)``: the
  constant-orientation workspace at the home orientation, a 3-D volume in mm^3
  over (x, y, z), 26^3 grid nodes, its cells along the boundary by linear margins
  (``cell_rule``).
* :func:`constant_orientation_workspace`: the same at any fixed orientation;
  :func:`orientation_workspace`: the rad^3 volume over (tilt_x, tilt_y,
  torsion) at a fixed position; :func:`workspace_6d`: the 6-D volume in
  mm^3 rad^3 over the pose coordinates above by randomised quasi-Monte-Carlo,
  with a Student-t confidence interval over independent scramblings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import qmc
from scipy.stats import t as student_t

from kinematics import kernels
from kinematics.algebra import unique_rows, wrap_angle
from kinematics.base import (
    DesignVariable,
    FixedParameter,
    Mechanism,
    check_positive,
    check_range,
    orientation_measure,
    sort_poses,
)
from kinematics.conditioning import inverse_condition_number


def _joint_angles(separation_deg: float, centres_deg: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """Angles (rad, (6,)) of joints ``centre + sign * separation / 2``."""
    return np.radians(centres_deg + signs * 0.5 * separation_deg)


#: leg order: pair centre and side of the base joint and of the platform joint of each leg (deg)
_BASE_CENTRES = np.array([0.0, 0.0, 120.0, 120.0, 240.0, 240.0])
_BASE_SIGNS = np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0])
_PLATFORM_CENTRES = np.array([-60.0, 60.0, 60.0, 180.0, 180.0, 300.0])
_PLATFORM_SIGNS = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])


def _hat(w: np.ndarray) -> np.ndarray:
    """Skew matrices (N, 3, 3) of vectors (N, 3): ``hat(w) v = w x v``."""
    zero = np.zeros(w.shape[0])
    return np.stack(
        [
            np.stack([zero, -w[:, 2], w[:, 1]], axis=-1),
            np.stack([w[:, 2], zero, -w[:, 0]], axis=-1),
            np.stack([-w[:, 1], w[:, 0], zero], axis=-1),
        ],
        axis=-2,
    )


def _tilt_terms(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``sin t / t``, ``(1 - cos t) / t^2`` and ``(t - sin t) / t^3`` (each (N,)), stable at t = 0."""
    a = np.sinc(theta / np.pi)
    b = 0.5 * np.sinc(theta / (2.0 * np.pi)) ** 2
    small = theta < 1e-3
    t2 = np.where(small, theta * theta, 0.0)
    safe = np.where(small, 1.0, theta)
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0, (safe - np.sin(safe)) / safe**3)
    return a, b, c


def _one_orientation(poses: np.ndarray) -> bool:
    """True when every row of ``poses`` (N > 1, 6) has the same (finite) angles: a grid at one
    orientation, whose rotation is computed once (the constant-orientation workspace)."""
    angles = poses[:, 3:6]
    return poses.shape[0] > 1 and bool(np.all(angles == angles[0]))


def rotation(poses: np.ndarray) -> np.ndarray:
    """``R = Exp([w]x) R_z(torsion)`` (N, 3, 3) of poses (N, 6) (module docstring; rad).

    When every row has the same angles the result is one matrix broadcast (read-only).
    """
    poses = np.asarray(poses, dtype=float)
    if _one_orientation(poses):
        return np.broadcast_to(rotation(poses[:1]), (poses.shape[0], 3, 3))
    w = np.zeros((poses.shape[0], 3))
    w[:, 0], w[:, 1] = poses[:, 3], poses[:, 4]
    theta = np.hypot(w[:, 0], w[:, 1])
    a, b, _ = _tilt_terms(theta)
    hat = _hat(w)
    tilt = np.eye(3) + a[:, None, None] * hat + b[:, None, None] * (hat @ hat)  # Rodrigues
    cs, sn = np.cos(poses[:, 5]), np.sin(poses[:, 5])
    zero, one = np.zeros_like(cs), np.ones_like(cs)
    rz = np.stack(
        [np.stack([cs, -sn, zero], -1), np.stack([sn, cs, zero], -1), np.stack([zero, zero, one], -1)], axis=-2
    )
    return tilt @ rz


def angular_velocity_map(poses: np.ndarray) -> np.ndarray:
    """``M`` (N, 3, 3) with ``omega = M (tilt_x_dot, tilt_y_dot, torsion_dot)`` (rad/s per rad/s).

    Columns: the left Jacobian of SO(3) ``J_l(w) = I + (1 - cos t)/t^2 [w]x + (t - sin t)/t^3 [w]x^2``
    applied to x and y (the tilt vector's rate), and the platform normal ``Exp(w) k`` (torsion).
    One matrix broadcast (read-only) when every row has the same angles.
    """
    poses = np.asarray(poses, dtype=float)
    if _one_orientation(poses):
        return np.broadcast_to(angular_velocity_map(poses[:1]), (poses.shape[0], 3, 3))
    w = np.zeros((poses.shape[0], 3))
    w[:, 0], w[:, 1] = poses[:, 3], poses[:, 4]
    theta = np.hypot(w[:, 0], w[:, 1])
    a, b, c = _tilt_terms(theta)
    hat = _hat(w)
    hat2 = hat @ hat
    left = np.eye(3) + b[:, None, None] * hat + c[:, None, None] * hat2
    normal = (np.eye(3) + a[:, None, None] * hat + b[:, None, None] * hat2)[:, :, 2]
    return np.concatenate([left[:, :, :2], normal[:, :, None]], axis=2)


def canonical_orientation(poses: np.ndarray) -> np.ndarray:
    """The same poses (N, 6) with tilt in [0, pi] and torsion in (-pi, pi].

    A tilt vector of length ``t > pi`` is the rotation by ``t - 2 pi`` about the
    same axis; torsion is periodic.
    """
    out = np.array(poses, dtype=float, copy=True)
    theta = np.hypot(out[:, 3], out[:, 4])
    turns = np.round(theta / (2 * np.pi))
    new = np.abs(theta - 2 * np.pi * turns)
    flip = np.where(theta - 2 * np.pi * turns < 0, -1.0, 1.0)
    scale = np.where(theta > 0, flip * new / np.where(theta > 0, theta, 1.0), 1.0)
    out[:, 3] *= scale
    out[:, 4] *= scale
    out[:, 5] = wrap_angle(out[:, 5])
    return out


class GoughStewart(Mechanism):
    """Gough–Stewart 6-UPS platform with semi-regular hexagonal joint layouts.

    Parameters
    ----------
    r_base, r_platform : float
        Radii of the base and platform joint circles (mm), > 0.
    sep_base, sep_platform : float
        Angle between the two joints of a pair (deg), in (0, 120).
    height : float
        Nominal height (mm) > 0: the home pose is ``(0, 0, height, 0, 0, 0)``; with
        ``cone_reference="home"`` the joints' axes are the home leg directions.
    q_min, q_max : float
        Leg stroke (mm), ``0 < q_min < q_max``.
    cone_base, cone_platform : float
        Largest passive-joint cone angle (deg), in (0, 180), at the base (U) and
        platform (S) joints.
    cone_reference : {"home", "normal"}
        Axis each cone angle is measured from (module docstring).
    homogenising : {"platform", "base", "mean"}
        Characteristic length dividing the angular Jacobian columns: ``r_platform``
        (default: the moment arm of the platform joints), ``r_base``, or their mean.
    """

    name = "gough_stewart"
    dof = 6
    pose_names = ("x", "y", "z", "tilt_x", "tilt_y", "torsion")
    angular = (False, False, False, True, True, True)
    length_unit = "mm"
    angle_params = ("sep_base", "sep_platform", "cone_base", "cone_platform")

    #: the pipeline's ``mechanism.fixed`` values and their ranges (``default_fixed`` derives from them)
    fixed_parameters = (
        FixedParameter("r_base", 400.0, 10.0, 10000.0, "mm"),
        FixedParameter("q_min", 600.0, 10.0, 20000.0, "mm"),
        FixedParameter("q_max", 900.0, 10.0, 20000.0, "mm"),
        FixedParameter("cone_base", 45.0, 1.0, 179.0, "deg"),
        FixedParameter("cone_platform", 45.0, 1.0, 179.0, "deg"),
        FixedParameter("cone_reference", "home", choices=("home", "normal")),
        FixedParameter("homogenising", "platform", choices=("platform", "base", "mean")),
    )
    #: 32^3 nodes: the constant-orientation default samples (x, y, z)
    default_nodes = 32**3
    #: linear margins at 26^3 nodes (the constant-orientation grid; a 6-D one keeps one plane per
    #: cell): V, GDI and eta within 0.1 % on the 13 designs of docs/accuracy.md (at most 0.085 %,
    #: at about 1.8x the cost of the cell-centre count at 32^3), where one plane per cell at 32^3
    #: cost about 2.6x; at 22^3 and 24^3 V misses on 3 and 2 of them (0.131 %, 0.115 %)
    cell_rule = "margins"
    grid_nodes = 26**3
    min_resolution = 16

    #: ``sep_base`` stops at 60 deg: (sep_base, sep_platform) and (120 - sep_base, 120 - sep_platform)
    #: are the same joints relabelled and turned by 60 deg, so the upper half would repeat the lower
    design_variables = (
        DesignVariable("r_platform", 150.0, 400.0, "mm"),
        DesignVariable("sep_base", 10.0, 60.0, "deg"),
        DesignVariable("sep_platform", 10.0, 110.0, "deg"),
        DesignVariable("height", 550.0, 850.0, "mm"),
    )

    def __init__(
        self,
        r_base: float,
        r_platform: float,
        sep_base: float,
        sep_platform: float,
        height: float,
        q_min: float = 600.0,
        q_max: float = 900.0,
        cone_base: float = 45.0,
        cone_platform: float = 45.0,
        cone_reference: str = "home",
        homogenising: str = "platform",
    ) -> None:
        owner = "GoughStewart"
        self.r_base = check_positive(owner, "r_base", r_base)
        self.r_platform = check_positive(owner, "r_platform", r_platform)
        self.height = check_positive(owner, "height", height)
        self.q_min, self.q_max = check_range(owner, "q_min", q_min, "q_max", q_max)
        for name, value in (("sep_base", sep_base), ("sep_platform", sep_platform)):
            v = check_positive(owner, name, value)
            if v >= 120.0:
                raise ValueError(f"{owner}: parameter '{name}' must be in (0, 120) degrees; got {value!r}")
        for name, value in (("cone_base", cone_base), ("cone_platform", cone_platform)):
            v = check_positive(owner, name, value)
            if v >= 180.0:
                raise ValueError(f"{owner}: parameter '{name}' must be in (0, 180) degrees; got {value!r}")
        for name, value, allowed in (
            ("cone_reference", cone_reference, ("home", "normal")),
            ("homogenising", homogenising, ("platform", "base", "mean")),
        ):
            if value not in allowed:
                raise ValueError(f"{owner}: parameter '{name}' must be one of {', '.join(allowed)}; got {value!r}")
        self.sep_base, self.sep_platform = float(sep_base), float(sep_platform)
        self.cone_base, self.cone_platform = float(cone_base), float(cone_platform)
        self.cone_reference, self.homogenising = cone_reference, homogenising
        self._params = {
            "r_base": self.r_base,
            "r_platform": self.r_platform,
            "sep_base": self.sep_base,
            "sep_platform": self.sep_platform,
            "height": self.height,
            "q_min": self.q_min,
            "q_max": self.q_max,
            "cone_base": self.cone_base,
            "cone_platform": self.cone_platform,
            "cone_reference": cone_reference,
            "homogenising": homogenising,
        }
        ang_b = _joint_angles(self.sep_base, _BASE_CENTRES, _BASE_SIGNS)
        ang_p = _joint_angles(self.sep_platform, _PLATFORM_CENTRES, _PLATFORM_SIGNS)
        #: base joints b_i (6, 3), mm, base frame
        self.base = self.r_base * np.column_stack([np.cos(ang_b), np.sin(ang_b), np.zeros(6)])
        #: platform joints p_i (6, 3), mm, platform frame
        self.platform = self.r_platform * np.column_stack([np.cos(ang_p), np.sin(ang_p), np.zeros(6)])
        home = self.platform + np.array([0.0, 0.0, self.height]) - self.base
        home_axes = home / np.linalg.norm(home, axis=1, keepdims=True)
        normal = np.tile([0.0, 0.0, 1.0], (6, 1))
        self._starts: dict[tuple[int, object], np.ndarray] = {}
        #: joint axes (6, 3): base ones in the base frame, platform ones in the platform frame
        self.base_axes = home_axes if cone_reference == "home" else normal
        self.platform_axes = home_axes if cone_reference == "home" else normal

    # ---------------------------------------------------------- properties
    @property
    def home_pose(self) -> np.ndarray:
        """``(0, 0, height, 0, 0, 0)`` (mm, rad), shape (6,)."""
        return np.array([0.0, 0.0, self.height, 0.0, 0.0, 0.0])

    @property
    def characteristic_length(self) -> float:
        """Length (mm) dividing the angular Jacobian columns (reading ``homogenising``).

        Default ``r_platform``: ``|R p_i|``, the moment arm of every platform joint, so an
        angular column divided by it is the leg speed per unit speed of the joints.
        """
        return {"platform": self.r_platform, "base": self.r_base, "mean": 0.5 * (self.r_base + self.r_platform)}[
            self.homogenising
        ]

    @property
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """``q_min <= q_i <= q_max`` (mm)."""
        return np.full(6, self.q_min), np.full(6, self.q_max)

    @property
    def default_orientation(self) -> tuple[float, float]:
        """(0, 0): the constant-orientation workspace at the home orientation (a 3-D volume, mm^3).

        A full 6-D grid is too costly for a GA; pass an orientation range (rad) to
        :func:`kinematics.workspace.evaluate` for a 6-D grid, or use :func:`workspace_6d`.
        """
        return (0.0, 0.0)

    def pose_bounds(self, orientation: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Box (mm, rad) containing the upper workspace at orientations in ``orientation``.

        ``c = b_i + L_i - R p_i`` for every leg i. The leg ``L_i`` (length <= q_max) lies
        in the cone of half-angle ``cone_base`` about the base axis ``a_i``, so along a
        unit direction d, ``L_i . d <= q_max cos(max(angle(a_i, d) - cone_base, 0))``,
        and ``|(R p_i) . d| <= r_platform`` (vertically ``<= r_platform sin(tilt)``);
        hence ``c . d <= min_i (b_i . d + q_max cos(...) + arm)`` for d = +-x, +-y, +z,
        and ``c_z >= max_i q_min cos(min(angle(a_i, k) + cone_base, pi/2)) - arm``.
        The orientation box's largest tilt is ``sqrt(2) max(|lo|, |hi|)``.
        """
        lo, hi = float(orientation[0]), float(orientation[1])
        tilt_max = min(math.sqrt(2.0) * max(abs(lo), abs(hi)), math.pi)
        drop = self.r_platform * (math.sin(tilt_max) if tilt_max < math.pi / 2 else 1.0)
        cone = math.radians(self.cone_base)
        directions = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 1.0]])
        angle = np.arccos(np.clip(self.base_axes @ directions.T, -1.0, 1.0))  # (6 legs, 5 directions)
        reach = self.q_max * np.cos(np.clip(angle - cone, 0.0, None))
        arm = np.array([self.r_platform] * 4 + [drop])
        upper = np.min(self.base @ directions.T + reach + arm, axis=0)
        from_vertical = np.minimum(angle[:, 4] + cone, math.pi / 2)
        z_lo = max(float(np.max(self.q_min * np.cos(from_vertical))) - drop, 0.0)
        return (
            np.array([-upper[1], -upper[3], z_lo, lo, lo, lo]),
            np.array([upper[0], upper[2], max(upper[4], z_lo), hi, hi, hi]),
        )

    def reference_volume(self, orientation: tuple[float, float]) -> float:
        """``V* = pi q_max^3`` times the orientation box's measure (mm^3, or mm^3 rad^3).

        The cylinder of radius and height ``q_max`` about the base axis: every platform
        centre at zero tilt lies at ``0 < z <= q_max``, and within ``q_max + r_platform -
        r_base cos(g/2)`` of the axis (:meth:`pose_bounds`). A robot size set by the
        stroke alone, so that at a fixed stroke SURI ranks designs by V; SURI stays
        well below 1 (about 0.13 at the largest workspaces of the default design box,
        ``docs/gough_stewart.md``).
        """
        return math.pi * self.q_max**3 * orientation_measure(orientation, 3)

    def plot_slice(self, orientation: tuple[float, float]) -> tuple[dict[str, float], tuple[int, int], str]:
        """The vertical (x, z) plane through the base centre (y = 0), angles at the middle of
        ``orientation``."""
        mid = 0.5 * (float(orientation[0]) + float(orientation[1]))
        fixed = {"y": 0.0, "tilt_x": mid, "tilt_y": mid, "torsion": mid}
        return fixed, (0, 2), f"y = 0 mm, tilt = torsion = {np.degrees(mid):.1f}°"

    # ------------------------------------------------------------ geometry
    def _legs(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Arms ``R p_i`` and legs ``c + R p_i - b_i``, each (N, 6, 3), mm, base frame."""
        if _one_orientation(poses):  # one orientation: the arms R p_i once
            arms = np.broadcast_to(self._legs(poses[:1])[0], (poses.shape[0], 6, 3))
        else:
            arms = (rotation(poses) @ self.platform.T).transpose(0, 2, 1)
        legs = arms + poses[:, None, 0:3] - self.base
        return arms, legs

    def platform_points(self, poses: np.ndarray) -> np.ndarray:
        """Platform joints ``P_i = c + R p_i`` (N, 6, 3), mm, base frame."""
        poses = self._check_poses(poses)
        arms, _ = self._legs(poses)
        return arms + poses[:, None, 0:3]

    def leg_vectors(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Leg lengths ``q_i`` (N, 6) (mm) and unit vectors ``u_i`` (N, 6, 3), base frame."""
        poses = self._check_poses(poses)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            _, legs = self._legs(poses)
            q = np.linalg.norm(legs, axis=-1)
            return q, legs / q[..., None]

    def cone_angles(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Passive-joint cone angles (rad), base and platform, each (N, 6).

        Angle between ``u_i`` and the base joint's axis, and between ``u_i`` and the
        platform joint's axis carried by R (``cone_reference``).
        """
        poses = self._check_poses(poses)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            _, unit = self.leg_vectors(poses)
            rot = rotation(poses)
            moved = np.einsum("nij,kj->nki", rot, self.platform_axes)
            base = np.arccos(np.clip(np.einsum("nki,ki->nk", unit, self.base_axes), -1.0, 1.0))
            plat = np.arccos(np.clip(np.einsum("nki,nki->nk", unit, moved), -1.0, 1.0))
        return base, plat

    def within_joint_limits(self, poses: np.ndarray) -> np.ndarray:
        """Every base cone angle ``<= cone_base`` and platform cone angle ``<= cone_platform`` (N,) bool."""
        base, plat = self.cone_angles(poses)
        return np.all(base <= math.radians(self.cone_base), axis=1) & np.all(
            plat <= math.radians(self.cone_platform), axis=1
        )

    def _kernel_arguments(self, poses: np.ndarray) -> tuple:
        """The leading arguments of the compiled leg kernels (:func:`_reachable_jacobians`,
        :func:`_margins`): the poses, their one rotation when they share it (else shape
        (0, 3): 2-D either way, so that each kernel compiles once), the joints and joint axes,
        the leg range (mm)."""
        poses = np.ascontiguousarray(poses, dtype=float)
        rot = np.ascontiguousarray(rotation(poses[:1])[0]) if _one_orientation(poses) else np.empty((0, 3))
        joints = (self.base, self.platform, self.base_axes, self.platform_axes)
        return (poses, rot, *(np.ascontiguousarray(a) for a in joints), self.q_min, self.q_max)

    def constraint_margins(self, poses: np.ndarray) -> np.ndarray:
        """Margins of the leg range, ``q_i - q_min`` and ``q_max - q_i`` (mm), and of the cone
        limits, ``cos(angle) - cos(limit)`` of each base and platform cone angle
        (:meth:`cone_angles`; >= 0 exactly where the angle is within its limit): (N, 24);
        legs are always real."""
        poses = self._check_poses(poses)
        if kernels.compiled():
            return _margins(
                *self._kernel_arguments(poses),
                math.cos(math.radians(self.cone_base)),
                math.cos(math.radians(self.cone_platform)),
            )
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            _, legs = self._legs(poses)
            q = np.sqrt(np.einsum("nki,nki->nk", legs, legs))
            unit = legs / q[..., None]
            rot = rotation(poses)
            base = np.einsum("nki,ki->nk", unit, self.base_axes)
            if _one_orientation(poses):
                plat = unit @ (rot[0] @ self.platform_axes.T)  # (N, 6, 6): the diagonal is wanted
                plat = np.einsum("nkk->nk", plat)
            else:
                plat = np.einsum("nki,nki->nk", unit, np.einsum("nij,kj->nki", rot, self.platform_axes))
        return np.hstack(
            [
                q - self.q_min,
                self.q_max - q,
                base - math.cos(math.radians(self.cone_base)),
                plat - math.cos(math.radians(self.cone_platform)),
            ]
        )

    def reachable_inverse_condition(self, poses: np.ndarray, length: float | None = None) -> np.ndarray | None:
        """Compiled membership test (see the base class): IK, leg range, cone limits and
        ``J diag(s)`` per pose in one loop (:func:`_reachable_jacobians`), then ``1/kappa`` of the
        poses inside by :func:`kinematics.conditioning.inverse_condition_number`; None when the
        numpy reference is selected."""
        if not kernels.compiled():
            return None
        poses = np.ascontiguousarray(poses, dtype=float)
        jac = _reachable_jacobians(
            *self._kernel_arguments(poses),
            math.radians(self.cone_base),
            math.radians(self.cone_platform),
            self.angular_scale(length),
        )
        ic = np.full(poses.shape[0], np.nan)
        inside = np.isfinite(jac[:, 0, 0])
        # 6 x 6: batched LAPACK SVD, the numpy path's own conditioning (the compiled 2-4 x 4 one does
        # not apply, and a per-pose SVD inside the loop was twice as slow)
        ic[inside] = inverse_condition_number(jac[inside])
        return ic

    def twist_jacobian(self, poses: np.ndarray) -> np.ndarray:
        """Inverse kinematic Jacobian in twist form (N, 6, 6): rows ``[u_i^T, (R p_i x u_i)^T]``.

        ``q_dot = J_twist (c_dot, omega)`` with omega the platform's angular velocity
        (rad/s) in the base frame (Merlet 2006, Sec. 5.2). Units mm/mm and mm/rad.
        """
        poses = self._check_poses(poses)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return self._twist_jacobian(poses)

    def _twist_jacobian(self, poses: np.ndarray) -> np.ndarray:
        arms, legs = self._legs(poses)
        unit = legs / np.linalg.norm(legs, axis=-1, keepdims=True)
        return np.concatenate([unit, np.cross(arms, unit)], axis=-1)

    # ------------------------------------------------------------- kernels
    def _inverse(self, poses: np.ndarray) -> np.ndarray:
        """Leg lengths ``q_i = |c + R p_i - b_i|`` (N, 6), mm (Merlet 2006, eq. 4.1)."""
        _, legs = self._legs(poses)
        return np.linalg.norm(legs, axis=-1)

    def _lengths_and_jacobian(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``q`` (N, 6) and ``J`` (N, 6, 6) of :meth:`_inverse` and :meth:`_jacobian`, sharing the legs."""
        arms, legs = self._legs(poses)
        q = np.linalg.norm(legs, axis=-1)
        unit = legs / q[..., None]
        jac = np.concatenate([unit, np.cross(arms, unit) @ angular_velocity_map(poses)], axis=-1)
        return q, jac

    def _constraints_jacobian(self, poses: np.ndarray, q: np.ndarray) -> np.ndarray:
        """``d(|L_i|^2 - q_i^2) / d pose = 2 q_i J_i`` (N, 6, 6), mm^2 per pose unit."""
        lengths, jac = self._lengths_and_jacobian(poses)
        return 2.0 * lengths[..., None] * jac

    def _jacobian(self, poses: np.ndarray) -> np.ndarray:
        """``J = J_twist diag(I, M)`` (N, 6, 6): ``d q / d (x, y, z, tilt_x, tilt_y, torsion)``.

        ``M`` maps the rates of the orientation coordinates to omega
        (:func:`angular_velocity_map`); at zero tilt ``M = I``.
        """
        twist = self._twist_jacobian(poses)
        out = twist.copy()
        out[:, :, 3:] = twist[:, :, 3:] @ angular_velocity_map(poses)
        return out

    # --------------------------------------------------- forward kinematics
    def _newton(self, q: np.ndarray, starts: np.ndarray, iterations: int = 30) -> np.ndarray:
        """Newton's method on ``q_i(pose) - q_i = 0`` (mm) from each start (K, 6); converged poses.

        Steps solve ``J step = residual`` with the analytic ``J`` (:meth:`_jacobian`).
        A start is dropped when its step or Jacobian is not finite, or when its
        position leaves a ball of ``10 (q_max + r_base)`` (diverged). Returned: the
        poses (k, 6) whose residual is below ``1e-10 (1 + q_i)`` mm, in canonical
        orientation (:func:`canonical_orientation`), in start order. Compiled
        (:func:`_newton_kernel`, one start at a time) unless the numpy reference is selected
        (:func:`kinematics.kernels.reference_kernels`); both take the same steps.
        """
        if kernels.compiled():
            x = _newton_kernel(
                np.ascontiguousarray(starts, dtype=float),
                np.ascontiguousarray(q, dtype=float),
                np.ascontiguousarray(self.base),
                np.ascontiguousarray(self.platform),
                int(iterations),
                10.0 * (self.q_max + self.r_base),
            )
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                x = canonical_orientation(x)
                lengths = self._inverse(x)
            ok = np.isfinite(lengths).all(axis=1) & np.all(np.abs(lengths - q) <= 1e-10 * (1.0 + q), axis=1)
            return x[ok]
        x = np.array(starts, dtype=float, copy=True)
        active = np.isfinite(x).all(axis=1)
        converged = np.zeros(x.shape[0], dtype=bool)
        far = 10.0 * (self.q_max + self.r_base)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            for _ in range(iterations):
                idx = np.nonzero(active)[0]
                if idx.size == 0:
                    break
                lengths, jac = self._lengths_and_jacobian(x[idx])
                residual = lengths - q
                good = np.isfinite(jac).all(axis=(1, 2)) & np.isfinite(residual).all(axis=1)
                good[good] = np.abs(np.linalg.det(jac[good])) > 1e-300
                step = np.zeros((idx.size, 6))
                step[good] = np.linalg.solve(jac[good], residual[good][..., None])[..., 0]
                x[idx] -= step
                small = np.max(np.abs(step) / (1.0 + np.abs(x[idx])), axis=1) < 1e-13
                lost = ~good | ~np.isfinite(x[idx]).all(axis=1) | (np.linalg.norm(x[idx, :3], axis=1) > far)
                active[idx[lost | small]] = False
                converged[idx[small & ~lost]] = True
            x = canonical_orientation(x)
            lengths = self._inverse(x)
        ok = np.isfinite(lengths).all(axis=1) & np.all(np.abs(lengths - q) <= 1e-10 * (1.0 + q), axis=1)
        return x[ok]

    def forward_from(self, q: np.ndarray, guess: np.ndarray, iterations: int = 30) -> np.ndarray:
        """One forward-kinematics solution by Newton's method from ``guess``.

        Parameters
        ----------
        q : array_like, shape (6,)
            Leg lengths (mm).
        guess : array_like, shape (6,)
            Starting pose (mm, rad), e.g. the last known pose of a trajectory.
        iterations : int
            Largest number of Newton steps.

        Returns
        -------
        ndarray, shape (6,)
            The pose Newton converges to (tilt in [0, pi], torsion in (-pi, pi]), or a
            row of NaN when it does not converge (leg residual > 1e-10 (1 + q) mm).
        """
        q = self._check_actuators(q)
        sols = self._newton(q, self._check_poses(guess), iterations)
        return sols[0] if len(sols) else np.full(6, np.nan)

    #: Sobol starts of :meth:`forward` (besides the home pose and its mirror)
    forward_starts: int = 64

    def assembly_starts(self, n: int = 1024, seed: int = 0) -> np.ndarray:
        """Deterministic starting poses (n + 2, 6) for the multi-start forward kinematics (mm, rad).

        The home pose, its mirror through the base plane, then ``n`` (a power of 2)
        points of a scrambled Sobol sequence (``seed``) over the box of
        :meth:`pose_bounds` at tilts and torsions in [-pi/2, pi/2], with z over
        ``[-z_hi, z_hi]`` (upper and mirrored lower assembly modes).
        """
        if n < 1 or n & (n - 1):
            raise ValueError(f"GoughStewart: n_starts must be a power of 2 >= 1; got {n!r}")
        key = (int(n), seed)
        if key not in self._starts:  # a pure function of the design: computed once per design
            self._starts[key] = self._make_starts(int(n), seed)
            self._starts[key].flags.writeable = False
        return self._starts[key]

    def _make_starts(self, n: int, seed: int) -> np.ndarray:
        lo, hi = self.pose_bounds((-np.pi / 2, np.pi / 2))
        lo = lo.copy()
        lo[2] = -hi[2]
        sobol = qmc.Sobol(6, scramble=True, seed=seed).random(n)
        mirror = self.home_pose * np.array([1, 1, -1, 1, 1, 1])
        return np.vstack([self.home_pose, mirror, lo + (hi - lo) * sobol])

    def assembly_modes(self, q: np.ndarray, n_starts: int = 1024, seed: int = 0) -> np.ndarray:
        """Several assembly modes (k, 6) of leg lengths ``q`` (mm): Newton from :meth:`assembly_starts`.

        Every returned pose reproduces ``q`` to ``1e-10 (1 + q)`` mm. The set is what
        the starts reach, not a certified complete one (a general 6-6 platform has up
        to 40 modes, Dietmaier 1998): more starts (``n_starts``) or other ``seed``
        values find more. Sorted by :func:`~kinematics.base.sort_poses`.
        """
        q = self._check_actuators(q)
        if not np.all(np.isfinite(q)):
            return np.empty((0, 6))
        return sort_poses(unique_rows(self._newton(q, self.assembly_starts(int(n_starts), seed))))

    def _forward(self, q: np.ndarray) -> np.ndarray:
        """:meth:`assembly_modes` from :attr:`forward_starts` starts; :meth:`forward` checks and sorts."""
        return unique_rows(self._newton(q, self.assembly_starts(self.forward_starts, 0)))


# ------------------------------------------------------------ workspaces
def constant_orientation_workspace(
    mech: GoughStewart, tilt_x: float = 0.0, tilt_y: float = 0.0, torsion: float = 0.0, **options
):
    """Constant-orientation workspace: the mm^3 volume over (x, y, z) at one orientation (rad).

    ``options`` go to :func:`kinematics.workspace.evaluate` (resolution,
    min_inverse_condition, length, return_samples, error_estimate). SURI is
    against ``pi r_base^2 (q_max - q_min)`` (:meth:`GoughStewart.reference_volume` at (0, 0)).
    """
    from kinematics.workspace import evaluate

    angles = (float(tilt_x), float(tilt_y), float(torsion))
    fixed = dict(zip(("tilt_x", "tilt_y", "torsion"), angles))
    ev = evaluate(mech, orientation=(min(angles), max(angles)), fixed=fixed, **options)
    reference = mech.reference_volume((0.0, 0.0))
    return replace(ev, reference_volume=reference, suri=ev.volume / reference)


def orientation_workspace(
    mech: GoughStewart,
    position: tuple[float, float, float],
    orientation: tuple[float, float] = (-np.pi / 2, np.pi / 2),
    **options,
):
    """Orientation workspace at a fixed platform centre ``position`` (mm): the rad^3 volume over
    (tilt_x, tilt_y, torsion) within the box ``orientation`` (rad) on every angle.

    SURI is the fraction of the orientation box (the reference is its measure).
    """
    from kinematics.workspace import evaluate

    fixed = dict(zip(("x", "y", "z"), (float(v) for v in position)))
    ev = evaluate(mech, orientation=orientation, fixed=fixed, **options)
    reference = orientation_measure(ev.orientation, 3)
    return replace(ev, reference_volume=reference, suri=ev.volume / reference)


@dataclass(frozen=True)
class QuasiMonteCarloVolume:
    """A 6-D workspace volume by randomised quasi-Monte-Carlo (:func:`workspace_6d`).

    ``volume`` (mm^3 rad^3 over (x, y, z, tilt_x, tilt_y, torsion)) is the mean over
    ``replicates`` independent scramblings; ``volume_ci`` its two-sided
    ``confidence`` interval (Student t over the replicates). ``gdi`` likewise
    (the mean of 1/kappa over the workspace). ``box_lower``/``box_upper`` is the reference box
    sampled, ``box_volume`` its measure.
    """

    volume: float
    volume_ci: tuple[float, float]
    gdi: float
    gdi_ci: tuple[float, float]
    fraction: float
    box_lower: tuple[float, ...]
    box_upper: tuple[float, ...]
    box_volume: float
    n_points: int
    replicates: int
    confidence: float
    unit: str = "mm³·rad³"


def workspace_6d(
    mech: GoughStewart,
    orientation: tuple[float, float] = (-np.radians(15), np.radians(15)),
    n_points: int = 2**14,
    replicates: int = 8,
    seed: int = 0,
    confidence: float = 0.95,
    min_inverse_condition: float = 0.01,
    length: float | None = None,
) -> QuasiMonteCarloVolume:
    """6-D workspace volume and GDI by randomised quasi-Monte-Carlo.

    Samples ``replicates`` independently scrambled Sobol sets of ``n_points``
    (a power of 2) each in the reference box ``pose_bounds(orientation)`` (x, y,
    z in mm; tilt_x, tilt_y, torsion in ``orientation``, rad) and applies the
    workspace's membership test (:func:`kinematics.workspace.membership`: leg
    range, cone limits, orientation box, ``1/kappa > min_inverse_condition``).
    Volume = box measure x inside fraction (mm^3 rad^3, in the tilt-vector /
    torsion coordinates: not the Haar measure of SO(3)); the confidence
    interval is the Student t interval over the replicates' estimates, which
    are independent and unbiased (Owen's scrambling).
    """
    from kinematics.workspace import membership

    if n_points < 2 or n_points & (n_points - 1):
        raise ValueError(f"workspace_6d: n_points must be a power of 2 >= 2; got {n_points!r}")
    if replicates < 2:
        raise ValueError(f"workspace_6d: replicates must be >= 2; got {replicates!r}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"workspace_6d: confidence must be in (0, 1); got {confidence!r}")
    orientation = (float(orientation[0]), float(orientation[1]))
    if not orientation[0] < orientation[1]:
        raise ValueError(f"workspace_6d: orientation must be (lo, hi) with lo < hi (rad); got {orientation!r}")
    lo, hi = mech.pose_bounds(orientation)
    box = float(np.prod(hi - lo))
    seeds = np.random.SeedSequence(seed).spawn(replicates)
    volumes, gdis = [], []
    for s in seeds:
        u = qmc.Sobol(6, scramble=True, seed=np.random.default_rng(s)).random(n_points)
        poses = lo + (hi - lo) * u
        inside, ic = membership(mech, poses, orientation, float(min_inverse_condition), length)
        volumes.append(box * inside.mean())
        gdis.append(float(ic[inside].mean()) if inside.any() else 0.0)
    volumes, gdis = np.array(volumes), np.array(gdis)
    tq = float(student_t.ppf(0.5 + 0.5 * confidence, replicates - 1))

    def interval(values: np.ndarray) -> tuple[float, float]:
        half = tq * values.std(ddof=1) / math.sqrt(len(values))
        return float(values.mean() - half), float(values.mean() + half)

    return QuasiMonteCarloVolume(
        volume=float(volumes.mean()),
        volume_ci=interval(volumes),
        gdi=float(gdis.mean()),
        gdi_ci=interval(gdis),
        fraction=float(volumes.mean() / box),
        box_lower=tuple(map(float, lo)),
        box_upper=tuple(map(float, hi)),
        box_volume=box,
        n_points=int(n_points),
        replicates=int(replicates),
        confidence=float(confidence),
    )


@kernels.jit
def _newton_kernel(starts, q, base, platform, iterations, far):
    """Compiled :meth:`GoughStewart._newton`: per start (K, 6), Newton on ``|c + R p_i - b_i| - q_i``
    (mm) with ``R = Exp([w]x) R_z(torsion)`` (:func:`rotation`) and the rows
    ``[u_i, ((R p_i) x u_i) M]`` of :meth:`GoughStewart._jacobian`, steps by Gaussian elimination
    with partial pivoting. Stops a start at a relative step below 1e-13, a zero pivot, a
    non-finite value or a position beyond ``far`` (mm). Returns the last iterates (K, 6); the
    caller keeps those whose leg residual is small."""
    count = starts.shape[0]
    out = starts.copy()
    rot = np.empty((3, 3))
    tilt = np.empty((3, 3))
    left = np.empty((3, 3))
    hat = np.empty((3, 3))
    hat2 = np.empty((3, 3))
    jac = np.empty((6, 7))
    for k in range(count):
        x = out[k]
        for _ in range(iterations):
            a, b, torsion = x[3], x[4], x[5]
            theta2 = a * a + b * b
            theta = math.sqrt(theta2)
            if theta < 1e-3:
                sa = 1.0 - theta2 / 6.0 + theta2 * theta2 / 120.0
                sb = 0.5 - theta2 / 24.0 + theta2 * theta2 / 720.0
                sc = 1.0 / 6.0 - theta2 / 120.0 + theta2 * theta2 / 5040.0
            else:
                sa = math.sin(theta) / theta
                sb = (1.0 - math.cos(theta)) / theta2
                sc = (theta - math.sin(theta)) / (theta2 * theta)
            hat[0, 0], hat[0, 1], hat[0, 2] = 0.0, 0.0, b
            hat[1, 0], hat[1, 1], hat[1, 2] = 0.0, 0.0, -a
            hat[2, 0], hat[2, 1], hat[2, 2] = -b, a, 0.0
            hat2[0, 0], hat2[0, 1], hat2[0, 2] = -b * b, a * b, 0.0
            hat2[1, 0], hat2[1, 1], hat2[1, 2] = a * b, -a * a, 0.0
            hat2[2, 0], hat2[2, 1], hat2[2, 2] = 0.0, 0.0, -theta2
            for r in range(3):
                for c in range(3):
                    eye = 1.0 if r == c else 0.0
                    tilt[r, c] = eye + sa * hat[r, c] + sb * hat2[r, c]
                    left[r, c] = eye + sb * hat[r, c] + sc * hat2[r, c]
            ct, st = math.cos(torsion), math.sin(torsion)
            for r in range(3):
                rot[r, 0] = tilt[r, 0] * ct + tilt[r, 1] * st
                rot[r, 1] = -tilt[r, 0] * st + tilt[r, 1] * ct
                rot[r, 2] = tilt[r, 2]
            for i in range(6):
                ax = rot[0, 0] * platform[i, 0] + rot[0, 1] * platform[i, 1] + rot[0, 2] * platform[i, 2]
                ay = rot[1, 0] * platform[i, 0] + rot[1, 1] * platform[i, 1] + rot[1, 2] * platform[i, 2]
                az = rot[2, 0] * platform[i, 0] + rot[2, 1] * platform[i, 1] + rot[2, 2] * platform[i, 2]
                lx, ly, lz = x[0] + ax - base[i, 0], x[1] + ay - base[i, 1], x[2] + az - base[i, 2]
                length = math.sqrt(lx * lx + ly * ly + lz * lz)
                ux, uy, uz = lx / length, ly / length, lz / length
                mx, my, mz = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
                jac[i, 0], jac[i, 1], jac[i, 2] = ux, uy, uz
                jac[i, 3] = mx * left[0, 0] + my * left[1, 0] + mz * left[2, 0]
                jac[i, 4] = mx * left[0, 1] + my * left[1, 1] + mz * left[2, 1]
                jac[i, 5] = mx * tilt[0, 2] + my * tilt[1, 2] + mz * tilt[2, 2]
                jac[i, 6] = length - q[i]
            # Gaussian elimination with partial pivoting on the augmented [J | residual]
            singular = False
            for col in range(6):
                pivot = col
                for r in range(col + 1, 6):
                    if abs(jac[r, col]) > abs(jac[pivot, col]):
                        pivot = r
                if not (abs(jac[pivot, col]) > 0.0):
                    singular = True
                    break
                if pivot != col:
                    for c in range(7):
                        jac[col, c], jac[pivot, c] = jac[pivot, c], jac[col, c]
                for r in range(col + 1, 6):
                    f = jac[r, col] / jac[col, col]
                    for c in range(col, 7):
                        jac[r, c] -= f * jac[col, c]
            if singular:
                break
            small = True
            finite = True
            for r in range(5, -1, -1):
                acc = jac[r, 6]
                for c in range(r + 1, 6):
                    acc -= jac[r, c] * jac[c, 6]
                jac[r, 6] = acc / jac[r, r]
            for j in range(6):
                x[j] -= jac[j, 6]
                if not math.isfinite(x[j]):
                    finite = False
                if abs(jac[j, 6]) >= 1e-13 * (1.0 + abs(x[j])):
                    small = False
            if not finite or math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) > far or small:
                break
    return out


@kernels.jit
def _rotation_and_rate_map(a, b, torsion, rot, rate):
    """``R`` of :func:`rotation` and ``M`` of :func:`angular_velocity_map` (each 3 x 3, written in
    place) for tilt vector (a, b) and torsion (rad)."""
    theta2 = a * a + b * b
    theta = math.sqrt(theta2)
    if theta < 1e-3:
        sa = 1.0 - theta2 / 6.0 + theta2 * theta2 / 120.0
        sb = 0.5 - theta2 / 24.0 + theta2 * theta2 / 720.0
        sc = 1.0 / 6.0 - theta2 / 120.0 + theta2 * theta2 / 5040.0
    else:
        sa = math.sin(theta) / theta
        sb = (1.0 - math.cos(theta)) / theta2
        sc = (theta - math.sin(theta)) / (theta2 * theta)
    hat = np.array([[0.0, 0.0, b], [0.0, 0.0, -a], [-b, a, 0.0]])
    hat2 = np.array([[-b * b, a * b, 0.0], [a * b, -a * a, 0.0], [0.0, 0.0, -theta2]])
    ct, st = math.cos(torsion), math.sin(torsion)
    for r in range(3):
        eye0 = 1.0 if r == 0 else 0.0
        eye1 = 1.0 if r == 1 else 0.0
        eye2 = 1.0 if r == 2 else 0.0
        t0 = eye0 + sa * hat[r, 0] + sb * hat2[r, 0]
        t1 = eye1 + sa * hat[r, 1] + sb * hat2[r, 1]
        t2 = eye2 + sa * hat[r, 2] + sb * hat2[r, 2]
        rot[r, 0] = t0 * ct + t1 * st
        rot[r, 1] = -t0 * st + t1 * ct
        rot[r, 2] = t2
        rate[r, 0] = eye0 + sb * hat[r, 0] + sc * hat2[r, 0]
        rate[r, 1] = eye1 + sb * hat[r, 1] + sc * hat2[r, 1]
        rate[r, 2] = t2


@kernels.inline_jit
def _leg(rot, pose, base, platform, base_axes, platform_axes, i):
    """Leg i at the pose (its position ``pose[:3]``, mm) and rotation ``rot``: the arm ``R p_i``
    (mm), the leg's length ``q_i`` (:meth:`GoughStewart._inverse`) and unit vector, and the
    cosines of its cone angles at the base and the platform joint
    (:meth:`GoughStewart.cone_angles`); the same operations as the numpy methods."""
    ax = rot[0, 0] * platform[i, 0] + rot[0, 1] * platform[i, 1] + rot[0, 2] * platform[i, 2]
    ay = rot[1, 0] * platform[i, 0] + rot[1, 1] * platform[i, 1] + rot[1, 2] * platform[i, 2]
    az = rot[2, 0] * platform[i, 0] + rot[2, 1] * platform[i, 1] + rot[2, 2] * platform[i, 2]
    lx, ly, lz = ax + pose[0] - base[i, 0], ay + pose[1] - base[i, 1], az + pose[2] - base[i, 2]
    length = math.sqrt(lx * lx + ly * ly + lz * lz)
    inverse = 1.0 / length if length > 0.0 else 0.0
    ux, uy, uz = lx * inverse, ly * inverse, lz * inverse
    cos_base = ux * base_axes[i, 0] + uy * base_axes[i, 1] + uz * base_axes[i, 2]
    mx = rot[0, 0] * platform_axes[i, 0] + rot[0, 1] * platform_axes[i, 1] + rot[0, 2] * platform_axes[i, 2]
    my = rot[1, 0] * platform_axes[i, 0] + rot[1, 1] * platform_axes[i, 1] + rot[1, 2] * platform_axes[i, 2]
    mz = rot[2, 0] * platform_axes[i, 0] + rot[2, 1] * platform_axes[i, 1] + rot[2, 2] * platform_axes[i, 2]
    return ax, ay, az, length, ux, uy, uz, cos_base, ux * mx + uy * my + uz * mz


@kernels.inline_jit
def _copy_into(target, source):
    """``target[:, :] = source`` (2-D, the same shape), element by element. Why: an array
    assigned to a slice makes numba compile its shape-mismatch message (string formatting),
    about 10 s of this module's compile on a machine without the cache (measured), for a copy."""
    for i in range(source.shape[0]):
        for j in range(source.shape[1]):
            target[i, j] = source[i, j]


@kernels.jit
def _reachable_jacobians(
    poses, one_rotation, base, platform, base_axes, platform_axes, q_min, q_max, cone_base, cone_platform, column_scale
):
    """Per pose (N, 6) (mm, rad): legs ``c + R p_i - b_i`` (:meth:`GoughStewart._inverse`) within
    ``q_min..q_max`` (mm), cone angles (rad) within ``cone_base`` / ``cone_platform``
    (:meth:`GoughStewart.within_joint_limits`), and ``J diag(column_scale)`` with the rows of
    :meth:`GoughStewart._jacobian`. ``one_rotation`` (3, 3): every pose's R when all share one
    orientation, else shape (0, 3). Returns (N, 6, 6), rows of NaN where the pose is out."""
    count = poses.shape[0]
    out = np.empty((count, 6, 6))
    rot = np.empty((3, 3))
    rate = np.empty((3, 3))
    if one_rotation.shape[0] == 3:
        _copy_into(rot, one_rotation)
        _rotation_and_rate_map(poses[0, 3], poses[0, 4], poses[0, 5], np.empty((3, 3)), rate)
    jac = np.empty((6, 6))
    for p in range(count):
        if not (np.isfinite(poses[p, 3]) and np.isfinite(poses[p, 4]) and np.isfinite(poses[p, 5])):
            out[p, :, :] = np.nan
            continue
        if one_rotation.shape[0] != 3:
            _rotation_and_rate_map(poses[p, 3], poses[p, 4], poses[p, 5], rot, rate)
        ok = True
        for i in range(6):
            ax, ay, az, length, ux, uy, uz, cos_base, cos_plat = _leg(
                rot, poses[p], base, platform, base_axes, platform_axes, i
            )
            if not (q_min <= length <= q_max):
                ok = False
                break
            if not (
                math.acos(min(max(cos_base, -1.0), 1.0)) <= cone_base
                and math.acos(min(max(cos_plat, -1.0), 1.0)) <= cone_platform
            ):
                ok = False
                break
            wx, wy, wz = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
            jac[i, 0], jac[i, 1], jac[i, 2] = ux * column_scale[0], uy * column_scale[1], uz * column_scale[2]
            for j in range(3):
                jac[i, 3 + j] = (wx * rate[0, j] + wy * rate[1, j] + wz * rate[2, j]) * column_scale[3 + j]
        if not ok:
            out[p, :, :] = np.nan
            continue
        _copy_into(out[p], jac)
    return out


@kernels.vector_jit
def _margins(poses, one_rotation, base, platform, base_axes, platform_axes, q_min, q_max, cos_base, cos_platform):
    """Kernel of :meth:`GoughStewart.constraint_margins` (the same operations, one pose at a time):
    per pose (N, 6) the 24 margins; ``one_rotation`` as in :func:`_reachable_jacobians`."""
    count = poses.shape[0]
    out = np.empty((count, 24))
    rot = np.empty((3, 3))
    rate = np.empty((3, 3))
    if one_rotation.shape[0] == 3:
        _copy_into(rot, one_rotation)
    for p in range(count):
        if one_rotation.shape[0] != 3:
            _rotation_and_rate_map(poses[p, 3], poses[p, 4], poses[p, 5], rot, rate)
        for i in range(6):
            _, _, _, length, _, _, _, base_joint, platform_joint = _leg(
                rot, poses[p], base, platform, base_axes, platform_axes, i
            )
            out[p, i] = length - q_min
            out[p, 6 + i] = q_max - length
            out[p, 12 + i] = base_joint - cos_base
            out[p, 18 + i] = platform_joint - cos_platform
    return out
