"""The document's driver: runs the experiments' declared sweeps into one dataset and collects sections.

Each paper table or figure is an experiment (``conf/experiment/*.yaml``)
that declares its own sweep in ``hydra.sweeper.params``. :meth:`Reproduction.experiment`
runs it as ``python -m pipeline -m +experiment=NAME`` runs it, in this process
(:func:`pipeline.reproduction.launch.multirun`: Hydra's compose API, the
project's sweeper, Hydra's joblib launcher with two jobs side by side and one
fitness worker each, the CLI's task), into the document's dataset, and returns
the jobs' ``best`` rows read back with ``pd.read_parquet`` from that dataset.
Which stages computed is read from the runs' manifests (``stages``). The
sections (one module per paper) only read the dataset and write text and figures.
"""

from __future__ import annotations

import copy
import re
import secrets
import threading
from collections.abc import Sequence
from pathlib import Path

import pandas as pd
from hydra import compose, initialize_config_dir
from hydra.core.override_parser.overrides_parser import OverridesParser
from joblib import Parallel, delayed
from omegaconf import DictConfig, OmegaConf, open_dict

from pipeline.config import CONFIG_DIR, register_configs
from pipeline.config import jobs as sweeps
from pipeline.reproduction.launch import multirun
from pipeline.store.cache import cached
from pipeline.store.runs import launch_id, read_manifest

#: studies run side by side (each with one fitness worker): the machine's 2 cores
STUDY_JOBS = 2


def _split(overrides: Sequence[str]) -> tuple[tuple[str, ...], list[str]]:
    """Group choices (keys without a dot: ``+experiment=``, ``mechanism=``) and value overrides."""
    groups = tuple(o for o in overrides if "." not in o.split("=", 1)[0])
    return groups, [o for o in overrides if "." in o.split("=", 1)[0]]


def with_values(cfg: DictConfig, values: Sequence[str]) -> DictConfig:
    """``cfg`` with value overrides (``key=value``) applied as Hydra applies them after composing."""
    for override in OverridesParser.create().parse_overrides(list(values)):
        OmegaConf.update(cfg, override.key_or_group, override.value(), merge=True)
    return cfg


def _worker_ready() -> None:
    """Nothing: unpickling it imports this module, and so everything a study needs, in a new worker.

    Why imports and not a bare no-op: loky takes a worker's memory after its first task as
    the reference of its leak guard (a worker more than 300 MB above it is replaced, with a
    warning); a first task that imported nothing would make the first study's imports look
    like a leak.
    """


def computed_stages(run_dir: Path) -> int:
    """How many stages the run in ``run_dir`` computed (cache misses), from its manifest's
    ``stages`` record (:func:`pipeline.study.run_study` writes it; no log text is read)."""
    manifest = read_manifest(run_dir) or {}
    return sum(state == "computed" for state in manifest.get("stages", {}).values())


def sweep_jobs(params: dict[str, str]) -> list[list[str]]:
    """The jobs of a declared sweep (``hydra.sweeper.params``), as ``python -m pipeline -m`` runs them.

    ``{"objective.w_d": "0.25,0.5", "optimizer.seed": "0,1"}`` gives
    ``[["objective.w_d=0.25", "optimizer.seed=0"], ...]`` (4 jobs); no params: one job, no overrides.
    """
    return sweeps.sweep_jobs(sweeps.declared_overrides(params, []))


