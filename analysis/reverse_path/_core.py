"""Reverse path / NIFO estimation of nonlinear coefficients from random data (paper ch. 3).

The nonlinear restoring forces are moved to the input side (paper eq 12-14):
``X = H_L F + sum_m p_m (H w_m) r_m`` with ``r_m = -F(g_m(w_m.x, w_m.v))``. One MIMO H1
estimate ``H_M = G_XR G_RR^-1`` over ``R = {F, r_1 .. r_m}`` (eq 15) gives the underlying
linear FRF columns ``H_L`` and, per element, the column ``p_m H w_m``. ``H w_m`` is known
from ``H_L`` either directly (``w_m`` lies in the span of the forced DOFs) or through
reciprocity on the forced rows (``(H w_m)_d = w_m . H_L[:, d]``, paper eq 16); every such
equation gives an estimate of ``p_m(f)``, combined with inverse-variance weights.

Uncertainty: the H1 covariance of output row ``y`` is ``sigma_y^2 G_RR^-1 / n_eff`` with
``sigma_y^2 = (1 - gamma_y^2) G_yy`` (Bendat & Piersol), propagated to each ``p_m(f)``; the
frequency average and its 95 % interval use those variances, inflated by the window's bin
correlation, and are never narrower than the observed spread over frequency: line by line
(sandwich variance) nor between contiguous sub-bands (batch means, Student t quantile), so
errors correlated over many lines, such as leakage bias at a resonance, widen the interval.

Sensor noise on the response (errors in variables) is treated in `._noise` and `._iv`:
instrumental variables for random records, and period averaging with split-period
instruments for periodic-random (multisine) records, which this module hands over whole.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
from scipy.stats import t as student_t

from .. import models as bas    # the reverse-path basis functions of a kind
from ..models import Element, Model, restoring_force
from ..errors import InputError
from ..recordings import (KIND_ORDER, Excitation, Recording, ResponseKind, signal_bandwidth,
                          to_kinematics)
from ..spectral import Spectra, conditioned_inputs, h1, multiple_coherence, spectral_matrix
from ._low_band import LowBand

Z95 = 1.959963984540054
N_BATCHES = 8             # sub-bands of the batch-means interval
ALIAS_TOLERANCE = 2e-4   # relative in-band error of a basis that triggers the aliasing fix
#: response channel rms, relative to the largest, below which the channel is dead
DEAD_SHARE = 1e-3
#: `noise_edge`: power over white noise floor an integrated record's lines must reach, the
#: run of lines that must reach it, and the highest edge as a share of the band's top
EDGE_SNR, EDGE_RUN, EDGE_CAP = 10.0, 4, 0.125


@dataclass
class Coefficient:
    """Estimate of one element parameter."""

    element: int
    kind: str
    w: np.ndarray
    param: str
    basis: str
    values: np.ndarray          # (n_f,) complex, p(f)
    variance: np.ndarray        # (n_f,) variance of p(f)
    value: float                # frequency-averaged real value
    std: float                  # standard error of `value`
    ci95: tuple[float, float]
    imag: float = 0.0           # same average of Im p(f): ~0 for the right basis


@dataclass
class ReversePathResult:
    """Outcome of `reverse_path`.

    Attributes
    ----------
    freqs : ndarray, shape (n_f,)
        Analysed frequencies, Hz.
    H_linear : ndarray, shape (n_f, n_dof, n_in)
        Underlying linear receptance columns at the forced DOFs.
    coefficients : list of Coefficient
    coherence_linear, coherence_nonlinear : ndarray, shape (n_f, n_dof)
        Multiple coherence of each output for the linear (forces only) and the nonlinear
        analysis (paper fig 3.9).
    conditioned_coherence : ndarray, shape (n_f, n_dof, n_r)
        Ordinary coherence of each output with each conditioned input (sums to the
        nonlinear multiple coherence).
    inputs : list of str
        Labels of the inputs R in order.
    band : (lo, hi)
    warnings : list of str
    noise : dict
        Noise treatment: ``method``, ``relative_std`` per DOF, ``lowpass_hz``, and for
        "iv" ``instrument_coherence`` (median per estimated input).
    refine : dict
        Empty for a joint estimate; for ``refine="sequential"`` the method and the joint
        values and intervals (`._stages`).
    """

    freqs: np.ndarray
    H_linear: np.ndarray
    coefficients: list[Coefficient]
    coherence_linear: np.ndarray
    coherence_nonlinear: np.ndarray
    conditioned_coherence: np.ndarray
    inputs: list[str]
    band: tuple[float, float]
    spectra: Spectra
    force_dofs: np.ndarray
    warnings: list[str] = field(default_factory=list)
    noise: dict[str, Any] = field(default_factory=dict)
    refine: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """Contracts section 4 dictionary."""
        by_el: dict[int, dict[str, Any]] = {}
        for c in self.coefficients:
            entry = by_el.setdefault(c.element, {"kind": c.kind, "w": c.w.tolist(),
                                                 "params": {}, "ci95": {}})
            entry["params"][c.param] = c.value
            entry["ci95"][c.param] = [c.ci95[0], c.ci95[1]]
        return {
            "elements": [by_el[k] for k in sorted(by_el)],
            "warnings": list(self.warnings),
            "multiple_coherence": {"min": float(self.coherence_nonlinear.min()),
                                   "min_linear": float(self.coherence_linear.min()),
                                   "band_hz": [self.band[0], self.band[1]]},
            "force_dofs": self.force_dofs.tolist(),
            "n_averages": self.spectra.n_avg,
            "resolution_hz": self.spectra.fs / self.spectra.nperseg,
            "noise": dict(self.noise),
            "refine": dict(self.refine) or {"method": "joint"},
        }

    def estimated_model(self, candidate: Model) -> Model:
        """The candidate with every estimated parameter filled in."""
        elements = [Element(el.kind, el.w.copy(), dict(el.params)) for el in candidate.elements]
        for c in self.coefficients:
            elements[c.element].params[c.param] = c.value
        return candidate.with_elements(elements)


def _records(data: Any, fs: float | None, force_dofs: Sequence[int] | None,
             response_kind: str) -> list[tuple[Recording, str]]:
    if isinstance(data, Recording):
        data = [data]
    if isinstance(data, tuple) and len(data) == 2:
        if fs is None or force_dofs is None:
            raise InputError("arrays (force, response) need fs= and force_dofs=")
        data = [Recording(fs, "random", force_dofs, np.atleast_2d(np.asarray(data[0]).T).T,
                          data[1], response_kind)]
    recs = list(data)
    if not recs or not all(isinstance(r, Recording) for r in recs):
        raise InputError("reverse path takes a Recording, a list of them, or a "
                         "(force, response) tuple")
    for r in recs:
        if r.excitation != Excitation.RANDOM:
            raise InputError(f"reverse path needs random excitation, got {r.excitation}; "
                             "fit stepped- or swept-sine runs with `nlid-lab analyze hbm`")
        _dead_channels(r)
    first = recs[0]
    for r in recs[1:]:
        if r.fs != first.fs or list(r.force_dofs) != list(first.force_dofs) \
                or r.n_dof != first.n_dof:
            raise InputError("the runs differ in sample rate, force DOFs or channel count; "
                             "analyse them separately")
    return [(r, r.response_kind) for r in recs]


def _dead_channels(rec: Recording) -> None:
    """Refuse a response channel `DEAD_SHARE` below the largest: a dead sensor or cable
    (reverse path needs every DOF; its basis would be formed from converter noise)."""
    rms = np.sqrt(np.mean(np.square(rec.response - rec.response.mean(axis=0)), axis=0))
    dead = np.flatnonzero(rms < DEAD_SHARE * rms.max())
    if dead.size:
        raise InputError(f"response channel(s) {', '.join(map(str, dead))} carry "
                         f"{20 * np.log10(max(rms[dead].max() / rms.max(), 1e-300)):.0f} dB "
                         "of the largest channel's signal: a dead sensor or cable? Reverse path "
                         "needs every DOF measured; repair the channel and record again")


def _elements(model: Model) -> tuple[list[tuple[int, Element, str, bas.Basis]],
                                     list[tuple[int, Element]]]:
    unknown, known = [], []
    for i, el in enumerate(model.elements):
        if el.known:
            known.append((i, el))
            continue
        param, fn = bas.element_basis(el, i)
        others = [m for m in el.missing if m != param]
        if others:
            raise InputError(f"element {i} ({el.kind}) misses {', '.join(others)}; reverse "
                             f"path estimates only {param}: give the others in the model")
        unknown.append((i, el, param, fn))
    if not unknown:
        raise InputError("the candidate model has no unknown parameter; omit the parameter "
                         "of each element to estimate")
    return unknown, known


def _force_span(w: np.ndarray, force_dofs: np.ndarray) -> np.ndarray | None:
    """Coefficients ``a`` with ``w = B a`` if ``w`` lies on the forced DOFs, else None."""
    nz = np.flatnonzero(w)
    if not set(nz) <= set(force_dofs.tolist()):
        return None
    b = np.zeros((w.size, force_dofs.size))
    b[force_dofs, np.arange(force_dofs.size)] = 1.0
    return np.linalg.lstsq(b, w, rcond=None)[0]


@dataclass
class _Processing:
    """How one record's channels are formed."""

    fs: float
    kind: str
    band: tuple[float, float]
    antialias: str
    hold: str
    lowpass: float | None
    highpass: float = 0.0       # integration high-pass of a velocity/acceleration record, Hz


