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
inputs, ``g2`` the coherence of each measured FRF, the FRFs taken in the recorded response
kind (an accelerance for accelerometers: integrated sensor noise would otherwise swamp the
lowest mode and hide the others). Statistics (`chi2`) use the H1 random-error
variance ``(1 - g2) / (g2 n_eff) |H|^2`` (Bendat & Piersol) -- or, for a one-input periodic
record, the spread of its periods -- plus a model-precision floor.
"""

from __future__ import annotations

import weakref
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Hashable

import numpy as np
from scipy.signal import firwin, resample, resample_poly

from ..models import KINDS, Element, Model, memory_force_series, restoring_force
from ..modal import welch_smoothing
from ..recordings import KIND_ORDER
from ..spectral import excited_lines, h1, hold_gain, multiple_coherence, spectral_matrix
from ._prepare import Prepared
from ._sensor_noise import noise_bias

GROUP = 8
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
    noise_dof : float, optional
        Degrees of freedom of the random part of ``var`` when it comes from the spread of
        the periods (periodic records); None for the coherence formula.
    kind_order : int
        Differentiations from displacement to the recorded response kind (acceleration 2):
        the error metric weighs the FRF as it was recorded.
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
    noise_dof: float | None = None
    kind_order: int = 0

    @property
    def weight(self) -> np.ndarray:
        """Weights of the error metric: coherence times ``|2 pi f|^(2 k)`` (the FRF in the
        recorded kind), shape like ``H``."""
        scale = (self.freqs / self.freqs.max()) ** (2 * self.kind_order)
        return self.coh * scale[:, None, None]

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


def deformation(p: Prepared, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Deformation ``u = w.x`` and its rate along the measured motion (read-only arrays).

    A periodic record's deformation is its period average, Wiener-filtered line by line
    with the noise variance from the spread of the periods, repeated over the record: a
    relative displacement of two accelerometer channels is a small difference of large
    doubly integrated signals, and the integrated sensor noise in it would otherwise shift
    the peaks a clearance or slider acts at (errors in the basis variables bias the fit).

    The pair is kept (`_Memo`) for the record and location: the search asks for it once per
    candidate kind, grid value and refinement step, and `law_force` keys the motion it
    interpolates for a memory law on these very arrays.
    """
    return _DEFORMATIONS.get((p,), (w.dtype.str, w.tobytes()),
                             lambda: _frozen(*_deformation(p, w)))


