"""The papers' reference numbers, as data beside the experiments that reproduce them.

One YAML file per paper and mechanism (``<name>.yaml``): ``mechanism``, the
``experiments`` that reproduce each objective, and ``rows``, one per printed
table row, with the objective (and ``w_d`` for the mixed index), the printed
values and the printed optimal design. Units are stated in each file's header.
:mod:`pipeline.reproduction.paper_report` compares a dataset with them; the reproduction
document and the readings study read the same rows.
"""

from __future__ import annotations

from pathlib import Path

from omegaconf import OmegaConf

from pipeline.errors import ConfigError

PAPERS_DIR = Path(__file__).resolve().parent


def paper_names() -> list[str]:
    """Names of the papers with reference data (``seed000_h4``, ...)."""
    return sorted(p.stem for p in PAPERS_DIR.glob("*.yaml"))


def load_paper(name: str) -> dict:
    """The reference data of one paper (see the module docstring); ConfigError for an unknown name."""
    path = PAPERS_DIR / f"{name}.yaml"
    if name not in paper_names():
        raise ConfigError(f"--paper={name!r} is invalid: allowed {', '.join(paper_names())}")
    return OmegaConf.to_container(OmegaConf.load(path))
