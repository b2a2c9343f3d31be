"""The recording formats by suffix: one table (`FORMATS`) that ``import``, ``export`` and every
command reading a recording directly (`load_recordings`) look a file up in.

A format is one `RecordingFormat`: its suffixes, how it reads a file as it is (with what
``import`` adds: `ReadOptions`), what a channel map (``--map``) takes from it, how it writes a
recording. A new format is a reader/writer module of this room and its entry here, or an entry
`register_format` adds at run time.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from analysis.errors import InputError
from analysis.recordings import Recording, RecordingKeys, StepTable

from ._csv import csv_time_rate, read_csv, read_csv_columns, write_csv
from ._mat_io import ChannelMap, apply_map, read_mat_tree
from ._mat_recording import is_recording, read_mat_recording, write_mat
from ._npz import load_npz_keys, read_npz, recording_from_keys, write_npz


@dataclass(frozen=True)
class ReadOptions:
    """What ``import`` adds to a file it reads without a channel map.

    Attributes
    ----------
    keys : dict
        Recording keys given on the command line (``--excitation``, ``--sweep``), over the
        file's own.
    force_cols, response_kind, force_dofs
        ``--force-cols``, ``--response-kind``, ``--force-dofs`` (for files that do not say).
    """

    keys: RecordingKeys = field(default_factory=dict)
    force_cols: list[str] | None = None
    response_kind: str | None = None
    force_dofs: list[int] | None = None


Reader = Callable[[Path, ReadOptions], "Recording | StepTable"]
Mapper = Callable[[Path, ChannelMap], RecordingKeys]
Writer = Callable[[Path, "Recording | StepTable"], None]


@dataclass(frozen=True)
class RecordingFormat:
    """One recording file format.

    Attributes
    ----------
    name : str
        What it is called in messages (``"NPZ"``).
    suffixes : tuple of str
        File suffixes, lower case with the dot; the first one names it in messages.
    read : callable, optional
        ``read(path, options)``: the recording a file holds (None: only through a map).
    mapped : callable, optional
        ``mapped(path, channel_map)``: the recording keys a ``--map`` takes from the file's
        variables or columns (None: the format takes no map).
    write : callable, optional
        ``write(path, recording)`` for ``export`` (None: read only).
    direct : bool
        Whether commands other than ``import`` read the file as it is (`load_recordings`).
    """

    name: str
    suffixes: tuple[str, ...]
    read: Reader | None = None
    mapped: Mapper | None = None
    write: Writer | None = None
    direct: bool = False


def _read_npz(path: Path, options: ReadOptions) -> Recording | StepTable:
    if not options.keys:
        return read_npz(path)
    return recording_from_keys({**load_npz_keys(path), **options.keys}, path)


def _read_csv(path: Path, options: ReadOptions) -> Recording:
    return read_csv(path, force_cols=options.force_cols, response_kind=options.response_kind,
                    force_dofs=options.force_dofs, excitation=options.keys.get("excitation"),
                    keys={k: v for k, v in options.keys.items() if k != "excitation"})


def _mapped_csv(path: Path, cmap: ChannelMap) -> RecordingKeys:
    tree, units = read_csv_columns(path)
    cmap = cmap.with_units(units)
    time = next((k for k in tree if k.lower() in ("t", "time")
                 and k not in {s.key for s in cmap.force + cmap.response}), None)
    if time is not None:          # a time column: the rate when none is given, no monitor
        t = tree.pop(time)
        if cmap.fs == "Fs" and not {"Fs", "fs"} & set(tree):
            cmap = dataclasses.replace(cmap, fs=csv_time_rate(t, units.get(time), path))
    if cmap.fs == "Fs" and "Fs" not in tree and "fs" in tree:
        cmap = dataclasses.replace(cmap, fs="fs")    # a '# fs = ...' line
    elif cmap.fs == "Fs" and "Fs" not in tree:
        raise InputError(f"{path}: the CSV gives no sample rate; add fs=RATE (Hz) to --map "
                         "(e.g. --map force=Force response=Acceleration1,Acceleration2 "
                         "fs=400)")
    return apply_map(tree, cmap, str(path))


def _read_mat(path: Path, options: ReadOptions) -> Recording:
    tree = read_mat_tree(path)
    if not is_recording(tree):
        raise InputError(f"{path}: a MAT file needs --map (e.g. --map force=Force "
                         "response=Acceleration[0:3]:g fs=Fs force_dofs=0); the file holds "
                         + ", ".join(sorted(tree)))
    rec = read_mat_recording(path)      # written by nlid-lab export
    if options.keys:
        raise InputError(f"{path}: an nlid-lab recording names its excitation and "
                         "sweep; drop --excitation/--sweep")
    return rec


def _mapped_mat(path: Path, cmap: ChannelMap) -> RecordingKeys:
    return apply_map(read_mat_tree(path), cmap, str(path))


#: The formats, in the order messages list them.
FORMATS: list[RecordingFormat] = [
    RecordingFormat("NPZ", (".npz",), _read_npz, None, write_npz, direct=True),
    RecordingFormat("CSV", (".csv",), _read_csv, _mapped_csv, write_csv, direct=True),
    RecordingFormat("MAT", (".mat",), _read_mat, _mapped_mat, write_mat),
]


def register_format(fmt: RecordingFormat) -> None:
    """Add ``fmt`` to `FORMATS` (a suffix already taken is refused).

    Raises
    ------
    ValueError
    """
    taken = sorted(set(fmt.suffixes) & {s for f in FORMATS for s in f.suffixes})
    if taken:
        raise ValueError(f"suffix {', '.join(taken)} already has a recording format")
    FORMATS.append(fmt)


def unregister_format(fmt: RecordingFormat) -> None:
    """Remove ``fmt`` from `FORMATS` (a format `register_format` added)."""
    FORMATS.remove(fmt)


def format_of(path: str | os.PathLike) -> RecordingFormat | None:
    """The format of ``path`` by its suffix (any case), None if no format has it."""
    suffix = Path(path).suffix.lower()
    return next((f for f in FORMATS if suffix in f.suffixes), None)


def suffix_list(role: str, first: tuple[str, ...] = ()) -> str:
    """The suffixes of the formats in ``role`` (``"read"``, ``"write"``, ``"direct"``) as
    ``.npz, .csv or .mat`` for messages, after ``first``."""
    names = list(first) + [f.suffixes[0] for f in FORMATS if (
        f.direct if role == "direct" else getattr(f, role) is not None)]
    return ", ".join(names[:-1]) + " or " + names[-1] if len(names) > 1 else names[0]