def _integrated(recs: Sequence[tuple[Recording, str]]) -> str:
    """The response kind of ``recs`` integrated most (the automatic band's lower edge is its
    high-pass, `analysis.recordings.excitation_band`)."""
    return max((kind for _, kind in recs), key=KIND_ORDER.__getitem__)


def noise_edge(recs: Sequence[tuple[Recording, str]], floors: Sequence[np.ndarray | None],
               band: tuple[float, float], nperseg: int) -> float:
    """Integration high-pass of the integrated records of ``recs``, Hz (0 when none is).

    Integrating an acceleration twice multiplies its white sensor noise by ``(2 pi f)^-4``
    while the displacement's own spectrum stays flat towards DC: below some frequency the
    displacement formed is noise, and a cubic basis formed from it noise cubed. The signal to
    noise ratio of a line is the same before and after integration, so the edge is read off
    the record as it is: the lowest line of ``band`` from which the median over channels of
    the response's power over its white noise floor (``floors``, `._noise.noise_floor`)
    reaches `EDGE_SNR` over `EDGE_RUN` consecutive lines, at most `EDGE_CAP` of the band's
    top. A record without a floor (noise-free) keeps the band's edge.

    Measured (2-DOF cubic, 0-300 Hz band noise at 10 N rms, fs 2048 Hz, 2^16 samples, 1 %
    white noise on the accelerations): integrated from 0.125 Hz the cubic came out at 5.3e8
    for a true 2e11, its interval excluding the truth.
    """
    lo, hi = band
    edges = [0.0]
    for (rec, kind), floor in zip(recs, floors):
        if KIND_ORDER[kind] == 0 or floor is None:
            continue
        spec = spectral_matrix(rec.response, rec.fs, nperseg=nperseg, band=(lo, hi))
        snr = np.median(spec.auto() / np.maximum(floor, 1e-300), axis=1)
        run = np.convolve(snr >= EDGE_SNR, np.ones(EDGE_RUN), "valid") == EDGE_RUN
        first = int(np.argmax(run)) if run.any() else snr.size - 1
        edges.append(min(float(spec.freqs[first]), EDGE_CAP * hi))
    return max(edges)


