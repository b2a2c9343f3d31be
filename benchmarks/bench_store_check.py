"""Cost of the readers' data check (`nlid_lab.store.Run.check`: every block's CRC-32) with the
read it precedes (`Run.recordings`), on a run of 4 levels x 32 blocks x 16384 samples x 5
channels (84 MB) written in a temporary directory: what every command reading runs does
(`nlid_lab.commands.repair.check_runs`, then `load_recordings`).

One pass: the check reads and verifies each block once and the read takes those samples
(`nlid_lab.store._verified`). Baseline timed in the same run: two passes, the check's samples
dropped (`release_checked`) so that the read reads the file again, as before. Prints the best
of 3 (interleaved, so that load from other processes hits both alike) and the ratio; the
one-pass check + read should cost about what the read alone did.

    python benchmarks/bench_store_check.py
"""

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from nlid_lab.store import RunWriter, open_run, release_checked  # noqa: E402

LEVELS, BLOCKS, BLOCK, N_DOF = 4, 32, 16384, 4
REPEATS = 3


def write_run(path: Path) -> None:
    """The benchmark's run: random samples, every level complete."""
    rng = np.random.default_rng(0)
    with RunWriter(path, fs=4096.0, excitation="random", force_dofs=[0], n_dof=N_DOF) as w:
        for index in range(LEVELS):
            lv = w.level(index, 1.0 + index)
            for _ in range(BLOCKS):
                lv.append_block(rng.standard_normal((BLOCK, 1)),
                                rng.standard_normal((BLOCK, N_DOF)))
            lv.complete()


def check_then_read(path: Path, one_pass: bool) -> tuple[float, list]:
    """Seconds to check the run (a first opening) and read its recordings (a second)."""
    t = time.perf_counter()
    result = open_run(path).check()
    if not one_pass:
        release_checked()
    recs = open_run(path).recordings()
    assert not result.left_out
    return time.perf_counter() - t, recs


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.h5"
        write_run(path)
        one, two, alone = [], [], []
        for _ in range(REPEATS):
            t1, a = check_then_read(path, True)
            t2, b = check_then_read(path, False)
            assert all(np.array_equal(x.force, y.force) and np.array_equal(x.response, y.response)
                       for x, y in zip(a, b))
            t = time.perf_counter()
            open_run(path).recordings()
            alone.append(time.perf_counter() - t)
            one.append(t1)
            two.append(t2)
        size = path.stat().st_size / 1e6
    print(f"run of {size:.0f} MB: check + read, two passes (before) {min(two):.3f} s; "
          f"one pass (now) {min(one):.3f} s; read alone {min(alone):.3f} s")
    print(f"one pass / two passes {min(one) / min(two):.2f}; "
          f"one pass / read alone {min(one) / min(alone):.2f}")


if __name__ == "__main__":
    main()
