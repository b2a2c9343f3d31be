"""Experimental modal analysis of one measured FRF column: poles, shapes, residual terms.

Three steps, each done by what does it best:

1. **Stabilisation diagram**: pyEMA's least-squares complex-frequency (LSCF) common-denominator
   estimator over increasing model orders (well conditioned in the z-domain, fast); lines
   with gaps (a multisine with lines left out, dips, interference dropped) go to the same
   estimator on the measured lines (`analysis.modal._lscf`).
2. **Automatic selection**: a pole is *stable* when the previous order has one within
   ``tol_freq`` in frequency and ``tol_damp`` in damping; stable poles are clustered in
   frequency and a cluster that recurs in at least ``min_share`` of the upper half of the orders
   is a physical mode (pyEMA's own selection needs the frequencies given and, measured on an
   FE beam, returned duplicates and a zero for modes its diagram clearly showed).
3. **Refinement**: poles, residues and lower/upper residual terms fitted to the receptance
   data by variable projection (poles by `scipy.optimize.least_squares` with the closed-form
   Jacobian of `analysis.modal._varpro`, everything linear solved inside), optionally through the Welch smoothing kernel of the estimate
   (`analysis.modal.welch_smoothing`), which removes the leakage bias of Welch H1 damping.

With the force at a measured point (the driving point), the residues scale to mass-normalised
real mode shapes at every measured point: ``A_id = φ_i φ_d / (2 j ω_d)``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from ..errors import EstimationError, InputError
from ..models import Model
from ._lscf import lscf_poles
from ._varpro import PoleProjection


@dataclass
class Stabilisation:
    """Poles of every model order (the stabilisation diagram).

    Attributes
    ----------
    orders : ndarray of int, shape (n_orders,)
    freqs_hz, damping : list of ndarray
        Pole frequencies and damping ratios per order (in band, 0 < ζ < 0.5).
    stable : list of ndarray of bool
        Whether each pole has a neighbour at the previous order.
    """

    orders: np.ndarray
    freqs_hz: list[np.ndarray]
    damping: list[np.ndarray]
    stable: list[np.ndarray]


@dataclass
class ModalFit:
    """Modes of one FRF column (receptance), sorted by frequency.

    Attributes
    ----------
    freqs_hz, damping : ndarray, shape (n_modes,)
        Undamped natural frequencies and damping ratios.
    poles : ndarray, complex, shape (n_modes,)
    residues : ndarray, complex, shape (n_modes, n_out)
        ``H_i(s) = sum_r A_ir / (s - λ_r) + conj + L_i / s^2 + U0_i + U2_i s^2``.
    lower : ndarray, complex, shape (n_out,)
        Modes below the band act as ``L / s^2`` (mass-like); with ``pseudo_hz``, the real
        coefficient ``a`` of a pseudo-mode ``a / (ω_l^2 + 2 ζ ω_l s + s^2)`` at ``pseudo_hz[0]``.
    upper : ndarray, complex, shape (2, n_out)
        Modes above the band act as ``U0 + U2 s^2`` (stiffness-like, with the first term of
        their rise towards resonance); with ``pseudo_hz``, ``upper[0]`` is the real
        coefficient of a pseudo-mode at ``pseudo_hz[1]`` (``upper[1]`` zero). Residual terms
        are zero where not fitted.
    shapes : ndarray, shape (n_modes, n_out)
        Real mode shapes, mass-normalised when ``driving_point`` was given, else scaled to unit
        largest component.
    mac : ndarray, shape (n_modes, n_modes)
        Modal assurance criterion between the shapes.
    support : ndarray, shape (n_modes,)
        Share of the upper orders at which the mode was stable (selection quality).
    frf_error : ndarray, shape (n_out,)
        In-band relative error ``||H_model - H|| / ||H||`` per output.
    band_hz : (float, float)
    """

    freqs_hz: np.ndarray
    damping: np.ndarray
    poles: np.ndarray
    residues: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    shapes: np.ndarray
    mac: np.ndarray
    support: np.ndarray
    frf_error: np.ndarray
    band_hz: tuple[float, float]
    pseudo_hz: tuple[float, float] | None = None
    """Frequencies of the residual pseudo-modes the residual terms were fitted as (None: the
    ``L / s^2`` and ``U0 + U2 s^2`` terms)."""

    def receptance(self, freqs: np.ndarray) -> np.ndarray:
        """Model receptance at ``freqs`` (Hz), shape (n_f, n_out)."""
        return _synthesis(2j * np.pi * np.asarray(freqs, dtype=float), self.poles,
                          self.residues, self.lower, self.upper, self.pseudo_hz)


def _synthesis(s, poles, residues, lower, upper, pseudo_hz=None):
    g = 1 / (s[:, None] - poles[None, :])
    gc = 1 / (s[:, None] - np.conj(poles)[None, :])
    modes = g @ residues + gc @ np.conj(residues)
    if pseudo_hz is not None:
        wl, wu = (_pseudo_mode(s[:, None], f) for f in pseudo_hz)
        return modes + lower * wl + upper[0] * wu
    with np.errstate(divide="ignore", invalid="ignore"):   # the lower residual is
        # unbounded at 0 Hz (a mass line): infinite there, as the model says, without a warning
        return modes + lower / s[:, None] ** 2 + upper[0] + upper[1] * s[:, None] ** 2


PSEUDO_DAMPING = 0.05
"""Damping ratio of the residual pseudo-modes (decays their ringing in a simulation)."""


def _pseudo_mode(s: np.ndarray, freq_hz: float) -> np.ndarray:
    """Receptance ``1 / (ω_r^2 + 2 ζ ω_r s + s^2)`` of a unit pseudo-mode as the written
    model holds it (damping `PSEUDO_DAMPING`: finite where the Welch kernel's shifted lines
    reach ``ω_r``)."""
    w = 2 * np.pi * freq_hz
    return 1 / (w ** 2 + 2 * PSEUDO_DAMPING * w * s + s ** 2)


TOL_FREQ = 0.01
"""Relative frequency change between model orders of a stable pole."""


def stabilisation(freqs: np.ndarray, frf: np.ndarray, band: tuple[float, float], *,
                  max_order: int = 40, tol_freq: float = TOL_FREQ,
                  tol_damp: float = 0.05) -> Stabilisation:
    """Poles of LSCF fits of orders 2..``max_order`` (pyEMA), with stability flags.

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Frequencies, Hz: a Welch or multisine FRF's lines. Uniform lines on a grid through
        0 Hz go to pyEMA; lines with gaps (left out by the design, where the force dips or
        interference sat) to the same estimator on the measured lines
        (`analysis.modal._lscf`).
    frf : ndarray, shape (n_f, n_out)
        FRF column of any form (receptance, mobility, accelerance: the poles are the same).
    band : (lo, hi)
        Band searched for modes, Hz.
    """
    f = np.asarray(freqs, dtype=float)
    h = np.asarray(frf, dtype=complex).reshape(f.size, -1)
    lo, hi = band
    if f.size < 16 or np.any(np.diff(f) <= 0):
        raise InputError("the stabilisation diagram needs an FRF on 16 or more increasing "
                         "frequencies (a random or multisine run's lines)")
    if _fft_grid(f):
        poles = _pyema_poles(f, h, band, max_order)
    else:
        inb = (f >= lo) & (f <= hi) & (f > 0)
        if inb.sum() < 16:
            raise InputError(f"{inb.sum()} lines in {lo:g}-{hi:g} Hz: the stabilisation "
                             "diagram needs 16 or more; widen the band")
        poles = zip(*lscf_poles(f[inb], h[inb], 2 * (max_order // 2)))
    orders = np.arange(2, 2 * (max_order // 2) + 1, 2)
    fr, zs, st = [], [], []
    prev_f, prev_z = np.array([]), np.array([])
    for pf, pz in poles:
        pf, pz = np.asarray(pf, dtype=float), np.asarray(pz, dtype=float)
        ok = (pf >= lo) & (pf <= hi) & (pz > 0) & (pz < 0.5)
        pf, pz = pf[ok], pz[ok]
        order = np.argsort(pf)
        pf, pz = pf[order], pz[order]
        stable = np.zeros(pf.size, dtype=bool)
        for i, (a, z) in enumerate(zip(pf, pz)):
            if prev_f.size:
                j = int(np.argmin(np.abs(prev_f - a)))
                stable[i] = (abs(prev_f[j] - a) <= tol_freq * a
                             and abs(prev_z[j] - z) <= tol_damp * z)
        fr.append(pf)
        zs.append(pz)
        st.append(stable)
        prev_f, prev_z = pf, pz
    return Stabilisation(orders[:len(fr)], fr, zs, st)


def _fft_grid(f: np.ndarray) -> bool:
    """Whether lines are uniformly spaced on a grid through 0 Hz (what pyEMA's FFT-based LSCF
    needs; zeros are padded below the first line)."""
    df = np.diff(f)
    k = f[0] / df.mean()
    return bool(np.ptp(df) <= 1e-6 * df.mean() and abs(k - round(k)) <= 1e-3)


def _pyema_poles(f: np.ndarray, h: np.ndarray, band: tuple[float, float], max_order: int):
    """pyEMA's LSCF poles (frequencies, damping ratios) per order of lines on a grid through
    0 Hz."""
    from pyEMA import Model as LSCF   # loaded on use: it imports matplotlib and Qt

    lo, hi = band
    df = np.diff(f)
    keep = f <= hi
    if f[0] > 0:                                  # LSCF's z-domain starts at 0 Hz
        pad = np.arange(0.0, f[0] - 0.5 * df[0], df[0])
        f = np.concatenate([pad, f])
        h = np.concatenate([np.zeros((pad.size, h.shape[1])), h])
        keep = f <= hi
    lscf = LSCF(frf=h[keep].T, freq=f[keep], lower=lo, upper=f[keep][-1],
                pol_order_high=max_order // 2, frf_form="receptance")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        lscf.get_poles(method="lscf", show_progress=False)
    return zip(lscf.pole_freq, lscf.pole_xi)


def select_modes(stab: Stabilisation, *, min_share: float = 0.5, cluster: float = 0.005,
                 n_modes: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Physical modes from the stable poles of the upper half of the orders.

    Returns frequencies, damping ratios (cluster medians) and support (share of those orders
    with a stable pole in the cluster); ``n_modes`` keeps that many best-supported clusters
    regardless of ``min_share``.
    """
    upper = range(len(stab.orders) // 2, len(stab.orders))
    pts = [(f, z, k) for k in upper
           for f, z, s in zip(stab.freqs_hz[k], stab.damping[k], stab.stable[k]) if s]
    if not pts:
        raise EstimationError("no stable pole in the band: the FRF shows no clear mode there; "
                              "check the band and the coherence")
    pts.sort()
    groups, current = [], [pts[0]]
    for p in pts[1:]:
        if p[0] - current[-1][0] <= cluster * p[0]:
            current.append(p)
        else:
            groups.append(current)
            current = [p]
    groups.append(current)
    n_upper = len(upper)
    rows = []
    for g in groups:
        support = len({k for _, _, k in g}) / n_upper
        rows.append((float(np.median([p[0] for p in g])), float(np.median([p[1] for p in g])),
                     support))
    rows.sort(key=lambda r: -r[2])
    chosen = rows[:n_modes] if n_modes else [r for r in rows if r[2] >= min_share]
    if not chosen:
        raise EstimationError("no mode is stable over enough model orders; give --modes N "
                              "or a narrower band")
    chosen.sort()
    return tuple(np.array(c) for c in zip(*chosen))


def refine(freqs: np.ndarray, receptance: np.ndarray, fn: np.ndarray, zeta: np.ndarray, *,
           residuals: tuple[bool, bool] = (True, True),
           smoothing: tuple[np.ndarray, np.ndarray] | None = None,
           weights: np.ndarray | None = None,
           pseudo_hz: tuple[float, float] | None = None, full_output: bool = False):
    """Poles, residues and residual terms fitted to receptance data (variable projection).

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Frequencies of the data, Hz (the fit band).
    receptance : ndarray, shape (n_f, n_out)
    fn, zeta : ndarray, shape (n_modes,)
        Starting poles.
    residuals : (lower, upper)
        Fit the ``L / s^2`` and the ``U0 + U2 s^2`` terms.
    smoothing : (offsets, kernel), optional
        Welch smoothing of the estimate (`analysis.modal.welch_smoothing`).
    weights : ndarray, shape (n_f,) or (n_f, n_out), optional
        Weights of the relative residual ``(model - H) / |H|`` per line (and output): for
        maximum likelihood, ``|H| / std(H)`` from the measured noise (e.g. the spread over the
        periods of a periodic run); equal relative weight when omitted.
    pseudo_hz : (lower, upper), optional
        Fit the residual terms as the pseudo-modes a modal model can hold: real coefficients
        of ``1 / (ω_r^2 + 2 ζ ω_r s + s^2)`` (ζ = `PSEUDO_DAMPING`) at these frequencies
        (below and above the band), instead of
        the complex ``L / s^2`` and ``U0 + U2 s^2`` (whose sum a model of modes cannot
        reproduce: on a structure with a strong mode just above the band the two upper terms
        nearly cancelled, and the model written from them missed by 12 % in band).
    full_output : bool
        Also return the weighted sum of squared residuals and their number.

    Returns
    -------
    poles, residues, lower, upper[, cost, n_residuals]
    """
    f = np.asarray(freqs, dtype=float)
    h = np.asarray(receptance, dtype=complex).reshape(f.size, -1)
    if smoothing is None:
        offsets, kernel = np.zeros(1), np.ones((1,))
    else:
        offsets, kernel = smoothing
    s = 2j * np.pi * (f[:, None] - offsets[None, :])
    mag = np.abs(h)
    wts = np.ones((f.size, 1)) if weights is None else np.asarray(weights, dtype=float)
    scale = wts.reshape(f.size, -1) / np.maximum(mag, 1e-3 * mag.max(axis=0))
    lower_on, upper_on = residuals
    # the lower term's 1/s^2 is left out at s = 0 (a kernel reaching 0 Hz from a low line)
    inv_s2 = np.divide(1.0, s ** 2, out=np.zeros_like(s), where=s != 0)
    if pseudo_hz is None:
        extra = ([np.sum(kernel * inv_s2, axis=-1)] if lower_on else []) \
            + ([np.sum(np.ones_like(s) * kernel, axis=-1), np.sum(s ** 2 * kernel, axis=-1)]
               if upper_on else [])
    else:
        extra = [np.sum(kernel * _pseudo_mode(s, fr), axis=-1)
                 for fr, on in zip(pseudo_hz, residuals) if on]

    vp = PoleProjection(s, kernel, extra, pseudo_hz is not None, h, scale)
    x0 = np.column_stack([fn, np.clip(zeta, 1e-5, 0.5)]).ravel()
    sol = scipy.optimize.least_squares(vp.residual, x0, jac=vp.jacobian, x_scale=x0,
                                       bounds=(np.tile([0.0, 1e-7], fn.size),
                                               np.tile([np.inf, 0.99], fn.size)))
    coef = vp.coefficients(sol.x)
    nm = fn.size
    zero = np.zeros(h.shape[1], dtype=complex)
    lower = coef[nm] if lower_on else zero
    if pseudo_hz is not None:
        upper = np.stack([coef[nm + int(lower_on)] if upper_on else zero, zero])
    else:
        upper = coef[nm + int(lower_on):nm + int(lower_on) + 2] if upper_on \
            else np.stack([zero, zero])
    if full_output:
        return vp.poles(sol.x), coef[:nm], lower, upper, 2 * float(sol.cost), sol.fun.size
    return vp.poles(sol.x), coef[:nm], lower, upper


def recurring_poles(stab: Stabilisation, known_hz: np.ndarray, *, cluster: float = 0.005,
                    min_orders: int = 3) -> list[tuple[float, float, float]]:
    """Candidate modes the stability flags missed: clusters of poles (stable or not) that,
    from the order where they first appear, recur at every higher order (at least
    ``min_orders``) and that no ``known_hz`` mode holds (a mode nearly still at the driving
    point is identified in frequency but not in damping, which then fails the test).

    Returns
    -------
    list of (freq_hz, damping, share)
        Cluster medians and the share of the orders holding the cluster, most recurrent
        first.
    """
    n = len(stab.orders)
    pts = sorted((f, z, k) for k in range(n) for f, z in zip(stab.freqs_hz[k], stab.damping[k]))
    groups: list[list] = []
    for p in pts:
        if groups and p[0] - groups[-1][-1][0] <= cluster * p[0]:
            groups[-1].append(p)
        else:
            groups.append([p])
    out = []
    for g in groups:
        orders = sorted({k for _, _, k in g})
        fc = float(np.median([p[0] for p in g]))
        if (len(orders) >= min_orders and orders == list(range(orders[0], n))
                and not np.any(np.abs(np.asarray(known_hz) - fc) <= 2 * cluster * fc)):
            out.append((fc, float(np.median([p[1] for p in g])), len(orders) / n))
    return sorted(out, key=lambda c: -c[2])


def mac(a: np.ndarray, b: np.ndarray | None = None) -> np.ndarray:
    """Modal assurance criterion between the rows of ``a`` and of ``b`` (default ``a``)."""
    b = a if b is None else b
    num = np.abs(np.conj(a) @ b.T) ** 2
    return num / np.outer(np.sum(np.abs(a) ** 2, axis=1), np.sum(np.abs(b) ** 2, axis=1))


def real_shapes(poles: np.ndarray, residues: np.ndarray, driving_point: int | None
                ) -> np.ndarray:
    """Real mode shapes from residues; mass-normalised through the driving-point residue."""
    wd = poles.imag
    modal_a = 2j * wd[:, None] * residues            # φ_i φ_d (real for proportional damping)
    if driving_point is None:
        k = np.argmax(np.abs(modal_a), axis=1)
        ref = modal_a[np.arange(poles.size), k]
        return np.real(modal_a * np.exp(-1j * np.angle(ref))[:, None]) \
            / np.abs(ref)[:, None]
    add = modal_a[:, driving_point]
    phi_d = np.sqrt(np.abs(add))
    rot = np.exp(-1j * np.angle(add))                 # align each mode's phase to real
    return np.real(modal_a * rot[:, None]) / phi_d[:, None]


def fit_modes(freqs: np.ndarray, receptance: np.ndarray, band: tuple[float, float], *,
              n_modes: int | None = None, driving_point: int | None = None,
              max_order: int = 40, residuals: tuple[bool, bool] = (True, True),
              smoothing: tuple[np.ndarray, np.ndarray] | None = None,
              std: np.ndarray | None = None, pseudo_modes: bool = False,
              stab: Stabilisation | None = None) -> tuple[ModalFit, Stabilisation]:
    """Modes of one receptance FRF column in ``band``: diagram, selection, refinement.

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Frequencies, Hz: a Welch or multisine FRF's lines, gaps allowed (`stabilisation`).
    receptance : ndarray, shape (n_f, n_out)
        Displacement per force at every measured point (convert accelerance first).
    band : (lo, hi)
    n_modes : int, optional
        Number of modes; automatic (stable over half the upper orders) when omitted.
    driving_point : int, optional
        Output measured where the force acts: shapes are then mass-normalised.
    smoothing : (offsets, weights), optional
        Welch smoothing kernel of the estimate (`analysis.modal.welch_smoothing`; weights
        of shape (n_k,) or one row per line of ``freqs``).
    std : ndarray, shape (n_f, n_out), optional
        Standard deviation of each receptance value (measured noise): the refinement is then
        a maximum-likelihood fit; equal relative weights when omitted.
    pseudo_modes : bool
        Fit the residual terms as pseudo-modes at half the band's lower and twice its upper
        edge (`refine`'s ``pseudo_hz``): what a ``[modal]`` model holds exactly, where the
        default ``L / s^2`` and ``U0 + U2 s^2`` terms fit the column more closely but can
        leave a written model off by their difference.
    stab : Stabilisation, optional
        A diagram of the same data already computed (not recomputed).
    """
    f = np.asarray(freqs, dtype=float)
    h = np.asarray(receptance, dtype=complex).reshape(f.size, -1)
    lo, hi = band
    if not 0 <= lo < hi:
        raise InputError(f"band {lo:g}..{hi:g} Hz: give 0 <= lo < hi")
    stab = stab if stab is not None else stabilisation(f, h, band, max_order=max_order)
    fn, zeta, support = select_modes(stab, n_modes=n_modes)
    inb = (f >= lo) & (f <= hi) & (f > 0)
    w = None if std is None else np.abs(h[inb]) / np.maximum(
        np.asarray(std, dtype=float).reshape(h.shape)[inb], 1e-300)
    if smoothing is not None and np.ndim(smoothing[1]) == 2:     # a kernel per line
        smoothing = (smoothing[0], smoothing[1][inb])
    # residual terms as the pseudo-modes the written model holds (`modal_model`)
    pseudo = (lo / 2, 2 * hi) if pseudo_modes and lo > 0 else None
    kw = dict(residuals=residuals, smoothing=smoothing, weights=w, pseudo_hz=pseudo,
              full_output=True)
    poles, res, lower, upper, cost, m = refine(f[inb], h[inb], fn, zeta, **kw)
    if n_modes is None:
        # a recurring pole the stability flags missed is a mode when the refined fit keeps it
        # where the diagram has it (within the stability tolerance) and it lowers the misfit
        # by more than BIC asks of its parameters (misfit scaled by its own residual variance:
        # the data need not be at their noise floor)
        for fc, zc, share in recurring_poles(stab, fn):
            trial = refine(f[inb], h[inb], np.r_[fn, fc], np.r_[zeta, zc], **kw)
            added = abs(trial[0][-1]) / (2 * np.pi)
            extra = 2 + 2 * h.shape[1]
            if (abs(added - fc) <= TOL_FREQ * fc and lo <= added <= hi
                    and (cost - trial[4]) * (m - extra * (fn.size + 1)) / trial[4]
                    > extra * math.log(m)):
                poles, res, lower, upper, cost, m = trial
                fn, zeta = np.r_[fn, added], np.r_[zeta, -trial[0][-1].real / abs(trial[0][-1])]
                support = np.r_[support, share]
    order = np.argsort(np.abs(poles))
    poles, res, support = poles[order], res[order], support[order]
    shapes = real_shapes(poles, res, driving_point)
    model = _synthesis(2j * np.pi * f[inb], poles, res, lower, upper, pseudo)
    err = np.linalg.norm(model - h[inb], axis=0) / np.linalg.norm(h[inb], axis=0)
    fit = ModalFit(np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles), poles, res,
                   lower, upper, shapes, mac(shapes), support, err, (float(lo), float(hi)),
                   pseudo)
    return fit, stab


