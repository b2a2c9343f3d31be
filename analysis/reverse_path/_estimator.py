"""The reverse path estimator's entry point: records in, `ReversePathResult` out.

It chooses the route (Welch spectra with or without instrumental variables, or period
averaging for periodic records, `._iv`, `._periodic`), runs the estimate (`._core`), forms
an integrated record's lowest band through the first estimate (`._low_band`) and runs the
optional sequential refinement (`._stages`). How to estimate is one `ReversePathOptions`;
what the records are (sample rate, forced DOFs, response kind, force hold, periodic layout)
stays in the arguments, because a `Recording` already carries it.
"""

from __future__ import annotations

import re
import warnings as pywarnings

import numpy as np
from dataclasses import dataclass, fields, replace
from typing import Any, Mapping, Sequence

from ..errors import InputError
from ..spectral import (Resolution, Spectra, default_nperseg, longest_nperseg,
                        pole_resolution, resolving_nperseg, spectral_matrix)
from ..models import Model
from ..recordings import excitation_band
from ._documents import NoiseInfo, WelchSettings
from ._iv import iv_passes
from ._noise import buried_random, noise_info, noise_variances
from ._periodic import periodic_layout, periodic_reverse_path
from ._core import (ReversePathResult, _channels, _elements, _estimate, _integrated,
                    _Processing, _records, noise_edge)
from ._low_band import LOW_SHARE, LowBand, quasi_static_top
from ._stages import sequential


@dataclass(frozen=True)
class ReversePathOptions:
    """How to run the reverse path, independent of the records it is run on.

    Parameters
    ----------
    band : (lo, hi), optional
        Analysis band, Hz; by default the excited band of the force spectrum.
    nperseg : int, optional
        Welch segment length (default: a power of two <= n/16, at most 8192). Random records
        only: periodic records are averaged period by period.
    window : str
        Welch window (random records only).
    overlap : float
        Welch overlap fraction (random records only).
    antialias : {"auto", "warn", "off"}
        When a basis function would alias into the band: upsample before forming it and
        note it ("auto"), only warn ("warn"), or do nothing ("off").
    method : {"direct", "conditioned"}
        Invert ``G_RR`` directly (partially correlated inputs) or go through Bendat's
        conditioned, uncorrelated inputs (same estimate, paper section 3.2; random records
        only).
    noise : {"auto", "iv", "none"}
        "iv": instrumental variables and debiased bases (`._iv`, `._noise`),
        "none": H1 (biased low by sensor noise), "auto": "iv" when the response's white
        noise floor exceeds ``NOISE_THRESHOLD`` of its rms (random records) or when there
        are two or more steady periods (periodic records).
    refine : {"joint", "sequential"}
        "sequential": after the joint estimate, re-estimate each coefficient with the
        elements on forced DOFs fixed at their joint estimates, their uncertainty propagated
        (`._stages`; for a basis that shares its deformation with another, such as v|v|
        next to x^3).

    Raises
    ------
    InputError
        A choice outside its allowed values.
    """

    band: tuple[float, float] | None = None
    nperseg: int | None = None
    window: str = "hann"
    overlap: float = 0.5
    antialias: str = "auto"
    method: str = "direct"
    noise: str = "auto"
    refine: str = "joint"

    def __post_init__(self) -> None:
        for name, allowed in _CHOICES.items():
            if getattr(self, name) not in allowed:
                raise InputError(f"{name} must be {', '.join(allowed[:-1])} or {allowed[-1]}, "
                                 f"got '{getattr(self, name)}'")

    def changed(self, *names: str) -> list[str]:
        """Those of ``names`` whose value differs from the default.

        Parameters
        ----------
        *names : str
            Field names.

        Returns
        -------
        list of str
        """
        default = ReversePathOptions()
        return [n for n in names if getattr(self, n) != getattr(default, n)]


_CHOICES = {"antialias": ("auto", "warn", "off"), "method": ("direct", "conditioned"),
            "noise": ("auto", "iv", "none"), "refine": ("joint", "sequential")}
_WELCH_ONLY = ("nperseg", "window", "overlap", "method")


