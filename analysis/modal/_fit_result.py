"""What ``fit-linear`` reports: the modes with their quality, the residual pseudo-modes, the
in-band FRF error, as a typed record with the command's JSON.

``LinearFitSummary.from_json(s.to_json()) == s``; the JSON is the command's (``nlid-lab
fit-linear --json``) with ``schema_version`` first, then ``interference`` (only when lines
were left out), ``delay_samples`` with ``delay_interval_samples`` (its 95 % interval) and
``delay_stated_samples`` (to the interval's resolution; only when a delay was taken out),
``warnings`` (only
when there are some) and ``mains_unchecked_hz`` (only with the mains caveat,
`analysis.spectral.MainsCaveat`) last.

`ModalSummary` is the reverse path's modal summary (`analysis.modal.modal_summary`): its JSON
is the ``modal`` entry of ``nlid-lab analyze reverse-path --json``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..spectral import Interference, MainsCaveat
from ._delay import DelayReading

if TYPE_CHECKING:
    from ._linear_fit import LinearFit

SCHEMA_VERSION = 1
"""Version of `LinearFitSummary`'s JSON (``schema_version``)."""


@dataclass(frozen=True)
class ModeSummary:
    """One fitted mode.

    Attributes
    ----------
    freq_hz, damping_ratio : float
    support : float
        Share of the upper model orders at which it was stable.
    max_mac_other : float
        Largest MAC with another mode (close to 1: a duplicate or a spatially aliased pair).
    shape : tuple of float
        Mass-normalised shape at every point.
    """

    freq_hz: float
    damping_ratio: float
    support: float
    max_mac_other: float
    shape: tuple[float, ...]

    def to_json(self) -> dict[str, Any]:
        """``{"freq_hz", "damping_ratio", "support", "max_mac_other", "shape"}``."""
        return {"freq_hz": self.freq_hz, "damping_ratio": self.damping_ratio,
                "support": self.support, "max_mac_other": self.max_mac_other,
                "shape": list(self.shape)}


@dataclass(frozen=True)
class ModalMode:
    """One mode of a `ModalSummary`.

    Attributes
    ----------
    freq_hz, damping_ratio : float
    shape : tuple of float
        Residue vector of the first forced column, scaled to a unit largest component.
    in_band : bool
        Inside the analysed band (False: extrapolated).
    """

    freq_hz: float
    damping_ratio: float
    shape: tuple[float, ...]
    in_band: bool

    def to_json(self) -> dict[str, Any]:
        """``{"freq_hz", "damping_ratio", "shape", "in_band"}``."""
        return {"freq_hz": self.freq_hz, "damping_ratio": self.damping_ratio,
                "shape": list(self.shape), "in_band": self.in_band}


@dataclass(frozen=True)
class ModalSummary:
    """Modes of a reverse path's underlying linear FRF (`analysis.modal.modal_summary`).

    Attributes
    ----------
    method : str
        The route taken (which FRF was fitted, how).
    force_dof : int
        DOF of the force column the shapes belong to.
    modes : tuple of ModalMode
    """

    method: str
    force_dof: int
    modes: tuple[ModalMode, ...]

    def to_json(self) -> dict[str, Any]:
        """``{"method", "force_dof", "modes"}`` (the ``modal`` of the reverse path's JSON)."""
        return {"method": self.method, "force_dof": self.force_dof,
                "modes": [m.to_json() for m in self.modes]}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> ModalSummary:
        """Inverse of `to_json`."""
        return cls(data["method"], data["force_dof"],
                   tuple(ModalMode(m["freq_hz"], m["damping_ratio"], tuple(m["shape"]),
                                   m["in_band"]) for m in data["modes"]))


