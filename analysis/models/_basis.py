"""Candidate nonlinear basis functions of ``u = w.x`` and ``u' = w.v`` (paper eq 20 and more).

A basis function is a zero-memory function of either the deformation ``u`` or its rate
``u'``. A model element kind that is linear in one parameter maps onto one basis function
(`element_basis`, from the kind's descriptor in `analysis.models._kinds`); its restoring force is
``param * basis(u, u')``.

A product of a band-limited signal spans a wider band (``u^3`` of a signal up to ``B`` Hz
spans ``3B``); sampled at ``fs`` it folds back into the analysis band when
``order * B > fs - band_hi``. `aliasing_factor` detects this and `evaluate` can form the basis
on a band-limited interpolation of the signal and discard what lies above ``fs/2``.

Sensor noise ``e`` (variance ``s2``) on the signal biases a basis: ``E[(u + e)^3 | u] = u^3 +
3 s2 u``. ``Basis.debias`` holds the Hermite-type correction that removes that conditional bias
for polynomials (exact for Gaussian noise) and its large-amplitude limit ``s2 sign(u)`` for
``u|u|`` (exact for ``|u| >> s``); `evaluate` subtracts it when given ``noise_var``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..errors import EstimationError, InputError
from ._kinds import lookup
from ._element import Element


@dataclass(frozen=True)
class Basis:
    """One candidate function.

    Attributes
    ----------
    name : str
        Short label, e.g. ``"x^3"``.
    variable : {"x", "v"}
        Acts on the deformation ``u`` or on its rate ``u'``.
    order : int
        Bandwidth multiplier used by the aliasing check (polynomial degree; for non-smooth
        functions the harmonic order above which their content is below about 1 %).
    func : callable
        ``func(s, arg)`` of the signal ``s`` and an optional parameter.
    arg : float
        Parameter passed to ``func`` (gap width, friction regularisation velocity).
    debias : callable, optional
        ``debias(s, s2)``: conditional noise bias of ``func`` for noise variance ``s2``
        (None: no correction known).
    """

    name: str
    variable: str
    order: int
    func: Callable[[np.ndarray, float], np.ndarray]
    arg: float = 0.0
    debias: Callable[[np.ndarray, float], np.ndarray] | None = None

    def __call__(self, s: np.ndarray) -> np.ndarray:
        return self.func(s, self.arg)


def _gap(s: np.ndarray, g: float) -> np.ndarray:
    return np.sign(s) * np.maximum(np.abs(s) - g, 0.0)


def _bias2(s: np.ndarray, s2: float) -> np.ndarray:
    return np.full_like(s, s2)


def _bias3(s: np.ndarray, s2: float) -> np.ndarray:
    return 3 * s2 * s


def _bias5(s: np.ndarray, s2: float) -> np.ndarray:
    return 10 * s2 * s**3 - 15 * s2**2 * s


def _bias_abs(s: np.ndarray, s2: float) -> np.ndarray:
    return s2 * np.sign(s)


LIBRARY: dict[str, Basis] = {b.name: b for b in (
    Basis("x^2", "x", 2, lambda s, _: s * s, debias=_bias2),
    Basis("x^3", "x", 3, lambda s, _: s * s * s, debias=_bias3),
    Basis("x|x|", "x", 5, lambda s, _: s * np.abs(s), debias=_bias_abs),
    Basis("x^5", "x", 5, lambda s, _: s**5, debias=_bias5),
    Basis("v|v|", "v", 5, lambda s, _: s * np.abs(s), debias=_bias_abs),
    Basis("v^3", "v", 3, lambda s, _: s * s * s, debias=_bias3),
    Basis("v^5", "v", 5, lambda s, _: s**5, debias=_bias5),
    Basis("sign(v)", "v", 9, lambda s, vr: np.tanh(s / vr), 1e-3),
)}
"""The candidate library screened by default (paper eq 20 plus x^5, v^3, v^5)."""

FAMILIES: dict[str, Basis] = {b.name: b for b in (
    Basis("gap", "x", 9, _gap),
)}
"""Basis functions of element kinds that need a parameter (not screened by default)."""


def element_basis(el: Element, index: int = 0) -> tuple[str, Basis]:
    """Parameter name and basis function of an element linear in one parameter.

    Raises
    ------
    EstimationError
        For kinds reverse path cannot estimate (memory elements).
    InputError
        For an unknown kind, or a basis parameter the model does not give (gap width).
    """
    spec = lookup(el.kind)
    if spec.coef is None:
        raise EstimationError(
            f"element {index} ({el.kind}) has memory and is not linear in its parameters; "
            "reverse path cannot estimate it: use `nlid-lab analyze hbm` with stepped-sine data")
    base = LIBRARY[spec.basis] if spec.basis in LIBRARY else FAMILIES[spec.basis]
    if spec.basis_arg is None:
        return spec.coef, base
    arg = spec.value(el.params, spec.basis_arg)
    if arg is None:
        meaning = spec.param(spec.basis_arg).meaning
        raise InputError(f"element {index} ({el.kind}) has no {meaning} {spec.basis_arg}; "
                         f"reverse path estimates {spec.coef} for a known {spec.basis_arg}: "
                         f"give {spec.basis_arg} in the model, or use `analyze hbm`")
    label = base.name if spec.basis_label is None else spec.basis_label.format(**el.params)
    return spec.coef, replace(base, name=label, arg=arg)


def deformation(w: np.ndarray, signal: np.ndarray) -> np.ndarray:
    """``u = signal @ w`` for a (n, n_dof) displacement or velocity record."""
    return np.asarray(signal, dtype=float) @ np.asarray(w, dtype=float)


def aliasing_factor(order: int, bandwidth: float, fs: float, band_hi: float) -> int:
    """Upsampling factor that keeps the basis free of in-band aliases (1 if none is needed).

    A basis of ``order`` applied to a signal whose content ends at ``bandwidth`` Hz spans
    ``order * bandwidth``; sampled at ``fs`` its content above ``fs/2`` folds onto
    ``fs - f`` and reaches the analysis band if ``order * bandwidth > fs - band_hi``.
    """
    span = order * bandwidth
    if span <= fs - band_hi:
        return 1
    return int(math.ceil((span + band_hi) / fs))


def evaluate(basis: Basis, s: np.ndarray, upsample: int = 1, noise_var: float = 0.0,
             periodic: bool = False) -> np.ndarray:
    """Apply ``basis`` to the signal ``s`` (time along the last axis), alias-free and debiased.

    ``noise_var > 0`` subtracts ``basis.debias(s, noise_var)`` (the conditional bias caused by
    sensor noise of that variance on ``s``; nothing when the basis has no correction).
    With ``upsample > 1`` the signal is interpolated band-limitedly, the function applied,
    and everything above the original ``fs/2`` discarded, so that it is removed instead of
    folded into the band. A ``periodic`` signal (one whole period) is interpolated from its
    own DFT, exactly; otherwise from the zero-padded FFT of its even extension (exact in
    band, no filter ripple), whose first and last few hundred samples carry end effects that
    callers trim.
    """
    if upsample <= 1:
        out = basis(s)
    elif periodic:
        out = _periodic_upsampled(basis, s, upsample)
    else:
        n = s.shape[-1]
        spec = np.fft.rfft(np.concatenate([s, s[..., ::-1]], axis=-1))
        fine = np.fft.irfft(spec, 2 * n * upsample) * upsample
        back = np.fft.rfft(basis(fine))[..., : n + 1] / upsample
        out = np.fft.irfft(back, 2 * n)[..., :n]
    if noise_var > 0 and basis.debias is not None:
        out = out - basis.debias(s, noise_var)
    return out


def _periodic_upsampled(basis: Basis, s: np.ndarray, upsample: int) -> np.ndarray:
    """``basis`` of a periodic signal formed on an ``upsample``-fold finer grid."""
    n = s.shape[-1]
    spec = np.fft.rfft(s)
    if n % 2 == 0:
        spec[..., -1] *= 0.5          # the Nyquist line splits into +-fs/2 on the fine grid
    fine = np.fft.irfft(spec, n * upsample) * upsample
    back = np.fft.rfft(basis(fine))[..., : n // 2 + 1] / upsample
    if n % 2 == 0:
        back[..., -1] = 2 * back[..., -1].real
    return np.fft.irfft(back, n)


def alias_error(basis: Basis, s: np.ndarray, fs: float, band: tuple[float, float],
                upsample: int, n_probe: int = 1 << 15, periodic: bool = False) -> float:
    """Relative in-band rms error of forming ``basis`` at ``fs`` instead of alias-free.

    The basis formed directly and after ``upsample``-fold interpolation are compared within
    ``band``: on the exact DFT lines of a ``periodic`` signal (one or more whole periods along
    the last axis), else on the Hann-windowed middle ``n_probe`` samples (enough for a
    spectral estimate, cheap on long records).
    """
    if periodic:
        plain, clean = evaluate(basis, s), evaluate(basis, s, upsample, periodic=True)
        win = 1.0
    else:
        n = s.shape[0]
        mid = s[max(0, (n - n_probe) // 2): (n + n_probe) // 2]
        edge = mid.size // 8
        plain = evaluate(basis, mid)[edge:-edge]
        clean = evaluate(basis, mid, upsample)[edge:-edge]
        win = np.hanning(plain.size)
    f = np.fft.rfftfreq(plain.shape[-1], 1 / fs)
    inband = (f >= band[0]) & (f <= band[1])
    ref = np.abs(np.fft.rfft(clean * win)[..., inband]) ** 2
    diff = np.abs(np.fft.rfft((plain - clean) * win)[..., inband]) ** 2
    return float(np.sqrt(diff.sum() / max(ref.sum(), 1e-300)))
