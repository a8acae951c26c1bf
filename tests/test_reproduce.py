"""Claims made in docs/reproduction.md that are checked by computation."""

from __future__ import annotations

import numpy as np

from kinematics import get_mechanism
from pipeline.reproduce import THESIS, _upper_hull, thesis_jacobian_program

PRINTED = np.array([[-0.855658, 0.190268, -0.0903346], [-0.811356, -0.93643, 0.444595],
                    [-0.00522636, -0.0127963, -0.00770599]])


def test_thesis_program_explains_the_printed_jacobian():
    """-A^-1 B with the appendix's index bug and legs (100, 150, 150) gives the printed matrix."""
    program = thesis_jacobian_program(97.99, 19.91, 85.02, (100.0, 150.0, 150.0))
    assert np.max(np.abs(program / PRINTED - 1)) < 0.01
    # ... and the stated data (legs 100, 120, 150) do not
    stated = thesis_jacobian_program(97.99, 19.91, 85.02, (100.0, 120.0, 150.0))
    assert np.max(np.abs(stated / PRINTED - 1)) > 0.1


def test_our_jacobian_is_not_the_printed_one():
    m = get_mechanism("rpr3", **THESIS)
    mode = m.forward([100.0, 120.0, 150.0])[1]
    inverse = np.linalg.inv(m.jacobian(mode[None])[0])
    assert np.max(np.abs(-inverse / PRINTED - 1)) > 0.1


def test_upper_hull_drops_concave_points():
    front = np.array([[1.0, 0.0], [0.6, 0.3], [0.55, 0.5], [0.0, 1.0]])  # (gdi, suri)
    # in the (SURI, GDI) plane (0.3, 0.6) lies below the chord from (0, 1) to (0.5, 0.55)
    assert _upper_hull(front).tolist() == [[1.0, 0.0], [0.55, 0.5], [0.0, 1.0]]
