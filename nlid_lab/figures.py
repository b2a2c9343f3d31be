"""Report figures (matplotlib, Agg): one function per paper-style figure, each returns a Figure.

Every axis carries its quantity and unit; curves across levels use one sequential colour map
(low level light, high level dark) so the trend reads at a glance.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from analysis.frf import LevelFRF

FIGSIZE = (8.0, 5.6)
DPI = 110


def level_colours(n: int) -> list[tuple[float, ...]]:
    """Sequential colours for ``n`` levels (light = low, dark = high)."""
    cmap = colormaps["viridis"]
    return [cmap(x) for x in np.linspace(0.85, 0.0, n)] if n > 1 else [cmap(0.3)]


def phase_deg(h: np.ndarray) -> np.ndarray:
    """Phase in [-270, 90) degrees: a receptance sits near 0 below a mode and near -180
    above it, so neither wraps (no +-180 flicker on noisy bins)."""
    return np.mod(np.degrees(np.angle(h)) + 270.0, 360.0) - 270.0


def _frf_axes(title: str) -> tuple[Figure, object, object]:
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    mag, ph = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    fig.suptitle(title)
    for ax in (mag, ph):
        ax.grid(True, which="both", alpha=0.3)
    ph.set_xlabel("Frequency [Hz]")
    ph.set_ylabel("Phase [deg]")
    ph.set_ylim(-275, 95)
    ph.set_yticks([-270, -180, -90, 0, 90])
    return fig, mag, ph


def _pair_name(frf: "LevelFRF", out: int, inp: int) -> str:
    return f"response DOF {out} / force at DOF {int(frf.force_dofs[inp])}"


def frf_levels(frfs: Sequence["LevelFRF"], out: int, inp: int = 0) -> Figure:
    """FRF magnitude and phase at every level overlaid (paper figs 2.1, 3.5, 4.5)."""
    ref = frfs[0]
    fig, mag, ph = _frf_axes(f"FRF per level: {_pair_name(ref, out, inp)}")
    for frf, colour in zip(frfs, level_colours(len(frfs))):
        h = frf.H[:, out, inp]
        style = "o-" if frf.excitation == "stepped-sine" else "-"
        mag.semilogy(frf.freqs, np.abs(h), style, color=colour, ms=3, lw=1.2, label=frf.label)
        ph.plot(frf.freqs, phase_deg(h), style, color=colour, ms=3, lw=1.2)
    mag.set_ylabel(f"|H| [{ref.units}]")
    mag.legend(title="force level", fontsize="small")
    _fit_band(mag, frfs)
    return fig


def _fit_band(ax, frfs: Sequence["LevelFRF"]) -> None:
    lo = min(float(f.freqs[f.freqs > 0].min()) for f in frfs)
    hi = max(float(f.freqs.max()) for f in frfs)
    ax.set_xlim(lo, hi)


def multiple_coherence_levels(frfs: Sequence["LevelFRF"], out: int) -> Figure:
    """Multiple coherence of one output at every random level (linear analysis)."""
    fig = Figure(figsize=(FIGSIZE[0], 3.6), dpi=DPI, layout="constrained")
    ax = fig.subplots()
    shown = [f for f in frfs if f.multiple_coherence is not None]
    for frf, colour in zip(shown, level_colours(len(shown))):
        ax.plot(frf.freqs, frf.multiple_coherence[:, out], color=colour, lw=1.2, label=frf.label)
    _coherence_axes(ax, f"Multiple coherence, response DOF {out} (linear analysis)")
    ax.legend(title="force level", fontsize="small")
    _fit_band(ax, shown)
    return fig


def level_change(change) -> Figure:
    """Change of the FRF between two levels over its noise, per response, in dB, with the
    line a linear structure exceeds on 1 % of the lines (`analysis.detect.LevelChange`)."""
    fig = Figure(figsize=(FIGSIZE[0], 3.8), dpi=DPI, layout="constrained")
    ax = fig.subplots()
    z = np.maximum(change.z, 1e-6)
    for q, colour in zip(range(z.shape[1]), level_colours(z.shape[1])):
        ax.plot(change.freqs, 10 * np.log10(z[:, q]), color=colour, lw=0.9,
                label=f"response DOF {q}")
    ax.axhline(10 * np.log10(change.threshold), color="k", ls="--", lw=1,
               label="linear structure: exceeded on 1 % of lines")
    lo, hi = change.summary["levels"]
    ax.set_title(f"FRF change between {lo:g} and {hi:g} N rms over its noise")
    ax.set_xlabel("Frequency [Hz]")
    ax.set_ylabel("|ΔH|² / var [dB]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_xlim(change.freqs[0], change.freqs[-1])
    return fig


def bla_levels(frfs: Sequence["LevelFRF"], out: int) -> Figure:
    """Robust BLA per periodic-random level: |G|, the total standard deviation of G (noise +
    nonlinear distortion, dashed) and its noise standard deviation (dotted)."""
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    ax = fig.subplots()
    for k, (frf, colour) in enumerate(zip(frfs, level_colours(len(frfs)))):
        b = frf.bla
        ax.semilogy(b.freqs, np.abs(b.G[:, out]), color=colour, lw=1.3, label=frf.label)
        ax.semilogy(b.freqs, np.sqrt(b.var_total[:, out]), "--", color=colour, lw=0.9,
                    label="std, total (noise + distortion)" if k == 0 else None)
        ax.semilogy(b.freqs, np.sqrt(b.var_noise[:, out]), ":", color=colour, lw=0.9,
                    label="std, noise" if k == 0 else None)
    ax.set_title(f"Best linear approximation, {_pair_name(frfs[0], out, 0)}")
    ax.set_xlabel("Frequency [Hz]")
    ax.set_ylabel(f"|G| [{frfs[0].units}]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    _fit_band(ax, frfs)
    return fig


def _coherence_axes(ax, title: str) -> None:
    ax.set_title(title)
    ax.set_xlabel("Frequency [Hz]")
    ax.set_ylabel("Coherence γ² [-]")
    ax.set_ylim(0, 1.05)
    ax.grid(True, alpha=0.3)


def linear_and_coefficients(freqs: np.ndarray, H_lin: np.ndarray, units: str,
                            coefficients: dict[str, np.ndarray],
                            coefficient_units: dict[str, str],
                            H_model: np.ndarray | None = None,
                            exact: dict[str, float] | None = None,
                            title: str = "Underlying linear FRF and nonlinear coefficients"
                            ) -> Figure:
    """Estimated linear FRF (one column) and each coefficient vs frequency (figs 3.6, 3.8).

    ``H_lin`` (n_f, n_dof) complex; ``coefficients`` name -> (n_f,) complex; ``exact``
    name -> true value drawn as a dashed line when known.
    """
    n_c = len(coefficients)
    fig = Figure(figsize=(FIGSIZE[0], 3.0 + 2.0 * n_c), dpi=DPI, layout="constrained")
    axes = fig.subplots(1 + n_c, 1, sharex=True, squeeze=False)[:, 0]
    fig.suptitle(title)
    colours = colormaps["tab10"]
    for q in range(H_lin.shape[1]):
        axes[0].semilogy(freqs, np.abs(H_lin[:, q]), color=colours(q), lw=1.3,
                         label=f"estimated, DOF {q}")
        if H_model is not None:
            axes[0].semilogy(freqs, np.abs(H_model[:, q]), "--", color="k", lw=0.9,
                             label="model" if q == 0 else None)
    axes[0].set_ylabel(f"|H_L| [{units}]")
    axes[0].legend(fontsize="small", ncol=2)
    for ax, (name, c) in zip(axes[1:], coefficients.items()):
        ax.plot(freqs, c.real, color="C0", lw=1.2, label="real part")
        ax.plot(freqs, c.imag, color="C1", lw=1.0, alpha=0.8, label="imaginary part")
        if exact and name in exact:
            ax.axhline(exact[name], color="k", ls="--", lw=0.9, label=f"true {exact[name]:.3g}")
        ax.set_title(name, fontsize="medium")
        ax.set_ylabel(f"coefficient [{coefficient_units.get(name, '-')}]")
        ax.set_ylim(*_robust_limits(c.real, exact.get(name) if exact else None))
        ax.legend(fontsize="small", loc="best")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    axes[-1].set_xlabel("Frequency [Hz]")
    return fig


def _robust_limits(values: np.ndarray, extra: float | None) -> tuple[float, float]:
    """Y range holding the central 90 % of ``values`` (and ``extra``): a few wild bins at
    resonance (where the estimate's variance peaks) must not flatten the rest."""
    lo, hi = np.nanpercentile(values, [5, 95])
    if extra is not None:
        lo, hi = min(lo, extra), max(hi, extra)
    pad = 0.5 * (hi - lo) or abs(hi) * 0.1 or 1.0
    return lo - pad, hi + pad


def coherence_linear_vs_nonlinear(freqs: np.ndarray, linear: np.ndarray,
                                  nonlinear: np.ndarray) -> Figure:
    """Multiple coherence of each output, linear vs nonlinear analysis (fig 3.9)."""
    fig = Figure(figsize=(FIGSIZE[0], 3.8), dpi=DPI, layout="constrained")
    ax = fig.subplots()
    colours = colormaps["tab10"]
    for q in range(linear.shape[1]):
        ax.plot(freqs, linear[:, q], "--", color=colours(q), lw=1.1, label=f"linear, DOF {q}")
        ax.plot(freqs, nonlinear[:, q], "-", color=colours(q), lw=1.5,
                label=f"nonlinear, DOF {q}")
    _coherence_axes(ax, "Multiple coherence: linear vs nonlinear analysis")
    ax.legend(fontsize="small", ncol=2, loc="lower left")
    ax.set_xlim(freqs[0], freqs[-1])
    return fig


def hysteresis_loops(loops: dict[str, tuple[np.ndarray, np.ndarray]]) -> Figure:
    """Restoring force vs deformation, one loop per label (fig 4.7)."""
    fig = Figure(figsize=(6.4, 5.0), dpi=DPI, layout="constrained")
    ax = fig.subplots()
    styles = ["-", "--", ":", "-."]
    for (label, (u, g)), style in zip(loops.items(), styles * 4):
        ax.plot(u, g, style, lw=1.6, label=label)
    ax.set_title("Hysteresis loop of the nonlinear element")
    ax.set_xlabel("Deformation u [m]")
    ax.set_ylabel("Restoring force g [N]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    return fig


def fitted_frfs(measured: Sequence["LevelFRF"], fitted: Sequence[tuple[np.ndarray, np.ndarray]],
                out: int, inp: int = 0) -> Figure:
    """Measured stepped-sine FRFs (markers) vs FRFs of the estimated model (lines), fig 4.8.

    ``fitted[i]`` is ``(freqs, H)`` with H (n_f, n_dof) complex for ``measured[i]``'s level.
    """
    ref = measured[0]
    fig, mag, ph = _frf_axes(f"Measured (markers) vs estimated model (lines): "
                             f"{_pair_name(ref, out, inp)}")
    for frf, (f_fit, h_fit), colour in zip(measured, fitted, level_colours(len(measured))):
        h = frf.H[:, out, inp]
        mag.semilogy(frf.freqs, np.abs(h), "o", color=colour, ms=3.5, label=frf.label)
        mag.semilogy(f_fit, np.abs(h_fit[:, out]), "-", color=colour, lw=1.2)
        ph.plot(frf.freqs, phase_deg(h), "o", color=colour, ms=3.5)
        ph.plot(f_fit, phase_deg(h_fit[:, out]), "-", color=colour, lw=1.2)
    mag.set_ylabel(f"|H| [{ref.units}]")
    mag.legend(title="force level", fontsize="small")
    _fit_band(mag, measured)
    return fig


def diagnosis_fit(metric: str, before: float, after: float, verdict: str) -> Figure:
    """Model-to-measurement discrepancy before and after the diagnosed correction."""
    fig = Figure(figsize=(5.0, 3.6), dpi=DPI, layout="constrained")
    ax = fig.subplots()
    bars = ax.bar(["model as given", "corrected model"], [before, after],
                  color=["#c0504d", "#4f81bd"])
    ax.bar_label(bars, fmt="%.3g")
    ax.set_ylabel(f"{metric} [-]")
    ax.set_title(f"Diagnosis: {verdict}")
    ax.grid(True, axis="y", alpha=0.3)
    return fig


def response_curves(branches: Sequence, amplitudes: Sequence[float], dof: int,
                    name: str, band: tuple[float, float]) -> Figure:
    """Forced-response curves through their folds: stable solid, unstable dashed, folds
    marked; one ordered colour per force amplitude."""
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    ax = fig.subplots()
    order = np.argsort(amplitudes)
    colours = dict(zip(order, level_colours(len(amplitudes))))
    for i, (branch, amp) in enumerate(zip(branches, amplitudes)):
        a = branch.amplitude(dof)
        colour = colours[i]
        for j, stable in enumerate((True, False)):
            shown = np.where(_runs_with_ends(branch.stable == stable), a, np.nan)
            ax.semilogy(branch.freqs, shown, "-" if stable else "--", color=colour, lw=1.4,
                        label=f"{amp:g} N" if stable else None)
        if branch.folds.size:
            ax.plot(branch.freqs[branch.folds], a[branch.folds], "o", mfc="none",
                    color=colour, ms=6)
    ax.plot([], [], "k--", label="unstable")
    ax.plot([], [], "ko", mfc="none", label="fold (jump)")
    ax.set_xlim(min(band), max(band))
    ax.set_xlabel("Frequency [Hz]")
    ax.set_ylabel(f"Amplitude at DOF {dof}, fundamental [m]")
    ax.set_title(f"{name}: predicted sine response through the folds")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(title="force amplitude", fontsize="small")
    return fig


def _runs_with_ends(mask: np.ndarray) -> np.ndarray:
    """``mask`` widened by one point each side so that dashed and solid parts meet."""
    out = mask.copy()
    out[1:] |= mask[:-1]
    out[:-1] |= mask[1:]
    return out