def reverse_path(data: Any, model: Model, options: ReversePathOptions | None = None, *,
                 fs: float | None = None, force_dofs: Sequence[int] | None = None,
                 response_kind: str = "displacement", force_hold: str | None = None,
                 period: int | None = None, transient_periods: int | None = None,
                 realizations: int | None = None, **option_fields: Any) -> ReversePathResult:
    """Estimate the unknown element parameters of ``model`` and the underlying linear FRF.

    Parameters
    ----------
    data : Recording, list of Recording, or (force, response) arrays
        Random-excitation records at one or several levels (pooled). ``response`` holds
        every DOF of the model. Periodic-random (multisine) records, marked by
        a ``layout`` or ``period=``, go to the period-averaging estimator
        (`._periodic.periodic_reverse_path`).
    model : Model
        Candidate: elements with omitted parameters are estimated; complete elements are
        included as known nonlinear forces.
    options : ReversePathOptions, optional
        How to estimate (band, Welch settings, antialiasing, inversion, noise treatment,
        refinement); defaults when omitted. An option that does not apply to the data
        (Welch settings on periodic records, ``refine="sequential"`` with no coefficient to
        fix) is ignored with a `UserWarning` saying so.
    fs, force_dofs, response_kind
        Needed with plain arrays only.
    force_hold : {"none", "linear"}, optional
        How the applied force behaves between its samples. "linear" (the simulated plant's
        first-order-hold drive) means the structure felt the baseband force
        ``F(f) sinc^2(f/fs)``, which is what enters H1; default: the recording's
        ``force_hold`` ("none": a force transducer behind an anti-alias filter).
    period, transient_periods, realizations : int, optional
        Periodic-random records: samples per period, leading periods of each realization
        dropped as transient (default 1) and realizations (blocks with their own random
        phases) per record (default 1); default: the recording's ``layout`` entries of the
        same names. Each realization holds ``transient_periods + P`` whole periods.
    **option_fields
        Deprecated: `ReversePathOptions` fields given as keywords (a `DeprecationWarning`);
        not together with ``options``.

    Returns
    -------
    ReversePathResult

    Raises
    ------
    InputError
        Invalid options or force hold, records that do not match the model, a band outside
        0..fs/2.
    """
    opts = _options(options, option_fields)
    if force_hold not in (None, "none", "linear"):
        raise InputError(f"force_hold must be none or linear, got '{force_hold}'")
    facts = dict(fs=fs, force_dofs=force_dofs, response_kind=response_kind,
                 force_hold=force_hold, period=period, transient_periods=transient_periods,
                 realizations=realizations)
    if opts.refine == "sequential":
        joint = replace(opts, refine="joint")
        return sequential(lambda cand: reverse_path(data, cand, joint, **facts), model)
    recs = _records(data, fs, force_dofs, response_kind)
    result = _estimated(recs, model, opts, force_hold, period, transient_periods, realizations)
    lag = channel_delay(result)
    if abs(lag) < MIN_DELAY:
        return result
    # the responses lag the force (an anti-alias filter's group delay on some channels):
    # delay the force to match, estimate again
    shifted = [(replace(r, force=_delayed(r.force, lag)), kind) for r, kind in recs]
    again = _estimated(shifted, model, opts, force_hold, period, transient_periods,
                       realizations)
    again.warnings.insert(0, f"the responses lag the force by {lag:.2f} samples (p(f) turns "
                          "with frequency as that delay makes it; an anti-alias filter's group "
                          "delay?): the force was delayed to match; record aligned channels "
                          "to avoid it")
    return again


def _options(options: ReversePathOptions | None,
             option_fields: Mapping[str, object]) -> ReversePathOptions:
    """The options given as ``options=`` or (deprecated) as keywords; the defaults without."""
    if option_fields:
        unknown_fields = set(option_fields) - {f.name for f in fields(ReversePathOptions)}
        if unknown_fields:
            raise TypeError(f"reverse_path() got unexpected keyword arguments "
                            f"{sorted(unknown_fields)}")
        if options is not None:
            raise InputError("give the reverse path options either as options= or as "
                             "keywords, not both")
        pywarnings.warn(f"reverse_path(..., {', '.join(sorted(option_fields))}=...) is "
                        "deprecated: pass options=ReversePathOptions(...)",
                        DeprecationWarning, stacklevel=3)
        options = ReversePathOptions(**option_fields)
    return options if options is not None else ReversePathOptions()


