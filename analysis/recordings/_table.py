"""Stepped-sine tables: per step the drive frequency and the fundamental phasors (contracts
section 6), as controllers export them instead of time blocks.

Phasors are of ``exp(+i w t)``: a response ``A cos(w t + p)`` is ``A exp(i p)``, an accelerance
has phase +90 deg at a resonance. One table is one level: what the controller held
(``control``: the force amplitude, or the response amplitude at ``control_dof``) at ``level``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from ..errors import RecordingError
from ._recording import MAX_SAMPLE, RESPONSE_KINDS, Control
from ._sensors import MIXED, SensorMap
from ._signals import KIND_ORDER


#: keys of a table recording with a `StepTable` field (every other key is kept in ``extra``)
STEP_TABLE_KEYS = ("excitation", "freqs", "force_phasor", "response_phasor", "force_dofs",
              "response_kind", "control", "control_dof", "level", "harmonics",
              "force_harmonics", "response_harmonics")


def _complex(value: Any, name: str, ndim: int) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype.kind not in "iufc":
        raise RecordingError(f"{name} must hold (complex) numbers, got dtype {arr.dtype}")
    arr = arr.astype(complex)
    if arr.ndim == ndim - 1:
        arr = arr[..., None]
    if arr.ndim != ndim:
        raise RecordingError(f"{name} must have {ndim} axes (steps first), got shape "
                             f"{arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise RecordingError(f"{name} holds NaN or infinite values; remove those steps")
    return arr


@dataclass(frozen=True)
class StepTable:
    """One stepped-sine level as a table of fundamental phasors.

    Attributes
    ----------
    freqs : ndarray, shape (n_steps,)
        Drive frequency of each step, Hz.
    force_phasor : ndarray, complex, shape (n_steps, n_in)
        Fundamental force phasors, N.
    response_phasor : ndarray, complex, shape (n_steps, n_out)
        Fundamental response phasors in the unit of ``response_kind``.
    force_dofs : ndarray of int, shape (n_in,)
        Response channel (0-based) measured where each force acts.
    control : Control
        What the controller held: the force amplitude, or the response amplitude at
        ``control_dof``.
    level : float
        The held amplitude (N, or the response's unit).
    response_kind : {"displacement", "velocity", "acceleration", "mixed"}
    control_dof : int, optional
        The held response channel (``control == "response"``; 0 if not given).
    harmonics : tuple of int
        Orders of ``force_harmonics`` / ``response_harmonics`` (empty: fundamentals only).
    force_harmonics, response_harmonics : ndarray, complex, optional
        Shape (n_steps, n_harmonics, channels).
    sensors : SensorMap, optional
        Model point and kind of each response channel.
    extra : dict of str to ndarray
        Keys of the source no field holds, written back on export.
    meta : dict
        Provenance (run file, level index); not part of the contract.
    """

    freqs: np.ndarray
    force_phasor: np.ndarray
    response_phasor: np.ndarray
    force_dofs: np.ndarray
    control: Control
    level: float
    response_kind: str = "displacement"
    control_dof: int | None = None
    harmonics: tuple[int, ...] = ()
    force_harmonics: np.ndarray | None = None
    response_harmonics: np.ndarray | None = None
    sensors: SensorMap | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)

    #: what the table's steps are (the `Recording.excitation` of time blocks)
    excitation: ClassVar[str] = "stepped-sine"

    def __post_init__(self) -> None:
        put = object.__setattr__       # frozen: normalise the arrays once, here
        put(self, "freqs", np.atleast_1d(np.asarray(self.freqs, dtype=float)))
        put(self, "force_phasor", _complex(self.force_phasor, "force_phasor", 2))
        put(self, "response_phasor", _complex(self.response_phasor, "response_phasor", 2))
        put(self, "force_dofs", np.atleast_1d(np.asarray(self.force_dofs)).astype(int))
        try:
            put(self, "control", Control(str(self.control)))
        except ValueError:
            raise RecordingError(f"control '{self.control}' is not one of "
                                 f"{', '.join(Control)}") from None
        put(self, "level", float(self.level))
        put(self, "harmonics", tuple(int(h) for h in self.harmonics))
        for name in ("force_harmonics", "response_harmonics"):
            if getattr(self, name) is not None:
                put(self, name, _complex(getattr(self, name), name, 3))
        if self.sensors is not None:
            put(self, "response_kind", self.sensors.kind)
        if self.control_dof is None and self.control == Control.RESPONSE:
            put(self, "control_dof", 0)
        self.validate()

    @property
    def n_steps(self) -> int:
        """Steps (drive frequencies)."""
        return self.freqs.size

    @property
    def n_dof(self) -> int:
        """Response channels."""
        return self.response_phasor.shape[1]

    @property
    def n_in(self) -> int:
        """Force channels."""
        return self.force_phasor.shape[1]

    @property
    def force_hold(self) -> str:
        """``"none"``: a table's force phasors are the force that acted
        (`Recording.force_hold`)."""
        return "none"

    @property
    def control_kind(self) -> str:
        """What the held amplitude measures: ``"force"``, or the held channel's kind."""
        if self.control == Control.FORCE:
            return "force"
        if self.sensors is not None:
            return self.sensors.response_kinds[self.control_dof]
        return self.response_kind

    def one_kind(self) -> "StepTable":
        """This table with every response channel in one kind (the highest present): mixed
        channels' phasors times ``(i w)`` per derivative; other tables unchanged."""
        if self.sensors is None or self.sensors.kind != MIXED:
            return self
        target = max(self.sensors.response_kinds, key=KIND_ORDER.__getitem__)
        order = np.array([KIND_ORDER[target] - KIND_ORDER[k] for k in self.sensors.response_kinds])
        iw = 2j * np.pi * self.freqs
        harm = None
        if self.response_harmonics is not None:
            ihw = iw[:, None, None] * np.asarray(self.harmonics)[None, :, None]
            harm = self.response_harmonics * ihw ** order
        smap = replace(self.sensors, response_kinds=(target,) * self.n_dof)
        return replace(self, response_phasor=self.response_phasor * iw[:, None] ** order,
                       response_harmonics=harm, sensors=smap, response_kind=target,
                       extra=dict(self.extra), meta=dict(self.meta))

    def frf(self) -> np.ndarray:
        """FRF of each step, ``response / force`` per force channel, shape
        (n_steps, n_out, n_in), in the table's response kind (exact for one force; an
        indicator only when several forces act at once)."""
        return self.response_phasor[:, :, None] / self.force_phasor[:, None, :]

    def held(self) -> np.ndarray:
        """Amplitude of the held quantity at each step (the force's first channel, or the
        response at ``control_dof``), shape (n_steps,)."""
        if self.control == Control.FORCE:
            return np.abs(self.force_phasor[:, 0])
        return np.abs(self.response_phasor[:, self.control_dof])

    def validate(self) -> None:
        """Raise `RecordingError` naming the first inconsistency found."""
        n = self.freqs.size
        if n < 2:
            raise RecordingError(f"a table needs at least 2 steps, got {n}")
        if not np.all(np.isfinite(self.freqs) & (self.freqs > 0)):
            raise RecordingError("freqs must be positive frequencies (Hz), one per step")
        for name in ("force_phasor", "response_phasor"):
            arr = getattr(self, name)
            if arr.shape[0] != n:
                raise RecordingError(f"{name} has {arr.shape[0]} steps, freqs {n}; give one "
                                     "row per step")
            if np.abs(arr).max(initial=0.0) > MAX_SAMPLE:
                raise RecordingError(f"{name} exceeds {MAX_SAMPLE:g}; check the units (SI)")
        if np.any(self.force_phasor == 0):
            raise RecordingError("force_phasor is zero at some step; a table step needs the "
                                 "force that drove it")
        if self.force_dofs.size != self.n_in:
            raise RecordingError(f"force_phasor has {self.n_in} channel(s) but force_dofs "
                                 f"names {self.force_dofs.size}")
        if np.any((self.force_dofs < 0) | (self.force_dofs >= self.n_dof)):
            raise RecordingError(f"force_dofs {self.force_dofs.tolist()} outside the response "
                                 f"channels 0..{self.n_dof - 1} (0-based)")
        if self.response_kind not in RESPONSE_KINDS and not (
                self.response_kind == MIXED and self.sensors is not None):
            raise RecordingError(f"response_kind '{self.response_kind}' is not one of "
                                 f"{', '.join(RESPONSE_KINDS)}")
        if self.control_dof is not None and not 0 <= self.control_dof < self.n_dof:
            raise RecordingError(f"control_dof {self.control_dof} is not a response channel "
                                 f"(0..{self.n_dof - 1})")
        if not 0 < self.level <= MAX_SAMPLE:  # False for NaN
            raise RecordingError(f"level (the held amplitude) must be a positive number, got "
                                 f"{self.level}")
        self._validate_harmonics()
        if self.sensors is not None:
            self.sensors.validate(self.n_dof, self.n_in)

    def _validate_harmonics(self) -> None:
        given = [self.force_harmonics is not None, self.response_harmonics is not None]
        if not any(given) and not self.harmonics:
            return
        if not all(given) or not self.harmonics:
            raise RecordingError("harmonics, force_harmonics and response_harmonics come "
                                 "together; give all three or none")
        if min(self.harmonics) < 1 or len(set(self.harmonics)) != len(self.harmonics):
            raise RecordingError(f"harmonics {list(self.harmonics)} must be distinct orders "
                                 ">= 1")
        for name, width in (("force_harmonics", self.n_in),
                            ("response_harmonics", self.n_dof)):
            shape = getattr(self, name).shape
            if shape != (self.n_steps, len(self.harmonics), width):
                raise RecordingError(f"{name} has shape {shape}, expected (n_steps, "
                                     f"n_harmonics, channels) = ({self.n_steps}, "
                                     f"{len(self.harmonics)}, {width})")
