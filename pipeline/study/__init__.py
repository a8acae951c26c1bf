"""Study layer: one run of the pipeline (:func:`run_study`), its lifecycle and its chain of stages.

:mod:`.run` owns the run's lifecycle (checked config, manifest states, identity);
:mod:`.compute` the chain of cached stages and the files it writes.
"""

from pipeline.study.run import run_study

__all__ = ["run_study"]
