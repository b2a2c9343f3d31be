"""Report figures (matplotlib, Agg): one function per paper-style figure, each returns a Figure.

Every axis carries its quantity and unit; curves across levels use one sequential colour map
ordered by force level (low level light, high level dark) so the trend reads at a glance, with
a legend in newtons (a colour bar when there are more than `MAX_LEGEND_LEVELS` levels).
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from analysis.recordings import Excitation
from analysis.spectral import HELD_UNITS

if TYPE_CHECKING:
    from analysis.spectral import LevelFRF

FIGSIZE = (8.0, 5.6)
DPI = 110
#: Colour map of force levels, and the span of it used (its lightest yellow is unreadable).
LEVEL_CMAP, LEVEL_SPAN = "viridis", (0.9, 0.0)
#: Up to this many levels are named in a legend; more get a colour bar.
MAX_LEGEND_LEVELS = 6


def level_colours(n: int, levels: Sequence[float | None] | None = None
                  ) -> list[tuple[float, ...]]:
    """Sequential colours for ``n`` levels (light = low, dark = high), ordered by the
    values ``levels`` when given (ties and missing values keep their position)."""
    cmap = colormaps[LEVEL_CMAP]
    if n <= 1:
        return [cmap(0.3)] * n
    palette = [cmap(x) for x in np.linspace(*LEVEL_SPAN, n)]
    if levels is None or any(v is None for v in levels):
        return palette
    rank = np.argsort(np.argsort(np.asarray(levels, dtype=float), kind="stable"),
                      kind="stable")
    return [palette[r] for r in rank]


def level_unit(frf: "LevelFRF") -> str:
    """Unit of a level's nominal force: rms for random, amplitude for sine excitation (a
    response-controlled level: its held response's unit)."""
    if frf.level_kind != "force":
        return HELD_UNITS[frf.level_kind]
    return "N rms" if frf.excitation == Excitation.RANDOM else "N"


def _level_title(frf: "LevelFRF") -> str:
    """What a level is: its force, or the response amplitude a controller held."""
    return "force level" if frf.level_kind == "force" else "held response amplitude"


def _level_key(fig: Figure, ax, frfs: Sequence["LevelFRF"], extra: list | None = None) -> None:
    """Legend of the levels (by their labels, in newtons) and ``extra`` handles; beyond
    `MAX_LEGEND_LEVELS` levels a colour bar in newtons replaces the level entries."""
    levels = [f.level for f in frfs]
    handles, labels = ax.get_legend_handles_labels()
    if len(frfs) > MAX_LEGEND_LEVELS and all(v is not None for v in levels):
        named = {f.label for f in frfs}
        keep = [(h, lab) for h, lab in zip(handles, labels) if lab not in named]
        order = np.argsort(levels)
        colours = level_colours(len(frfs), levels)
        cmap = ListedColormap([colours[i] for i in order])
        norm = BoundaryNorm(np.arange(len(frfs) + 1) - 0.5, cmap.N)
        bar = fig.colorbar(ScalarMappable(norm, cmap), ax=ax, ticks=np.arange(len(frfs)),
                           fraction=0.05, pad=0.02)
        bar.ax.set_yticklabels([f"{levels[i]:.3g}" for i in order])
        bar.set_label(f"{_level_title(frfs[0])} [{level_unit(frfs[0])}]")
        handles, labels = [h for h, _ in keep], [lab for _, lab in keep]
    for h in extra or []:
        handles.append(h)
        labels.append(h.get_label())
    if handles:
        ax.legend(handles, labels, title=_level_title(frfs[0]) if len(frfs) <= MAX_LEGEND_LEVELS
                  else None, fontsize="small")


def phase_deg(h: np.ndarray) -> np.ndarray:
    """Phase in [-180, 180] degrees, as test engineers read it (numpy's principal value)."""
    return np.degrees(np.angle(h))


