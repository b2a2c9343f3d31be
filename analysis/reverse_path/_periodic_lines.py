"""Lines of periodic-random records: the period averages' inputs and outputs at the excited
lines, the per-line instrumental-variable estimate and the delete-one-realization jackknife
(`._periodic`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.ndimage
import scipy.stats

from .. import models as bas    # the reverse-path basis functions of a kind
from ..models import restoring_force
from ..recordings import period_spectra, periodic_kinematics
from ._documents import PeriodicStats
from ._iv import iv_transfer
from ._core import (EDGE_CAP, EDGE_RUN, EDGE_SNR, Z95, ReversePathResult, _alias_upsampling,
                    _coefficients, _force_span, _Processing)


TRANSIENT_LEVEL = 1e-3  # rms of a left-over transient, relative to the response, that warns


@dataclass
class _Formed:
    """Lines of one set of period averages: outputs ``X`` (M, n_f, n_dof), inputs ``R``."""

    X: np.ndarray
    R: np.ndarray


def _jackknife(result: ReversePathResult, X: np.ndarray, R: np.ndarray, Z: np.ndarray,
               n_real: int, fdofs: np.ndarray, unknown) -> None:
    """Delete-one-realization jackknife of every coefficient (in place).

    Realizations are independent replicates, so the jackknife sees every error source,
    including the correlation between lines that the noise on the bases causes (the
    line-based variance misses it). The interval is the wider of the line-based one and
    ``t_(M-1) x`` the jackknife standard error. The value is corrected for the leading
    ``1/M`` bias of the per-line IV (few realizations per line: weak-instrument bias towards
    H1, several percent for a deformation buried in noise), ``M p - (M-1) mean(p_-m)``.
    """
    if n_real - 1 <= R.shape[2] * n_real // X.shape[0]:
        return                                    # no residual degrees of freedom left
    vals = []
    for r in range(n_real):
        keep = np.ones(X.shape[0], dtype=bool)
        keep[r::n_real] = False                   # both halves of realization r
        H, cov, s2, _ = _lines_iv(X[keep], R[keep], Z[keep])
        vals.append([c.value for c in _coefficients(H, cov, s2, fdofs, unknown, 1.0)])
    vals = np.array(vals)
    mean = vals.mean(axis=0)
    std_j = np.sqrt((n_real - 1) / n_real * ((vals - mean) ** 2).sum(axis=0))
    t = float(scipy.stats.t.ppf(0.975, n_real - 1))
    for c, m, sj in zip(result.coefficients, mean, std_j):
        c.value = float(n_real * c.value - (n_real - 1) * m)
        half = max(Z95 * c.std, t * sj)
        c.std = float(max(c.std, sj))
        c.ci95 = (c.value - half, c.value + half)


def _lines_iv(X: np.ndarray, R: np.ndarray, Z: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]:
    """Per-line IV over observations (axis 0): transfer, row covariance, residual variance.

    ``H = S_XZ S_RZ^-1`` with sums over observations; the row covariance is
    ``sigma^2 A^H S_ZZ A`` (`iv_transfer`) with ``sigma^2`` the residual variance per
    observation. Also the median coherence of each input with its
    instrument.
    """
    S_xz = np.einsum("ofy,ofa->fya", X, Z.conj())
    S_rz = np.einsum("ofa,ofb->fab", R, Z.conj())
    S_zz = np.einsum("ofa,ofb->fab", Z, Z.conj())
    H, cov = iv_transfer(S_xz, S_rz, S_zz,
                         "the inputs are linearly dependent over the realizations at some "
                         "line (a repeated basis or an unexcited force); remove it")
    resid = X - np.einsum("fya,ofa->ofy", H, R)
    dof = X.shape[0] - R.shape[2]
    sigma2 = (np.abs(resid) ** 2).sum(axis=0) / dof
    s_rr = np.einsum("ofa,ofa->fa", R, R.conj()).real
    s_zz = np.einsum("faa->fa", S_zz).real
    coh = np.abs(np.einsum("faa->fa", S_rz)) ** 2 / (s_rr * s_zz)
    return H, cov, sigma2, np.median(coh, axis=0).tolist()


def _periodic_edge(sig: np.ndarray, noi: np.ndarray, fs: float, period: int,
                   band: tuple[float, float]) -> float:
    """Integration high-pass of a periodic record from its lines' signal over noise (the
    period spread): the lowest line of ``band`` from which every channel stands `EDGE_SNR`
    above its noise over `EDGE_RUN` lines, at most `EDGE_CAP` of the band's top."""
    f = np.fft.rfftfreq(period, 1 / fs)
    inband = (f >= band[0]) & (f <= band[1])
    ok = (sig >= EDGE_SNR * np.maximum(noi, 1e-300)).all(axis=1)[inband]
    run = np.convolve(ok, np.ones(EDGE_RUN), "valid") == EDGE_RUN
    first = f[inband][int(np.argmax(run))] if run.any() else band[1]
    return float(min(first, EDGE_CAP * band[1]))


