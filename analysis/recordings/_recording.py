"""Recorded (or simulated) test data as arrays (contracts section 3)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from ..errors import RecordingError
from ._sensors import MIXED, SensorMap
from ._sweep_law import Sweep



class Excitation(StrEnum):
    """How a level was driven: a recording's ``excitation``, a campaign's ``kind``."""

    RANDOM = "random"                  # random and periodic random (multisine)
    STEPPED_SINE = "stepped-sine"
    SWEPT_SINE = "swept-sine"


class ResponseKind(StrEnum):
    """What a response channel measures (a sensor map may also mix them: ``MIXED``)."""

    DISPLACEMENT = "displacement"
    VELOCITY = "velocity"
    ACCELERATION = "acceleration"


#: Unit of each channel kind (a force, a response kind) on summary lines and table levels.
CHANNEL_UNITS = {"force": "N", "displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}

#: The enums' members as tuples, for ``in`` checks, ``choices`` and messages.
EXCITATIONS = tuple(Excitation)
RESPONSE_KINDS = tuple(ResponseKind)
#: excitations recorded as one (n, channels) record (stepped sine: one record per step)
CONTINUOUS = (Excitation.RANDOM, Excitation.SWEPT_SINE)
MIN_FS, MAX_FS = 1e-3, 1e9  # Hz: sample rates of any acquisition
MAX_SAMPLE = 1e15     # largest |force| or |response| sample: squares and sums stay finite
MIN_PEAK = 1e-100     # smallest peak of a channel that is not all zero
FORCE_HOLDS = ("none", "linear")
DEFAULT_TRANSIENT_PERIODS = 1


@dataclass(frozen=True)
class PeriodicLayout:
    """Periodic layout of a random (multisine) record (contracts section 5).

    Each of ``realizations`` consecutive realizations holds ``transient_periods`` periods
    of start-up transient then ``periods`` steady periods of ``period`` samples.

    Attributes
    ----------
    period : int
        Samples per period.
    transient_periods : int
    periods : int
    realizations : int
    """

    period: int
    transient_periods: int
    periods: int
    realizations: int

    @property
    def realization_samples(self) -> int:
        """Samples of one realization: ``(transient_periods + periods) * period``."""
        return (self.transient_periods + self.periods) * self.period

    @classmethod
    def complete(cls, n: int, period: int, transient_periods: int | None = None,
                 periods: int | None = None, realizations: int | None = None
                 ) -> "PeriodicLayout":
        """The layout of an ``n``-sample record from the keys given; missing ones follow.

        ``transient_periods`` defaults to `DEFAULT_TRANSIENT_PERIODS`, ``realizations`` to
        1 (or to what ``periods`` implies) and ``periods`` to what fills the record.

        Raises
        ------
        RecordingError
            A key is not a positive whole number (``transient_periods`` may be 0), or the
            record does not hold whole realizations of the layout.
        """
        given = {"period": period, "transient_periods": transient_periods,
                 "periods": periods, "realizations": realizations}
        for key, value in given.items():
            lo = 0 if key == "transient_periods" else 1
            if value is not None and not (float(value).is_integer() and value >= lo):
                raise RecordingError(f"{key} = {value} must be a whole number >= {lo}")
        period = int(period)
        t = DEFAULT_TRANSIENT_PERIODS if transient_periods is None else int(transient_periods)
        if n % period:
            raise RecordingError(f"{n} samples are not a whole number of periods of {period}")
        total = n // period
        if periods is None:
            m = 1 if realizations is None else int(realizations)
            if total % m or total // m <= t:
                raise RecordingError(f"{total} periods of {period} samples do not split into "
                                     f"{m} realization(s) of {t} transient period(s) and at "
                                     "least one steady period; give periods")
            periods = total // m - t
        m = total // (t + int(periods)) if realizations is None else int(realizations)
        layout = cls(period, t, int(periods), m)
        if layout.realizations * layout.realization_samples != n:
            raise RecordingError(
                f"{n} samples are not {m} realization(s) of ({t} + {periods}) periods of "
                f"{period} samples; fix period, transient_periods, periods or realizations")
        return layout


class Control(StrEnum):
    """What a stepped-sine controller held at each step."""

    FORCE = "force"
    RESPONSE = "response"


@dataclass
class Recording:
    """Forces and responses of one run at one level.

    Attributes
    ----------
    fs : float
        Sample rate, Hz.
    excitation : {"random", "stepped-sine", "swept-sine"}
    force_dofs : ndarray of int, shape (n_in,)
        DOF (0-based) each force acts on.
    force : ndarray
        Random and swept-sine: (n, n_in); stepped-sine: (n_steps, n, n_in). Newtons.
    response : ndarray
        Random and swept-sine: (n, n_dof); stepped-sine: (n_steps, n, n_dof).
    response_kind : {"displacement", "velocity", "acceleration", "mixed"}
        What every response channel measures; with a sensor map it follows the map (its
        channels' common kind, or ``"mixed"``).
    freqs : ndarray, shape (n_steps,), optional
        Stepped-sine drive frequency of each step, Hz.
    level : float, optional
        Nominal level (force rms for random, force amplitude for stepped and swept sine).
    force_hold : {"none", "linear"}
        How the recorded force samples acted: as recorded ("none", a transducer behind an
        anti-alias filter) or linearly interpolated between samples ("linear", the
        simulated plant's drive).
    layout : PeriodicLayout, optional
        Periodic (multisine) layout of a random record; None for plain random data.
    sweep : Sweep, optional
        The sweep law of swept-sine data (required there, None otherwise).
    extra : dict of str to ndarray
        Keys of the source file that no field holds (e.g. ``sweep_start_hz``), kept
        verbatim so that they are written back on export.
    meta : dict
        Free-form provenance (run file, block sequence numbers, settings); not part of the
        recording contract.
    sensors : SensorMap, optional
        Model point and kind of each response channel, point of each force
        (`analysis.recordings._sensors`); None: channel ``j`` is point ``j``, all in ``response_kind``.
    monitors : dict of str to ndarray
        Channels that are neither force nor response (say the shaker amplifier's drive
        voltage), by name, each shaped like one force channel (``force.shape[:-1]``), as
        recorded. Kept through import, the run store and export; no estimator reads them.
    monitor_units : dict of str to str
        Unit text of each monitor (``""`` or missing: not given).
    control : Control
        Stepped sine: what the controller held per step, the force amplitude or (``level``
        then in the response's unit) the response amplitude at channel ``control_dof``.
    control_dof : int, optional
        The held response channel of a response-controlled level.
    """

    fs: float
    excitation: str
    force_dofs: np.ndarray
    force: np.ndarray
    response: np.ndarray
    response_kind: str = "displacement"
    freqs: np.ndarray | None = None
    level: float | None = None
    force_hold: str = "none"
    layout: PeriodicLayout | None = None
    sweep: Sweep | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)
    sensors: SensorMap | None = None
    monitors: dict[str, np.ndarray] = field(default_factory=dict)
    monitor_units: dict[str, str] = field(default_factory=dict)
    control: Control = Control.FORCE
    control_dof: int | None = None

    def __post_init__(self) -> None:
        if self.sensors is not None:
            self.response_kind = self.sensors.kind
        self.force_dofs = np.atleast_1d(np.asarray(self.force_dofs)).astype(int)
        self.force = np.asarray(self.force, dtype=float)
        self.response = np.asarray(self.response, dtype=float)
        if self.freqs is not None:
            self.freqs = np.atleast_1d(np.asarray(self.freqs, dtype=float))
        self.monitors = {str(k): np.asarray(v) for k, v in self.monitors.items()}
        self.monitor_units = {str(k): str(v) for k, v in self.monitor_units.items()}
        self.validate()
        self.monitors = {k: v.astype(float, copy=False) for k, v in self.monitors.items()}

    @property
    def n_dof(self) -> int:
        return self.response.shape[-1]

    @property
    def n_in(self) -> int:
        return self.force.shape[-1]

    def validate(self) -> None:
        """Raise `RecordingError` naming the first inconsistency found."""
        self._validate_settings()
        self._validate_samples()
        self._validate_channels()
        self._validate_drive()
        self._validate_monitors()
        self._validate_layout()

    def _validate_settings(self) -> None:
        """Sample rate, level and the vocabularies (excitation, force hold, response kind)."""
        if not MIN_FS <= self.fs <= MAX_FS:  # False for NaN
            raise RecordingError(f"sample rate fs must be a number in {MIN_FS:g}..{MAX_FS:g} "
                                 f"Hz, got {self.fs}")
        if self.level is not None and not 0 < self.level <= MAX_SAMPLE:
            raise RecordingError(f"level (force_rms or force_amplitude) must be a number in "
                                 f"(0, {MAX_SAMPLE:g}] N, got {self.level}")
        if self.excitation not in EXCITATIONS:
            raise RecordingError(f"excitation '{self.excitation}' is not one of "
                                 f"{', '.join(EXCITATIONS)}")
        if self.force_hold not in FORCE_HOLDS:
            raise RecordingError(f"force_hold '{self.force_hold}' is not one of "
                                 f"{', '.join(FORCE_HOLDS)}")
        if self.response_kind not in RESPONSE_KINDS and not (
                self.response_kind == MIXED and self.sensors is not None):
            raise RecordingError(f"response_kind '{self.response_kind}' is not one of "
                                 f"{', '.join(RESPONSE_KINDS)}")

    def _validate_samples(self) -> None:
        """Force and response: the excitation's shape, finite samples in SI ranges."""
        ndim = 2 if self.excitation in CONTINUOUS else 3
        shape_doc = "(n, channels)" if ndim == 2 else "(n_steps, n, channels)"
        for name in ("force", "response"):
            arr = getattr(self, name)
            if arr.ndim != ndim:
                raise RecordingError(f"{name} must have shape {shape_doc} for "
                                     f"{self.excitation} data, got {arr.shape}")
            # a finite sum proves every sample finite (cheap); an infinite one may be overflow
            if not np.isfinite(arr.sum()) and not np.all(np.isfinite(arr)):
                bad = int(np.count_nonzero(~np.isfinite(arr)))
                raise RecordingError(f"{name} holds {bad} NaN/infinite samples; "
                                     "remove or repair them before analysis")
            if arr.shape[-2] < 2 or arr.shape[-1] < 1:
                raise RecordingError(f"{name} of shape {arr.shape} holds no data: it needs at "
                                     "least 2 samples and 1 channel")
            flat = arr.reshape(-1, arr.shape[-1])
            peak = np.maximum(flat.max(axis=0), -flat.min(axis=0))
            bad = (peak > MAX_SAMPLE) | ((peak > 0) & (peak < MIN_PEAK))
            if np.any(bad):
                j = int(np.argmax(bad))
                raise RecordingError(f"{name} channel {j} peaks at {peak[j]:.3g}, outside "
                                     f"{MIN_PEAK:g}..{MAX_SAMPLE:g}; check the units (SI) and "
                                     "the scaling")

    def _validate_channels(self) -> None:
        """Force and response of one length; force DOFs (and the sensor map) agree."""
        if self.force.shape[:-1] != self.response.shape[:-1]:
            raise RecordingError(f"force {self.force.shape} and response "
                                 f"{self.response.shape} differ in length")
        if self.force_dofs.ndim != 1:
            raise RecordingError(f"force_dofs must be a flat list of DOF indices, one per "
                                 f"force channel, got shape {self.force_dofs.shape}; write "
                                 f"e.g. [0] or [0, 2]")
        if self.force.shape[-1] != self.force_dofs.size:
            raise RecordingError(f"force has {self.force.shape[-1]} channels but force_dofs "
                                 f"names {self.force_dofs.size}")
        if np.any(self.force_dofs < 0) or np.any(self.force_dofs >= self.n_dof):
            raise RecordingError(f"force_dofs {self.force_dofs.tolist()} outside 0..."
                                 f"{self.n_dof - 1} (DOF indices are 0-based)")
        if self.sensors is not None:
            self.sensors.validate(self.n_dof, self.n_in)
            if self.sensors.force_channels != self.force_dofs.tolist():
                raise RecordingError(f"force_dofs {self.force_dofs.tolist()} are not the "
                                     "channels measuring force_points "
                                     f"{list(self.sensors.force_points)}; drop force_dofs or "
                                     "make them agree")

    def _validate_drive(self) -> None:
        """A stepped sine's frequencies, a swept sine's law, each below fs/2."""
        if self.excitation == "stepped-sine":
            if self.freqs is None or self.freqs.shape != (self.force.shape[0],):
                raise RecordingError("stepped-sine data needs freqs with one drive frequency "
                                     "per step")
            if not np.all((self.freqs > 0) & (self.freqs < self.fs / 2)):
                raise RecordingError("stepped-sine freqs must lie between 0 and fs/2")
        if (self.sweep is not None) != (self.excitation == "swept-sine"):
            raise RecordingError("swept-sine data need their sweep law (sweep_start_hz, "
                                 "sweep_stop_hz, sweep_law, sweep_rate) and other data none")
        top = max(self.sweep.law.start_hz, self.sweep.law.stop_hz) if self.sweep else 0.0
        if top >= self.fs / 2:
            raise RecordingError(f"the sweep reaches {top:g} Hz, not below fs/2 = "
                                 f"{self.fs / 2:g} Hz; check sweep_start_hz/sweep_stop_hz")

    def _validate_layout(self) -> None:
        """A periodic layout belongs to random data and fills its samples exactly."""
        if self.layout is None:
            return
        if self.excitation != "random":
            raise RecordingError("a periodic layout (period, ...) belongs to random "
                                 f"(multisine) data, not {self.excitation}")
        lay = self.layout
        if lay.realizations * lay.realization_samples != self.force.shape[0]:
            raise RecordingError(
                f"{self.force.shape[0]} samples are not {lay.realizations} realization(s) "
                f"of ({lay.transient_periods} + {lay.periods}) periods of {lay.period} "
                "samples")

    def _validate_monitors(self) -> None:
        """Monitor channels: named (no comma), real numbers, one force channel's shape."""
        shape = self.force.shape[:-1]
        for name, arr in self.monitors.items():
            if not name.strip() or "," in name or name != name.strip():
                raise RecordingError(f"monitor name {name!r} must be non-empty text without "
                                     "commas or surrounding spaces; rename the channel")
            if arr.dtype.kind not in "iuf":
                raise RecordingError(f"monitor '{name}' must hold real numbers, got dtype "
                                     f"{arr.dtype}")
            if arr.shape != shape:
                raise RecordingError(f"monitor '{name}' has shape {arr.shape}, not the "
                                     f"force's {shape} (one sample per force sample)")
        unknown = sorted(set(self.monitor_units) - set(self.monitors))
        if unknown:
            raise RecordingError(f"monitor_units names {unknown}, which are not monitors")
        for name, unit in self.monitor_units.items():
            if "," in unit:
                raise RecordingError(f"monitor '{name}': unit {unit!r} holds a comma; write "
                                     "it without")
