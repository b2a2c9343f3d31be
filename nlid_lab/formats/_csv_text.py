"""The text of a CSV export: its ``# key = value`` lines, the header and data rows after any
preamble (delimiter and decimal comma recognised), and the checks of what a cut write leaves
behind (docs/recording-formats.md).
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._recording_keys import RecordingFileError

MAX_CSV_BYTES = 2**31  # a CSV recording is read into memory whole


def csv_table(text: str, path: Path) -> tuple[list[str], np.ndarray]:
    """Header names and data of a CSV export: comment lines (``#``) and any preamble before
    the header are skipped; the delimiter (``,``, ``;`` or tab) and a decimal comma are
    recognised from the first data row."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    for h in range(len(lines) - 1):
        for delim in (",", ";", "\t"):
            first = lines[h + 1].split(delim)
            names = next(csv.reader([lines[h]], delimiter=delim))
            if len(first) < 2 or len(first) != len(names):
                continue
            decimal_comma = delim != "," and any("," in c for c in first)
            try:
                [float(c.replace(",", ".") if decimal_comma else c) for c in first]
            except ValueError:
                continue
            body = lines[h + 1:]
            if decimal_comma:
                body = [ln.replace(",", ".") for ln in body]
            if len(body) < 2:
                break
            rows = _Rows(text, body, delim, len(names), path, h + 1)
            rows.check_fields()
            rows.check_last_text()
            try:
                data = np.loadtxt(io.StringIO("\n".join(body)), delimiter=delim, ndmin=2)
            except ValueError as exc:
                raise RecordingFileError(f"{path}: bad number in the data ({exc}); fix or "
                                         "delete that row") from None
            rows.check_last(data)
            return names, data
    raise RecordingFileError(f"{path}: needs a header row and at least two data rows of "
                             "numbers (comma, semicolon or tab separated) after any preamble")


_FIELD = re.compile(r"^\s*[+-]?\d*(\.(\d*))?([eE][+-]?(\d*))?\s*$")


@dataclass
class _Rows:
    """The data rows of a CSV table and the checks of what a cut write leaves behind.

    An exporter writes a row's fields left to right and its newline last, so a file cut while
    being written ends in a row without a newline whose last field is the prefix of a number:
    it lost, in this order, its exponent digits, its exponent, its fraction digits, its
    decimal point. Rows are otherwise never cut. The rule (`check_last`): a last row without
    a newline must hold every field, and its last field must be written as fully as the least
    complete nonzero field of its column elsewhere (decimal point, fraction and exponent
    digits; ``%g`` writes a zero as ``0``) and
    lie within ten times that column's largest magnitude (a lost exponent ``e-05`` makes the
    value 1e5 too large, a lost exponent digit as much as 1e9). A cut losing fraction digits
    only, in a column written with varying precision, changes one sample below its last kept
    digit and stays undetectable.
    """

    text: str
    body: list[str]
    delim: str
    n: int
    path: Path
    offset: int       # rows of the file before the first data row (blank and # lines aside)

    def check_fields(self) -> None:
        """Every row has the header's number of fields (a cut row has fewer)."""
        counts = np.fromiter((ln.count(self.delim) for ln in self.body), int, len(self.body))
        bad = np.flatnonzero(counts != self.n - 1)
        if not bad.size:
            return
        i = int(bad[0])
        where = f"line {self._line(i)}"
        if i == len(self.body) - 1:
            raise RecordingFileError(f"{self.path}: {where}, the last, has {counts[i] + 1} of "
                                     f"{self.n} fields: the file looks cut; export it again "
                                     "or delete that line")
        raise RecordingFileError(f"{self.path}: {where} has {counts[i] + 1} fields but the "
                                 f"header names {self.n}; fix or delete that line")

    @property
    def unterminated(self) -> bool:
        """Whether the last row has no newline (the one row a cut write leaves)."""
        return not self.text.rstrip(" \t").endswith(("\n", "\r"))

    def check_last_text(self) -> None:
        """Refuse an unterminated last row whose last field is no number (``-``, ``1e``)."""
        if not self.unterminated:
            return
        last = self.body[-1].rsplit(self.delim, 1)[-1].strip()
        try:
            float(last)
        except ValueError:
            self._cut(last, "not a number")

    def check_last(self, data: np.ndarray) -> None:
        """Refuse an unterminated last row whose last field looks cut (`_Rows`)."""
        if not self.unterminated:
            return
        last = self.body[-1].rsplit(self.delim, 1)[-1].strip()
        why = self._incomplete(last, data[:-1, -1])
        column = np.abs(data[:-1, -1])
        if why is None and not abs(data[-1, -1]) <= 10 * column.max():
            why = (f"{data[-1, -1]:.4g} is over ten times the column's largest value "
                   f"{column.max():.4g} elsewhere")
        if why is not None:
            self._cut(last, why)

    def _cut(self, last: str, why: str) -> None:
        raise RecordingFileError(
            f"{self.path}: line {self._line(len(self.body) - 1)}, the last, ends without a "
            f"newline and its last number '{last}' looks cut ({why}); export the file "
            "again, or delete that line (end it with a newline if it is whole)")

    def _incomplete(self, last: str, column: np.ndarray) -> str | None:
        """What ``last`` lacks that every other nonzero field of its column (values
        ``column``) has, if anything; zeros say nothing of the format (``%g`` writes ``0``)."""
        others = [_FIELD.match(ln.rsplit(self.delim, 1)[-1])
                  for ln, value in zip(self.body[:-1], column) if value != 0]
        mine = _FIELD.match(last)
        if mine is None or not others or any(m is None for m in others):
            return None  # not plain numbers: loadtxt has read them, nothing to compare

        def size(m: re.Match, k: int) -> int:   # groups 1, 3: present; 2, 4: digit count
            part = m.group(k) or ""
            return min(len(part), 1) if k in (1, 3) else len(part)

        for k, name in ((1, "decimal point"), (2, "fraction digits"), (3, "exponent"),
                        (4, "exponent digits")):
            if size(mine, k) < min(size(m, k) for m in others):
                return f"fewer {name} than every other number of its column" if k in (2, 4) \
                    else f"no {name}, which every other number of its column has"
        return None

    def _line(self, i: int) -> int:
        """The file line number (1-based) of data row ``i``."""
        want, seen = self.offset + i, -1
        for number, line in enumerate(self.text.splitlines(), 1):
            if line.strip() and not line.lstrip().startswith("#"):
                seen += 1
                if seen == want:
                    return number
        return self.text.count("\n") + 1



_CSV_KEY = re.compile(r"^\s*#\s*([A-Za-z_]\w*)\s*=\s*(.*?)\s*$")


def csv_keys(text: str, path: Path) -> dict[str, np.ndarray]:
    """Recording keys of ``# key = value`` comment lines: numbers, or strings in quotes."""
    keys: dict[str, np.ndarray] = {}
    for line in text.splitlines():
        m = _CSV_KEY.match(line)
        if not m:
            continue
        key, raw = m.groups()
        if key in ("force", "response", "freqs"):
            raise RecordingFileError(f"{path}: '{key}' comes from the CSV header and data, not "
                                     "from a '# key = value' line; remove that line")
        if len(raw) >= 2 and raw[0] == raw[-1] == '"':
            keys[key] = np.str_(raw[1:-1])
            continue
        if raw.startswith("[") and raw.endswith("]"):        # a list of integers
            try:
                keys[key] = np.array([int(v) for v in raw[1:-1].split(",")])
                continue
            except ValueError:
                pass
        for cast in (int, float):
            try:
                keys[key] = np.asarray(cast(raw))
                break
            except ValueError:
                pass
        else:
            keys[key] = np.str_(raw)
    return keys
