"""The small vectorised interface every mechanism implements.

Each mechanism is a subclass of :class:`Mechanism`. The public methods check
their input (shape, dtype) and delegate to private vectorised kernels
(``_inverse``, ``_jacobian``, ``_forward``), in the style of pymoo's
checked-public / private-kernel split.

Conventions (all mechanisms)
----------------------------
* Rows are samples: poses have shape ``(N, dof)``, actuator values
  ``(N, dof)``, Jacobians ``(N, dof, dof)``. A 1-D pose of length ``dof`` is
  accepted and treated as ``N = 1``; the result is still a batch.
* Angles are in radians; lengths in the unit of the mechanism's paper (cm for
  H4, mm for the others).
* ``jacobian`` is the *inverse-kinematic* Jacobian ``J`` with
  ``q_dot = J @ x_dot`` (the papers' ``J_q^-1 J_x``).
* ``inverse_condition`` is ``1/kappa`` of the dimensionally homogeneous
  Jacobian: every angular column of ``J`` is divided by a characteristic
  length ``L`` (seed 001 eq. 37; seed 000 Sec. 4.2), so that all singular
  values carry the same unit.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from kinematics.conditioning import inverse_condition_number


class Mechanism(ABC):
    """Abstract base of a parallel mechanism with ``dof`` actuators and pose variables.

    Subclasses set the class attributes and implement the private kernels.
    """

    #: registry name, e.g. ``"h4"``
    name: ClassVar[str]
    #: number of actuators == number of pose variables
    dof: ClassVar[int]
    #: names of the pose variables, in column order
    pose_names: ClassVar[tuple[str, ...]]
    #: which pose variables are angles (radians); the others are lengths
    angular: ClassVar[tuple[bool, ...]]
    #: unit of every length of this mechanism
    length_unit: ClassVar[str]

    # ------------------------------------------------------------------ checks
    def _check_poses(self, poses: np.ndarray) -> np.ndarray:
        arr = np.asarray(poses, dtype=float)
        if arr.ndim == 1 and arr.shape[0] == self.dof:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.dof:
            raise ValueError(
                f"{self.name}: poses must have shape (N, {self.dof}) with columns "
                f"{self.pose_names}; got shape {np.shape(poses)}"
            )
        return arr

    def _check_actuators(self, q: np.ndarray) -> np.ndarray:
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.dof,):
            raise ValueError(
                f"{self.name}: actuator vector must have shape ({self.dof},); "
                f"got shape {np.shape(q)}"
            )
        return arr

    # ------------------------------------------------------------ public API
    def inverse(self, poses: np.ndarray) -> np.ndarray:
        """Actuator values of each pose (inverse kinematics).

        Parameters
        ----------
        poses : array_like, shape (N, dof)
            Poses in the base frame, columns :attr:`pose_names`.

        Returns
        -------
        ndarray, shape (N, dof)
            Actuator values (lengths in :attr:`length_unit`); a row of NaN where
            the pose has no real solution. Never raises or warns for such poses.
        """
        poses = self._check_poses(poses)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return self._inverse(poses)

    def forward(self, q: np.ndarray) -> np.ndarray:
        """All real poses that give the actuator values ``q`` (forward kinematics).

        Parameters
        ----------
        q : array_like, shape (dof,)
            One actuator vector.

        Returns
        -------
        ndarray, shape (k, dof)
            Every real pose ``x`` with ``inverse(x) == q`` (``k`` may be 0), sorted
            lexicographically by the pose columns so the order is deterministic.
        """
        q = self._check_actuators(q)
        if not np.all(np.isfinite(q)):
            return np.empty((0, self.dof))
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            sols = self._forward(q)
            # keep the poses whose inverse kinematics (on the branch `inverse`
            # uses) gives back q: the polynomial routes also find the other
            # branches, and a negative length squares to a valid constraint
            back = self._inverse(sols) if len(sols) else sols
        same = np.all(np.abs(back - q) <= 1e-7 * (1.0 + np.abs(q)), axis=1)
        return sort_poses(sols[same])

    def jacobian(self, poses: np.ndarray) -> np.ndarray:
        """Analytic inverse-kinematic Jacobian ``J`` with ``q_dot = J @ x_dot``.

        Parameters
        ----------
        poses : array_like, shape (N, dof)

        Returns
        -------
        ndarray, shape (N, dof, dof)
            ``J[n, i, j] = d q_i / d x_j`` at pose ``n``; units length/length for
            translational columns and length/rad for angular ones. NaN where the
            pose is unreachable, +-inf where the actuator Jacobian is singular.
        """
        poses = self._check_poses(poses)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return self._jacobian(poses)

    def inverse_condition(self, poses: np.ndarray, length: float | None = None) -> np.ndarray:
        """Inverse condition number ``1/kappa`` of the homogenised Jacobian.

        ``kappa = sigma_max / sigma_min`` (seed 000 eq. 35) of ``J @ diag(s)`` with
        ``s_j = 1/length`` for angular pose variables and 1 otherwise.

        Parameters
        ----------
        poses : array_like, shape (N, dof)
        length : float, optional
            Characteristic length in :attr:`length_unit`; ``None`` uses
            :attr:`characteristic_length`.

        Returns
        -------
        ndarray, shape (N,)
            Values in [0, 1]: 1 is isotropic, 0 singular; NaN where unreachable.
        """
        poses = self._check_poses(poses)
        jac = self.jacobian(poses)
        return inverse_condition_number(jac, self.angular_scale(length))

    def angular_scale(self, length: float | None = None) -> np.ndarray:
        """Column scale ``s`` (shape (dof,)) that homogenises the Jacobian.

        ``s_j = 1/length`` for angular pose variables, 1 for translational ones.
        """
        if length is None:
            length = self.characteristic_length
        length = float(length)
        if not (math.isfinite(length) and length > 0):
            raise ValueError(f"{self.name}: length must be a finite number > 0; got {length}")
        return np.where(np.asarray(self.angular), 1.0 / length, 1.0)

    # ------------------------------------------------------------- properties
    @property
    @abstractmethod
    def characteristic_length(self) -> float:
        """Default length (in :attr:`length_unit`) dividing angular Jacobian columns."""

    @property
    @abstractmethod
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper actuator limits, each shape (dof,), in :attr:`length_unit`."""

    def params(self) -> dict[str, object]:
        """Constructor keyword arguments that rebuild this mechanism."""
        return dict(self._params)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self._params.items())
        return f"{type(self).__name__}({args})"

    # --------------------------------------------------------------- kernels
    @abstractmethod
    def _inverse(self, poses: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def _jacobian(self, poses: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def _forward(self, q: np.ndarray) -> np.ndarray: ...

    _params: dict[str, object]


# ---------------------------------------------------------------- validation
def check_positive(owner: str, name: str, value: float) -> float:
    """Return ``value`` as float, or raise ValueError unless it is finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}: parameter '{name}' must be a number > 0; got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{owner}: parameter '{name}' must be a finite number > 0; got {value!r}")
    return v


def check_range(owner: str, lo_name: str, lo: float, hi_name: str, hi: float) -> tuple[float, float]:
    """Return ``(lo, hi)`` as floats, or raise unless ``0 < lo < hi`` and both finite."""
    lo_v = check_positive(owner, lo_name, lo)
    hi_v = check_positive(owner, hi_name, hi)
    if not lo_v < hi_v:
        raise ValueError(
            f"{owner}: parameter '{lo_name}' must be below '{hi_name}' "
            f"(allowed: 0 < {lo_name} < {hi_name}); got {lo_name}={lo_v}, {hi_name}={hi_v}"
        )
    return lo_v, hi_v


def sort_poses(poses: np.ndarray) -> np.ndarray:
    """Sort poses (k, dof) lexicographically by column 0, then 1, ...; deterministic."""
    poses = np.asarray(poses, dtype=float)
    if poses.shape[0] <= 1:
        return poses
    order = np.lexsort(tuple(np.round(poses[:, j], 9) for j in reversed(range(poses.shape[1]))))
    return poses[order]
