"""Offline run browser: runs and levels of a campaign, FRFs overlaid across levels (paper figs
2.1, 3.5, 4.5; periodic-random levels: the BLA with its total (dashed) and noise (dotted)
standard deviation), multiple coherence of random levels (fig 3.9), harmonic distortion of
stepped-sine levels and the estimates stored in each run."""

from __future__ import annotations

from typing import Any

import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtWidgets

from analysis.spectral import FRF_UNITS, LevelFRF, convert_frf, sine_fit
from analysis.recordings import Excitation, Recording, StepTable, channel_labels

from .. import methods
from ..reports import RunData, estimate_rows
from . import _plots as plots


class OfflineView(QtWidgets.QWidget):
    """Browse ``runs`` (with their per-level FRFs ``frfs[i]`` for ``runs[i]``).

    FRFs are drawn as one response kind (``kind``, by default the first run's; chosen in the
    "FRF as" box; its quantity and unit on the axis): levels of runs that measured another
    kind are converted (times or divided by ``i 2 pi f``) and marked "converted" in the
    legend. The lower panels show what each
    ticked level has: multiple coherence (random) and harmonic distortion (stepped sine);
    a panel with nothing to show is hidden.
    """

    def __init__(self, runs: list[RunData], frfs: list[list[LevelFRF]],
                 parent: QtWidgets.QWidget | None = None, kind: str | None = None) -> None:
        super().__init__(parent)
        self.runs, self.frfs = runs, frfs
        self.kind = kind or frfs[0][0].response_kind
        self.frf_as = QtWidgets.QComboBox()
        for k, quantity in plots.FRF_QUANTITY.items():
            self.frf_as.addItem(f"FRF as {quantity.split()[0].lower()} ({k})", k)
        self.frf_as.setCurrentIndex(list(plots.FRF_QUANTITY).index(self.kind))
        self.setWindowTitle("nlid-lab view: " + ", ".join(r.name for r in runs))
        self.tree = QtWidgets.QTreeWidget()
        self.tree.setHeaderLabels(["run / level", "excitation", "averages"])
        self.tree.header().setSectionResizeMode(
            QtWidgets.QHeaderView.ResizeMode.ResizeToContents)
        self.output = QtWidgets.QComboBox()
        self.table = QtWidgets.QTableWidget(0, 5)
        self.table.setHorizontalHeaderLabels(["result", "element", "parameter", "value",
                                              "95 % interval"])
        self.table.horizontalHeader().setSectionResizeMode(
            QtWidgets.QHeaderView.ResizeMode.ResizeToContents)
        self.table.verticalHeader().setVisible(False)
        self.graphs = pg.GraphicsLayoutWidget()
        self._distortion: dict[tuple[int, int], np.ndarray] = {}
        self._fill_tree()
        n_dof = max(f.H.shape[1] for run in frfs for f in run)
        self.output.addItems([f"response {label}" for label in response_labels(runs, n_dof)])
        self._build_plots()
        left = QtWidgets.QWidget()
        lbox = QtWidgets.QVBoxLayout(left)
        lbox.addWidget(QtWidgets.QLabel("Runs and levels (tick to overlay)"))
        lbox.addWidget(self.tree, 3)
        lbox.addWidget(self.output)
        lbox.addWidget(self.frf_as)
        lbox.addWidget(QtWidgets.QLabel("Stored estimates"))
        lbox.addWidget(self.table, 2)
        split = QtWidgets.QSplitter()
        split.addWidget(left)
        split.addWidget(self.graphs)
        split.setStretchFactor(1, 3)
        QtWidgets.QHBoxLayout(self).addWidget(split)
        self._fill_table()
        split.setSizes([self._left_width(), 1020])
        self.tree.itemChanged.connect(self.redraw)
        self.output.currentIndexChanged.connect(self.redraw)
        self.frf_as.currentIndexChanged.connect(
            lambda i: self.set_kind(self.frf_as.itemData(i)))
        self.redraw()

    def set_kind(self, kind: str) -> None:
        """Draw every FRF as response ``kind`` (displacement, velocity or acceleration):
        the axis names its quantity and unit, other kinds are converted."""
        self.kind = kind
        with QtCore.QSignalBlocker(self.frf_as):
            self.frf_as.setCurrentIndex(list(plots.FRF_QUANTITY).index(kind))
        self.mag.setLabel("left", f"{plots.FRF_QUANTITY[kind]} [{FRF_UNITS[kind]}]")
        self.redraw()

    def _fill_tree(self) -> None:
        for r, (run, levels) in enumerate(zip(self.runs, self.frfs)):
            top = QtWidgets.QTreeWidgetItem([f"{run.name} ({run.status})",
                                             _excitation(levels[0]), ""])
            self.tree.addTopLevelItem(top)
            for i, frf in enumerate(levels):
                item = QtWidgets.QTreeWidgetItem([frf.label, _excitation(frf), _averages(frf)])
                item.setData(0, QtCore.Qt.ItemDataRole.UserRole, (r, i))
                item.setCheckState(0, QtCore.Qt.CheckState.Checked)
                top.addChild(item)
            top.setExpanded(True)

    def _fill_table(self) -> None:
        rows = [row for run in self.runs for row in estimate_rows(run.results, methods)]
        self.table.setRowCount(len(rows))
        for i, row in enumerate(rows):
            for j, text in enumerate(row):
                self.table.setItem(i, j, QtWidgets.QTableWidgetItem(text))
        self.table.resizeColumnsToContents()

    def _left_width(self) -> int:
        """Width showing every column of the estimates table and of the tree."""
        table = sum(self.table.columnWidth(j) for j in range(self.table.columnCount()))
        tree = sum(self.tree.columnWidth(j) for j in range(self.tree.columnCount()))
        return min(max(380, table + 30, tree + 30), 600)

    def _build_plots(self) -> None:
        self.mag, self.phase = plots.frf_plots(self.graphs.ci, FRF_UNITS[self.kind],
                                               title="FRF per level (first force input)",
                                               quantity=plots.FRF_QUANTITY[self.kind])
        self.coh = plots.coherence_plot(self.graphs.ci, row=2,
                                        title="Multiple coherence per level (linear analysis)")
        self.coh.setXLink(self.mag)
        self.dist = self.graphs.ci.addPlot(
            row=3, col=0, title="Harmonic distortion of the response per step (stepped sine)")
        plots.style(self.dist, "THD", "dB")
        self.dist.setXLink(self.mag)
        for row, stretch in enumerate((3, 2, 2, 2)):
            self.graphs.ci.layout.setRowStretchFactor(row, stretch)

    def checked(self) -> list[tuple[int, int]]:
        """(run, level) pairs ticked in the tree, in tree order."""
        out = []
        for r in range(self.tree.topLevelItemCount()):
            top = self.tree.topLevelItem(r)
            for i in range(top.childCount()):
                item = top.child(i)
                if item.checkState(0) == QtCore.Qt.CheckState.Checked:
                    out.append(item.data(0, QtCore.Qt.ItemDataRole.UserRole))
        return out

    def redraw(self, *_: Any) -> None:
        """Draw the ticked levels at the chosen response DOF, as `kind`."""
        q = max(self.output.currentIndex(), 0)
        for p in (self.mag, self.phase, self.coh, self.dist):
            p.clear()
        self.mag.legend.clear()
        picked = self.checked()
        multi_run = len({r for r, _ in picked}) > 1
        levels = [self.frfs[r][i].level for r, i in picked]
        colours = plots.level_colours(len(picked), levels)
        shown_coh = shown_dist = shown_std = False
        for (r, i), colour in zip(picked, colours):
            frf = self.frfs[r][i]
            if q >= frf.H.shape[1]:
                continue
            stepped = frf.excitation == Excitation.STEPPED_SINE
            sym = dict(symbol="o", symbolSize=5, symbolBrush=colour, symbolPen=colour)
            extra = sym if stepped else {}
            name = f"{self.runs[r].name}: {frf.label}" if multi_run else frf.label
            if frf.response_kind != self.kind:
                name += f" ({frf.response_kind} converted)"
            band = frf.freqs > 0
            mc = self.mag.plot(pen=plots.pen(colour), name=name, **extra)
            pc = self.phase.plot(pen=plots.pen(colour), **extra)
            plots.set_frf(mc, pc, frf.freqs[band],
                          convert_frf(frf.H[band, q, 0], frf.freqs[band], frf.response_kind,
                                      self.kind))
            if frf.bla is not None:           # periodic random: noise and total std of G
                for var, dash in ((frf.bla.var_total, QtCore.Qt.PenStyle.DashLine),
                                  (frf.bla.var_noise, QtCore.Qt.PenStyle.DotLine)):
                    if np.all(np.isnan(var)):     # total: one realization does not give it
                        continue
                    curve = self.mag.plot(pen=pg.mkPen(colour, width=1, style=dash))
                    std = convert_frf(np.sqrt(var[:, q]), frf.bla.freqs, frf.response_kind,
                                      self.kind)
                    plots.set_frf(curve, None, frf.bla.freqs, std)
                shown_std = True
            if frf.multiple_coherence is not None:
                self.coh.plot(frf.freqs[band], frf.multiple_coherence[band, q],
                              pen=plots.pen(colour))
                shown_coh = True
            if stepped:
                thd = self.distortion(r, i)
                if q < thd.shape[1] and not np.all(np.isnan(thd[:, q])):
                    self.dist.plot(frf.freqs, thd[:, q], pen=plots.pen(colour), symbol="o",
                                   symbolSize=5, symbolBrush=colour, symbolPen=colour)
                    shown_dist = True
        if shown_std:                          # legend entries of the line styles, once
            for label, dash in (("std of G: noise + distortion", QtCore.Qt.PenStyle.DashLine),
                                ("std of G: noise", QtCore.Qt.PenStyle.DotLine)):
                self.mag.legend.addItem(pg.PlotDataItem(pen=pg.mkPen("#555", width=1,
                                                                      style=dash)), label)
        self._show_panel(self.coh, 2, shown_coh)
        self._show_panel(self.dist, 3, shown_dist)

    def _show_panel(self, plot: pg.PlotItem, row: int, shown: bool) -> None:
        """Show a lower panel, or hide it and give its room to the others."""
        plot.setVisible(shown)
        plot.setMaximumHeight(1e6 if shown else 0)
        self.graphs.ci.layout.setRowStretchFactor(row, 2 if shown else 0)

    def distortion(self, r: int, i: int) -> np.ndarray:
        """Total harmonic distortion (dB) of each step's response of stepped level ``i`` of
        run ``r``, shape (n_steps, n_dof); computed once."""
        if (r, i) not in self._distortion:
            self._distortion[(r, i)] = harmonic_distortion(self.runs[r].recordings[i])
        return self._distortion[(r, i)]


