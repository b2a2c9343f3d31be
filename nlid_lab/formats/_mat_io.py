"""MATLAB recordings (``.mat``) as acquisition systems export them, through a channel map.

A commercial export is a struct (or plain variables) of channel arrays and a sample rate,
e.g. ``data.Force`` (n x 1), ``data.Voltage``, ``data.Acceleration`` (n x 3), ``data.Fs``. The
file is read into a flat tree of dotted names (`read_mat_tree`: v5/v6/v7 by `scipy.io`, v7.3 —
HDF5 — by the store); a `ChannelMap` says which leaves are the force, the responses and the
sample rate, with their units::

    fs=Fs  force=Force  response=Acceleration[0:3]:g

(``NAME[cols]`` selects columns — ``[0:3]``, ``[0,2]`` — of a 2-D array, channel-major arrays
are transposed automatically; ``:UNIT`` scales to SI and names the response kind of those
columns; ``@A,B,C`` names the model point of each selected column: the sensor map.) Channels
that are neither force nor response (the amplifier's ``Voltage``) are kept as monitor channels
(`nlid_lab.formats._monitors`): those ``monitor=NAME[cols]:UNIT`` names, else every channel
array of the record's length the map does not use; ``monitor=none`` keeps none. The same
keys can come from a small TOML file (docs/recording-formats.md).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from analysis.documents import MatTree, TomlTable
from analysis.errors import InputError
from analysis.models import parse_toml, read_text
from analysis.recordings import RecordingKeys

from ._units import kind_of_name, lookup

MAT73_SIGNATURE = b"MATLAB 7.3 MAT-file"
#: channel-map keys that select channels (repeatable)
ROLES = ("force", "response", "monitor")
MAX_MAP_BYTES = 1 << 16
_COMMA = re.compile(r",(?![^\[]*\])")  # commas between names, not inside NAME[0,2]
_SELECT = re.compile(r"^(?P<key>[A-Za-z_][\w.]*)(?:\[(?P<cols>[^\]]*)\])?(?::(?P<unit>.+))?$")


class MatFileError(InputError):
    """A MAT file or its channel map does not give what an import needs."""


@dataclass(frozen=True)
class Selection:
    """Columns of one named array, with the unit they are in."""

    key: str
    cols: tuple[int, ...] | slice | None = None
    unit: str | None = None
    #: model points of the selected columns (``NAME[0:3]@wing,joint,payload``), one each
    points: tuple[str, ...] | None = None

    @classmethod
    def parse(cls, text: str, role: str) -> "Selection":
        text, at, where = text.strip().partition("@")
        points = tuple(p.strip() for p in where.split(",")) if at else None
        if points is not None and not all(points):
            raise MatFileError(f"channel map {role}={text}@{where}: name a point per column "
                               "after '@', comma-separated (NAME[0:3]@a,b,c)")
        m = _SELECT.match(text)
        if not m:
            raise MatFileError(f"channel map {role}={text!r}: write NAME, NAME[0:3], NAME[0,2] "
                               "or NAME[0]:UNIT, optionally @POINT,... (the model points)")
        cols = m["cols"]
        if cols is None:
            sel = None
        elif ":" in cols:
            parts = cols.split(":")
            try:
                sel = slice(*(int(p) if p.strip() else None for p in parts))
            except (TypeError, ValueError):
                raise MatFileError(f"channel map {role}={text!r}: bad column range "
                                   f"[{cols}]") from None
        else:
            try:
                sel = tuple(int(c) for c in cols.split(","))
            except ValueError:
                raise MatFileError(f"channel map {role}={text!r}: columns must be integers "
                                   f"(0-based), got [{cols}]") from None
        return cls(m["key"], sel, m["unit"], points)


@dataclass(frozen=True)
class ChannelMap:
    """Where the force, responses and sample rate of a recording are in a MAT tree (the
    ``--map`` words or the map file, parsed)."""

    force: list[Selection]
    response: list[Selection]
    fs: str | float = "Fs"
    response_kind: str | None = None
    #: other recording keys (force_dofs, level, period, ...): literal values, or names of
    #: variables in the file
    extra: dict[str, Any] = field(default_factory=dict)
    #: monitor channels named by the map; None: every channel array the map does not use
    monitor: list[Selection] | None = None
    #: units by variable name (a CSV header's), for monitors the map does not name
    units: dict[str, str] = field(default_factory=dict)

    @classmethod
    def from_items(cls, items: list[str]) -> "ChannelMap":
        """From ``KEY=VALUE`` words (``--map force=Force response=Acc[0:3]:g fs=Fs``)."""
        data: TomlTable = {}
        for key, value in map_items(items, "channel map", "force=Force", MatFileError):
            data.setdefault(key, []).append(map_value(value))
        return cls.from_dict({k: v if k in ROLES else v[-1] for k, v in data.items()}, "--map")

    def with_units(self, units: dict[str, str]) -> "ChannelMap":
        """This map with ``units`` (name -> unit, e.g. from a CSV header) on the selections
        that give none."""
        def fill(sels: list[Selection]) -> list[Selection]:
            return [Selection(s.key, s.cols, s.unit or units.get(s.key), s.points)
                    for s in sels]
        return ChannelMap(fill(self.force), fill(self.response), self.fs, self.response_kind,
                          self.extra, None if self.monitor is None else fill(self.monitor),
                          {**self.units, **units})

    @classmethod
    def from_toml(cls, path: str | os.PathLike) -> "ChannelMap":
        path = Path(path)
        if not path.is_file() or path.stat().st_size > MAX_MAP_BYTES:
            raise MatFileError(f"channel map {path}: not a (small) regular file")
        text = read_text(path, "channel map", MatFileError, max_bytes=MAX_MAP_BYTES)
        data = parse_toml(text, f"channel map {path}", MatFileError)
        return cls.from_dict(data, str(path))

    @classmethod
    def from_dict(cls, data: TomlTable, source: str) -> "ChannelMap":
        known = {"fs", "response_kind", *ROLES}
        for role in ("force", "response"):
            if role not in data:
                raise MatFileError(f"{source}: the channel map needs '{role}' (e.g. "
                                   f"{role}=Force)")
        extra = {k: v for k, v in data.items() if k not in known}
        given = {role: [str(v) for v in np.atleast_1d(data[role])]
                 for role in ROLES if role in data}
        if given.get("monitor") == ["none"]:
            given["monitor"] = []
        elif "none" in given.get("monitor", []):
            raise MatFileError(f"{source}: monitor=none keeps no monitor channel; drop it or "
                               "the other monitor= items")
        sels = {role: [s for v in values for s in _selections(v, role)]
                for role, values in given.items()}
        for sel in sels.get("monitor", []):
            if sel.points is not None:
                raise MatFileError(f"{source}: monitor={sel.key}@...: a monitor channel has "
                                   "no model point; drop the '@' part")
        fs = data.get("fs", "Fs")
        try:
            fs = float(fs)
        except (TypeError, ValueError):
            fs = str(fs)
        return cls(sels["force"], sels["response"], fs, data.get("response_kind"), extra,
                   sels.get("monitor"))


def _selections(text: str, role: str) -> list[Selection]:
    """``A,B,C:g`` -> three selections, the closing unit applying to all three
    (``A,B,C:g@p,q,r``: one point each)."""
    names, at, where = text.partition("@")
    parts = _COMMA.split(names)
    if len(parts) == 1:
        return [Selection.parse(text, role)]
    points = [p.strip() for p in where.split(",")] if at else [None] * len(parts)
    if len(points) != len(parts):
        raise MatFileError(f"channel map {role}={text}: {len(parts)} names but {len(points)} "
                           "point(s) after '@'; give one point per name")
    sels = [Selection.parse(part if point is None else f"{part}@{point}", role)
            for part, point in zip(parts, points)]
    unit = sels[-1].unit
    if unit and all(s.unit is None for s in sels[:-1]):
        sels = [Selection(s.key, s.cols, unit, s.points) for s in sels]
    return sels


def map_items(items: list[str], what: str, example: str, error: type[InputError]
              ) -> list[tuple[str, str]]:
    """The ``KEY=VALUE`` words of a map given on the command line (``--map ...``) as
    (key, value) pairs, stripped; a word without ``=`` or value raises ``error``."""
    pairs = []
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not value.strip():
            raise error(f"{what} item {item!r}: write KEY=VALUE, e.g. {example}")
        pairs.append((key.strip(), value.strip()))
    return pairs


def map_value(text: str) -> Any:
    """A map value as TOML reads it (``0``, ``2.5``, ``[0, 1]``), else the text itself."""
    try:
        return parse_toml(f"v = {text}", "map value")["v"]
    except InputError:
        return text


def is_mat73(path: Path) -> bool:
    with open(path, "rb") as fh:
        return fh.read(128).startswith(MAT73_SIGNATURE)


def read_mat_tree(path: str | os.PathLike) -> MatTree:
    """Every leaf of a MAT file by dotted name (struct fields joined with ``.``)."""
    path = Path(path)
    if not path.is_file():
        raise MatFileError(f"MAT file {path} not found; check the path")
    if is_mat73(path):
        from ..store import read_mat73   # loads on use (h5py): every command imports formats
        return read_mat73(path)
    import scipy.io   # loads on use: every command line imports this room
    from scipy.io.matlab import MatReadError

    try:
        raw = scipy.io.loadmat(path, simplify_cells=True)
    # a cut or damaged file makes scipy's reader fail in many ways (IndexError, EOFError,
    # struct and zlib errors...): whatever it raises, the file is not readable
    except (MatReadError, Exception) as exc:  # noqa: BLE001
        raise MatFileError(f"{path} is not a readable MAT file ({exc}); save it with MATLAB's "
                           "save or scipy.io.savemat") from None
    out: MatTree = {}
    _flatten("", {k: v for k, v in raw.items() if not k.startswith("__")}, out)
    return out


def _flatten(prefix: str, value: Any, out: MatTree) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else k, v, out)
    else:
        out[prefix] = value


def _leaf(tree: MatTree, key: str, source: str) -> Any:
    """A leaf by full dotted name, or by its last part(s) when that is unique."""
    return tree[_full_name(tree, key, source)]


def _full_name(tree: MatTree, key: str, source: str) -> str:
    """The full dotted name of the leaf ``key`` names (`_leaf`)."""
    if key in tree:
        return key
    hits = [k for k in tree if k.endswith("." + key)]
    if len(hits) == 1:
        return hits[0]
    names = ", ".join(sorted(tree)) or "none"
    if hits:
        raise MatFileError(f"{source}: '{key}' is ambiguous ({', '.join(hits)}); give the full "
                           "dotted name")
    raise MatFileError(f"{source}: no variable '{key}' (the file holds {names})")


def _columns(tree: MatTree, sel: Selection, n: int | None, source: str) -> np.ndarray:
    value = _leaf(tree, sel.key, source)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise MatFileError(f"{source}: '{sel.key}' is not numeric") from None
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise MatFileError(f"{source}: '{sel.key}' has shape {arr.shape}; a channel array is "
                           "1-D or 2-D")
    if n is not None and arr.shape[0] != n and arr.shape[1] == n:
        arr = arr.T                                          # channel-major export
    elif n is None and arr.shape[0] < arr.shape[1]:
        arr = arr.T                                          # channel-major (fewer rows)
    try:
        arr = arr[:, sel.cols] if isinstance(sel.cols, slice) else \
            arr[:, list(sel.cols)] if sel.cols is not None else arr
    except IndexError:
        raise MatFileError(f"{source}: '{sel.key}' has {arr.shape[1]} column(s); the map asks "
                           f"for {sel.cols}") from None
    if arr.shape[1] == 0:
        raise MatFileError(f"{source}: '{sel.key}{sel.cols}' selects no column")
    return arr


def apply_map(tree: MatTree, cmap: ChannelMap, source: str) -> RecordingKeys:
    """Force, response, fs and response kind (SI) from a MAT tree.

    Returns
    -------
    RecordingKeys
        ``fs``, ``force`` (n, n_in) in N, ``response`` (n, n_out) in SI, ``response_kind``,
        and the map's other keys (values read from the file where they name a variable).
    """
    force = [_columns(tree, s, None, source) for s in cmap.force]
    n = force[0].shape[0]
    force = [_columns(tree, s, n, source) for s in cmap.force]
    response = [_columns(tree, s, n, source) for s in cmap.response]
    for sel, arr in zip(cmap.force + cmap.response, force + response):
        if arr.shape[0] != n:
            raise MatFileError(f"{source}: '{sel.key}' has {arr.shape[0]} samples, the force "
                               f"{n}; channels of one recording have one length")
    kinds: list[str | None] = []       # per response channel
    for sel, arr in zip(cmap.force, force):
        if sel.unit:
            factor, quantity = lookup(sel.unit, f"{source}: force {sel.key}")
            if quantity != "force":
                raise MatFileError(f"{source}: force {sel.key} is in {sel.unit}, a "
                                   f"{quantity} unit")
            arr *= factor
    for sel, arr in zip(cmap.response, response):
        if sel.unit:
            factor, quantity = lookup(sel.unit, f"{source}: response {sel.key}")
            if quantity == "force":
                raise MatFileError(f"{source}: response {sel.key} is in {sel.unit}, a force "
                                   "unit; map it as force=")
            arr *= factor
        kinds += [quantity if sel.unit else cmap.response_kind or kind_of_name(sel.key)
                  ] * arr.shape[1]
    if cmap.response_kind and {k for k in kinds if k} - {cmap.response_kind}:
        raise MatFileError(f"{source}: response_kind = {cmap.response_kind} but the units say "
                           f"{', '.join(sorted({k for k in kinds if k}))}; drop one of them")
    known = {k for k in kinds if k}
    if len(known) > 1 and None in kinds:
        raise MatFileError(f"{source}: responses of different kinds; give every response "
                           "selection a unit (NAME[0]:m/s^2) so each channel's kind is known")
    kinds = [k or (next(iter(known)) if known else None) for k in kinds]
    points = _points(cmap.force, force, "force", source) | _points(cmap.response, response,
                                                                   "response", source)
    if isinstance(cmap.fs, float):
        fs = cmap.fs
    elif not _known(tree, cmap.fs):
        raise MatFileError(f"{source}: no sample rate variable '{cmap.fs}' (the file holds "
                           f"{', '.join(sorted(tree)) or 'none'}); give the rate in the map: "
                           "fs=RATE (Hz)")
    else:
        try:
            fs = float(np.asarray(_leaf(tree, cmap.fs, source), dtype=float).reshape(()))
        except (TypeError, ValueError):
            raise MatFileError(f"{source}: the sample rate '{cmap.fs}' is not one number") \
                from None
    extra, used = {}, {_full_name(tree, s.key, source) for s in cmap.force + cmap.response}
    for key, value in cmap.extra.items():
        if isinstance(value, str) and value not in ("none", "linear") and _known(tree, value):
            used.add(_full_name(tree, value, source))
            value = _leaf(tree, value, source)
        extra[key] = value
    if isinstance(cmap.fs, str):
        used.add(_full_name(tree, cmap.fs, source))
    extra.update(monitor_keys_of(tree, cmap, n, used, source))
    if len(set(kinds)) > 1:
        points["response_kinds"] = np.array(kinds)
    kind = kinds[0] if len(set(kinds)) == 1 and kinds[0] else "displacement"
    return {"fs": fs, "force": np.hstack(force), "response": np.hstack(response),
            **({"response_kind": kind} if "response_kinds" not in points else {}),
            **points, **extra}


def _points(sels: list[Selection], arrays: list[np.ndarray], role: str,
            source: str) -> dict[str, np.ndarray]:
    """``force_points``/``response_points`` from the selections' ``@`` names (all or none)."""
    if all(s.points is None for s in sels):
        return {}
    out = []
    for sel, arr in zip(sels, arrays):
        if sel.points is None or len(sel.points) != arr.shape[1]:
            have = 0 if sel.points is None else len(sel.points)
            raise MatFileError(f"{source}: {role} {sel.key} selects {arr.shape[1]} column(s) "
                               f"but names {have} point(s); give one point per column after "
                               "'@' (on every selection or none)")
        out += sel.points
    return {f"{role}_points": np.array(out)}


