"""What a shaker plays: one output record per waveform, each with its check and its player.

An output record (`RandomOutput`, `MultisineOutput`, `SineOutput`, `SweepOutput`) is what a
campaign hands `SignalGenerator.configure`; ``level`` (volts) scales it. Each record checks
itself (`check`, a `DriverConfigError` naming the problem) and makes the `Player` that
generates its samples at unit level for the simulated rig (`drivers.rig.SimRig`) and the
emulators on it. A new waveform is one record here with those two methods (a hardware backend
that can play it maps it to its commands, e.g. `drivers.serial_shaker`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from analysis.plant import ExcitationError, multisine, random_gaussian, sine_block
from analysis.recordings import SweepLaw

from .errors import DriverConfigError

# Random drive is generated in chunks of this many samples, independent of the DAQ frame
# size, so that the drive sequence depends only on the seed.
RANDOM_CHUNK = 8192


class Player(Protocol):
    """The samples of one output at unit level, in stream order.

    A shallow copy (`copy.copy`) is an independent player: state is scalars and arrays that
    are replaced, never written into (the rig looks ahead on a copy).
    """

    def play(self, n: int) -> np.ndarray:
        """The next ``n`` samples."""

    def idle(self, n: int) -> None:
        """``n`` samples pass with the output silent (its ramp at zero)."""

    def resume(self, last: "Player | None") -> None:
        """Take over from ``last``, the last player of the same record type (None: the
        first), as the rig switches to this one (under its lock: ``last`` stands still)."""


def _band(band: tuple[float, float], fs: float | None) -> None:
    lo, hi = band
    if not (0 <= lo < hi) or (fs is not None and hi > fs / 2):
        raise DriverConfigError(f"random band {list(band)} must satisfy 0 <= lo < hi <= fs/2")


@dataclass(frozen=True)
class RandomOutput:
    """Band-limited Gaussian noise; ``level`` is the drive rms in volts."""

    band: tuple[float, float]
    seed: int | None = None

    def check(self, fs: float | None = None) -> None:
        """Raise `DriverConfigError` if the band is unusable (at ``fs``, when given)."""
        _band(self.band, fs)

    def player(self, fs: float, seed: int | None) -> Player:
        """A fresh noise stream, seeded by the record's seed, else the rig's ``seed``."""
        return _RandomPlayer(fs, self.band, self.seed if self.seed is not None else seed or 0)


@dataclass
class _RandomPlayer:
    fs: float
    band: tuple[float, float]
    base: int
    chunk: np.ndarray | None = None
    index: int = -1
    pos: int = 0

    def play(self, n: int) -> np.ndarray:
        out = np.empty(n)
        filled = 0
        while filled < n:
            if self.chunk is None or self.pos >= RANDOM_CHUNK:
                self.index += 1
                seed = np.random.SeedSequence([self.base, self.index]).generate_state(1)[0]
                self.chunk = random_gaussian(RANDOM_CHUNK, self.fs, self.band, 1.0, int(seed))
                self.pos = 0
            take = min(n - filled, RANDOM_CHUNK - self.pos)
            out[filled:filled + take] = self.chunk[self.pos:self.pos + take]
            self.pos += take
            filled += take
        return out

    def idle(self, n: int) -> None:
        """The noise waits: it resumes where it stopped."""

    def resume(self, last: Player | None) -> None:
        """Start afresh."""


@dataclass(frozen=True)
class MultisineOutput:
    """Periodic random: a random-phase multisine with a flat amplitude spectrum in ``band``,
    one period of ``period`` samples at the DAQ's sample rate (generator and DAQ share the
    sample clock), repeated; ``level`` is the drive rms in volts."""

    band: tuple[float, float]
    period: int
    seed: int | None = None

    def check(self, fs: float | None = None) -> None:
        """Raise `DriverConfigError` if the band or the period is unusable."""
        _band(self.band, fs)
        if not (isinstance(self.period, int) and 16 <= self.period <= 1 << 24):
            raise DriverConfigError(f"multisine period {self.period} must be an integer "
                                    "number of samples in 16..2^24")

    def player(self, fs: float, seed: int | None) -> Player:
        """The period, played from its start."""
        try:
            period = multisine(self.period, fs, self.band, 1.0, self.seed)
        except ExcitationError as exc:        # e.g. no line of the period in the band
            raise DriverConfigError(str(exc)) from None
        return _PeriodPlayer(period)


@dataclass
class _PeriodPlayer:
    period: np.ndarray
    pos: int = 0

    def play(self, n: int) -> np.ndarray:
        idx = (self.pos + np.arange(n)) % self.period.size
        self.pos = int(idx[-1] + 1) % self.period.size
        return self.period[idx]

    def idle(self, n: int) -> None:
        """The period runs on the sample clock, heard or not."""
        self.pos = (self.pos + n) % self.period.size

    def resume(self, last: Player | None) -> None:
        """Start afresh."""


@dataclass(frozen=True)
class SineOutput:
    """Pure sine at ``freq`` Hz; ``level`` is the drive amplitude in volts."""

    freq: float

    def check(self, fs: float | None = None) -> None:
        """Raise `DriverConfigError` if ``freq`` is not in (0, fs/2)."""
        if not self.freq > 0 or (fs is not None and self.freq >= fs / 2):
            raise DriverConfigError(f"sine frequency {self.freq} Hz must lie in (0, fs/2)")

    def player(self, fs: float, seed: int | None) -> Player:
        """The sine, phase-continuous with the last sine played (`_SinePlayer.resume`)."""
        return _SinePlayer(fs, self.freq)


@dataclass
class _SinePlayer:
    fs: float
    freq: float
    phase: float = 0.0

    def play(self, n: int) -> np.ndarray:
        wave = sine_block(self.freq, 1.0, n, self.fs, phase=self.phase)
        self.idle(n)
        return wave

    def idle(self, n: int) -> None:
        """The phase runs on, heard or not."""
        self.phase = (self.phase + 2 * np.pi * self.freq * n / self.fs) % (2 * np.pi)

    def resume(self, last: "_SinePlayer | None") -> None:
        """Start where the last sine's phase stands."""
        self.phase = last.phase if last is not None else 0.0