def phase_lines(freqs: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`phase_deg` of ``h`` with a gap (NaN) where it wraps between +-180 degrees: a phase
    near 180 (an accelerance below its first mode) that noise takes across the wrap is drawn
    along the axis's edges, not as a full-height spike at every crossing."""
    f, deg = np.asarray(freqs, dtype=float), phase_deg(h)
    wraps = np.flatnonzero(np.abs(np.diff(deg)) > 180) + 1
    return np.insert(f, wraps, np.nan), np.insert(deg, wraps, np.nan)


def _frf_axes(title: str) -> tuple[Figure, object, object]:
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    mag, ph = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    fig.suptitle(title)
    for ax in (mag, ph):
        ax.grid(True, which="both", alpha=0.3)
    ph.set_xlabel("Frequency [Hz]")
    ph.set_ylabel("Phase [deg]")
    ph.set_ylim(-190, 190)
    ph.set_yticks([-180, -90, 0, 90, 180])
    return fig, mag, ph


def response_name(out: int, names: tuple[Sequence[str], Sequence[str]] | None = None) -> str:
    """``"drive (acceleration)"`` with a sensor map's channel ``names`` (`channel_names` of
    the report), else ``"DOF 0"``."""
    return names[0][out] if names is not None else f"DOF {out}"


def _pair_name(frf: "LevelFRF", out: int, inp: int,
               names: tuple[Sequence[str], Sequence[str]] | None = None) -> str:
    if names is not None:            # a sensor map: "point (kind)" / force point
        return f"response {names[0][out]} / force at {names[1][inp]}"
    return f"response DOF {out} / force at DOF {int(frf.force_dofs[inp])}"


def frf_levels(frfs: Sequence["LevelFRF"], out: int, inp: int = 0,
               names: tuple[Sequence[str], Sequence[str]] | None = None) -> Figure:
    """FRF magnitude and phase at every level overlaid (paper figs 2.1, 3.5, 4.5);
    ``names``: response and force channel names of a run with a sensor map."""
    ref = frfs[0]
    fig, mag, ph = _frf_axes(f"FRF per level: {_pair_name(ref, out, inp, names)}")
    for frf, colour in zip(frfs, _colours_of(frfs)):
        h = frf.H[:, out, inp]
        style = "o-" if frf.excitation == Excitation.STEPPED_SINE else "-"
        mag.semilogy(frf.freqs, np.abs(h), style, color=colour, ms=3, lw=1.2, label=frf.label)
        ph.plot(*phase_lines(frf.freqs, h), style, color=colour, ms=3, lw=1.2)
    mag.set_ylabel(f"|H| [{ref.units}]")
    _level_key(fig, mag, frfs)
    _fit_band(mag, frfs)
    return fig


def _colours_of(frfs: Sequence["LevelFRF"]) -> list[tuple[float, ...]]:
    return level_colours(len(frfs), [f.level for f in frfs])


def _fit_band(ax, frfs: Sequence["LevelFRF"]) -> None:
    lo = min(float(f.freqs[f.freqs > 0].min()) for f in frfs)
    hi = max(float(f.freqs.max()) for f in frfs)
    ax.set_xlim(lo, hi)


def multiple_coherence_levels(frfs: Sequence["LevelFRF"], out: int,
                              names: tuple[Sequence[str], Sequence[str]] | None = None
                              ) -> Figure:
    """Multiple coherence of one output at every random level (linear analysis); ``names``
    as for `frf_levels`."""
    fig = Figure(figsize=(FIGSIZE[0], 3.6), dpi=DPI, layout="constrained")
    ax = fig.subplots()
    shown = [f for f in frfs if f.multiple_coherence is not None]
    for frf, colour in zip(shown, _colours_of(shown)):
        ax.plot(frf.freqs, frf.multiple_coherence[:, out], color=colour, lw=1.2, label=frf.label)
    _coherence_axes(ax, f"Multiple coherence, response {response_name(out, names)} "
                        "(linear analysis)")
    _level_key(fig, ax, shown)
    _fit_band(ax, shown)
    return fig


def level_change(change, names: tuple[Sequence[str], Sequence[str]] | None = None) -> Figure:
    """Change of the FRF between two levels over its noise, per response, in dB, with the
    line a linear structure exceeds on 1 % of the lines (`analysis.detection._detect.LevelChange`);
    ``names`` as for `frf_levels`."""
    fig = Figure(figsize=(FIGSIZE[0], 3.8), dpi=DPI, layout="constrained")
    ax = fig.subplots()
    z = np.maximum(change.z, 1e-6)
    for q, colour in zip(range(z.shape[1]), level_colours(z.shape[1])):
        ax.plot(change.freqs, 10 * np.log10(z[:, q]), color=colour, lw=0.9,
                label=f"response {response_name(q, names)}")
    ax.axhline(10 * np.log10(change.threshold), color="k", ls="--", lw=1,
               label="linear structure: exceeded on 1 % of lines")
    lo, hi = change.summary.labels
    ax.set_title(f"FRF change between {lo} and {hi} over its noise")
    ax.set_xlabel("Frequency [Hz]")
    ax.set_ylabel("|ΔH|² / var [dB]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_xlim(change.freqs[0], change.freqs[-1])
    return fig


def bla_levels(frfs: Sequence["LevelFRF"], out: int,
               names: tuple[Sequence[str], Sequence[str]] | None = None) -> Figure:
    """Robust BLA per periodic-random level: |G|, the total standard deviation of G (noise +
    nonlinear distortion, dashed) and its noise standard deviation (dotted)."""
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    ax = fig.subplots()
    for k, (frf, colour) in enumerate(zip(frfs, _colours_of(frfs))):
        b = frf.bla
        ax.semilogy(b.freqs, np.abs(b.G[:, out]), color=colour, lw=1.3, label=frf.label)
        ax.semilogy(b.freqs, np.sqrt(b.var_total[:, out]), "--", color=colour, lw=0.9,
                    label="std, total (noise + distortion)" if k == 0 else None)
        ax.semilogy(b.freqs, np.sqrt(b.var_noise[:, out]), ":", color=colour, lw=0.9,
                    label="std, noise" if k == 0 else None)
    ax.set_title(f"Best linear approximation, {_pair_name(frfs[0], out, 0, names)}")
    ax.set_xlabel("Frequency [Hz]")
    ax.set_ylabel(f"|G| [{frfs[0].units}]")
    ax.grid(True, which="both", alpha=0.3)
    _level_key(fig, ax, frfs)
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
        ratio = np.nanmedian(np.abs(c.imag) / np.maximum(np.abs(c.real), 1e-300))
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.plot(freqs, c.real, color="C0", lw=1.2, label="real part")
        ax.plot(freqs, c.imag, color="C1", lw=1.0, alpha=0.9,
                label=f"imaginary part (median |Im/Re| {100 * ratio:.2g} %)")
        if exact and name in exact:
            ax.axhline(exact[name], color="k", ls="--", lw=0.9, label=f"true {exact[name]:.3g}")
        ax.set_title(name, fontsize="medium")
        ax.set_ylabel(f"coefficient [{coefficient_units.get(name, '-')}]")
        ax.set_ylim(*coefficient_limits(c, exact.get(name) if exact else None))
        ax.legend(fontsize="small", loc="best")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    axes[-1].set_xlabel("Frequency [Hz]")
    return fig


def coefficient_limits(c: np.ndarray, extra: float | None = None) -> tuple[float, float]:
    """One y range showing the real and the imaginary part of a coefficient (and zero and
    ``extra``): the central 90 % of each part, so that a few wild bins at resonance (where
    the estimate's variance peaks) do not flatten the rest, padded by a tenth of the span."""
    parts = [np.nanpercentile(part, [5, 95]) for part in (c.real, c.imag)]
    lo = min(0.0, *(p[0] for p in parts))
    hi = max(0.0, *(p[1] for p in parts))
    if extra is not None:
        lo, hi = min(lo, extra), max(hi, extra)
    pad = 0.1 * (hi - lo) or abs(hi) * 0.1 or 1.0
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


@dataclass
class ModelCurve:
    """A model's fundamental FRF along a continued response curve (through its folds).

    ``H`` (n, n_dof) complex, in the measured response kind; ``stable`` (n,) bool.
    """

    freqs: np.ndarray
    H: np.ndarray
    stable: np.ndarray


def fitted_frfs(measured: Sequence["LevelFRF"], fitted: Sequence[ModelCurve], out: int,
                inp: int = 0) -> Figure:
    """Measured stepped-sine FRFs (markers) vs the estimated model's response curves through
    their folds (lines: stable solid, unstable dashed, folds circled), paper fig 4.8.

    ``fitted[i]`` is the model curve at ``measured[i]``'s level.
    """
    ref = measured[0]
    fig, mag, ph = _frf_axes(f"Measured (markers) vs estimated model (lines): "
                             f"{_pair_name(ref, out, inp)}")
    for frf, curve, colour in zip(measured, fitted, _colours_of(measured)):
        h = frf.H[:, out, inp]
        hm = curve.H[:, out]
        for ax, y, ym in ((mag, np.abs(h), np.abs(hm)), (ph, phase_deg(h), phase_deg(hm))):
            for stable in (True, False):
                shown = np.where(_runs_with_ends(curve.stable == stable), ym, np.nan)
                ax.plot(curve.freqs, shown, "-" if stable else "--", color=colour, lw=1.3)
            folds = np.flatnonzero(np.diff(curve.stable.astype(int)) != 0) + 1
            ax.plot(curve.freqs[folds], ym[folds], "o", mfc="none", color=colour, ms=7)
            ax.plot(frf.freqs, y, "o", color=colour, mec="k", mew=0.6, ms=4.5, ls="none",
                    label=frf.label if ax is mag else None)
    mag.set_yscale("log")
    mag.set_ylabel(f"|H| [{ref.units}]")
    _level_key(fig, mag, measured, [
        Line2D([], [], color="0.3", marker="o", mec="k", ls="none", label="measured"),
        Line2D([], [], color="0.3", label="model, stable"),
        Line2D([], [], color="0.3", ls="--", label="model, unstable"),
        Line2D([], [], color="0.3", marker="o", mfc="none", ls="none",
               label="model fold (jump)")])
    _fit_band(mag, measured)
    return fig


@dataclass(frozen=True)
class LevelBars:
    """One level's bar pair of `diagnosis_fit`: its FRF error before and after the
    correction, and whether the level was held back from the fit."""

    label: str
    before: float
    after: float
    held_back: bool = False


def diagnosis_fit(metric: str, before: float, after: float, title: str,
                  levels: Sequence[LevelBars] | None = None) -> Figure:
    """Model-to-measurement discrepancy before and after the diagnosed correction: one bar
    pair, or one pair per level when ``levels`` are given. ``metric`` (a sentence) is the
    subtitle."""
    fig = Figure(figsize=(6.4, 4.2), dpi=DPI, layout="constrained")
    ax = fig.subplots()
    if levels:
        names = [f"{lv.label}{' (held back)' if lv.held_back else ''}" for lv in levels]
        b = [float(lv.before) for lv in levels]
        a = [float(lv.after) for lv in levels]
    else:
        names, b, a = ["held-back recording"], [before], [after]
    x = np.arange(len(names))
    for vals, shift, colour, label in ((b, -0.2, "#c0504d", "model as given"),
                                       (a, 0.2, "#4f81bd", "corrected model")):
        bars = ax.bar(x + shift, vals, 0.4, color=colour, label=label)
        ax.bar_label(bars, fmt="%.3g", fontsize="small")
    ax.set_xticks(x, names)
    ax.set_ylabel("relative error [-]")
    ax.set_ylim(0, 1.18 * max(max(b), max(a), 1e-12))
    ax.set_title(title, fontsize="medium")
    fig.suptitle("\n".join(textwrap.wrap(metric, 80)), fontsize="small", color="0.3")
    ax.legend(fontsize="small")
    ax.grid(True, axis="y", alpha=0.3)
    return fig


def diagnosis_overlay(curve, title: str) -> Figure:
    """One level of a diagnosis (`analysis.diagnose._report.LevelCurves`): measured FRF
    against the model before and after the correction, and the time residuals of the
    replays, one row per response DOF."""
    n_dof = curve.measured.shape[1]
    fig = Figure(figsize=(11.0, 1.0 + 2.8 * n_dof), dpi=DPI, layout="constrained")
    axes = fig.subplots(n_dof, 2, squeeze=False)
    fig.suptitle(title)
    for dof in range(n_dof):
        ax = axes[dof, 0]
        ax.semilogy(curve.freqs, np.abs(curve.measured[:, dof, 0]), "k", lw=1.2,
                    label="measured")
        ax.semilogy(curve.freqs, np.abs(curve.before[:, dof, 0]), "C3--", lw=1.1,
                    label="model before")
        ax.semilogy(curve.freqs, np.abs(curve.after[:, dof, 0]), "C0", lw=1.1,
                    label="model after")
        ax.set_ylabel(f"|H| DOF {dof} [m/N]")
        ax.grid(True, which="both", alpha=0.3)
        _time_residual_panel(axes[dof, 1], curve, dof)
    axes[0, 0].set_title("FRF")
    axes[0, 1].set_title("Time residual (replay of the measured force)")
    for ax in axes[0]:
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize="small")
    axes[-1, 0].set_xlabel("Frequency [Hz]")
    axes[-1, 1].set_xlabel("Time [s]")
    return fig


def _time_residual_panel(ax, curve, dof: int) -> None:
    """Measured displacement and the residuals of the replays before/after."""
    rb, ra = curve.replay_before, curve.replay_after
    if rb is None or ra is None or rb.t.size == 0:
        ax.text(0.5, 0.5, "no replay", transform=ax.transAxes, ha="center")
        return
    ax.plot(rb.t, rb.measured[:, dof], "k", lw=1.0, label="measured")
    ax.plot(rb.t, rb.measured[:, dof] - rb.predicted[:, dof], "C3--", lw=1,
            label=f"residual before ({rb.residual[dof]:.3g})")
    ax.plot(ra.t, ra.measured[:, dof] - ra.predicted[:, dof], "C0", lw=1,
            label=f"residual after ({ra.residual[dof]:.3g})")
    symbol, unit = {"displacement": ("x", "m"), "velocity": ("v", "m/s"),
                    "acceleration": ("a", "m/s²")}[rb.kind]
    ax.set_ylabel(f"{symbol} DOF {dof} [{unit}]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")


def response_curves(branches: Sequence, amplitudes: Sequence[float], dof: int,
                    name: str, band: tuple[float, float]) -> Figure:
    """Forced-response curves through their folds: stable solid, unstable dashed, folds
    marked; one ordered colour per force amplitude."""
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    ax = fig.subplots()
    colours = level_colours(len(amplitudes), amplitudes)
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


def stabilisation(fit) -> Figure:
    """Stabilisation diagram of a modal fit (`analysis.modal.LinearFit`): the poles of
    every model order (``+`` stable, ``o`` not), the selected modes dashed, over the sum of
    the measured receptance magnitudes."""
    stab, m, d = fit.stabilisation, fit.modes, fit.data
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    ax = fig.subplots()
    twin = ax.twinx()
    inb = (d.freqs >= m.band_hz[0]) & (d.freqs <= m.band_hz[1])
    twin.semilogy(d.freqs[inb], np.abs(d.H[inb]).sum(axis=1), color="0.35", lw=0.8)
    twin.set_ylabel("Sum of |receptance| [m/N]")
    ax.set_zorder(twin.get_zorder() + 1)             # poles over the curve
    ax.patch.set_visible(False)
    for order, fr, st in zip(stab.orders, stab.freqs_hz, stab.stable):
        ax.plot(fr[~st], np.full((~st).sum(), order), "o", mfc="none", color="0.6", ms=4)
        ax.plot(fr[st], np.full(st.sum(), order), "+", color="C0", ms=6)
    for f in m.freqs_hz:
        ax.axvline(f, color="C3", lw=0.8, ls="--")
    ax.set_xlim(*m.band_hz)
    ax.set_xlabel("Frequency [Hz]")
    ax.set_ylabel("Model order")
    ax.set_title(f"Stabilisation diagram: {m.freqs_hz.size} mode(s) selected")
    ax.legend([Line2D([], [], ls="", marker="+", color="C0", ms=6),
               Line2D([], [], ls="", marker="o", mfc="none", color="0.6", ms=4),
               Line2D([], [], ls="--", color="C3", lw=0.8),
               Line2D([], [], color="0.35", lw=0.8)],
              ["stable pole", "not stable", "selected mode", "sum of |receptance|"],
              fontsize="small", loc="lower right")
    return fig
