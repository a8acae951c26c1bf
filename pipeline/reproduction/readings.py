"""The readings study: which interpretation of the papers' unstated choices did they use?

For H4 (seed 000) and the Tricept (seed 001) every choice the paper leaves
open is a constructor parameter (a *reading*, see the module docstrings of
:mod:`kinematics.h4` and :mod:`kinematics.tricept`). This module

1. evaluates the paper's published designs under every combination of
   readings, beside the paper's numbers, with a log-error score (the mean of
   ``|ln(ours / paper)|`` over the quantities compared);
2. for the best few readings, asks whether the paper's optimum is
   (near-)optimal under that reading (IPOP-CMA-ES + polish from
   :mod:`pipeline.optimizers`), whether V and GDI conflict (Spearman rank
   correlation over 64 Sobol designs, and the GDI of the max-V optimum
   against the max-GDI optimum), and, for H4, where a w_d sweep collapses
   the workspace;
3. returns the Markdown section that :mod:`pipeline.reproduction` puts into
   ``docs/reproduction.md``, naming the best reading and the
   ``+reading=...`` preset (``conf/reading/``) that selects it.

Paper numbers are data (:data:`H4_PAPER`, :data:`TRICEPT_PAPER`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
import yaml
from scipy.stats import spearmanr

from kinematics import get_mechanism
from kinematics.workspace import evaluate
from pipeline.config import CONFIG_DIR, MechanismConfig, SampleConfig
from pipeline.evaluation import DesignEvaluator
from pipeline.objectives import objective_values
from pipeline.optimizers import reference_optimum
from pipeline.optimizers.base import Problem
from pipeline.reproduction.papers import load_paper
from pipeline.stages.sample import sample_designs
from pipeline.store.cache import cached

#: seed 000 Tables 1-3: V (cm³ as printed), GDI, and the design (cm), from pipeline/reproduction/papers/seed000_h4.yaml
H4_PAPER = {row["table"]: {k: row[k] for k in ("V", "gdi", "d", "h", "Qz")} for row in load_paper("seed000_h4")["rows"]}
#: Table 2's V = 4.1887 is 4π/3 to five digits: a floor of the paper's volume routine, not a volume
H4_DEGENERATE_V = ("Table 2 (max GDI)",)
#: seed 001 Table 2: V (mm·rad²), the LCI range and the design (a and b swapped back into their bounds),
#: from pipeline/reproduction/papers/seed001_tricept.yaml
TRICEPT_PAPER = {
    k: v for k, v in load_paper("seed001_tricept")["rows"][0].items() if k in ("V", "lci_min", "lci_max", "a", "b", "d")
}

H4_READINGS = dict(
    base=("scaled", "tracking", "fixed"), homogenising=("h", "d", "rod", "none"), theta=(45.0, 30.0, 15.0, 0.0)
)
TRICEPT_READINGS = dict(
    cone_joints=("both", "base", "none"),
    cone_reference=("normal", "home"),
    offset_side=(1, -1),
    tilt_limit=(None, 30.0, 45.0),
    homogenising=("arm", "a"),
)


@dataclass(frozen=True)
class Reading:
    """One combination of readings: ``fixed`` constructor parameters and the orientation range (deg)."""

    mechanism: str
    fixed: tuple[tuple[str, object], ...]
    orientation: tuple[float, float]

    @property
    def label(self) -> str:
        parts = [f"{k}={v}" for k, v in self.fixed]
        lo, hi = self.orientation
        return ", ".join(parts + [f"angles ±{hi:g}°" if lo != hi else f"angles {abs(lo):g}° (constant)"])

    def config(self) -> MechanismConfig:
        return MechanismConfig(name=self.mechanism, fixed=dict(self.fixed), orientation=list(self.orientation))

    def evaluate(self, **design: float):
        fixed = {k: v for k, v in self.fixed}
        mech = get_mechanism(self.mechanism, **design, **fixed)
        return evaluate(mech, orientation=tuple(math.radians(v) for v in self.orientation), error_estimate=False)


def _log_error(ours: float, paper: float) -> float:
    return abs(math.log(max(ours, 1e-12) / paper))


# ------------------------------------------------------------------ H4
def h4_readings() -> list[Reading]:
    out = []
    for base, hom, theta in itertools.product(*H4_READINGS.values()):
        out.append(Reading("h4", (("base", base), ("homogenising", hom)), (-theta, theta)))
    return out


def h4_table(readings: list[Reading]) -> pd.DataFrame:
    """V and GDI of the paper's five designs under each reading, and the log-error score."""
    rows = []
    for reading in readings:
        row: dict = {"reading": reading.label}
        errors = []
        for name, p in H4_PAPER.items():
            ev = reading.evaluate(d=p["d"], h=p["h"], Qz=p["Qz"])
            row[f"{name} V"], row[f"{name} GDI"] = ev.volume, ev.gdi
            if name not in H4_DEGENERATE_V:
                errors.append(_log_error(ev.volume, p["V"]))
            errors.append(_log_error(ev.gdi, p["gdi"]))
        row["score"] = float(np.mean(errors))
        gdis = [
            row[f"{n} GDI"]
            for n in ("Table 1 (max V)", "Table 3 (w_d = 0.25)", "Table 3 (w_d = 0.5)", "Table 3 (w_d = 0.75)")
        ]
        row["paper's GDI order"] = bool(all(a < b for a, b in zip(gdis, gdis[1:])))
        rows.append(row)
    return pd.DataFrame(rows).sort_values("score", kind="stable").reset_index(drop=True)


