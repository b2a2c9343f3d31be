"""A test-derived modal model from one measured level (``nlid-lab fit-linear``).

The receptance column of the driving force at every response channel is taken from the
level as it was recorded:

* periodic (multisine) levels: the period-averaged FRF on the excited lines, with its noise
  from the spread over the periods (`analysis.spectral._bla`), which weights the modal fit (maximum
  likelihood);
* random levels: Welch H1, fitted through the window's smoothing kernel
  (`analysis.modal.welch_smoothing`), which removes the leakage bias of the damping.

Accelerance and mobility are converted to receptance. The modes are then found and refined by
`analysis.modal.fit_modes` and written as a ``[modal]`` model with residual pseudo-modes
(`analysis.modal._ema.modal_model`). A delay of the responses behind the force (anti-alias
filters that differ between channels) is read off a first fit's poles
(`analysis.modal._delay`) and taken out of the FRF before the fit that is kept.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..spectral import (Interference, MainsCaveat, best_linear_approximation, convert_frf,
                        default_nperseg, h1, hold_gain, spectral_matrix)
from ._delay import DelayReading, response_delay
from ._ema import ModalFit, Stabilisation, fit_modes, modal_model
from ..errors import InputError
from ._modal import welch_smoothing
from ..models import Model
from ..recordings import KIND_ORDER, Excitation, Recording, StepTable

#: A random level's lines count as excited where the force autospectrum is within this many
#: dB of its peak (a band-limited drive leaves the lines beyond its band to noise).
EXCITED_DB = 30.0
#: The written model may lose this factor of the free fit's error (both in the measured
#: kind, `frf_error`; floor 1 %) before the residual terms are refitted as pseudo-modes
#: (F-16-like twin, 8192-sample periods: 9.4 % written against a 3.2 % fit; FE beam: 1.4 %
#: against 0.65 %, within the floor).
LOST = 1.5
#: response channel rms, relative to the largest, below which the channel is dead (as the
#: reverse path's check)
DEAD_SHARE = 1e-3


@dataclass
class MeasuredReceptance:
    """Receptance column of one level.

    Attributes
    ----------
    freqs : ndarray, shape (n_f,)
        Uniformly spaced lines, Hz.
    H : ndarray, complex, shape (n_f, n_out)
    std : ndarray, shape (n_f, n_out), optional
        Noise standard deviation of ``H`` (periodic levels).
    smoothing : (offsets, weights), optional
        Welch smoothing kernel of ``H`` (random levels).
    driving_point : int
        Response channel at the force's DOF.
    method : str
    excited_hz : (lo, hi), optional
        Band the force excites (random levels: its autospectrum within `EXCITED_DB` of its
        peak); periodic levels hold only their excited lines.
    interference : tuple of Interference
        Steady force lines of a periodic level left out (`analysis.spectral.excited_lines`).
    caveat : MainsCaveat or None
        A periodic level of one realization with mains multiples on its drive lines.
    """

    freqs: np.ndarray
    H: np.ndarray
    std: np.ndarray | None
    smoothing: tuple[np.ndarray, np.ndarray] | None
    driving_point: int
    method: str
    excited_hz: tuple[float, float] | None = None
    interference: tuple[Interference, ...] = ()
    caveat: MainsCaveat | None = None


@dataclass
class LinearFit:
    """`fit_linear` result: the model, the modal fit behind it, the data and the errors."""

    model: Model
    modes: ModalFit
    stabilisation: Stabilisation
    data: MeasuredReceptance
    frf_error: np.ndarray          # (n_out,) in band, model against the data
    delay: DelayReading = DelayReading()    # responses behind the force, corrected in ``data``
    warnings: tuple[str, ...] = ()

    @property
    def delay_samples(self) -> float:
        """The delay taken out of ``data``, samples (0: none)."""
        return self.delay.samples


def measured_receptance(rec: Recording | StepTable, nperseg: int | None = None,
                        band: tuple[float, float] | None = None) -> MeasuredReceptance:
    """Receptance column of the (single) force at every response channel of ``rec``; a
    periodic level's lines picked within ``band`` (Hz) when given."""
    if isinstance(rec, StepTable):
        return table_receptance(rec)
    if rec.excitation != Excitation.RANDOM:
        raise InputError(f"fit-linear takes a random or multisine level, got "
                         f"{rec.excitation}: the modal fit needs uniformly spaced lines; test a sweep with "
                         "`nlid-lab detect` and fit a model to it with `nlid-lab analyze hbm`")
    if rec.n_in != 1:
        raise InputError(f"fit-linear takes one force channel, the level has {rec.n_in}; "
                         "fit each shaker's run separately")
    d = int(rec.force_dofs[0])
    if not 0 <= d < rec.n_dof:
        raise InputError(f"the force acts on DOF {d}, which no response channel measures; "
                         "fit-linear needs the driving point measured to scale the shapes")
    lay = rec.layout
    if lay is not None and (lay.periods >= 2 or lay.realizations >= 2):
        b = best_linear_approximation(rec.force, rec.response, rec.fs, lay.period,
                                      transient_periods=lay.transient_periods,
                                      realizations=lay.realizations, force_hold=rec.force_hold,
                                      band=band)
        H = convert_frf(b.G, b.freqs, rec.response_kind, "displacement")
        std = np.abs(convert_frf(np.sqrt(b.var_weight), b.freqs, rec.response_kind,
                                 "displacement"))
        return MeasuredReceptance(b.freqs, H, std, None, d,
                                  f"period-averaged FRF ({b.realizations} x {b.periods} "
                                  "periods), weighted by its noise from the period spread"
                                  if b.periods >= 2 else f"BLA over {b.realizations} "
                                  "realizations of one period, weighted by their spread",
                                  interference=b.interference, caveat=b.caveat)
    nseg = nperseg or default_nperseg(rec.force.shape[0])
    spec = spectral_matrix(np.concatenate([rec.force, rec.response], axis=1), rec.fs,
                           nperseg=nseg)
    auto = spec.auto()
    keep = spec.freqs > 0
    S = spec.S[keep]
    freqs = spec.freqs[keep]
    H = h1(S[:, 1:, :1], S[:, :1, :1])[:, :, 0] / hold_gain(freqs, rec.fs,
                                                            rec.force_hold)[:, None]
    smoothing = welch_smoothing(spec.window, spec.nperseg, spec.fs,
                                input_spectrum=(freqs, auto[keep, 0]))
    force_psd = np.abs(auto[keep, 0])
    excited = freqs[force_psd >= force_psd.max() * 10 ** (-EXCITED_DB / 10)]
    return MeasuredReceptance(freqs, convert_frf(H, freqs, rec.response_kind, "displacement"),
                              None, smoothing, d,
                              f"Welch H1 ({spec.n_avg} averages), fitted through the "
                              f"{spec.window} window's smoothing kernel",
                              (float(excited.min()), float(excited.max())))