def _deformation(p: Prepared, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u, v = p.x @ w, p.v @ w
    n_per = u.size // p.period if p.period else 0
    if n_per < 2:
        return u, v
    spec = np.fft.rfft(u[:n_per * p.period].reshape(n_per, p.period), axis=1)
    mean = spec.mean(axis=0)
    noise = (np.abs(spec - mean) ** 2).sum(axis=0) / ((n_per - 1) * n_per)
    mean *= np.clip(1 - noise / np.maximum(np.abs(mean) ** 2, 1e-300), 0.0, 1.0)
    om = 2j * np.pi * np.fft.rfftfreq(p.period, 1 / p.fs)
    if p.period % 2 == 0:
        om[-1] = 0.0   # Nyquist line of a derivative is not real
    one_u, one_v = np.fft.irfft(mean, p.period), np.fft.irfft(om * mean, p.period)
    return np.tile(one_u, n_per), np.tile(one_v, n_per)


def _frozen(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    for a in arrays:
        a.flags.writeable = False
    return arrays


class _Memo:
    """The most recent values of a function of some objects (held weakly: an entry holds only
    while they live, their ``id`` may be reused afterwards) and hashable details, up to
    ``max_bytes`` of arrays in all.

    Hand-written because `functools.lru_cache` would keep the records (and their motion)
    alive, needs hashable arguments, which arrays and records are not, and bounds entries,
    not memory.
    """

    def __init__(self, max_bytes: int) -> None:
        self.max_bytes, self.nbytes = max_bytes, 0
        self.items: OrderedDict[tuple, tuple[list[weakref.ref], Any, int]] = OrderedDict()

    def get(self, objs: tuple, detail: Hashable, make: Callable[[], Any]) -> Any:
        """The value for ``objs`` and ``detail``, made by ``make`` when absent."""
        key = (tuple(map(id, objs)), detail)
        hit = self.items.get(key)
        if hit is not None and all(r() is o for r, o in zip(hit[0], objs)):
            self.items.move_to_end(key)
            return hit[1]
        value = make()
        size = sum(a.nbytes for a in (value if isinstance(value, tuple) else (value,))
                   if isinstance(a, np.ndarray))
        if hit is not None:
            self.nbytes -= self.items.pop(key)[2]
        self.items[key] = ([weakref.ref(o) for o in objs], value, size)
        self.nbytes += size
        while self.nbytes > self.max_bytes and len(self.items) > 1:
            self.nbytes -= self.items.popitem(last=False)[1][2]
        return value


_DEFORMATIONS = _Memo(128 << 20)
"""Deformation and rate by (record, location)."""
_INTERPOLATED = _Memo(96 << 20)
"""Motion interpolated for the memory laws, by (deformation array, rate array, period)."""
_MEMORY_FORCES = _Memo(128 << 20)
"""Memory-law forces by (deformation array, rate array) and (kind, parameters, period): each
search pass screens the same candidates on the same records again."""


def law_force(kind: str, params: dict[str, float], u: np.ndarray, v: np.ndarray,
              period: int | None) -> np.ndarray:
    """Force of an element along ``u``, ``v``; a periodic memory element is first run
    through one period so that the record sees its settled loop, not the virgin start.

    A memory law is run on the motion interpolated band-limited to `MEMORY_OVERSAMPLE`
    times the sample rate (`oversampled_force`): its reversals are the motion's turning
    points, which the samples miss between them. The interpolated motion is computed once
    per ``u``, ``v`` (the same arrays from `deformation`) and period, not per law, and a
    memory law's force (read-only) once per parameters along them.
    """
    if not KINDS[kind].memory:
        return restoring_force(kind, params, u, v)[0]
    return _MEMORY_FORCES.get((u, v), (kind, tuple(sorted(params.items())), period),
                              lambda: _frozen(_memory_force(kind, params, u, v, period))[0])


def _memory_force(kind: str, params: dict[str, float], u: np.ndarray, v: np.ndarray,
                  period: int | None) -> np.ndarray:
    if period and u.size >= period:
        g = oversampled_force(kind, params, *_INTERPOLATED.get(
            (u, v), period, lambda: interpolated_motion(np.concatenate([u[-period:], u]),
                                                        np.concatenate([v[-period:], v]),
                                                        u.size % period == 0)))
        return g[period:]
    return oversampled_force(kind, params, *_INTERPOLATED.get(
        (u, v), None, lambda: interpolated_motion(u, v, False)))


MEMORY_OVERSAMPLE = 8
"""Rate factor at which memory laws run along the measured motion (`oversampled_force`)."""
_POLY_FILTER = firwin(20 * MEMORY_OVERSAMPLE + 1, 1.0 / MEMORY_OVERSAMPLE,
                      window=("kaiser", 5.0))
"""The low-pass `scipy.signal.resample_poly` designs for a factor `MEMORY_OVERSAMPLE` either
way (its default window), designed once instead of at every call."""


def interpolated_motion(u: np.ndarray, v: np.ndarray, periodic: bool
                        ) -> tuple[np.ndarray, np.ndarray, int, bool]:
    """``u``, ``v`` interpolated band-limited to `MEMORY_OVERSAMPLE` times the rate (FFT for
    whole periods, `scipy.signal.resample_poly` otherwise), with the sample count ``n`` and
    ``periodic`` that `oversampled_force` brings the force back with."""
    n, up = u.size, MEMORY_OVERSAMPLE
    if periodic:
        return _frozen(resample(u, n * up), resample(v, n * up)) + (n, True)
    return _frozen(resample_poly(u, up, 1, window=_POLY_FILTER),
                   resample_poly(v, up, 1, window=_POLY_FILTER)) + (n, False)


def oversampled_force(kind: str, params: dict[str, float], u_up: np.ndarray,
                      v_up: np.ndarray, n: int, periodic: bool) -> np.ndarray:
    """Force of a memory law run along the motion interpolated at `MEMORY_OVERSAMPLE` times
    the rate (`interpolated_motion`), brought back to the ``n`` samples.

    A slider reverses where the velocity changes sign; at the sample rate that turning point
    is missed by up to half a sample, so each Masing branch starts from a wrong ``(u_r, F_r)``
    (measured, SDOF hysteresis, multisine 2-60 Hz at 256 Hz, noise-free: the law on the
    samples fits the true force to 6-17 % and puts ``fd`` 7 % off; 8x: 1 % and 0.3-4 %).
    The law runs with its state in registers (`analysis.models.memory_force_series`), and
    the force is brought back to the sample rate by the same band-limited resampling as the
    motion was interpolated with, anti-aliased (a DAQ samples a continuous force).

    Parameters
    ----------
    kind : str
        Element kind (a memory kind).
    params : dict
        Its parameters by name.
    u_up, v_up : ndarray, shape (n * MEMORY_OVERSAMPLE,)
        Interpolated deformation and rate.
    n : int
        Samples at the record's rate.
    periodic : bool
        The motion holds whole periods of a periodic motion.

    Returns
    -------
    ndarray, shape (n,)
        The force at the sample rate.
    """
    g = memory_force_series(kind, params, u_up, v_up)
    if periodic:
        return resample(g, n)
    return resample_poly(g, 1, MEMORY_OVERSAMPLE, window=_POLY_FILTER)[:n]


def unit_force(kind: str, params: dict[str, float], w: np.ndarray, p: Prepared) -> np.ndarray:
    """Restoring force of one element (given parameters) along the measured motion."""
    u, v = deformation(p, w)
    return law_force(kind, params, u, v, p.period)


def stuck_stiffness(el: Element) -> float:
    """The element's stiffness before it slips (`analysis.models.Kind.initial_stiffness`),
    0 for kinds without one."""
    name = KINDS[el.kind].initial_stiffness
    return 0.0 if name is None else float(el.params[name])


def element_force(el: Element, p: Prepared) -> np.ndarray:
    """A model element's force along the measured motion, in the *stuck form*: less its
    stuck stiffness times the deformation, which `stuck_linear` holds instead."""
    u, v = deformation(p, el.w)
    return (law_force(el.kind, el.params, u, v, p.period) - stuck_stiffness(el) * u
            - noise_bias(el.kind, el.params, el.w, u, v, p.noise))


def stuck_linear(model: Model) -> Model:
    """The model with each element's stuck stiffness (sliders) added to its linear part.

    Predicting a level as ``H_L (B - sum w p T)`` is exact for either split of the
    stiffness, but with the stuck stiffness outside ``H_L`` the linear part resonates where
    the structure does not and amplifies the sensor noise in the measured basis forces; with
    it inside, ``H_L`` is the structure at low level and the terms carry only the slip.
    """
    stuck = [(el.w, stuck_stiffness(el)) for el in model.elements if stuck_stiffness(el)]
    if not stuck:
        return model
    K = model.stiffness.copy()
    for w, kd in stuck:
        wq = model.to_q(w)
        K += kd * np.outer(wq, wq)
    return model.with_linear(model.mass, model.damping, K, model.elements, model.name)


def level_frf(p: Prepared, band: tuple[float, float], nperseg: int,
              bases: dict[Hashable, np.ndarray], *, floor: float = FLOOR) -> LevelFRF:
    """Measured FRF of one level plus the force-to-basis transfer of every basis force.

    Both are per unit of the force that acted: a first-order-hold force (``force_hold =
    "linear"``) acted with ``sinc^2(f / fs)`` of its samples (`analysis.spectral.hold_gain`).
    """
    n_dof, n_in = p.x.shape[1], p.force.shape[1]
    sp = _spectra(p, band, nperseg, np.concatenate([p.x, p.force], axis=1))
    xi, fi = list(range(n_dof)), list(range(n_dof, n_dof + n_in))
    # Only the lines the force excites carry an FRF (`analysis.spectral.excited_lines`).
    fpsd = np.einsum("fii->f", sp.block(fi, fi)).real
    keep = _excited(p, sp.freqs, fpsd, band)
    sp.freqs, sp.S = sp.freqs[keep], sp.S[keep]
    S_ff = sp.block(fi, fi)
    S_xf = sp.block(xi, fi)
    gain = hold_gain(sp.freqs, p.fs, p.force_hold)
    H = h1(S_xf, S_ff) / gain[:, None, None]
    S_xx = np.einsum("fii->fi", sp.block(xi, xi)).real
    coh = np.clip(multiple_coherence(S_xx, S_xf, S_ff), 1e-6, 1 - 1e-12)
    coh = np.repeat(coh[:, :, None], n_in, axis=2)
    n_eff = max(sp.n_eff, 1.0)
    noise, dof = _period_noise(p, sp.freqs, H * gain[:, None, None]) if p.period else (None, None)
    if noise is None:
        var = ((1 - coh) / (coh * n_eff) + floor**2) * np.abs(H) ** 2
    else:
        var = noise / np.abs(gain[:, None, None]) ** 2 + floor**2 * np.abs(H) ** 2
    var = np.maximum(var, 1e-30 * np.abs(H).max() ** 2)
    T = _transfers(p, band, nperseg, bases, sp.freqs, gain)
    B = np.zeros((n_dof, n_in))
    B[p.force_dofs, np.arange(n_in)] = 1.0
    smoothing = None if p.period is not None else welch_smoothing(
        "hann", nperseg, p.fs, input_spectrum=(sp.freqs, fpsd[keep]))
    return LevelFRF(p.label, p.level, sp.freqs, H, coh, var, B, T, sp.bin_factor, n_eff,
                    smoothing, noise_dof=dof, kind_order=KIND_ORDER[p.response_kind])


MAINS_HZ = (50.0, 60.0)
"""Mains frequencies: their first three harmonics are interference on periodic records."""


def _excited(p: Prepared, freqs: np.ndarray, fpsd: np.ndarray, band: tuple[float, float]
             ) -> np.ndarray:
    """Mask of the lines of ``freqs`` the force excites (`analysis.spectral.excited_lines`:
    the project's one rule; for a periodic record with the steadiness of each line over the
    periods). A periodic record also leaves out its lines at the mains frequencies and their
    harmonics: mains pick-up on a response is steady from period to period, so where the
    drive excites that line too nothing tells the two apart (measured: a 50 Hz line at 5 %
    of the rms put a linear model's FRF error at 0.050 against a floor of 0.0105)."""
    noise = None
    if p.period is not None and p.x.shape[0] >= 2 * p.period:
        n_per = p.force.shape[0] // p.period
        per = p.force[:n_per * p.period].reshape(n_per, p.period, -1)
        F = np.fft.rfft(per, axis=1)[:, np.rint(freqs * p.period / p.fs).astype(int)]
        noise = np.sum(np.var(F, axis=0), axis=-1) / n_per * np.sum(fpsd) / max(
            float(np.sum(np.abs(F.mean(axis=0)) ** 2)), 1e-300)
    keep = np.zeros(freqs.size, dtype=bool)
    keep[excited_lines(freqs, fpsd, noise, band=band).lines] = True
    if p.period is not None:
        df = p.fs / p.period
        for f0 in MAINS_HZ:
            for k in (1, 2, 3):
                keep &= np.abs(freqs - k * f0) > df / 2
    return keep


def _spectra(p: Prepared, band: tuple[float, float], nperseg: int, data: np.ndarray):
    """Spectral matrix of ``data`` (rows of ``p``): exact lines of whole periods for a
    periodic record; Welch segments of a random one, leaving out those a clipped sample
    reaches (`Prepared.clipped`)."""
    if p.period is not None:
        return spectral_matrix(data, p.fs, nperseg=p.period, window="boxcar", overlap=0.0,
                               band=band)
    pieces = [data] if p.clipped is None else [
        data[a:b] for a, b in _runs(~p.clipped) if b - a >= nperseg]
    parts = [spectral_matrix(d, p.fs, nperseg=nperseg, band=band) for d in pieces or [data]]
    if len(parts) == 1:
        return parts[0]
    n_avg = sum(sp.n_avg for sp in parts)
    S = sum(sp.S * sp.n_avg for sp in parts) / n_avg
    return replace(parts[0], S=S, n_avg=n_avg, n_eff=sum(sp.n_eff for sp in parts))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2], edges[1::2]))


