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


def _basis(case):
    """Two 300 x 6 bases with columns scaled 1e-6 .. 1e6 and right-hand sides."""
    rng = np.random.default_rng(2)
    a = rng.normal(size=(2, 300, 6)) * np.logspace(-6, 6, 6)
    if case == "ill-conditioned":
        a[:, :, 5] = a[:, :, 4] * 1e6 + 1e-4 * a[:, :, 5]
    elif case == "rank-deficient":
        a[:, :, 5] = 0.0
    return a, rng.normal(size=(2, 300))


def _lstsq_check(x, a, b):
    """Error of ``x`` against a reference solution of ``min |a x - b|`` and the bound a
    backward-stable solver's error obeys.

    Where every column is non-zero and the column-scaled ``an = a / |a_j|`` is well
    conditioned, `_range_and_pinv` solves for ``an`` (CholeskyQR2) and the reference is
    lstsq of ``an``: the error is measured on the scaled coefficients ``x |a_j|``. Otherwise
    both are lstsq's truncated SVD of ``a`` itself, compared on ``x``. Two backward-stable
    solvers (backward error ``m n u``, Higham, *Accuracy and Stability*, Thm 20.1) each
    stay within ``kappa m n u (2 + (kappa + 1) |r| / (|a| |x|)) |x|`` of the exact solution,
    ``kappa`` the condition number of the matrix solved (of its kept singular values), so
    they differ by at most twice that. Column scaling is why a fixed digit count fails:
    lstsq of the unscaled basis (condition 1e12) is only good to ~1e-7 in the scaled case.
    """
    norm = np.linalg.norm(a, axis=0)
    scaled = bool(np.all(norm > 0)) and np.linalg.cond(a / norm) < 1e6
    m = a / norm if scaled else a
    w = norm if scaled else np.ones_like(norm)
    ref = np.linalg.lstsq(m, b, rcond=None)[0]
    sv = np.linalg.svd(m, compute_uv=False)
    kept = sv[sv > np.finfo(float).eps * max(m.shape) * sv[0]]      # lstsq's cut-off
    kappa = kept[0] / kept[-1]
    r = np.linalg.norm(m @ ref - b)
    size = np.linalg.norm(ref)
    eps = m.size * np.finfo(float).eps
    bound = 2 * kappa * eps * (2 + (kappa + 1) * r / (kept[0] * size)) * size
    return float(np.linalg.norm(x * w - ref)), float(bound)


@pytest.mark.parametrize("case", ["scaled", "ill-conditioned", "rank-deficient"])
def test_range_and_pinv_solve_as_lstsq(case):
    """CholeskyQR2 (columns of very different scale) and the SVD fallback give lstsq's
    minimum-norm solution within the conditioning bound, and an orthonormal range."""
    a, b = _basis(case)
    q, pinv = _range_and_pinv(a)
    c = np.einsum("yij,yj->yi", pinv, np.einsum("yfj,yf->yj", q, b))
    for y in range(2):
        err, bound = _lstsq_check(c[y], a[y], b[y])
        assert err <= bound, (err, bound)
        rank = np.linalg.matrix_rank(a[y])
        np.testing.assert_allclose(q[y].T @ q[y], np.diag([1.0] * rank + [0.0] * (6 - rank)),
                                   atol=1e-12)


def test_lstsq_check_rejects_a_wrong_solver():
    """The bound is tight enough to catch a solver that loses digits: CholeskyQR2 in single
    precision, and lstsq of the unscaled basis (accurate to eps times its condition, 1e12)."""
    a, b = _basis("scaled")
    q, pinv = _range_and_pinv(a.astype(np.float32))
    single = np.einsum("yij,yj->yi", pinv, np.einsum("yfj,yf->yj", q, b.astype(np.float32)))
    for y in range(2):
        for x in (single[y].astype(float), np.linalg.lstsq(a[y], b[y], rcond=None)[0]):
            err, bound = _lstsq_check(x, a[y], b[y])
            assert err > bound, (err, bound)
