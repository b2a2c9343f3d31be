"""Every public function, class and method of the three layers (analysis/, drivers/,
nlid_lab/) says what it does: a docstring on each callable whose name has no leading
underscore (numpydoc in analysis/)."""

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LAYERS = ("analysis", "drivers", "nlid_lab")
#: Files other helpers change in this session (recordings, sweeps, FRFs, detection, linear
#: fit, diagnosis, campaigns, the store, MAT import): their docstrings come after the merge,
#: to keep it clean. Paths from the repository root.
PENDING = {"analysis/recordings/_recording.py", "analysis/spectral/_sweep.py", "analysis/spectral/_frf.py", "analysis/detection/_detect.py",
           "analysis/modal/_linear_fit.py", "nlid_lab/formats/_mat_io.py",
           "nlid_lab/campaign/_campaign.py", "nlid_lab/campaign/_campaign_bench.py", "nlid_lab/campaign/_campaign_config.py"}
PENDING_DIRS = {"analysis/diagnose", "nlid_lab/store"}


def undocumented(source: str, name: str) -> list[str]:
    """``name:line qualname`` of each public callable in ``source`` without a docstring."""
    out = []

    def visit(body, prefix: str) -> None:
        for node in body:
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                continue
            if node.name.startswith("_"):
                continue
            if ast.get_docstring(node) is None:
                out.append(f"{name}:{node.lineno} {prefix}{node.name}")
            if isinstance(node, ast.ClassDef):
                visit(node.body, f"{prefix}{node.name}.")

    visit(ast.parse(source).body, "")
    return out


def _pending(rel: str) -> bool:
    return rel in PENDING or any(rel.startswith(d + "/") for d in PENDING_DIRS)


def checked_files() -> list[Path]:
    return [p for layer in LAYERS for p in sorted((REPO / layer).rglob("*.py"))
            if not _pending(p.relative_to(REPO).as_posix())]


def test_public_callables_have_docstrings():
    missing = [m for p in checked_files()
               for m in undocumented(p.read_text(), p.relative_to(REPO).as_posix())]
    assert missing == []


def test_the_check_sees_what_it_should():
    files = [p.relative_to(REPO).parts[0] for p in checked_files()]
    # every layer, not a corner of one
    assert files.count("analysis") > 25 and files.count("drivers") > 10 \
        and files.count("nlid_lab") > 35, {layer: files.count(layer) for layer in LAYERS}
    assert all((REPO / p).is_file() for p in PENDING)         # no stale exclusion
    assert all((REPO / d).is_dir() for d in PENDING_DIRS)
    source = ("def f():\n    pass\n\n\ndef _private():\n    pass\n\n\n"
              "class C:\n    \"\"\"Doc.\"\"\"\n\n    def m(self):\n        return 1\n\n"
              "    @property\n    def p(self):\n        \"\"\"Doc.\"\"\"\n")
    assert undocumented(source, "x.py") == ["x.py:1 f", "x.py:12 C.m"]
