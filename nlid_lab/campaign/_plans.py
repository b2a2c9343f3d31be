"""The excitation kinds a campaign runs: one `LevelPlan` class per kind, registered by its
``kind`` in `PLANS`.

A plan class is the kind's one place in the campaign: it reads its table of the campaign file
(`LevelPlan.from_table`), is the plan record (levels, block size and the kind's settings), says
what a level stores (`unit`, `per_level`, `blocks_per_level`, `stored_bytes`, `layout`) and
what the watchers are told, and runs its levels (`run`, on the campaign's runner). The shaker
plays its `drivers.outputs` records; the run stores its levels as recordings of `excitation`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

from analysis.documents import JsonObject, TomlTable
from analysis.recordings import Excitation, PeriodicLayout
from drivers import Channel

from ._campaign_fields import CampaignError


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

    def start_info(self) -> dict[str, Any]:
        """The kind's fields of `CampaignStart` (averages, period, steps, harmonics)."""
        return {"averages": None}

    def held(self, channels: list[Channel]) -> tuple[str, str]:
        """What a level holds and its unit, for the level summary."""
        return ("force", "N")

    @abstractmethod
    def run(self, runner: Any) -> None:
        """Measure every level not stored yet.

        ``runner`` is the campaign's runner (`_campaign._Runner`); a level loop uses its
        ``_level_start`` / ``_level_end`` (the level's writer and summary), ``_start`` /
        ``_stop`` (an output record on the shaker, the DAQ streaming), ``control`` (the
        level control on a measure of a block), ``take`` and ``split`` (contiguous samples,
        force and response columns), ``_stored`` and ``observer`` (what the watchers are
        told), as `RandomSpec`, `SteppedSpec` and `SweepSpec` (``_campaign_sweep``) do.
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
