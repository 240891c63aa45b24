"""Stale numba caches are dropped when a module a kernel depends on changes."""

from swarm_sim.core._numba_cache import drop_stale_cache


def test_cache_dropped_once_per_change_of_dependencies(tmp_path, monkeypatch):
    (tmp_path / "dep_mod.py").write_text("X = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    source = tmp_path / "kern.py"
    source.write_text("")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    stale = [cache / "kern.f-1.py311.nbi", cache / "kern.f-1.py311.1.nbc"]
    other = cache / "other.f-1.py311.nbi"
    for f in [*stale, other]:
        f.write_text("x")
    drop_stale_cache(str(source), ["dep_mod"])
    assert not any(f.exists() for f in stale) and other.exists()
    # Same dependencies: a fresh cache is kept.
    for f in stale:
        f.write_text("x")
    drop_stale_cache(str(source), ["dep_mod"])
    assert all(f.exists() for f in stale)
    # A dependency changes: dropped again.
    (tmp_path / "dep_mod.py").write_text("X = 2\n")
    drop_stale_cache(str(source), ["dep_mod"])
    assert not any(f.exists() for f in stale)
