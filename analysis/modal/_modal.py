"""Modal parameters of measured FRF columns (natural frequencies, damping, mode shapes).

Method: global rational fraction polynomial (Richardson & Formenti 1982) with a common
denominator for all outputs, fitted by Sanathanan-Koerner iterations (Levy's linear least
squares, re-weighted by the previous denominator). Poles are the denominator roots; mode
shapes follow from the residues ``N_y(s_k) / D'(s_k)`` of each output. No maintained Python
package offers a small, dependency-free global RFP/LSCF fit for one FRF column, hence this
implementation (about 100 lines).

For receptance data of an ``n``-DOF lumped system the model ``H_y(s) = N_y(s) / D(s)`` with
``deg D = 2 n`` and ``deg N_y <= 2 n - 2`` is exact.

Welch leakage: a Welch estimate is the true spectrum smoothed by the window's power kernel
``|W(nu)|^2``; when the line spacing is not well below a resonance's half-power bandwidth
``2 zeta f_n`` that smoothing widens the peak and the damping comes out high (x2 at one line
per bandwidth). Given the kernel (`welch_smoothing`), `modal_fit` refines the poles so that
the *smoothed* pole-residue model matches the estimate (variable projection: poles by
`scipy.optimize.least_squares`, residues by linear least squares inside), which removes that
bias (exactly for a flat input spectrum, approximately when the kernel is weighted by a
measured, non-flat one).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.signal

from ..errors import EstimationError, InputError
from ..spectral import Spectra, multiple_coherence
from ._ema import refine
from ._fit_result import ModalMode, ModalSummary

if TYPE_CHECKING:
    from ..reverse_path import ReversePathResult


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
        """One dict per mode: ``freq_hz``, ``damping_ratio`` and the real part of ``shape``."""
        return [{"freq_hz": float(f), "damping_ratio": float(z),
                 "shape": [float(v) for v in np.real(s)]}
                for f, z, s in zip(self.freqs_hz, self.damping, self.shapes)]


def welch_smoothing(window: str, nperseg: int, fs: float, *,
                    input_spectrum: tuple[np.ndarray, np.ndarray] | None = None,
                    oversample: int = 8, half_width: int = 16
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (Hz) and weights with which a Welch H1 estimate smooths the true FRF.

    The expected Welch (cross-)spectrum is the true one convolved with ``|W(nu)|^2``, ``W``
    the window's transform, normalised to unit area; sampled ``oversample`` times per line
    over ``+-half_width`` lines (Hann's power side lobes fall as ``nu^-6``: what lies beyond
    is far below 1e-6 of the total). H1 = smoothed ``H S_ff`` over smoothed ``S_ff``: for a
    flat input spectrum that is the kernel itself; otherwise each line's kernel is weighted
    by the input spectrum at the offset frequencies.

    Parameters
    ----------
    window : str
        Window name for `scipy.signal.get_window`.
    nperseg : int
        Segment length, samples.
    fs : float
        Sample rate, Hz.
    input_spectrum : (freqs, psd), optional
        Input auto-spectrum on the FRF's lines (several inputs: their sum), interpolated
        linearly between lines. It is itself a Welch estimate, so sharp features of the true
        input spectrum are seen smoothed: an approximation, good to ~2 % in damping where
        the input spectrum has a deep notch at the resonance (residual forces).

    Returns
    -------
    offsets : ndarray, shape (n_k,)
        Frequency offsets, Hz.
    weights : ndarray, shape (n_k,) or (n_f, n_k)
        Kernel weights (per line with ``input_spectrum``), each row summing to one.
    """
    w = scipy.signal.get_window(window, nperseg)
    power = np.abs(np.fft.fft(w, nperseg * oversample)) ** 2
    k = np.arange(-half_width * oversample, half_width * oversample + 1)
    offsets = k * fs / (nperseg * oversample)
    weights = power[k % power.size]
    if input_spectrum is not None:
        f, psd = input_spectrum
        weights = weights * np.interp(f[:, None] - offsets[None, :], f, psd)
        return offsets, weights / weights.sum(axis=-1, keepdims=True)
    return offsets, weights / weights.sum()


def _vander(s: np.ndarray, deg: int) -> np.ndarray:
    return s[:, None] ** np.arange(deg + 1)


def modal_fit(freqs: np.ndarray, frf: np.ndarray, n_modes: int, *,
              iterations: int = 8, weights: np.ndarray | None = None,
              smoothing: tuple[np.ndarray, np.ndarray] | None = None) -> ModalResult:
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
    smoothing : (offsets, weights), optional
        The estimate's Welch smoothing kernel (`welch_smoothing`, weights of shape (n_k,)
        or (n_f, n_k)): the rational-fraction poles are refined so that the smoothed model
        matches (see the module docstring).

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
    num, den = _rational_fraction(s, h, wts, nn, nd, iterations)
    n_out = h.shape[1]
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
    if smoothing is not None:
        poles, residues = _refine_smoothed(f, h, wts, poles, smoothing)
        order = np.argsort(np.abs(poles))
        poles, residues = poles[order], residues[order]
    k = np.argmax(np.abs(residues), axis=1)
    ref = residues[np.arange(poles.size), k]
    shapes = residues / ref[:, None]
    return ModalResult(np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles), shapes,
                       residues, poles)


