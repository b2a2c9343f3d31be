"""Backbone of one mode: natural frequency and damping ratio against amplitude, level by level
(single-nonlinear-mode theory: the mode keeps its shape, its frequency and damping depend on
its amplitude).

* Response-controlled levels (the controller held the response amplitude at
  ``control_dof``) are quasi-linear: at a held amplitude the joint's stiffness and damping
  are fixed, so each level's FRF is fitted by a single linear mode (`fit_single_mode`) and
  the fit gives that amplitude's frequency and damping with their intervals.
* Force-controlled levels sweep through amplitudes along each curve. They are read as the
  literature reads them (Szemplinska-Stupnicka 1979; Peeters et al. 2011, phase resonance;
  Krack 2015, single nonlinear mode): every step is inverted through the modal constant
  ``A`` and residual ``R`` of the lowest level (the most linear one), ``D = (i w)^k A /
  (H - R) = wn^2 - w^2 + 2 i zeta wn w``, which gives ``wn`` and ``zeta`` at that step's
  amplitude; the level's backbone point is read at phase resonance (``Re D = 0``: the
  displacement lags the force by 90 deg), interpolated between its two bracketing steps,
  whose spread is the interval.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ..errors import EstimationError, InputError
from ..recordings import KIND_ORDER, Control, StepTable
from ._single_mode import ModalEstimate, ModeFit, fit_single_mode

#: version of `Backbone.to_json`'s layout
SCHEMA_VERSION = 1
#: relative rounding of the step-wise inversion: the narrowest interval it reports
ROUNDING = 1e-9
#: method names written to the JSON
#: key order of a level in the JSON (contracts section 6)
JSON_ORDER = ("level", "amplitude", "amplitude_kind", "displacement_amplitude", "frequency_hz",
              "frequency_ci95", "damping_ratio", "damping_ci95", "modal_constant", "fit_error",
              "method", "n_steps")
RESPONSE_METHOD = "single-mode fit at held response amplitude"
FORCE_METHOD = "phase resonance of the step-wise inverse FRF (single nonlinear mode)"


@dataclass(frozen=True, kw_only=True)
class BackbonePoint(ModalEstimate):
    """One level of a backbone: a `ModalEstimate` (force control: the lowest level's modal
    constant) at an amplitude.

    Attributes
    ----------
    level : float
        The level's held amplitude (N for force control, else the response's unit).
    amplitude : float
        Response amplitude of the mode's channel at this point, in ``amplitude_kind``.
    amplitude_kind : str
    displacement_amplitude : float
        ``amplitude`` as displacement at the natural frequency, m.
    fit_error : float
        Relative error of the level's single-mode fit (for a force-controlled level it
        measures how far the curve is from a linear mode).
    method : str
    n_steps : int
    """

    level: float
    amplitude: float
    amplitude_kind: str
    displacement_amplitude: float
    fit_error: float
    method: str
    n_steps: int

    def to_json(self) -> dict[str, Any]:
        """The point's entry of ``levels`` (contracts section 6 names)."""
        out: dict[str, Any] = {k: getattr(self, k) for k in JSON_ORDER}
        out["modal_constant"] = float(self.modal_constant.real)
        out["modal_constant_imag"] = float(self.modal_constant.imag)
        out["frequency_ci95"] = list(self.frequency_ci95)
        out["damping_ci95"] = list(self.damping_ci95)
        return out


@dataclass(frozen=True)
class Backbone:
    """Amplitude-dependent modal properties of one mode, one point per level in run order.

    Attributes
    ----------
    points : tuple of BackbonePoint
    channel : int
        Response channel the amplitudes and FRFs are read at.
    control : Control
    band_hz : (float, float)
        Frequencies the levels span.
    linear : ModeFit
        Single-mode fit of the lowest level (the mode's linear properties).
    """

    points: tuple[BackbonePoint, ...]
    channel: int
    control: Control
    band_hz: tuple[float, float]
    linear: ModeFit
    schema_version: int = SCHEMA_VERSION

    def to_json(self) -> dict[str, Any]:
        """``{"schema_version", "levels": [...], "mode": {...}}`` (contracts section 6)."""
        lin = self.linear
        mode = {"channel": self.channel, "control": str(self.control),
                "band_hz": list(self.band_hz), "frequency_hz": lin.frequency_hz,
                "damping_ratio": lin.damping_ratio,
                "modal_constant": float(lin.modal_constant.real),
                "method": self.points[0].method if self.points else ""}
        return json.loads(json.dumps({"schema_version": self.schema_version,
                                      "levels": [p.to_json() for p in self.points],
                                      "mode": mode}))


def _kind(table: StepTable, channel: int) -> str:
    if table.sensors is not None:
        return table.sensors.response_kinds[channel]
    return table.response_kind


def _channel(tables: Sequence[StepTable], channel: int | None) -> int:
    first = tables[0]
    if channel is None:
        channel = first.control_dof if first.control == Control.RESPONSE else \
            int(first.force_dofs[0])
    if not 0 <= channel < first.n_dof:
        raise InputError(f"channel {channel} is not a response channel (0..{first.n_dof - 1})")
    return int(channel)


