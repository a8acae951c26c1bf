"""Checks of a composed config before any work: unknown keys, ranges, grid budget, paths, dask.

:func:`validate` turns a composed Hydra config into the typed
:class:`~pipeline.config.schema.Config` (``OmegaConf.to_object``, which runs
every section's own range checks), after refusing unknown keys, then checks
what spans sections. Each failure is one :class:`~pipeline.errors.ConfigError`
line naming the field and what is allowed.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import socket
from collections.abc import Callable

from omegaconf import DictConfig, OmegaConf, open_dict
from omegaconf.errors import MissingMandatoryValue, OmegaConfBaseException

from pipeline.config.schema import MAX_HOURS, Config, ParallelConfig
from pipeline.config.suggest import did_you_mean
from pipeline.errors import ConfigError, check, check_writable
from pipeline.evaluation.pool import usable_cores, worker_count
from pipeline.optimizers import OPTIMIZERS
from pipeline.optimizers.reference import expected_evaluations as reference_evaluations

#: conservative grid throughput (nodes/s per worker) for the run-time estimate (midpoint count)
NODES_PER_SECOND = 1.0e6
#: cost of a grid node relative to the midpoint count's, per ``evaluate.method`` and, for the grid
#: method, per cell rule (``Mechanism.cell_rule``): one plane per cell costs up to 5x (H4) per node
#: at the mechanisms' default resolutions, linear margins up to 9x (the Tricept: about 2x the
#: midpoint default's time on a quarter of its nodes; docs/accuracy.md, "Measured")
METHOD_COST = {"midpoint": 1.0, "grid": 5.0, "margins": 10.0}


def _node_cost(mech, method: str) -> float:
    """:data:`METHOD_COST` of the run's method, the grid method's by the mechanism's cell rule."""
    return METHOD_COST["margins" if method == "grid" and mech.cell_rule == "margins" else method]


#: the largest evaluate.max_nodes the schema accepts (EvaluateConfig's range check): a larger
#: budget is suggested only up to it
MAX_NODES = 10**9


def _refuse_unknown_keys(node: DictConfig, schema: type, prefix: str) -> None:
    allowed = {f.name for f in dataclasses.fields(schema)}
    for key in node.keys():
        if key == "hydra" and not prefix:
            continue
        if key not in allowed:
            suggestion = did_you_mean(str(key), allowed).replace("mean ", f"mean {prefix}")
            raise ConfigError(f"{prefix}{key} is an unknown key: allowed {', '.join(sorted(allowed))}{suggestion}")
        child = node._get_node(key)
        child_type = OmegaConf.get_type(node, key) if isinstance(child, DictConfig) else None
        if isinstance(child, DictConfig) and dataclasses.is_dataclass(child_type):
            _refuse_unknown_keys(child, child_type, f"{prefix}{key}.")


def validate(cfg: DictConfig | Config) -> Config:
    """The typed config of a composed Hydra config, checked before any work.

    Raises
    ------
    ConfigError
        One line naming the first bad field and what is allowed.
    """
    if isinstance(cfg, DictConfig):
        _refuse_unknown_keys(cfg, Config, "")
        optimizer = cfg.get("optimizer")
        name = optimizer.get("name") if isinstance(optimizer, DictConfig) else None
        check("optimizer.name", name, name in OPTIMIZERS, "one of " + ", ".join(OPTIMIZERS))
        if OmegaConf.get_type(optimizer) is not OPTIMIZERS[name].Config:
            raise ConfigError(
                f"optimizer.name={name!r} is invalid: choose the optimiser with "
                f"optimizer={name} (allowed: {', '.join(OPTIMIZERS)})"
            )
        try:
            if "hydra" in cfg:  # a sweep job's config carries Hydra's own node
                cfg = copy.deepcopy(cfg)
                with open_dict(cfg):
                    del cfg["hydra"]
            typed = OmegaConf.to_object(cfg)
        except MissingMandatoryValue as exc:
            raise ConfigError(_missing_message(getattr(exc, "full_key", None) or "config")) from None
        except OmegaConfBaseException as exc:
            key = getattr(exc, "full_key", None) or "config"
            raise ConfigError(f"{key} is invalid: {str(exc).splitlines()[0]}") from None
    else:
        typed = cfg
    mech = typed.mechanism.build(typed.mechanism.centre)
    _check_orientation(typed, mech)
    _check_budget(typed, mech)
    _check_parallel(typed.parallel)
    _check_kernels()
    for key in ("output_dir", "cache_dir", "dataset_dir"):
        check_writable(f"paths.{key}", getattr(typed.paths, key))
    return typed


def _missing_message(key: str) -> str:
    """A required value left unset (``???``): which key to set, and what it takes."""
    if key == "mechanism.name":
        from kinematics import MECHANISMS

        return (
            "mechanism.name is missing: mechanism=path takes a Mechanism class of your own by its path; "
            "allowed: mechanism.name=package.module:Class (importable), or a built-in mechanism "
            f"with mechanism=NAME ({', '.join(MECHANISMS)})"
        )
    return f"{key} is missing: allowed {key}=VALUE (it has no default)"


