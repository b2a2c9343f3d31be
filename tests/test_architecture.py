"""The tree's structure: imports run one way, no module or room cycles, rooms entered only
through their ``__init__``, h5py only in the store, no function over 80 lines but the listed
numeric kernels and functions being split (``LONG_FUNCTIONS``), no public signature taking or
returning a dict of anything outside the JSON edge (``JSON_EDGE``).

The import graph is read from the source (every ``import``, local ones inside functions
included; ``if TYPE_CHECKING:`` blocks excluded because they never run). A room is a package
one level below a layer (``analysis.models``, ``drivers.emulators``, ``nlid_lab.store``);
code outside a room imports the room itself and its public names, never one of its modules
nor an underscore name (docs/architecture.md).
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("analysis", "drivers", "nlid_lab")          # each may import only those before it


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in LAYERS:
        for path in (ROOT / pkg).rglob("*.py"):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def _runtime_nodes(tree: ast.AST):
    """Every node except the bodies of ``if TYPE_CHECKING:``."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            stack.extend(node.orelse)
            continue
        stack.extend(ast.iter_child_nodes(node))


@functools.cache     # the graph is read by seven tests: each file parsed once per process
def _imports(name: str, path: Path) -> frozenset[str]:
    """Fully qualified names imported by one module (module or module.attribute)."""
    base = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()
    for node in _runtime_nodes(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            head = base[: len(base) - node.level + 1] if node.level else []
            mod = ".".join(head + ([node.module] if node.module else []))
            if node.module:                 # ``from . import x`` imports x, not the package
                found.add(mod)
            found.update(f"{mod}.{a.name}" for a in node.names)
    return frozenset(found)


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    graph = {}
    for name, path in mods.items():
        edges = set()
        for target in _imports(name, path):
            while target and target not in mods:
                target = target.rpartition(".")[0]
            if target and target != name:
                edges.add(target)
        graph[name] = edges
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def _room(name: str, mods: dict[str, Path]) -> str | None:
    """The room holding module ``name`` (the room's own ``__init__`` included), or None for
    a layer's top-level modules (``nlid_lab.cli``, ``drivers.registry``)."""
    pkg = ".".join(name.split(".")[:2])
    return pkg if pkg.count(".") == 1 and mods.get(pkg, Path()).name == "__init__.py" else None


def _module_of(target: str, mods: dict[str, Path]) -> str:
    """The module an imported name (module or module.attribute) lives in ("" if outside)."""
    while target and target not in mods:
        target = target.rpartition(".")[0]
    return target


def _reaches_inside(name: str, target: str, mods: dict[str, Path]) -> bool:
    """Does module ``name`` importing ``target`` (module or module.attribute) reach into
    another room: one of its modules other than the ``__init__``, or an underscore name?"""
    module = _module_of(target, mods)
    room = _room(module, mods) if module else None
    if room is None or room == _room(name, mods):
        return False
    attribute = target[len(module) + 1:]
    return module != room or (attribute.startswith("_") and not attribute.startswith("__"))


def _room_graph(mods: dict[str, Path], graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """Rooms (and top-level modules) and the rooms they import."""
    rooms: dict[str, set[str]] = {}
    for name, targets in graph.items():
        here = _room(name, mods) or name
        edges = rooms.setdefault(here, set())
        for t in targets:
            there = _room(t, mods) or t
            if there != here:
                edges.add(there)
    for targets in list(rooms.values()):
        for t in targets:
            rooms.setdefault(t, set())
    return rooms


def test_rooms_are_entered_through_their_init():
    mods = _modules()
    wrong = sorted((name, t) for name, path in mods.items() for t in _imports(name, path)
                   if _reaches_inside(name, t, mods))
    assert wrong == []


def test_no_room_cycles():
    assert _cycles(_room_graph(_modules(), _graph())) == []


def test_room_rule_sees_a_reach_inside():
    mods = {name: Path(f"{name.replace('.', '/')}.py") for name in
            ("a.r._m", "a.r.pub", "a.s._n", "a.top")} | {"a.r": Path("a/r/__init__.py"),
                                                         "a.s": Path("a/s/__init__.py")}
    assert _reaches_inside("a.s._n", "a.r._m.f", mods)          # a private module
    assert _reaches_inside("a.s._n", "a.r.pub", mods)           # any module but the __init__
    assert _reaches_inside("a.top", "a.r._hidden", mods)        # an underscore name
    assert not _reaches_inside("a.s._n", "a.r.f", mods)         # the room's API
    assert not _reaches_inside("a.r.pub", "a.r._m.f", mods)     # inside its own room
    assert not _reaches_inside("a.s._n", "a.top.f", mods)       # a layer's top-level module
    graph = {"a.r._m": {"a.s._n"}, "a.s._n": {"a.r.pub"}, "a.r.pub": set(), "a.top": set()}
    assert _cycles(_room_graph(mods, graph)) == [["a.r", "a.s"]]


#: Packages whose imports inside functions have their reason in the package's documentation:
#: every command line imports them (`nlid_lab/commands/__init__.py`,
#: `nlid_lab/methods/_registry.py`); and code being rewritten elsewhere (issue 24).
LOCAL_IMPORTS_EXPLAINED = ("nlid_lab/commands/", "nlid_lab/methods/", "analysis/diagnose/")


def _unexplained_local_imports(source: str) -> list[int]:
    """Lines of runs of imports inside a function with no comment on them or on the line
    above (the comment says why the import waits: import cost, an optional extra, a cycle)."""
    lines = source.splitlines()
    bodies = [node.body for node in ast.walk(ast.parse(source))
              if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))]
    for fn in list(bodies):
        bodies += [getattr(n, f) for n in ast.walk(ast.Module(body=fn, type_ignores=[]))
                   for f in ("body", "orelse", "finalbody", "handlers")
                   if isinstance(n, (ast.If, ast.Try, ast.With, ast.For, ast.ExceptHandler))
                   and isinstance(getattr(n, f, None), list)]
    found = set()
    for body in bodies:
        run: list[ast.stmt] = []
        for stmt in [*body, None]:
            if isinstance(stmt, (ast.Import, ast.ImportFrom)):
                run.append(stmt)
                continue
            if run and not any("#" in line for line in
                               lines[max(run[0].lineno - 2, 0):run[-1].end_lineno]):
                found.add(run[0].lineno)
            run = []
    return sorted(found)


