"""The lowest band of an integrated record's displacement, formed from the force through the
estimated model instead of by integration.

A double integration of an acceleration record misses part of the displacement's content far
below the first resonance (the high-pass, the detrend of the integration constants and the
record's ends take it: 40-100 % of the content below 0.5 Hz on the 2-DOF cubic of
docs/reverse-path.md), and a polynomial basis mixes that slow error over the whole band (a
term ``3 p s^2 delta`` no input holds). There the structure responds quasi-statically: the
candidate's linear part carries the measured force less the elements' forces (evaluated with
the first pass's estimates on the measured motion) to the displacement,
``X = H_L (B F - sum w_m G_m)``, as well as the model knows the stiffness. The displacement
formed keeps its integrated content above the crossover and takes the model's below it.
The elements' forces come from the measured motion, not from a simulation: a strongly
driven cubic structure is chaotic (a 1e-6 change of p moved a simulated response 5-9 %).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft

from ..models import Model, deformation, restoring_force

#: The crossover sits at this share of the top of the quasi-static band (where the largest
#: |H| of the forces first doubles its low-frequency value, `quasi_static_top`).
LOW_SHARE = 0.18
#: Passes of forming the low band, each from the elements' forces on the previous motion,
#: and the share of the way to the new band each pass moves (a full step diverged on the
#: 2-DOF cubic of docs/reverse-path.md after 3-6 passes; half steps settle within 8).
LOW_PASSES, RELAX = 8, 0.5


@dataclass(frozen=True)
class LowBand:
    """The estimated model that forms an integrated record's lowest band.

    Attributes
    ----------
    model : Model
        The candidate with every estimated parameter filled in.
    fc : float
        Crossover, Hz: the model's content below ``fc``, the integrated one above ``2 fc``,
        a squared-cosine taper between.
    """

    model: Model
    fc: float

    def apply(self, x: np.ndarray, v: np.ndarray, force: np.ndarray, force_dofs: np.ndarray,
              fs: float) -> tuple[np.ndarray, np.ndarray]:
        """Integrated displacement and velocity with their lowest band from the model.

        Parameters
        ----------
        x, v : ndarray, shape (n, n_dof)
            Displacement and velocity formed by integration.
        force : ndarray, shape (n, n_in)
            The force the structure felt.
        force_dofs : ndarray of int
        fs : float
            Sample rate, Hz.

        Returns
        -------
        x, v : ndarray
        """
        n = x.shape[0]
        # zero padding: a linear (not circular) filter; its end effects, about 1 / fc long,
        # fall in the samples the channels drop at both ends
        m = scipy.fft.next_fast_len(n + int(4 * fs / self.fc))
        f = np.fft.rfftfreq(m, 1 / fs)
        near = f < 2 * self.fc
        low = np.sin(0.5 * np.pi * np.clip((2 * self.fc - f[near]) / self.fc, 0, 1)) ** 2
        h = self.model.linear_frf(f[near])                   # (n_f, n_dof, n_dof)
        iw = 2j * np.pi * f[near, None]
        for _ in range(LOW_PASSES):
            load, tangent = self._loads(x, v, force, force_dofs, iw[:, 0])
            # X = H (B F - G(x)) as (I + H D) X = H (B F - G(x) + D x) with D the elements'
            # mean stiffness and damping: iterated from the integrated motion, the plain
            # form diverges (a cubic's tangent stiffness dominates on a strong drive)
            rhs = np.einsum("fab,fb->fa", h, scipy.fft.rfft(load, m, axis=0)[near]
                            + np.einsum("fab,fb->fa", tangent,
                                        scipy.fft.rfft(x, m, axis=0)[near]))
            lhs = np.eye(x.shape[1]) + h @ tangent
            model_x = np.linalg.solve(lhs, rhs[..., None])[..., 0]
            x, v = (_swap(sig, target, RELAX * low, near, m)
                    for sig, target in ((x, model_x), (v, iw * model_x)))
        return x, v

    def _loads(self, x: np.ndarray, v: np.ndarray, force: np.ndarray, force_dofs: np.ndarray,
               iw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The load ``B F - sum w_m g_m`` on the DOFs, (n, n_dof), and the elements' mean
        dynamic stiffness ``sum w_m (k_m + i w c_m) w_m'`` per line, (n_f, n_dof, n_dof):
        ``k_m, c_m`` the least-squares fit of ``g_m`` on the deformation and its rate."""
        load = np.zeros_like(x)
        load[:, force_dofs] += force
        tangent = np.zeros((iw.size, x.shape[1], x.shape[1]), dtype=complex)
        for el in self.model.elements:
            s, sv = deformation(el.w, x), deformation(el.w, v)
            g = restoring_force(el.kind, el.params, s, sv)[0]
            load -= np.outer(g, el.w)
            k, c = np.linalg.lstsq(np.column_stack([s, sv]), g, rcond=None)[0]
            tangent += (k + iw * c)[:, None, None] * np.outer(el.w, el.w)
        return load, tangent


def _swap(sig: np.ndarray, target: np.ndarray, low: np.ndarray, near: np.ndarray,
          m: int) -> np.ndarray:
    """``sig`` with its lines under ``near`` moved towards ``target`` by ``low``."""
    spec = scipy.fft.rfft(sig, m, axis=0)
    spec[near] += low[:, None] * (target - spec[near])
    return scipy.fft.irfft(spec, m, axis=0)[:sig.shape[0]]


def quasi_static_top(freqs: np.ndarray, gain: np.ndarray) -> float:
    """Frequency at which ``gain`` (largest |H| of the forces per line) first reaches twice
    its median over the lowest four lines: the quasi-static band ends there (an undamped
    single mode's does at 0.71 of its frequency). A peak search would be fooled by the
    ripple of an estimated FRF.

    Parameters
    ----------
    freqs, gain : ndarray, shape (n_f,)

    Returns
    -------
    float
    """
    above = np.flatnonzero(gain > 2 * np.median(gain[:4]))
    return float(freqs[above[0]] if above.size else freqs[-1])
