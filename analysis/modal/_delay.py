"""Delay of the response channels behind the force, read off a modal fit's poles.

A DAQ whose anti-alias filters differ between the force and the response channels (a group
delay of a sample or so) multiplies every measured FRF by ``exp(-i w tau)``. The poles
survive it (the stabilisation diagram finds them), but no sum of modes holds the phase ramp:
on the artifact twin of `tests/daq_twin.py` (one-sample delay at fs 512 Hz, modes at 15 and
36 Hz) the written model missed the FRFs by 49 % / 35 % with the right modes. With the poles
fixed, a real-mode FRF is linear in its (imaginary) residues and real residual terms, so the
delay is the one that leaves the least-squares residual of ``H exp(i w tau)`` smallest (a
grid over +-`MAX_DELAY` samples, each point one linear solve). The residual's profile over
that grid gives the delay's confidence interval (the delays an F test with one parameter does
not tell from the least-residual one), and the interval the resolution it is stated to.
"""

from __future__ import annotations

from dataclasses import dataclass

from typing import Callable

import numpy as np
import scipy.ndimage
import scipy.optimize
import scipy.stats

#: largest delay searched, samples (anti-alias group delays differ by a few samples at most)
MAX_DELAY = 3.0
#: grid step of the search, samples
STEP = 0.01
#: significance of the F test that keeps a delay (one parameter more than none)
ALPHA = 1e-3
#: tolerance of the least-residual delay and of its interval's ends, samples
TOL = 1e-4
#: lines over which the noise's standard deviation is smoothed (running median) for weights
SMOOTH = 9
#: confidence of the stated interval (the profile F test, one parameter)
LEVEL = 0.95


@dataclass(frozen=True)
class DelayReading:
    """The responses' delay behind the force read off a modal fit, with its interval.

    Attributes
    ----------
    samples : float
        The least-residual delay, samples (the grid's parabola); 0 when not significant.
    low, high : float
        Its `LEVEL` confidence interval, samples: the delays whose residual the F test (one
        parameter) does not tell from the least one; ``(0, 0)`` when no delay was read.
    """

    samples: float = 0.0
    low: float = 0.0
    high: float = 0.0

    @property
    def stated(self) -> float:
        """The delay to the resolution the data carry: the decimal with the fewest digits
        (whole samples first, at most those of `TOL`) inside the interval, nearest
        ``samples``."""
        for digits in range(int(round(-np.log10(TOL))) + 1):
            value = round(self.samples, digits)
            if self.low <= value <= self.high:
                return float(value) if digits else float(int(value))
        return self.samples

    @property
    def resolved(self) -> bool:
        """Whether the interval excludes no delay (a run worth re-importing aligned)."""
        return self.low > 0 or self.high < 0

    def text(self) -> str:
        """The delay in words, stated to its resolution with its 95 % interval ("" when none
        was read): what the fit-linear summary line and the report say."""
        if not self.samples:
            return ""
        n = self.stated
        way = "lag" if n > 0 else "lead"
        digits = max(2, len(f"{n:g}".partition(".")[2]) + 1)     # one more than the statement's
        return (f"the responses {way} the force by {abs(n):g} sample{'s' * (abs(n) != 1)} "
                f"(95 % interval {self.low:.{digits}f} to {self.high:.{digits}f}; the channels' "
                "anti-alias filters differ?)")


