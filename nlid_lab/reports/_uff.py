"""UFF58 export of a run's FRFs and coherences (pyuff).

One dataset 58 per level, output and input: the FRF as function type 4 (complex) and, for
random levels, the ordinary coherence as type 6 (real). Those are the types pyuff's writer
accepts and round-trips (it rejects 26, multiple coherence; with one force input the ordinary
coherence equals the multiple coherence). Node numbers are DOF + 1 (UFF nodes start at 1),
direction +X; ``load_case_id`` is the level number (1-based).
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

import numpy as np
import pyuff

from analysis.documents import UffDataset
from analysis.spectral import LevelFRF

FUNC_FRF = 4
FUNC_COHERENCE = 6

# UFF "specific data type" codes and unit exponents for (length, force) per response kind.
_RESPONSE = {"displacement": (8, 1, "m"), "velocity": (11, 1, "m/s"),
             "acceleration": (12, 1, "m/s^2")}
_FREQUENCY, _FORCE, _UNKNOWN = 18, 13, 0


def _abscissa(freqs: np.ndarray) -> UffDataset:
    """Even spacing only when min and step survive pyuff's 6-digit header format exactly."""
    x = np.asarray(freqs, float)
    dx = np.diff(x)
    even = (x.size > 1 and np.allclose(dx, dx[0], rtol=1e-12, atol=0)
            and float(f"{dx[0]:.5e}") == dx[0] and float(f"{x[0]:.5e}") == x[0])
    return {"x": x, "abscissa_spacing": int(even), "abscissa_min": float(x[0]),
            "abscissa_inc": float(dx[0]) if even else 0.0}


def _base(frf: LevelFRF, level_no: int, out: int, inp: int, run_name: str) -> UffDataset:
    return {
        "type": 58, "binary": 0, "id2": f"level {level_no}: {frf.label} ({frf.excitation})"[:80],
        "id3": f"run {run_name}"[:80], "id4": "NONE", "id5": "NONE",
        "ver_num": 0, "load_case_id": level_no,
        "rsp_ent_name": "DOF", "rsp_node": out + 1, "rsp_dir": 1,
        "ref_ent_name": "DOF", "ref_node": int(frf.force_dofs[inp]) + 1, "ref_dir": 1,
        "z_axis_value": float(frf.level or 0.0),
        "abscissa_spec_data_type": _FREQUENCY, "abscissa_len_unit_exp": 0,
        "abscissa_force_unit_exp": 0, "abscissa_temp_unit_exp": 0,
        "abscissa_axis_lab": "Frequency", "abscissa_axis_units_lab": "Hz",
        "z_axis_spec_data_type": _UNKNOWN, "z_axis_len_unit_exp": 0,
        "z_axis_force_unit_exp": 0, "z_axis_temp_unit_exp": 0,
        "z_axis_axis_lab": "Force level", "z_axis_axis_units_lab": "N",
        **_abscissa(frf.freqs),
    }


def frf_dataset(frf: LevelFRF, level_no: int, out: int, inp: int, run_name: str) -> UffDataset:
    """Dataset 58 dict of one FRF (function type 4)."""
    spec, len_exp, unit = _RESPONSE[frf.response_kind]
    d = _base(frf, level_no, out, inp, run_name)
    d.update(func_type=FUNC_FRF, id1="nlid-lab FRF", data=frf.H[:, out, inp].astype(complex),
             ordinate_spec_data_type=spec, ordinate_len_unit_exp=len_exp,
             ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
             ordinate_axis_lab=frf.response_kind, ordinate_axis_units_lab=unit,
             orddenom_spec_data_type=_FORCE, orddenom_len_unit_exp=0,
             orddenom_force_unit_exp=1, orddenom_temp_unit_exp=0,
             orddenom_axis_lab="Force", orddenom_axis_units_lab="N")
    return d


def coherence_dataset(frf: LevelFRF, level_no: int, out: int, inp: int, run_name: str
                      ) -> UffDataset:
    """Dataset 58 dict of one ordinary coherence (function type 6, dimensionless)."""
    d = _base(frf, level_no, out, inp, run_name)
    d.update(func_type=FUNC_COHERENCE, id1="nlid-lab coherence",
             data=np.asarray(frf.coherence[:, out, inp], float),
             ordinate_spec_data_type=_UNKNOWN, ordinate_len_unit_exp=0,
             ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
             ordinate_axis_lab="Coherence", ordinate_axis_units_lab="-",
             orddenom_spec_data_type=_UNKNOWN, orddenom_len_unit_exp=0,
             orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
             orddenom_axis_lab="NONE", orddenom_axis_units_lab="NONE")
    return d


def datasets(frfs: Iterable[LevelFRF], run_name: str) -> list[UffDataset]:
    """All dataset-58 dicts of a run: FRFs, then coherences where they exist, per level."""
    out = []
    for no, frf in enumerate(frfs, start=1):
        n_dof, n_in = frf.H.shape[1:]
        pairs = [(q, p) for p in range(n_in) for q in range(n_dof)]
        out += [frf_dataset(frf, no, q, p, run_name) for q, p in pairs]
        if frf.coherence is not None:
            out += [coherence_dataset(frf, no, q, p, run_name) for q, p in pairs]
    return out


def write_uff(path: str | Path, sets: list[UffDataset], progress=None) -> None:
    """Write dataset dicts to ``path`` (replacing it); ``progress(n)`` called per dataset."""
    path = Path(path)
    path.unlink(missing_ok=True)
    uff = pyuff.UFF(str(path))
    for d in sets:
        uff.write_sets(d, mode="add")
        if progress:
            progress(1)


def read_uff(path: str | Path) -> list[UffDataset]:
    """Every dataset 58 in a UFF file, as pyuff reads it."""
    sets = pyuff.UFF(str(path)).read_sets()
    sets = sets if isinstance(sets, list) else [sets]
    return [s for s in sets if s.get("type") == 58]
