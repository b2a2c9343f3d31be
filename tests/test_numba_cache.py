"""The numba cache guard drops a module's compiled cache when a dependency changes."""

from analysis._numba_cache import guard


def test_guard_clears_cache_only_when_a_dependency_changes(tmp_path):
    (tmp_path / "kern.py").write_text("# kernel\n")
    (tmp_path / "laws.py").write_text("# law v1\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    stale = cache / "kern.f-10.py311.nbi"
    other = cache / "laws.g-3.py311.nbi"
    stale.write_text("x")
    other.write_text("x")
    guard(str(tmp_path / "kern.py"), "laws")          # no stamp yet: cache of unknown age
    assert not stale.exists() and other.exists()
    stale.write_text("x")
    guard(str(tmp_path / "kern.py"), "laws")          # dependency unchanged: keep
    assert stale.exists()
    (tmp_path / "laws.py").write_text("# law v2\n")
    guard(str(tmp_path / "kern.py"), "laws")          # dependency changed: drop
    assert not stale.exists() and other.exists()
