"""What a view, report or export reads from one stored run: its recordings, metadata,
stored results and reference model (`load_run`), and the building blocks of report sections
that the estimators' sections (`nlid_lab.methods`) use too.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping

from analysis.errors import InputError
from analysis.spectral import LevelFRF, level_frf
from analysis.models import Element, Model, coefficient_units
from analysis.recordings import Recording, one_kind

from ..formats import load_recordings
from .. import store


class ReportError(InputError):
    """A run cannot be reported or exported as asked."""


@dataclass
class RunData:
    """Everything a view, report or export needs from one stored run.

    Attributes
    ----------
    path : Path
        The run file (or NPZ recording).
    recordings : list of Recording
        Its levels with data, in stored order.
    model_toml : str
        The model stored with the run (`nlid_lab.store.Run.model_toml`), ``""`` when none;
        read by `reference_model`.
    results : Mapping of str to object
        The run's stored results, name -> the document saved (`nlid_lab.store.save_result`),
        read-only. Nothing reads them by key: each result type has one typed reader, the
        diagnosis's `Diagnosis.from_json` (`nlid_lab.reports.stored_diagnosis`), an
        estimator's its `Method.result` (the registry's ``find_stored`` and
        ``stored_estimates``).
    status : str
        The run's status as last written.
    """

    path: Path
    recordings: list[Recording]
    model_toml: str = ""
    results: Mapping[str, object] = field(default_factory=lambda: MappingProxyType({}))
    status: str = "complete"

    @property
    def name(self) -> str:
        """The run's file name without its suffix."""
        return self.path.stem


def load_run(path: str | Path) -> RunData:
    """Read a run: an HDF5 file written by the store, or an NPZ recording (contracts 3)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(2, "No such file or directory", str(path))
    if path.suffix.lower() not in (".h5", ".hdf5"):
        return RunData(path, load_recordings(path))
    run = store.open_run(path)
    recs = run.recordings()
    if not recs:
        raise ReportError(f"{path} holds no recorded level; run or resume the campaign first")
    return RunData(path, recs, run.model_toml, MappingProxyType(dict(run.results)), run.status)


def all_level_frfs(run: RunData, progress: Callable[[int], None] | None = None
                   ) -> list[LevelFRF]:
    """`level_frf` of every level, in stored order; a sensor map mixing kinds is converted to
    its highest kind first (`analysis.recordings.one_kind`, as `analyze` and `fit-linear`)."""
    out = []
    for i, rec in enumerate(run.recordings):
        out.append(level_frf(one_kind(rec), i))
        if progress:
            progress(1)
    return out


@dataclass
class Section:
    """One report section: a heading, a short explanation and its figures."""

    title: str
    text: str
    figures: list[tuple[str, Any]] = field(default_factory=list)   # (file stem, Figure)


def reference_model(run: RunData) -> Model | None:
    """The model stored with a simulated run (the reference system), or None."""
    return Model.loads(run.model_toml) if run.model_toml.strip() else None


#: Units of the coefficient of each element kind's basis function.
PARAM_UNITS = coefficient_units()


def candidate_model(run: RunData, candidate=None):
    """Model for reverse path: ``candidate`` if given, else the run's stored reference model
    with every element parameter removed (to be estimated); None when neither exists."""
    if candidate is not None:
        return candidate
    ref = reference_model(run)
    if ref is None or not ref.elements:
        return None
    return ref.with_elements([Element(el.kind, el.w.copy(), {}) for el in ref.elements])