#: Smallest and largest delay between force and responses (samples) `channel_delay` reads.
MIN_DELAY, MAX_DELAY = 0.25, 4.0


def channel_delay(result: ReversePathResult) -> float:
    """Delay of the responses behind the force, in samples, read off the estimates' phase.

    A response channel delayed by ``tau`` relative to the force turns every ``p(f)`` by
    ``exp(i 2 pi f tau)``: the linear FRF absorbs the delay, the basis formed from the
    delayed response does not. ``tau`` (within +-`MAX_DELAY` samples) is where the
    weighted average of ``p(f) exp(-i 2 pi f tau)`` has the largest real part; 0 unless
    that changes some coefficient by more than 3 of its standard errors.
    """
    if not result.coefficients:
        return 0.0
    taus = np.linspace(-MAX_DELAY, MAX_DELAY, 801)
    turn = np.exp(-2j * np.pi * np.outer(taus, result.freqs) / result.spectra.fs)
    gains = []
    for c in result.coefficients:
        w = 1 / np.maximum(c.variance, 1e-300)
        real = (turn @ (w * c.values)).real / w.sum() * np.sign(c.value or 1.0)
        gains.append((real - abs(c.value)) / max(c.std, 1e-300))
    total = np.sum(gains, axis=0)
    best = int(np.argmax(total))
    return float(taus[best]) if max(g[best] for g in gains) > 3 else 0.0


def _delayed(force: np.ndarray, lag: float) -> np.ndarray:
    """``force`` delayed by ``lag`` samples (a phase ramp on the whole record: exact for
    whole periods, a few samples of end effect otherwise)."""
    n = force.shape[0]
    ramp = np.exp(-2j * np.pi * np.fft.rfftfreq(n) * lag)
    return np.fft.irfft(np.fft.rfft(force, axis=0) * ramp[:, None], n, axis=0)


def _estimated(recs, model: Model, opts: ReversePathOptions, force_hold: str | None,
               period: int | None, transient_periods: int | None,
               realizations: int | None) -> ReversePathResult:
    """`reverse_path` on checked records: the periodic or the Welch route."""
    rec0 = recs[0][0]
    if rec0.n_dof != model.n_dof:
        raise InputError(f"the response has {rec0.n_dof} channels but the model has "
                         f"{model.n_dof} DOFs; reverse path needs every DOF measured")
    unknown, known = _elements(model)
    warnings: list[str] = []
    layouts = [periodic_layout(r, period, transient_periods, realizations)
               for r, _ in recs]
    if any(lay is not None for lay in layouts):
        ignored = opts.changed(*_WELCH_ONLY)
        if ignored:
            pywarnings.warn(f"reverse path: {', '.join(ignored)} ignored: the records are "
                            "periodic, so they are averaged period by period (no Welch "
                            "segments, one input inversion)", UserWarning, stacklevel=2)
        return periodic_reverse_path(recs, layouts, model, unknown, known, opts.band,
                                               opts.antialias, force_hold, opts.noise,
                                               warnings)
    return _welch_route(recs, model, opts, force_hold, warnings)


def _welch_route(recs, model: Model, opts: ReversePathOptions, force_hold: str | None,
                 warnings: list[str]) -> ReversePathResult:
    """The Welch route. Without ``opts.nperseg`` (and without sensor noise) the segment
    resolves the narrowest of the resonances of the measured FRF (`_resolving`) and the
    modes of the candidate's linear part (`analysis.spectral.pole_resolution`): a nonlinear
    structure's FRF shows its modes shifted and widened by the nonlinearity (the paper's
    3-DOF case at 0.28x damping, 8 N rms: 83.5 Hz, 1.5 Hz wide, where the linear part's mode
    is 70.8 Hz, 0.71 Hz wide), and the linear part's leakage is what biases the estimate.
    Without ``opts.band`` the band is read at the segment length used."""
    fsr = float(recs[0][0].fs)
    n_min = min(r.force.shape[0] for r, _ in recs)
    nps = opts.nperseg if opts.nperseg is not None else default_nperseg(n_min)
    band = _band(recs, opts, nps)
    info, floors = noise_info([r for r, _ in recs], fsr, band[1], opts.noise, warnings)
    if opts.nperseg is None and info["method"] != "iv":
        # with sensor noise, ripples of H1 read as narrow peaks: the default length stays
        found = _resolving(recs, band, n_min)
        poles = pole_resolution(model.mass, model.damping, model.stiffness, band,
                                found.nperseg, fsr)
        by_poles = poles.bandwidth_hz < found.bandwidth_hz or np.isnan(found.bandwidth_hz)
        if by_poles:
            found = poles.at(min(max(poles.needed, found.nperseg), longest_nperseg(n_min)))
        nps = found.nperseg
        band = _band(recs, opts, nps)
        if not found.resolved or (by_poles and nps < found.needed):
            warnings.append(found.advice())
    return _at_nperseg(recs, model, opts, force_hold, info, floors, band, nps, warnings)