def _known(tree: MatTree, key: str) -> bool:
    return key in tree or sum(k.endswith("." + key) for k in tree) == 1


def monitor_keys_of(tree: MatTree, cmap: ChannelMap, n: int, used: set[str],
                    source: str) -> dict[str, np.ndarray]:
    """The ``monitor``, ``monitor_names``, ``monitor_units`` keys (`nlid_lab.formats._monitors`)
    of a mapped file: the map's ``monitor=`` selections, else every numeric 1-D or 2-D
    variable with ``n`` samples along one axis that the map does not use (all its columns);
    none when there are none. Units are kept as the map or header gives them, unconverted."""
    if cmap.monitor is None:
        sels = [Selection(k, None, cmap.units.get(k)) for k, v in tree.items()
                if k not in used and _is_channel(v, n)]
    else:
        sels = cmap.monitor
    full = [_full_name(tree, s.key, source) for s in sels]
    short = [k.rpartition(".")[2] for k in full]
    base = [s if short.count(s) == 1 else k for s, k in zip(short, full)]
    cols, labels, units = [], [], []
    for sel, name in zip(sels, base):
        arr = _columns(tree, Selection(sel.key), n, source)
        if arr.shape[0] != n:
            raise MatFileError(f"{source}: monitor '{sel.key}' has {arr.shape[0]} samples, "
                               f"the force {n}; channels of one recording have one length")
        picked = np.arange(arr.shape[1])
        picked = picked[sel.cols] if isinstance(sel.cols, slice) else \
            picked[list(sel.cols)] if sel.cols is not None else picked
        whole = arr.shape[1] == 1 and sel.cols is None
        cols.append(_columns(tree, sel, n, source))
        labels += [name] if whole else [f"{name}[{j}]" for j in picked]
        units += [sel.unit or ""] * len(picked)
    if not cols:
        return {}
    if len(set(labels)) != len(labels):
        raise MatFileError(f"{source}: monitor channels {labels} repeat a name; select each "
                           "column once")
    return {"monitor": np.hstack(cols), "monitor_names": np.array(labels),
            "monitor_units": np.array(units)}


def _is_channel(value: Any, n: int) -> bool:
    """True for a numeric 1-D or 2-D array with ``n`` samples along one axis."""
    arr = np.asarray(value)
    return (arr.dtype.kind in "iuf" and arr.ndim in (1, 2) and n in arr.shape
            and arr.size >= n > 1)
