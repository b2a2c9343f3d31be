"""What a running campaign tells its watchers (live view, progress, logs).

The campaign calls these methods from its acquisition thread; an observer must not block and
must not touch GUI widgets directly (the live view queues the data for the GUI thread).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np


class CampaignObserver(Protocol):
    def campaign_started(self, info: dict[str, Any]) -> None:
        """``info``: fs, excitation, force_dofs, n_dof, channel names and units, levels."""

    def block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        """A random-excitation block: force (n, n_in), response (n, n_dof)."""

    def step(self, level: int, index: int, freq: float, force: np.ndarray,
             response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        """A measured stepped-sine step; ``harmonics`` (n_harm, n_dof) complex amplitudes;
        ``control_error`` the relative force-amplitude error of the level control."""

    def campaign_finished(self, status: str) -> None:
        """``status``: complete, aborted or interrupted."""


class NullObserver:
    """Observer that ignores everything (the default)."""

    def campaign_started(self, info: dict[str, Any]) -> None:
        pass

    def block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        pass

    def step(self, level: int, index: int, freq: float, force: np.ndarray,
             response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        pass

    def campaign_finished(self, status: str) -> None:
        pass
