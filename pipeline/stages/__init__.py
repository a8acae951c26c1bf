"""Stages layer: sample, evaluate, optimise, aggregate, plot; functions from tables to tables.

Each computing stage is a plain function of typed config sections, cached by
:mod:`pipeline.study` with :func:`pipeline.store.cache.cached`.
"""
