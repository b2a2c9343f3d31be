"""Reverse path speed: 3 outputs x 7 inputs (3 forces + 4 basis functions) x 2^20 samples.

Prints, in one run (issue 3): the full estimate; bare ``numpy.fft.rfft`` of the same 10
channels over the whole record, both as the estimator receives them (columns of an (n, 10)
array, ``axis=0``) and as contiguous rows (the faster, stricter baseline); the Welch spectral
matrix alone; and a pairwise ``scipy.signal.csd`` route over the same channel pairs with the
same segment length, window (Hann), overlap (50 %) and mean removal.
Targets: full <= 2x bare FFT, >= 20x faster than pairwise. Everything single-threaded: FFTs
and, pinned below, BLAS. Each time is the best of several repeats, interleaved so that load
from other processes hits every route alike.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads its BLAS

import time  # noqa: E402

import numpy as np  # noqa: E402
import scipy.signal  # noqa: E402

from analysis.models import Element, Model  # noqa: E402
from analysis.reverse_path import ReversePathOptions, reverse_path  # noqa: E402
from analysis.spectral import spectral_matrix  # noqa: E402

N, FS, NPERSEG, BAND = 2**20, 4096.0, 4096, (5.0, 1500.0)
REPEATS = 5


def main() -> None:
    rng = np.random.default_rng(0)
    model = Model.load("examples/models/three-dof-paper.toml")
    ws = [[1, 0, 0], [0, -1, 1], [-1, 0, 1], [0, 1, 0]]
    kinds = ["cubic_spring", "cubic_spring", "quadratic_spring", "quadratic_spring"]
    cand = model.with_elements([Element(k, np.array(w, float), {}) for k, w in zip(kinds, ws)])
    force = rng.standard_normal((N, 3))
    resp = 1e-5 * rng.standard_normal((N, 3))
    channels = np.column_stack([resp, force, resp @ np.array(ws, float).T])
    rows = np.ascontiguousarray(channels.T)

    def full():
        # plain H1 reverse path: the random stand-in response would look like pure sensor
        # noise to noise="auto", which then runs the (simulation-based) IV estimator
        reverse_path((force, resp), cand, ReversePathOptions(band=BAND, nperseg=NPERSEG,
                                                             antialias="off", noise="none"),
                     fs=FS, force_dofs=[0, 1, 2])

    def pairwise():
        # outputs x inputs, then the upper triangle of inputs x inputs (scipy's csd(x, y)
        # is E[X^* Y]; which of the pair is conjugated does not change the cost)
        for i in range(3):
            for j in range(3, 10):
                scipy.signal.csd(channels[:, j], channels[:, i], FS, nperseg=NPERSEG)
        for i in range(3, 10):
            for j in range(i, 10):
                scipy.signal.csd(channels[:, j], channels[:, i], FS, nperseg=NPERSEG)

    routes = {
        "full estimate": full,
        "bare numpy rfft, (n, 10) axis 0": lambda: np.fft.rfft(channels, axis=0),
        "bare numpy rfft, 10 contiguous rows": lambda: np.fft.rfft(rows, axis=-1),
        "spectral matrix alone": lambda: spectral_matrix(channels, FS, nperseg=NPERSEG,
                                                         band=BAND),
    }
    full()   # compile / warm up
    best = dict.fromkeys(routes, np.inf)
    for _ in range(REPEATS):
        for name, fn in routes.items():
            t = time.perf_counter()
            fn()
            best[name] = min(best[name], time.perf_counter() - t)
    t_pair = np.inf
    for _ in range(2):
        t = time.perf_counter()
        pairwise()
        t_pair = min(t_pair, time.perf_counter() - t)
    t_full = best["full estimate"]
    for name, t in best.items():
        ratio = "" if name == "full estimate" else f"   full / this {t_full / t:6.2f}"
        print(f"{name:<38} {t:8.3f} s{ratio}")
    print(f"{'pairwise scipy.signal.csd (49 pairs)':<38} {t_pair:8.3f} s   this / full "
          f"{t_pair / t_full:6.1f}")
    print("targets: full / bare rfft <= 2, pairwise / full >= 20")


if __name__ == "__main__":
    main()