def _check_orientation(c: Config, mech) -> None:
    """An orientation range only for a mechanism with an angular pose variable (it would be
    ignored, yet split the cache and label the results)."""
    if c.mechanism.orientation is not None and not any(mech.angular):
        raise ConfigError(
            f"mechanism.orientation={list(c.mechanism.orientation)} is invalid: {c.mechanism.name} has no angular "
            f"pose variable ({', '.join(mech.pose_names)}); allowed: null"
        )


def _check_budget(c: Config, mech) -> None:
    """Grid resolution between the mechanism's minimum and the node and time budgets (the
    default resolution and the cost per node are the integration method's)."""
    from kinematics.workspace import default_resolution, grid_nodes, sampled_axes

    orientation = c.mechanism.orientation_rad() or mech.default_orientation
    n_axes = max(len(sampled_axes(mech, orientation)), 1)
    res = c.evaluate.resolution
    if res is not None and res < mech.min_resolution and not c.evaluate.allow_coarse:
        raise ConfigError(
            f"evaluate.resolution={res} is invalid: allowed >= {mech.min_resolution} for "
            f"{c.mechanism.name} (coarser grids err by more than ~3 % in V or GDI; "
            f"evaluate.allow_coarse=true to accept that)"
        )
    method = c.evaluate.method
    res = res or default_resolution(mech, orientation, None, method)

    def nodes_at(resolution: int) -> int:
        return grid_nodes(mech, resolution, orientation, None, method)

    refined_nodes = nodes_at(res * c.evaluate.refine_factor)
    if refined_nodes > c.evaluate.max_nodes:
        top = _largest_resolution(
            c.evaluate.max_nodes ** (1 / n_axes) / c.evaluate.refine_factor,
            lambda r: nodes_at(r * c.evaluate.refine_factor) <= c.evaluate.max_nodes,
        )
        budget = (
            f"({n_axes} sampled axes x refine_factor {c.evaluate.refine_factor} give "
            f"{refined_nodes:.3g} nodes > evaluate.max_nodes={c.evaluate.max_nodes})"
        )
        if c.evaluate.resolution is not None:
            raise ConfigError(f"evaluate.resolution={res} is invalid: allowed <= {top} for {c.mechanism.name} {budget}")
        # the user set no resolution: naming 5 alone reads as a value they typed, so the message
        # says whose default it is and lists the settings that pass
        raise ConfigError(
            f"evaluate.resolution={res} (not set: the default of {_default_of(c, method)}) is invalid: "
            f"allowed <= {top} for {c.mechanism.name} {budget}; allowed: "
            + ", or ".join(_node_budget_fixes(c, mech, res, top, nodes_at))
        )
    evaluations = c.sample.n + OPTIMIZERS[c.optimizer.name](c.optimizer).expected_evaluations()
    evaluations += c.optimizer.polish_evaluations if c.optimizer.polish else 0
    # the reference optimum is computed once per problem, by the first run that asks for it: the
    # estimate is that run's (cached stages are not looked up: it is an upper bound)
    reference = reference_evaluations(len(c.mechanism.design.lower)) if c.optimizer.reference else 0
    evaluations += reference
    # nodes per second of the whole run: the method's per-worker throughput x the workers, which a
    # local backend caps at the cores this process may use (a dask cluster's are elsewhere)
    workers = c.parallel.n_jobs if c.parallel.backend == "dask" else worker_count(c.parallel.n_jobs)
    rate = NODES_PER_SECOND / _node_cost(mech, method) * workers

    def hours_at(resolution: int) -> float:
        return evaluations * nodes_at(resolution) / rate / 3600

    hours = hours_at(res)
    if hours <= c.evaluate.max_hours:
        return
    # the estimate spans fields: it grows with evaluate.resolution (nodes per evaluation), sample.n
    # and the optimiser's budget (evaluations), and falls with parallel.n_jobs; the message names
    # the bound and the resolution, and each change that would pass
    top = _largest_resolution(
        (c.evaluate.max_hours * 3600 * rate / evaluations) ** (1 / n_axes),
        lambda r: hours_at(r) <= c.evaluate.max_hours,
    )
    needed = _round_up(hours)
    fixes = [f"evaluate.max_hours >= {needed:g}"] if needed <= MAX_HOURS else []
    if top >= (1 if c.evaluate.allow_coarse else mech.min_resolution):
        fixes.append(f"evaluate.resolution <= {top}")
    elif top >= 1:
        fixes.append(
            f"evaluate.resolution <= {top} with evaluate.allow_coarse=true (below {c.mechanism.name}'s minimum)"
        )
    fixes.append(
        "fewer evaluations (sample.n, the optimizer's budget"
        + (", optimizer.reference=false" if reference else "")
        + ")"
        + (" or more parallel.n_jobs" if c.parallel.backend == "dask" or c.parallel.n_jobs < usable_cores() else "")
    )
    default = "" if c.evaluate.resolution is not None else f" (the default of {c.mechanism.name}, method {method})"
    raise ConfigError(
        f"evaluate.max_hours={c.evaluate.max_hours:g} is invalid: the run at evaluate.resolution={res}{default} "
        f"is estimated at up to {hours:.3g} h ({evaluations} evaluations of {nodes_at(res):.3g} nodes"
        + (f", {reference} of them the reference optimum's," if reference else "")
        + f" at {NODES_PER_SECOND / _node_cost(mech, method):.0e} nodes/s/worker x {workers} workers of "
        f"parallel.n_jobs={c.parallel.n_jobs}; cached stages counted too); "
        f"allowed: {', or '.join(fixes)}"
    )