def _rational_fraction(s: np.ndarray, h: np.ndarray, wts: np.ndarray, nn: int, nd: int,
                       iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """Common-denominator rational fraction ``N_y(s) / D(s)`` of FRF columns by
    Sanathanan-Koerner iterations (Levy's linear least squares re-weighted by the previous
    denominator).

    Parameters
    ----------
    s : ndarray, complex, shape (n_f,)
        Normalised Laplace variable of each line.
    h : ndarray, complex, shape (n_f, n_out)
        FRF columns.
    wts : ndarray, shape (n_f,)
        Per-line weights.
    nn, nd : int
        Numerator and denominator degrees.
    iterations : int
        Re-weightings.

    Returns
    -------
    num : ndarray, shape (n_out, nn + 1)
        Numerator coefficients of each column, ascending powers.
    den : ndarray, shape (nd + 1,)
        Denominator coefficients, ascending powers, monic (``d_nd = 1``).
    """
    pn = _vander(s, nn)
    pd = _vander(s, nd)
    den = np.ones(nd + 1)
    d_prev = np.ones(s.size, dtype=complex)
    n_f, n_out = h.shape
    for _ in range(iterations):
        w = wts / np.abs(d_prev)
        # Unknowns: numerator coefficients of each output, then d_0..d_{nd-1} (d_nd = 1).
        rows = []
        rhs = []
        for y in range(n_out):
            blk = np.zeros((n_f, n_out * (nn + 1) + nd), dtype=complex)
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
    return sol[: n_out * (nn + 1)].reshape(n_out, nn + 1), den


def _refine_smoothed(f: np.ndarray, h: np.ndarray, wts: np.ndarray, poles: np.ndarray,
                     smoothing: tuple[np.ndarray, np.ndarray]
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Poles and residues of ``sum_k r_k / (s - s_k) + conj`` whose Welch-smoothed FRF fits
    ``h`` (relative error per line, times ``wts``); starts from ``poles`` (`analysis.modal._ema.refine`
    without residual terms)."""
    fn, zeta = np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles)
    refined, residues, _, _ = refine(f, h, fn, zeta, residuals=(False, False),
                                     smoothing=smoothing, weights=wts)
    return refined, residues


def modal_summary(result: "ReversePathResult", n_modes: int,
                  linear: tuple[np.ndarray, np.ndarray, Spectra] | None = None
                  ) -> ModalSummary:
    """Modes of a reverse path's underlying linear FRF columns (rational-fraction fit).

    All columns share the poles; each mode shape is the residue vector of the first forced
    column, scaled to a unit largest component.

    Parameters
    ----------
    result : analysis.reverse_path.ReversePathResult
    n_modes : int
        The model's DOF count, for which the fit of a lumped system's receptance is exact;
        modes outside the analysed band are extrapolated and flagged ``in_band: false``.
    linear : (freqs, frf, spectra), optional
        The residual-force H1 (`analysis.reverse_path.residual_force_frf`): the fit
        then goes through the Welch window's smoothing kernel, which removes the leakage bias
        of the damping. Without it the reverse path's ``H_linear`` is fitted directly.

    Returns
    -------
    ModalSummary
        The route taken, the force DOF and the modes.

    Raises
    ------
    EstimationError, InputError
        From `modal_fit` when the modes cannot be found.
    """
    if linear is not None:
        freqs, frf, spec = linear
        n, auto = frf.shape[1], spec.auto()
        coh = multiple_coherence(auto[:, :n], spec.S[:, :n, n:], spec.S[:, n:, n:])
        smoothing = welch_smoothing(spec.window, spec.nperseg, spec.fs,
                                    input_spectrum=(freqs, auto[:, n:].sum(axis=1)))
        fit = modal_fit(freqs, frf, n_modes, weights=coh.min(axis=1), smoothing=smoothing)
        method = ("global rational fraction polynomial on the residual-force H1, through "
                  f"the {spec.window} window's Welch kernel")
    else:
        frf = result.H_linear
        fit = modal_fit(result.freqs, frf, n_modes,
                        weights=result.coherence_nonlinear.min(axis=1))
        method = "global rational fraction polynomial on the reverse-path H_linear"
    n_in = frf.shape[2]
    lo, hi = result.band
    modes = []
    for f, zeta, r in zip(fit.freqs_hz, fit.damping, fit.residues):
        col = r[::n_in]                                   # outputs of the first force column
        k = int(np.argmax(np.abs(col)))
        shape = col / col[k]
        shape[k] = 1.0                                    # exactly, not to round-off
        modes.append(ModalMode(float(f), float(zeta), tuple(float(v) for v in shape.real),
                               bool(lo <= f <= hi)))
    return ModalSummary(method, int(result.force_dofs[0]), tuple(modes))