def _optimum(mechanism: MechanismConfig, objective: str, w_d: float, seed: int = 0) -> tuple[np.ndarray, float]:
    """The reference optimum (IPOP-CMA-ES + polish, :func:`~pipeline.optimizers.reference_optimum`)
    of one objective (cached). Evaluated in-process: the reproduction runs the checks that call
    it side by side on its workers (a pool per check inside them only added overhead)."""
    evaluator = DesignEvaluator(mechanism, None, 1)
    problem = Problem(
        lambda x: objective_values(objective, evaluator.evaluate(x), w_d),
        mechanism.design.lower,
        mechanism.design.upper,
    )
    best = reference_optimum(problem, seed)
    return best.x, best.fun


def _values(mechanism: MechanismConfig, designs: np.ndarray) -> pd.DataFrame:
    rows = DesignEvaluator(mechanism, None, 1).evaluate(designs)
    return pd.DataFrame({"V": rows[:, 0], "GDI": rows[:, 1], "SURI": rows[:, 4]})


def check_reading(
    reading: Reading,
    paper_designs: dict[str, np.ndarray],
    cache_dir: str,
    sweep: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0),
) -> dict:
    """Optimality of the paper's designs, the V-GDI conflict and the w_d collapse under ``reading``."""
    mech = reading.config()
    optimum = cached(_optimum, cache_dir)
    out: dict = {"reading": reading.label}
    for label, objective, w_d in (("max V", "volume", 0.0), ("max GDI", "gdi", 1.0), ("η(0.5)", "mixed", 0.5)):
        x, value = optimum(mech, objective, w_d)
        out[f"{label} optimum"] = value
        out[f"{label} design"] = x
        paper_x = paper_designs.get(label)
        if paper_x is not None:
            paper_value = float(objective_values(objective, DesignEvaluator(mech, None, 1).evaluate(paper_x), w_d)[0])
            out[f"{label} paper/optimum"] = paper_value / value if value else float("nan")
    samples = sample_designs(mech.design, SampleConfig(n=64, seed=0))[mech.design.names].to_numpy()
    table = _values(mech, samples)
    inside = table["V"] > 0
    out["spearman V-GDI"] = (
        float(spearmanr(table["V"][inside], table["GDI"][inside]).statistic) if inside.sum() > 2 else float("nan")
    )
    at_max_v = _values(mech, out["max V design"][None]).iloc[0]
    out["GDI at max-V / max GDI"] = at_max_v["GDI"] / out["max GDI optimum"] if out["max GDI optimum"] else np.nan
    volumes = []
    for w_d in sweep:
        x, _ = optimum(mech, "mixed", w_d)
        volumes.append(float(_values(mech, x[None]).iloc[0]["V"]))
    out["sweep V"] = volumes
    v0 = volumes[0] or 1.0
    collapsed = [w for w, v in zip(sweep, volumes) if v < 0.1 * v0]
    out["collapse w_d"] = min(collapsed) if collapsed else None
    return out


def reading_preset(reading: Reading) -> str | None:
    """Name of the ``conf/reading/`` preset that selects exactly this reading, if any."""
    for path in sorted((CONFIG_DIR / "reading").glob("*.yaml")):
        data = yaml.safe_load(path.read_text()) or {}
        mech = data.get("mechanism", {})
        if mech.get("orientation") is None:
            continue
        if mech.get("fixed", {}) == dict(reading.fixed) and tuple(float(v) for v in mech["orientation"]) == tuple(
            reading.orientation
        ):
            return path.stem
    return None


# -------------------------------------------------------------- Tricept
def tricept_readings() -> list[Reading]:
    out = []
    for joints, ref, side, tilt, hom in itertools.product(*TRICEPT_READINGS.values()):
        if joints == "none" and ref != "normal":
            continue  # the reference does not matter without a cone limit
        fixed = (
            ("cone_joints", joints),
            ("cone_reference", ref),
            ("offset_side", side),
            ("tilt_limit", tilt),
            ("homogenising", hom),
        )
        out.append(Reading("tricept", fixed, (-90.0, 90.0)))
    return out


def tricept_table(readings: list[Reading]) -> pd.DataFrame:
    p = TRICEPT_PAPER
    rows = []
    for reading in readings:
        ev = reading.evaluate(a=p["a"], b=p["b"], d=p["d"])
        score = np.mean(
            [
                _log_error(ev.volume, p["V"]),
                _log_error(ev.inverse_condition_min, p["lci_min"]),
                _log_error(ev.inverse_condition_max, p["lci_max"]),
            ]
        )
        rows.append(
            {
                "reading": reading.label,
                "V": ev.volume,
                "1/κ min": ev.inverse_condition_min,
                "1/κ max": ev.inverse_condition_max,
                "score": float(score),
            }
        )
    return pd.DataFrame(rows).sort_values("score", kind="stable").reset_index(drop=True)