class Reproduction:
    """Runs the experiments (cached) into one dataset and collects the document's sections.

    Parameters
    ----------
    out : Path
        Document directory (``reproduction.md``, ``figures/``).
    output_dir : Path
        Pipeline outputs: the stage cache (``cache/``) and this document's runs and
        dataset (``reproduction/<id>/runs``, ``reproduction/<id>/dataset``; a new
        ``<id>`` per document, so a dataset never mixes two documents' runs).
    """

    def __init__(self, out: Path, output_dir: Path) -> None:
        self.out = out
        self.figures = out / "figures"
        self.figures.mkdir(parents=True, exist_ok=True)
        self.output_dir = output_dir
        self.sections: list[str] = []
        self.computed = 0  # stages computed (cache misses) by the studies, and document computations
        self._bases: dict[tuple[str, ...], DictConfig] = {}  # composed configs by group choices
        root = output_dir / "reproduction" / f"{launch_id()}-{secrets.token_hex(2)}"
        self.runs_dir = root / "runs"
        self.dataset = root / "dataset"
        self.runs: list[pd.DataFrame] = []  # every experiment's best rows, in the order first read
        self._ran: dict[str, tuple[list[list[str]], list[Path]]] = {}  # label -> jobs, run directories
        self._read: set[str] = set()
        self._sweeps: dict[tuple[str, ...], dict[str, str]] = {}  # declared sweeps by group choices
        register_configs()
        # joblib's workers start now, in the background: their start-up (~1.5 s of imports)
        # then overlaps the composing of the first batch instead of following it (the batch's
        # Parallel call reuses them: joblib keeps one reusable pool)
        self._warm = threading.Thread(
            target=lambda: Parallel(n_jobs=STUDY_JOBS)(delayed(_worker_ready)() for _ in range(STUDY_JOBS)), daemon=True
        )
        self._warm.start()

    # ------------------------------------------------------------ experiments
    def run_experiments(self, requests: Sequence[tuple[str, Sequence[str]]], alongside: Sequence = ()) -> None:
        """Run the declared sweeps of several experiments, each as a user's multirun.

        Each request ``(name, extra overrides)`` is ``python -m pipeline -m
        +experiment=NAME *extra`` (:func:`pipeline.reproduction.launch.multirun`:
        the project's sweeper checks every job first, Hydra's joblib launcher
        runs :data:`STUDY_JOBS` jobs side by side with one fitness worker each,
        the sweep is aggregated into the document's dataset at its end); a
        one-job sweep runs on the basic launcher with :data:`STUDY_JOBS` fitness
        workers. Experiments already run by this document are not run again.
        ``alongside``: other independent tasks (:meth:`pending`), run first,
        :data:`STUDY_JOBS` at a time.

        Cost of the user's path: Hydra composes every job twice (the sweeper's
        check, the launcher; ~0.15 s each) and writes its records and log per
        job: about 1 s more per job than when the driver ran the studies itself
        from :meth:`_base`'s composed configs (measured alternately on this
        2-core machine, two tiny sweeps of 9 jobs each with every stage cached:
        21-25 s against 7-11 s; the whole document with a full cache took 74 s
        under a load of 5). :meth:`_base` still composes once per experiment,
        to read its declared sweep.
        """
        self._run_tasks(list(alongside))
        for name, extra in requests:
            label, jobs = self._plan(name, extra)
            if label in self._ran:
                continue
            sweep_dir = self.runs_dir / label
            launcher = (
                ["parallel.n_jobs=1", "hydra/launcher=joblib", f"hydra.launcher.n_jobs={STUDY_JOBS}"]
                if len(jobs) > 1
                else [f"parallel.n_jobs={STUDY_JOBS}"]
            )
            self._warm.join()  # the joblib launcher's Parallel runs on joblib's (now warm) pool
            multirun(
                [
                    f"+experiment={name}",
                    *extra,
                    # quoted: a label holds "=" and "+", which Hydra's override grammar would parse
                    f"paths.output_dir='{self.output_dir}'",
                    f"paths.dataset_dir='{self.dataset}'",
                    f"hydra.sweep.dir='{sweep_dir}'",
                    "hydra.sweep.subdir=${hydra.job.num}",  # job k's run directory: <sweep>/k
                    "plot.enabled=false",
                    "hydra.sweeper.report=false",  # the document draws its own figures
                    *launcher,
                ]
            )
            run_dirs = [sweep_dir / str(k) for k in range(len(jobs))]
            # the studies' own record of what they computed (their manifests), wherever they ran
            self.computed += sum(computed_stages(run_dir) for run_dir in run_dirs)
            self._ran[label] = (jobs, run_dirs)

    def experiment(self, name: str, extra: Sequence[str] = ()) -> pd.DataFrame:
        """Experiment ``name``'s declared sweep (plus ``extra`` overrides), run if not yet; its best rows.

        An ``extra`` override of a swept key replaces that key's sweep (Hydra's precedence).

        Returns
        -------
        DataFrame
            One row per job, in the sweep's job order, read back from the
            document's dataset (``pd.read_parquet(dataset / "best")``), with the
            job's overrides in a column ``overrides`` and a label in ``study``.
        """
        label, _ = self._plan(name, extra)
        if label not in self._ran:
            self.run_experiments([(name, extra)])
        jobs, run_dirs = self._ran[label]
        best = self.table("best", [read_manifest(d)["run_id"] for d in run_dirs])
        best.insert(0, "overrides", [" ".join(job) for job in jobs])
        best.insert(0, "study", [f"{label} {' '.join(job)}".strip() for job in jobs])
        if label not in self._read:
            self._read.add(label)
            self.runs.append(best)
        return best

    def _plan(self, name: str, extra: Sequence[str]) -> tuple[str, list[list[str]]]:
        """The label of an experiment with ``extra`` overrides, and its jobs' overrides."""
        # as on Hydra's command line, an override of a swept key replaces that key's declared sweep
        given = {o.split("=", 1)[0].lstrip("+~") for o in extra}
        params = {key: values for key, values in self._declared_sweep(name).items() if key not in given}
        label = "+".join([name, *(re.sub(r"[^A-Za-z0-9_.=-]", "_", o.lstrip("+")) for o in extra)])
        return label, sweep_jobs(params)

    def table(self, table: str, run_ids: Sequence[str]) -> pd.DataFrame:
        """Rows of a dataset table for ``run_ids``, in that order (``pd.read_parquet`` with a filter)."""
        frame = pd.read_parquet(self.dataset / table, filters=[("run_id", "in", list(run_ids))])
        order = {run_id: k for k, run_id in enumerate(run_ids)}
        frame = frame.iloc[frame["run_id"].map(order).argsort(kind="stable")]
        return frame.reset_index(drop=True)

    def _declared_sweep(self, name: str) -> dict[str, str]:
        """``hydra.sweeper.params`` of experiment ``name``."""
        groups = (f"+experiment={name}",)
        self._base(groups)
        return self._sweeps[groups]

    def _base(self, groups: tuple[str, ...]) -> DictConfig:
        """The config of a set of group choices, composed by Hydra once (with its declared sweep).

        Why: a Hydra compose costs ~0.15 s and the document runs ~75 studies
        that differ only in values (w_d, seed, ...).
        """
        if groups not in self._bases:
            with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
                cfg = compose(config_name="config", overrides=list(groups), return_hydra_config=True)
            with open_dict(cfg):
                hydra = cfg.pop("hydra")
            self._sweeps[groups] = {str(k): str(v) for k, v in (hydra.sweeper.params or {}).items()}
            self._bases[groups] = cfg
        return self._bases[groups]

    def compose(self, overrides: list[str]) -> DictConfig:
        """Hydra's config for ``overrides``, composing once per set of group choices.

        Group choices (``+experiment=``, ``+reading=``, ``mechanism=``: keys
        without a dot) are composed by Hydra and kept (:meth:`_base`); value
        overrides (dotted keys) are then applied the way Hydra applies them
        after composing (:func:`with_values`). ``tests/test_reproduce.py``
        checks the result equals a full compose.
        """
        groups, values = _split(overrides)
        return with_values(copy.deepcopy(self._base(groups)), values)

    def _run_tasks(self, tasks: list) -> list:
        """joblib's delayed ``tasks``, :data:`STUDY_JOBS` at a time (in order, results in order)."""
        if len(tasks) <= 1:
            return [func(*args, **kwargs) for func, args, kwargs in tasks]
        self._warm.join()  # one Parallel call at a time on joblib's pool
        return Parallel(n_jobs=min(STUDY_JOBS, len(tasks)))(tasks)

    # ------------------------------------------------------------ document
    def memo(self, func):
        """``func`` cached in the stage cache (the document's own computations: evaluations,
        readings tables), so a second run only reads them back."""
        return cached(func, str(self.output_dir / "cache"))

    def pending(self, func, calls: Sequence[tuple]) -> list:
        """The calls ``self.memo(func)(*args)`` not yet in the cache, as joblib tasks for
        :meth:`run_experiments` (``alongside``) or :meth:`memo_map`."""
        memo = self.memo(func)
        tasks = [delayed(memo)(*args) for args in calls if not memo.check_call_in_cache(*args)]
        self.computed += len(tasks)  # each is a computation (a cache miss) once run
        return tasks

    def memo_map(self, func, calls: Sequence[tuple]) -> list:
        """``[self.memo(func)(*args) for args in calls]``, the calls not yet in the cache computed
        :data:`STUDY_JOBS` at a time on the studies' workers (independent calls, e.g. the
        readings study's optimality checks, which would otherwise leave a core idle)."""
        self._run_tasks(self.pending(func, calls))
        memo = self.memo(func)
        return [memo(*args) for args in calls]

    def cached_figures(self, draw, *args: object) -> None:
        """Write the PNG files ``draw(*args)`` returns (``{file name: bytes}``) into ``figures/``,
        drawn once per arguments (cached like :meth:`memo`): a warm document copies them."""
        for name, data in self.memo(draw)(*args).items():
            (self.figures / name).write_bytes(data)

    def figure(self, name: str) -> str:
        return f"figures/{name}"

    def add(self, text: str) -> None:
        self.sections.append(text.strip() + "\n")
