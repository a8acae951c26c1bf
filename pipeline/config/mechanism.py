"""The mechanism's config section: which mechanism, its fixed parameters, its design box and
workspace limits, each checked against what the mechanism class declares (one source).

Angles in the config are degrees; they are converted to radians once, in
:meth:`MechanismConfig.evaluation_options`. Part of the schema (:mod:`pipeline.config.schema`).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

import numpy as np
from omegaconf import MISSING

from kinematics import MECHANISMS, resolve_mechanism
from kinematics.base import Mechanism
from kinematics.plugins import PluginError
from pipeline.errors import ConfigError, check, finite


@dataclass
class DesignSpace:
    """Design variables: names (the class's, in order) and box bounds (design units)."""

    names: list[str] = field(default_factory=list)
    lower: list[float] = field(default_factory=list)
    upper: list[float] = field(default_factory=list)


@dataclass
class MechanismConfig:
    """One mechanism: registry name, fixed constructor parameters, design box, workspace limits.

    ``orientation`` is the range of every angular pose variable in degrees
    (null: the class's default); ``length`` the homogenising length in the
    mechanism's length unit (null: the class's default). Empty ``names``,
    ``lower``, ``upper`` and missing ``fixed`` entries take the class's values.
    """

    #: registry name of the mechanism class (the group option `mechanism=NAME` sets it)
    name: str = MISSING
    #: fixed constructor parameters and paper readings (per mechanism, listed below); missing keys take the class's
    fixed: dict[str, Any] = field(default_factory=dict)
    #: design box: `names`, `lower`, `upper` in the design variables' units (empty: the class's)
    design: DesignSpace = field(default_factory=DesignSpace)
    #: range [lo, hi] of every angular pose variable, degrees (null: the class's default)
    orientation: Optional[list[float]] = None
    #: dexterity limit 1/κ of a workspace pose, [0, 1) (seed 000 Sec. 4.4)
    min_inverse_condition: float = 0.01
    #: homogenising length of the Jacobian, mechanism length unit (null: the class's)
    length: Optional[float] = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not (self.name in MECHANISMS or ":" in self.name):
            check(
                "mechanism.name",
                self.name,
                False,
                "one of " + ", ".join(MECHANISMS) + ", or 'package.module:Class' with mechanism=path",
            )
        try:
            resolve_mechanism(self.name)
        except PluginError as exc:
            raise ConfigError(
                f"mechanism.name={self.name!r} is invalid: {exc}{working_folder_hint(self.name)}"
            ) from None
        cls = self.cls
        expected = [v.name for v in cls.design_variables]
        d = self.design
        d.names = list(d.names) or expected
        check("mechanism.design.names", d.names, d.names == expected, f"{expected}")
        d.lower = [float(v) for v in (d.lower or [v.lower for v in cls.design_variables])]
        d.upper = [float(v) for v in (d.upper or [v.upper for v in cls.design_variables])]
        for key in ("lower", "upper"):
            values = getattr(d, key)
            check(f"mechanism.design.{key}", values, len(values) == len(expected), f"{len(expected)} numbers")
        for name, lo, hi in zip(expected, d.lower, d.upper):
            check(
                f"mechanism.design bounds of {name}",
                [lo, hi],
                finite(lo) and finite(hi) and lo < hi,
                "finite numbers with lower < upper",
            )
        self.fixed = _checked_fixed(cls, dict(self.fixed))
        if self.orientation is not None:
            o = list(self.orientation)
            check(
                "mechanism.orientation",
                o,
                len(o) == 2 and all(finite(v) for v in o) and -360 <= o[0] <= o[1] <= 360,
                "null or [lo, hi] in degrees, -360 <= lo <= hi <= 360",
            )
            self.orientation = [float(v) for v in o]
        check(
            "mechanism.min_inverse_condition",
            self.min_inverse_condition,
            finite(self.min_inverse_condition) and 0 <= self.min_inverse_condition < 1,
            "[0, 1)",
        )
        check(
            "mechanism.length",
            self.length,
            self.length is None or (finite(self.length) and self.length > 0),
            "null or a finite number > 0",
        )
        self._check_design_box()
        try:
            self.build(self.centre)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"mechanism.fixed: {exc}") from None

    def _check_design_box(self) -> None:
        """Each bound of the design box alone (the others at the class's default centre) builds a
        mechanism; else the error names the bound and the design variable, not the parameter it feeds."""
        variables = self.cls.design_variables
        default_centre = np.array([0.5 * (v.lower + v.upper) for v in variables])
        try:
            self.build(default_centre)
        except (TypeError, ValueError):
            return  # the fixed parameters alone fail: reported as mechanism.fixed
        for key in ("lower", "upper"):
            bounds = getattr(self.design, key)
            for k, (v, value) in enumerate(zip(variables, bounds)):
                x = default_centre.copy()
                x[k] = value
                try:
                    self.build(x)
                except (TypeError, ValueError) as exc:
                    unit = f" ({v.unit})" if v.unit else ""
                    raise ConfigError(
                        f"mechanism.design.{key}={bounds} is invalid: {v.name}={value:g} cannot be built "
                        f"({exc}); allowed for {v.name}: values {self.name} can build, e.g. its default "
                        f"[{v.lower:g}, {v.upper:g}]{unit}"
                    ) from None

    @property
    def cls(self) -> type[Mechanism]:
        """The mechanism class: a registry name or a ``package.module:Class`` path."""
        return resolve_mechanism(self.name)

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * (np.asarray(self.design.lower) + np.asarray(self.design.upper))

    def build(self, design: np.ndarray) -> Mechanism:
        """The mechanism of one design vector (design units); ValueError if the design is infeasible."""
        return self.cls.from_design(np.asarray(design, dtype=float), **self.fixed)

    def orientation_rad(self) -> tuple[float, float] | None:
        """``orientation`` in radians (None: the class's default)."""
        return None if self.orientation is None else tuple(math.radians(v) for v in self.orientation)

    def evaluation_options(self) -> dict:
        """Keyword options of :func:`kinematics.workspace.evaluate` (angles in rad)."""
        options: dict = {"min_inverse_condition": float(self.min_inverse_condition)}
        if self.orientation is not None:
            options["orientation"] = self.orientation_rad()
        if self.length is not None:
            options["length"] = float(self.length)
        return options

    @classmethod
    def for_class(cls, mechanism: type[Mechanism]) -> MechanismConfig:
        """The default config of a mechanism class (its Hydra group option)."""
        probe_orientation = None
        if any(mechanism.angular):
            lo, hi = _default_orientation(mechanism)
            probe_orientation = [round(math.degrees(lo), 9), round(math.degrees(hi), 9)]
        return cls(
            name=mechanism.name,
            fixed=dict(mechanism.default_fixed),
            design=DesignSpace(
                names=[v.name for v in mechanism.design_variables],
                lower=[v.lower for v in mechanism.design_variables],
                upper=[v.upper for v in mechanism.design_variables],
            ),
            orientation=probe_orientation,
        )


