"""Parquet I/O: atomic writes, the config in the schema metadata, units in the field metadata.

:data:`COLUMNS` is the column dictionary of every table (docs/configuration.md prints it):
unit and meaning; a ``<var>_...`` entry stands for one column per design variable. Each file's schema metadata holds the resolved config
(JSON), the package version and the git commit.

Units rule (one unit per column, whatever mechanisms a dataset mixes)
---------------------------------------------------------------------
* a column whose unit would depend on the mechanism carries the unit in its
  name: mechanism parameters are ``param_<name>_<unit>`` (``param_d_cm`` for
  H4's d, ``param_q_min_mm``, ``param_cone_deg``; no suffix for readings and
  unitless numbers), so H4's cm and Tricept's mm never share a column;
* design variables keep their names (``d_ratio``, ``a``, ...); each name
  belongs to one mechanism or has the same unit wherever it occurs (tested);
  a constructor parameter that *is* a design variable is not repeated as
  ``param_*``;
* the workspace volume's *dimension* differs between mechanisms (H4 cm³·rad
  over (x, y, z, θ), Tricept mm·rad², 2-RPR mm²), so no one unit exists:
  ``volume``, ``volume_refined``, ``reference_volume`` are in the row's
  ``volume_unit`` and objective values in ``objective_unit``; compare volumes
  of one ``volume_unit`` only (within one mechanism, its unit may change with
  the settings: the Gough-Stewart's is mm³ at constant orientation, mm³·rad³
  with ``mechanism.orientation`` set);
* every other column has one fixed unit (``COLUMNS``), stored in the Arrow
  field metadata (``unit``, ``description``) and, read back with
  :func:`pipeline.store.dataset.read_dataset`, in ``DataFrame.attrs["units"]``.
"""

from __future__ import annotations

import errno
import json
import os
import subprocess
from functools import lru_cache
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.errors import RunError
from pipeline.store.cache import __version__

META_CONFIG = b"pm_design.config"
META_VERSION = b"pm_design.version"
META_COMMIT = b"pm_design.git_commit"

#: stands for a design variable's name in a column of :data:`COLUMNS` that exists once per design
#: variable (``<var>_reference`` is ``d_ratio_reference``, ... for H4); such a column has the variable's
#: unit, and its meaning (which says "the design variable", never the placeholder) names the variable
VARIABLE = "<var>"

