"""Shared fixtures: one paper design per mechanism and random poses around it."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import get_mechanism

#: one design per mechanism, in the papers' units
PAPER_DESIGNS = {
    "h4": dict(d=6.0, h=6.0, Qz=42.0),  # seed 000 eq. 25
    "tricept": dict(a=250.0, b=400.0, d=100.0),  # inside seed 001 Table 1 bounds
    "rpr3": dict(
        base=[[0, 0], [200, 0], [0, 200]], platform=[[0, 0], [50, 0], [40, 40]], rho_min=80.0, rho_max=160.0
    ),  # seed 003 Sec. 5.2-5.4
    "rpr2": dict(b=5.0, q_min=6.0, q_max=9.6),  # seed 004
    "delta": dict(R=200.0, r=50.0, la=200.0, lb=400.0),  # kinematics/delta.py
    "gough_stewart": dict(
        r_base=400.0, r_platform=250.0, sep_base=30.0, sep_platform=30.0, height=700.0
    ),  # kinematics/gough_stewart.py, docs/gough_stewart.md
}

#: a box of poses (lower, upper) per mechanism where most poses are reachable
POSE_BOXES = {
    "h4": ([-25.0, -25.0, -70.0, -1.2], [25.0, 25.0, 10.0, 1.2]),
    "tricept": ([420.0, -0.6, -0.6], [720.0, 0.6, 0.6]),
    "rpr3": ([20.0, 20.0, -np.pi], [180.0, 180.0, np.pi]),
    "rpr2": ([-6.0, -9.0], [11.0, 9.0]),
    "delta": ([-150.0, -150.0, -480.0], [150.0, 150.0, -250.0]),
    "gough_stewart": ([-150.0, -150.0, 600.0, -0.4, -0.4, -0.4], [150.0, 150.0, 850.0, 0.4, 0.4, 0.4]),
}


def random_poses(name: str, n: int, seed: int) -> np.ndarray:
    """``n`` uniform poses (n, dof) in :data:`POSE_BOXES` [name]."""
    lo, hi = POSE_BOXES[name]
    return np.random.default_rng(seed).uniform(lo, hi, size=(n, len(lo)))


@pytest.fixture(params=sorted(PAPER_DESIGNS))
def mechanism(request):
    return get_mechanism(request.param, **PAPER_DESIGNS[request.param])
