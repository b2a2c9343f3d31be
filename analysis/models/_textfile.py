"""Reading small text input files (model and campaign TOML, CSV) with bounded work.

A path that names a device, pipe or directory, or a file larger than the caller's bound, is
refused before anything is read: ``/dev/zero`` or a multi-gigabyte file given by mistake must
end in a one-line error, not in a read that never finishes.
"""

from __future__ import annotations

import difflib
import os
import re
import stat
import tomllib
from collections.abc import Iterable
from pathlib import Path

from ..errors import InputError

MAX_TOML_BYTES = 16 * 2**20  # a model or campaign file; the largest example is a few kB
MAX_TOML_DEPTH = 32  # nested arrays/inline tables; a model matrix needs 2, a campaign 3


def read_text(path: str | os.PathLike, what: str, error: type[InputError] = InputError,
              max_bytes: int = MAX_TOML_BYTES) -> str:
    """Return the UTF-8 text of the regular file ``path``.

    Parameters
    ----------
    path : str or path-like
    what : str
        What the file is, for the messages ("model file", "campaign file").
    error : type
        `InputError` subclass raised for every problem (missing, not a regular file, larger
        than ``max_bytes``, unreadable, not UTF-8).
    max_bytes : int
        Largest accepted size.

    Returns
    -------
    str
    """
    path = Path(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise error(f"{what} {path} not found; check the path") from None
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{what} {path} is not a regular file (a directory, device or pipe); "
                    "give the path of a file")
    if info.st_size > max_bytes:
        raise error(f"{what} {path} holds {info.st_size} bytes, more than the {max_bytes} "
                    f"a {what} may have; check the path")
    try:
        with open(path, "rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if len(data) > max_bytes:
        raise error(f"{what} {path} grew beyond {max_bytes} bytes while being read")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{what} {path} is not UTF-8 text ({exc.reason} at byte {exc.start}); "
                    "save it as UTF-8") from None


def parse_toml(text: str, what: str, error: type[InputError] = InputError) -> dict:
    """The TOML document ``text``, its nesting depth bounded before it is parsed.

    Parameters
    ----------
    text : str
    what : str
        What the text is, for the messages ("model file m.toml").
    error : type
        `InputError` subclass raised for invalid TOML or too deep nesting.

    Returns
    -------
    dict
    """
    depth, line = toml_depth(text)
    if depth > MAX_TOML_DEPTH:
        raise error(f"{what}: arrays or inline tables nested {depth} deep on line {line}, "
                    f"more than the {MAX_TOML_DEPTH} any of our formats needs; check that "
                    "line's brackets")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{what}: not valid TOML ({exc}); fix the syntax") from None


# strings (which may hold brackets), comments, and the brackets themselves
_TOML_TOKEN = re.compile(r'"""(?:[^"\\]|\\.|"(?!""))*"{3,5}|\'\'\'.*?\'{3,5}'
                         r'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*|[\[\]{}]', re.S)


def toml_depth(text: str) -> tuple[int, int]:
    """Deepest nesting of ``[`` / ``{`` outside strings and comments, and its line (1-based).

    Scanned by hand because tomllib parses each level by recursion with no bound of its own
    (RecursionError past ~1000 levels); this linear scan bounds the depth first. Unbalanced or
    invalid text is left for tomllib to report.
    """
    depth = deepest = where = 0
    for m in _TOML_TOKEN.finditer(text):
        tok = m.group()
        if tok in ("[", "{"):
            depth += 1
            if depth > deepest:
                deepest, where = depth, m.start()
        elif tok in ("]", "}"):
            depth = max(depth - 1, 0)
    return deepest, text.count("\n", 0, where) + 1


def nearest(word: str, choices: Iterable[str]) -> str | None:
    """The choice closest to ``word`` (case-insensitive), if any is close."""
    lower = {c.lower(): c for c in choices}
    near = difflib.get_close_matches(word.lower(), list(lower), n=1, cutoff=0.6)
    return lower[near[0]] if near else None


def unknown_keys(given: Iterable[str], allowed: Iterable[str], where: str,
                 noun: str = "key") -> str | None:
    """Message naming the first key of ``given`` outside ``allowed`` and the nearest valid
    key (a typo is an error, not an ignored setting), or None if every key is allowed."""
    allowed = list(allowed)
    for key in given:
        if key in allowed:
            continue
        hint = f"did you mean '{near}'? " if (near := nearest(str(key), allowed)) else ""
        return f"{where}: unknown {noun} '{key}'; {hint}valid {noun}s: {', '.join(allowed)}"
    return None
