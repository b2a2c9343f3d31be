"""What a real data-acquisition export adds to a clean (simulated) recording.

A catalogue of the artifacts real exports carry, each at the level they show, for simulated
twins: `DaqArtifacts` says which and how much, `apply_daq_artifacts` adds them to a
`Recording` in the order a measurement chain makes them (sensor, analog pick-up, anti-alias
filter, converter, export), and `shaker_force` makes a drive's force dip at the structure's
resonances as a force cell between shaker and structure measures it. ``DaqArtifacts.of``
builds a spec from catalogue names (`ARTIFACTS`, the ``--daq-artifacts`` names of
``nlid-lab simulate``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import StrEnum
from typing import Iterable

import numpy as np

from ..errors import InputError
from ._recording import Recording


class Artifact(StrEnum):
    """Catalogue names (docs/daq-artifacts.md gives each one's level and source)."""

    MAINS = "mains"
    DC = "dc"
    DRIFT = "drift"
    QUANTIZATION = "quantization"
    CLIPPING = "clipping"
    DELAY = "delay"
    DEAD_CHANNEL = "dead-channel"
    NOISY_CHANNEL = "noisy-channel"
    FORCE_DIPS = "force-dips"
    ZEROS = "zeros"
    PARTIAL_PERIOD = "partial-period"


ARTIFACTS = tuple(a.value for a in Artifact)


@dataclass(frozen=True)
class Shaker:
    """An electrodynamic shaker's armature, fixed to the drive point through a stiff stinger.

    Attributes
    ----------
    mass : float
        Armature (moving) mass, kg.
    stiffness : float
        Armature suspension, N/m.
    damping : float
        Back-EMF damping ``(Bl)^2 / R``, N s/m.
    """

    mass: float = 3.0
    stiffness: float = 3.0e3
    damping: float = 1500.0


@dataclass(frozen=True)
class DaqArtifacts:
    """Which artifacts to add and how much; the defaults add none.

    Levels are relative to each channel's own rms (the drive's, for the force), as a channel
    range is set to the signal it expects.

    Attributes
    ----------
    mains_hz : float, optional
        Mains frequency (50 or 60 Hz); lines at 1..`mains_harmonics` times it in every
        channel.
    mains_db : float
        First line's rms re the channel's rms (real exports: -30 to -50 dB); each harmonic
        6 dB below the previous one.
    mains_harmonics : int
    dc_offset : float
        Offset, times the channel's rms.
    drift : float
        Peak of a slow drift (a quarter sine over the record plus a ramp), times the rms.
    bits : int, optional
        Converter resolution over ``+-full_scale`` times the channel's peak.
    full_scale : float
        Range of the converter, times each channel's peak (a range set with margin).
    clipped : int
        Samples clipped in the response channel with the largest crest factor (its largest
        ``clipped`` |samples| cut to the next one).
    delay : float
        Samples the response channels lag the force (anti-alias filter group delay): whole
        samples by repeating the first, a fraction by a phase ramp over the record (a
        band-limited delay, circular: the record's first samples hold its last ones').
    dead_channel, noisy_channel : int, optional
        Response channel that records only converter noise (a broken cable), and one with
        `noisy_level` times its rms of white noise added (a loose sensor).
    noisy_level : float
    lead_in, trailing : int
        Samples of exact zeros before and after the record (the export's padding).
    partial_period : float
        Share of a period cut from the end of a periodic record (not a whole number of
        periods; the layout is dropped, as an export would not state it).
    """

    mains_hz: float | None = None
    mains_db: float = -40.0
    mains_harmonics: int = 3
    dc_offset: float = 0.0
    drift: float = 0.0
    bits: int | None = None
    full_scale: float = 2.0
    clipped: int = 0
    delay: float = 0
    dead_channel: int | None = None
    noisy_channel: int | None = None
    noisy_level: float = 0.3
    lead_in: int = 0
    trailing: int = 0
    partial_period: float = 0.0

    @classmethod
    def of(cls, names: Iterable[str], fs: float = 1.0) -> "DaqArtifacts":
        """The catalogue's level of each named artifact (`ARTIFACTS`); ``fs`` sets the
        length of the zeros (0.5 s). ``force-dips`` is a drive's (`shaker_force`): ignored here.

        Raises
        ------
        InputError
            A name outside the catalogue.
        """
        spec = cls()
        for name in names:
            if name not in ARTIFACTS:
                raise InputError(f"DAQ artifact '{name}' is not one of {', '.join(ARTIFACTS)}")
            spec = replace(spec, **_CATALOGUE[Artifact(name)](fs))
        return spec


#: Level of each artifact as real exports show it (docs/daq-artifacts.md).
_CATALOGUE = {
    Artifact.MAINS: lambda fs: {"mains_hz": 50.0, "mains_db": -40.0},
    Artifact.DC: lambda fs: {"dc_offset": 0.05},
    Artifact.DRIFT: lambda fs: {"drift": 0.1},
    Artifact.QUANTIZATION: lambda fs: {"bits": 16},
    Artifact.CLIPPING: lambda fs: {"clipped": 5},
    Artifact.DELAY: lambda fs: {"delay": 1},
    Artifact.DEAD_CHANNEL: lambda fs: {"dead_channel": -1},
    Artifact.NOISY_CHANNEL: lambda fs: {"noisy_channel": -1},
    Artifact.FORCE_DIPS: lambda fs: {},
    Artifact.ZEROS: lambda fs: {"lead_in": int(fs / 2), "trailing": int(fs / 2)},
    Artifact.PARTIAL_PERIOD: lambda fs: {"partial_period": 0.37},
}


def apply_daq_artifacts(recording: Recording, spec: DaqArtifacts,
                        rng: np.random.Generator) -> Recording:
    """``recording`` as a DAQ with ``spec``'s artifacts would have exported it.

    Continuous records (random, swept sine) and each step of a stepped sine alike; the zeros
    and the partial period apply to continuous records only.

    Parameters
    ----------
    recording : Recording
    spec : DaqArtifacts
    rng : numpy.random.Generator
        Source of the mains phases and the noise.

    Returns
    -------
    Recording
        A new recording (the input is not changed); its layout is dropped when the record
        length no longer holds it.
    """
    n_in = recording.force.shape[-1]
    data = np.concatenate([recording.force, recording.response], axis=-1).astype(float)
    t = np.arange(data.shape[-2]) / recording.fs
    rms = data.std(axis=-2, keepdims=True)
    data = _sensors(data, n_in, spec, rms, rng)
    data = data + _pickup(t, spec, rms, data.shape[-1], rng)
    if spec.delay:
        data[..., n_in:] = _delayed(data[..., n_in:], spec.delay)
    data = _converter(data, n_in, spec, rms)
    layout = recording.layout
    if recording.force.ndim == 2:
        data, layout = _framed(data, spec, layout)
    return replace(recording, force=data[..., :n_in], response=data[..., n_in:], layout=layout,
                   meta={**recording.meta, "daq_artifacts": spec})


def _delayed(resp: np.ndarray, delay: float) -> np.ndarray:
    """``resp`` (samples on axis -2) ``delay`` samples later: whole samples by repeating the
    first, the fraction by the phase ramp ``exp(-i 2 pi f frac / fs)``."""
    whole = int(np.floor(delay))
    frac = delay - whole
    if frac:
        n = resp.shape[-2]
        ramp = np.exp(-2j * np.pi * np.fft.rfftfreq(n) * frac)[:, None]
        resp = np.fft.irfft(np.fft.rfft(resp, axis=-2) * ramp, n, axis=-2)
    if whole:
        lag = resp[..., :-whole, :]
        resp = np.concatenate([np.repeat(lag[..., :1, :], whole, axis=-2), lag], axis=-2)
    return resp


def _sensors(data: np.ndarray, n_in: int, spec: DaqArtifacts, rms: np.ndarray,
             rng: np.random.Generator) -> np.ndarray:
    """The dead and the noisy response channel."""
    if spec.noisy_channel is not None:
        j = n_in + spec.noisy_channel % (data.shape[-1] - n_in)
        data[..., j] += spec.noisy_level * rms[..., j] * rng.standard_normal(data.shape[:-1])
    if spec.dead_channel is not None:
        j = n_in + spec.dead_channel % (data.shape[-1] - n_in)
        data[..., j] = 1e-5 * rms[..., j] * rng.standard_normal(data.shape[:-1])
    return data


def _pickup(t: np.ndarray, spec: DaqArtifacts, rms: np.ndarray, n_ch: int,
            rng: np.random.Generator) -> np.ndarray:
    """Mains lines, DC offsets and drift, per channel (broadcast over steps)."""
    out = np.zeros((t.size, n_ch))
    if spec.mains_hz:
        for k in range(1, spec.mains_harmonics + 1):
            amp = np.sqrt(2) * 10 ** ((spec.mains_db - 6.0 * (k - 1)) / 20)
            out += amp * np.sin(2 * np.pi * k * spec.mains_hz * t[:, None]
                                + rng.uniform(0, 2 * np.pi, n_ch))
    span = max(t[-1], 1e-300)
    out += spec.dc_offset * rng.choice([-1.0, 1.0], n_ch)
    out += spec.drift * (0.5 * np.sin(0.5 * np.pi * t / span) + 0.5 * t / span)[:, None]
    return out * rms


def _converter(data: np.ndarray, n_in: int, spec: DaqArtifacts, rms: np.ndarray) -> np.ndarray:
    """Clipping of a few samples, then quantisation over each channel's range."""
    if spec.clipped:
        resp = data[..., n_in:]
        crest = np.abs(resp).max(axis=-2) / np.maximum(resp.std(axis=-2), 1e-300)
        j = n_in + int(np.argmax(crest.reshape(-1, crest.shape[-1]).max(axis=0)))
        mags = np.sort(np.abs(data[..., j]), axis=-1)
        level = mags[..., -spec.clipped - 1: -spec.clipped]
        data[..., j] = np.clip(data[..., j], -level, level)
    if spec.bits:
        peak = np.abs(data).max(axis=-2, keepdims=True)
        step = 2 * spec.full_scale * np.maximum(peak, 1e-300) / 2 ** spec.bits
        data = np.round(data / step) * step
    return data


def _framed(data: np.ndarray, spec: DaqArtifacts, layout):
    """Partial last period, then the export's zeros; the layout when it still holds."""
    n = data.shape[0]
    if spec.partial_period and layout is not None:
        data = data[: n - int(round(spec.partial_period * layout.period))]
    if spec.lead_in or spec.trailing:
        data = np.concatenate([np.zeros((spec.lead_in, data.shape[1])), data,
                               np.zeros((spec.trailing, data.shape[1]))])
    return data, layout if data.shape[0] == n else None


def shaker_force(force: np.ndarray, fs: float, receptance: np.ndarray,
                 shaker: Shaker = Shaker()) -> np.ndarray:
    """The force a force cell measures when ``shaker`` pushes with ``force`` on a structure.

    The armature, moving with the drive point, takes part of the coil's force:
    ``F = F_coil / (1 + Z_a H_dd)`` with ``Z_a = k - m w^2 + i w c`` the armature's dynamic
    stiffness and ``H_dd`` the drive point's receptance, so the force dips at the
    structure's resonances (where ``H_dd`` peaks). Exact for a linear structure; for a
    nonlinear one ``H_dd`` is that of its underlying linear part (the dips keep the linear
    shape), while the record stays exact: simulated with this force, the response is the
    response to what the cell measured.

    Parameters
    ----------
    force : ndarray, shape (n,) or (n, 1)
        The coil's force (a flat-spectrum drive), applied over the whole record as a periodic
        signal (exact for whole periods of a multisine).
    fs : float
    receptance : ndarray, shape (n // 2 + 1,)
        Drive-point receptance at ``numpy.fft.rfftfreq(n, 1 / fs)``, m/N.
    shaker : Shaker

    Returns
    -------
    ndarray, shape of ``force``
    """
    f = np.asarray(force, dtype=float)
    n = f.shape[0]
    w = 2 * np.pi * np.fft.rfftfreq(n, 1 / fs)
    z = shaker.stiffness - shaker.mass * w ** 2 + 1j * w * shaker.damping
    gain = 1 / (1 + z * receptance)
    spec = np.fft.rfft(f.reshape(n, -1), axis=0) * gain[:, None]
    return np.fft.irfft(spec, n, axis=0).reshape(f.shape)
