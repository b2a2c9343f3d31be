"""The backbone figure (`nlid-lab backbone --plot`, docs/backbone.md): natural frequency and
damping ratio of the mode against its amplitude, each level with its 95 % interval, and the
levels' FRFs with their single-mode fits; the report's backbone section."""

from __future__ import annotations

import html
from typing import TYPE_CHECKING, Sequence

import numpy as np
from matplotlib.figure import Figure

from analysis.backbone import backbone, fit_single_mode
from analysis.errors import EstimationError, InputError
from analysis.recordings import KIND_ORDER, StepTable, one_kind

from ._figures import DPI, level_colours
from ._rundata import RunData, Section

if TYPE_CHECKING:
    from analysis.backbone import Backbone

UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}


def backbone_figure(bb: Backbone, tables: Sequence[StepTable], title: str = "",
                    model: Backbone | None = None) -> Figure:
    """Frequency and damping against amplitude (error bars: 95 % intervals) beside the
    measured FRF magnitude of every level (dots) with its single-mode fit (line); ``model``:
    a model's backbone through the same steps, drawn beside the measured one."""

    fig = Figure(figsize=(11.0, 6.4), dpi=DPI, layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.1))
    ax_f, ax_z = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0])
    ax_h = fig.add_subplot(grid[:, 1])
    pts = bb.points
    amp = np.array([p.amplitude for p in pts])
    kind = pts[0].amplitude_kind
    for ax, value, ci, label in (
            (ax_f, [p.frequency_hz for p in pts], [p.frequency_ci95 for p in pts],
             "natural frequency [Hz]"),
            (ax_z, [100 * p.damping_ratio for p in pts],
             [(100 * p.damping_ci95[0], 100 * p.damping_ci95[1]) for p in pts],
             "damping ratio [%]")):
        value, ci = np.asarray(value), np.asarray(ci)
        err = np.abs(np.stack([value - ci[:, 0], ci[:, 1] - value]))
        ax.errorbar(amp, value, yerr=err, fmt="o-", color="C0", ecolor="C3", capsize=4,
                    lw=1.2, ms=5, label="measured")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    if model is not None:
        m_amp = [p.amplitude for p in model.points]
        ax_f.plot(m_amp, [p.frequency_hz for p in model.points], "s--", color="C2", ms=4,
                  label="model, same steps")
        ax_z.plot(m_amp, [100 * p.damping_ratio for p in model.points], "s--", color="C2",
                  ms=4, label="model, same steps")
        ax_f.legend(fontsize=8)
    ax_z.set_xlabel(f"response amplitude at channel {bb.channel} [{UNITS.get(kind, kind)}]")
    ax_f.set_title("backbone (error bars: 95 % intervals)")
    colours = level_colours(len(tables), [t.level for t in tables])
    j = bb.channel
    for t, p, c in zip(tables, pts, colours):
        order = KIND_ORDER[p.amplitude_kind]
        H = t.frf()[:, j, 0]
        fit = fit_single_mode(t.freqs, H, order)
        fine = np.linspace(t.freqs.min(), t.freqs.max(), 400)
        ax_h.plot(t.freqs, np.abs(H), "o", ms=2.5, color=c)
        ax_h.plot(fine, np.abs(fit.frf(fine, order)), "-", lw=1.0, color=c,
                  label=f"{p.amplitude:.3g} {UNITS.get(kind, kind)}: fit error "
                  f"{100 * p.fit_error:.2f} %")
    ax_h.set_yscale("log")
    ax_h.set_xlabel("frequency [Hz]")
    ax_h.set_ylabel(f"|FRF| channel {j} [{UNITS.get(kind, kind)}/N]")
    ax_h.set_title("levels (dots) and their single-mode fits (lines)")
    ax_h.legend(fontsize=7, loc="upper right")
    ax_h.grid(True, which="both", alpha=0.3)
    if title:
        fig.suptitle(title)
    return fig


def backbone_section(run: RunData) -> Section | None:
    """Stepped-sine table runs: the backbone (frequency and damping per level, with the
    figure of `backbone_figure`); None for other runs or a single level."""
    tables = [one_kind(r) for r in run.recordings]
    if len(tables) < 2 or not all(isinstance(t, StepTable) for t in tables):
        return None
    try:
        bb = backbone(tables)
    except (EstimationError, InputError) as exc:
        return Section("Backbone", f"No backbone: {html.escape(str(exc))}.")
    unit = UNITS.get(bb.points[0].amplitude_kind, "")
    rows = "".join(f"<tr><td>{p.amplitude:.4g}</td><td>{p.frequency_hz:.4f}</td>"
                   f"<td>{100 * p.damping_ratio:.4f}</td><td>{100 * p.fit_error:.2f}</td></tr>"
                   for p in bb.points)
    return Section("Backbone",
                   f"Natural frequency and damping of the mode against its amplitude at "
                   f"channel {bb.channel} ({html.escape(bb.points[0].method)}; "
                   "docs/backbone.md). <code>nlid-lab backbone RUN --json FILE</code> writes "
                   "them with their 95 % intervals."
                   f"<table><tr><th>amplitude [{unit}]</th><th>f [Hz]</th><th>&zeta; [%]</th>"
                   f"<th>fit error [%]</th></tr>{rows}</table>",
                   [("backbone", backbone_figure(bb, tables))])
