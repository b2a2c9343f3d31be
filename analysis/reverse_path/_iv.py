"""Instrumental variables for random records with sensor noise on the response.

``H = G_XZ G_RZ^-1`` with instruments ``Z``: the same basis functions evaluated on the
response *simulated* from the measured force through the candidate model with the current
estimates, so they are independent of the sensor noise at every lag (a delayed copy of the
measured response is not: a delay only multiplies its spectrum by a phase). The bases are
debiased with the noise variance of `._noise` and the velocity is low-passed where its
spectrum sinks into the noise floor.
"""

from __future__ import annotations


import numpy as np

from ..errors import InputError, ModelError
from ..models import Model
from ..plant import Plant, PlantError
from ..spectral import Spectra, spectral_matrix
from ._core import ReversePathResult, _channels, _estimate
from ._documents import IvNoise, NoiseInfo, WelchSettings

IV_PASSES = 2            # instrument refinements (each re-simulates with the latest estimate)


def iv_passes(result: ReversePathResult, model: Model, built, unknown, known,
              welch: WelchSettings, info: NoiseInfo,
              warnings: list[str]) -> ReversePathResult:
    """Instrumental-variable refinements: simulate, form instruments, re-estimate."""
    n_dof = model.n_dof
    for _ in range(IV_PASSES):
        try:
            current = result.estimated_model(model)
            parts = []
            for rec, proc, channels in built:
                out = Plant(current, rec.fs, rec.force_dofs).run(rec.force)
                sim = {"displacement": out.displacement, "velocity": out.velocity,
                       "acceleration": out.acceleration}[proc.kind]
                z, _ = _channels(sim, rec.force, rec.force_dofs, proc, unknown, known, [],
                                 None)
                parts.append(spectral_matrix([*channels, *z[n_dof:]], rec.fs, **welch))
        except (PlantError, ModelError) as exc:
            warnings.append(f"noise correction skipped: the candidate with the current "
                            f"estimates cannot be simulated ({exc}); estimates biased low")
            info["method"] = "none"
            return result
        scratch: list[str] = []
        spec = Spectra.pool(parts)
        solved = _iv_solution(spec, n_dof, result.force_dofs.size, len(result.inputs))
        result = _estimate(spec, n_dof, result.force_dofs, unknown, result.inputs,
                           result.band, "direct", scratch, solved)
    warnings.extend(scratch)
    coh = result.noise.get("instrument_coherence", [])
    info["instrument_coherence"] = coh
    if coh and min(coh) < 0.3:
        warnings.append(f"weak instruments (median coherence with the regressors "
                        f"{min(coh):.2f}): wide intervals; check the candidate's linear part "
                        "or record longer")
    return result


def _iv_solution(spec: Spectra, n_dof: int, n_in: int, n_r: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, IvNoise]:
    """IV transfer matrix, row covariance and residual variance from ``[X, R, Z]`` spectra."""
    S = spec.S
    xs, rs, zs = slice(0, n_dof), slice(n_dof, n_dof + n_r), slice(n_dof + n_r, None)
    H, cov, resid = _iv(S, xs, rs, zs)
    S_xx = np.einsum("fii->fi", S[:, xs, xs]).real
    sigma2 = np.maximum(resid, 1e-15 * S_xx) / max(spec.n_eff - n_r, 1.0)
    auto = np.einsum("fii->fi", S).real
    coh = [float(np.median(np.abs(S[:, n_dof + k, n_dof + n_r + k]) ** 2
                           / (auto[:, n_dof + k] * auto[:, n_dof + n_r + k])))
           for k in range(n_in, n_r)]
    return H, cov, sigma2, IvNoise(instrument_coherence=coh)


def iv_transfer(S_xz: np.ndarray, S_rz: np.ndarray, S_zz: np.ndarray, singular: str
                ) -> tuple[np.ndarray, np.ndarray]:
    """Instrumental-variable transfer ``H = S_XZ S_RZ^-1`` per frequency and the row
    covariance factor ``A^H S_ZZ A`` (``A = S_RZ^-1``; times the residual variance, the
    covariance of a row of ``H`` in `_form_covariance` order), from cross spectra or sums
    over observations alike.

    Raises
    ------
    InputError
        ``singular`` when ``S_RZ`` is singular at some frequency.
    """
    try:
        a = np.linalg.inv(S_rz)
    except np.linalg.LinAlgError:
        raise InputError(singular) from None
    return S_xz @ a, a.conj().transpose(0, 2, 1) @ S_zz @ a


def _iv(S: np.ndarray, xs: slice, rs: slice, zs: slice
        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Instrumental-variable ``H = S_XZ S_RZ^-1``, its row covariance matrix, residual PSD.

    With ``A = S_RZ^-1`` the row error ``dh = s_EZ A`` has covariance
    ``sigma^2 A^H S_ZZ A / n`` (`iv_transfer`); ``sigma^2`` is the auto-spectrum of the
    residual ``X - H R``.
    """
    S_xx, S_xr, S_rr = S[:, xs, xs], S[:, xs, rs], S[:, rs, rs]
    H, cov = iv_transfer(S[:, xs, zs], S[:, rs, zs], S[:, zs, zs],
                         "the instruments do not span the inputs (singular G_RZ): an input "
                         "is repeated or not excited; remove it or use noise='none'")
    hs = H @ S_xr.conj().transpose(0, 2, 1)
    resid = (np.einsum("fii->fi", S_xx).real - 2 * np.einsum("fii->fi", hs).real
             + np.einsum("fya,fab,fyb->fy", H, S_rr, H.conj()).real)
    return H, cov, resid
