"""A stepped-sine table twin: an SDOF with a Jenkins joint (spring ``kd`` in series with a
slider of force ``fd``) in single-harmonic balance, its closed-form describing function
(Caughey 1960), under response or force control. The backbone it implies is known exactly:
``wn(a)^2 = (k + Re N(a)) / m`` and ``zeta(a) = (c wn + Im N(a)) / (2 m wn^2)``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.recordings import StepTable


@dataclass(frozen=True)
class JenkinsSDOF:
    """The twin's parameters (SI)."""

    m: float = 1.0
    k: float = (2 * np.pi * 80.0) ** 2
    c: float = 2 * 0.0015 * 2 * np.pi * 80.0
    kd: float = 2.5e4
    fd: float = 0.75

    def describing(self, a: np.ndarray) -> np.ndarray:
        """First-harmonic stiffness ``N(a)`` of the Jenkins element (complex: Im = loss)."""
        a = np.asarray(a, dtype=float)
        d = self.fd / self.kd
        out = np.full(a.shape, complex(self.kd))
        slip = a > d
        b = np.arccos(1 - 2 * d / a[slip])
        out[slip] = (self.kd / np.pi * (b - np.sin(2 * b) / 2)
                     + 1j * 4 * self.fd * (a[slip] - d) / (np.pi * a[slip] ** 2))
        return out

    def dynamic_stiffness(self, w: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Force per displacement amplitude at ``w`` with amplitude ``a``."""
        return self.k + self.describing(a) - self.m * w**2 + 1j * self.c * w

    def backbone_at(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact natural frequency (Hz) and damping ratio at displacement amplitude ``a``."""
        N = self.describing(a)
        wn = np.sqrt((self.k + N.real) / self.m)
        return wn / (2 * np.pi), (self.c * wn + N.imag) / (2 * self.m * wn**2)

    def held_acceleration(self, level: float, freqs: np.ndarray) -> StepTable:
        """A response-controlled table holding the acceleration amplitude ``level``."""
        w = 2 * np.pi * np.asarray(freqs, dtype=float)
        a = level / w**2
        force = self.dynamic_stiffness(w, a) * a
        return StepTable(freqs, force[:, None], (-(w**2) * a)[:, None], [0], "response",
                         level, response_kind="acceleration", control_dof=0)

    def held_force(self, level: float, freqs: np.ndarray) -> StepTable:
        """A force-controlled table at force amplitude ``level`` (the stable branch of
        each step, solved for the displacement amplitude by bisection on |F(a)| = level)."""
        w = 2 * np.pi * np.asarray(freqs, dtype=float)
        a = np.empty_like(w)
        for i, wi in enumerate(w):
            lo, hi = 0.0, 10 * level / (self.c * wi)
            for _ in range(64):           # |F(a)| grows with a on the stable branch
                mid = (lo + hi) / 2
                lo, hi = (mid, hi) if abs(self.dynamic_stiffness(wi, np.array([mid]))[0]
                                          * mid) < level else (lo, mid)
            a[i] = (lo + hi) / 2
        x = np.conj(self.dynamic_stiffness(w, a)) / np.abs(self.dynamic_stiffness(w, a)) * a
        return StepTable(freqs, np.full((w.size, 1), level, complex), (-(w**2) * x)[:, None],
                         [0], "force", level, response_kind="acceleration")

    def resonance_amplitude(self, level: float) -> float:
        """Displacement amplitude at resonance under held acceleration ``level``."""
        a = level / (2 * np.pi * 80.0) ** 2
        for _ in range(100):                        # fixed point: a = level / wn(a)^2
            a = level / (2 * np.pi * self.backbone_at(np.array([a]))[0][0]) ** 2
        return float(a)
