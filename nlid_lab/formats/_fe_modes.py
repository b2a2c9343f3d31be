"""FE modes from a universal file (UFF dataset 55) as a ``[modal]`` model.

Dataset 55 ("data at nodes") holds one mode per dataset: normal modes (analysis type 2:
frequency, modal mass, viscous and hysteretic damping ratio, real shapes) or complex modes
(analysis type 3: eigenvalue, modal A, complex shapes), with 3 or 6 values (X, Y, Z, RX, RY, RZ)
per node. A model point is one node and one translation direction (``12:z``; ``12:-z`` flips
the sign, for a sensor mounted against the axis).

Normalisation to unit modal mass: real shapes are divided by the square root of the file's
modal mass; complex shapes ``φ`` of modal A ``a`` (state-space, ``a = 2 i ω_d`` for a
mass-normalised real mode) become ``φ sqrt(2 i ω_d / a)``, real up to the mode's complexity
(reported). Where the file gives no modal mass (0, or no modal A), the shapes are taken as
already mass-normalised and the summary says so.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from analysis.documents import UffDataset
from analysis.errors import InputError
from analysis.models import MAX_DOF, Model

#: Dataset 55 analysis types read here.
NORMAL_MODES, COMPLEX_MODES = 2, 3
_DIRECTIONS = {"x": 1, "y": 2, "z": 3}
_POINT = re.compile(r"^(?:(?P<name>[^=]+)=)?(?P<node>\d+):(?P<sign>[+-]?)(?P<dir>[xyz123])$",
                    re.IGNORECASE)


class UffModesError(InputError):
    """A universal file holds no usable modes, or a point or option does not fit it."""


@dataclass(frozen=True)
class PointSpec:
    """One model point: a node, a translation direction (1 X, 2 Y, 3 Z) and its sign."""

    name: str
    node: int
    direction: int
    sign: float = 1.0


@dataclass
class FEModes:
    """Modes read from dataset 55, mass-normalised, at every node translation in the file.

    Parameters
    ----------
    freqs_hz : ndarray, shape (n_modes,)
        Undamped natural frequencies.
    damping : ndarray, shape (n_modes,)
        Viscous damping ratios; NaN where the file gives none.
    damping_source : list of str
        Where each damping ratio comes from (``"viscous"``, ``"hysteretic / 2"``,
        ``"eigenvalue"`` or ``"none"``).
    shapes : dict
        ``(node, direction) -> ndarray (n_modes,)``, mass-normalised (1/sqrt(kg)).
    normalised_by : str
        ``"modal mass"``, ``"modal A"`` or ``"assumed"`` (the file gives no modal mass).
    complexity : ndarray, shape (n_modes,)
        Imaginary part left after making a complex mode real, relative to its norm (0 for
        normal modes).
    analysis_type : int
        2 (normal modes) or 3 (complex modes).
    """

    freqs_hz: np.ndarray
    damping: np.ndarray
    damping_source: list[str]
    shapes: dict[tuple[int, int], np.ndarray]
    normalised_by: str
    complexity: np.ndarray
    analysis_type: int
    skipped_hz: list[float] = field(default_factory=list)


def parse_point(text: str) -> PointSpec:
    """``[NAME=]NODE:DIR`` with DIR one of x, y, z (or 1, 2, 3), optionally signed."""
    m = _POINT.match(text.strip())
    if not m:
        raise UffModesError(f"--points {text!r}: give NODE:DIR or NAME=NODE:DIR with DIR x, y "
                            "or z (a sign flips it), e.g. tip=12:z or 7:-y")
    d = m["dir"].lower()
    direction = _DIRECTIONS.get(d) or int(d)
    node = int(m["node"])
    sign = -1.0 if m["sign"] == "-" else 1.0
    name = (m["name"] or f"{node}:{m['sign']}{'xyz'[direction - 1]}").strip()
    return PointSpec(name, node, direction, sign)


def read_modes(path: str | Path, load_case: int | None = None) -> FEModes:
    """The normal or complex modes of a universal file (dataset 55), mass-normalised."""
    sets = _mode_sets(path, load_case)
    atype = sets[0]["analysis_type"]
    sets = sorted(sets, key=lambda s: _freq(s))
    nodes = sets[0]["node_nums"]
    keys = [(int(n), d) for d in (1, 2, 3) for n in nodes]
    raw = np.empty((len(sets), len(keys)), complex)
    for i, s in enumerate(sets):
        if not np.array_equal(s["node_nums"], nodes):
            raise UffModesError(f"{path}: mode {s.get('mode_n')} lists other nodes than mode "
                                f"{sets[0].get('mode_n')}; export every mode at the same nodes")
        raw[i] = np.concatenate([np.asarray(s[f"r{d}"]) for d in (1, 2, 3)])
    if not np.all(np.isfinite(raw)):
        raise UffModesError(f"{path}: a mode shape holds NaN or infinite values")
    if atype == NORMAL_MODES:
        freqs, zeta, source, scale, by = _normal(sets)
        shapes, complexity = raw.real * scale[:, None], np.zeros(len(sets))
    else:
        freqs, zeta, source, scale, by = _complex(sets)
        shapes, complexity = _realise(raw * scale[:, None])
    keep = freqs > 0
    return FEModes(freqs[keep], zeta[keep], [s for s, k in zip(source, keep) if k],
                   {key: shapes[keep, j] for j, key in enumerate(keys)}, by,
                   complexity[keep], atype, [float(f) for f in freqs[~keep]])


def to_model(modes: FEModes, points: list[PointSpec] | None, band: tuple[float, float] | None,
             damping: float | None, name: str) -> tuple[Model, np.ndarray]:
    """The ``[modal]`` model of the modes in ``band`` at ``points`` (every node translation
    with a non-zero shape when ``None``) and the indices of those modes in ``modes``;
    ``damping`` fills the modes the file gives none."""
    sel = np.ones(modes.freqs_hz.size, bool)
    if band is not None:
        lo, hi = band
        if not 0 <= lo < hi:
            raise UffModesError(f"--band {lo:g} {hi:g}: give 0 <= LO < HI in Hz")
        sel = (modes.freqs_hz >= lo) & (modes.freqs_hz <= hi)
        if not sel.any():
            raise UffModesError(f"--band {lo:g} {hi:g}: no mode in it (the file's modes span "
                                f"{modes.freqs_hz.min():.4g}-{modes.freqs_hz.max():.4g} Hz)")
    if points is None:
        points = [PointSpec(f"{n}:{'xyz'[d - 1]}", n, d) for (n, d), v in modes.shapes.items()
                  if np.any(v[sel])]
    _check_points(points, modes)
    zeta = modes.damping[sel].copy()
    missing = np.isnan(zeta)
    if missing.any():
        if damping is None:
            raise UffModesError(f"the file gives no damping for {missing.sum()} mode(s); pass "
                                "--damping Z (viscous ratio, e.g. 0.01)")
        if not 0 < damping < 1:
            raise UffModesError(f"--damping {damping:g}: give a damping ratio in (0, 1)")
        zeta[missing] = damping
    shapes = np.column_stack([p.sign * modes.shapes[(p.node, p.direction)][sel]
                              for p in points])
    model = Model.modal(modes.freqs_hz[sel], zeta, shapes, name=name,
                        points=[p.name for p in points])
    return model, np.flatnonzero(sel)


def _mode_sets(path: str | Path, load_case: int | None) -> list[UffDataset]:
    import pyuff   # loads on use (import-modes only)
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(2, "No such file", str(path))
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # noqa: BLE001 - pyuff raises bare Exceptions for bad files
        raise UffModesError(f"{path}: not a readable universal file ({exc}); export the modes "
                            "as UFF dataset 55") from None
    sets = sets if isinstance(sets, list) else [sets]
    modes = [s for s in sets if s.get("type") == 55
             and s.get("analysis_type") in (NORMAL_MODES, COMPLEX_MODES)]
    if not modes:
        found = sorted({str(s.get("type")) for s in sets}) or ["none"]
        raise UffModesError(f"{path}: no mode shapes (dataset 55 of analysis type 2, normal "
                            f"modes, or 3, complex modes); datasets found: {', '.join(found)}")
    _check_complete(path)
    odd = [s for s in modes if s.get("n_data_per_node") not in (3, 6)]
    if odd:
        n = odd[0].get("n_data_per_node")
        raise UffModesError(f"{path}: mode {odd[0].get('mode_n')} has {n} values per node; "
                            "export the shapes as 3 (X, Y, Z) or 6 (with "
                            "rotations) values per node")
    types = {s["analysis_type"] for s in modes}
    if len(types) > 1:
        raise UffModesError(f"{path}: holds both normal and complex modes; export one kind")
    cases = sorted({int(s["load_case"]) for s in modes})
    if load_case is not None:
        modes = [s for s in modes if int(s["load_case"]) == load_case]
        if not modes:
            raise UffModesError(f"--load-case {load_case}: the file holds load case(s) "
                                f"{', '.join(map(str, cases))}")
    elif len(cases) > 1:
        raise UffModesError(f"{path}: holds load cases {', '.join(map(str, cases))}; pick one "
                            "with --load-case N")
    return modes


def _check_complete(path: Path) -> None:
    """A universal file is datasets between ``-1`` lines; pyuff skips an unfinished last one
    silently, which would drop modes from a truncated file."""
    with open(path, "rb") as fh:
        lines = [ln.strip() for ln in fh.read().splitlines() if ln.strip()]
    delimiters = sum(ln == b"-1" for ln in lines)
    if delimiters % 2 or (lines and lines[-1] != b"-1"):
        raise UffModesError(f"{path}: the last dataset is not closed by a -1 line (file "
                            "truncated?); export the file again")


def _freq(s: UffDataset) -> float:
    return float(s["freq"]) if s["analysis_type"] == NORMAL_MODES else abs(s["eig"]) / (2 * np.pi)


def _normal(sets: list[UffDataset]) -> tuple:
    freqs = np.array([float(s["freq"]) for s in sets])
    mass = np.array([float(s["modal_m"]) for s in sets])
    vis = np.array([float(s["modal_damp_vis"]) for s in sets])
    his = np.array([float(s["modal_damp_his"]) for s in sets])
    zeta = np.where(vis > 0, vis, np.where(his > 0, his / 2, np.nan))
    source = ["viscous" if v > 0 else "hysteretic / 2" if h > 0 else "none"
              for v, h in zip(vis, his)]
    if np.any(mass < 0) or (np.any(mass > 0) and not np.all(mass > 0)):
        raise UffModesError("the modal masses in the file are partly zero or negative; give "
                            "every mode its modal mass, or none (mass-normalised shapes)")
    if np.all(mass > 0):
        return freqs, zeta, source, 1 / np.sqrt(mass), "modal mass"
    return freqs, zeta, source, np.ones(len(sets)), "assumed"


def _complex(sets: list[UffDataset]) -> tuple:
    lam = np.array([complex(s["eig"]) for s in sets])
    if np.any(lam.imag <= 0):
        raise UffModesError("a complex mode has an eigenvalue with imaginary part <= 0; "
                            "export the modes of positive frequency")
    wn = np.abs(lam)
    zeta = -lam.real / wn
    a = np.array([complex(s["modal_a"]) for s in sets])
    if np.all(a != 0):
        return wn / (2 * np.pi), zeta, ["eigenvalue"] * len(sets), np.sqrt(2j * lam.imag / a), \
            "modal A"
    if np.any(a != 0):
        raise UffModesError("the modal A values in the file are partly zero; give every mode "
                            "its modal A, or none (mass-normalised shapes)")
    return wn / (2 * np.pi), zeta, ["eigenvalue"] * len(sets), np.ones(len(sets)), "assumed"


def _realise(shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotate each complex mode to its most real phase (least squares); the imaginary part
    left, relative to the mode's norm, measures its complexity."""
    out, complexity = np.empty(shapes.shape), np.empty(shapes.shape[0])
    for i, phi in enumerate(shapes):
        theta = -0.5 * np.angle(np.sum(phi ** 2))
        rot = phi * np.exp(1j * theta)
        out[i] = rot.real
        complexity[i] = np.linalg.norm(rot.imag) / max(np.linalg.norm(rot), 1e-300)
    return out, complexity


def _check_points(points: list[PointSpec], modes: FEModes) -> None:
    nodes = sorted({n for n, _ in modes.shapes})
    names = [p.name for p in points]
    for p in points:
        if (p.node, p.direction) not in modes.shapes:
            raise UffModesError(f"--points: node {p.node} is not in the file's mode shapes "
                                f"(nodes {nodes[0]}..{nodes[-1]}, {len(nodes)} in all)")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise UffModesError(f"--points: the name {dup[0]!r} is given twice; name each point "
                            "once")
    if not points:
        raise UffModesError("the modes in the band are zero at every node; check the file")
    if len(points) > MAX_DOF:
        raise UffModesError(f"{len(points)} node translations carry the modes, more than "
                            f"{MAX_DOF} points; choose the points with --points NAME=NODE:DIR")