def backbone(tables: Sequence[StepTable], channel: int | None = None) -> Backbone:
    """The backbone of the mode in the levels' band (module docstring).

    Parameters
    ----------
    tables : sequence of StepTable
        The levels of one run (all response- or all force-controlled), in run order.
    channel : int, optional
        Response channel to read (default: the held one, else the driving point).

    Returns
    -------
    Backbone
    """
    if not tables:
        raise InputError("a backbone needs at least one stepped-sine level")
    controls = {t.control for t in tables}
    if len(controls) != 1:
        raise InputError("the levels mix force and response control; compute their "
                         "backbones separately")
    j = _channel(tables, channel)
    fits = [fit_single_mode(t.freqs, t.frf()[:, j, 0], KIND_ORDER[_kind(t, j)])
            for t in tables]
    low = int(np.argmin([t.level for t in tables]))
    control = controls.pop()
    if control == Control.RESPONSE:
        points = [_held_point(t, fit, j) for t, fit in zip(tables, fits)]
    else:
        points = [_phase_resonance(t, fits[low], fit, j) for t, fit in zip(tables, fits)]
    lo = min(float(t.freqs.min()) for t in tables)
    hi = max(float(t.freqs.max()) for t in tables)
    return Backbone(tuple(points), j, control, (lo, hi), fits[low])


def _held_point(t: StepTable, fit: ModeFit, j: int) -> BackbonePoint:
    """A response-controlled level: its own single-mode fit at its held amplitude."""
    kind = _kind(t, j)
    amp = float(np.median(np.abs(t.response_phasor[:, j])))
    disp = amp / (2 * np.pi * fit.frequency_hz) ** KIND_ORDER[kind]
    return BackbonePoint(level=t.level, amplitude=amp, amplitude_kind=kind,
                         displacement_amplitude=disp, frequency_hz=fit.frequency_hz,
                         frequency_ci95=fit.frequency_ci95, damping_ratio=fit.damping_ratio,
                         damping_ci95=fit.damping_ci95, modal_constant=fit.modal_constant,
                         fit_error=fit.fit_error, method=RESPONSE_METHOD, n_steps=t.n_steps)


def stepwise_modal(t: StepTable, linear: ModeFit, j: int) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency (Hz) and damping ratio at each step of a level, by inverting its FRF
    through the linear fit's modal constant and residual (module docstring).

    Parameters
    ----------
    t : StepTable
    linear : ModeFit
        The lowest level's fit.
    j : int
        Response channel.

    Returns
    -------
    fn, zeta : ndarray, shape (n_steps,)
    """
    w = 2 * np.pi * t.freqs
    H = t.frf()[:, j, 0]
    D = (1j * w) ** KIND_ORDER[_kind(t, j)] * linear.modal_constant / (H - linear.residual)
    wn = np.sqrt(np.maximum(D.real + w**2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = D.imag / (2 * wn * w)
    return wn / (2 * np.pi), zeta


def _phase_resonance(t: StepTable, linear: ModeFit, fit: ModeFit, j: int) -> BackbonePoint:
    """A force-controlled level's point at phase resonance (module docstring)."""
    kind = _kind(t, j)
    order = np.argsort(t.freqs)
    w = 2 * np.pi * t.freqs[order]
    H = t.frf()[order, j, 0]
    D = (1j * w) ** KIND_ORDER[kind] * linear.modal_constant / (H - linear.residual)
    cross = np.flatnonzero(np.diff(np.sign(D.real)) != 0)
    if cross.size == 0:
        raise EstimationError(f"level {t.level:g}: the curve does not pass through phase "
                              "resonance (90 deg lag) within its steps; widen the band")
    i = int(cross[np.argmin(np.abs(H[cross]))]) if cross.size > 1 else int(cross[0])
    s = D.real[i] / (D.real[i] - D.real[i + 1])   # in w^2, where Re D = wn^2 - w^2 is linear
    fn_steps, zeta_steps = stepwise_modal(t, linear, j)
    fn_steps, zeta_steps = fn_steps[order], zeta_steps[order]
    fn = float(np.sqrt(w[i] ** 2 + s * (w[i + 1] ** 2 - w[i] ** 2))) / (2 * np.pi)
    zeta = float(zeta_steps[i] + s * (zeta_steps[i + 1] - zeta_steps[i]))
    amps = np.abs(t.response_phasor[order, j])
    amp = float(amps[i] + s * (amps[i + 1] - amps[i]))
    # the interval: the bracketing steps' spread, at least the inversion's rounding (RELATIVE)
    dz = max(float(abs(zeta_steps[i + 1] - zeta_steps[i])) / 2, ROUNDING * abs(zeta))
    df = max(float(abs(fn_steps[i + 1] - fn_steps[i])) / 2,
             float(abs(fn - fn_steps[i:i + 2]).max()), ROUNDING * fn)
    disp = amp / (2 * np.pi * fn) ** KIND_ORDER[kind]
    return BackbonePoint(level=t.level, amplitude=amp, amplitude_kind=kind,
                         displacement_amplitude=disp, frequency_hz=fn,
                         frequency_ci95=(fn - df, fn + df), damping_ratio=zeta,
                         damping_ci95=(zeta - dz, zeta + dz),
                         modal_constant=linear.modal_constant, fit_error=fit.fit_error,
                         method=FORCE_METHOD, n_steps=t.n_steps)
