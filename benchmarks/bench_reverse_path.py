"""Reverse path speed: 3 outputs x 7 inputs (3 forces + 4 basis functions) x 2^20 samples.

Prints, in one run: the full estimate, bare ``numpy.fft.rfft`` of the same 10 channels
(whole record), and a pairwise ``scipy.signal.csd`` route over the same channel pairs.
Targets (issue 3): full <= 2x bare FFT, >= 20x faster than pairwise.
"""

import time

import numpy as np
import scipy.signal

from analysis.model import Element, Model
from analysis.reverse_path import reverse_path

N, FS, NPERSEG = 2**20, 4096.0, 4096


def _best(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main() -> None:
    rng = np.random.default_rng(0)
    model = Model.load("examples/models/three-dof-paper.toml")
    ws = [[1, 0, 0], [0, -1, 1], [-1, 0, 1], [0, 1, 0]]
    kinds = ["cubic_spring", "cubic_spring", "quadratic_spring", "quadratic_spring"]
    cand = model.with_elements([Element(k, np.array(w, float), {}) for k, w in zip(kinds, ws)])
    force = rng.standard_normal((N, 3))
    resp = 1e-5 * rng.standard_normal((N, 3))
    channels = np.column_stack([resp, force, resp @ np.array(ws, float).T])

    def full():
        reverse_path((force, resp), cand, fs=FS, force_dofs=[0, 1, 2], band=(5.0, 1500.0),
                     nperseg=NPERSEG, antialias="off")

    def bare():
        np.fft.rfft(channels, axis=0)

    def pairwise():
        for i in range(3):
            for j in range(3, 10):
                scipy.signal.csd(channels[:, j], channels[:, i], FS, nperseg=NPERSEG)
        for i in range(3, 10):
            for j in range(i, 10):
                scipy.signal.csd(channels[:, j], channels[:, i], FS, nperseg=NPERSEG)

    full()
    t_full, t_bare = _best(full), _best(bare)
    t_pair = _best(pairwise, 1)
    print(f"full estimate      {t_full:8.3f} s")
    print(f"bare numpy rfft    {t_bare:8.3f} s   ratio full/bare     {t_full / t_bare:6.2f} "
          "(target <= 2)")
    print(f"pairwise csd       {t_pair:8.3f} s   speed-up vs pairwise {t_pair / t_full:6.1f} "
          "(target >= 20)")


if __name__ == "__main__":
    main()
