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


def _cli_stderr(args, cache_dir):
    import os
    import subprocess
    import sys
    from pathlib import Path
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache_dir), "PYTHONPATH": str(root)}
    proc = subprocess.run([sys.executable, "-m", "nlid_lab.cli", *args], env=env, cwd=root,
                          capture_output=True, text=True, timeout=120)
    return proc.returncode, proc.stderr


def test_a_cold_cache_is_announced_before_the_command_runs(tmp_path):
    rc, err = _cli_stderr(["detect", str(tmp_path / "missing.h5")], tmp_path / "empty")
    assert rc == 2 and "compiling numeric kernels (first run only" in err
    rc, err = _cli_stderr(["import", str(tmp_path / "missing.npz"), "--out",
                           str(tmp_path / "x.h5")], tmp_path / "empty")
    assert rc == 2 and "compiling" not in err          # import runs no kernel
    warm = tmp_path / "warm" / "analysis_x"
    warm.mkdir(parents=True)
    for stem in ("_plant_kernels", "_aft", "_hbm", "_spectral", "_elements"):
        (warm / f"{stem}.f-1.py311.nbi").write_bytes(b"")
    rc, err = _cli_stderr(["detect", str(tmp_path / "missing.h5")], tmp_path / "warm")
    assert rc == 2 and "compiling" not in err
