"""Evaluation layer: the parallel evaluator of designs (workspace V, GDI, SURI of each)."""

from pipeline.evaluation.evaluator import DesignEvaluator, MechanismSpec

__all__ = ["DesignEvaluator", "MechanismSpec"]