def _transfers(p: Prepared, band: tuple[float, float], nperseg: int,
               bases: dict[Hashable, np.ndarray], freqs: np.ndarray, gain: np.ndarray
               ) -> dict[Hashable, np.ndarray]:
    """``S_gf S_ff^-1`` of each basis force at ``freqs`` (excited bins of the estimate)."""
    T = {}
    keys = list(bases)
    n_in = p.force.shape[1]
    # Only basis-versus-force cross spectra are needed: small groups keep the spectral
    # matrices small (their cost grows with the square of the channel count).
    fcols = list(range(n_in))
    for g0 in range(0, len(keys), GROUP):
        group = keys[g0:g0 + GROUP]
        data = np.concatenate([p.force] + [np.asarray(bases[k])[:, None] for k in group],
                              axis=1)
        sg = _spectra(p, band, nperseg, data)
        sg.S = sg.S[np.isin(sg.freqs, freqs)]
        for j, k in enumerate(group):
            T[k] = h1(sg.block([n_in + j], fcols), sg.block(fcols, fcols))[:, 0, :] \
                / gain[:, None]
    return T


def add_basis(lf: LevelFRF, p: Prepared, band: tuple[float, float], nperseg: int,
              key: Hashable, basis: np.ndarray) -> None:
    """Add the transfer of one more basis force to ``lf`` (as `level_frf` forms it)."""
    gain = hold_gain(lf.freqs, p.fs, p.force_hold)
    lf.T.update(_transfers(p, band, nperseg, {key: basis}, lf.freqs, gain))


