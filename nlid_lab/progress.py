"""Progress bars for long commands (tqdm on stderr).

Bars show when stderr is a terminal; ``NLID_PROGRESS=1`` forces them on, ``0`` off.
"""

from __future__ import annotations

import os
from typing import Iterable, TypeVar

from tqdm.auto import tqdm

T = TypeVar("T")


def enabled() -> bool | None:
    """tqdm's ``disable`` argument for the current environment."""
    setting = os.environ.get("NLID_PROGRESS", "")
    if setting in ("0", "1"):
        return setting == "0"
    return None  # tqdm: disabled when stderr is not a terminal


def progress(iterable: Iterable[T] | None = None, *, total: float | None = None,
             desc: str | None = None, unit: str = "it", leave: bool = True) -> tqdm:
    """A tqdm bar over ``iterable`` (or a manual bar with ``total``; call ``.update(n)``)."""
    return tqdm(iterable, total=total, desc=desc, unit=unit, leave=leave,
                disable=enabled(), dynamic_ncols=True)