#: name -> (unit, meaning); "volume_unit" means the unit named in that row's volume_unit column
COLUMNS: dict[str, tuple[str, str]] = {
    "run_id": ("", "unique id of the run: config_hash-launch_id-job-token (dataset only)"),
    "launch_id": ("", "the launch (process) that ran it: time_pid_token (dataset only)"),
    "job": ("", "job number within its launch (dataset only)"),
    "config_hash": ("", "content hash of the result config (equal studies, equal hash)"),
    "study_hash": (
        "",
        "content hash of the result config without the seed and w_d: one study's seeds and w_d points "
        "(dataset only; empty for runs aggregated before it existed)",
    ),
    "experiment": ("", "experiment_name of the run"),
    "mechanism": ("", "mechanism registry name"),
    "objective": ("", "maximised objective: volume, gdi, suri or mixed"),
    "w_d": ("1", "weight of the GDI in eta = w_d GDI + (1 - w_d) SURI (seed 000 eq. 36)"),
    "optimizer": ("", "optimiser registry name"),
    "seed": ("", "optimiser seed"),
    "purpose": (
        "",
        "why the run was made: study, debug (+debug presets) or benchmark (dataset only; "
        "read_dataset leaves debug runs out unless asked)",
    ),
    "design_id": ("", "index of the sampled design"),
    "generation": ("", "generation (0 = initial population)"),
    "best": ("objective_unit", "best objective value in the population"),
    "mean": ("objective_unit", "mean objective value in the population"),
    "worst": ("objective_unit", "worst objective value in the population"),
    "n_evaluations": ("", "objective evaluations (history: new in that generation; best: whole run)"),
    "restart": ("", "CMA-ES run index (-1: the scout batch)"),
    "front_size": ("", "non-dominated designs in the NSGA-II population"),
    "volume": ("volume_unit", "workspace volume V (seed 000 Sec. 4.3; seed 001 eq. 38-39)"),
    "volume_unit": ("", "unit of volume, e.g. cm³·rad for H4 over (x, y, z, θ)"),
    "gdi": ("1", "global dexterity index (1/V) ∫ 1/κ dV (seed 000 eq. 36)"),
    "inverse_condition_min": ("1", "smallest 1/κ in the workspace"),
    "inverse_condition_max": ("1", "largest 1/κ in the workspace"),
    "suri": ("1", "space utility ratio V/V*"),
    "reference_volume": ("volume_unit", "robot size V* of SURI"),
    "n_samples": (
        "",
        "sample points of the integration rule: the grid's nodes; exact sections (2-RPR, 3-RPR): "
        "one per node spacing along each row (kinematics.workspace.Evaluation)",
    ),
    "n_inside": (
        "",
        "of those, the points inside the dexterous workspace: n_inside / n_samples is the filled "
        "share of the region the rule samples (the grid's box; the 2-RPR's pose box; the 3-RPR's y extents)",
    ),
    "valid": ("", "the design could be built (false: infeasible parameters, all zeros)"),
    "objective_value": ("objective_unit", "value of the run's objective (eta when objective = mixed)"),
    "objective_unit": ("", "unit of objective_value: volume_unit for volume, 1 otherwise"),
    "objective_value_refined": ("objective_unit", "objective at refine_factor x the resolution"),
    "objective_error": (
        "objective_unit",
        "estimated discretisation error of objective_value: |objective_value_refined - objective_value|",
    ),
    "volume_refined": ("volume_unit", "V at refine_factor x the resolution"),
    "gdi_refined": ("1", "GDI at refine_factor x the resolution"),
    "resolution": ("", "grid points per sampled axis of the run's evaluations"),
    "method": (
        "",
        "workspace integration method of the run's evaluations (evaluate.method): grid (boundary "
        "fractions, second order; cells by the mechanism's cell rule, docs/accuracy.md) or midpoint "
        "(cell-centre count, first order); null in runs made before it was recorded (they used midpoint)",
    ),
    "at_bounds": ("", "design variables on a bound of the design box, as name=lower or name=upper"),
    "optimizer_value": ("objective_unit", "what the configured optimiser found, before polish"),
    "found_by": ("", "where the reported optimum comes from: the optimiser or its polish step"),
    "polish_improvement": ("objective_unit", "gain of the polish step over the optimiser's result"),
    "reference_value": (
        "objective_unit",
        "reference optimum of the problem: the best of several independent "
        "searches (CMA-ES seeds, DE, dense grid; each polished); null if not run",
    ),
    "reference_gap": (
        "1",
        "(reference_value - objective_value) / reference_value: how far the run stops "
        "short of the reference optimum; null if no reference was run",
    ),
    "reference_error": (
        "objective_unit",
        "estimated discretisation error of reference_value (its change at refine_factor x the resolution)",
    ),
    "reference_gap_error": ("1", "(objective_error + reference_error) / reference_value: the error of reference_gap"),
    "reference_gap_within_error": (
        "",
        "|reference_gap| <= reference_gap_error: the gap is not resolved by the "
        "objective's accuracy; false if no reference was run",
    ),
    "reference_gap_label": (
        "",
        "the gap as reported: 'within error (< e %)', 'g % ± e %' or, for a run better than the reference "
        "by more than the error, 'beats the reference by g % ± e %'",
    ),
    "reference_found_by": ("", "the search that found the reference optimum and how many searches agree"),
    "reference_evaluations": ("", "objective evaluations of the reference searches (not in n_evaluations)"),
    VARIABLE + "_reference": (
        "the design variable's",
        "the design variable at the reference optimum (in best, one column per design variable; null if no "
        "reference was run)",
    ),
    "flat_variables": ("", "design variables along which the objective is flat at the optimum (the optimum is a set)"),
    VARIABLE + "_flat_lower": (
        "the design variable's",
        "lower end of the interval of the design variable (the others held at the optimum) over which the "
        "objective stays within a relative 1e-9 of the optimum's value (in best, one column per design "
        "variable; the optimum's value of the variable if it is not flat)",
    ),
    VARIABLE + "_flat_upper": (
        "the design variable's",
        "upper end of the interval of the design variable over which the objective is flat at the optimum "
        "(as for the lower end; in best, one column per design variable)",
    ),
    "eta": (
        "1",
        "mixed index eta = w_d GDI + (1 - w_d) SURI at the row's w_d (seed 000 eq. 36); only in the file "
        "of pm-design evaluate --parquet (in a run's tables: objective_value when objective = mixed)",
    ),
    "status": ("", "run status from its manifest: complete"),
    "wall_time": ("s", "wall time of the run"),
    "source": ("", "run directory the dataset row was read from"),
    "overrides": ("", "the run's command-line overrides"),
    "code_version": ("", "package version + hash of the sources that computed the run"),
    "git_commit": ("", "git commit of the sources (-dirty: with uncommitted changes)"),
}


