"""Live campaign view: time blocks, FRFs building up average by average, stepped-sine sweep.

Every level keeps its curves when the next one starts, so the finished levels stay overlaid
in ordered colours (`plots.level_colours`, light = low level); response DOFs differ by line
style (`DOF_STYLES`).

`LiveObserver` is the `nlid_lab.campaign._observer.CampaignObserver` handed to the campaign: its methods
run in the acquisition thread and only copy the data onto a queue. `LiveView` (GUI thread)
drains that queue on a QTimer, folds each random block into a running spectral matrix
(`FrfAccumulator`) and redraws at most once per tick.
"""

from __future__ import annotations

import queue
from typing import TYPE_CHECKING, Any

import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtWidgets

from analysis.recordings import MIXED, Excitation, SensorMap
from analysis.spectral import (FRF_UNITS, LevelFRF, Spectra, best_linear_approximation,
                               frf_from_bla, frf_from_spectra, sine_fit, spectral_matrix)

from . import _plots as plots

if TYPE_CHECKING:
    from ..campaign import CampaignStart

#: Seconds of time history kept per channel (ring buffer).
HISTORY_S = 2.0
REFRESH_MS = 50
#: Pen style of response DOF q in the FRF panels (colour is the level's).
DOF_STYLES = [QtCore.Qt.PenStyle.SolidLine, QtCore.Qt.PenStyle.DashLine,
              QtCore.Qt.PenStyle.DotLine, QtCore.Qt.PenStyle.DashDotLine]
#: Bottom of the harmonic-content bars, dB below the fundamental.
HARMONIC_FLOOR_DB = -120.0


