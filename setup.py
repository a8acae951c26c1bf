"""Build hook: ship the top-level ``conf/`` inside the wheel as ``pipeline/conf``.

The config groups live at the top of the repository (they mirror the code,
and users read them there); an installed package must still find them from
any folder, so the build copies them into the package. An editable install
reads ``conf/`` in place (``pipeline.config.registry.CONFIG_DIR``).
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py


class BuildWithConf(build_py):
    def run(self) -> None:
        super().run()
        if self.editable_mode:
            return
        source = Path(__file__).resolve().parent / "conf"
        target = Path(self.build_lib) / "pipeline" / "conf"
        shutil.rmtree(target, ignore_errors=True)
        shutil.copytree(source, target, ignore=shutil.ignore_patterns("*.pyc", "__pycache__"))


setup(cmdclass={"build_py": BuildWithConf})