def response_delay(freqs: np.ndarray, H: np.ndarray, std: np.ndarray | None,
                   poles: np.ndarray, fs: float) -> DelayReading:
    """Delay of the responses behind the force with its interval (none unless significant).

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Lines of the fit band, Hz.
    H : ndarray, complex, shape (n_f, n_out)
        Measured receptance column.
    std : ndarray, shape (n_f, n_out), optional
        Its noise standard deviation (weights); unit weights when None.
    poles : ndarray, complex, shape (n_modes,)
        Poles of a modal fit of ``H`` (rad/s).
    fs : float
        Sample rate, Hz.

    Returns
    -------
    DelayReading
        The ``tau`` minimising the weighted residual of ``H exp(i 2 pi f tau / fs)`` fitted
        by real modes (imaginary residues) plus real ``L / s^2 + U0 + U2 s^2``, and the
        profile interval around it; empty when its F test against ``tau = 0`` (one
        parameter, `ALPHA`) fails.
    """
    s = 2j * np.pi * np.asarray(freqs, dtype=float)
    g = 1 / (s[:, None] - poles[None, :])
    gc = 1 / (s[:, None] - np.conj(poles)[None, :])
    # real modes (what the written model holds): imaginary residues on conjugate poles, real
    # residual terms; free complex residues would rotate each mode's phase and absorb most of
    # the ramp (1 % noise then moved a one-sample delay by 0.2-0.3 samples)
    basis = np.column_stack([1j * (g - gc), 1 / s ** 2, np.ones_like(s), s ** 2])
    w = np.ones(H.shape) if std is None else 1 / np.maximum(
        scipy.ndimage.median_filter(std, size=(SMOOTH, 1), mode="nearest"),
        1e-300 + 1e-12 * np.abs(H))
    taus = np.arange(-MAX_DELAY, MAX_DELAY + STEP / 2, STEP)

    def rss_at(tau: float) -> float:
        return _rss(basis, H * np.exp(s * tau / fs)[:, None], w)
    rss = np.array([rss_at(tau) for tau in taus])
    best = int(np.argmin(rss))
    zero = int(np.argmin(np.abs(taus)))
    dof = 2 * H.size - basis.shape[1] * H.shape[1] - 1
    if dof <= 0 or rss[best] <= 0:
        return DelayReading()
    if (rss[zero] - rss[best]) / (rss[best] / dof) <= scipy.stats.f.ppf(1 - ALPHA, 1, dof):
        return DelayReading()
    near = taus[max(best - 1, 0)], taus[min(best + 1, taus.size - 1)]
    opt = scipy.optimize.minimize_scalar(rss_at, bounds=near, method="bounded",
                                         options={"xatol": TOL})
    tau, least = float(opt.x), min(float(opt.fun), float(rss[best]))
    # the profile interval: the delays an F test (one parameter) does not tell from ``tau``
    limit = least + scipy.stats.f.ppf(LEVEL, 1, dof) * least / dof
    return DelayReading(tau, *(_crossing(rss_at, taus, rss, tau, limit, side)
                               for side in (-1, 1)))


def _crossing(rss_at: Callable[[float], float], taus: np.ndarray, rss: np.ndarray,
              tau: float, limit: float, side: int) -> float:
    """The delay on ``side`` (-1, +1) of ``tau`` where the residual ``rss_at`` first exceeds
    ``limit``: bracketed by the first grid point beyond it (``taus``, ``rss``), then Brent's
    root; the grid's end when the residual stays below."""
    beyond = np.flatnonzero((rss > limit) & (side * (taus - tau) > 0))
    if beyond.size == 0:
        return float(taus[0] if side < 0 else taus[-1])
    edge = float(taus[beyond[-1] if side < 0 else beyond[0]])
    if rss_at(tau) >= limit:
        return tau
    return float(scipy.optimize.brentq(lambda t: rss_at(t) - limit, tau, edge, xtol=TOL))


def _rss(basis: np.ndarray, H: np.ndarray, w: np.ndarray) -> float:
    """Weighted residual sum of squares of the fit of each column of ``H`` by real
    combinations of the (complex) ``basis`` columns."""
    total = 0.0
    for j in range(H.shape[1]):
        a = basis * w[:, j, None]
        b = H[:, j] * w[:, j]
        a2, b2 = np.concatenate([a.real, a.imag]), np.concatenate([b.real, b.imag])
        coef = np.linalg.lstsq(a2, b2, rcond=None)[0]
        total += float(np.sum((a2 @ coef - b2) ** 2))
    return total