def _checked_fixed(cls: type[Mechanism], given: dict[str, Any]) -> dict[str, Any]:
    """The class's defaults updated with ``given``, each value in its declared range or choices.

    The ranges come from the mechanism (``fixed_parameters``, one source);
    every fixed parameter must be declared there.
    """
    declared = {p.name: p for p in cls.fixed_parameters}
    keys = ", ".join(declared) or "none"
    # first the class's own defaults (its group option passes them as ``given``): a class that
    # omits a declaration is named as such, not the user for an override never made
    for name in cls.default_fixed:
        if name not in declared:
            raise ConfigError(
                f"mechanism={cls.name!r} is invalid: {cls.__name__}.default_fixed has {name!r} but "
                f"fixed_parameters declares no kinematics.base.FixedParameter for it (its range and unit); "
                f"allowed: a mechanism declaring each fixed parameter (docs/extending.md)"
            )
    for name in given:
        check(f"mechanism.fixed.{name}", given[name], name in declared, f"keys {keys} for {cls.name}")
    fixed = {**cls.default_fixed, **given}
    for name, value in fixed.items():
        p = declared[name]
        check(f"mechanism.fixed.{name}", value, p.accepts(value), f"{p.allowed()} for {cls.name}")
    return fixed


def _default_orientation(mechanism: type[Mechanism]) -> tuple[float, float]:
    centre = [0.5 * (v.lower + v.upper) for v in mechanism.design_variables]
    return mechanism.from_design(np.array(centre), **mechanism.default_fixed).default_orientation


def working_folder_hint(path: str) -> str:
    """Why a module lying in the working folder is not found: the ``pm-design`` console script,
    unlike ``python -m pipeline``, does not put the working folder on ``sys.path`` (Python's rule
    for ``-m``; the project adds no path of its own)."""
    top = path.partition(":")[0].split(".")[0]
    here = Path.cwd()
    on_path = any(Path(p or ".").resolve() == here.resolve() for p in sys.path)
    if not top or on_path or not ((here / f"{top}.py").is_file() or (here / top / "__init__.py").is_file()):
        return ""
    return (
        f"; {top} is in the working folder, which pm-design does not import from: "
        f"run python -m pipeline here instead, or install it (pip install -e <its project folder>)"
    )
