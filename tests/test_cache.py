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