@dataclass(frozen=True)
class LinearFitSummary:
    """Result of ``nlid-lab fit-linear`` (docs/model-format.md, docs/gvt-workflow.md).

    Attributes
    ----------
    method : str
        How the measured receptance was estimated.
    band_hz : (lo, hi)
    points : tuple of str
    driving_point : str
    modes : tuple of ModeSummary
    residual_pseudo_modes_hz : tuple of float
        The pseudo-modes standing for the modes outside the band.
    frf_error : tuple of float
        In-band relative FRF error of the written model per point (measured kind).
    level : float or None
        Nominal level of the fitted recording (None: none in the file).
    interference : tuple of Interference
        Steady force lines left out of the excited set (`analysis.spectral.excited_lines`).
    delay : DelayReading
        Delay of the responses behind the force taken out of the FRF before the fit, with its
        interval (`analysis.modal._delay`), samples; empty when none was found.
    warnings : tuple of str
        What the fit could not serve (a dead channel).
    caveat : MainsCaveat or None
        One realization with mains multiples on the drive lines (`analysis.spectral.
        MainsCaveat`; JSON ``"mains_unchecked_hz"``).
    """

    method: str
    band_hz: tuple[float, float]
    points: tuple[str, ...]
    driving_point: str
    modes: tuple[ModeSummary, ...]
    residual_pseudo_modes_hz: tuple[float, ...]
    frf_error: tuple[float, ...]
    level: float | None = None
    interference: tuple[Interference, ...] = ()
    delay: DelayReading = DelayReading()
    warnings: tuple[str, ...] = ()
    caveat: MainsCaveat | None = None

    @property
    def delay_samples(self) -> float:
        """The delay taken out, samples (0: none)."""
        return self.delay.samples

    @classmethod
    def of(cls, fit: LinearFit, level: float | None) -> LinearFitSummary:
        """The summary of a `analysis.modal.fit_linear` result of a level at ``level``."""
        m = fit.modes
        mac = m.mac - np.eye(m.mac.shape[0])
        model = fit.model
        nr = model.n_residual
        # the pseudo-modes are the trailing modal coordinates (below and above the band)
        pseudo = np.sqrt(np.diag(model.stiffness)[model.n_q - nr:]) / (2 * np.pi)
        modes = tuple(ModeSummary(float(f), float(z), float(s),
                                  float(mac[i].max(initial=0.0)),
                                  tuple(float(v) for v in m.shapes[i]))
                      for i, (f, z, s) in enumerate(zip(m.freqs_hz, m.damping, m.support)))
        return cls(fit.data.method, (float(m.band_hz[0]), float(m.band_hz[1])),
                   tuple(model.points), model.points[fit.data.driving_point], modes,
                   tuple(float(f) for f in pseudo), tuple(float(e) for e in fit.frf_error),
                   None if level is None else float(level), fit.data.interference,
                   fit.delay, tuple(fit.warnings), fit.data.caveat)

    def to_json(self) -> dict[str, Any]:
        """The command's JSON (module docstring)."""
        out = {"schema_version": SCHEMA_VERSION, "method": self.method,
               "band_hz": list(self.band_hz), "points": list(self.points),
               "driving_point": self.driving_point,
               "modes": [m.to_json() for m in self.modes],
               "residual_pseudo_modes_hz": list(self.residual_pseudo_modes_hz),
               "frf_error": dict(zip(self.points, self.frf_error)), "level": self.level}
        if self.interference:
            out["interference"] = [{"freq_hz": i.freq_hz, "level_db": i.level_db}
                                   | ({"on_drive_line": True} if i.on_drive_line else {})
                                   | ({"drift": True} if i.drift else {})
                                   | ({"unlocked_hz": i.unlocked_hz} if i.unlocked_hz else {})
                                   for i in self.interference]
        if self.delay_samples:
            out["delay_samples"] = self.delay_samples
            out["delay_interval_samples"] = [self.delay.low, self.delay.high]
            out["delay_stated_samples"] = self.delay.stated
        if self.warnings:
            out["warnings"] = list(self.warnings)
        if self.caveat is not None:
            out["mains_unchecked_hz"] = list(self.caveat.freqs_hz)
        return out

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> LinearFitSummary:
        """Inverse of `to_json`; refuses another schema version."""
        got = data.get("schema_version")
        if got != SCHEMA_VERSION:
            raise ValueError(f"fit-linear JSON of schema_version {got}, this version reads "
                             f"{SCHEMA_VERSION}; re-run the command to write it again")
        points = tuple(data["points"])
        return cls(data["method"], tuple(data["band_hz"]), points, data["driving_point"],
                   tuple(ModeSummary(m["freq_hz"], m["damping_ratio"], m["support"],
                                     m["max_mac_other"], tuple(m["shape"]))
                         for m in data["modes"]),
                   tuple(data["residual_pseudo_modes_hz"]),
                   tuple(data["frf_error"][p] for p in points), data["level"],
                   tuple(Interference(i["freq_hz"], i["level_db"], i.get("on_drive_line", False),
                                      i.get("drift", False), i.get("unlocked_hz"))
                         for i in data.get("interference", ())),
                   DelayReading(float(data.get("delay_samples", 0.0)),
                                *data.get("delay_interval_samples", (0.0, 0.0))),
                   tuple(data.get("warnings", ())),
                   MainsCaveat(tuple(data["mains_unchecked_hz"]))
                   if "mains_unchecked_hz" in data else None)
