"""Nonlinearity detection from data alone (level dependence of H1 and of stepped-sine FRFs, BLA
distortion, swept-sine tests). Its own room: it builds on the diagnosis' level preparation,
which itself builds on the spectral room.

Modules behind this API: ``_detect``, ``_detect_sweep``. Code inside this package imports its
siblings by their private module path.
"""

from ._detect import bla_summary, detect, level_change

__all__ = ["bla_summary", "detect", "level_change"]
