"""Model-versus-data comparison per level on FRFs (the diagnosis metric).

For each random recording (one level) the H1 FRF from the forces to the displacements is
compared with the model's FRF *at that level*. For a model with nonlinear elements the level
FRF follows from the reverse-path identity (paper eq 12)::

    H1_xf = H_L (B - sum_m w_m p_m T_m),   T_m = S_{g_m f} S_ff^-1

where ``g_m`` is element m's restoring force evaluated on the *measured* motion. This is a
short-horizon (equation-based) prediction: it needs no long time-domain replay, which drifts
for nonlinear models under random drive even when the model is exact.

Metric (`weighted_error`): coherence-weighted relative FRF error over the analysis band,
``sqrt(sum g2 |H_meas - H_model|^2 / sum g2 |H_meas|^2)`` summed over frequencies, outputs and
inputs, ``g2`` the coherence of each measured FRF. Statistics (`chi2`) use the H1 random-error
variance ``(1 - g2) / (g2 n_eff) |H|^2`` (Bendat & Piersol) plus a model-precision floor.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Hashable

import numpy as np

from ..elements import restoring_force
from ..modal import welch_smoothing
from ..model import Model
from ..sine_fit import hold_gain
from ..spectral import h1, multiple_coherence, spectral_matrix
from .prepare import Prepared

GROUP = 8
EXCITED = 1e-3
FLOOR = 0.01
"""Model-precision floor: FRF deviations below 1 % of |H| are not treated as significant."""


@dataclass
class LevelFRF:
    """Measured FRF of one level and the force-to-basis transfers of candidate forces.

    Attributes
    ----------
    label : str
    level : float
    freqs : ndarray, shape (n_f,)
    H : ndarray, complex, shape (n_f, n_dof, n_in)
        H1 from forces to displacements.
    coh : ndarray, shape (n_f, n_dof, n_in)
        Coherence of each FRF (ordinary for one input, multiple otherwise).
    var : ndarray, shape (n_f, n_dof, n_in)
        Variance of each H1 value (random error plus the precision floor).
    B : ndarray, shape (n_dof, n_in)
        Force distribution.
    T : dict
        Basis key -> ``S_gf S_ff^-1``, shape (n_f, n_in).
    rms : dict
        Basis key -> rms of the deformation ``u`` and rate ``u'`` it acts on.
    bin_factor : float
        Correlation of adjacent bins (effective number of independent values divisor).
    n_eff : float
        Equivalent number of independent Welch averages.
    smoothing : (offsets, weights), optional
        The Welch kernel with which the estimate smooths the true FRF
        (`analysis.modal.welch_smoothing`, weighted by the measured input spectrum); None for
        leakage-free whole-period spectra.
    leakage : ndarray, optional
        Welch leakage of the model FRF at this level (`.leakage.leakage_bias`), added by
        `model_frf` so that the model is compared as the estimator sees it.
    """

    label: str
    level: float
    freqs: np.ndarray
    H: np.ndarray
    coh: np.ndarray
    var: np.ndarray
    B: np.ndarray
    T: dict[Hashable, np.ndarray] = field(default_factory=dict)
    bin_factor: float = 1.0
    n_eff: float = 1.0
    smoothing: tuple[np.ndarray, np.ndarray] | None = None
    leakage: np.ndarray | None = None

    @property
    def n_values(self) -> float:
        """Effective number of independent real values in the comparison."""
        return 2 * self.H.size / self.bin_factor


def choose_nperseg(model: Model, fs: float, n: int, *, min_avg: int = 24) -> int:
    """Welch segment length resolving the narrowest model resonance (bias below ~1 %).

    The frequency step is a sixth of the narrowest half-power bandwidth ``-Re(lambda)/pi``,
    limited so that at least ``min_avg`` half-overlapped segments fit in the record.
    """
    nd = model.n_q
    minv = np.linalg.inv(model.mass)
    a = np.block([[np.zeros((nd, nd)), np.eye(nd)],
                  [-minv @ model.stiffness, -minv @ model.damping]])
    lam = np.linalg.eigvals(a)
    bw = np.abs(lam.real[np.abs(lam.imag) > 0]) / np.pi
    df = (bw.min() / 6) if bw.size else fs / 1024
    want = 1 << int(np.ceil(np.log2(fs / max(df, 1e-9))))
    cap = 1 << int(np.floor(np.log2(max(2 * n / (min_avg + 1), 64))))
    return int(max(64, min(want, cap)))


def unit_force(kind: str, params: dict[str, float], w: np.ndarray, p: Prepared) -> np.ndarray:
    """Restoring force of one element (given parameters) along the measured motion."""
    u, v = p.x @ w, p.v @ w
    return restoring_force(kind, params, u, v)[0]


def level_frf(p: Prepared, band: tuple[float, float], nperseg: int,
              bases: dict[Hashable, np.ndarray], *, floor: float = FLOOR) -> LevelFRF:
    """Measured FRF of one level plus the force-to-basis transfer of every basis force.

    Both are per unit of the force that acted: a first-order-hold force (``force_hold =
    "linear"``) acted with ``sinc^2(f / fs)`` of its samples (`analysis.sine_fit.hold_gain`).
    """
    keys = list(bases)
    n_dof, n_in = p.x.shape[1], p.force.shape[1]

    def spectra(data: np.ndarray):
        if p.period is not None:
            return spectral_matrix(data, p.fs, nperseg=p.period, window="boxcar",
                                   overlap=0.0, band=band)
        return spectral_matrix(data, p.fs, nperseg=nperseg, band=band)

    sp = spectra(np.concatenate([p.x, p.force], axis=1))
    xi, fi = list(range(n_dof)), list(range(n_dof, n_dof + n_in))
    # Unexcited bins (between multisine lines, outside the drive band) carry no FRF.
    fpsd = np.einsum("fii->f", sp.block(fi, fi)).real
    keep = fpsd >= EXCITED * np.median(fpsd)
    sp.freqs, sp.S = sp.freqs[keep], sp.S[keep]
    S_ff = sp.block(fi, fi)
    S_xf = sp.block(xi, fi)
    gain = hold_gain(sp.freqs, p.fs, p.force_hold)
    H = h1(S_xf, S_ff) / gain[:, None, None]
    S_xx = np.einsum("fii->fi", sp.block(xi, xi)).real
    coh = np.clip(multiple_coherence(S_xx, S_xf, S_ff), 1e-6, 1 - 1e-12)
    coh = np.repeat(coh[:, :, None], n_in, axis=2)
    n_eff = max(sp.n_eff, 1.0)
    var = ((1 - coh) / (coh * n_eff) + floor**2) * np.abs(H) ** 2
    var = np.maximum(var, 1e-30 * np.abs(H).max() ** 2)
    T = {}
    # Only basis-versus-force cross spectra are needed: small groups keep the spectral
    # matrices small (their cost grows with the square of the channel count).
    fcols = list(range(n_in))
    for g0 in range(0, len(keys), GROUP):
        group = keys[g0:g0 + GROUP]
        data = np.concatenate([p.force] + [np.asarray(bases[k])[:, None] for k in group],
                              axis=1)
        sg = spectra(data)
        sg.S = sg.S[keep]
        for j, k in enumerate(group):
            T[k] = h1(sg.block([n_in + j], fcols), sg.block(fcols, fcols))[:, 0, :] \
                / gain[:, None]
    B = np.zeros((n_dof, n_in))
    B[p.force_dofs, np.arange(n_in)] = 1.0
    smoothing = None if p.period is not None else welch_smoothing(
        "hann", nperseg, p.fs, input_spectrum=(sp.freqs, fpsd[keep]))
    return LevelFRF(p.label, p.level, sp.freqs, H, coh, var, B, T, sp.bin_factor, n_eff,
                    smoothing)


def model_frf(H_lin: np.ndarray, lf: LevelFRF,
              terms: list[tuple[np.ndarray, float, Hashable]]) -> np.ndarray:
    """Model FRF at this level: ``H_L (B - sum w p T)``.

    Parameters
    ----------
    H_lin : ndarray, shape (n_f, n_dof, n_dof)
        Receptance of the model's underlying linear system on ``lf.freqs``.
    terms : list of (w, p, key)
        Element position, coefficient and basis key (``lf.T[key]``) of each nonlinear term.
    """
    rhs = np.broadcast_to(lf.B, (lf.freqs.size,) + lf.B.shape).astype(complex)
    for w, coef, key in terms:
        rhs = rhs - coef * w[None, :, None] * lf.T[key][:, None, :]
    return H_lin @ rhs if lf.leakage is None else H_lin @ rhs + lf.leakage


def chi2(lf: LevelFRF, H_model: np.ndarray) -> float:
    """Variance-weighted squared misfit (effective, bin correlation removed)."""
    return float(2 * np.sum(np.abs(lf.H - H_model) ** 2 / lf.var) / lf.bin_factor)


def weighted_error(lf: LevelFRF, H_model: np.ndarray) -> float:
    """Coherence-weighted relative FRF error (rms over the band; 0 = perfect)."""
    num = np.sum(lf.coh * np.abs(lf.H - H_model) ** 2)
    den = np.sum(lf.coh * np.abs(lf.H) ** 2)
    return float(np.sqrt(num / den))


def error_by_dof(lf: LevelFRF, H_model: np.ndarray) -> np.ndarray:
    """Share of the weighted misfit carried by each response DOF, shape (n_dof,)."""
    e = np.sum(np.abs(lf.H - H_model) ** 2 / lf.var, axis=(0, 2))
    return e / max(e.sum(), 1e-300)
