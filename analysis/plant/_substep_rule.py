"""The substep rule's inputs: element slopes, the tangent frequency and the starting substeps
(`auto_oversample`; `analysis.plant._plant`'s module docstring states the rule), and the
exponential integrator's phi functions."""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from scipy.linalg import eigh, expm
from scipy.sparse.csgraph import connected_components
from threadpoolctl import ThreadpoolController

from ..models import KINDS, Model

AUTO_H_OMEGA = 0.25


def _element_stiffness(el: Any, umax: float = 0.0, vmax: float = 0.0) -> tuple[float, float]:
    """Largest stiffness and viscous slope of element ``el`` (N/m, N s/m), from its kind's
    descriptor (`analysis.models._kinds`).

    With ``umax = vmax = 0`` the slopes known before a run (piecewise-linear kinds); with the
    element's largest deformation ``umax`` and rate ``vmax`` over a stretch of run, the
    largest tangent of the amplitude-dependent kinds as well.
    """
    spec = KINDS[el.kind]
    k = spec.stiffness(el.params, umax) if spec.stiffness is not None else 0.0
    c = spec.damping(el.params, vmax) if spec.damping is not None else 0.0
    return k, c


def _element_slopes(model: Model, peak: np.ndarray | None = None) -> np.ndarray:
    """(2, n_elements): each element's largest stiffness and viscous slope
    (`_element_stiffness`); with ``peak`` (2 n_elements), the largest deformations then
    rates of the elements over a stretch of run, from their running tangents (a slope grows
    with its peak: `Plant._advance` relies on it)."""
    ne = len(model.elements)
    peak = np.zeros(2 * ne) if peak is None else peak
    out = np.zeros((2, ne))
    for i, el in enumerate(model.elements):
        out[:, i] = _element_stiffness(el, peak[i], peak[ne + i])
    return out


@functools.cache
def _blas_controller() -> ThreadpoolController:
    """The BLAS thread pools of this process (found once: ~3 ms)."""
    return ThreadpoolController()


_BLAS_LOCK = threading.Lock()
_blas_depth = 0          # plants inside `one_blas_thread`, over all threads
_blas_limit: Any = None  # the outermost entry's limit, restored by the last exit


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """BLAS on one thread inside the ``with`` block (threadpoolctl; ~50 us to enter).

    The plant's set-up works on matrices of 2 x 2 to ~100 x 100, where OpenBLAS's threads
    cost more than the arithmetic: measured on a shared 2-core machine, ``scipy.linalg.expm``
    of a 6 x 6 matrix took 8 ms of process CPU (20 ms wall) with its default threads and
    13 us with one (OpenBLAS issue 4387); a run's discretisations and step-doubling checks
    then cost as much as its kernel. The limit is process-wide: plants in several threads
    share one, set by the first to enter and lifted by the last to leave, so the caller's
    threads come back whatever the order."""
    global _blas_depth, _blas_limit
    with _BLAS_LOCK:
        if _blas_depth == 0:
            _blas_limit = _blas_controller().limit(limits=1, user_api="blas")
        _blas_depth += 1
    try:
        yield
    finally:
        with _BLAS_LOCK:
            _blas_depth -= 1
            if _blas_depth == 0:
                _blas_limit.restore_original_limits()
                _blas_limit = None


def _tangent_omega(model: Model, slopes: np.ndarray | None = None) -> float:
    """The frequency ``omega`` of the substep rule (module docstring), rad/s, with the
    element slopes (`_element_slopes`; default: those known before a run)."""
    k, c = _element_slopes(model) if slopes is None else slopes
    wq = np.array([model.to_q(el.w) for el in model.elements]).reshape(-1, model.n_q)
    stiff = model.stiffness + (wq.T * k) @ wq
    visc = (wq.T * c) @ wq
    with one_blas_thread():
        omega = math.sqrt(max(eigh(stiff, model.mass, eigvals_only=True).max(), 0.0))
        rate = max(eigh(visc, model.mass, eigvals_only=True).max(), 0.0)
    return max(omega, rate)


def auto_oversample(model: Model, fs: float) -> int:
    """Substeps per output sample a run starts with (module docstring)."""
    if not model.elements:
        return 1
    return max(1, math.ceil(_tangent_omega(model) / (AUTO_H_OMEGA * fs)))


def _blocks(z: np.ndarray) -> list[np.ndarray]:
    """Index sets of the connected components of the nonzero pattern of ``z`` (the 2 x 2
    modes of a modal model; one block for a coupled one)."""
    n_blocks, labels = connected_components(z != 0, directed=False)
    return [np.flatnonzero(labels == b) for b in range(n_blocks)]


def _phi_functions(z: np.ndarray, p: int, blocks: list[np.ndarray] | None = None
                   ) -> list[np.ndarray]:
    """``[exp(z), phi_1(z), ..., phi_p(z)]`` from augmented matrix exponentials, one per
    block of ``z`` (`_blocks`, or ``blocks`` when known: a plant's are those of its ``A``,
    whatever the step), so their zero pattern is exact."""
    blocks = _blocks(z) if blocks is None else blocks
    out = [np.zeros_like(z) for _ in range(p + 1)]
    for size in sorted({b.size for b in blocks}):
        idx = np.array([b for b in blocks if b.size == size])           # (k, size)
        big = np.zeros((idx.shape[0], size * (p + 1), size * (p + 1)))
        big[:, :size, :size] = z[idx[:, :, None], idx[:, None, :]]
        for i in range(p):
            big[:, size * i:size * (i + 1), size * (i + 1):size * (i + 2)] = np.eye(size)
        e = expm(big)
        for i in range(p + 1):
            out[i][idx[:, :, None], idx[:, None, :]] = e[:, :size, size * i:size * (i + 1)]
    return out
