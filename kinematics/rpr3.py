"""Planar 3-RPR parallel mechanism (seed 003: Nigam 2012, thesis).

Frame and units
---------------
Base frame with origin and axes chosen by the user (the thesis: origin at
A_1, x axis through A_2). Lengths in the unit of the coordinates given (the
thesis uses mm), angles in rad. Pose ``(x, y, phi)``: position of the
platform joint B_1 and the platform's orientation.

Geometry (seed 003 eq. 7-9)
---------------------------
Base joints ``A_i``; platform joints ``B'_i`` in the moving frame, whose origin
is ``B'_1 = (0, 0)``. In the base frame ``B_i = (x, y) + Rot(phi) B'_i`` and the
legs are ``rho_i = |B_i - A_i|`` (eq. 7-9 with ``c_2, c_3, d_3`` the base
coordinates and ``l_2, l_3, beta`` the platform's polar coordinates).

The Jacobian printed in the thesis (Sec. 5.3)
---------------------------------------------
The matrix printed for legs (100, 120, 150) at (97.99, 19.91, 85.02 deg) does
not follow from the stated data. We traced it to the appendix's C++ program:

1. it prints ``-A^-1 B`` (the forward Jacobian, ``x_dot = J rho_dot``), not the
   ``-B^-1 A`` of eq. 16 (a different matrix: its third row is in rad/mm);
2. its ``a[2][2]`` uses ``x - t3`` (``t3`` = d_3 = 200) where eq. 27 has
   ``x - c_3`` (c_3 = 0);
3. its second column is 1.25 = 150/120 times too large: the printed matrix
   corresponds to leg lengths entered as (100, 150, 150).

With (1)-(3) the program's formula reproduces every printed entry to within
1 % (the rest is float32 and the rounded inputs). Our :meth:`RPR3.jacobian` is
the correct ``B^-1 A`` and is verified against finite differences; we do not
test against the printed matrix.
"""

from __future__ import annotations

import math

import numpy as np

from kinematics import kernels
from kinematics.algebra import (
    real_tan_half_angles,
    sample_angles,
    trig_coefficients,
    trig_to_tan_half,
    wrap_angle,
)
from kinematics.annuli import annuli_intersection_area, annuli_x_sections, annuli_y_extent
from kinematics.base import (
    DesignVariable,
    FixedParameter,
    Mechanism,
    check_range,
    cosine_range,
    orientation_measure,
)


def _points(owner: str, name: str, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}: parameter '{name}' must be 3 points [[x, y]] * 3; got {value!r}") from None
    if arr.shape != (3, 2):
        raise ValueError(f"{owner}: parameter '{name}' must have shape (3, 2); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{owner}: parameter '{name}' must be finite; got {value!r}")
    return arr