def harmonic_distortion(rec: Recording | StepTable, max_order: int = 7) -> np.ndarray:
    """``20 log10(sqrt(sum_k>=2 |X_k|^2) / |X_1|)`` of each step's response, over the orders
    below Nyquist (at most ``max_order``), shape (n_steps, n_dof); NaN when only the
    fundamental fits below Nyquist (a table: over the harmonics it holds, NaN without)."""
    out = np.full((rec.freqs.size, rec.n_dof), np.nan)
    if isinstance(rec, StepTable):
        if rec.harmonics:
            X = np.abs(rec.response_harmonics) ** 2
            with np.errstate(divide="ignore", invalid="ignore"):
                out[:] = 10 * np.log10(X[:, [h >= 2 for h in rec.harmonics]].sum(axis=1)
                                       / np.abs(rec.response_phasor) ** 2)
        return out
    for k, f in enumerate(rec.freqs):
        top = min(max_order, int(np.ceil(rec.fs / 2 / f)) - 1)
        if top < 2:
            continue
        X = np.abs(sine_fit(rec.response[k], rec.fs, f, range(1, top + 1)))
        with np.errstate(divide="ignore", invalid="ignore"):
            out[k] = 20 * np.log10(np.sqrt(np.sum(X[1:] ** 2, axis=0)) / X[0])
    return out


def _excitation(frf: LevelFRF) -> str:
    if frf.sweep is not None:
        return f"swept sine {'up' if frf.sweep.direction > 0 else 'down'}"
    return "periodic random" if frf.bla is not None else frf.excitation


def _averages(frf: LevelFRF) -> str:
    if frf.excitation == Excitation.STEPPED_SINE:
        return f"{frf.freqs.size} steps"
    if frf.excitation == Excitation.SWEPT_SINE:
        return f"{frf.freqs.size} tracked points"
    return f"{frf.n_averages} {'realizations' if frf.bla is not None else 'averages'}"


def response_labels(runs: list[RunData], n_dof: int) -> list[str]:
    """``"point (kind)"`` per response when every run has the same sensor map
    (`analysis.recordings.channel_labels`, as the report's figures), else ``"DOF q"``."""
    recs = [run.recordings[0] for run in runs if run.recordings]
    maps = {rec.sensors for rec in recs}
    if len(recs) == len(runs) and len(maps) == 1 and None not in maps \
            and recs[0].n_dof == n_dof:
        return channel_labels(recs[0])
    return [f"DOF {q}" for q in range(n_dof)]
