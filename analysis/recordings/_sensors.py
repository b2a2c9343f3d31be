"""Sensor maps: which model point and kind each response channel measures, where each force acts.

A recording's channels are not model DOFs. A `SensorMap` names, per response channel, the
model *point* it measures and its kind (displacement, velocity or acceleration), and per
force channel the point it acts on. A recording without one uses the identity map of old:
response channel ``j`` measures point ``j`` (named ``"j"``) in the recording's single
``response_kind``, and force ``i`` acts on point ``force_dofs[i]``.

This module is the one place that turns (model, sensor map) into what the consumers use:
`one_kind` converts mixed-kind channels to one kind, `model_at_sensors` restricts a model to
its measured points in channel order (exact: the internal coordinates stay, only the rows of
``T`` at unmeasured points are dropped), `channel_labels` names the channels.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ..errors import InputError, RecordingError
from ._keys import RecordingKeys
from ._signals import KIND_ORDER, change_kind

if TYPE_CHECKING:
    from ..models import Model
    from ._recording import Recording

#: recording-file keys of a sensor map (NPZ arrays of strings; CSV/TOML comma lists)
KEYS = ("response_points", "response_kinds", "force_points")
MIXED = "mixed"


@dataclass(frozen=True)
class SensorMap:
    """Point and kind of each response channel, point of each force channel.

    Attributes
    ----------
    response_points : tuple of str
        Model point each response channel measures (unique).
    response_kinds : tuple of str
        ``"displacement"``, ``"velocity"`` or ``"acceleration"`` per response channel.
    force_points : tuple of str
        Model point each force acts on; it must be a measured point (the driving point).
    """

    response_points: tuple[str, ...]
    response_kinds: tuple[str, ...]
    force_points: tuple[str, ...]

    def __post_init__(self) -> None:
        for name in KEYS:
            object.__setattr__(self, name, tuple(str(v) for v in getattr(self, name)))

    @property
    def kind(self) -> str:
        """The channels' common kind, or ``"mixed"``."""
        kinds = set(self.response_kinds)
        return kinds.pop() if len(kinds) == 1 else MIXED

    @property
    def labels(self) -> list[str]:
        """``"point (kind)"`` per response channel, as figures and views name them."""
        return [f"{p} ({k})" for p, k in zip(self.response_points, self.response_kinds)]

    @property
    def force_channels(self) -> list[int]:
        """Response channel measuring each force's point."""
        return [self.response_points.index(p) for p in self.force_points]

    def validate(self, n_response: int, n_force: int) -> None:
        """Raise `RecordingError` naming the first inconsistency with the channel counts."""
        for key, n in zip(KEYS, (n_response, n_response, n_force)):
            if len(getattr(self, key)) != n:
                raise RecordingError(f"{key} names {len(getattr(self, key))} channel(s) but the "
                                     f"recording has {n}; give one entry per channel")
        for p in self.response_points + self.force_points:
            if not p.strip():
                raise RecordingError("sensor map: a point name is empty; name every point")
        dup = sorted({p for p in self.response_points if self.response_points.count(p) > 1})
        if dup:
            raise RecordingError(f"response_points: {', '.join(dup)} measured by two channels; "
                                 "name each channel's point once (two directions are two points)")
        bad = [k for k in self.response_kinds if k not in KIND_ORDER]
        if bad:
            raise RecordingError(f"response_kinds: '{bad[0]}' is not one of "
                                 f"{', '.join(KIND_ORDER)}")
        lost = [p for p in self.force_points if p not in self.response_points]
        if lost:
            raise RecordingError(f"force_points: no response channel measures '{lost[0]}' "
                                 "(the driving point); add its channel to response_points")

    def to_keys(self) -> dict[str, np.ndarray]:
        """The map as recording keys (arrays of strings)."""
        return {k: np.array(getattr(self, k), dtype=str) for k in KEYS}

    @classmethod
    def from_keys(cls, data: RecordingKeys, n_response: int, force_dofs: Sequence[int],
                  response_kind: str | None) -> "SensorMap | None":
        """The map a file's keys give (missing ones completed from the identity map), or None
        when the file has none of `KEYS`.

        ``response_kind`` is the file's own key (checked against ``response_kinds``).
        """
        if not any(k in data for k in KEYS):
            return None
        given = {k: names(data[k], k) for k in KEYS if k in data}
        points = given.get("response_points", [str(j) for j in range(n_response)])
        if len(points) != n_response:
            raise RecordingError(f"response_points names {len(points)} point(s) but the "
                                 f"recording has {n_response} response channel(s)")
        default = response_kind if response_kind not in (None, MIXED) else "displacement"
        kinds = given.get("response_kinds", [default] * n_response)
        forces = given.get("force_points")
        if forces is None:
            forces = [points[int(d)] for d in force_dofs if 0 <= int(d) < n_response]
        smap = cls(tuple(points), tuple(kinds), tuple(forces))
        if response_kind is not None and "response_kinds" in given \
                and response_kind != smap.kind:
            raise RecordingError(f"response_kind = {response_kind} but response_kinds say "
                                 f"{smap.kind}; drop response_kind or make them agree")
        return smap