def modal_model(fit: ModalFit, driving_point: int, *, points: list[str] | None = None,
                name: str = "fitted modal model", residuals: bool = True) -> Model:
    """A ``[modal]`` model of the fitted modes, with residual pseudo-modes.

    The modes keep their frequencies, damping ratios and mass-normalised real shapes. The
    fit's residual terms become pseudo-modes with real coefficients ``a_i = φ_i φ_d``: the
    upper term ``U0 + U2 s^2`` one with the same static flexibility (``a = Re(U0) ω_r^2``)
    at ``ω_r^2 = -U0 / U2`` of the driving point where that lies above the band (else at
    twice its upper edge), the lower term ``L / s^2`` one at half its lower edge with the same
    mass line (``L / s^2 = -L / ω^2``, and ``a / (ω_r^2 - ω^2) -> -a / ω^2``: ``a = Re(L)``). A
    pseudo-mode is kept where its driving-point coefficient is positive (it is then a mode of
    shape ``a / sqrt(a_d)``).

    Parameters
    ----------
    fit : ModalFit
        From `fit_modes` with ``driving_point`` given (mass-normalised shapes).
    driving_point : int
        Output where the force acts.
    points : list of str, optional
        Point names of the outputs.
    name : str
    residuals : bool
        Add the pseudo-modes (else the modes only).

    Returns
    -------
    analysis.models.Model
    """
    lo, hi = fit.band_hz
    pseudo, coef = [], []
    if residuals and fit.pseudo_hz is not None:
        for fr, a in zip(fit.pseudo_hz, (np.real(fit.lower), np.real(fit.upper[0]))):
            if a[driving_point] > 0:
                pseudo.append(fr)
                coef.append(a / np.sqrt(a[driving_point]))
    elif residuals:
        u0, u2 = np.real(fit.upper[:, driving_point])
        # the U0 + U2 s^2 rise fixes the pseudo-mode's frequency where it lies above the band
        up = math.sqrt(-u0 / u2) / (2 * np.pi) if u0 * u2 < 0 else 0.0
        up = up if up > 1.05 * hi else 2 * hi
        for fr, a in ((lo / 2, np.real(fit.lower)), (up, np.real(fit.upper[0])
                                                     * (2 * np.pi * up) ** 2)):
            if fr > 0 and a[driving_point] > 0:
                pseudo.append(fr)
                coef.append(a / np.sqrt(a[driving_point]))
    return Model.modal(fit.freqs_hz, fit.damping, fit.shapes, points=points, name=name,
                       residual_freqs_hz=pseudo, residual_damping=[PSEUDO_DAMPING] * len(pseudo),
                       residual_shapes=np.array(coef) if coef else None)