def _default_of(c: Config, method: str) -> str:
    """Whose default resolution this is: the mechanism's, at the orientation range (it sets how
    many axes are sampled) and the integration method."""
    orientation = c.mechanism.orientation
    at = f" at mechanism.orientation=[{', '.join(f'{a:g}' for a in orientation)}]" if orientation is not None else ""
    return f"{c.mechanism.name}{at}, method {method}"


def _node_budget_fixes(c: Config, mech, res: int, top: int, nodes_at: Callable[[int], int]) -> list[str]:
    """The settings that pass the node budget when the default resolution ``res`` does not: a
    larger ``evaluate.max_nodes``, a smaller ``evaluate.refine_factor``, an explicit coarser
    ``evaluate.resolution``, or the mechanism's default orientation (fewer sampled axes).
    ``nodes_at`` gives the nodes of one evaluation at a resolution (the run's orientation and method)."""
    from kinematics.workspace import default_resolution, grid_nodes

    e = c.evaluate
    fixes = []
    refined_nodes = nodes_at(res * e.refine_factor)
    if refined_nodes <= MAX_NODES:
        fixes.append(f"evaluate.max_nodes={refined_nodes}")
    factors = [f for f in range(e.refine_factor - 1, 1, -1) if nodes_at(res * f) <= e.max_nodes]
    if factors:
        fixes.append(f"evaluate.refine_factor={factors[0]}")
    if top >= 1:
        coarse = top < mech.min_resolution and not e.allow_coarse
        fixes.append(
            f"evaluate.resolution={top}"
            + (
                f" with evaluate.allow_coarse=true (below {c.mechanism.name}'s minimum {mech.min_resolution})"
                if coarse
                else ""
            )
        )
    if c.mechanism.orientation is not None:
        plain = mech.default_orientation
        plain_res = default_resolution(mech, plain, None, e.method)
        if grid_nodes(mech, plain_res * e.refine_factor, plain, None, e.method) <= e.max_nodes:
            fixes.append(f"mechanism.orientation=null (the default of {c.mechanism.name}: fewer sampled axes)")
    return fixes


def _largest_resolution(estimate: float, fits: Callable[[int], bool]) -> int:
    """The largest resolution >= 0 that ``fits`` (a bound on nodes, which grow with it), searched
    from ``estimate``, the root of the bound with ``resolution`` nodes on every axis: floating point
    may put the root just below its integer (``8000 ** (1 / 3)`` is 19.999...), and an axis with
    fewer nodes (``grid_axis_nodes``) allows more."""
    top = max(int(estimate), 0)
    while fits(top + 1):
        top += 1
    while top > 0 and not fits(top):
        top -= 1
    return top


def _round_up(hours: float) -> float:
    """``hours`` rounded up to 2 significant digits (a bound that passes the check)."""
    step = 10.0 ** (math.floor(math.log10(hours)) - 1)
    return float(f"{math.ceil(hours / step) * step:.2g}") if hours > 0 else hours


def _check_kernels() -> None:
    """The environment's kernel choice (``PM_DESIGN_KERNELS``, kinematics/kernels.py) is known."""
    from kinematics import kernels

    try:
        kernels.compiled()
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def _check_parallel(p: ParallelConfig) -> None:
    """dask installed and its scheduler reachable (within 5 s), before any work."""
    if p.backend != "dask":
        return
    try:
        import distributed  # noqa: F401  (only when the dask backend is asked for)
    except ImportError:
        raise ConfigError(
            "parallel.backend='dask' is invalid: dask.distributed is not installed "
            '(pip install -e ".[dask]"); allowed without it: loky, threading, multiprocessing'
        ) from None
    if p.scheduler_address:
        host, port = p.scheduler_address.split("://", 1)[1].rsplit(":", 1)
        try:
            socket.create_connection((host, int(port)), timeout=5).close()
        except OSError as exc:
            raise ConfigError(
                f"parallel.scheduler_address={p.scheduler_address!r} is invalid: no scheduler "
                f"answers there ({exc.strerror or exc}); allowed: a reachable "
                f"tcp://host:port or null for a local cluster"
            ) from None
