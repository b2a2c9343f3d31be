"""JSON field helpers of the diagnosis result types (`._result`, `._evidence`)."""

from __future__ import annotations

from typing import Any

Json = dict[str, Any]


def opt(cls: Any, data: Json | None) -> Any:
    """``cls.from_json(data)``, None for None."""
    return None if data is None else cls.from_json(data)


def pair(v: Any) -> tuple[float, float] | None:
    """A JSON pair as a tuple, None for None."""
    return None if v is None else (v[0], v[1])


def as_list(v: Any) -> list | None:
    """A JSON array as a list, None for None."""
    return None if v is None else list(v)
