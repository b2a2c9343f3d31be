"""The schema of a recording file's keys: what an NPZ file, a CSV file's ``# key = value``
lines and a mapped MAT import hold, by name (contracts sections 3, 5 and 6,
docs/recording-formats.md).

A reader gets the keys as the file gives them (arrays from NPZ and MAT, numbers and text from
CSV), checks each one and builds a `Recording` or `StepTable`; keys this schema does not name
are kept in ``extra`` and written back (a `TypedDict` does not forbid them at run time).
"""

from __future__ import annotations

from typing import TypedDict

from numpy.typing import ArrayLike


class RecordingKeys(TypedDict, total=False):
    """The keys of one recording file, every one optional (the readers say which they need).

    Samples (contracts section 3): ``fs``, ``excitation``, ``force_dofs``, ``force``,
    ``response``, ``response_kind``, ``freqs``, a level (``force_rms`` / ``force_amplitude``
    / ``level``), ``force_hold``; periodic layout (``period``, ``transient_periods``,
    ``periods``, ``realizations``); sweep law (``sweep_*``); sensor map (``response_points``,
    ``response_kinds``, ``force_points``); monitors (``monitor``, ``monitor_names``,
    ``monitor_units``). Tables (section 6): ``force_phasor``, ``response_phasor``,
    ``control``, ``control_dof``, ``harmonics``, ``force_harmonics``, ``response_harmonics``.
    """

    fs: ArrayLike
    excitation: ArrayLike
    force_dofs: ArrayLike
    force: ArrayLike
    response: ArrayLike
    response_kind: ArrayLike
    freqs: ArrayLike
    force_rms: ArrayLike
    force_amplitude: ArrayLike
    level: ArrayLike
    force_hold: ArrayLike
    period: ArrayLike
    transient_periods: ArrayLike
    periods: ArrayLike
    realizations: ArrayLike
    sweep_start_hz: ArrayLike
    sweep_stop_hz: ArrayLike
    sweep_law: ArrayLike
    sweep_rate: ArrayLike
    sweep_estimated: ArrayLike
    sweep_trimmed_lead: ArrayLike
    sweep_trimmed_tail: ArrayLike
    response_points: ArrayLike
    response_kinds: ArrayLike
    force_points: ArrayLike
    monitor: ArrayLike
    monitor_names: ArrayLike
    monitor_units: ArrayLike
    force_phasor: ArrayLike
    response_phasor: ArrayLike
    control: ArrayLike
    control_dof: ArrayLike
    harmonics: ArrayLike
    force_harmonics: ArrayLike
    response_harmonics: ArrayLike