class RPR3(Mechanism):
    """Planar 3-RPR with actuated prismatic legs (seed 003).

    Parameters
    ----------
    base : array_like, shape (3, 2)
        Base joints A_i in the base frame.
    platform : array_like, shape (3, 2)
        Platform joints B'_i in the moving frame; the first must be (0, 0)
        because the pose is that of B_1.
    rho_min, rho_max : float
        Leg length range, ``0 < rho_min < rho_max`` (thesis Fig. 8-11: 80, 160).
    """

    name = "rpr3"
    dof = 3
    pose_names = ("x", "y", "phi")
    angular = (False, False, True)
    length_unit = "mm"

    def __init__(self, base, platform, rho_min: float, rho_max: float) -> None:
        owner = "RPR3"
        self.base = _points(owner, "base", base)
        self.platform = _points(owner, "platform", platform)
        if np.any(self.platform[0] != 0.0):
            raise ValueError(
                f"RPR3: parameter 'platform' must start with the joint at the moving frame's "
                f"origin (0, 0); got {self.platform[0].tolist()}"
            )
        self.rho_min, self.rho_max = check_range(owner, "rho_min", rho_min, "rho_max", rho_max)
        self._params = {
            "base": self.base.tolist(),
            "platform": self.platform.tolist(),
            "rho_min": self.rho_min,
            "rho_max": self.rho_max,
        }

    fixed_parameters = (
        FixedParameter("rho_min", 80.0, 1.0, 10000.0, "mm"),
        FixedParameter("rho_max", 160.0, 1.0, 10000.0, "mm"),
    )
    default_nodes = 32**3
    min_resolution = 24

    design_variables = (
        DesignVariable("base_side", 100.0, 300.0, "mm"),
        DesignVariable("platform_side", 20.0, 100.0, "mm"),
    )

    @classmethod
    def from_design(cls, design: np.ndarray, **fixed: object) -> RPR3:
        """The thesis' shapes scaled: base A = (0,0), (s_b,0), (0,s_b) (thesis s_b = 200)
        and platform B' = (0,0), (s_p,0), (0.8 s_p, 0.8 s_p) (thesis s_p = 50)."""
        side_b, side_p = (float(v) for v in np.ravel(design))
        base = [[0.0, 0.0], [side_b, 0.0], [0.0, side_b]]
        platform = [[0.0, 0.0], [side_p, 0.0], [0.8 * side_p, 0.8 * side_p]]
        return cls(base=base, platform=platform, **fixed)

    @property
    def default_orientation(self) -> tuple[float, float]:
        """phi in [15, 60] deg: the span of the thesis' Fig. 8-11."""
        return (np.pi / 12, np.pi / 3)

    def pose_bounds(self, orientation: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Box of the workspace: ``B_i = (x, y) + Rot(phi) B'_i`` within ``rho_max`` of ``A_i``."""
        lo, hi = float(orientation[0]), float(orientation[1])
        radius = np.hypot(*self.platform.T)
        phase = np.arctan2(self.platform[:, 1], self.platform[:, 0])
        cmin, cmax = cosine_range(lo, hi, phase)
        smin, smax = cosine_range(lo, hi, phase - np.pi / 2)
        x_lo = np.max(self.base[:, 0] - self.rho_max - radius * cmax)
        x_hi = np.min(self.base[:, 0] + self.rho_max - radius * cmin)
        y_lo = np.max(self.base[:, 1] - self.rho_max - radius * smax)
        y_hi = np.min(self.base[:, 1] + self.rho_max - radius * smin)
        return np.array([x_lo, y_lo, lo]), np.array([x_hi, y_hi, hi])

    def reference_volume(self, orientation: tuple[float, float]) -> float:
        """``V* = pi (rho_max^2 - rho_min^2) * phi range`` (mm^2 rad).

        One leg's annulus: the constant-orientation workspace is an
        intersection of three such annuli, so ``V/V* <= 1``.
        """
        return math.pi * (self.rho_max**2 - self.rho_min**2) * orientation_measure(orientation, 1)

    def annulus_centres(self, phi: float) -> np.ndarray:
        """Centres (3, 2) of the annuli confining B_1 at orientation ``phi`` (rad): ``A_i - Rot(phi) B'_i``.

        (The thesis' eq. 12-14 and its Fig. 8-11.)
        """
        return self.base - self._rotated_platform(np.array([float(phi)]))[0]

    def exact_area(self, phi: float) -> float:
        """Exact area (mm^2) of the constant-orientation workspace at ``phi`` (rad), no dexterity limit."""
        return annuli_intersection_area(self.annulus_centres(phi), self.rho_min, self.rho_max)

    #: the pose variable integrated in closed form by :meth:`exact_sections` (x)
    section_axis = 0

    def exact_sections(
        self, poses: np.ndarray, origin: float, step: float, min_inverse_condition: float, length: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """Workspace sections along x at given (y, phi), exact in their ends.

        At fixed ``(y, phi)`` leg i gives ``rho_min^2 <= (x - c_ix)^2 + (y - c_iy)^2 <= rho_max^2``
        with ``c_i = A_i - Rot(phi) B'_i`` the centre of its annulus (eq. 7-9, 12-14): an
        interval of x minus an inner one, in closed form. The section is the intersection over
        the legs: at most four intervals. Along each interval ``s = sign(det J) / kappa`` (the
        homogenised Jacobian of :meth:`_jacobian`, smooth through a singularity) is sampled at
        its ends and at the nodes ``origin + k step`` inside it, with its x-derivative (forward
        difference); the dexterous part ``|s| > min_inverse_condition`` is cut where the linear
        interpolant of s meets the limit (each such crossing is sampled too), and ``|s|`` is
        integrated by the corrected trapezoid rule (cubic Hermite). Every quantity moves
        continuously with the design and the pose.

        Returns what :meth:`~kinematics.base.Mechanism.exact_sections` states (lengths in mm).

        Parameters
        ----------
        poses : ndarray, shape (N, 3)
            Rows ``(x, y, phi)`` (mm, mm, rad); the x column is ignored.
        origin, step : float
            Sample nodes along x (mm), ``step > 0``.
        min_inverse_condition : float
            Dexterity limit on ``1/kappa`` (0: none).
        length : float, optional
            Characteristic length (mm) homogenising the Jacobian (default
            :attr:`characteristic_length`).
        """
        poses = self._check_poses(poses)
        if not step > 0:
            raise ValueError(f"RPR3.exact_sections: step must be > 0 (mm); got {step!r}")
        arms = self._rotated_platform(poses[:, 2])  # (N, 3, 2): Rot(phi) B'_i
        centres = self.base - arms  # c_i = A_i - Rot(phi) B'_i (eq. 12-14)
        return annuli_x_sections(
            np.ascontiguousarray(poses[:, 1]),
            *(np.ascontiguousarray(a) for a in (centres[..., 0], centres[..., 1], arms[..., 0], arms[..., 1])),
            self.rho_min,
            self.rho_max,
            float(self.angular_scale(length)[2]),
            float(origin),
            float(step),
            float(min_inverse_condition),
        )

    def transverse_extent(self, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact y extent (mm) of the reachable workspace at each orientation ``angles`` (L,)
        (rad): the intersection of the legs' annuli around ``c_i = A_i - Rot(phi) B'_i``
        (eq. 12-14), by :func:`~kinematics.annuli.annuli_y_extent`. Returns ``(lower, upper)``,
        each (L,) (mm), NaN where the annuli do not meet."""
        centres = self.base - self._rotated_platform(np.asarray(angles, dtype=float).ravel())  # (L, 3, 2)
        return annuli_y_extent(
            np.ascontiguousarray(centres[..., 0]), np.ascontiguousarray(centres[..., 1]), self.rho_min, self.rho_max
        )

    @property
    def characteristic_length(self) -> float:
        """RMS distance of the platform joints from their centroid (mm).

        A size of the platform that does not depend on which joint carries
        the pose; it turns phi_dot into a joint speed.
        """
        centred = self.platform - self.platform.mean(axis=0)
        length = math.sqrt(float((centred**2).sum(axis=1).mean()))
        return length if length > 0 else 1.0

    @property
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """``rho_min <= rho_i <= rho_max``."""
        return np.full(3, self.rho_min), np.full(3, self.rho_max)

    # ----------------------------------------------------------- geometry
    def _rotated_platform(self, phi: np.ndarray) -> np.ndarray:
        """``Rot(phi) B'_i``, shape (N, 3, 2)."""
        c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
        px, py = self.platform[:, 0], self.platform[:, 1]
        return np.stack([c * px - s * py, s * px + c * py], axis=-1)

    def platform_points(self, poses: np.ndarray) -> np.ndarray:
        """Platform joints ``B_i`` in the base frame, shape (N, 3, 2)."""
        poses = self._check_poses(poses)
        return self._rotated_platform(poses[:, 2]) + poses[:, None, :2]

    def _legs(self, poses: np.ndarray):
        arms = self._rotated_platform(poses[:, 2])
        return arms + poses[:, None, :2] - self.base, arms

    def constraint_margins(self, poses: np.ndarray) -> np.ndarray:
        """``rho_i - rho_min`` and ``rho_max - rho_i`` (N, 6), mm (eq. 7-9): the only
        reachability constraints (every pose has real leg lengths)."""
        return self._actuator_margins(self._check_poses(poses))

    # ------------------------------------------------------------- kernels
    def _inverse(self, poses: np.ndarray) -> np.ndarray:
        """``rho_i = |B_i - A_i|`` (eq. 7-9)."""
        legs, _ = self._legs(poses)
        return np.linalg.norm(legs, axis=-1)

    def _jacobian(self, poses: np.ndarray) -> np.ndarray:
        """``J = B^-1 A`` (the sign-free form of eq. 15-27), ``rho_dot = J (x, y, phi)_dot``.

        Row i of A (eq. 19-27): ``[L_x, L_y, (Rot(phi) B'_i x L_i)_z]`` with
        ``L_i = B_i - A_i``; ``B = diag(rho_i)`` (eq. 18). The thesis writes
        ``J = -B^-1 A`` for ``A x_dot + B rho_dot = 0``, i.e. with the opposite sign
        convention for A; both describe the same map.
        """
        legs, arms = self._legs(poses)
        rho = np.linalg.norm(legs, axis=-1)
        ang = arms[..., 0] * legs[..., 1] - arms[..., 1] * legs[..., 0]
        jac = np.stack([legs[..., 0], legs[..., 1], ang], axis=-1) / rho[..., None]
        jac[rho == 0] = np.inf  # leg of zero length: direction undefined
        return jac

    def _compiled_reachable_jacobian(self, poses: np.ndarray, column_scale: np.ndarray) -> np.ndarray:
        """Eq. 7-9 and the Jacobian of :meth:`_jacobian`, compiled, NaN rows outside
        ``rho_min..rho_max`` (see :func:`_rpr3_reachable_jacobians`)."""
        cos_phi, sin_phi = kernels.periodic_cos_sin(np.ascontiguousarray(poses[:, 2]))
        return _rpr3_reachable_jacobians(
            poses,
            cos_phi,
            sin_phi,
            np.ascontiguousarray(self.base),
            np.ascontiguousarray(self.platform),
            self.rho_min,
            self.rho_max,
            column_scale,
        )

    # --------------------------------------------------- forward kinematics
    def _linear_position(self, phi: np.ndarray, q: np.ndarray):
        """(x, y) = N / D from legs 2 - 1 and 3 - 1 (linear in x, y at given phi)."""
        arms = self._rotated_platform(phi)
        rows = 2.0 * (arms[:, 1:] - self.base[1:] + self.base[0])  # (K, 2, 2)
        rhs = q[1:] ** 2 - q[0] ** 2 - ((arms[:, 1:] - self.base[1:]) ** 2).sum(-1) + (self.base[0] ** 2).sum()
        den = rows[:, 0, 0] * rows[:, 1, 1] - rows[:, 0, 1] * rows[:, 1, 0]
        nx = rhs[:, 0] * rows[:, 1, 1] - rows[:, 0, 1] * rhs[:, 1]
        ny = rows[:, 0, 0] * rhs[:, 1] - rhs[:, 0] * rows[:, 1, 0]
        return np.stack([nx, ny], axis=-1), den

    def forward_polynomial(self, q: np.ndarray) -> np.ndarray:
        """Polynomial in ``t = tan(phi/2)`` whose real roots are the assembly modes.

        Substituting ``(x, y) = N/D`` into eq. 7 gives
        ``|N - D A_1|^2 - rho_1^2 D^2 = 0``, a trig polynomial of degree 4 in
        phi whose 4th harmonic cancels identically. Written over
        ``(1 + t^2)^4`` its t-polynomial therefore carries the spurious factor
        ``(1 + t^2)``; we read the harmonics by FFT and drop the vanishing one,
        which leaves the degree-6 polynomial (at most 6 modes).

        Parameters
        ----------
        q : array_like, shape (3,)

        Returns
        -------
        ndarray
            Coefficients, highest degree first (7 of them; 9 in the
            degenerate case where the 4th harmonic does not vanish), scaled so
            the largest magnitude is 1.
        """
        q = self._check_actuators(q)
        phi = sample_angles(4)
        num, den = self._linear_position(phi, q)
        values = ((num - den[:, None] * self.base[0]) ** 2).sum(-1) - q[0] ** 2 * den**2
        coefs = trig_coefficients(values, 4)
        if np.max(np.abs(coefs[[0, -1]])) <= 1e-11 * np.max(np.abs(coefs)):
            coefs = coefs[1:-1]
        poly = np.real(trig_to_tan_half(coefs))[::-1]
        return poly / np.max(np.abs(poly))

    def _forward(self, q: np.ndarray) -> np.ndarray:
        """Real roots of :meth:`forward_polynomial`, back-substituted and Newton-polished."""
        phi = real_tan_half_angles(self.forward_polynomial(q))
        if phi.size == 0:
            return np.empty((0, 3))
        num, den = self._linear_position(phi, q)
        return self._polish(np.column_stack([num / den[:, None], phi]), q, np.maximum(q**2, 1e-300))

    # ----------------------------------------------- the thesis' GA route
    def forward_ga(
        self,
        q: np.ndarray,
        seed: int,
        generations: int = 500,
        population: int = 40,
        crossover: float = 0.999,
        mutation: float = 0.001,
        bits: int = 20,
    ) -> np.ndarray:
        """One forward solution by a genetic algorithm, as in the thesis (Sec. 2.2, 5.2).

        Minimises ``F = sum_i (rho_i(x) - rho_gi)^2`` (eq. 10-11) with fitness
        ``1/F`` (Sec. 3.2). The thesis' operator rates (uniform crossover 0.999,
        mutation 0.001, population 40, 500 or 1000 generations) are those of a
        binary-coded GA, so each of x, y, phi is a ``bits``-bit string over its
        search interval; selection is fitness-proportional (roulette, which the
        thesis does not name) with the best individual kept (elitism).
        Search box: ``|x - A_1x|, |y - A_1y| <= rho_1`` and ``phi`` in [-pi, pi].

        Parameters
        ----------
        q : array_like, shape (3,)
            Leg lengths.
        seed : int
            Seed of the random generator; the result is a function of it.

        Returns
        -------
        ndarray, shape (1, 3)
            The best pose found (x, y in length units, phi in rad).
        """
        q = self._check_actuators(q)
        rng = np.random.default_rng(seed)
        reach = float(q[0])
        lower = np.array([self.base[0, 0] - reach, self.base[0, 1] - reach, -np.pi])
        upper = np.array([self.base[0, 0] + reach, self.base[0, 1] + reach, np.pi])
        weights = 2.0 ** np.arange(bits - 1, -1, -1)

        def decode(genes: np.ndarray) -> np.ndarray:
            ints = genes.reshape(genes.shape[0], 3, bits) @ weights
            return lower + (upper - lower) * ints / (2.0**bits - 1.0)

        def error(genes: np.ndarray) -> np.ndarray:
            return ((self._inverse(decode(genes)) - q) ** 2).sum(axis=1)

        n_genes = 3 * bits
        pop = rng.random((population, n_genes)) < 0.5
        err = error(pop)
        for _ in range(generations):
            best = pop[np.argmin(err)].copy()
            fitness = 1.0 / (err + 1e-300)
            parents = pop[rng.choice(population, size=population, p=fitness / fitness.sum())]
            mates = parents[rng.permutation(population)]
            cross = rng.random(population) < crossover
            swap = (rng.random((population, n_genes)) < 0.5) & cross[:, None]
            children = np.where(swap, mates, parents)
            children ^= rng.random((population, n_genes)) < mutation
            children[0] = best
            pop = children
            err = error(pop)
        out = decode(pop[np.argmin(err)][None, :])
        out[:, 2] = wrap_angle(out[:, 2])
        return out


@kernels.jit
def _rpr3_reachable_jacobians(poses, cos_phi, sin_phi, base, platform, rho_min, rho_max, column_scale):
    """Per pose (N, 3) of (x, y, phi) (mm, rad; ``cos_phi``, ``sin_phi`` of each pose's phi,
    :func:`kinematics.kernels.periodic_cos_sin`): the legs ``L_i = Rot(phi) B'_i + (x, y) - A_i``,
    the range test ``rho_min <= |L_i| <= rho_max`` (eq. 7-9) and the rows
    ``[L_x, L_y, (Rot(phi) B'_i x L_i)_z] / rho_i`` (as :meth:`RPR3._jacobian`) times
    ``column_scale``. Returns (N, 3, 3); rows of NaN where a leg is out of range
    (``rho_min > 0``, so no division by zero)."""
    count = poses.shape[0]
    out = np.empty((count, 3, 3))
    for p in range(count):
        x, y, c, s = poses[p, 0], poses[p, 1], cos_phi[p], sin_phi[p]
        for i in range(3):
            arm_x = c * platform[i, 0] - s * platform[i, 1]
            arm_y = s * platform[i, 0] + c * platform[i, 1]
            leg_x = arm_x + x - base[i, 0]
            leg_y = arm_y + y - base[i, 1]
            rho = math.sqrt(leg_x * leg_x + leg_y * leg_y)
            if not (rho_min <= rho <= rho_max):
                out[p, :, :] = np.nan
                break
            out[p, i, 0] = leg_x / rho * column_scale[0]
            out[p, i, 1] = leg_y / rho * column_scale[1]
            out[p, i, 2] = (arm_x * leg_y - arm_y * leg_x) / rho * column_scale[2]
    return out
