"""White sensor noise of a random record, read below the drive band, carried into the
displacement and velocity the diagnosis forms from it.

A candidate's force evaluated on the measured deformation holds the sensor noise: ``E[(u +
e)^3 | u] = u^3 + 3 s2 u``, a stiffness-like term that biases the fitted coefficient low
(errors in variables). For a doubly integrated accelerometer record the noise variance ``s2``
grows as ``1/f^4`` towards the band's lower edge (the integration's high-pass). The white
floor above the band is unreadable on strongly nonlinear levels (the element's harmonics
fill it: zoo `chain-cubic01-acc-random` at 12 N, 250-340x the floor); below the band, where
the force has no content, the response is sensor noise alone (measured there: 0.90-1.10x the
true floor at 1, 4 and 12 N). `floor_below_band` reads it there; `kinematic_noise` carries it
through the brick-wall integration of `analysis.recordings.change_kind`.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import welch

from ..models import KINDS, LIBRARY
from ..recordings import KIND_ORDER

QUIET_FORCE = 1e-3
"""The force's power below the band over its in-band median under which the response there
is read as sensor noise alone (a drive band-limited at its source; a shaker's residual
force below the band moves the structure and the floor is not read)."""

LINES = (0.15, 0.85)
"""Part of the band's lower edge over which the floor is averaged (clear of DC and of the
window leakage of the in-band response)."""

MIN_LINES = 8


def floor_below_band(force: np.ndarray, response: np.ndarray, fs: float,
                     band: tuple[float, float]) -> np.ndarray | None:
    """One-sided white noise PSD of each response channel (its unit squared per Hz), read
    below ``band`` where the force is quiet; None when the band starts too low to resolve
    `MIN_LINES` lines below it or the force is not quiet there.

    Parameters
    ----------
    force : ndarray, shape (n, n_in)
    response : ndarray, shape (n, n_dof)
        In its recorded kind, DC removed.
    fs : float
    band : (lo, hi)
        Drive band, Hz.
    """
    n = response.shape[0]
    nperseg = 1 << int(np.ceil(np.log2(MIN_LINES * 2 * fs / band[0])))
    if band[0] <= 0 or nperseg > n // 4:
        return None
    f, pf = welch(force, fs=fs, nperseg=nperseg, axis=0)
    _, pr = welch(response, fs=fs, nperseg=nperseg, axis=0)
    below = (f >= LINES[0] * band[0]) & (f <= LINES[1] * band[0])
    inside = (f >= band[0]) & (f <= band[1])
    if below.sum() < MIN_LINES or not inside.any():
        return None
    if np.any(pf[below].mean(axis=0) > QUIET_FORCE * np.median(pf[inside], axis=0)):
        return None
    return pr[below].mean(axis=0)


def kinematic_noise(floor: np.ndarray, kind: str, highpass: float, lowpass: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Noise variance of the displacement and velocity formed from a ``kind`` record with
    white noise ``floor`` (one-sided PSD per channel) by `analysis.recordings.change_kind`
    (gain ``(2 pi f)^order`` on the lines from ``highpass`` to ``lowpass``, zero outside)."""
    k = KIND_ORDER[kind]

    def through(m: int) -> float:   # integral of (2 pi f)^m over the kept lines, m even
        a = max(highpass, 1e-12 if m < 0 else 0.0)
        return float((2 * np.pi) ** m * (lowpass ** (m + 1) - a ** (m + 1)) / (m + 1))
    return floor * through(-2 * k), floor * through(2 * (1 - k))


def noise_bias(kind: str, params: dict[str, float], w: np.ndarray, u: np.ndarray,
               v: np.ndarray, noise: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray | float:
    """Conditional bias of a ``kind`` element's force along the measured ``u = w.x``, ``v``
    from the white sensor noise in them (``noise``: variance per DOF of ``x`` and ``v``),
    to be subtracted: the coefficient times its basis's `analysis.models.Basis.debias`
    (``3 s2 u`` for a cubic). Zero when the noise was not read, for memory kinds and for
    kinds without a known correction (gaps, friction)."""
    spec = KINDS[kind]
    basis = LIBRARY.get(spec.basis or "")
    if noise is None or spec.memory or spec.basis_arg is not None or basis is None \
            or basis.debias is None:
        return 0.0
    x_var, v_var = noise
    s2 = float(np.sum(np.asarray(w) ** 2 * (x_var if basis.variable == "x" else v_var)))
    return params[spec.coef] * basis.debias(u if basis.variable == "x" else v, s2)
