"""Underlying linear FRF from the residual force, for modal parameters free of Welch leakage.

With every element known (the reverse-path estimates filled in), the force the linear part
feels is ``f_lin = F - sum_m p_m w_m g_m``. When all elements act on the forced DOFs it is a
force at those DOFs only and ``x = H_L f_lin`` with the forced columns of the receptance:
a plain H1 whose input spectrum is as flat as the excitation. That is what a Welch
estimate's leakage model needs (`analysis.modal.welch_smoothing`): the expected estimate is
the true FRF smoothed by the window's kernel, so the modal fit can undo the smoothing. The
reverse path's own ``H_linear`` comes out of a regression on bases whose spectra peak at the
resonances, where that model does not hold (measured: damping 1.34 % instead of 0.79 % at
0.5 Hz lines on `examples/campaign-sim-random.toml`, 0.84 % by this route, 0.79 % at 0.25 Hz).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..models import Model
from ._core import ReversePathResult, _channels, _force_span, _Processing, _records
from ..spectral import Spectra, h1, spectral_matrix


def residual_force_frf(data: Any, estimated: Model, result: ReversePathResult, *,
                       fs: float | None = None, force_dofs: Any = None,
                       response_kind: str = "displacement", overlap: float = 0.5,
                       force_hold: str | None = None
                       ) -> tuple[np.ndarray, np.ndarray, Spectra] | None:
    """H1 from the residual force at the forced DOFs to every DOF, on ``result``'s grid.

    Parameters
    ----------
    data, fs, force_dofs, response_kind, overlap, force_hold
        As given to `analysis.reverse_path.reverse_path` for ``result``.
    estimated : Model
        The candidate with every parameter filled in (`ReversePathResult.estimated_model`).
    result : ReversePathResult
        Its band, segment length, window and noise treatment are reused.

    Returns
    -------
    (freqs, H, spectra) or None
        ``H`` of shape (n_f, n_dof, n_in); None where the route does not apply: an element
        off the forced DOFs, periodic (exact-line) records, or a noisy response (``noise``
        method "iv": the noise would enter ``f_lin`` through the elements).
    """
    spec = result.spectra
    if spec.window is None or result.noise.get("method") != "none":
        return None
    fdofs = result.force_dofs
    if any(_force_span(el.w, fdofs) is None for el in estimated.elements):
        return None
    known = list(enumerate(estimated.elements))
    lo, hi = result.band
    parts = []
    for rec, kind in _records(data, fs, force_dofs, response_kind):
        proc = _Processing(float(rec.fs), kind, (lo, hi), "off",
                           force_hold or rec.force_hold, None)
        channels, _ = _channels(rec.response, rec.force, rec.force_dofs, proc, [], known, [],
                                None)
        parts.append(spectral_matrix(channels, float(rec.fs), nperseg=spec.nperseg,
                                     window=spec.window, overlap=overlap, band=(lo, hi)))
    pooled = Spectra.pool(parts)
    n_dof = estimated.n_dof
    S = pooled.S
    return pooled.freqs, h1(S[:, :n_dof, n_dof:], S[:, n_dof:, n_dof:]), pooled
