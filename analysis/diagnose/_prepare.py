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
from ..recordings import (ClippingCaveat, Recording, clean_export, excitation_band,
                          periodic_kinematics, record_level, remove_dc, to_kinematics)
from ..spectral import spectral_matrix
from ._sensor_noise import floor_below_band, kinematic_noise

EDGE_FRACTION = 0.02
"""Fraction of an integrated record dropped at each end (FFT-integration end effects)."""
CLIP_REACH = 1.0
"""Periods of the integration's high-pass over which a clipped sample's error is taken to
reach the motion (`clip_margin`)."""


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
    clipped : ndarray of bool, shape (n,), optional
        Samples of a random record whose motion a clipped sample reaches
        (`analysis.recordings.ClippingCaveat`): the Welch segments holding one are left out
        of its spectra. None: nothing clipped (a periodic record drops the clipped periods
        instead, and marks its samples only when it cannot: fewer than two would stay).
    clipped_periods : int
        Periods of a periodic record left out for holding a clipped sample.
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
    clipped: np.ndarray | None = None
    clipped_periods: int = 0


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
                   period: int | None = None, transient_periods: int = 1,
                   clipped: ClippingCaveat | None = None) -> Prepared:
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
    clipped : ClippingCaveat, optional
        The record's clipped samples: a random record marks the samples they reach
        (`Prepared.clipped`), a periodic one leaves out the periods holding them.
    """
    if rec.excitation != "random":
        raise DiagnoseInputError(f"{label}: expected a random recording, got {rec.excitation}")
    force = remove_dc(rec.force)
    resp = remove_dc(rec.response)
    # Low-pass well above the band: keeps the harmonics the nonlinear forces need while
    # cutting the sensor noise that differentiation would amplify near Nyquist.
    highpass, lowpass = kinematic_band(rec.fs, rec.response_kind, band, period is not None)
    # a periodic record's motion is formed period by period: a clipped sample stays in its own
    margin = 0 if period is not None else clip_margin(rec.fs, rec.response_kind, highpass)
    hit = None if clipped is None else _reach(force.shape[0], clipped.samples, margin)
    if period is not None:
        return _prepare_periodic(rec, force, resp, label, period, transient_periods,
                                 (highpass, lowpass), hit)
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
        hit = None if hit is None else hit[edge:-edge]
    return Prepared(x, v, force, rec.force_dofs, rec.fs, record_level(rec), period, label,
                    rec.force_hold, rec.response_kind, noise,
                    None if hit is None or not hit.any() else hit)


def clipped_note(caveat: ClippingCaveat, p: Prepared) -> str:
    """The diagnosis's warning line for a level's clipped samples: the caveat and what was
    left out of ``p`` (its periods, or the Welch segments the samples reach)."""
    if p.period is not None and (p.clipped_periods or p.clipped is not None):
        kept = ("left out of the diagnosis: the periods holding them" if p.clipped_periods
                else "kept: fewer than two periods would stay without them")
        what = f"{kept} ({p.clipped_periods} of {p.clipped_periods + p.x.shape[0] // p.period})"
    elif p.clipped is None:
        what = "they fall outside the analysed samples (transient periods, trimmed ends)"
    else:
        share = 100 * float(p.clipped.mean())
        what = (f"left out of the diagnosis: the Welch segments they reach ({share:.2g} % of "
                "the record)")
    return caveat.text(what)


def clip_margin(fs: float, kind: str, highpass: float) -> int:
    """Samples on each side of a clipped sample that its error reaches in the motion: an
    integrated record's error spreads over about one period of the integration's high-pass
    (a clipped acceleration sample is a velocity step there); a displacement's stays put."""
    return 0 if kind == "displacement" or highpass <= 0 else int(np.ceil(CLIP_REACH * fs / highpass))


def _reach(n: int, samples: np.ndarray, margin: int) -> np.ndarray:
    """Mask of the ``n`` samples within ``margin`` of any of ``samples``."""
    hit = np.zeros(n + 1, dtype=int)
    np.add.at(hit, np.clip(samples - margin, 0, n), 1)
    np.add.at(hit, np.clip(samples + margin + 1, 0, n), -1)
    return np.cumsum(hit[:n]) > 0


def _prepare_periodic(rec: Recording, force: np.ndarray, resp: np.ndarray, label: str,
                      period: int, transient_periods: int, band: tuple[float, float],
                      hit: np.ndarray | None) -> Prepared:
    """`prepare_random` of a periodic record: steady whole periods, those holding a clipped
    sample (``hit``) left out while two or more periods stay."""
    lay = rec.layout
    rows = np.arange(force.shape[0])
    if lay is not None and lay.period == period:
        rows = (np.arange(lay.realizations)[:, None] * lay.realization_samples
                + lay.transient_periods * period + np.arange(lay.periods * period)).ravel()
        transient_periods = 0
    n_per = rows.size // period - transient_periods
    if n_per < 2:
        raise DiagnoseInputError(
            f"{label}: {rows.size} samples hold fewer than {transient_periods + 2} "
            f"periods of {period} samples; give the right --period or a longer record")
    rows = rows[transient_periods * period: (transient_periods + n_per) * period]
    dropped, kept = 0, None
    if hit is not None:
        bad = hit[rows].reshape(n_per, period).any(axis=1)
        if bad.any() and n_per - bad.sum() >= 2:
            rows, dropped = rows.reshape(n_per, period)[~bad].ravel(), int(bad.sum())
        elif bad.any():
            kept = hit[rows]
    force, resp = remove_dc(force[rows]), remove_dc(resp[rows])
    # whole periods: exact DFT lines, no extension or end effect
    x, v = (a.reshape(resp.shape) for a in periodic_kinematics(
        resp.reshape(-1, period, resp.shape[1]), rec.fs, rec.response_kind,
        highpass=band[0], lowpass=band[1]))
    return Prepared(x, v, force, rec.force_dofs, rec.fs, record_level(rec), period, label,
                    rec.force_hold, rec.response_kind, clipped=kept, clipped_periods=dropped)


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
        hit = None if p.clipped is None or not p.clipped[s].any() else p.clipped[s]
        return Prepared(p.x[s], p.v[s], p.force[s], p.force_dofs, p.fs, p.level, p.period,
                        f"{p.label} ({tag})", p.force_hold, p.response_kind, clipped=hit)
    return part(slice(0, cut), "fit segment"), part(slice(cut, n), "held-back segment")
