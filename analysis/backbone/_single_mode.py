"""Single-mode fit of one level's FRF: natural frequency, damping ratio and modal constant,
each with its 95 % interval.

The FRF in the measured kind ``k`` (0 receptance, 1 mobility, 2 accelerance) is modelled as

    H(w) = (i w)^k A / (wn^2 - w^2 + 2 i zeta wn w) + R

with a complex modal constant ``A`` (receptance, 1/kg for a mass-normalised mode; complex to
absorb a rotated circle) and a complex residual ``R`` for the modes outside the band: the
rational-fraction form of a circle fit. ``A`` and ``R`` enter linearly and are solved inside
(variable projection, Golub & Pereyra 1973) for each (wn, zeta), which
`scipy.optimize.least_squares` adjusts; the intervals come from its Jacobian and the
residuals (heteroscedasticity-consistent sandwich covariance, MacKinnon & White 1985, HC3; t quantile).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.stats

from ..errors import EstimationError, InputError

#: linear (complex) unknowns of the model: modal constant and residual
N_LINEAR = 2


@dataclass(frozen=True)
class ModalEstimate:
    """Natural frequency, damping ratio and modal constant of one mode, with intervals.

    Attributes
    ----------
    frequency_hz : float
        Natural frequency ``wn / 2 pi``.
    frequency_ci95 : (float, float)
    damping_ratio : float
    damping_ci95 : (float, float)
    modal_constant : complex
        ``A`` of the receptance form (module docstring).
    """

    frequency_hz: float
    frequency_ci95: tuple[float, float]
    damping_ratio: float
    damping_ci95: tuple[float, float]
    modal_constant: complex


@dataclass(frozen=True)
class ModeFit(ModalEstimate):
    """Single-mode fit of one FRF: a `ModalEstimate` and

    Attributes
    ----------
    residual : complex
        ``R``, in the measured kind.
    fit_error : float
        ``||H - H_fit|| / ||H||`` over the fitted steps.
    n_points : int
        Frequencies fitted.
    """

    residual: complex
    fit_error: float
    n_points: int

    def frf(self, freqs: np.ndarray, kind_order: int) -> np.ndarray:
        """The fitted FRF at ``freqs`` (Hz) in the kind of order ``kind_order``."""
        w = 2 * np.pi * np.asarray(freqs, dtype=float)
        return _basis(w, 2 * np.pi * self.frequency_hz, self.damping_ratio,
                      kind_order) @ np.array([self.modal_constant, self.residual])


def _basis(w: np.ndarray, wn: float, zeta: float, order: int) -> np.ndarray:
    """Columns of the linear unknowns (A, R) at ``w``, shape (n, 2)."""
    pole = (1j * w) ** order / (wn**2 - w**2 + 2j * zeta * wn * w)
    return np.stack([pole, np.ones_like(pole)], axis=1)


def _solve(w: np.ndarray, H: np.ndarray, wn: float, zeta: float, order: int
           ) -> tuple[np.ndarray, np.ndarray]:
    """Linear unknowns and the complex residual at (wn, zeta)."""
    B = _basis(w, wn, zeta, order)
    coef = np.linalg.lstsq(B, H, rcond=None)[0]
    return coef, H - B @ coef


def _start(w: np.ndarray, H: np.ndarray, order: int) -> tuple[float, float]:
    """Peak of the receptance magnitude and its half-power width (at least two steps)."""
    mag = np.abs(H / (1j * w) ** order)
    i = int(np.argmax(mag))
    wn = w[i]
    above = w[mag >= mag[i] / np.sqrt(2)]
    width = max(above.max() - above.min(), 2 * np.median(np.diff(np.sort(w))))
    return float(wn), float(np.clip(width / (2 * wn), 1e-5, 0.3))


def fit_single_mode(freqs: np.ndarray, H: np.ndarray, kind_order: int) -> ModeFit:
    """Fit one mode to an FRF (module docstring).

    Parameters
    ----------
    freqs : ndarray, shape (n,)
        Frequencies, Hz (any spacing; at least 4 distinct).
    H : ndarray, complex, shape (n,)
        FRF in the measured kind.
    kind_order : int
        0 receptance, 1 mobility, 2 accelerance.

    Returns
    -------
    ModeFit

    Raises
    ------
    InputError
        Too few points or non-finite values.
    EstimationError
        The fit does not converge to a mode inside the band.
    """
    f = np.asarray(freqs, dtype=float)
    H = np.asarray(H, dtype=complex)
    if f.size < 4 or np.unique(f).size < 4 or not np.all(np.isfinite(H)):
        raise InputError("a single-mode fit needs at least 4 distinct frequencies with finite "
                         "FRF values")
    w = 2 * np.pi * f
    scale = np.abs(H).max()
    Hs = H / scale
    wn0, z0 = _start(w, Hs, kind_order)

    def residual(p: np.ndarray) -> np.ndarray:
        r = _solve(w, Hs, wn0 * p[0], z0 * p[1], kind_order)[1]
        return np.concatenate([r.real, r.imag])

    sol = scipy.optimize.least_squares(residual, [1.0, 1.0], x_scale=[z0, 1.0],
                                       bounds=([0.5, 1e-4], [2.0, 1e3]), xtol=1e-14,
                                       ftol=1e-14, gtol=1e-14)
    wn, zeta = wn0 * sol.x[0], z0 * sol.x[1]
    if not w.min() <= wn <= w.max():
        raise EstimationError(f"the single-mode fit puts the mode at {wn / 2 / np.pi:.4g} Hz, "
                              f"outside the steps {f.min():g}-{f.max():g} Hz; widen the band")
    coef, r = _solve(w, Hs, wn, zeta, kind_order)
    m, p = 2 * f.size, 2 + 2 * N_LINEAR
    dof = max(m - p, 1)
    J = sol.jac * np.array([wn0, z0])[None, :] ** -1     # d residual / d (wn, zeta)
    rows = np.concatenate([r.real, r.imag])
    bread = np.linalg.pinv(J.T @ J)
    # heteroscedasticity-consistent (sandwich, HC3) covariance: the noise of an FRF is not
    # even across a resonance (a held response over a force that dips there), and the few
    # steps at the peak carry the estimate (their leverage)
    B = _basis(w, wn, zeta, kind_order)
    full = np.column_stack([J, np.vstack([np.column_stack([B.real, -B.imag]),
                                          np.column_stack([B.imag, B.real])])])
    q = np.linalg.qr(full)[0]
    lev = np.minimum(np.sum(q**2, axis=1), 0.99)
    meat = (J * (rows / (1 - lev))[:, None] ** 2).T @ J
    cov = bread @ meat @ bread
    half = scipy.stats.t.ppf(0.975, dof) * np.sqrt(np.maximum(np.diag(cov), 0.0))
    fn, dfn = wn / (2 * np.pi), half[0] / (2 * np.pi)
    return ModeFit(float(fn), (float(fn - dfn), float(fn + dfn)), float(zeta),
                   (float(zeta - half[1]), float(zeta + half[1])), complex(coef[0] * scale),
                   complex(coef[1] * scale), float(np.linalg.norm(r) / np.linalg.norm(Hs)),
                   int(f.size))


def frf_noise(freqs: np.ndarray, H: np.ndarray, kind_order: int) -> np.ndarray:
    """Noise variance of each output's FRF values from the residual of its single-mode fit.

    A table carries no repeated measurement of a step, so its noise is read from how far
    the steps scatter about a single mode (``sum |r|^2 / (n - 3)``: three complex unknowns
    per output); a level whose curve is not one linear mode gets a larger variance, which
    only makes a test using it more cautious.

    Parameters
    ----------
    freqs : ndarray, shape (n,)
    H : ndarray, complex, shape (n, n_out)
    kind_order : int

    Returns
    -------
    ndarray, shape (n_out,)
    """
    H = np.asarray(H, dtype=complex).reshape(len(freqs), -1)
    out = np.empty(H.shape[1])
    for q in range(H.shape[1]):
        fit = fit_single_mode(freqs, H[:, q], kind_order)
        r = H[:, q] - fit.frf(freqs, kind_order)
        out[q] = float(np.sum(np.abs(r) ** 2)) / max(H.shape[0] - 3, 1)
    return out