def test_imports_inside_functions_say_why():
    wrong = [f"{path.relative_to(ROOT)}:{line}" for path in _modules().values()
             if not str(path.relative_to(ROOT)).startswith(LOCAL_IMPORTS_EXPLAINED)
             for line in _unexplained_local_imports(path.read_text())]
    assert wrong == []


def test_local_import_check_sees_a_silent_one():
    source = ("def f():\n    import json\n    return json\n\n"
              "def g():\n    import csv   # loads on use\n    import io\n    return csv, io\n")
    assert _unexplained_local_imports(source) == [2]


def test_no_import_cycles():
    assert _cycles(_graph()) == []


@pytest.mark.parametrize("layer", LAYERS)
def test_imports_run_one_way(layer):
    allowed = set(LAYERS[: LAYERS.index(layer) + 1])
    wrong = {(m, t) for m, ts in _graph().items() if m.split(".")[0] == layer
             for t in ts if t.split(".")[0] not in allowed}
    assert wrong == set()


def test_h5py_only_in_the_store():
    users = {name for name, path in _modules().items()
             if any(t.split(".")[0] == "h5py" for t in _imports(name, path))}
    assert users and all(u.startswith("nlid_lab.store") for u in users), users


def test_cycle_finder_sees_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_every_name_of_the_analysis_api_resolves():
    import analysis
    for name in analysis.__all__:
        assert getattr(analysis, name) is not None, name


#: The longest a function may be (issue 22 item 4), decorators not counted.
MAX_FUNCTION_LINES = 80
#: Functions still longer, each with its reason; an entry goes when its function is split
#: (`test_long_function_allow_list_is_current` says which).
LONG_FUNCTIONS: dict[str, str] = {}


def _function_lengths(source: str) -> dict[str, int]:
    """Lines from ``def`` to the last line of each function (methods as ``Class.name``,
    nested functions as ``outer.inner``)."""
    out: dict[str, int] = {}

    def visit(body: list[ast.stmt], prefix: str) -> None:
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}{node.name}"
                if not isinstance(node, ast.ClassDef):
                    out[name] = node.end_lineno - node.lineno + 1
                visit(node.body, f"{name}.")
            elif hasattr(node, "body"):      # if/try/with blocks at any level
                for field in ("body", "orelse", "finalbody", "handlers"):
                    visit(getattr(node, field, []), prefix)
    visit(ast.parse(source).body, "")
    return out


def _long_functions() -> dict[str, int]:
    return {f"{path.relative_to(ROOT).as_posix()}::{name}": n
            for path in _modules().values()
            for name, n in _function_lengths(path.read_text()).items()
            if n > MAX_FUNCTION_LINES}


def test_no_function_over_80_lines():
    assert sorted(set(_long_functions()) - set(LONG_FUNCTIONS)) == []


def test_long_function_allow_list_is_current():
    long = _long_functions()
    stale = sorted(key for key in LONG_FUNCTIONS if key not in long)
    assert stale == [], "no longer over 80 lines (or gone): delete its LONG_FUNCTIONS entry"


def test_function_length_check_sees_a_long_one():
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES))
    source = (f"class C:\n    def m(self):\n{body.replace('    ', '        ')}"
              f"\n\nif True:\n    def f():\n{body.replace('    ', '        ')}"
              f"\n\ndef g():\n    pass\n")
    lengths = _function_lengths(source)
    assert lengths == {"C.m": MAX_FUNCTION_LINES + 1, "f": MAX_FUNCTION_LINES + 1, "g": 2}


