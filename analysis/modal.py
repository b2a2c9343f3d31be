"""Modal parameters of measured FRF columns (natural frequencies, damping, mode shapes).

Method: global rational fraction polynomial (Richardson & Formenti 1982) with a common
denominator for all outputs, fitted by Sanathanan-Koerner iterations (Levy's linear least
squares, re-weighted by the previous denominator). Poles are the denominator roots; mode
shapes follow from the residues ``N_y(s_k) / D'(s_k)`` of each output. No maintained Python
package offers a small, dependency-free global RFP/LSCF fit for one FRF column, hence this
implementation (about 100 lines).

For receptance data of an ``n``-DOF lumped system the model ``H_y(s) = N_y(s) / D(s)`` with
``deg D = 2 n`` and ``deg N_y <= 2 n - 2`` is exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import EstimationError, InputError


@dataclass
class ModalResult:
    """Modes found in an FRF column, sorted by frequency.

    Attributes
    ----------
    freqs_hz : ndarray, shape (n_modes,)
        Undamped natural frequencies ``|s_k| / 2 pi``.
    damping : ndarray, shape (n_modes,)
        Damping ratios ``-Re(s_k) / |s_k|``.
    shapes : ndarray, shape (n_modes, n_out), complex
        Residue vectors, each scaled to unit largest component (phase of that component 0).
    residues : ndarray, shape (n_modes, n_out), complex
        Unscaled residues of ``H_y(s) = sum_k r_yk / (s - s_k) + conj``.
    poles : ndarray, shape (n_modes,), complex
    """

    freqs_hz: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray
    residues: np.ndarray
    poles: np.ndarray

    def to_json(self) -> list[dict]:
        return [{"freq_hz": float(f), "damping_ratio": float(z),
                 "shape": [float(v) for v in np.real(s)]}
                for f, z, s in zip(self.freqs_hz, self.damping, self.shapes)]


def _vander(s: np.ndarray, deg: int) -> np.ndarray:
    return s[:, None] ** np.arange(deg + 1)


def modal_fit(freqs: np.ndarray, frf: np.ndarray, n_modes: int, *,
              iterations: int = 8, weights: np.ndarray | None = None) -> ModalResult:
    """Fit ``n_modes`` modes to one or more FRF columns of receptance.

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Frequencies, Hz.
    frf : ndarray, shape (n_f, n_out) or (n_f, n_out, n_in)
        Receptance FRFs (all columns share the poles).
    n_modes : int
        Number of modes in the band (denominator degree ``2 n_modes``).
    iterations : int
        Sanathanan-Koerner re-weightings.
    weights : ndarray, shape (n_f,), optional
        Per-frequency weights (e.g. coherence).

    Returns
    -------
    ModalResult
    """
    f = np.asarray(freqs, dtype=float)
    h = np.asarray(frf, dtype=complex)
    if h.ndim == 3:
        h = h.reshape(h.shape[0], -1)
    if h.ndim != 2 or h.shape[0] != f.size:
        raise InputError(f"frf must have shape (n_f, n_out[, n_in]) matching freqs, got {h.shape}")
    nd = 2 * n_modes
    nn = nd - 2 if n_modes > 0 else 0
    if n_modes < 1 or f.size < 2 * (nd + 1):
        raise InputError(f"{f.size} frequency points cannot fit {n_modes} modes; use a wider "
                         "band or finer resolution")
    scale = 2 * np.pi * f.max()
    s = 2j * np.pi * f / scale                       # normalised Laplace variable
    wts = np.ones(f.size) if weights is None else np.asarray(weights, dtype=float)
    pn = _vander(s, nn)
    pd = _vander(s, nd)
    den = np.ones(nd + 1)
    d_prev = np.ones(f.size, dtype=complex)
    n_out = h.shape[1]
    for _ in range(iterations):
        w = wts / np.abs(d_prev)
        # Unknowns: numerator coefficients of each output, then d_0..d_{nd-1} (d_nd = 1).
        rows = []
        rhs = []
        for y in range(n_out):
            blk = np.zeros((f.size, n_out * (nn + 1) + nd), dtype=complex)
            blk[:, y * (nn + 1):(y + 1) * (nn + 1)] = pn * w[:, None]
            blk[:, n_out * (nn + 1):] = -(h[:, y] * w)[:, None] * pd[:, :nd]
            rows.append(blk)
            rhs.append(h[:, y] * w * pd[:, nd])
        a = np.concatenate(rows)
        b = np.concatenate(rhs)
        sol = np.linalg.lstsq(np.concatenate([a.real, a.imag]),
                              np.concatenate([b.real, b.imag]), rcond=None)[0]
        den = np.append(sol[n_out * (nn + 1):], 1.0)
        d_prev = pd @ den
    num = sol[: n_out * (nn + 1)].reshape(n_out, nn + 1)
    roots = np.roots(den[::-1])
    poles = roots[roots.imag > 0]
    if poles.size == 0:
        raise EstimationError("no oscillatory pole found in the FRF; widen the band around "
                              "the resonances")
    poles = poles[np.argsort(np.abs(poles))]
    dden = np.polyder(den[::-1])
    residues = np.array([[np.polyval(num[y][::-1], p) / np.polyval(dden, p)
                          for y in range(n_out)] for p in poles]) * scale
    poles = poles * scale
    k = np.argmax(np.abs(residues), axis=1)
    ref = residues[np.arange(poles.size), k]
    shapes = residues / ref[:, None]
    return ModalResult(np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles), shapes,
                       residues, poles)
