"""What a reader leaves out of a run and why: blocks failing their checksum, blocks whose
samples never reached the disk, blocks naming a level the run does not list; and how much of
its plan a run holds (`RunCheck`, what commands say in their summary and JSON)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from analysis.documents import JsonObject


class LeftOutReason(StrEnum):
    """Why a stored block is not used."""

    CHECKSUM = "failed its checksum"
    NOT_ON_DISK = "its samples are not on disk"
    TEXT_DAMAGED = "its stored text (step record or sweep keys) is damaged"


@dataclass(frozen=True)
class LeftOut:
    """One block (random, swept) or step (stepped sine) a reader did not use."""

    level: int
    seq: int
    reason: LeftOutReason

    def to_json(self) -> dict[str, Any]:
        """The JSON form (an entry of `RunCheck.to_json`'s ``left_out``)."""
        return {"level": self.level, "seq": self.seq, "reason": str(self.reason)}


def left_out_text(left_out: list[LeftOut] | tuple[LeftOut, ...]) -> str:
    """``left_out`` for people: ``level 0 block 3 (failed its checksum), ...``."""
    return ", ".join(f"level {b.level} block {b.seq} ({b.reason})" for b in left_out)


@dataclass(frozen=True)
class RunCheck:
    """What a run holds against its plan, and the blocks readers leave out of it.

    ``incomplete`` is empty for a complete run, else the words readers print after "run is"
    ("incomplete: 3 of 8 blocks; ..."). ``left_out`` lists every block a reader skips;
    ``notes`` other facts readers say (a block naming a level the run does not list).
    """

    path: str
    status: str
    stored: int
    planned: int | None
    incomplete: str
    left_out: tuple[LeftOut, ...]
    notes: tuple[str, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """The JSON form commands add to their result (``"runs"`` entries)."""
        return {"path": self.path, "status": self.status, "blocks_stored": self.stored,
                "blocks_planned": self.planned, "incomplete": self.incomplete,
                "left_out": [b.to_json() for b in self.left_out], "notes": list(self.notes)}

    def lines(self) -> list[str]:
        """One line per fact for people (empty when the run is whole and complete)."""
        out = [f"note: {self.path}: run is {self.incomplete}"] if self.incomplete else []
        if self.left_out:
            out.append(f"warning: {self.path}: {len(self.left_out)} block(s) left out: "
                       f"{left_out_text(self.left_out)}")
        return out + [f"note: {self.path}: {n}" for n in self.notes]


@dataclass(frozen=True)
class Repaired:
    """What `repair_run` did: true when the file was rebuilt."""

    rebuilt: bool
    kept: int
    dropped: tuple[LeftOut, ...] = ()
    log_dropped: int = 0
    attrs_reset: tuple[str, ...] = ()

    def __bool__(self) -> bool:
        return self.rebuilt

    def text(self) -> str:
        """What the rebuild dropped or reset, for people (``""``: nothing)."""
        parts = [f"{len(self.dropped)} damaged block(s) dropped: "
                 f"{left_out_text(self.dropped)}"] if self.dropped else []
        parts += [f"{self.log_dropped} damaged log entr{'y' if self.log_dropped == 1 else 'ies'}"
                  " dropped"] if self.log_dropped else []
        parts += [f"damaged attribute(s) {', '.join(self.attrs_reset)} reset"] \
            if self.attrs_reset else []
        return "; ".join(parts)


def planned_blocks(stored: int | None, excitation_settings: JsonObject) -> int | None:
    """Blocks, steps or sweeps a campaign's plan stores: the run's ``planned_blocks``
    attribute (``stored``, written by the campaign from its plan); for runs written before
    it, counted from the plan in ``excitation_settings`` (`_planned_before_attribute`); None
    when the run does not say (imported runs)."""
    if stored is not None:
        return int(stored)
    return _planned_before_attribute(excitation_settings)


def _planned_before_attribute(settings: JsonObject) -> int | None:
    """The planned count of a campaign run written before ``planned_blocks``, from its
    plan's settings: the ``levels`` times the segments a level stores, the plan's
    ``averages`` (random, periodic random), one sweep (a ``laws`` entry per level) or one
    step per ``freqs`` entry (stepped sine). The plans of that time only: a kind added
    since writes ``planned_blocks``."""
    levels = settings.get("levels")
    if not isinstance(levels, list):
        return None
    per_level = settings["averages"] if "averages" in settings else \
        1 if "laws" in settings else len(settings.get("freqs") or []) or None
    return len(levels) * per_level if isinstance(per_level, int) else None


class Damage(ValueError):
    """What is damaged in a run file, and whether `repair_run` mends it."""

    def __init__(self, what: str, repairable: bool) -> None:
        super().__init__(what)
        self.repairable = repairable


def json_text(raw: bytes | np.ndarray, what: str, repairable: bool = True) -> Any:
    """Parse stored JSON text; `Damage` naming ``what`` when it is damaged (not UTF-8, not
    JSON)."""
    try:
        return json.loads(bytes(raw))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise Damage(f"{what} is damaged ({type(exc).__name__}: "
                     f"{' '.join(str(exc).split())[:80]})", repairable) from None