#: What a public signature may not take or return outside the JSON edge (issue 22 item 1:
#: results are typed; JSON only at the CLI and store edge): a string-keyed dict of anything,
#: spelled out or by the aliases that name it (`analysis.documents.JsonObject`,
#: `analysis.diagnose._json_fields.Json`).
UNTYPED = ("dict[str, Any]", "Mapping[str, Any]", "MutableMapping[str, Any]", "JsonObject",
           "Json")
#: The serialisers of a type, allowed by name.
SERIALISERS = ("to_json", "from_json")
#: The edge itself: functions that read or write a JSON document, each with its reason.
JSON_EDGE: dict[str, str] = {
    "nlid_lab/outputs.py::write_json": "CLI JSON output: writes a command's document",
    "nlid_lab/outputs.py::with_checks": "CLI JSON output: a document with its data checks",
    "nlid_lab/store/_estimates.py::elements_from_json":
        "store codec: the `elements` list of any stored estimate, old layouts too",
    "nlid_lab/store/_tables.py::write_table": "store codec: a results table's attributes",
    "nlid_lab/store/_tables.py::read_table": "store codec: a results table's attributes",
    "nlid_lab/store/_steptables.py::read_table": "store codec: a stored table's attributes",
    "nlid_lab/store/_steptables.py::is_table_run": "store codec: a run's attributes",
    "analysis/diagnose/_result.py::CandidateFit.physics_json":
        "serialiser: a chosen effect's `missing_physics` entry of `Diagnosis.to_json`",
    "nlid_lab/campaign/_plans.py::LevelPlan.settings":
        "store codec: the plan as the run's `excitation_settings` attribute",
    "nlid_lab/campaign/_kinds/_stepped.py::SteppedSpec.settings":
        "store codec: the plan as the run's `excitation_settings` attribute",
    "nlid_lab/campaign/_kinds/_sweep.py::SweepSpec.settings":
        "store codec: the plan as the run's `excitation_settings` attribute",
    "nlid_lab/store/_integrity.py::planned_blocks":
        "store codec: a run's planned count from its stored `excitation_settings` (old runs)",
    "analysis/diagnose/_json_fields.py::opt": "serialiser helper: an optional JSON field",
}


def _untyped_signatures(source: str) -> list[str]:
    """Public functions and methods (``Class.name``) of ``source`` whose annotations hold an
    `UNTYPED` dict, serialisers (`SERIALISERS`) left out."""
    pattern = re.compile(r"(?<![\w.])(" + "|".join(re.escape(u) for u in UNTYPED) + r")(?!\w)")
    out = []

    def visit(body: list[ast.stmt], prefix: str) -> None:
        for node in body:
            if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                visit(node.body, f"{prefix}{node.name}.")
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if node.name in SERIALISERS or (node.name.startswith("_")
                                                and not node.name.endswith("__")):
                    continue
                a = node.args
                args = [*a.posonlyargs, *a.args, *a.kwonlyargs, a.vararg, a.kwarg]
                notes = [x.annotation for x in args if x is not None and x.annotation]
                if any(pattern.search(ast.unparse(n)) for n in notes + [node.returns] if n):
                    out.append(f"{prefix}{node.name}")
            elif isinstance(node, (ast.If, ast.Try)):   # definitions under if/try blocks
                for field in ("body", "orelse", "finalbody"):
                    visit(getattr(node, field, []), prefix)
    visit(ast.parse(source).body, "")
    return out


def _untyped() -> list[str]:
    return [f"{path.relative_to(ROOT).as_posix()}::{name}" for path in _modules().values()
            for name in _untyped_signatures(path.read_text())]


def test_results_are_typed_outside_the_json_edge():
    allowed = set(JSON_EDGE)
    assert sorted(set(_untyped()) - allowed) == [], (
        "a public signature takes or returns a dict of anything: type it (a frozen "
        "dataclass, typed fields, a TypedDict of a document) or, if it is the JSON edge "
        "itself, add it to JSON_EDGE with its reason")


def test_json_edge_allow_list_is_current():
    stale = sorted(set(JSON_EDGE) - set(_untyped()))
    assert stale == [], "typed now (or gone): delete its JSON_EDGE entry"


def test_untyped_signature_check_sees_one():
    source = ("from typing import Any, Mapping\n"
              "def f(x: dict[str, Any]) -> int: ...\n"
              "def h(*, y: tuple[str, Mapping[str, Any]] | None) -> None: ...\n"
              "def _private(x: dict[str, Any]) -> None: ...\n"
              "def typed(x: dict[str, float], j: JsonObjects) -> Mapping[str, int]: ...\n"
              "if True:\n    def g() -> JsonObject: ...\n"
              "class C:\n"
              "    def to_json(self) -> dict[str, Any]: ...\n"
              "    def m(self, **kw: Json) -> None: ...\n"
              "    def __init__(self, data: Mapping[str, Any]) -> None: ...\n"
              "class _Hidden:\n    def m(self) -> dict[str, Any]: ...\n")
    assert _untyped_signatures(source) == ["f", "h", "g", "C.m", "C.__init__"]
