"""The candidate library: every location x kind, grounded ones narrowed by ``[support]``, and
kept below the diagnosis so that reverse-path screening needs no import of it."""

from __future__ import annotations

import ast
from pathlib import Path

from analysis.models import LINEAR_KINDS, Candidate, Model, Support, library, locations

ROOT = Path(__file__).resolve().parents[3]


def _grounded(lib: list[Candidate]) -> set[tuple[str, int]]:
    return {(c.kind, c.dofs[0]) for c in lib if len(c.dofs) == 1}


def _pairs(lib: list[Candidate]) -> list[Candidate]:
    return [c for c in lib if len(c.dofs) == 2]


def test_without_support_every_point_may_be_grounded():
    lib = library(3)
    assert {d for _, d in _grounded(lib)} == {0, 1, 2}
    assert library(3, support=None) == lib
    assert [c.dofs for c in lib if c.kind == "cubic_spring"] == [(0,), (1,), (2,), (0, 1),
                                                                 (0, 2), (1, 2)]


def test_support_points_hold_the_only_grounded_elements():
    full, held = library(3), library(3, support=Support((1,)))
    nonlinear = {(k, d) for k, d in _grounded(held) if k not in LINEAR_KINDS}
    assert nonlinear and {d for _, d in nonlinear} == {1}
    # stiffness and damping errors to ground only at the support; a mass error at every point
    assert {d for k, d in _grounded(held) if k == "stiffness_error"} == {1}
    assert {d for k, d in _grounded(held) if k == "mass_error"} == {0, 1, 2}
    assert _pairs(held) == _pairs(full)          # joints are never narrowed


def test_free_structure_has_only_linear_errors_to_ground():
    lib = library(3, support=Support(free=True))
    assert {k for k, _ in _grounded(lib)} == set(LINEAR_KINDS)
    assert {d for _, d in _grounded(lib)} == {0, 1, 2}
    assert _pairs(lib) == _pairs(library(3))


def test_model_file_support_reaches_the_library(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text('points = ["root", "tip"]\n[linear]\nmass = [[1.0, 0.0], [0.0, 1.0]]\n'
                    'stiffness = [[2e4, -1e4], [-1e4, 1e4]]\n'
                    'damping = [[2.0, -1.0], [-1.0, 1.0]]\n'
                    '[support]\npoints = ["root"]\n')
    m = Model.load(path)
    lib = library(m.n_dof, m.points, m.support)
    assert {(k, d) for k, d in _grounded(lib) if k not in LINEAR_KINDS} == {
        (k, 0) for k, d in _grounded(library(2)) if k not in LINEAR_KINDS}
    assert "root to ground" in next(c.where for c in lib if c.dofs == (0,))


def test_locations_are_every_point_and_pair():
    assert locations(3) == [(0,), (1,), (2,), (0, 1), (0, 2), (1, 2)]


def _imported_modules(path: Path) -> set[str]:
    """Every module a file imports, function-local imports included (relative ones resolved
    against the file's package)."""
    pkg = list(path.relative_to(ROOT).with_suffix("").parts[:-1])
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            head = pkg[: len(pkg) - node.level + 1] if node.level else []
            out.add(".".join(head + ([node.module] if node.module else [])))
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_no_room_below_the_diagnosis_imports_it():
    """The candidate library lives in `analysis.models`: reverse path, and every other room the
    diagnosis imports, reaches it without importing `analysis.diagnose`, not even inside a
    function (no hidden two-way room dependency)."""
    below = {m.split(".")[1] for path in (ROOT / "analysis" / "diagnose").rglob("*.py")
             for m in _imported_modules(path)
             if m.startswith("analysis.") and not m.startswith("analysis.diagnose")}
    assert {"models", "reverse_path"} <= below
    for room in sorted(below):
        for path in (ROOT / "analysis" / room).rglob("*.py"):
            bad = {m for m in _imported_modules(path) if m.startswith("analysis.diagnose")}
            assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}"
