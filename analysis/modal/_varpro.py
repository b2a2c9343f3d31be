"""Variable projection of the modal receptance model: residual and Jacobian in the poles.

The model ``H_i(s) = sum_r A_ir / (s - λ_r) + conj + residual terms``, seen through a
smoothing kernel, is linear in the residues and residual terms and nonlinear only in the
poles. For given poles the linear coefficients are the least-squares solution; what is left
(the *reduced* residual) depends on the poles alone, and its Jacobian is closed form
(Golub & Pereyra 1973): with ``A`` the weighted basis, ``c = A⁺ b``, ``r = A c - b`` and
``P⊥ = I - A A⁺``,

    ``∂r/∂x_k = P⊥ (∂A/∂x_k) c - (A⁺)ᵀ (∂A/∂x_k)ᵀ r``,

where only the two columns of the pole ``x_k`` belongs to depend on it
(``∂/∂λ 1/(s - λ) = 1/(s - λ)²``). Every output shares the basis up to its row weights, so
all outputs are solved at once (CholeskyQR2, or the SVD of ``numpy.linalg.lstsq`` where
ill-conditioned: `_range_and_pinv`). The kernel sum is a sparse matrix over the distinct points ``s`` it reaches: a
Welch kernel oversampled by an integer factor reaches each point from many lines, so the
pole terms are evaluated once per point, not once per line and offset.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse


class PoleProjection:
    """Reduced residual of a modal receptance fit as a function of its poles.

    Parameters
    ----------
    s : ndarray, complex, shape (n_f, n_k)
        Laplace variable of every line (rows) and kernel offset (columns).
    kernel : ndarray, shape (n_k,) or (n_f, n_k)
        Kernel weights (one row per line, or one row for all).
    extra : list of ndarray, complex, shape (n_f,)
        Residual-term columns (already summed through the kernel).
    real_extra : bool
        The residual terms have real coefficients (pseudo-modes) instead of complex ones.
    h : ndarray, complex, shape (n_f, n_out)
        Data.
    scale : ndarray, shape (n_f, n_out)
        Weight of each residual.

    Notes
    -----
    The parameters ``x`` are ``[f_0, ζ_0, f_1, ζ_1, ...]`` (Hz, damping ratio); the residual
    is ``[Re, Im]`` of ``scale * (model - h)`` per output, outputs concatenated.
    """

    def __init__(self, s: np.ndarray, kernel: np.ndarray, extra: list[np.ndarray],
                 real_extra: bool, h: np.ndarray, scale: np.ndarray) -> None:
        n_f, n_k = s.shape
        self.points, inverse = np.unique(s.ravel(), return_inverse=True)
        rows = np.repeat(np.arange(n_f), n_k)
        weights = np.broadcast_to(kernel, (n_f, n_k)).ravel()
        self.kernel = scipy.sparse.csr_matrix((weights, (rows, inverse.ravel())),
                                              shape=(n_f, self.points.size))
        self.kernel.sum_duplicates()
        cols = [c * m for c in extra for m in ((1.0,) if real_extra else (1.0, 1j))]
        self.fixed = np.stack(cols, axis=1) if cols else np.zeros((n_f, 0), dtype=complex)
        self.real_extra = real_extra
        self.scale = np.asarray(scale, dtype=float).T               # (n_out, n_f)
        hs = self.scale * np.asarray(h, dtype=complex).T
        self.b = np.concatenate([hs.real, hs.imag], axis=1)         # (n_out, 2 n_f)
        self._x: np.ndarray | None = None

    @staticmethod
    def poles(x: np.ndarray) -> np.ndarray:
        """Poles ``λ = 2π f (-ζ + j sqrt(1 - ζ²))`` of the parameters."""
        x = np.asarray(x, dtype=float)
        return 2 * np.pi * x[0::2] * (-x[1::2] + 1j * np.sqrt(1 - x[1::2] ** 2))

    def _stack(self, z: np.ndarray) -> np.ndarray:
        """Real form ``[Re; Im]`` along the line axis (axis 1) of a weighted complex array."""
        return np.concatenate([z.real, z.imag], axis=1)

    def _evaluate(self, x: np.ndarray) -> None:
        """Basis, its pole derivatives and the least-squares solution at ``x`` (cached)."""
        if self._x is not None and np.array_equal(x, self._x):
            return
        p = self.poles(x)
        nm = p.size
        g = 1 / (self.points[:, None] - p[None, :])
        gc = 1 / (self.points[:, None] - np.conj(p)[None, :])
        summed = self.kernel @ np.concatenate([g, gc, g * g, gc * gc], axis=1)
        G, Gc, G2, Gc2 = (summed[:, i * nm:(i + 1) * nm] for i in range(4))
        modes = np.stack([G + Gc, 1j * (G - Gc)], axis=2).reshape(G.shape[0], 2 * nm)
        basis = np.concatenate([modes, self.fixed], axis=1)       # (n_f, n_lin)
        a = self._stack(self.scale[:, :, None] * basis[None])     # (n_out, 2 n_f, n_lin)
        q, pinv = _range_and_pinv(a)
        c = np.einsum("yij,yj->yi", pinv, np.einsum("yfj,yf->yj", q, self.b))
        # pole derivatives: dλ/df = λ/f, dλ/dζ = 2π f (-1 - j ζ / sqrt(1 - ζ²))
        f, z = x[0::2], x[1::2]
        dp = np.stack([p / f, 2 * np.pi * f * (-1 - 1j * z / np.sqrt(1 - z ** 2))],
                      axis=1).ravel()                             # (2 nm,) as x
        mode = np.repeat(np.arange(nm), 2)
        d_g, d_gc = G2[:, mode] * dp, Gc2[:, mode] * np.conj(dp)
        self._x = np.array(x, dtype=float)
        self._cache = (q, pinv, c, d_g + d_gc, 1j * (d_g - d_gc), mode,
                       np.einsum("yfi,yi->yf", a, c) - self.b)

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Reduced residual, shape (2 n_f n_out,)."""
        self._evaluate(x)
        return self._cache[-1].ravel()

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of `residual`, shape (2 n_f n_out, len(x)) (Golub-Pereyra, module doc)."""
        self._evaluate(x)
        q, pinv, c, d1, d2, mode, r = self._cache
        c1, c2 = c[:, 2 * mode], c[:, 2 * mode + 1]                # (n_out, 2 nm)
        s1 = self._stack(self.scale[:, :, None] * d1[None])       # (n_out, 2 n_f, 2 nm)
        s2 = self._stack(self.scale[:, :, None] * d2[None])
        dac = s1 * c1[:, None, :] + s2 * c2[:, None, :]           # (∂A/∂x_k) c
        proj = dac - q @ (np.swapaxes(q, 1, 2) @ dac)
        k = np.arange(mode.size)
        w = np.zeros((c.shape[0], c.shape[1], k.size))            # (∂A/∂x_k)ᵀ r
        w[:, 2 * mode, k] = np.einsum("yfk,yf->yk", s1, r)
        w[:, 2 * mode + 1, k] = np.einsum("yfk,yf->yk", s2, r)
        jac = proj - q @ (np.swapaxes(pinv, 1, 2) @ w)          # (A⁺)ᵀ = q P^T
        return jac.reshape(-1, x.size)

    def coefficients(self, x: np.ndarray) -> np.ndarray:
        """Linear coefficients at ``x``, complex, shape (n_modes + n_extra, n_out): residues,
        then residual terms (real for pseudo-modes)."""
        self._evaluate(x)
        c = self._cache[2]
        nm = x.size // 2
        modes = c[:, 0:2 * nm:2] + 1j * c[:, 1:2 * nm:2]
        rest = c[:, 2 * nm:]
        extra = rest + 0j if self.real_extra else rest[:, 0::2] + 1j * rest[:, 1::2]
        return np.concatenate([modes, extra], axis=1).T


GRAM_RATIO = 1e-10
"""Smallest eigenvalue ratio of the column-scaled Gram matrix (condition number 1e5) for
which Cholesky QR is used: twice applied (CholeskyQR2) it is then as accurate as
Householder QR (Yamamoto et al. 2015); below, or where a column is zero, the SVD."""


def _range_and_pinv(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal basis ``q`` of the column space of each ``a[y]`` and ``P`` with
    ``a⁺ = P qᵀ``.

    Tall matrices by matrix products and small factorisations (CholeskyQR2 of the column-
    scaled matrix), which cost little where LAPACK's tall SVD/QR, threaded, spin on a loaded
    machine; an ill-conditioned or rank-deficient ``a`` takes the SVD with the cut-off of
    `numpy.linalg.lstsq` (its minimum-norm solution).

    Parameters
    ----------
    a : ndarray, shape (n_out, m, n), m >= n

    Returns
    -------
    q : ndarray, shape (n_out, m, n)
        Orthonormal columns (zero columns for a cut singular value).
    pinv : ndarray, shape (n_out, n, n)
    """
    norm = np.linalg.norm(a, axis=1)                               # (n_out, n)
    if np.all(norm > 0):
        an = a / norm[:, None, :]
        gram = np.swapaxes(an, 1, 2) @ an
        ev = np.linalg.eigvalsh(gram)
        if np.all(ev[:, 0] > GRAM_RATIO * ev[:, -1]):
            r1 = np.swapaxes(np.linalg.cholesky(gram), 1, 2)
            q1 = an @ np.linalg.inv(r1)
            r2 = np.swapaxes(np.linalg.cholesky(np.swapaxes(q1, 1, 2) @ q1), 1, 2)
            q = q1 @ np.linalg.inv(r2)
            return q, np.linalg.inv(r2 @ r1) / norm[:, :, None]
    u, sv, vt = np.linalg.svd(a, full_matrices=False)
    keep = sv > np.finfo(float).eps * max(a.shape[1:]) * sv[:, :1]   # lstsq's rcond
    sinv = np.where(keep, 1 / np.where(keep, sv, 1.0), 0.0)
    return u * keep[:, None, :], np.swapaxes(vt, 1, 2) * sinv[:, None, :]