def table_receptance(table: StepTable) -> MeasuredReceptance:
    """Receptance column of a stepped-sine table (its steps' phasor ratios; steps in
    frequency order). Its steps must be evenly spaced: the stabilisation diagram (LSCF)
    works on a uniform grid."""
    if table.n_in != 1:
        raise InputError(f"fit-linear takes one force channel, the level has {table.n_in}; "
                         "fit each shaker's run separately")
    order = np.argsort(table.freqs)
    f = table.freqs[order]
    step = np.diff(f)
    if step.min() <= 0 or np.ptp(step) > 1e-3 * step.mean():
        raise InputError("fit-linear needs the table's steps evenly spaced in frequency "
                         f"(steps {step.min():.4g}..{step.max():.4g} Hz)")
    iw = (2j * np.pi * f)[:, None] ** KIND_ORDER[table.response_kind]
    H = table.response_phasor[order] / table.force_phasor[order, :1] / iw
    return MeasuredReceptance(f, H, None, None, int(table.force_dofs[0]),
                              "stepped-sine table (fundamental phasors, "
                              f"{table.n_steps} steps)", (float(f[0]), float(f[-1])))


def fit_linear(rec: Recording | StepTable, band: tuple[float, float] | None = None, *,
               n_modes: int | None = None, points: list[str] | None = None,
               name: str = "fitted modal model", nperseg: int | None = None) -> LinearFit:
    """Modal model of one level (module docstring).

    Parameters
    ----------
    rec : Recording
        A low level (the structure closest to linear) of a random or multisine run.
    band : (lo, hi), optional
        Fit band, Hz; the excited lines by default.
    n_modes : int, optional
        Number of modes; automatic (the stabilisation diagram) when omitted.
    points : list of str, optional
        Names of the response channels (the model's points); ``"0", "1", ...`` by default.
    name : str
    nperseg : int, optional
        Welch segment length of a random level.

    Returns
    -------
    LinearFit
    """
    data = measured_receptance(rec, nperseg, band)
    if band is None and data.excited_hz is not None:
        band = data.excited_hz
    elif band is None:
        power = np.abs(data.H).max(axis=1)
        band = (float(data.freqs[power > 0].min()), float(data.freqs.max()))
    if points is not None and len(points) != rec.n_dof:
        raise InputError(f"{len(points)} point names for {rec.n_dof} response channels; "
                         "name each channel once")
    data, delay, stab = _delay_corrected(rec, data, band, n_modes)
    best = None
    # residual terms fitted freely (`fit_modes`); when the model written from them departs
    # from the fit (by more than LOST x its error: terms a pseudo-mode cannot hold), fitted
    # again as the pseudo-modes the model holds; the pseudo-modes kept or not: the written
    # model with the lowest error (measured kind)
    for pseudo in (False, True):
        modes, stab = fit_modes(data.freqs, data.H, band, n_modes=n_modes,
                                driving_point=data.driving_point, smoothing=data.smoothing,
                                std=data.std, pseudo_modes=pseudo, stab=stab)
        for residuals in (True, False):
            model = modal_model(modes, data.driving_point, points=points, name=name,
                                residuals=residuals)
            err = model_error(model, data, band, rec.response_kind)
            if best is None or err.max() < best[1].max():
                best = (model, err, modes)
        if not pseudo and best[1].max() <= LOST * max(
                frf_error(modes.receptance, data, band, rec.response_kind).max(), 0.01):
            break
    return LinearFit(best[0], best[2], stab, data, best[1], delay, _dead_channels(rec, points))