NOISE_LINES = 9
"""Lines over which a periodic record's noise variance is averaged: sensor noise over the
force spectrum varies slowly with frequency, and a variance from a few periods alone has so
few degrees of freedom that its inverse (the misfit weight) would be biased high."""


def _period_noise(p: Prepared, freqs: np.ndarray, H: np.ndarray
                  ) -> tuple[np.ndarray | None, float | None]:
    """Noise variance of the period-averaged FRF of a one-input periodic record, from the
    spread of its periods (Pintelon & Schoukens' nonparametric estimate), averaged over
    `NOISE_LINES` neighbouring excited lines; and its degrees of freedom.

    Returns ``(None, None)`` with several inputs or fewer than two periods (the coherence
    formula is used then).
    """
    n_per = p.x.shape[0] // p.period
    if p.force.shape[1] != 1 or n_per < 2:
        return None, None
    idx = np.rint(freqs * p.period / p.fs).astype(int)     # the DFT lines of ``freqs``

    def lines(a: np.ndarray) -> np.ndarray:
        per = a[:n_per * p.period].reshape(n_per, p.period, a.shape[1])
        return np.fft.rfft(per, axis=1)[:, idx]
    X, F = lines(p.x), lines(p.force)[:, :, 0]
    resid = X - H[None, :, :, 0] * F[:, :, None]        # the periods' spread about H F
    f_mean = np.abs(F.mean(axis=0)) ** 2
    var = (np.abs(resid) ** 2).sum(axis=0) / ((n_per - 1) * n_per) / f_mean[:, None]
    kernel = np.ones(NOISE_LINES) / NOISE_LINES
    pad = NOISE_LINES // 2
    padded = np.pad(var, ((pad, pad), (0, 0)), mode="edge")
    smooth = np.stack([np.convolve(padded[:, j], kernel, mode="valid")
                       for j in range(var.shape[1])], axis=1)
    return smooth[:, :, None], float(2 * (n_per - 1) * NOISE_LINES)


