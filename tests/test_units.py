"""The dataset's units rule (pipeline/store/parquet.py): one unit per column whatever mechanisms are mixed."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import MECHANISMS
from pipeline.store.parquet import PARAM_UNITS, column_unit, param_column

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow


def test_a_design_variable_name_has_one_unit_in_every_mechanism():
    units: dict[str, set[str]] = {}
    for cls in MECHANISMS.values():
        for v in cls.design_variables:
            units.setdefault(v.name, set()).add(v.unit)
    assert {n: u for n, u in units.items() if len(u) > 1} == {}


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_parameter_columns_name_their_unit_and_never_repeat_a_design_variable(name):
    cls = MECHANISMS[name]
    centre = np.array([0.5 * (v.lower + v.upper) for v in cls.design_variables])
    params = cls.from_design(centre, **cls.default_fixed).params()
    names = {v.name for v in cls.design_variables}
    for key, value in params.items():
        if not isinstance(value, (int, float, str)) or isinstance(value, bool) or key in names:
            continue
        unit = cls.param_unit(key, value)
        column = param_column(key, unit)
        assert column_unit(column)[0] == ("" if unit in ("", "1") else unit)
        if isinstance(value, str):
            assert column == f"param_{key}"
        else:
            assert unit in (*PARAM_UNITS, "1"), (key, unit)


def test_one_column_one_unit_across_mechanisms():
    """H4's d (cm) and the Tricept's parameters (mm) can never meet in one column."""
    seen: dict[str, str] = {}
    for cls in MECHANISMS.values():
        centre = np.array([0.5 * (v.lower + v.upper) for v in cls.design_variables])
        for key, value in cls.from_design(centre, **cls.default_fixed).params().items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                column = param_column(key, cls.param_unit(key, value))
                assert seen.setdefault(column, cls.param_unit(key, value)) == cls.param_unit(key, value)
    assert "param_d_cm" in seen and "param_d" not in seen


def test_unknown_parameter_units_are_refused():
    with pytest.raises(ValueError, match="not one of"):
        param_column("d", "inch")
