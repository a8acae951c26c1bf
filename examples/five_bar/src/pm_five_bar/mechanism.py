"""Planar five-bar (2-RR, actuated base revolutes) in pure numpy: an external pm-design mechanism.

Frame and units
---------------
Base frame with origin midway between the two actuated base joints
``A_1 = (-d/2, 0)`` and ``A_2 = (d/2, 0)``, x axis through them. Lengths in
mm, angles in rad. Pose ``(x, y)``: the end-effector point P, where the two
distal links meet. Actuators: the angles ``theta_1, theta_2`` of the proximal
links (length ``l1``) from the x axis, in (-pi, pi]. Each distal link
(length ``l2``) joins the elbow ``C_i = A_i + l1 (cos theta_i, sin theta_i)``
to P. Working mode "elbows out": the elbow of leg 1 lies to the left of the
line A_1 -> P, that of leg 2 to the right of A_2 -> P.

Closed-form workspace area
--------------------------
With no limit on the actuated angles and no dexterity limit
(``min_inverse_condition = 0``), P is reachable by leg i exactly when the
triangle ``A_i C_i P`` with sides ``l1``, ``l2`` and ``rho_i = |P - A_i|``
exists, i.e. by the triangle inequality when

    r = |l1 - l2|  <=  rho_i  <=  R = l1 + l2,

and then both elbow positions exist, so each working mode reaches the same
set. The workspace is therefore the intersection of two annuli of radii
``r..R`` around ``A_1`` and ``A_2``, whose centres are ``d`` apart. Write
``O_i`` for the disc of radius R around ``A_i`` and ``I_i`` for the one of
radius r; since ``I_i`` lies inside ``O_i``, inclusion-exclusion gives

    |(O_1 - I_1) ∩ (O_2 - I_2)| = |O_1 ∩ O_2| - |O_1 ∩ I_2| - |I_1 ∩ O_2| + |I_1 ∩ I_2|
                                = L(R, R, d) - 2 L(R, r, d) + L(r, r, d),

with ``L(a, b, d)`` the area of the lens of two discs of radii a, b whose
centres are d apart: 0 when ``d >= a + b``, ``pi min(a, b)^2`` when
``d <= |a - b|``, and otherwise two circular segments minus the kite of the
centres and the two crossing points,

    L = a^2 acos((d^2 + a^2 - b^2) / (2 d a)) + b^2 acos((d^2 + b^2 - a^2) / (2 d b))
        - 1/2 sqrt((-d + a + b)(d + a - b)(d - a + b)(d + a + b)).

:meth:`FiveBar.exact_area` evaluates this with pm-design's
:func:`kinematics.annuli.two_annuli_area` (the same two-annuli formula
serves its 2-RPR).

Singularities: the inverse-kinematic Jacobian ``J`` (``theta_dot = J p_dot``)
has an infinite row where leg i is stretched or folded (``rho_i = R`` or
``r``: the annuli's boundaries) and is singular where the two distal links
are aligned (inside the workspace); both have ``1/kappa = 0``, so the
pipeline's dexterity limit (``1/kappa > 0.01``) removes a thin band around
them and the area with the limit is below the closed form.
"""

from __future__ import annotations

import math

import numpy as np

from kinematics.annuli import two_annuli_area
from kinematics.base import DesignVariable, FixedParameter, Mechanism, check_positive


