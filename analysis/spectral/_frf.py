"""FRFs of one force level: H1 and coherences (random), BLA (periodic random), X1/F1 (sine).

`level_frf` turns one level's `Recording` into a `LevelFRF`; reports, views, exports and the
live view all build their FRFs here. `default_nperseg` is the one rule for the Welch segment
length of a whole record, used by the reverse path, detection and these FRFs alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _spectral as spectral
from ._bla import BLA, best_linear_approximation
from ..recordings import (CHANNEL_UNITS, KIND_ORDER, Excitation, Recording, StepTable, excitation_band,
                          measured_level)
from ._sine_fit import hold_gain, sine_fit
from ._sweep import recording_sweep_frf

#: FRF units by response kind (receptance, mobility, accelerance).
FRF_UNITS = {"displacement": "m/N", "velocity": "(m/s)/N", "acceleration": "(m/s²)/N"}

#: Units of a held amplitude by what was held (a table's `StepTable.control_kind`).
HELD_UNITS = CHANNEL_UNITS

#: Shortest and longest default Welch segment, samples.
MIN_NPERSEG, MAX_NPERSEG = 64, 8192


@dataclass
class LevelFRF:
    """FRFs of one level of a run.

    Attributes
    ----------
    label : str
        Legend text, e.g. ``"10 N rms"``.
    level : float, optional
        Nominal level (force rms or amplitude).
    excitation : str
        ``"random"``, ``"stepped-sine"`` or ``"swept-sine"``.
    response_kind : str
        ``"displacement"``, ``"velocity"`` or ``"acceleration"``.
    force_dofs : ndarray of int
    freqs : ndarray, shape (n_f,)
        Frequencies, Hz (uneven for stepped sine; in sweep order for a swept sine).
    H : ndarray, shape (n_f, n_dof, n_in), complex
        H1 estimate (random) or fundamental-harmonic ratio X1/F1 (stepped sine; swept sine
        by sine-fit tracking, `analysis.spectral.sweep_frf`).
    coherence : ndarray, shape (n_f, n_dof, n_in), optional
        Ordinary coherence of each output/input pair (random only).
    multiple_coherence : ndarray, shape (n_f, n_dof), optional
        Multiple coherence of each output with all inputs (random only).
    n_averages : int
        Welch segments or BLA realizations averaged (1 for stepped sine).
    bla : analysis.spectral.BLA, optional
        Periodic-random levels: the robust best linear approximation (``H`` is its ``G``)
        with its noise and total variances.
    sweep : analysis.spectral.SweepFRF, optional
        Swept-sine levels: the tracked fundamental and harmonics (``sweep.direction`` +1 up,
        -1 down).
    level_kind : str
        What ``level`` measures: ``"force"``, or the held response's kind (a
        response-controlled table).
    """

    label: str
    level: float | None
    excitation: str
    response_kind: str
    force_dofs: np.ndarray
    freqs: np.ndarray
    H: np.ndarray
    coherence: np.ndarray | None = None
    multiple_coherence: np.ndarray | None = None
    n_averages: int = 1
    bla: Any = None
    sweep: Any = None
    level_kind: str = "force"

    @property
    def units(self) -> str:
        return FRF_UNITS[self.response_kind]


def default_nperseg(n: int) -> int:
    """Default Welch segment length of an ``n``-sample record.

    Parameters
    ----------
    n : int
        Record length, samples.

    Returns
    -------
    int
        The largest power of two giving at least 16 segments, clipped to
        [`MIN_NPERSEG`, `MAX_NPERSEG`].
    """
    target = max(n // 16, MIN_NPERSEG)
    return int(min(2 ** int(np.floor(np.log2(target))), MAX_NPERSEG))


def level_name(rec: Recording | StepTable) -> str:
    """A level as people read it: its nominal force (a response-controlled table: its held
    response amplitude), else the force it measured (``12.4 N rms``, ``4.8 N`` for sines:
    exports such as MAT files carry no level), three figures."""
    if isinstance(rec, StepTable):
        return f"{rec.level:.3g} {HELD_UNITS.get(rec.control_kind, 'N')}"
    unit = "N rms" if rec.excitation == Excitation.RANDOM else "N"
    value = measured_level(rec) if rec.level is None else rec.level
    return f"{value:.3g} {unit}"


def level_label(rec: Recording | StepTable, index: int | None = None) -> str:
    """Legend text of a level: `level_name` (and a swept sine's direction); ``index`` (the
    level's position in its run) is not needed since every level has a force."""
    if isinstance(rec, StepTable):
        return level_name(rec)
    direction = "" if rec.sweep is None else \
        f", sweep {'up' if rec.sweep.law.direction > 0 else 'down'}"
    return f"{level_name(rec)}{direction}"


def level_frf(rec: Recording | StepTable, index: int = 0,
              nperseg: int | None = None) -> LevelFRF:
    """FRFs (and coherences for random data) of one level's recording.

    Parameters
    ----------
    rec : Recording or StepTable
        One level (a table: its phasor ratios).
    index : int
        Position of the level in its run (for the label of a level without nominal force).
    nperseg : int, optional
        Welch segment length of random levels (default `default_nperseg`).

    Returns
    -------
    LevelFRF
        Stepped sine: X1/F1 per step; swept sine: the tracked X1/F1 (first force channel);
        periodic random with >= 2 realizations: the BLA;
        otherwise H1 with coherences over the excited band.
    """
    common = dict(label=level_label(rec, index), level=rec.level, excitation=rec.excitation,
                  response_kind=rec.response_kind, force_dofs=rec.force_dofs)
    if isinstance(rec, StepTable):
        return LevelFRF(freqs=rec.freqs.copy(), H=rec.frf(), n_averages=1,
                        level_kind=rec.control_kind, **common)
    if rec.excitation == Excitation.STEPPED_SINE:
        freqs, H = sine_frf(rec)
        return LevelFRF(freqs=freqs, H=H, n_averages=1, **common)
    if rec.excitation == Excitation.SWEPT_SINE:
        r = recording_sweep_frf(rec)
        H = convert_frf(r.frf, r.freqs, "displacement", rec.response_kind)
        return LevelFRF(freqs=r.freqs, H=H[:, :, None], n_averages=1, sweep=r, **common)
    lay = rec.layout
    if lay is not None and rec.n_in == 1 and (lay.realizations >= 2 or lay.periods >= 2):
        b = best_linear_approximation(rec.force, rec.response, rec.fs, lay.period,
                                      transient_periods=lay.transient_periods,
                                      realizations=lay.realizations,
                                      force_hold=rec.force_hold)
        return frf_from_bla(b, **common)
    nseg = nperseg or default_nperseg(rec.force.shape[0])
    spec = spectral.spectral_matrix(np.concatenate([rec.force, rec.response], axis=1),
                                    rec.fs, nperseg=nseg)
    return frf_from_spectra(spec, rec.n_in, **common)


def frf_from_spectra(spec: spectral.Spectra, n_in: int, **common: Any) -> LevelFRF:
    """H1, ordinary and multiple coherence from a spectral matrix of [forces, responses].

    Kept only over the excited band: outside it the force carries no power and H1 is noise.
    ``common`` holds the `LevelFRF` fields that describe the level (label, level, ...).
    """
    n_ch = spec.S.shape[1]
    fin, fout = list(range(n_in)), list(range(n_in, n_ch))
    auto = spec.auto()
    lo, hi = excitation_band(spec.freqs, auto[:, fin])
    keep = (spec.freqs >= lo) & (spec.freqs <= hi)
    S = spec.S[keep]
    S_rr, S_xr = S[:, fin][:, :, fin], S[:, fout][:, :, fin]
    coh = np.stack([np.stack([spectral.ordinary_coherence(S, q, p) for p in fin], -1)
                    for q in fout], 1)
    mcoh = spectral.multiple_coherence(auto[keep][:, fout], S_xr, S_rr)
    return LevelFRF(freqs=spec.freqs[keep], H=spectral.h1(S_xr, S_rr), coherence=coh,
                    multiple_coherence=mcoh, n_averages=spec.n_avg, **common)


def frf_from_bla(b: BLA, **common: Any) -> LevelFRF:
    """A periodic-random level's FRFs: the BLA and its coherence across realizations."""
    return LevelFRF(freqs=b.freqs, H=b.G[:, :, None], coherence=b.coherence[:, :, None],
                    multiple_coherence=b.coherence, n_averages=b.realizations, bla=b, **common)


def sine_frf(rec: Recording) -> tuple[np.ndarray, np.ndarray]:
    """Fundamental-harmonic FRF X1/F1 of each stepped-sine step.

    Returns
    -------
    freqs : ndarray, shape (n_steps,)
    H : ndarray, shape (n_steps, n_dof, n_in), complex
        With several force channels each column is the ratio to that channel's fundamental:
        exact for a single shaker, an indicator only when several forces act at once.
    """
    H = np.empty((rec.freqs.size, rec.n_dof, rec.n_in), complex)
    for i, f in enumerate(rec.freqs):
        X = sine_fit(rec.response[i], rec.fs, f)[0]     # (n_dof,)
        F = sine_fit(rec.force[i], rec.fs, f)[0]        # (n_in,)
        H[i] = X[:, None] / (F[None, :] * hold_gain(f, rec.fs, rec.force_hold))
    return rec.freqs.copy(), H


def convert_frf(H: np.ndarray, freqs: np.ndarray, kind: str, to: str) -> np.ndarray:
    """FRF ``H`` (first axis along ``freqs``) of response ``kind`` as response ``to``: times
    ``(i 2 pi f)`` per derivative (receptance -> mobility -> accelerance) or divided by it."""
    iw = (2j * np.pi * np.asarray(freqs, dtype=float)).reshape((-1,) + (1,) * (H.ndim - 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        return H * iw ** (KIND_ORDER[to] - KIND_ORDER[kind])