def _band(recs, opts: ReversePathOptions, nps: int) -> tuple[float, float]:
    """``opts.band``, else where the force is excited (`analysis.recordings.excitation_band`)
    as read with segments of ``nps`` samples (coarser lines would reach past the drive's
    edge: at 64 s, 0.28x damping, the band read at 16384 and analysed at 32768 took 3 lines
    below the 5 Hz edge and the cubic came out -8.9 % instead of -0.03 %)."""
    fsr = float(recs[0][0].fs)
    band = opts.band
    if band is None:
        fspec = Spectra.pool([spectral_matrix(r.force, fsr, nperseg=nps, window=opts.window,
                                              overlap=opts.overlap) for r, _ in recs])
        band = excitation_band(fspec.freqs, fspec.auto(), kind=_integrated(recs))
    lo, hi = float(band[0]), float(band[1])
    if not 0 <= lo < hi <= fsr / 2:
        raise InputError(f"band {lo:g}-{hi:g} Hz must satisfy 0 <= lo < hi <= fs/2 = "
                         f"{fsr / 2:g}")
    return lo, hi


def _at_nperseg(recs, model: Model, opts: ReversePathOptions, force_hold: str | None,
                info: NoiseInfo, floors, band: tuple[float, float], nps: int,
                warnings: list[str]) -> ReversePathResult:
    """The estimate with Welch segments of ``nps`` samples in ``band``."""
    fsr = float(recs[0][0].fs)
    fdofs = recs[0][0].force_dofs
    unknown, known = _elements(model)
    lo, hi = band
    edge = noise_edge(recs, floors, (lo, hi), nps)
    if edge > lo + 2 * fsr / nps:
        # the lines just above a brick-wall high-pass see its edge through the window
        warnings.append(f"the integrated response is below 10x its sensor noise under "
                        f"{edge:.3g} Hz (noise grows as 1/f^2 when integrated): analysed from "
                        f"{edge + 2 * fsr / nps:.3g} Hz")
        lo = edge + 2 * fsr / nps
    welch = WelchSettings(nperseg=nps, window=opts.window, overlap=opts.overlap, band=(lo, hi))
    inputs = [f"force@{d}" for d in fdofs]
    built, buried, labels = _built(recs, floors, (lo, hi), edge, opts, force_hold, info, unknown,
                                   known, warnings)
    inputs += labels
    spec = Spectra.pool([spectral_matrix(c, fsr, **welch) for *_, c in built])
    first: list[str] = []
    result = _estimate(spec, model.n_dof, fdofs, unknown, inputs, (lo, hi), opts.method,
                       first)
    if info["method"] != "iv" and _integrated(recs) != "displacement":
        result, first = _low_band_pass(result, first, recs, floors, (lo, hi), edge, opts,
                                       force_hold, info, model, welch)
    if info["method"] != "iv":
        warnings.extend(first)
    else:
        result = iv_passes(result, model, built, unknown, known, welch, info,
                                     warnings)
    if buried:
        info["buried"] = [max(buried[i::len(unknown)]) for i in range(len(unknown))]
        buried_random(info["buried"], unknown, warnings)
    result.warnings = _merge_alias_warnings(warnings)
    result.noise = info
    return result


