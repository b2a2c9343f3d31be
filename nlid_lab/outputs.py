"""Writing command outputs: the no-overwrite guard, whole-or-nothing files and JSON results.

Every command that writes a file checks its targets with `refuse_overwrite` before it starts
working, so that an existing file is never replaced without ``--force`` (the command exits 2
with one line naming the file, and the file is left as it was). ``-`` (stdout) is never a file.
A directory target (``report --out DIR``) is refused when it exists and is not empty.
Every output is written through `atomic_path` (a directory of files through `atomic_dir`):
to a temporary name in the same directory, renamed over the target only when whole, so that a
full disk or a failure leaves the old file (or none), never half a file; a full disk is one
line naming the file (exit 2).
Commands print a summary for people on `summary_stream` (stderr with ``--json -``, nothing
with ``--quiet``).
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import json
import os
import shutil
import sys
from pathlib import Path
from typing import Any, Iterator, Sequence, TextIO

import numpy as np

from analysis.documents import JsonObject
from analysis.errors import InputError

STDOUT = "-"


class OverwriteError(InputError):
    """An output file exists and ``--force`` was not given."""


class OutputFullError(InputError):
    """The disk had no room for an output file; nothing was written."""


def _temporary(target: Path) -> Path:
    """A hidden name beside ``target`` keeping its suffix (writers choose formats by it)."""
    return target.with_name(f".{target.stem}.part-{os.getpid()}{target.suffix}")


def _full(target: Path, exc: OSError) -> OutputFullError:
    return OutputFullError(f"no room on the disk for {target} ({exc.strerror}); nothing was "
                           "written: free space or write to another disk")


def _is_full(exc: BaseException) -> bool:
    """A full disk or quota, as an OSError or as the text of a library's error."""
    return (isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)) \
        or "No space left" in str(exc) or "errno = 28," in str(exc)


@contextlib.contextmanager
def atomic_path(target: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``target`` to write the output to; when the ``with``
    body ends without error it is renamed over ``target`` (atomic on one file system),
    otherwise it is removed and ``target`` left as it was. A full disk becomes
    `OutputFullError`."""
    target = Path(target)
    tmp = _temporary(target)
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if _is_full(exc):
            raise _full(target, exc if isinstance(exc, OSError) else
                        OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))) from None
        if isinstance(exc, OSError) and exc.filename == str(tmp):
            exc.filename = str(target)      # name the file the user asked for
        raise


@contextlib.contextmanager
def atomic_dir(target: str | Path) -> Iterator[Path]:
    """Like `atomic_path` for a directory of files (a report): written into a temporary
    directory beside ``target``; when whole, renamed to ``target`` (an empty or missing
    one), or its files moved into ``target`` (``--force`` into a full one; renames need no
    room). On error the temporary directory is removed and ``target`` left as it was."""
    target = Path(target)
    tmp = _temporary(target)
    tmp.mkdir(parents=True, exist_ok=True)
    try:
        yield tmp
        if target.is_dir() and not any(target.iterdir()):
            target.rmdir()
        if not target.exists():
            os.replace(tmp, target)
            return
        for item in sorted(tmp.iterdir(), key=lambda p: p.suffix == ".html"):  # page last
            if (target / item.name).is_dir():
                shutil.rmtree(target / item.name)
            os.replace(item, target / item.name)
        tmp.rmdir()
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if _is_full(exc):
            raise _full(target, exc if isinstance(exc, OSError) else
                        OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))) from None
        raise


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


def write_json(result: JsonObject, dest: str | None) -> None:
    """Write a command's machine-readable result to ``dest`` (``-`` for stdout).

    The caller checked ``dest`` with `refuse_overwrite` before doing its work.
    """
    if not dest:
        return
    text = json.dumps(result, indent=2, default=_jsonable, allow_nan=False)
    if dest == STDOUT:
        print(text)
    else:
        with atomic_path(dest) as tmp:
            tmp.write_text(text + "\n")


def with_checks(result: JsonObject, checks: Sequence[Any]) -> JsonObject:
    """``result`` with the data checks of its input runs (`nlid_lab.store.RunCheck`, from
    `nlid_lab.commands.repair.check_runs`) under ``"data_checks"``: each run's status,
    blocks stored and planned, whether it is incomplete, and the blocks left out and why."""
    return {**result, "data_checks": [c.to_json() for c in checks]}
