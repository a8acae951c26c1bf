"""pm-design's workflow: Hydra-configured, cached design studies of parallel mechanisms.

Six floors, each importing only floors below it (``[tool.importlinter]`` in
pyproject.toml; ``docs/architecture.md``): cli | reproduction | sweeps (the entry
points) > report | study > stages > config > evaluation | optimizers | store >
objectives | errors.
"""

from pathlib import Path


def _config_dir() -> Path:
    """The primary config directory: the wheel's copy (``pipeline/conf``, mapped from the
    top-level ``conf/`` at build time by ``setup.py``), else the source tree's ``conf/``."""
    packaged = Path(__file__).resolve().parent / "conf"
    return packaged if packaged.is_dir() else Path(__file__).resolve().parents[1] / "conf"


#: the primary config directory (works from a wheel, from an editable install, from any folder)
CONFIG_DIR = _config_dir()