def _low_band_pass(result: ReversePathResult, first: list[str], recs, floors,
                   band: tuple[float, float], edge: float, opts: ReversePathOptions,
                   force_hold: str | None, info: NoiseInfo, model: Model,
                   welch: WelchSettings) -> tuple[ReversePathResult, list[str]]:
    """The estimate again with every integrated record's lowest band formed from the force
    through the first one (`._low_band`), and its warnings; the first when the outputs are
    explained less well (a candidate far from the structure would form a wrong band)."""
    unknown, known = _elements(model)
    fc = LOW_SHARE * quasi_static_top(result.freqs, abs(result.H_linear).max(axis=(1, 2)))
    low = LowBand(result.estimated_model(model), fc)
    built, _, _ = _built(recs, floors, band, edge, opts, force_hold, info, unknown, known, [],
                         low)
    spec = Spectra.pool([spectral_matrix(c, result.spectra.fs, **welch) for *_, c in built])
    again: list[str] = []
    low_result = _estimate(spec, model.n_dof, result.force_dofs, unknown, result.inputs, band,
                           opts.method, again)
    if low_result.coherence_nonlinear.mean() >= result.coherence_nonlinear.mean():
        return low_result, again
    return result, first


def _built(recs, floors, band: tuple[float, float], highpass: float, opts: ReversePathOptions,
           force_hold: str | None, info: dict[str, Any], unknown, known, warnings: list[str],
           low: LowBand | None = None) -> tuple[list, list[float], list[str]]:
    """Every record's channels (`._core._channels`) as ``(rec, proc, channels)``, the
    bases' buried-noise shares and the input labels."""
    built, buried, labels = [], [], []
    for (rec, kind), floor in zip(recs, floors):
        proc = _Processing(float(rec.fs), kind, band, opts.antialias,
                           force_hold or rec.force_hold, info["lowpass_hz"],
                           highpass)
        nvar = noise_variances(proc, floor) if info["method"] == "iv" else None
        channels, labels = _channels(rec.response, rec.force, rec.force_dofs, proc, unknown,
                                     known, warnings, nvar, buried, low)
        built.append((rec, proc, channels))
    return built, buried, labels


def _resolving(recs, band: tuple[float, float], n_min: int) -> Resolution:
    """A first segment length: one that resolves the narrowest resonance of every record's
    measured FRF (`analysis.spectral.resolving_nperseg`), the same for all (they are
    pooled), with the narrowest resonance found (seen at that length)."""
    found = [resolving_nperseg(r.force, r.response, float(r.fs), band, kind)
             for r, kind in recs]
    nps = min(max(r.nperseg for r in found), longest_nperseg(n_min))
    peaks = [r for r in found if r.bandwidth_hz > 0]
    if not peaks:
        return found[0].at(nps)
    return min(peaks, key=lambda r: r.bandwidth_hz).at(nps)


_ALIAS = re.compile(r"^(aliasing: basis .+? of element \d+) spans (\d+) Hz and folds into the "
                    r"band \(([\d.e+-]+) % in-band error\) at fs = (\S+) Hz; (.*)$")


def _merge_alias_warnings(warnings: list[str]) -> list[str]:
    """Unique warnings in order, one aliasing line per basis instead of one per record."""
    out: list[str] = []
    groups: dict[str, list[re.Match]] = {}
    for w in warnings:
        m = _ALIAS.match(w)
        if m is None:
            if w not in out:
                out.append(w)
            continue
        if m.group(1) not in groups:
            groups[m.group(1)] = []
            out.append(m.group(1))           # placeholder, keeps the order
        groups[m.group(1)].append(m)
    for key, ms in groups.items():
        if len(ms) == 1:
            text = ms[0].group(0)
        else:
            factors = sorted({int(f) for x in ms for f in re.findall(r"upsampled x(\d+)",
                                                                      x.group(5))})
            what = (f"upsampled x{'-x'.join(map(str, (factors[0], factors[-1])))} before "
                    "forming it" if len(factors) > 1 else ms[0].group(5))
            text = (f"{key} spans up to {max(int(x.group(2)) for x in ms)} Hz and folds into "
                    f"the band (up to {max(float(x.group(3)) for x in ms):.2g} % in-band error, "
                    f"{len(ms)} records) at fs = {ms[0].group(4)} Hz; {what}")
        out[out.index(key)] = text
    return out