@dataclass(frozen=True)
class SweepOutput:
    """Swept sine (`analysis.recordings.SweepLaw`: ``start_hz`` -> ``stop_hz``, ``law``
    linear or log, ``rate`` Hz/s or octaves/min), starting when the output turns on and
    silent once the sweep is over; ``level`` is the drive amplitude in volts."""

    start_hz: float
    stop_hz: float
    law: str = "linear"
    rate: float = 1.0

    def check(self, fs: float | None = None) -> None:
        """Raise `DriverConfigError` unless the sweep goes between two different
        frequencies in (0, fs/2), linear or log, at a rate > 0."""
        top = max(self.start_hz, self.stop_hz)
        if self.law not in ("linear", "log") or not (
                min(self.start_hz, self.stop_hz) > 0 and self.rate > 0
                and self.start_hz != self.stop_hz) or (fs is not None and top >= fs / 2):
            raise DriverConfigError(f"sweep {self} must go between two different "
                                    "frequencies in (0, fs/2), linear or log, at a rate > 0")

    def player(self, fs: float, seed: int | None) -> Player:
        """The sweep from its start."""
        return _SweepPlayer(fs, SweepLaw(self.start_hz, self.stop_hz, self.law, self.rate))


@dataclass
class _SweepPlayer:
    fs: float
    law: SweepLaw
    pos: int = 0        # samples of the sweep played so far

    def play(self, n: int) -> np.ndarray:
        t = (self.pos + np.arange(n)) / self.fs
        self.pos += n
        return np.where(t <= self.law.duration, np.sin(self.law.phase(t)), 0.0)

    def idle(self, n: int) -> None:
        """The sweep starts when the output turns on."""

    def resume(self, last: Player | None) -> None:
        """Start afresh."""


Output = RandomOutput | MultisineOutput | SineOutput | SweepOutput


def check_output(output: Output, fs: float | None = None) -> None:
    """Raise `DriverConfigError` if an output description is unusable (its own `check`)."""
    check = getattr(output, "check", None)
    if not (callable(check) and callable(getattr(output, "player", None))):
        raise DriverConfigError(f"unknown output type {type(output).__name__}")
    check(fs)