def _dead_channels(rec: Recording | StepTable, points: list[str] | None) -> tuple[str, ...]:
    """A warning per response channel `DEAD_SHARE` below the largest (a dead sensor or
    cable): its FRF and its entries of the shapes are converter noise."""
    if isinstance(rec, StepTable):
        return ()
    rms = rec.response.std(axis=0)
    names = points or [str(j) for j in range(rms.size)]
    return tuple(f"response channel {names[j]} carries "
                 f"{20 * np.log10(max(rms[j] / rms.max(), 1e-300)):.0f} dB of the largest "
                 "channel's signal: a dead sensor or cable? Its FRF and mode-shape entries are "
                 "noise; repair the channel and record again"
                 for j in np.flatnonzero(rms < DEAD_SHARE * rms.max()))


def _delay_corrected(rec: Recording | StepTable, data: MeasuredReceptance,
                     band: tuple[float, float], n_modes: int | None
                     ) -> tuple[MeasuredReceptance, DelayReading, Stabilisation | None]:
    """``data`` with the responses' delay behind the force (`._delay.response_delay`, read
    off a first fit's poles) taken out, the delay, and that fit's stabilisation diagram when
    nothing was changed (None: the corrected data need their own)."""
    if isinstance(rec, StepTable):
        return data, DelayReading(), None
    modes, stab = fit_modes(data.freqs, data.H, band, n_modes=n_modes,
                            driving_point=data.driving_point, smoothing=data.smoothing,
                            std=data.std)
    inb = (data.freqs >= band[0]) & (data.freqs <= band[1]) & (data.freqs > 0)
    if modes.poles.size == 0 or not inb.any():
        return data, DelayReading(), stab
    delay = response_delay(data.freqs[inb], data.H[inb],
                           None if data.std is None else data.std[inb], modes.poles, rec.fs)
    if delay.samples == 0.0:
        return data, delay, stab
    turn = np.exp(2j * np.pi * data.freqs * delay.samples / rec.fs)[:, None]
    return dataclasses.replace(data, H=data.H * turn), delay, None


def model_error(model: Model, data: MeasuredReceptance, band: tuple[float, float],
                kind: str) -> np.ndarray:
    """In-band relative error ``||H_model - H|| / ||H||`` per output, in the measured
    response ``kind`` (accelerance for accelerometers: the noise is flat there, where
    receptance would be dominated by the lowest lines), the model seen through the Welch
    kernel of a random level's estimate."""
    d = data.driving_point
    return frf_error(lambda f: model.linear_frf(f, [d])[:, :, 0], data, band, kind)


def frf_error(receptance: Callable[[np.ndarray], np.ndarray], data: MeasuredReceptance,
              band: tuple[float, float], kind: str) -> np.ndarray:
    """`model_error` of any receptance column ``receptance(freqs) -> (n_f, n_out)`` (a
    model's, or a modal fit's own synthesis)."""
    f = data.freqs
    inb = (f >= band[0]) & (f <= band[1]) & (f > 0)
    f = f[inb]
    if data.smoothing is None:
        synth = receptance(f)
    else:
        offsets, weights = data.smoothing
        weights = weights[inb] if np.ndim(weights) == 2 else np.broadcast_to(
            weights, (f.size, offsets.size))
        grid = receptance(np.abs(f[:, None] - offsets[None, :]).ravel())
        synth = np.einsum("fk,fko->fo", weights, grid.reshape(f.size, offsets.size, -1))
    a, b = (convert_frf(x, f, "displacement", kind) for x in (synth, data.H[inb]))
    return np.linalg.norm(a - b, axis=0) / np.linalg.norm(b, axis=0)
