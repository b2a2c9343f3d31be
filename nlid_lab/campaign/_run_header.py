"""What a campaign writes into its run's header: its channels (`RunChannel`) and the
excitation it records with the plan's settings and planned segments (`RunExcitation`); each
record's ``to_json`` is the JSON the store keeps (docs/run-format.md)."""

from __future__ import annotations

from dataclasses import dataclass

from analysis.documents import JsonObject

from ._campaign_config import Campaign


@dataclass(frozen=True)
class RunChannel:
    """One channel of the run's channel table: its ``kind`` is ``"force"`` or
    ``"response"``, ``dof`` the run's DOF."""

    name: str
    unit: str
    dof: int
    sensitivity: float
    kind: str

    def to_json(self) -> JsonObject:
        """The channel as `nlid_lab.store.RunWriter` takes it (``channels`` entries)."""
        return {"name": self.name, "unit": self.unit, "dof": self.dof,
                "sensitivity": self.sensitivity, "kind": self.kind}


@dataclass(frozen=True)
class RunExcitation:
    """The excitation a campaign's levels record (``kind``, an `Excitation` for the built-in
    plans), the plan as the run stores it (``settings``, `LevelPlan.settings`) and the
    segments a complete level stores (``per_level``) over ``n_levels`` levels."""

    kind: str
    settings: JsonObject
    per_level: int
    n_levels: int

    @property
    def planned_blocks(self) -> int:
        """Blocks, steps or sweeps the plan stores (the run's ``planned_blocks``)."""
        return self.per_level * self.n_levels

    def to_json(self) -> JsonObject:
        """The run's ``excitation_settings``: the kind, then the plan's settings."""
        return {"kind": self.kind, **self.settings}


def run_channels(c: Campaign) -> tuple[RunChannel, ...]:
    """The campaign's channels as its run stores them: forces first, then responses by DOF."""
    return tuple(RunChannel(ch.name, ch.unit, ch.dof, ch.sensitivity,
                            "force" if ch.quantity == "force" else "response")
                 for ch in sorted(c.channels, key=lambda ch: (ch.quantity != "force", ch.dof)))


def run_excitation(c: Campaign) -> RunExcitation:
    """The campaign's excitation record (`RunExcitation`)."""
    return RunExcitation(c.plan.excitation, c.plan.settings(c.channels), c.plan.per_level,
                         len(c.levels))
