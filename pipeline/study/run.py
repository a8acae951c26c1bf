"""One study: validate -> sample -> evaluate -> optimise -> Parquet -> plots -> manifest.

``run_study(cfg, run_dir)`` is what ``python -m pipeline`` calls for every
run of a launch, and what the tests call with a config built by Hydra's
compose API.

Run lifecycle and identity
--------------------------
* the config is checked completely before anything is computed or written;
* a run directory that already holds a run (a ``manifest.json``) is refused:
  nothing is ever replaced;
* ``manifest.json`` is written first with ``status: running`` and rewritten
  *last* (after the figures) with ``complete`` and the timings, or ``failed``
  with a one-line reason, or ``interrupted``. Aggregation takes complete
  runs only. Its ``stages`` says, per stage, whether it was ``computed`` or
  read from the cache (``cached``): the record the reproduction counts;
* the run id is ``<config_hash>-<launch_id>-<job>-<token>``: the content hash
  of the result config (equal studies share it), the launch and job that ran
  it, and a random token, so different runs never share it even when one
  process runs the same study twice. The result tables carry ``config_hash``
  only, so the same config gives bit-identical Parquet files whatever the
  workers or the launch; the run id is in the manifest and in the dataset.
"""

from __future__ import annotations

import json
import logging
import os
import secrets
import time
from pathlib import Path

from omegaconf import DictConfig

from pipeline.config import Config, validate
from pipeline.errors import RunError, Terminated, describe_fault, interrupt_in
from pipeline.store.cache import CODE_VERSION
from pipeline.store.parquet import git_commit, write_text
from pipeline.store.runs import MANIFEST, check_run_dir, launch_id
from pipeline.study.compute import compute

log = logging.getLogger(__name__)


def run_study(
    cfg: DictConfig | Config, run_dir: Path, job: int = 0, overrides: list[str] | None = None
) -> dict[str, Path]:
    """Run one study into ``run_dir``; returns the paths written.

    Raises
    ------
    ConfigError
        Before any computation or file, for bad input.
    RunError
        When the run fails at run time; the manifest then says ``failed`` and why.
    """
    c = validate(cfg)
    run_dir = Path(run_dir)
    check_run_dir(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    config = c.result_dict()
    # the token keeps two runs of one launch and job apart (API use: tests, notebooks, reproduce)
    run_id = f"{c.config_hash()}-{launch_id()}-{job}-{secrets.token_hex(3)}"
    manifest = {
        "run_id": run_id,
        "config_hash": c.config_hash(),
        "launch_id": launch_id(),
        "job": job,
        "status": "running",
        "reason": "",
        "overrides": list(overrides or []),
        "code_version": CODE_VERSION,
        "git_commit": git_commit(),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "timings": {},
        "stages": {},
        "files": [],
        "config": config,
    }
    write_text(run_dir / MANIFEST, json.dumps(manifest, indent=1))
    try:
        paths = compute(c, run_dir, manifest["timings"], manifest["stages"])
        manifest.update(
            status="complete", files=sorted(p.name for p in paths.values()), finished=time.strftime("%Y-%m-%dT%H:%M:%S")
        )
        write_text(run_dir / MANIFEST, json.dumps(manifest, indent=1))
    except BaseException as exc:  # noqa: BLE001 - every way out leaves a final state, then re-raises
        interrupt = interrupt_in(exc)
        if interrupt is not None:
            what = "terminated (SIGTERM)" if isinstance(interrupt, Terminated) else "interrupted (Ctrl-C)"
            manifest.update(status="interrupted", reason=what)
            _write_final_manifest(run_dir, manifest)
            if interrupt is exc:
                raise
            raise interrupt from None
        if not isinstance(exc, Exception):  # SystemExit, GeneratorExit: not a result either
            manifest.update(status="failed", reason=type(exc).__name__)
            _write_final_manifest(run_dir, manifest)
            raise
        manifest.update(status="failed", reason=describe_fault(exc, run_dir))
        _write_final_manifest(run_dir, manifest)
        raise RunError(manifest["reason"]) from exc
    return paths


def _write_final_manifest(run_dir: Path, manifest: dict) -> None:
    """Rewrite the manifest with its final state, even on a full disk.

    The usual atomic rewrite needs new blocks; when it fails, the state is
    written over the ``running`` manifest in place (its blocks are already
    allocated), without the config and padded with spaces (valid JSON).
    """
    try:
        write_text(run_dir / MANIFEST, json.dumps(manifest, indent=1))
        return
    except RunError as exc:  # the disk that failed the run may refuse this too
        failure = exc
    slim = {k: v for k, v in manifest.items() if k not in ("config", "overrides", "timings")}
    data = json.dumps(slim).encode()
    try:
        with open(run_dir / MANIFEST, "r+b") as handle:
            size = os.fstat(handle.fileno()).st_size
            if len(data) > size:
                slim["reason"] = slim["reason"][: max(0, len(slim["reason"]) - (len(data) - size))]
                data = json.dumps(slim).encode()
            handle.write(data + b" " * max(0, size - len(data)))
            handle.flush()
            os.fsync(handle.fileno())
        log.error("%s; the manifest was updated in place", failure)
    except OSError as exc:
        log.error("manifest of %s not updated to %s: %s", run_dir, manifest["status"], exc.strerror or exc)