def _channels(response: np.ndarray, force_in: np.ndarray, force_dofs: np.ndarray,
              proc: _Processing, unknown, known, warnings: list[str],
              noise_var: tuple[np.ndarray, np.ndarray] | None,
              buried: list[float] | None = None,
              low: LowBand | None = None) -> tuple[list[np.ndarray], list[str]]:
    """Time-domain channels ``[x_0.., f_0.., r_known.., r_1..]`` of one record, input labels.

    With ``noise_var`` (the formed displacement's and velocity's noise variance per DOF),
    ``buried`` receives, per unknown element, its deformation's noise std over the rms of
    what is not noise (`._noise.BURIED_RANDOM`). With ``low`` (an integrated record), the
    displacement's and velocity's lowest band is formed through the estimated model
    (`._low_band`)."""
    fs, n = proc.fs, response.shape[0]
    lo, hi = proc.band
    needs_v = bool(known) or any(fn.variable == "v" for *_, fn in unknown)
    # Frequency-domain integration/differentiation leaves end effects of a few periods of
    # the lowest analysed frequency: those samples are dropped from every channel.
    edge = int(min(n // 16, 4 * fs / max(lo, 1.0)))
    if proc.kind == ResponseKind.DISPLACEMENT and not needs_v:
        x, v, edge = response, None, 0
    else:
        # Only the velocity is low-passed: cutting the displacement would drop true content
        # and bias the basis; its white noise is removed exactly by the debiasing instead.
        hp = 0.0 if proc.kind == ResponseKind.DISPLACEMENT else \
            max(lo / 2, 2 * fs / n, proc.highpass)
        x, v = to_kinematics(response, fs, proc.kind, highpass=hp)
        if proc.lowpass is not None and needs_v:
            v = to_kinematics(response, fs, proc.kind, highpass=hp, lowpass=proc.lowpass)[1]
    force = force_in if proc.hold == "none" else _linear_hold(force_in, fs)
    if low is not None and proc.kind != ResponseKind.DISPLACEMENT:
        x, v = low.apply(x, v, force, force_dofs, fs)
    force, cols, labels = _inputs(x, v, force, force_dofs, proc, unknown, known, warnings,
                                  noise_var, buried, edge)
    # a list of (strided) columns: spectral_matrix reads them in place, no stacked copy
    return [c[edge: n - edge] for c in (*x.T, *force.T, *cols)], labels


def _inputs(x: np.ndarray, v: np.ndarray | None, force: np.ndarray, force_dofs: np.ndarray,
            proc: _Processing, unknown, known, warnings: list[str],
            noise_var: tuple[np.ndarray, np.ndarray] | None, buried: list[float] | None,
            edge: int) -> tuple[np.ndarray, list[np.ndarray], list[str]]:
    """The inputs formed from ``x`` and ``v``: the forces (less the known forces on forced
    DOFs), the other known forces' and the unknown bases' columns, and their labels."""
    n = x.shape[0]
    cols: list[np.ndarray] = []
    labels: list[str] = []
    for i, el in known:
        g = restoring_force(el.kind, el.params, bas.deformation(el.w, x),
                            bas.deformation(el.w, v))[0]
        a = _force_span(el.w, force_dofs)
        if a is not None:
            force = force - np.outer(g, a)   # a known force on forced DOFs: subtract it
        else:
            cols.append(-g)              # elsewhere: a nuisance input with its own column
            labels.append(f"-{el.kind}@{i}(known)")
    for i, el, _, fn in unknown:
        s = bas.deformation(el.w, x if fn.variable == "x" else v)
        up = _alias_upsampling(fn, s, i, proc, warnings)
        s2 = 0.0
        if noise_var is not None:
            s2 = float(noise_var[0 if fn.variable == "x" else 1] @ (el.w ** 2))
            if fn.debias is None and s2 > (0.05 * s.std()) ** 2:
                warnings.append(f"basis {fn.name} of element {i} has no noise correction: "
                                "its estimate stays biased by the noise")
            if buried is not None:
                core = s[edge: n - edge]
                buried.append(float(np.sqrt(s2 / max(core.var() - s2, 1e-12 * s2, 1e-300))))
        cols.append(-bas.evaluate(fn, s, up, s2))
        labels.append(f"-{fn.name}@{i}")
    return force, cols, labels


def _alias_upsampling(fn: bas.Basis, s: np.ndarray, i: int, proc: _Processing,
                      warnings: list[str], periodic: bool = False) -> int:
    """Upsampling factor for forming basis ``fn`` of signal ``s`` (element ``i``), warning
    when it would alias into the band."""
    fs, hi = proc.fs, proc.band[1]
    if proc.antialias == "off":
        return 1
    factor = bas.aliasing_factor(fn.order, signal_bandwidth(s[: 1 << 16], fs), fs, hi)
    err = bas.alias_error(fn, s, fs, proc.band, factor, periodic=periodic) if factor > 1 else 0.0
    if err > ALIAS_TOLERANCE:
        what = (f"upsampled x{factor} before forming it" if proc.antialias == "auto"
                else "raise fs or use antialias='auto'")
        warnings.append(f"aliasing: basis {fn.name} of element {i} spans "
                        f"{fn.order * signal_bandwidth(s, fs):.0f} Hz and folds into the "
                        f"band ({100 * err:.2g} % in-band error) at fs = {fs:g} Hz; {what}")
    return factor if err > ALIAS_TOLERANCE and proc.antialias == "auto" else 1


def _linear_hold(force: np.ndarray, fs: float) -> np.ndarray:
    """Baseband part of a first-order-hold force: spectrum times ``sinc^2(f / fs)``."""
    n = force.shape[0]
    ext = np.concatenate([force, force[::-1]])          # even extension: no end jump
    spec = np.fft.rfft(ext, axis=0) * (np.sinc(np.fft.rfftfreq(2 * n)) ** 2)[:, None]
    return np.fft.irfft(spec, 2 * n, axis=0)[:n]


def _form_covariance(rr_inv: np.ndarray, sigma2: np.ndarray, forms: np.ndarray) -> np.ndarray:
    """``E[(sum v_k dH)(sum v_l dH)^*]`` per frequency for real linear forms ``v_k`` of H_M.

    ``forms`` has shape (n_forms, n_dof, n_r), the same at every frequency; row errors are
    independent across outputs with covariance ``sigma_y^2 [G_RR^-1]_{ba}`` (``sigma2``
    already divided by the degrees of freedom). Returns shape (n_f, n_forms, n_forms).
    """
    cov = np.zeros((rr_inv.shape[0], forms.shape[0], forms.shape[0]), dtype=complex)
    for y in range(forms.shape[1]):
        rows = np.flatnonzero(forms[:, y, :].any(axis=1))     # forms that read output y
        if rows.size:
            v = forms[rows, y, :]
            # q[l, f, k] = v_l^T inv_f v_k: two flat matrix products (a broadcast matmul
            # over the frequencies is one small product per line)
            q = np.tensordot(v, rr_inv, axes=(1, 1)) @ v.T
            cov[:, rows[:, None], rows] += sigma2[:, y, None, None] * q.transpose(1, 2, 0)
    return cov


def _estimate(spec: Spectra, n_dof: int, fdofs: np.ndarray, unknown, inputs: list[str],
              band: tuple[float, float], method: str, warnings: list[str],
              solved: tuple[np.ndarray, np.ndarray, np.ndarray, dict] | None = None
              ) -> ReversePathResult:
    """Estimate from the spectral matrix of ``[X, R]`` (later channels are ignored).

    H1 unless ``solved = (H, cov, sigma2, noise)`` gives another estimator's transfer matrix,
    its row covariance (`_form_covariance` order) and per-output residual variance;
    coherences always come from ``spec``.
    """
    n_in, n_r = fdofs.size, len(inputs)
    xs, rs = slice(0, n_dof), slice(n_dof, n_dof + n_r)
    S_xx = spec.S[:, xs, xs].diagonal(axis1=1, axis2=2).real
    S_xr, S_rr = spec.S[:, xs, rs], spec.S[:, rs, rs]
    cond = conditioned_inputs(S_xx, S_xr, S_rr)
    coh_nl = cond.coherence.sum(axis=2)
    coh_lin = multiple_coherence(S_xx, S_xr[:, :, :n_in], S_rr[:, :n_in, :n_in])
    if solved is None:
        H = cond.transfer() if method == "conditioned" else h1(S_xr, S_rr)
        dof = max(spec.n_eff - n_r, 1.0)
        sigma2 = np.maximum((1 - coh_nl) * S_xx, 1e-15 * S_xx) / dof
        rr_inv = np.linalg.inv(S_rr)
        noise: dict[str, Any] = {}
    else:
        H, rr_inv, sigma2, noise = solved
    coefs = _coefficients(H, rr_inv, sigma2, fdofs, unknown, spec.bin_factor)
    for c in coefs:
        if abs(c.imag) > max(0.1 * abs(c.value), 3 * c.std):
            warnings.append(f"element {c.element} ({c.kind}): p(f) has a large imaginary part "
                            f"({100 * abs(c.imag / c.value):.0f} % of the real value); the "
                            "basis function or its location is probably wrong: try --screen")
    if coh_nl.min() < 0.9:
        worst = int(np.argmin(coh_nl.min(axis=0)))
        warnings.append(f"nonlinear multiple coherence drops to {coh_nl.min():.3f} (output "
                        f"{worst}); noise, a missing nonlinearity or too coarse a resolution")
    return ReversePathResult(spec.freqs, H[:, :, :n_in], coefs, coh_lin, coh_nl,
                             cond.coherence, inputs, band, spec, fdofs, warnings, noise)


def _coefficients(H: np.ndarray, rr_inv: np.ndarray, sigma2: np.ndarray, fdofs: np.ndarray,
                  unknown, bin_factor: float) -> list[Coefficient]:
    """Frequency-averaged estimate of every unknown parameter from ``H_M`` (last columns)."""
    n_r = H.shape[2]
    return [_average(i, el, param, fn.name,
                     *_element_estimates(H, rr_inv, sigma2, el.w, fdofs,
                                         n_r - len(unknown) + k), bin_factor)
            for k, (i, el, param, fn) in enumerate(unknown)]


def _element_estimates(H: np.ndarray, rr_inv: np.ndarray, sigma2: np.ndarray, w: np.ndarray,
                       fdofs: np.ndarray, col: int) -> tuple[np.ndarray, np.ndarray]:
    """Inverse-variance combination of the equations ``H_M[y, col] = p a_y`` per frequency."""
    _, n_dof, n_r = H.shape
    a_span = _force_span(w, fdofs)
    forms = []   # (beta, alpha): p = (beta . H) / (alpha . H)
    if a_span is not None:
        for y in range(n_dof):
            beta = np.zeros((n_dof, n_r))
            beta[y, col] = 1.0
            alpha = np.zeros((n_dof, n_r))
            alpha[y, : fdofs.size] = a_span
            forms.append((beta, alpha))
    else:
        for j, d in enumerate(fdofs):   # reciprocity on the forced rows (paper eq 16)
            beta = np.zeros((n_dof, n_r))
            beta[d, col] = 1.0
            alpha = np.zeros((n_dof, n_r))
            alpha[:, j] = w
            forms.append((beta, alpha))
    m = len(forms)
    v = np.array([beta for beta, _ in forms] + [alpha for _, alpha in forms])
    lin = np.einsum("fya,kya->fk", H, v)
    b, a = lin[:, :m], lin[:, m:]
    p = b / a
    cov = _form_covariance(rr_inv, sigma2, v)
    k = np.arange(m)
    var = (cov[:, k, k].real + np.abs(p) ** 2 * cov[:, k + m, k + m].real
           - 2 * (p.conj() * cov[:, k, k + m]).real)
    var = np.maximum(var, 1e-300) / np.abs(a) ** 2
    num, den = np.sum(p / var, axis=1), np.sum(1 / var, axis=1)
    return num / den, 1 / den


def _average(i: int, el: Element, param: str, name: str, est: np.ndarray, var: np.ndarray,
             bin_factor: float) -> Coefficient:
    """Frequency average of Re p(f) with a 95 % interval (see module docstring)."""
    wts = 2 / var                       # the real part carries half the complex variance
    value = float(np.sum(wts * est.real) / wts.sum())
    std_model = np.sqrt(bin_factor / wts.sum())
    # observed spread: the heteroscedasticity-robust (sandwich) variance of the weighted
    # mean, valid whatever the quality of the weights
    n = est.size
    spread = np.sum(wts**2 * (est.real - value) ** 2) / wts.sum() ** 2 * n / max(n - 1, 1)
    std_batch, dof = _batch_means_std(est.real, wts, value)
    std = float(max(std_model, np.sqrt(bin_factor * spread), std_batch))
    q = float(student_t.ppf(0.975, dof)) if dof else Z95
    return Coefficient(i, el.kind, el.w.copy(), param, name, est, var, value, std,
                       (value - q * std, value + q * std),
                       float(np.sum(wts * est.imag) / wts.sum()))


def _batch_means_std(x: np.ndarray, wts: np.ndarray, value: float) -> tuple[float, int]:
    """Standard error of a weighted mean by batch means over contiguous frequency bands.

    Errors that are correlated over many lines (leakage bias around a resonance, a slowly
    varying model error) make line-by-line variances too optimistic; the spread of the means
    of `N_BATCHES` contiguous sub-bands sees them. Returns (std, degrees of freedom), or
    (0, 0) when the band is too short to split.
    """
    k = min(N_BATCHES, x.size // 4)
    if k < 3:
        return 0.0, 0
    parts = np.array_split(np.arange(x.size), k)
    w = np.array([wts[p].sum() for p in parts])
    m = np.array([np.sum(wts[p] * x[p]) / wts[p].sum() for p in parts])
    var = np.sum(w**2 * (m - value) ** 2) / w.sum() ** 2 * k / (k - 1)
    return float(np.sqrt(var)), k - 1