class LiveObserver:
    """Campaign observer that queues everything for the GUI thread (never touches widgets)."""

    def __init__(self) -> None:
        self.events: queue.SimpleQueue = queue.SimpleQueue()

    def campaign_started(self, info: CampaignStart) -> None:
        """Queue the campaign's start (`CampaignObserver`)."""
        self.events.put(("started", info))

    def block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        """Queue a copy of a random-excitation block."""
        self.events.put(("block", level, seq, np.array(force), np.array(response)))

    def step(self, level: int, index: int, freq: float, force: np.ndarray,
             response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        """Queue a copy of a measured stepped-sine step."""
        self.events.put(("step", level, index, float(freq), np.array(force),
                         np.array(response), float(control_error), np.array(harmonics)))

    def campaign_finished(self, status: str) -> None:
        """Queue the campaign's end and its status."""
        self.events.put(("finished", status))


class RingBuffer:
    """Last ``capacity`` samples of ``n_ch`` channels."""

    def __init__(self, n_ch: int, capacity: int) -> None:
        self.data = np.zeros((capacity, n_ch))
        self.count = 0

    def extend(self, block: np.ndarray) -> None:
        """Append ``block`` (rows are samples), dropping the oldest rows beyond the
        capacity."""
        cap = self.data.shape[0]
        block = block[-cap:]
        n = block.shape[0]
        self.data = np.roll(self.data, -n, axis=0)
        self.data[-n:] = block
        self.count = min(self.count + n, cap)

    def view(self) -> np.ndarray:
        """The samples held, oldest first (a view, not a copy)."""
        return self.data[self.data.shape[0] - self.count:]


class FrfAccumulator:
    """Running Welch average over blocks: each block's spectral matrix is pooled with the
    earlier ones (`analysis.spectral.Spectra.pool`), so the FRF and coherence after block k
    equal a Welch estimate over all k blocks (no overlap across block boundaries)."""

    def __init__(self, fs: float, n_in: int, nperseg: int) -> None:
        self.fs, self.n_in, self.nperseg = fs, n_in, nperseg
        self.spectra: Spectra | None = None

    def add(self, force: np.ndarray, response: np.ndarray) -> None:
        """Pool the cross-spectra of one more block (shorter than a segment: ignored)."""
        data = np.concatenate([force, response], axis=1)
        if data.shape[0] < self.nperseg:
            return
        spec = spectral_matrix(data, self.fs, nperseg=self.nperseg)
        self.spectra = spec if self.spectra is None else Spectra.pool(
            [self.spectra, spec])

    def estimate(self, **labels: Any) -> LevelFRF | None:
        """H1 and coherences of the blocks pooled so far, or None before the first; ``labels``
        go to the `LevelFRF`."""
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
        """Keep one more realization (force, response)."""
        self.blocks.append((force, response))

    def estimate(self, **labels: Any) -> LevelFRF | None:
        """Best linear approximation over the realizations kept, or None before the second;
        ``labels`` go to the `LevelFRF`."""
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
        self.info: CampaignStart | None = None
        self.status = "waiting"
        self.blocks = 0               # blocks or steps received in the whole campaign
        self.level_blocks = 0         # ... in the current level
        self.step_index: int | None = None   # campaign's index of the last step in its level
        self.steps: list[tuple[float, np.ndarray, float]] = []  # freq, H1 (n_dof,), error
        self.harmonics: np.ndarray | None = None
        self.level: int | None = None
        self.level_curves: dict[int, dict[str, list]] = {}   # level -> its plot items
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

    def _on_started(self, info: CampaignStart) -> None:
        self.info = info
        self.status = "running"
        self.blocks = self.level_blocks = 0
        self.steps = []
        self.level = self.step_index = None
        self.level_curves = {}
        self._build()
        self._dirty = True

    def _on_block(self, level: int, seq: int, force: np.ndarray, response: np.ndarray) -> None:
        if level != self.level:
            self._finish_level()
            self.level, self.level_blocks = level, 0
            if self.info.period:
                self._acc = BlaAccumulator(self.fs, self.info.period,
                                           self.info.transient_periods)
            else:
                self._acc = FrfAccumulator(self.fs, force.shape[1], live_nperseg(
                    self.fs, self.info.block_len or force.shape[0]))
        self._acc.add(force, response)
        self._ring.extend(np.concatenate([force, response], axis=1))
        self.blocks += 1
        self.level_blocks += 1
        self.frf = self._acc.estimate(label=self.level_text(level), level=self.level_value(level),
                                      excitation="random",
                                      response_kind=self.response_kind,
                                      force_dofs=np.asarray(self.force_dofs))
        self._dirty = True

    def _on_step(self, level: int, index: int, freq: float, force: np.ndarray,
                 response: np.ndarray, control_error: float, harmonics: np.ndarray) -> None:
        if level != self.level:
            self._finish_level()
            self.level, self.level_blocks = level, 0
            self.steps = []
        self.step_index = index
        f1 = sine_fit(force[:, 0], self.fs, freq)[0]
        h = harmonics[self._h1_row(len(harmonics))] / f1 if f1 != 0 else np.full(harmonics.shape[1], np.nan)
        self.steps.append((freq, h, control_error))
        self.harmonics = harmonics
        self._ring.extend(np.concatenate([force, response], axis=1))
        self.blocks += 1
        self.level_blocks += 1
        self._dirty = True

    def _finish_level(self) -> None:
        """Draw the last data of the level that ends (its curves stay in the plots)."""
        if self.level is None:
            return
        if self.stepped:
            self._redraw_steps()
        else:
            self._redraw_frf()

    def level_value(self, level: int) -> float | None:
        """Nominal force of level index ``level`` (N rms or N), or None."""
        levels = self.info.levels
        return float(levels[level]) if level is not None and level < len(levels) else None

    def level_text(self, level: int | None) -> str:
        """``"5 N rms"`` (random) or ``"8 N"`` (stepped-sine amplitude) of a level index."""
        value = self.level_value(level)
        if value is None:
            return "-" if level is None else f"level {level + 1}"
        unit = "N" if self.stepped else "N rms"
        return f"{value:.3g} {unit}"

    @property
    def stepped(self) -> bool:
        """Whether the campaign is a stepped sine."""
        return self.info is not None and self.info.excitation == Excitation.STEPPED_SINE

    def orders(self, n_rows: int) -> list[int]:
        """Harmonic order of each row of ``harmonics`` (campaign default: 0, 1, ... n-1)."""
        return list(self.info.harmonics or range(n_rows))

    def _h1_row(self, n_rows: int) -> int:
        return self.orders(n_rows).index(1)

    def _on_finished(self, status: str) -> None:
        self.status = status
        self._dirty = True

    # --- layout -----------------------------------------------------------------------------
    @property
    def fs(self) -> float:
        """Sample rate of the campaign, Hz."""
        return float(self.info.fs)

    @property
    def force_dofs(self) -> list[int]:
        """DOF each force acts on."""
        return list(self.info.force_dofs)

    @property
    def response_kind(self) -> str:
        """Kind of the response channels (displacement, velocity or acceleration)."""
        return self.info.response_kind

    @property
    def sensors(self) -> SensorMap | None:
        """The campaign's sensor map (``[sensors]``), or None."""
        return self.info.sensors

    def response_labels(self) -> list[str]:
        """Name of each response channel: ``"point (kind)"`` with a sensor map
        (`analysis.recordings.SensorMap.labels`, as the report's figures), else ``"DOF q"``."""
        smap = self.sensors
        return smap.labels if smap is not None else \
            [f"DOF {q}" for q in range(self.info.n_dof)]

    def channel_names(self) -> list[tuple[str, str]]:
        """(name, unit) of every channel, forces first; with a sensor map the responses are
        named ``"point (kind)"``."""
        if self.info.channels:
            out = list(self.info.channels)
            if self.sensors is not None:
                n_in = len(out) - self.info.n_dof
                out[n_in:] = [(label, unit) for label, (_, unit) in
                              zip(self.response_labels(), out[n_in:])]
            return out
        unit = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}
        return ([(f"F{d}", "N") for d in self.force_dofs]
                + [(f"x{q}", unit[self.response_kind]) for q in range(self.info.n_dof)])

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
        n_dof = self.info.n_dof
        mixed = self.response_kind == MIXED     # a sensor map mixing kinds: each in its own
        units = "SI" if mixed else FRF_UNITS[self.response_kind]
        stepped = self.stepped
        title = ("FRF of the fundamental, per step" if stepped else
                 "FRF: best linear approximation over the realizations"
                 if self.info.period else "FRF: H1 averaged over the blocks")
        self.mag, self.phase = plots.frf_plots(right, units, title=title,
                                               quantity="|H| (each in its kind)" if mixed else
                                               plots.FRF_QUANTITY[self.response_kind])
        if n_dof > 1:                 # line style per response, colour per level
            for q, label in enumerate(self.response_labels()):
                self.mag.legend.addItem(pg.PlotDataItem(pen=pg.mkPen(
                    "#555", width=1.5, style=DOF_STYLES[q % len(DOF_STYLES)])), label)
        if stepped:
            self.error_plot = right.addPlot(row=2, col=0, title="Level-control error")
            plots.style(self.error_plot, "error", "%")
            self.error_plot.setXLink(self.mag)
            self.harm_plot = right.addPlot(row=3, col=0, title="Harmonic content (current step)")
            plots.style(self.harm_plot, "|X_k| / |X_1|", "dB", bottom="Harmonic order",
                        bottom_unit="-")
            self.harm_bars: list[pg.BarGraphItem] = []
        else:
            self.coh_plot = plots.coherence_plot(
                right, row=2, title="Multiple coherence (across realizations)"
                if self.info.period else "Multiple coherence")
            self.coh_plot.setXLink(self.mag)
        g.ci.layout.setColumnStretchFactor(0, 2)
        g.ci.layout.setColumnStretchFactor(1, 3)
        self.progress.setVisible(True)
        self.progress.setValue(0)
        self.progress.setFormat("waiting for the first level")

    def _curves(self, level: int) -> dict[str, list]:
        """The plot items of ``level`` (made on its first data; kept when it is finished)."""
        if level not in self.level_curves:
            levels = [float(v) for v in self.info.levels]
            colour = (plots.level_colours(len(levels), levels) if level < len(levels)
                      else plots.level_colours(level + 1))[level]
            sym = dict(symbol="o", symbolSize=5, symbolBrush=colour, symbolPen=colour) \
                if self.stepped else {}
            items: dict[str, list] = {"mag": [], "phase": [], "coh": [], "error": []}
            for q in range(self.info.n_dof):
                pen = pg.mkPen(colour, width=1.5, style=DOF_STYLES[q % len(DOF_STYLES)])
                items["mag"].append(self.mag.plot(
                    pen=pen, name=self.level_text(level) if q == 0 else None, **sym))
                items["phase"].append(self.phase.plot(pen=pen, **sym))
                if not self.stepped:
                    items["coh"].append(self.coh_plot.plot(pen=pen))
            if self.stepped:
                items["error"].append(self.error_plot.plot(
                    pen=plots.pen(colour), symbol="o", symbolSize=4, symbolBrush=colour,
                    symbolPen=colour))
            self.level_curves[level] = items
        return self.level_curves[level]

    @property
    def mag_curves(self) -> list:
        """Magnitude curves of the current level, one per response DOF."""
        return self._curves(self.level)["mag"] if self.level is not None else []

    @property
    def phase_curves(self) -> list:
        """Phase curves of the current level."""
        return self._curves(self.level)["phase"] if self.level is not None else []

    @property
    def coh_curves(self) -> list:
        """Coherence curves of the current level."""
        return self._curves(self.level)["coh"] if self.level is not None else []

    @property
    def error_curve(self):
        """Control-error curve of the current stepped level."""
        return self._curves(self.level)["error"][0]

    # --- drawing ----------------------------------------------------------------------------
    def _redraw(self) -> None:
        if self.info is None:
            return
        data = self._ring.view()
        t = (np.arange(data.shape[0]) - data.shape[0]) / self.fs
        for i, curve in enumerate(self.time_curves):
            curve.setData(t, data[:, i])
        if self.stepped:
            self._redraw_steps()
        else:
            self._redraw_frf()
        self._update_progress()
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
        with np.errstate(divide="ignore"):
            db = np.maximum(20 * np.log10(mags / ref), HARMONIC_FLOOR_DB)
        for q in range(n_dof):
            bars = pg.BarGraphItem(x=orders + (q - (n_dof - 1) / 2) * width,
                                   y0=HARMONIC_FLOOR_DB, height=db[:, q] - HARMONIC_FLOOR_DB,
                                   width=width,
                                   brush=plots.channel_colour(len(self.force_dofs) + q))
            self.harm_plot.addItem(bars)
            self.harm_bars.append(bars)
        self.harm_plot.setYRange(HARMONIC_FLOOR_DB, 5)
        self.harm_plot.getAxis("bottom").setTicks([[(int(k), str(int(k))) for k in orders]])

    def _update_progress(self) -> None:
        """Progress of the current level, in the same numbers as the header."""
        done, total = self._level_progress()
        if self.level is None:
            return
        self.progress.setRange(0, max(total, 1))
        self.progress.setValue(min(done, max(total, 1)))
        what = "step" if self.stepped else "realization" if self.info.period \
            else "block"
        self.progress.setFormat(f"level {self._level_of()} · {what} {done}/{total}")

    def _level_progress(self) -> tuple[int, int]:
        """(done, planned) steps or blocks of the current level."""
        if self.stepped:
            done = (self.step_index + 1) if self.step_index is not None else 0
            return done, (self.info.n_steps or 0) or done
        return self.level_blocks, (self.info.averages or 0) or self.level_blocks

    def _level_of(self) -> str:
        n = len(self.info.levels)
        return f"{self.level + 1}/{n}" if n else f"{self.level + 1}"

    def _summary(self) -> str:
        kind = self.info.excitation
        if self.info.period:
            kind = "periodic random"
        if self.level is None:
            return f"{kind} · {self.status}"
        text = (f"{kind} · level {self._level_of()}: {self.level_text(self.level)} · "
                f"{self.status}")
        done, total = self._level_progress()
        if self.stepped and self.steps:
            f, _, err = self.steps[-1]
            text += (f" · step {done}/{total} · {f:.2f} Hz · control error "
                     f"{100 * err:+.2f} %")
        elif self.info.period:
            text += f" · realization {done}/{total}"
            if self.frf is not None:
                text += f" · BLA over {self.frf.n_averages} realizations"
        else:
            text += f" · block {done}/{total}"
            if self.frf is not None:
                text += f" · {self.frf.n_averages} averages"
        return text
