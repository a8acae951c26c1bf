"""Claims made in docs/reproduction.md that are checked by computation."""

from __future__ import annotations

import numpy as np
import pytest

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


def test_independent_studies_run_side_by_side_and_are_cached(tmp_path):
    from pipeline.reproduce import Reproduction

    tiny = ["+experiment=rpr2_mixed", "+debug=fast", "optimizer.population=4", "optimizer.generations=2"]
    specs = [(f"wd{w}", [*tiny, f"objective.w_d={w}"]) for w in (0.0, 1.0)]
    side = Reproduction(tmp_path / "doc", tmp_path / "outputs")
    first = side.studies(specs)
    assert side.computed >= 4  # sample, evaluate, optimise of each study (sample may be shared)
    again = Reproduction(tmp_path / "doc", tmp_path / "outputs")
    second = again.studies(specs)
    assert again.computed == 0  # every stage from the cache
    alone = Reproduction(tmp_path / "doc2", tmp_path / "other")
    one_by_one = [alone.study(name, overrides) for name, overrides in specs]
    for (b1, h1), (b2, h2), (b3, h3) in zip(first, second, one_by_one):
        assert b1.equals(b2) and h1.equals(h2)
        assert b1.equals(b3)  # one worker per study or two: the same results
        assert h1.equals(h3)
    assert first[0][0]["w_d"] == 0.0 and first[1][0]["w_d"] == 1.0


@pytest.mark.parametrize("overrides", [
    ["+experiment=h4_mixed", "objective.w_d=0.25", "optimizer.seed=2", "parallel.n_jobs=1"],
    ["+experiment=h4_mixed", "+reading=h4_paper_gdi", "objective.w_d=0.7", "optimizer.seed=0"],
    ["+experiment=tricept_max_volume", "objective.name=mixed", "objective.w_d=0.5", "optimizer.population=20",
     "optimizer.generations=30", "plot.enabled=false"],
    ["+experiment=h4_max_volume", "optimizer.seed=1", "paths.output_dir=/tmp/x"],
])
def test_reproduction_compose_equals_hydras(overrides, tmp_path):
    from hydra import compose, initialize_config_dir
    from omegaconf import OmegaConf

    from pipeline.config import CONFIG_DIR
    from pipeline.reproduce import Reproduction

    r = Reproduction(tmp_path / "doc", tmp_path / "out")
    r.compose([o for o in overrides if "." not in o.split("=", 1)[0]])  # a base kept from another study
    ours = r.compose(overrides)
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        theirs = compose(config_name="config", overrides=overrides)
    assert OmegaConf.to_yaml(ours) == OmegaConf.to_yaml(theirs)
