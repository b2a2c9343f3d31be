"""Where a structure meets the ground: a model file's ``[support]`` table."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..errors import ModelError
from ._model_file import check_keys, point_index, short, toml_str

SUPPORT_KEYS = ("points", "free")


@dataclass(frozen=True)
class Support:
    """Where the structure meets the ground (a model file's ``[support]``, contracts section 7).

    Parameters
    ----------
    points : tuple of int
        Indices of the points held by the supports (``[support] points = [...]``).
    free : bool
        A free or suspended structure: no point is held (``[support] free = true``).
    """

    points: tuple[int, ...] = ()
    free: bool = False

    def toml(self, names: list[str]) -> list[str]:
        """The ``[support]`` table's lines."""
        if self.free:
            return ["", "[support]", "free = true"]
        held = ", ".join(toml_str(names[i]) for i in self.points)
        return ["", "[support]", f"points = [{held}]"]


def support_table(raw: Any, names: list[str]) -> Support:
    """`Support` from a ``[support]`` table (exactly one of ``points`` and ``free``)."""
    check_keys(raw, SUPPORT_KEYS, "[support]")
    if len(raw) != 1:
        raise ModelError("[support] takes either points = [...] (the points held) or "
                         "free = true (a free or suspended structure)")
    if "free" in raw:
        if raw["free"] is not True:
            raise ModelError(f"[support] free = {short(raw['free'])}: write free = true, or "
                             "give points = [...] instead")
        return Support(free=True)
    pts = raw["points"]
    if not isinstance(pts, list) or not pts:
        raise ModelError(f"[support] points = {short(pts)} must list the points held, e.g. "
                         '["root"]')
    return Support(tuple(sorted({point_index(p, names, "[support] points") for p in pts})))
