"""What a running campaign tells its watchers (live view, progress, logs).

The campaign calls these methods from its acquisition thread; an observer must not block and
must not touch GUI widgets directly (the live view queues the data for the GUI thread).
``level_progress`` and ``level_finished`` are optional: a watcher without them is not told.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Protocol

import numpy as np

from analysis.recordings import SensorMap


@dataclass(frozen=True)
class PlanInfo:
    """The kind's fields of `CampaignStart` (`LevelPlan.start_info`): random ``averages``
    (periodic random: its ``period`` and ``transient_periods``), stepped sine ``n_steps``
    and the harmonic orders of a step's rows, swept sine one average (its H1 live)."""

    averages: int | None = None
    period: int | None = None
    transient_periods: int = 1
    n_steps: int | None = None
    harmonics: tuple[int, ...] | None = None


@dataclass(frozen=True)
class CampaignStart:
    """What a campaign tells its watchers as it starts.

    ``unit`` is what a level stores: block, realization (periodic random: ``period``
    samples, ``transient_periods`` dropped), sweep or step; ``planned`` of them per level,
    ``stored`` per level already in the run. ``channels`` are (name, unit), forces first.
    Stepped sine gives ``n_steps`` and the harmonic order of each row of a step's
    harmonics; random ``averages`` blocks of ``block_len`` samples.
    """

    fs: float
    excitation: str
    force_dofs: tuple[int, ...]
    n_dof: int
    response_kind: str = "displacement"
    sensors: SensorMap | None = None
    channels: tuple[tuple[str, str], ...] = ()
    levels: tuple[float, ...] = ()
    block_len: int | None = None
    averages: int | None = None
    planned: int = 0
    unit: str = "block"
    stored: tuple[int, ...] = ()
    period: int | None = None
    transient_periods: int = 1
    n_steps: int | None = None
    harmonics: tuple[int, ...] | None = None


@dataclass(frozen=True)
class LevelStatus:
    """Where a level stands after a stored block/step (or at its start, with nothing
    measured yet in this session)."""

    level: int
    target: float                 # N: force rms (random) or amplitude (stepped sine)
    done: int                     # blocks/steps stored in the run
    planned: int
    measured: float | None        # last block's force rms / last step's amplitude, N
    drive: float | None           # drive of the last block/step, V
    control_error: float | None   # measured / target - 1


@dataclass(frozen=True)
class LevelSummary:
    """One level once it ends, built from the blocks/steps stored in the run.

    ``force`` is the force rms over the stored blocks (steady periods of a periodic-random
    realization) or the mean held amplitude of the stored steps (``held``: the force, or a
    response-controlled level's response, in ``held_unit``); ``control_error`` is
    ``force / target - 1`` (random) or the stored step farthest from the target (stepped);
    ``drive`` the last drive of this session (None: the level was already complete);
    ``seconds`` the time spent on the level in this session.
    """

    level: int
    target: float
    measure: str                  # "rms" | "amplitude"
    unit: str                     # "block" | "realization" | "step"
    done: int
    planned: int
    force: float | None
    control_error: float | None
    drive: float | None
    seconds: float
    held: str = "force"           # what the level held: "force" or "response (channel)"
    held_unit: str = "N"

    def line(self, n_levels: int) -> str:
        """One line for people: level, blocks done/total, force against the target."""
        u = self.held_unit
        text = (f"level {self.level + 1}/{n_levels} ({self.target:g} {u} {self.measure}): "
                f"{self.done}/{self.planned} {self.unit}s")
        if self.force is not None:
            sweep = self.unit == "sweep"
            what = "amplitude" if sweep else "mean amplitude" if self.measure == "amplitude" \
                else "rms"
            err = "worst step " if self.measure == "amplitude" and not sweep else ""
            text += (f", {self.held} {what} {self.force:.4g} {u} (target {self.target:g} {u}, "
                     f"{err}{self.control_error:+.2%})")
        if self.drive is not None:
            text += f", drive {self.drive:.4g} V"
        return text + (f", {self.seconds:.1f} s" if self.drive is not None
                       else ", already stored")

    def to_json(self) -> dict[str, Any]:
        """The summary as a JSON-ready dict."""
        return asdict(self)


class CampaignObserver(Protocol):
    """What a running campaign tells its watchers (live view, terminal progress); every method
    is optional to implement."""
    def campaign_started(self, info: CampaignStart) -> None:
        """The campaign's layout and what the run already holds (`CampaignStart`)."""

    def block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        """A random-excitation block: force (n, n_in), response (n, n_dof)."""

    def step(self, level: int, index: int, freq: float, force: np.ndarray,
             response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        """A measured stepped-sine step; ``harmonics`` (n_harm, n_dof) complex amplitudes;
        ``control_error`` the relative force-amplitude error of the level control."""

    def level_progress(self, status: LevelStatus) -> None:
        """Optional: a level started or stored a block/step."""

    def level_finished(self, summary: LevelSummary) -> None:
        """Optional: a level ended (complete)."""

    def campaign_finished(self, status: str) -> None:
        """``status``: complete, aborted or interrupted."""


class NullObserver:
    """Observer that ignores everything (the default)."""

    def campaign_started(self, info: CampaignStart) -> None:
        """Ignore the start."""
        pass

    def block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        """Ignore a block."""
        pass

    def step(self, level: int, index: int, freq: float, force: np.ndarray,
             response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        """Ignore a step."""
        pass

    def level_progress(self, status: LevelStatus) -> None:
        """Ignore a level's progress."""
        pass

    def level_finished(self, summary: LevelSummary) -> None:
        """Ignore a level's end."""
        pass

    def campaign_finished(self, status: str) -> None:
        """Ignore the end."""
        pass


class Watchers:
    """Several observers as one: each event goes to every watcher that has its method."""

    def __init__(self, *observers: CampaignObserver | None) -> None:
        self.observers = [o for o in observers if o is not None]

    def _tell(self, event: str, *args: Any) -> None:
        for observer in self.observers:
            method = getattr(observer, event, None)
            if method is not None:
                method(*args)

    def campaign_started(self, info: CampaignStart) -> None:
        """Tell every watcher the campaign started."""
        self._tell("campaign_started", info)

    def block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        """Tell every watcher about a block."""
        self._tell("block", level, seq, force, response)

    def step(self, level: int, index: int, freq: float, force: np.ndarray,
             response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        """Tell every watcher about a step."""
        self._tell("step", level, index, freq, force, response, control_error, harmonics)

    def level_progress(self, status: LevelStatus) -> None:
        """Tell every watcher a level's progress."""
        self._tell("level_progress", status)

    def level_finished(self, summary: LevelSummary) -> None:
        """Tell every watcher a level ended."""
        self._tell("level_finished", summary)

    def campaign_finished(self, status: str) -> None:
        """Tell every watcher the campaign ended."""
        self._tell("campaign_finished", status)