@lru_cache(maxsize=1)
def git_commit() -> str:
    """Commit of the source checkout ("unknown" outside git), "-dirty" if it has changes."""
    root = Path(__file__).resolve().parent.parent
    try:
        sha = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return sha + ("-dirty" if dirty else "")


def column_unit(name: str, units: dict[str, str] | None = None) -> tuple[str, str]:
    """(unit, meaning) of a column; ``units`` gives the mechanism's design-variable units."""
    units = units or {}
    if name in units:
        return units[name], "design variable or mechanism parameter"
    if name in COLUMNS:
        return COLUMNS[name]
    for pattern, (_, meaning) in COLUMNS.items():
        if pattern.startswith(VARIABLE):
            suffix = pattern[len(VARIABLE) :]
            variable = name[: -len(suffix)]
            if name.endswith(suffix) and variable in units:
                return units[variable], meaning.replace("the design variable", f"the design variable {variable}", 1)
    if name.startswith("param_"):
        stem = name[len("param_") :]
        for unit in PARAM_UNITS:
            if stem.endswith(f"_{unit}"):
                return unit, f"mechanism constructor parameter {stem[: -len(unit) - 1]} ({unit})"
        return "", f"mechanism constructor parameter {stem} (a reading's name or a unitless number)"
    return "", ""


#: units a ``param_*`` column name can end with (:func:`param_column`)
PARAM_UNITS = ("cm", "mm", "m", "deg")


def param_column(name: str, unit: str) -> str:
    """Dataset column of mechanism parameter ``name`` in ``unit`` (units rule of this module):
    ``param_d_cm``; ``param_base`` for a reading or a unitless number (unit "" or "1")."""
    if unit in ("", "1"):
        return f"param_{name}"
    if unit not in PARAM_UNITS:
        raise ValueError(f"parameter {name!r}: unit {unit!r} is not one of {', '.join(PARAM_UNITS)}")
    return f"param_{name}_{unit}"


def to_table(df: pd.DataFrame, units: dict[str, str] | None = None) -> pa.Table:
    """Arrow table of ``df`` with each field's unit and meaning in its metadata."""
    table = pa.Table.from_pandas(df, preserve_index=False)
    fields = []
    for f in table.schema:
        unit, meaning = column_unit(f.name, units)
        fields.append(f.with_metadata({b"unit": unit.encode(), b"description": meaning.encode()}))
    return table.cast(pa.schema(fields, metadata=table.schema.metadata))


def write_table(table: pa.Table, path: Path, config: dict | None = None) -> Path:
    """Write ``table`` to ``path`` atomically (temporary file, then rename).

    Raises
    ------
    RunError
        One line when the file cannot be written (disk full, permission).
    """
    path = Path(path)
    meta = dict(table.schema.metadata or {})
    meta.pop(b"pandas", None)
    if config is not None:
        meta[META_CONFIG] = json.dumps(config, sort_keys=True, default=str).encode()
    meta[META_VERSION] = __version__.encode()
    meta[META_COMMIT] = git_commit().encode()
    table = table.replace_schema_metadata(meta)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(table, tmp)
        os.replace(tmp, path)
    except OSError as exc:
        reason = "no space left on device" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        raise RunError(f"cannot write {path}: {reason}") from None
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def write_parquet(df: pd.DataFrame, path: Path, config: dict, units: dict[str, str] | None = None) -> Path:
    """``df`` to ``path`` (atomic), with units and the config (see :func:`write_table`)."""
    return write_table(to_table(df, units), path, config)


def write_text(path: Path, text: str) -> Path:
    """Write a small text file atomically; :class:`RunError` (one line) if it cannot be written."""
    return write_bytes(path, text.encode())


def write_bytes(path: Path, data: bytes) -> Path:
    """Write a file atomically (temporary file, then rename); :class:`RunError` (one line) on failure."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    except OSError as exc:
        if tmp.exists():
            tmp.unlink()
        reason = "no space left on device" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        raise RunError(f"cannot write {path}: {reason}") from None
    return path


def read_metadata(path: Path) -> dict:
    """``{"config": dict, "version": str, "git_commit": str}`` of a file written here."""
    meta = pq.read_schema(path).metadata or {}
    return {
        "config": json.loads(meta[META_CONFIG]) if META_CONFIG in meta else None,
        "version": meta[META_VERSION].decode(),
        "git_commit": meta[META_COMMIT].decode(),
    }