class FiveBar(Mechanism):
    """Planar five-bar with actuated base revolutes, elbows-out working mode.

    Parameters
    ----------
    l1 : float
        Proximal link length (mm), > 0.
    l2 : float
        Distal link length (mm), > 0.
    d : float
        Distance between the base joints (mm), ``0 < d < 2 (l1 + l2)`` (else
        the legs cannot meet).
    """

    name = "five_bar"
    dof = 2
    pose_names = ("x", "y")
    angular = (False, False)
    length_unit = "mm"

    design_variables = (
        DesignVariable("l1", 20.0, 60.0, "mm"),
        DesignVariable("l2", 20.0, 60.0, "mm"),
    )
    #: the fixed base length d (mechanism.fixed.d) and its range; default_fixed derives from it
    fixed_parameters = (FixedParameter("d", 40.0, 1.0, 1000.0, "mm"),)
    #: 2-D grid: 160 x 160 nodes per evaluation by default
    default_nodes = 160**2
    #: coarsest grid whose V and GDI stay within ~3 % of a fine one (measured in the example's tests)
    min_resolution = 48

    #: sign of the elbow angle of each leg: +1 turns from A_i -> P counter-clockwise ("elbows out")
    ELBOW = np.array([1.0, -1.0])

    def __init__(self, l1: float, l2: float, d: float) -> None:
        owner = "FiveBar"
        self.l1 = check_positive(owner, "l1", l1)
        self.l2 = check_positive(owner, "l2", l2)
        self.d = check_positive(owner, "d", d)
        if not self.d < 2.0 * (self.l1 + self.l2):
            raise ValueError(
                f"{owner}: parameter 'd' must be below 2 (l1 + l2) = {2 * (self.l1 + self.l2)} mm "
                f"(the legs cannot meet); got d={self.d}"
            )
        self._params = {"l1": self.l1, "l2": self.l2, "d": self.d}
        #: base joints A_1, A_2 (mm), shape (2, 2)
        self.base = np.array([[-0.5 * self.d, 0.0], [0.5 * self.d, 0.0]])

    # ------------------------------------------------------------ geometry
    @property
    def default_orientation(self) -> tuple[float, float]:
        """No angular pose variable; (0, 0) is a placeholder."""
        return (0.0, 0.0)

    def pose_bounds(self, orientation: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Box of the lens of the two discs of radius ``R = l1 + l2`` around A_1, A_2 (mm).

        ``|x| <= R - d/2`` and ``|y| <= sqrt(R^2 - d^2/4)``: the lens's extreme points.
        """
        reach = self.l1 + self.l2
        half_width = reach - 0.5 * self.d
        half_height = math.sqrt(reach**2 - 0.25 * self.d**2)
        return np.array([-half_width, -half_height]), np.array([half_width, half_height])

    def reference_volume(self, orientation: tuple[float, float]) -> float:
        """``V* = pi (l1 + l2)^2`` (mm^2): the disc one leg reaches, so ``V/V* <= 1``."""
        return math.pi * (self.l1 + self.l2) ** 2

    def exact_area(self) -> float:
        """Closed-form workspace area (mm^2) without dexterity limit (module docstring):
        ``L(R, R, d) - 2 L(R, r, d) + L(r, r, d)`` with ``r = |l1 - l2|``, ``R = l1 + l2``."""
        return two_annuli_area(self.d, abs(self.l1 - self.l2), self.l1 + self.l2)

    @property
    def characteristic_length(self) -> float:
        """``l1`` (mm); unused: the five-bar has no angular pose variable."""
        return self.l1

    @property
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """Unlimited actuated angles: ``-pi <= theta_i <= pi`` (rad)."""
        return np.full(2, -math.pi), np.full(2, math.pi)

    # ------------------------------------------------------------- kernels
    def _proximal(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``P - A_i`` and the proximal links ``C_i - A_i`` (mm), x and y columns, each (N, 2 legs).

        ``C_i`` is where the circles of radius l1 around A_i and l2 around P
        cross: with ``v = P - A_i`` and ``rho = |v|``, the law of cosines puts
        it at ``a = (l1^2 - l2^2 + rho^2) / (2 rho)`` along ``v`` and
        ``s_i sqrt(l1^2 - a^2)`` along ``v`` turned by +90 degrees (``s = (+1, -1)``:
        elbows out), i.e. ``C_i - A_i = f v + g rot90(v)`` with ``f = a / rho``,
        ``g = s_i sqrt(l1^2 - a^2) / rho``. Square roots only: trigonometric
        functions cost numpy 5-10x more per pose. NaN where ``rho`` is outside
        ``|l1 - l2|..l1 + l2`` (the square root of a negative number).
        """
        vx = poses[:, 0, None] - self.base[:, 0]
        vy = np.repeat(poses[:, 1, None], 2, axis=1)
        rho2 = vx * vx + vy * vy
        f = (self.l1**2 - self.l2**2 + rho2) / (2.0 * rho2)
        g = self.ELBOW * np.sqrt(self.l1**2 / rho2 - f * f)
        return vx, vy, f * vx - g * vy, f * vy + g * vx

    def _inverse(self, poses: np.ndarray) -> np.ndarray:
        """``theta_i = atan2(C_i - A_i)`` (rad) in (-pi, pi], shape (N, 2); NaN where unreachable.

        Equal to ``atan2(P - A_i) + s_i acos((l1^2 + rho_i^2 - l2^2) / (2 l1 rho_i))``, the
        law of cosines in the triangle ``A_i C_i P`` (see :meth:`_proximal`).
        """
        _, _, cx, cy = self._proximal(poses)
        return np.arctan2(cy, cx)

    def _elbows(self, theta: np.ndarray) -> np.ndarray:
        """Elbow points ``C_i = A_i + l1 (cos theta_i, sin theta_i)`` (mm), shape (..., 2, 2)."""
        return self.base + self.l1 * np.stack([np.cos(theta), np.sin(theta)], axis=-1)

    def _jacobian(self, poses: np.ndarray) -> np.ndarray:
        """Rows ``(P - C_i)^T / ((P - C_i) . t_i)`` (rad/mm), shape (N, 2, 2).

        ``t_i = rot90(C_i - A_i) = l1 (-sin theta_i, cos theta_i) = dC_i/dtheta_i``.
        Differentiating the closure ``|P - C_i|^2 = l2^2`` gives
        ``(P - C_i) . (dP - t_i dtheta_i) = 0``. A row is infinite where the leg
        is stretched or folded (``(P - C_i) . t_i = 0``).
        """
        vx, vy, cx, cy = self._proximal(poses)
        distal = np.stack([vx - cx, vy - cy], axis=-1)  # (N, 2 legs, 2): P - C_i
        denom = distal[..., 1] * cx - distal[..., 0] * cy
        jac = distal / denom[..., None]
        jac[denom == 0] = np.inf
        return jac

    def _forward(self, q: np.ndarray) -> np.ndarray:
        """Both intersections of the circles of radius ``l2`` around the elbows C_1, C_2 (mm).

        ``Mechanism.forward`` keeps those whose inverse kinematics (elbows
        out) gives back ``q``.
        """
        c1, c2 = self._elbows(np.asarray(q, dtype=float))
        span = c2 - c1
        dist = float(np.hypot(*span))
        if dist == 0.0 or dist > 2.0 * self.l2:
            return np.empty((0, 2))
        mid = c1 + 0.5 * span
        height = math.sqrt(max(self.l2**2 - 0.25 * dist**2, 0.0))
        normal = np.array([-span[1], span[0]]) / dist
        return np.array([mid + height * normal, mid - height * normal])
