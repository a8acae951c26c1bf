"""The stage cache's key covers the numeric libraries' versions, and old code versions can be pruned."""

from __future__ import annotations

from pipeline.store import cache


def test_a_new_numpy_or_numba_starts_a_fresh_cache(monkeypatch):
    now = cache._source_digest()
    for library in ("numpy", "numba"):
        real = cache.version

        def other(name, library=library, real=real):
            return "0.0.1" if name == library else real(name)

        monkeypatch.setattr(cache, "version", other)
        assert cache._source_digest() != now, library
        monkeypatch.setattr(cache, "version", real)
    assert cache._source_digest() == now


def test_prune_removes_only_other_code_versions(tmp_path):
    current = tmp_path / cache.CODE_VERSION
    stale = [tmp_path / "0.1.0+0123456789ab", tmp_path / "0.0.9+ffffffffffff"]
    keep = [tmp_path / "notes", tmp_path / "0.1.0+short"]
    for d in [current, *stale, *keep]:
        (d / "sub").mkdir(parents=True)
        (d / "sub" / "entry.pkl").write_bytes(b"x" * 100)
    planned = cache.prune(tmp_path, dry_run=True)
    assert sorted(p for p, _ in planned) == sorted(stale) and all(s == 100 for _, s in planned)
    assert all(d.exists() for d in stale)
    removed = cache.prune(tmp_path)
    assert sorted(p for p, _ in removed) == sorted(stale)
    assert not any(d.exists() for d in stale) and current.exists() and all(d.exists() for d in keep)
    assert cache.prune(tmp_path / "absent") == []


def test_a_new_refine_factor_reruns_only_the_refined_re_evaluation(tmp_path):
    """``evaluate.refine_factor`` reaches only the refined re-evaluation of the optimum (stage
    ``refine``): the reference searches and the optimiser's run are read from the cache (checked
    with joblib's ``check_call_in_cache``), and the run's manifest says so."""
    import json

    import numpy as np
    from hydra import compose, initialize_config_dir

    from pipeline.config import CONFIG_DIR, register_configs, validate
    from pipeline.stages.optimise import optimiser_run, reference_stage, refine_stage
    from pipeline.study import run_study
    from tests.helpers import TINY

    def make_cfg(*extra: str):
        register_configs()
        with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
            return compose(
                config_name="config",
                overrides=["+experiment=rpr2_mixed", *TINY, "optimizer.reference=true", f"paths.output_dir={tmp_path}"]
                + list(extra),
            )

    first, other = validate(make_cfg()), validate(make_cfg("evaluate.refine_factor=3"))
    assert (first.evaluate.refine_factor, other.evaluate.refine_factor) == (2, 3)
    run_study(make_cfg(), tmp_path / "first")
    cache_dir = first.paths.cache_dir
    c = other  # every stage's arguments as the second run passes them
    problem = (c.mechanism, c.evaluate.resolution, c.evaluate.method)
    stage = {f: cache.cached(f, cache_dir) for f in (reference_stage, optimiser_run, refine_stage)}
    assert stage[reference_stage].check_call_in_cache(*problem, c.objective)
    assert stage[optimiser_run].check_call_in_cache(*problem, c.objective, c.optimizer, None)
    run = stage[optimiser_run](*problem, c.objective, c.optimizer, None)
    reference_x = np.asarray(stage[reference_stage](*problem, c.objective)["x"])
    assert stage[refine_stage].check_call_in_cache(*problem, 2, run["x"], reference_x)
    assert not stage[refine_stage].check_call_in_cache(*problem, 3, run["x"], reference_x)
    run_study(make_cfg("evaluate.refine_factor=3"), tmp_path / "second")
    stages = json.loads((tmp_path / "second" / "manifest.json").read_text())["stages"]
    assert stages == {
        "sample": "cached",
        "evaluate": "cached",
        "reference": "cached",
        "optimise": "cached",
        "refine": "computed",
    }
    assert stage[refine_stage].check_call_in_cache(*problem, 3, run["x"], reference_x)