def names(value: Any, key: str) -> list[str]:
    """A list of names from an array of strings or one comma-separated string."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "US":
        raise RecordingError(f"{key} must be names (strings), got {arr.dtype}")
    if arr.ndim == 0:
        return [p.strip() for p in str(arr.item()).split(",")]
    return [str(p).strip() for p in arr.ravel()]


def table_keys(table: Any, where: str) -> dict[str, list[str]]:
    """The sensor-map keys of a TOML table (a ``--sensors`` file, a campaign's ``[sensors]``):
    each of `KEYS` a list of names, no other key.

    Raises
    ------
    RecordingError
        An unknown key, an empty table or a value that is not a list of names (``where``
        names the table in the message).
    """
    if not isinstance(table, dict):
        raise RecordingError(f"{where} must be a table of {', '.join(KEYS)}")
    unknown = sorted(set(table) - set(KEYS))
    if unknown or not table:
        raise RecordingError(f"{where} holds {', '.join(KEYS)}"
                             + (f", not {', '.join(unknown)}" if unknown else ""))
    out = {}
    for key, value in table.items():
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise RecordingError(f"{where}: {key} must be a list of names, e.g. "
                                 f"{key} = [\"wing_tip\", \"payload\"]")
        out[key] = [v.strip() for v in value]
    return out


def sensor_map(rec: "Recording") -> SensorMap:
    """The recording's sensor map, or the identity map it implies."""
    if rec.sensors is not None:
        return rec.sensors
    points = tuple(str(j) for j in range(rec.n_dof))
    return SensorMap(points, (rec.response_kind,) * rec.n_dof,
                     tuple(points[int(d)] for d in rec.force_dofs))


def channel_labels(rec: "Recording") -> list[str]:
    """``"point (kind)"`` per response channel (``"x0"`` style without a sensor map)."""
    if rec.sensors is None:
        return [f"{rec.response_kind[0]}{j}" for j in range(rec.n_dof)]
    return rec.sensors.labels


def one_kind(rec: "Recording") -> "Recording":
    """``rec`` with every response channel in one kind: mixed channels are differentiated to
    the highest kind present (frequency-domain, `analysis.recordings.change_kind`; periodic
    records period by period, which is exact in steady state; a stepped-sine table by its own
    ``one_kind``, on its phasors). Other recordings unchanged."""
    if rec.sensors is None or rec.sensors.kind != MIXED:
        return rec
    own = getattr(rec, "one_kind", None)      # `StepTable.one_kind` (no import: _table imports us)
    if own is not None:
        return own()
    target = max(rec.sensors.response_kinds, key=KIND_ORDER.__getitem__)
    out = rec.response.copy()
    for j, kind in enumerate(rec.sensors.response_kinds):
        order = KIND_ORDER[target] - KIND_ORDER[kind]
        if order:
            out[..., j] = _differentiate(rec, rec.response[..., j], order)
    smap = dataclasses.replace(rec.sensors, response_kinds=(target,) * rec.n_dof)
    return dataclasses.replace(rec, response=out, response_kind=target, sensors=smap,
                               extra=dict(rec.extra), meta=dict(rec.meta))


def _differentiate(rec: "Recording", x: np.ndarray, order: int) -> np.ndarray:
    if rec.excitation != "random":            # stepped sine: each step's record
        return np.stack([change_kind(step, rec.fs, order) for step in x])
    if rec.layout is None:
        return change_kind(x, rec.fs, order)
    periods = x.reshape(-1, rec.layout.period)
    f = np.fft.rfftfreq(rec.layout.period, 1 / rec.fs)
    gain = (2j * np.pi * f) ** order
    if rec.layout.period % 2 == 0:
        gain[-1] = gain[-1].real if order % 2 == 0 else 0.0
    return np.fft.irfft(np.fft.rfft(periods, axis=1) * gain, rec.layout.period,
                        axis=1).ravel()


def model_at_sensors(model: "Model", recs: "Recording | Sequence[Recording]",
                     purpose: str = "this analysis") -> "Model":
    """``model`` seen at the recordings' measured points, in channel order.

    Without a sensor map the channels are the model's points (returned unchanged). With one,
    the model keeps its linear part and internal coordinates; ``T`` keeps the rows of the
    measured points, so simulating the result gives exactly the full model's response at
    the sensors. Elements must act on measured points only (``purpose`` forms their basis or
    compares them from data).

    Raises
    ------
    InputError
        A mapped point is not in the model, the runs map their channels differently, or an
        element acts on an unmeasured point (naming the element and the point).
    """
    from ..models import Element, Model   # models (numba) load on use: recordings stay light
    recs = [recs] if not isinstance(recs, (list, tuple)) else list(recs)
    maps = {r.sensors for r in recs}
    if len(maps) > 1:
        raise InputError("the runs map their channels to different points or kinds; analyse "
                         "them separately")
    smap = maps.pop()
    if smap is None:
        return model
    if list(smap.response_points) == list(model.points):
        return model
    missing = [p for p in smap.response_points if p not in model.points]
    if missing:
        raise InputError(f"the run measures point '{missing[0]}', which the model does not "
                         f"have (its points: {', '.join(model.points)}); fix the sensor map "
                         "or the model's points")
    idx = [model.points.index(p) for p in smap.response_points]
    elements = []
    for i, el in enumerate(model.elements):
        off = [model.points[j] for j in np.flatnonzero(el.w) if j not in idx]
        if off:
            raise InputError(f"element {i} ({el.kind}) acts on point '{off[0]}', which no "
                             f"channel measures; {purpose} needs its end points measured: add "
                             f"a sensor at '{off[0]}' or move the element")
        elements.append(Element(el.kind, el.w[idx], dict(el.params)))
    return Model(model.mass, model.damping, model.stiffness, elements, model.name,
                 list(smap.response_points), model.shapes[idx], model.n_residual)


def at_points(model: "Model", full: "Model") -> "Model":
    """A `model_at_sensors` result (possibly refitted: same internal coordinates) back over
    ``full``'s points: its linear part and elements, with ``full``'s shapes and point names.
    Returned unchanged when it already has ``full``'s points."""
    from ..models import Element, Model   # models (numba) load on use: recordings stay light
    if list(model.points) == list(full.points) or model.n_q != full.n_q:
        return model
    idx = [full.points.index(p) for p in model.points]
    elements = []
    for el in model.elements:
        w = np.zeros(full.n_dof)
        w[idx] = el.w
        elements.append(Element(el.kind, w, dict(el.params)))
    return Model(model.mass, model.damping, model.stiffness, elements, model.name,
                 list(full.points), full.shapes.copy(), model.n_residual)