def _periodic_inputs(proc: _Processing, fp: np.ndarray, yp: np.ndarray, idx: np.ndarray,
                     unknown, known, fdofs: np.ndarray, split: bool, warnings: list[str]
                     ) -> tuple[list[tuple[_Formed, np.ndarray]], _Formed, PeriodicStats]:
    """Lines of the half averages (A, B; with their smoothed instruments) and of the full
    average of one record.

    ``fp``, ``yp``: steady periods (M, P, N, ch) of force and response.
    """
    fs, n_p = proc.fs, yp.shape[1]
    rel, wiener = None, None
    if n_p >= 2:
        sig, noi = period_spectra(yp)
        # smoothed over ~1 % of the lines: single noise lines must not pass as signal
        width = max(9, sig.shape[0] // 100)
        sig, noi = (scipy.ndimage.uniform_filter1d(a, width, axis=0) for a in (sig, noi))
        # Wiener gain for a half average (noise P / (P // 2) times that of the full one);
        # it shapes the instruments only, so it biases nothing
        noi_half = noi * n_p / (n_p // 2)
        sig_half = sig + noi_half - noi
        wiener = np.maximum(sig_half - noi_half, 0.0) / np.maximum(sig_half, 1e-300)
        noise_std = np.sqrt(yp.var(axis=1, ddof=1).mean(axis=(0, 1)))
        rel = (noise_std / np.maximum(yp.std(axis=(0, 1, 2)), 1e-300)).tolist()
        _transient_check(yp, warnings)
    # as the Welch route does: integrated records lose the lines below half the band, and
    # those where the averaged record is under 10x its noise (`_core.noise_edge`)
    hp = proc.band[0] / 2 if proc.kind != "displacement" else 0.0
    if hp and n_p >= 2:
        hp = max(hp, _periodic_edge(sig, noi, fs, yp.shape[2], proc.band))
    x_p, v_p = periodic_kinematics(yp, fs, proc.kind, highpass=hp)
    sets = [slice(0, None, 2), slice(1, None, 2)] if split else []
    # basis noise variance per period, per unknown element (variance across periods)
    var_p = [(x_p if fn.variable == "x" else v_p) @ el.w for _, el, _, fn in unknown]
    # noise std of each deformation per period over its rms (for `_weak_instruments`)
    buried = [float(np.sqrt(u.var(axis=1, ddof=1).mean()) / max(u.mean(axis=1).std(), 1e-300))
              if n_p >= 2 else 0.0 for u in var_p]
    var_p = [float(u.var(axis=1, ddof=1).mean()) if n_p >= 2 else 0.0 for u in var_p]
    x_m, v_m = x_p[0].mean(axis=0), v_p[0].mean(axis=0)
    upsample = [_alias_upsampling(fn, (x_m if fn.variable == "x" else v_m) @ el.w, i, proc,
                                  warnings, periodic=True) for i, el, _, fn in unknown]
    gain = np.ones(idx.size) if proc.hold == "none" else np.sinc(idx / yp.shape[2]) ** 2
    labels: list[str] = []

    def formed(sel: slice, debias: bool, smooth: np.ndarray | None = None) -> _Formed:
        count = len(range(n_p)[sel])
        if smooth is None:
            x, v = x_p[:, sel].mean(axis=1), v_p[:, sel].mean(axis=1)
        else:
            x, v = periodic_kinematics(yp[:, sel].mean(axis=1), fs, proc.kind,
                                       weights=smooth, highpass=hp)
        force = np.fft.rfft(fp[:, sel].mean(axis=1), axis=1)[:, idx] * gain[:, None]
        cols = []
        labels.clear()
        for i, el in known:
            g = _periodic_force(el, x @ el.w, v @ el.w)[:, idx, None]
            a = _force_span(el.w, fdofs)
            if a is not None:
                force = force - g * a     # a known force on forced DOFs: subtract it
            else:
                cols.append(-g)
                labels.append(f"-{el.kind}@{i}(known)")
        for (i, el, _, fn), s2, up in zip(unknown, var_p, upsample):
            u = (x if fn.variable == "x" else v) @ el.w
            if debias and fn.debias is None and s2 / count > (0.05 * u.std()) ** 2:
                warnings.append(f"basis {fn.name} of element {i} has no noise correction: "
                                "its estimate stays biased by the noise")
            b = bas.evaluate(fn, u, up, s2 / count if debias else 0.0, periodic=True)
            cols.append(-np.fft.rfft(b, axis=1)[:, idx, None])
            labels.append(f"-{fn.name}@{i}")
        X = np.fft.rfft(x, axis=1)[:, idx]
        return _Formed(X, np.concatenate([force] + cols, axis=2))

    halves = [(formed(s, True), formed(s, False, wiener).R) for s in sets]
    full = formed(slice(None), split)
    return halves, full, PeriodicStats(labels=list(labels), relative_std=rel, buried=buried)


def _periodic_force(el, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Lines (all of them) of a known element's steady-state force, per realization."""
    n = u.shape[1]
    out = []
    for um, vm in zip(u, v):
        # two periods: memory elements settle on their periodic loop during the first
        g = restoring_force(el.kind, el.params, np.tile(um, 2), np.tile(vm, 2))[0][n:]
        out.append(np.fft.rfft(g))
    return np.array(out)


def _transient_check(yp: np.ndarray, warnings: list[str]) -> None:
    """Warn when the first steady period still differs from the last beyond the noise.

    The mean square of their difference is ``2 sigma^2`` for a settled response; the excess
    over that (allowing five standard errors of the estimate) is the transient's power.
    """
    if yp.shape[1] < 3:
        return
    d2 = ((yp[:, 0] - yp[:, -1]) ** 2).mean(axis=(0, 1))
    s2 = yp.var(axis=1, ddof=1).mean(axis=(0, 1))
    power = (yp ** 2).mean(axis=(0, 1, 2))
    tol = 5 * 2 * s2 * np.sqrt(2 / (yp.shape[0] * yp.shape[2]))
    ratio = np.sqrt(np.maximum(d2 - 2 * s2 - tol, 0.0) / np.maximum(power, 1e-300))
    if ratio.max() > TRANSIENT_LEVEL:
        warnings.append(f"the response has not settled: the first steady period differs from "
                        f"the last by {100 * ratio.max():.2g} % of the rms beyond the noise; "
                        "drop more transient periods (transient_periods)")