def model_frf(H_lin: np.ndarray, lf: LevelFRF,
              terms: list[tuple[np.ndarray, float, Hashable]], *, leakage: bool = True
              ) -> np.ndarray:
    """Model FRF at this level: ``H_L (B - sum w p T)`` (plus ``lf.leakage``).

    Parameters
    ----------
    H_lin : ndarray, shape (n_f, n_dof, n_dof)
        Receptance of the model's underlying linear system on ``lf.freqs``.
    terms : list of (w, p, key)
        Element position, coefficient and basis key (``lf.T[key]``) of each nonlinear term.
    leakage : bool
        Add the level's Welch leakage term; False gives the model's own response (what a
        linear correction acts on, `.linear_update.updated_frf`).
    """
    rhs = np.broadcast_to(lf.B, (lf.freqs.size,) + lf.B.shape).astype(complex)
    for w, coef, key in terms:
        rhs = rhs - coef * w[None, :, None] * lf.T[key][:, None, :]
    return H_lin @ rhs if lf.leakage is None or not leakage else H_lin @ rhs + lf.leakage


def chi2(lf: LevelFRF, H_model: np.ndarray) -> float:
    """Variance-weighted squared misfit (effective, bin correlation removed)."""
    return float(2 * np.sum(np.abs(lf.H - H_model) ** 2 / lf.var) / lf.bin_factor)


def weighted_error(lf: LevelFRF, H_model: np.ndarray) -> float:
    """Coherence-weighted relative FRF error in the recorded kind (rms over the band; 0 =
    perfect)."""
    num = np.sum(lf.weight * np.abs(lf.H - H_model) ** 2)
    den = np.sum(lf.weight * np.abs(lf.H) ** 2)
    return float(np.sqrt(num / den))


def error_by_dof(lf: LevelFRF, H_model: np.ndarray) -> np.ndarray:
    """Share of the weighted misfit carried by each response DOF, shape (n_dof,)."""
    e = np.sum(np.abs(lf.H - H_model) ** 2 / lf.var, axis=(0, 2))
    return e / max(e.sum(), 1e-300)
