"""Typed fields read out of a campaign file's tables: each problem a `CampaignError` (an
`InputError`: the CLI exits 2) naming the table, the key and what it must be."""

from __future__ import annotations

import dataclasses
import math
from enum import StrEnum
from typing import Any

from analysis.errors import InputError
from analysis.models import unknown_keys


class CampaignError(InputError):
    """A campaign file is invalid."""


#: the ``direction`` of a stepped-sine or swept-sine plan
DIRECTIONS = ("up", "down", "up-down")


def _table(data: dict, key: str, where: str = "", required: bool = True) -> dict:
    value = data.get(key)
    name = f"{where}{key}"
    if value is None:
        if required:
            raise CampaignError(f"missing [{name}] table; see docs/campaign-format.md")
        return {}
    if not isinstance(value, dict):
        raise CampaignError(f"'{name}' must be a table ([{name}])")
    return value


def _unknown(table: dict, allowed: set[str], name: str) -> None:
    message = unknown_keys(table, sorted(allowed), f"[{name}]")
    if message:
        raise CampaignError(message)


def _num(table: dict, key: str, name: str, *, default: Any = ..., lo: float = -math.inf,
         hi: float = math.inf, integer: bool = False, open_lo: bool = False) -> Any:
    if key not in table:
        if default is ...:
            raise CampaignError(f"[{name}] needs '{key}'")
        return default
    v = table[key]
    ok_type = isinstance(v, int) if integer else isinstance(v, (int, float))
    if isinstance(v, bool) or not ok_type or not math.isfinite(v) \
            or v < lo or v > hi or (open_lo and v == lo):
        kind = "an integer" if integer else "a number"
        bound = f"> {lo:g}" if open_lo else f">= {lo:g}"
        raise CampaignError(f"[{name}] {key} must be {kind} {bound}"
                            f"{'' if hi == math.inf else f' and <= {hi:g}'}, got {v!r}")
    return int(v) if integer else float(v)


def _opt(table: dict, key: str, name: str, spec: type, attribute: str | None = None,
         **bounds: Any) -> Any:
    """`_num` of an optional key whose default is the field ``attribute`` (default ``key``)
    of the dataclass ``spec``: each default is written once, on its field."""
    attribute = attribute or key
    default = next(f.default for f in dataclasses.fields(spec) if f.name == attribute)
    return _num(table, key, name, default=default, **bounds)


def _levels(table: dict, name: str) -> list[float]:
    levels = table.get("levels")
    if not isinstance(levels, list) or not levels or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
            and x > 0 for x in levels):
        raise CampaignError(f"[{name}] levels must be a non-empty list of force levels > 0 N, "
                            f"got {levels!r}")
    return [float(x) for x in levels]


def _choice(value: Any, vocabulary: type[StrEnum], what: str) -> Any:
    """``value`` as a member of ``vocabulary``; `CampaignError` listing the members."""
    try:
        return vocabulary(value)
    except ValueError:
        raise CampaignError(f"{what} must be one of {', '.join(vocabulary)}, got "
                            f"{value!r}") from None
