"""Workflow pipeline: sample -> evaluate -> optimise -> aggregate -> plot."""
