"""Make recordings ready for comparison: displacement and velocity, DC removed, whole periods.

Real recordings carry DC offsets, responses recorded as velocity or acceleration and, for
periodic multisine drives, a start-up transient. `prepare_random` removes the offsets,
integrates or differentiates in the frequency domain (`analysis.recordings.to_kinematics`),
drops the transient periods and keeps a whole number of periods, so that a Welch estimate
with one period per segment and a rectangular window is free of leakage and averages periods.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..recordings import (Recording, clean_export, excitation_band, periodic_kinematics,
                          record_level, remove_dc, to_kinematics)
from ..spectral import spectral_matrix
from ._sensor_noise import floor_below_band, kinematic_noise

EDGE_FRACTION = 0.02
"""Fraction of an integrated record dropped at each end (FFT-integration end effects)."""


class DiagnoseInputError(InputError):
    """Recordings or options unfit for a diagnosis."""


@dataclass
class Prepared:
    """One random (or multisine) recording as displacement and velocity.

    Attributes
    ----------
    x, v : ndarray, shape (n, n_dof)
    force : ndarray, shape (n, n_in)
    force_dofs : ndarray of int
    fs : float
    level : float
        Nominal level (the recording's, else the force rms).
    period : int or None
        Samples per period of a periodic drive (whole periods are kept).
    label : str
    force_hold : {"none", "linear"}
        How the recorded force samples acted (`analysis.recordings.Recording.force_hold`).
    response_kind : str
        The kind the response was recorded as (displacement and velocity were formed
        from it).
    noise : (ndarray, ndarray), optional
        White sensor noise variance per DOF in ``x`` and ``v`` (`.sensor_noise`: read
        below the band of a random velocity or acceleration record); None when not read
        (displacement records; periodic records: their deformation is the Wiener-filtered
        period average).
    """

    x: np.ndarray
    v: np.ndarray
    force: np.ndarray
    force_dofs: np.ndarray
    fs: float
    level: float
    period: int | None
    label: str
    force_hold: str = "none"
    response_kind: str = "displacement"
    noise: tuple[np.ndarray, np.ndarray] | None = None


def level_name(rec: Recording) -> str:
    """A level as people read it: its nominal value (``level 30``), else its measured force,
    rounded to three figures (``12.4 N rms`` random, ``4.8 N`` sine amplitude): exports such
    as MAT files carry no nominal level."""
    if rec.level is not None:
        return f"level {rec.level:g}"
    unit = "N rms" if rec.excitation == "random" else "N"
    return f"{record_level(rec):.3g} {unit}"


def cleaned_exports(recs: list[Recording]) -> tuple[list[Recording], list[str]]:
    """``recs`` as ``nlid-lab import`` would have stored them (`analysis.recordings.clean_export`:
    an export's lead-in and trailing zeros dropped; a periodic record without a layout cut to
    whole periods, its layout found), and one line per change for the warnings. Records that
    did come through the import (or carry a layout) are returned as they are."""
    out, notes = [], []
    for r in recs:
        c = clean_export(r)
        out.append(c.recording)
        notes += c.notes(level_name(r))
    return out, notes


def analysis_band(rec: Recording, nperseg: int) -> tuple[float, float]:
    """Excited band of a random recording (from its force spectrum; for a record to be
    integrated, the lower edge as `analysis.recordings.excitation_band` gives it)."""
    f = remove_dc(rec.force)
    sp = spectral_matrix(f, rec.fs, nperseg=min(nperseg, f.shape[0]))
    return excitation_band(sp.freqs, sp.auto(), kind=rec.response_kind)


def prepare_random(rec: Recording, band: tuple[float, float], label: str, *,
                   period: int | None = None, transient_periods: int = 1) -> Prepared:
    """Displacement/velocity of a random or periodic-multisine recording.

    Parameters
    ----------
    rec : Recording
        ``excitation == "random"``.
    band : (lo, hi)
        Analysis band, Hz; its lower edge is the high-pass of any integration.
    label : str
    period : int, optional
        Samples per period of a periodic drive; the first ``transient_periods`` periods are
        dropped and a whole number of periods kept. When it is the period of the
        recording's ``layout``, the layout's transient periods of every realization are
        dropped instead.
    transient_periods : int
    """
    if rec.excitation != "random":
        raise DiagnoseInputError(f"{label}: expected a random recording, got {rec.excitation}")
    force = remove_dc(rec.force)
    resp = remove_dc(rec.response)
    lay = rec.layout
    if period is not None and lay is not None and lay.period == period:
        steady = (np.arange(lay.realizations)[:, None] * lay.realization_samples
                  + lay.transient_periods * period + np.arange(lay.periods * period)).ravel()
        force, resp, transient_periods = force[steady], resp[steady], 0
    if period is not None:
        n_per = force.shape[0] // period - transient_periods
        if n_per < 2:
            raise DiagnoseInputError(
                f"{label}: {force.shape[0]} samples hold fewer than {transient_periods + 2} "
                f"periods of {period} samples; give the right --period or a longer record")
        keep = slice(transient_periods * period, (transient_periods + n_per) * period)
        force, resp = remove_dc(force[keep]), remove_dc(resp[keep])
    # Low-pass well above the band: keeps the harmonics the nonlinear forces need while
    # cutting the sensor noise that differentiation would amplify near Nyquist.
    highpass, lowpass = kinematic_band(rec.fs, rec.response_kind, band, period is not None)
    if period is not None:   # whole periods: exact DFT lines, no extension or end effect
        x, v = (a.reshape(resp.shape) for a in periodic_kinematics(
            resp.reshape(-1, period, resp.shape[1]), rec.fs, rec.response_kind,
            highpass=highpass, lowpass=lowpass))
        return Prepared(x, v, force, rec.force_dofs, rec.fs, record_level(rec), period, label,
                        rec.force_hold, rec.response_kind)
    x, v = to_kinematics(resp, rec.fs, rec.response_kind, highpass=highpass, lowpass=lowpass)
    # integrated records only: their noise grows as 1/f^k towards the high-pass; a
    # displacement record's white noise is a negligible share, and below the band a
    # displacement holds the element's low-frequency distortion, not only the noise
    floor = (None if rec.response_kind == "displacement"
             else floor_below_band(force, resp, rec.fs, band))
    noise = None if floor is None else kinematic_noise(floor, rec.response_kind, highpass,
                                                       lowpass)
    if rec.response_kind != "displacement":
        edge = int(EDGE_FRACTION * x.shape[0])
        x, v, force = x[edge:-edge], v[edge:-edge], force[edge:-edge]
    return Prepared(x, v, force, rec.force_dofs, rec.fs, record_level(rec), period, label,
                    rec.force_hold, rec.response_kind, noise)


def kinematic_band(fs: float, kind: str, band: tuple[float, float],
                   periodic: bool = False) -> tuple[float, float]:
    """High- and low-pass (Hz) with which a record of response ``kind`` is made displacement
    and velocity.

    The low-pass is twice the band's upper edge, except for periodic records of
    integrated kinds (``periodic``): there it is 0.9 x Nyquist, because a slider's
    deformation carries harmonics far above the drive band (its reversals) that
    the law needs, integration attenuates the sensor noise there and the period average
    of `analysis.diagnose._compare.deformation` Wiener-filters each line (measured on
    `twin-hysteresis_joint-acc-multisine`, band 2-15 Hz: the slip force fd -17 % with
    the 30 Hz low-pass, +0.5 % with 180 Hz).
    """
    wide = periodic and kind != "displacement"
    return (band[0] if kind != "displacement" else 0.0), (
        0.9 * fs / 2 if wide else min(0.9 * fs / 2, 2 * band[1]))


def prepared_band(p: Prepared, band: tuple[float, float]) -> tuple[float, float]:
    """The band `prepare_random` limited ``p``'s motion to."""
    return kinematic_band(p.fs, p.response_kind, band, p.period is not None)


def split_segment(p: Prepared, fraction: float = 0.7) -> tuple[Prepared, Prepared]:
    """Split one recording into a fitting part and a held-back part (time segments)."""
    n = p.x.shape[0]
    cut = int(fraction * n) if p.period is None else int(fraction * n / p.period) * p.period
    def part(s: slice, tag: str) -> Prepared:
        return Prepared(p.x[s], p.v[s], p.force[s], p.force_dofs, p.fs, p.level, p.period,
                        f"{p.label} ({tag})", p.force_hold, p.response_kind)
    return part(slice(0, cut), "fit segment"), part(slice(cut, n), "held-back segment")
