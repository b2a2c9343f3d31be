"""Writing command outputs: the no-overwrite guard and JSON results.

Every command that writes a file checks its targets with `refuse_overwrite` before it starts
working, so that an existing file is never replaced without ``--force`` (the command exits 2
with one line naming the file, and the file is left as it was). ``-`` (stdout) is never a file.
A directory target (``report --out DIR``) is refused when it exists and is not empty.
Commands print a summary for people on `summary_stream` (stderr with ``--json -``, nothing
with ``--quiet``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from analysis.errors import InputError

STDOUT = "-"


class OverwriteError(InputError):
    """An output file exists and ``--force`` was not given."""


def add_force_option(p: argparse.ArgumentParser) -> None:
    """The ``--force`` option of a command that writes files."""
    p.add_argument("--force", action="store_true",
                   help="replace output files that already exist (default: refuse)")


def add_quiet_option(p: argparse.ArgumentParser) -> None:
    """The ``--quiet`` option of a command that prints a summary of its result."""
    p.add_argument("-q", "--quiet", action="store_true",
                   help="print no summary and no progress (errors still go to stderr; "
                   "--json keeps the result)")


class _Discard:
    """A text stream that drops what is written (``--quiet``)."""

    def write(self, text: str) -> int:
        return len(text)

    def flush(self) -> None:
        pass


def summary_stream(json_dest: str | None, quiet: bool = False) -> TextIO:
    """Where a command prints its summary for people: stdout, or stderr when ``--json -``
    holds stdout (which then stays pure JSON); nowhere with ``--quiet``."""
    if quiet:
        return _Discard()  # type: ignore[return-value]
    return sys.stderr if json_dest == STDOUT else sys.stdout


def refuse_overwrite(force: bool, *targets: str | Path | None,
                     directories: tuple[str | Path | None, ...] = ()) -> None:
    """Raise `OverwriteError` if a target file (or a non-empty target directory) exists.

    ``None`` and ``-`` (stdout) targets are skipped; nothing is checked when ``force``.
    """
    if force:
        return
    for target in targets:
        if target is None or str(target) == STDOUT:
            continue
        path = Path(target)
        if path.is_dir():
            raise OverwriteError(f"{path} is a directory; give a file name")
        if path.exists():
            raise OverwriteError(f"{path} already exists; pass --force to replace it, or "
                                 "choose another name")
    for target in directories:
        if target is None:
            continue
        path = Path(target)
        if path.exists() and (not path.is_dir() or any(path.iterdir())):
            raise OverwriteError(f"{path} already exists and is not an empty directory; pass "
                                 "--force to write into it (files of the same name are "
                                 "replaced), or choose another directory")


def level_text(level: float | None) -> str:
    """A nominal level for people: ``30`` or ``unknown`` (recordings imported without one)."""
    return "unknown" if level is None else f"{level:g}"


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def write_json(result: dict[str, Any], dest: str | None) -> None:
    """Write a command's machine-readable result to ``dest`` (``-`` for stdout).

    The caller checked ``dest`` with `refuse_overwrite` before doing its work.
    """
    if not dest:
        return
    text = json.dumps(result, indent=2, default=_jsonable, allow_nan=False)
    if dest == STDOUT:
        print(text)
    else:
        Path(dest).write_text(text + "\n")
