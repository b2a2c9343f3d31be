"""Cost of the readers' data check (`nlid_lab.store.Run.check`: every block's CRC-32) against
the read it precedes (`Run.recordings`), on a run of 4 levels x 32 blocks x 16384 samples x 5
channels (84 MB) written in a temporary directory.

Prints both times (best of 3, interleaved so that load from other processes hits both alike)
and their ratio; the check is an extra read of the samples plus CRC-32, so the ratio should
stay below 1.
"""

import tempfile
import time
from pathlib import Path

import numpy as np

from nlid_lab.store import RunWriter, open_run

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


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.h5"
        write_run(path)
        check, read = [], []
        for _ in range(REPEATS):
            t = time.perf_counter()
            result = open_run(path).check()
            check.append(time.perf_counter() - t)
            t = time.perf_counter()
            open_run(path).recordings()
            read.append(time.perf_counter() - t)
        assert not result.left_out
        size = path.stat().st_size / 1e6
    print(f"run of {size:.0f} MB: check {min(check):.3f} s ({1e3 * min(check) / size:.1f} ms/MB), "
          f"recordings {min(read):.3f} s, check/recordings {min(check) / min(read):.2f}")


if __name__ == "__main__":
    main()
