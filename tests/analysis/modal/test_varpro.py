"""Variable projection of the modal receptance model (`analysis.modal._varpro`)."""

import numpy as np
import pytest
from scipy.optimize._numdiff import approx_derivative

from analysis.modal import welch_smoothing
from analysis.modal._ema import refine
from analysis.modal._varpro import PoleProjection, _range_and_pinv


@pytest.fixture
def column():
    """Three modes seen through a Welch kernel weighted by a rippled input spectrum."""
    fs, nps = 1024.0, 2048
    f = np.fft.rfftfreq(nps, 1 / fs)[1:]
    offsets, kernel = welch_smoothing("hann", nps, fs, input_spectrum=(f, 1 + 0.3 * np.cos(f)))
    keep = (f >= 3) & (f <= 100)
    f, kernel = f[keep], kernel[keep]
    fn, zeta = np.array([6.6, 35.2, 53.9]), np.array([0.012, 0.01, 0.01])
    poles = 2 * np.pi * fn * (-zeta + 1j * np.sqrt(1 - zeta ** 2))
    res = 1e-3j * np.random.default_rng(0).normal(size=(3, 2))
    s = 2j * np.pi * (f[:, None] - offsets[None, :])
    g = 1 / (s[..., None] - poles) @ res + 1 / (s[..., None] - np.conj(poles)) @ np.conj(res)
    h = np.einsum("fk,fko->fo", kernel, g)
    return f, offsets, kernel, s, h, fn, zeta, poles, res


@pytest.mark.parametrize("real_extra", [False, True])
def test_closed_form_jacobian_matches_finite_differences(column, real_extra):
    f, offsets, kernel, s, h, fn, zeta, _, _ = column
    extra = [np.sum(kernel * np.divide(1.0, s ** 2, out=np.zeros_like(s), where=s != 0), -1)]
    noisy = h * (1 + 0.01 * np.random.default_rng(1).normal(size=h.shape))
    vp = PoleProjection(s, kernel, extra, real_extra, noisy, 1 / np.abs(noisy))
    x = np.column_stack([1.003 * fn, 1.1 * zeta]).ravel()
    jac = vp.jacobian(x)
    # central differences: truncation error ~ (eps^(1/3))^2 ~ 4e-11 relative to the curvature
    num = approx_derivative(vp.residual, x, method="3-point")
    assert np.abs(jac - num).max() <= 1e-5 * np.abs(num).max()


def test_refine_recovers_exact_poles_and_residues_through_the_kernel(column):
    f, offsets, kernel, s, h, fn, zeta, poles, residues = column
    # noise-free data: the fit is exact up to least_squares' tolerances (1e-8)
    p, res, _, _ = refine(f, h, 1.01 * fn, 1.2 * zeta, smoothing=(offsets, kernel))
    np.testing.assert_allclose(p, poles, rtol=1e-7)
    np.testing.assert_allclose(res, residues, rtol=1e-5, atol=1e-5 * np.abs(residues).max())


@pytest.mark.parametrize("case", ["scaled", "ill-conditioned", "rank-deficient"])
def test_range_and_pinv_solve_as_lstsq(case):
    """CholeskyQR2 (columns of very different scale) and the SVD fallback give lstsq's
    minimum-norm solution and an orthonormal range."""
    rng = np.random.default_rng(2)
    a = rng.normal(size=(2, 300, 6)) * np.logspace(-6, 6, 6)
    if case == "ill-conditioned":
        a[:, :, 5] = a[:, :, 4] * 1e6 + 1e-4 * a[:, :, 5]
    elif case == "rank-deficient":
        a[:, :, 5] = 0.0
    b = rng.normal(size=(2, 300))
    q, pinv = _range_and_pinv(a)
    c = np.einsum("yij,yj->yi", pinv, np.einsum("yfj,yf->yj", q, b))
    for y in range(2):
        ref = np.linalg.lstsq(a[y], b[y], rcond=None)[0]
        # error bound of a backward-stable solver: eps * cond(a) relative
        cond = np.linalg.cond(a[y] / np.maximum(np.linalg.norm(a[y], axis=0), 1e-300))
        tol = 100 * np.finfo(float).eps * min(cond, 1e8)
        np.testing.assert_allclose(c[y] * np.linalg.norm(a[y], axis=0),
                                   ref * np.linalg.norm(a[y], axis=0), atol=tol * np.abs(b[y]).sum())
        rank = np.linalg.matrix_rank(a[y])
        np.testing.assert_allclose(q[y].T @ q[y], np.diag([1.0] * rank + [0.0] * (6 - rank)),
                                   atol=1e-12)
