"""The excitation kinds a campaign runs: one `LevelPlan` class per kind, registered by its
``kind`` in `PLANS`.

A plan class is the kind's one place in the campaign: it reads its table of the campaign file
(`LevelPlan.from_table`), is the plan record (levels, block size and the kind's settings), says
what a level stores (`unit`, `per_level`, `blocks_per_level`, `stored_bytes`, `layout`) and
what the watchers are told (`start_info`), and runs its levels (`run`: the kind's level loop,
on the primitives the campaign's runner offers, `Runner`). The shaker plays its
`drivers.outputs` records; the run stores its levels as recordings of `excitation` and the
plan's count of segments (`per_level` per level) beside them. The built-in kinds are the
modules of ``_kinds``, one per kind.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Callable, ClassVar, Protocol, Sequence

import numpy as np

from analysis.documents import JsonObject, TomlTable
from analysis.recordings import Excitation, PeriodicLayout
from drivers import Channel
from drivers.outputs import Output

from ..plugins import discover as discover_kinds
from ._campaign_fields import CampaignError
from ._observer import PlanInfo

if TYPE_CHECKING:
    from ..store import LevelWriter
    from ._campaign_bench import Bench
    from ._campaign_config import Campaign
    from ._observer import Watchers


class Runner(Protocol):
    """What a kind's level loop (`LevelPlan.run`) uses of the campaign's runner.

    Attributes
    ----------
    c : Campaign
        The campaign (``fs``, ``max_drive``, ``channels``, ``limits``, ``plant``).
    bench : Bench
        The open devices (``bench.shaker.set_level`` / ``set_frequency`` between blocks).
    gain : float
        Force per drive volt, as last measured (the level control updates it).
    force_col, resp_cols : int, list of int
        DAQ columns of the force and of the responses (by DOF).
    observer : Watchers
        The watchers, told of each stored block (``block``) or step (``step``).
    warnings : list of str
        What the campaign result and the run's log say at the end.
    """

    c: "Campaign"
    bench: "Bench"
    gain: float
    force_col: int
    resp_cols: list[int]
    observer: "Watchers"
    warnings: list[str]

    def level_start(self, index: int, target: float, planned: int) -> "LevelWriter":
        """Open level ``index`` (its writer) and tell the watchers it starts."""

    def level_end(self, lw: "LevelWriter", target: float, planned: int) -> None:
        """Mark the level complete and tell its summary."""

    def start(self, output: Output, drive: float) -> None:
        """Configure the shaker with ``output`` at ``drive`` V, start the DAQ and the shaker."""

    def stop(self) -> None:
        """Stop the shaker and the DAQ."""

    def take(self, n: int) -> tuple[np.ndarray, float]:
        """``n`` contiguous, safety-checked samples and the first one's time."""

    def split(self, data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The force and response columns of ``data``."""

    def control(self, target: float, drive: float, measure: Callable[[np.ndarray], float],
                what: str, block_size: int, settle_blocks: int, tolerance: float,
                max_iterations: int, where: str = "") -> tuple[float, np.ndarray | None, float]:
        """The level control on ``measure`` of a block: the drive, the last block measured
        at it (None if the drive changed after it) and its time."""

    def new_drive(self, drive: float, wanted: float) -> float:
        """``wanted``, limited to a factor of 4 from ``drive`` and to ``max_drive``."""

    def stored(self, lw: "LevelWriter", target: float, planned: int, measured: float,
               drive: float) -> None:
        """Tell the watchers where the level stands after a stored segment."""


class LevelPlan(ABC):
    """What a campaign of one excitation kind does per level (a dataclass subclass per kind,
    its fields in the order of its table's keys: they are the run's stored settings).

    Attributes
    ----------
    levels : list of float
        Force level of each level (rms or amplitude: `measure`), N.
    block_size : int
        Samples per DAQ block the level control and the records use.
    """

    levels: list[float]
    block_size: int

    #: the campaign file's ``kind`` (the registry key)
    kind: ClassVar[str]
    #: the table of the campaign file holding the plan
    table: ClassVar[str]
    #: what the run's levels are recorded as (`Recording.excitation`)
    excitation: ClassVar[Excitation]
    #: what a level's target is: the force ``"rms"`` or ``"amplitude"``
    measure: ClassVar[str] = "rms"

    @classmethod
    @abstractmethod
    def from_table(cls, data: TomlTable, fs: float) -> "LevelPlan":
        """The plan of a campaign file (``data``: the whole file, ``fs``: the DAQ's rate).

        Raises
        ------
        CampaignError
            A key of the table is missing or out of range (the message names it).
        """

    @property
    def title(self) -> str:
        """What ``campaign check`` calls the plan (its kind)."""
        return str(self.kind)

    @property
    def unit(self) -> str:
        """What one stored segment of a level is called (``block``, ``step``...)."""
        return "block"

    @property
    @abstractmethod
    def per_level(self) -> int:
        """Segments a complete level stores."""

    @property
    def skip(self) -> int:
        """Samples of a stored block before its steady part."""
        return 0

    @property
    def block_len(self) -> int:
        """Samples of one stored block (what the live view shows as one)."""
        return self.block_size

    @abstractmethod
    def blocks_per_level(self, fs: float) -> tuple[int, int]:
        """DAQ blocks of ``block_size`` one level takes: at least (level control right at
        once) and at most (every control and settling allowance used)."""

    def stored_bytes(self, n_channels: int, fs: float) -> int:
        """Bytes one level leaves in the run file (float64 samples of every channel)."""
        return self.per_level * self.block_len * n_channels * 8

    def layout(self) -> PeriodicLayout | None:
        """The periodic layout of a stored block, None when not periodic."""
        return None

    def check(self, channels: list[Channel]) -> None:
        """Check the plan against the campaign's channels (`CampaignError`)."""

    def settings(self, channels: list[Channel]) -> JsonObject:
        """The plan as the run's ``excitation_settings`` store it (after ``kind``)."""
        return dict(self.__dict__)

    def start_info(self) -> PlanInfo:
        """The kind's fields of `CampaignStart` (averages, period, steps, harmonics)."""
        return PlanInfo()

    def held(self, channels: list[Channel]) -> tuple[str, str]:
        """What a level holds and its unit, for the level summary."""
        return ("force", "N")

    @abstractmethod
    def run(self, runner: Runner) -> None:
        """Measure every level not stored yet: the kind's level loop.

        A loop uses the runner's primitives (`Runner`): ``level_start`` / ``level_end`` (the
        level's writer and summary), ``start`` / ``stop`` (an output record on the shaker,
        the DAQ streaming), ``control`` (the level control on a measure of a block),
        ``take`` and ``split`` (contiguous samples, force and response columns), ``stored``
        and ``observer`` (what the watchers are told), as the kinds of ``_kinds`` do. A
        resumed run holds some levels complete already: the loop skips what is stored.
        """


#: The kinds campaigns run, by ``kind``.
PLANS: dict[str, type[LevelPlan]] = {}


def register_plan(plan: type[LevelPlan]) -> type[LevelPlan]:
    """Register ``plan`` under its ``kind`` (a class decorator; a kind taken is refused).

    Raises
    ------
    ValueError
    """
    if plan.kind in PLANS and PLANS[plan.kind] is not plan:
        raise ValueError(f"campaign kind '{plan.kind}' is registered already")
    PLANS[plan.kind] = plan
    return plan


def unregister_plan(plan: type[LevelPlan]) -> None:
    """Remove ``plan`` from `PLANS` (a kind `register_plan` added)."""
    del PLANS[plan.kind]


def plan_of(data: TomlTable) -> type[LevelPlan]:
    """The plan class of a campaign file's ``kind``.

    Raises
    ------
    CampaignError
        ``kind`` is not a kind campaigns run (the message lists those they do).
    """
    kind = data.get("kind")
    if isinstance(kind, str) and kind in PLANS:
        return PLANS[kind]
    if kind in list(Excitation):     # a kind recordings know that campaigns do not run
        raise CampaignError(f"campaigns run {_listed(' and ')} excitations, not {kind}")
    raise CampaignError(f"kind must be one of {', '.join(PLANS)}, got {kind!r}")


def _listed(last: str) -> str:
    kinds = list(PLANS)
    return ", ".join(kinds[:-1]) + last + kinds[-1] if len(kinds) > 1 else kinds[0]
