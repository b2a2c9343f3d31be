"""Nonlinearity detection from data alone (level dependence of H1 and of stepped-sine FRFs, BLA
distortion, swept-sine tests). Its own room: it builds on the diagnosis' level preparation,
which itself builds on the spectral room.

Modules behind this API: ``_detect``, ``_detect_sweep``, ``_result`` (the typed result and
its JSON). Code inside this package imports its
siblings by their private module path.
"""

from ._detect import LevelChange, bla_summary, detect, level_change
from ._result import (SCHEMA_VERSION, Detection, DetectionTest, Jumps, SweepJump, TestMethod,
                      Verdict)

__all__ = ["Detection", "DetectionTest", "Jumps", "LevelChange", "SCHEMA_VERSION", "SweepJump",
           "TestMethod", "Verdict", "bla_summary", "detect", "level_change"]
