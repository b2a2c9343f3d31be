"""Live campaign view: time blocks, FRFs building up average by average, stepped-sine sweep.

`LiveObserver` is the `nlid_lab.observer.CampaignObserver` handed to the campaign: its methods
run in the acquisition thread and only copy the data onto a queue. `LiveView` (GUI thread)
drains that queue on a QTimer, folds each random block into a running spectral matrix
(`FrfAccumulator`) and redraws at most once per tick.
"""

from __future__ import annotations

import queue
from typing import Any

import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtWidgets

from analysis import spectral
from analysis.bla import best_linear_approximation
from analysis.frf import FRF_UNITS, LevelFRF, frf_from_bla, frf_from_spectra
from analysis.sine_fit import sine_fit

from . import plots

#: Seconds of time history kept per channel (ring buffer).
HISTORY_S = 2.0
REFRESH_MS = 50


class LiveObserver:
    """Campaign observer that queues everything for the GUI thread (never touches widgets)."""

    def __init__(self) -> None:
        self.events: queue.SimpleQueue = queue.SimpleQueue()

    def campaign_started(self, info: dict[str, Any]) -> None:
        self.events.put(("started", dict(info)))

    def block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        self.events.put(("block", level, seq, np.array(force), np.array(response)))

    def step(self, level: int, index: int, freq: float, force: np.ndarray,
             response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        self.events.put(("step", level, index, float(freq), np.array(force),
                         np.array(response), float(control_error), np.array(harmonics)))

    def campaign_finished(self, status: str) -> None:
        self.events.put(("finished", status))


class RingBuffer:
    """Last ``capacity`` samples of ``n_ch`` channels."""

    def __init__(self, n_ch: int, capacity: int) -> None:
        self.data = np.zeros((capacity, n_ch))
        self.count = 0

    def extend(self, block: np.ndarray) -> None:
        cap = self.data.shape[0]
        block = block[-cap:]
        n = block.shape[0]
        self.data = np.roll(self.data, -n, axis=0)
        self.data[-n:] = block
        self.count = min(self.count + n, cap)

    def view(self) -> np.ndarray:
        return self.data[self.data.shape[0] - self.count:]


class FrfAccumulator:
    """Running Welch average over blocks: each block's spectral matrix is pooled with the
    earlier ones (`analysis.spectral.Spectra.pool`), so the FRF and coherence after block k
    equal a Welch estimate over all k blocks (no overlap across block boundaries)."""

    def __init__(self, fs: float, n_in: int, nperseg: int) -> None:
        self.fs, self.n_in, self.nperseg = fs, n_in, nperseg
        self.spectra: spectral.Spectra | None = None

    def add(self, force: np.ndarray, response: np.ndarray) -> None:
        data = np.concatenate([force, response], axis=1)
        if data.shape[0] < self.nperseg:
            return
        spec = spectral.spectral_matrix(data, self.fs, nperseg=self.nperseg)
        self.spectra = spec if self.spectra is None else spectral.Spectra.pool(
            [self.spectra, spec])

    def estimate(self, **labels: Any) -> LevelFRF | None:
        if self.spectra is None:
            return None
        return frf_from_spectra(self.spectra, self.n_in, **labels)


class BlaAccumulator:
    """Periodic-random levels: each block is one realization; the estimate is the robust BLA
    over the realizations received so far (from the second one on)."""

    def __init__(self, fs: float, period: int, transient_periods: int) -> None:
        self.fs, self.period, self.transient = fs, period, transient_periods
        self.blocks: list[tuple[np.ndarray, np.ndarray]] = []

    def add(self, force: np.ndarray, response: np.ndarray) -> None:
        self.blocks.append((force, response))

    def estimate(self, **labels: Any) -> LevelFRF | None:
        if len(self.blocks) < 2:
            return None
        b = best_linear_approximation(np.concatenate([f for f, _ in self.blocks]),
                                      np.concatenate([x for _, x in self.blocks]), self.fs,
                                      self.period, transient_periods=self.transient,
                                      realizations=len(self.blocks))
        return frf_from_bla(b, **labels)


def live_nperseg(fs: float, block_len: int | None) -> int:
    """Segment length for live averaging: ~0.5 Hz resolution, at most one block, power of 2."""
    target = min(int(2 * fs), block_len or int(2 * fs))
    return int(2 ** int(np.floor(np.log2(max(target, 64)))))


class LiveView(QtWidgets.QWidget):
    """The live campaign window; feed it through ``view.observer``."""

    def __init__(self, parent: QtWidgets.QWidget | None = None,
                 refresh_ms: int = REFRESH_MS) -> None:
        super().__init__(parent)
        self.setWindowTitle("nlid-lab live")
        self.observer = LiveObserver()
        self.info: dict[str, Any] = {}
        self.status = "waiting"
        self.blocks = 0
        self.steps: list[tuple[float, np.ndarray, float]] = []  # freq, H1 (n_dof,), error
        self.harmonics: np.ndarray | None = None
        self.level: int | None = None
        self.frf: LevelFRF | None = None
        self._acc: FrfAccumulator | BlaAccumulator | None = None
        self._ring: RingBuffer | None = None
        self._dirty = False
        self.label = QtWidgets.QLabel("waiting for a campaign ...")
        self.progress = QtWidgets.QProgressBar()
        self.progress.setMinimumWidth(280)
        self.progress.setVisible(False)
        self.graphs = pg.GraphicsLayoutWidget()
        box = QtWidgets.QVBoxLayout(self)
        head = QtWidgets.QHBoxLayout()
        head.addWidget(self.label, 1)
        head.addWidget(self.progress)
        box.addLayout(head)
        box.addWidget(self.graphs, 1)
        self.timer = QtCore.QTimer(self)
        self.timer.timeout.connect(self.drain)
        self.timer.start(refresh_ms)

    # --- queue -> state (GUI thread) --------------------------------------------------------
    def drain(self) -> int:
        """Handle every queued event, then redraw once; returns the number handled."""
        n = 0
        while True:
            try:
                event = self.observer.events.get_nowait()
            except queue.Empty:
                break
            getattr(self, f"_on_{event[0]}")(*event[1:])
            n += 1
        if self._dirty:
            self._redraw()
            self._dirty = False
        return n

    def _on_started(self, info: dict[str, Any]) -> None:
        self.info = info
        self.status = "running"
        self.blocks = 0
        self.steps = []
        self.level = None
        self._build()
        self._dirty = True

    def _on_block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        if level != self.level:
            self.level = level
            if self.info.get("period"):
                self._acc = BlaAccumulator(self.fs, int(self.info["period"]),
                                           int(self.info.get("transient_periods", 1)))
            else:
                self._acc = FrfAccumulator(self.fs, force.shape[1], live_nperseg(
                    self.fs, self.info.get("block_len") or force.shape[0]))
        self._acc.add(force, response)
        self._ring.extend(np.concatenate([force, response], axis=1))
        self.blocks += 1
        self.frf = self._acc.estimate(label=f"level {level}", level=None, excitation="random",
                                      response_kind=self.response_kind,
                                      force_dofs=np.asarray(self.force_dofs))
        self._dirty = True

    def _on_step(self, level: int, index: int, freq: float, force: np.ndarray,
                 response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        if level != self.level:
            self.level = level
            self.steps = []
        f1 = sine_fit(force[:, 0], self.fs, freq)[0]
        h = harmonics[self._h1_row(len(harmonics))] / f1 if f1 != 0 else np.full(harmonics.shape[1], np.nan)
        self.steps.append((freq, h, control_error))
        self.harmonics = harmonics
        self._ring.extend(np.concatenate([force, response], axis=1))
        self.blocks += 1
        self._dirty = True

    def orders(self, n_rows: int) -> list[int]:
        """Harmonic order of each row of ``harmonics`` (campaign default: 0, 1, ... n-1)."""
        return [int(k) for k in self.info.get("harmonics") or range(n_rows)]

    def _h1_row(self, n_rows: int) -> int:
        return self.orders(n_rows).index(1)

    def _on_finished(self, status: str) -> None:
        self.status = status
        self._dirty = True

    # --- layout -----------------------------------------------------------------------------
    @property
    def fs(self) -> float:
        return float(self.info["fs"])

    @property
    def force_dofs(self) -> list[int]:
        return [int(d) for d in self.info.get("force_dofs", [0])]

    @property
    def response_kind(self) -> str:
        return self.info.get("response_kind", "displacement")

    def channel_names(self) -> list[tuple[str, str]]:
        """(name, unit) of every channel, forces first."""
        chans = self.info.get("channels")
        if chans:
            return [(c["name"], c.get("unit", "")) if isinstance(c, dict) else tuple(c)
                    for c in chans]
        unit = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}
        return ([(f"F{d}", "N") for d in self.force_dofs]
                + [(f"x{q}", unit[self.response_kind]) for q in range(int(self.info["n_dof"]))])

    def _build(self) -> None:
        g = self.graphs
        g.clear()
        names = self.channel_names()
        self._ring = RingBuffer(len(names), int(HISTORY_S * self.fs))
        left = g.addLayout(row=0, col=0)
        right = g.addLayout(row=0, col=1)
        self.time_curves = []
        for i, (name, unit) in enumerate(names):
            p = plots.time_plot(left, i, name, unit, bottom=i == len(names) - 1)
            if i:
                p.setXLink(left.getItem(0, 0))
            self.time_curves.append(p.plot(pen=plots.pen(plots.channel_colour(i), 1)))
        n_dof = int(self.info["n_dof"])
        units = FRF_UNITS[self.response_kind]
        stepped = self.info.get("excitation") == "stepped-sine"
        self.mag, self.phase = plots.frf_plots(
            right, units, title="FRF (fundamental, per step)" if stepped else "FRF H1")
        style = dict(symbol="o", symbolSize=5) if stepped else {}
        self.mag_curves, self.phase_curves = [], []
        for q in range(n_dof):
            c = plots.channel_colour(len(self.force_dofs) + q)
            sym = dict(symbolBrush=c, symbolPen=c, **style) if stepped else {}
            self.mag_curves.append(self.mag.plot(pen=plots.pen(c), name=f"DOF {q}", **sym))
            self.phase_curves.append(self.phase.plot(pen=plots.pen(c), **sym))
        if stepped:
            self.error_plot = right.addPlot(row=2, col=0, title="Level-control error")
            plots.style(self.error_plot, "error", "%")
            self.error_plot.setXLink(self.mag)
            self.error_curve = self.error_plot.plot(pen=plots.pen("#d62728"), symbol="o",
                                                    symbolSize=4, symbolBrush="#d62728")
            self.harm_plot = right.addPlot(row=3, col=0, title="Harmonic content (current step)")
            plots.style(self.harm_plot, "|X_k| / |X_1|", "-", bottom="Harmonic order",
                         bottom_unit="-")
            self.harm_bars: list[pg.BarGraphItem] = []
        else:
            self.coh_plot = plots.coherence_plot(right, row=2)
            self.coh_plot.setXLink(self.mag)
            self.coh_curves = [self.coh_plot.plot(pen=plots.pen(
                plots.channel_colour(len(self.force_dofs) + q))) for q in range(n_dof)]
        g.ci.layout.setColumnStretchFactor(0, 2)
        g.ci.layout.setColumnStretchFactor(1, 3)
        self.progress.setVisible(stepped)

    # --- drawing ----------------------------------------------------------------------------
    def _redraw(self) -> None:
        if not self.info:
            return
        data = self._ring.view()
        t = (np.arange(data.shape[0]) - data.shape[0]) / self.fs
        for i, curve in enumerate(self.time_curves):
            curve.setData(t, data[:, i])
        if self.info.get("excitation") == "stepped-sine":
            self._redraw_steps()
        else:
            self._redraw_frf()
        self.label.setText(self._summary())

    def _redraw_frf(self) -> None:
        frf = self.frf
        if frf is None:
            return
        band = frf.freqs > 0
        for q, (mc, pc, cc) in enumerate(zip(self.mag_curves, self.phase_curves,
                                             self.coh_curves)):
            plots.set_frf(mc, pc, frf.freqs[band], frf.H[band, q, 0])
            cc.setData(frf.freqs[band], frf.multiple_coherence[band, q])

    def _redraw_steps(self) -> None:
        if not self.steps:
            return
        f = np.array([s[0] for s in self.steps])
        H = np.array([s[1] for s in self.steps])
        for q, (mc, pc) in enumerate(zip(self.mag_curves, self.phase_curves)):
            plots.set_frf(mc, pc, f, H[:, q])
        self.error_curve.setData(f, 100 * np.array([s[2] for s in self.steps]))
        orders = np.asarray(self.orders(len(self.harmonics)))
        shown = orders >= 1                                 # the mean (order 0) is not content
        orders = orders[shown]
        mags = np.abs(self.harmonics)
        h1 = mags[self._h1_row(len(mags))]
        ref = np.where(h1 > 0, h1, 1.0)
        mags = mags[shown]
        for item in self.harm_bars:
            self.harm_plot.removeItem(item)
        self.harm_bars = []
        n_dof = mags.shape[1]
        width = 0.8 / n_dof
        for q in range(n_dof):
            bars = pg.BarGraphItem(x=orders + (q - (n_dof - 1) / 2) * width,
                                   height=mags[:, q] / ref[q], width=width,
                                   brush=plots.channel_colour(len(self.force_dofs) + q))
            self.harm_plot.addItem(bars)
            self.harm_bars.append(bars)
        n_steps = int(self.info.get("n_steps", 0)) or len(self.steps)
        self.progress.setRange(0, n_steps)
        self.progress.setValue(len(self.steps))
        self.progress.setFormat(f"step %v/%m at {f[-1]:.2f} Hz")

    def _summary(self) -> str:
        kind = self.info.get("excitation", "?")
        text = f"{kind} · level {self.level} · {self.status}"
        if kind == "stepped-sine" and self.steps:
            f, _, err = self.steps[-1]
            text += (f" · step {len(self.steps)} · {f:.2f} Hz · control error "
                     f"{100 * err:+.2f} %")
        elif self.frf is not None:
            text += f" · {self.blocks} blocks · {self.frf.n_averages} averages"
        return text
