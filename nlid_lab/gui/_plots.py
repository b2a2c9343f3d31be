"""Shared pyqtgraph helpers: colours, FRF/coherence/time plots and safe curve updates."""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg

from PySide6 import QtGui

from .. import reports
from ..reports import phase_deg, phase_lines

pg.setConfigOptions(background="w", foreground="k", antialias=False)

#: Channel colours (matplotlib tab10), so a channel keeps its colour in every panel.
CHANNEL_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                   "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"]


#: What the FRF of each response kind is called on an axis.
FRF_QUANTITY = {"displacement": "Receptance |X/F|", "velocity": "Mobility |V/F|",
                "acceleration": "Accelerance |A/F|"}


def channel_colour(i: int) -> str:
    """Colour of channel ``i`` (the same in every panel)."""
    return CHANNEL_COLOURS[i % len(CHANNEL_COLOURS)]


def level_colours(n: int, levels=None) -> list[str]:
    """Sequential colours for ``n`` levels, ordered by the values ``levels`` when given
    (viridis: light = low level, dark = high; as the report, `nlid_lab.reports.level_colours`)."""
    return [QtGui.QColor.fromRgbF(*c).name() for c in reports.level_colours(n, levels)]


def pen(colour: str, width: float = 1.5) -> pg.mkPen:
    """A solid pen of ``colour`` and ``width`` pixels."""
    return pg.mkPen(colour, width=width)


def style(plot: pg.PlotItem, left: str, unit: str, bottom: str | None = "Frequency",
           bottom_unit: str = "Hz", grid: bool = True) -> pg.PlotItem:
    """Grid and axis labels ``left [unit]`` and ``bottom [bottom_unit]`` (no SI prefixing);
    returns ``plot``."""
    if grid:
        plot.showGrid(x=True, y=True, alpha=0.3)
    # units as text: pyqtgraph's SI prefixing would print "kHz" or "mm/N" inconsistently
    plot.setLabel("left", f"{left} [{unit}]")
    if bottom:
        plot.setLabel("bottom", f"{bottom} [{bottom_unit}]")
    plot.getAxis("left").enableAutoSIPrefix(False)
    plot.getAxis("bottom").enableAutoSIPrefix(False)
    return plot


class LogAxis(pg.AxisItem):
    """Log axis with ticks at the decades and their 2x and 5x only: pyqtgraph's own log ticks
    label every 1..9 x 10^n, and over a decade or two those labels pile up."""

    def logTickValues(self, minVal, maxVal, size, stdTicks):  # noqa: N802 (pyqtgraph API)
        """Ticks at the decades and their 2x and 5x (decades only over more than three)."""
        lo, hi = int(np.floor(minVal)), int(np.ceil(maxVal))
        decades = [float(d) for d in range(lo, hi + 1) if minVal <= d <= maxVal]
        if hi - lo > 3:           # wide range: decades only, thinned to about six labels
            step = max(1, (hi - lo) // 6)
            return [(float(step), [d for d in decades if int(d) % step == 0]), (None, [])]
        minor = [d + np.log10(m) for d in range(lo, hi + 1) for m in (2, 5)
                 if minVal <= d + np.log10(m) <= maxVal]
        return [(1.0, decades), (None, minor)]


def frf_plots(layout: pg.GraphicsLayout, units: str, row: int = 0, col: int = 0,
              title: str = "FRF", quantity: str = "|H|") -> tuple[pg.PlotItem, pg.PlotItem]:
    """Magnitude (log) above phase, x-linked; returns both plot items."""
    mag = layout.addPlot(row=row, col=col, title=title,
                         axisItems={"left": LogAxis(orientation="left")})
    style(mag, quantity, units, bottom=None)
    mag.setLogMode(y=True)
    mag.addLegend(offset=(-10, 10), labelTextSize="8pt", brush=(255, 255, 255, 210),
                  pen=(180, 180, 180))
    ph = layout.addPlot(row=row + 1, col=col)
    style(ph, "Phase", "deg")
    ph.setYRange(-180, 180)
    ph.getAxis("left").setTicks([[(v, f"{v}") for v in (-180, -90, 0, 90, 180)]])
    ph.setXLink(mag)
    return mag, ph


def coherence_plot(layout: pg.GraphicsLayout, row: int, col: int = 0,
                   title: str = "Multiple coherence") -> pg.PlotItem:
    """A coherence panel (0 to 1) at ``row``, ``col`` of ``layout``."""
    p = layout.addPlot(row=row, col=col, title=title)
    style(p, "γ²", "-")
    p.setYRange(0, 1.05)
    return p


def time_plot(layout: pg.GraphicsLayout, row: int, name: str, unit: str,
              bottom: bool = False) -> pg.PlotItem:
    """One channel's time trace: peak downsampling and clip-to-view keep long buffers fast."""
    p = layout.addPlot(row=row, col=0)
    # no grid: grid lines of many stacked traces cost more to paint than the traces
    style(p, name, unit, bottom="Time" if bottom else None, bottom_unit="s", grid=False)
    p.setDownsampling(auto=True, mode="peak")
    p.setClipToView(True)
    p.getAxis("left").setWidth(70)
    return p


def set_frf(mag_curve: pg.PlotDataItem, phase_curve: pg.PlotDataItem | None,
            freqs: np.ndarray, h: np.ndarray) -> None:
    """Show one FRF; bins where |H| is 0 or not finite are dropped (log axis)."""
    a = np.abs(h)
    ok = np.isfinite(a) & (a > 0)
    mag_curve.setData(freqs[ok], a[ok])
    if phase_curve is not None:
        phase_curve.setData(*phase_lines(freqs[ok], h[ok]), connect="finite")
