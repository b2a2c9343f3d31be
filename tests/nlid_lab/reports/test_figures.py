"""Report figures read back through their Axes: labels with units, scales, legend entries,
limits that hold the data, no text cut off at the figure's edge, colours ordered by level."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb

from analysis.diagnose._replay import Replay
from analysis.spectral import LevelFRF
from analysis.hbm import HBMSystem
from analysis.models import Model
from nlid_lab.reports import _figures as figures
from nlid_lab.methods._hbm import model_curve

QUAD = Model.load("examples/models/sdof-cubic-quaddamp.toml")


def sdof_frf(level: float, kind: str = "random", n: int = 200) -> LevelFRF:
    """Receptance of a 2 kg, 2e5 N/m SDOF (50.3 Hz), softened a little per level."""
    f = np.linspace(5.0, 150.0, n)
    k = 2e5 * (1 + 0.01 * level)
    H = 1.0 / (k - 2.0 * (2 * np.pi * f) ** 2 + 1j * 2 * np.pi * f * 20.0)
    unit = "N rms" if kind == "random" else "N"
    coh = np.full((n, 1), 0.9) if kind == "random" else None
    return LevelFRF(label=f"{level:g} {unit}", level=level, excitation=kind,
                    response_kind="displacement", force_dofs=np.array([0]), freqs=f,
                    H=H[:, None, None], multiple_coherence=coh)


def render(fig):
    canvas = FigureCanvasAgg(fig)          # report figures are made without pyplot
    canvas.draw()
    return canvas.get_renderer()


def assert_text_inside(fig) -> None:
    """Every label, title and tick label lies inside the figure (nothing cut off)."""
    renderer = render(fig)
    box = fig.bbox
    texts = [fig._suptitle] if fig._suptitle else []
    for ax in fig.axes:
        texts += [ax.xaxis.label, ax.yaxis.label, ax.title]
        for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
            texts += [label for loc, label in zip(axis.get_ticklocs(), axis.get_ticklabels())
                      if min(lo, hi) <= loc <= max(lo, hi) and label.get_visible()]
    for t in texts:
        if not t.get_text():
            continue
        ext = t.get_window_extent(renderer)
        assert ext.x0 >= box.x0 - 1 and ext.x1 <= box.x1 + 1, t.get_text()
        assert ext.y0 >= box.y0 - 1 and ext.y1 <= box.y1 + 1, t.get_text()


def lines_with_data(ax):
    return [ln for ln in ax.get_lines() if np.isfinite(np.asarray(ln.get_ydata(), float)).any()]


def assert_limits_hold(ax, lines=None) -> None:
    lo, hi = ax.get_ylim()
    for ln in lines if lines is not None else lines_with_data(ax):
        y = np.asarray(ln.get_ydata(), float)
        y = y[np.isfinite(y)]
        assert lo <= y.min() and y.max() <= hi, ln.get_label()


def luminance(colour) -> float:
    r, g, b = to_rgb(colour)
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def test_frf_levels_axes_legend_and_colours_ordered_by_level():
    frfs = [sdof_frf(lv) for lv in (20.0, 5.0, 10.0)]           # not in level order
    fig = figures.frf_levels(frfs, 0)
    mag, ph = fig.axes
    assert mag.get_yscale() == "log" and ph.get_yscale() == "linear"
    assert mag.get_ylabel() == "|H| [m/N]"
    assert ph.get_ylabel() == "Phase [deg]" and ph.get_xlabel() == "Frequency [Hz]"
    assert [t.get_text() for t in mag.get_legend().get_texts()] == \
        ["20 N rms", "5 N rms", "10 N rms"]
    assert_limits_hold(mag)
    assert_limits_hold(ph)
    lum = {ln.get_label(): luminance(ln.get_color()) for ln in mag.get_lines()}
    assert lum["5 N rms"] > lum["10 N rms"] > lum["20 N rms"]      # light = low level
    assert_text_inside(fig)


def test_many_levels_get_a_colour_bar_in_newtons():
    levels = [1.0, 2.0, 3.0, 5.0, 8.0, 13.0, 21.0, 34.0]
    fig = figures.frf_levels([sdof_frf(lv) for lv in levels], 0)
    assert len(fig.axes) == 3                                       # mag, phase, colour bar
    bar = fig.axes[2]
    assert bar.get_ylabel() == "force level [N rms]"
    assert [t.get_text() for t in bar.get_yticklabels()] == [f"{v:g}" for v in levels]
    assert fig.axes[0].get_legend() is None                         # no 8-entry legend
    colours = figures.level_colours(len(levels), levels)
    steps = [np.linalg.norm(np.subtract(to_rgb(a), to_rgb(b)))
             for a, b in zip(colours, colours[1:])]
    assert min(steps) > 0.05                                        # neighbours distinct
    assert_text_inside(fig)


def test_coefficient_panel_shows_real_and_imaginary_parts():
    rng = np.random.default_rng(0)
    f = np.linspace(5, 200, 400)
    c = 6e10 * (1 + 0.01 * rng.standard_normal(f.size)) + 1j * 4e8 * rng.standard_normal(f.size)
    c[195:205] *= 50                                               # wild bins at resonance
    H = 1.0 / (2e5 - 2.0 * (2 * np.pi * f) ** 2 + 1j * 40 * np.pi * f)
    fig = figures.linear_and_coefficients(f, H[:, None], "m/N", {"p": c}, {"p": "N/m³"},
                                          exact={"p": 6e10})
    lin, coef = fig.axes
    assert lin.get_yscale() == "log" and lin.get_ylabel() == "|H_L| [m/N]"
    assert coef.get_ylabel() == "coefficient [N/m³]"
    lo, hi = coef.get_ylim()
    for part in (c.real, c.imag):                                  # central 90 % of each
        p5, p95 = np.percentile(part, [5, 95])
        assert lo <= p5 and p95 <= hi
    assert hi - lo < 0.2 * 6e10 * 50                               # wild bins not shown whole
    labels = [t.get_text() for t in coef.get_legend().get_texts()]
    ratio = np.median(np.abs(c.imag) / np.abs(c.real))
    assert labels[0] == "real part" and labels[2] == "true 6e+10"
    assert f"{100 * ratio:.2g} %" in labels[1]
    assert_text_inside(fig)


def test_hbm_fit_draws_the_model_through_its_folds():
    """Hardening Duffing at 8 N: stepping up, the measured response jumps down past the
    fold; the model curve bends back there, its unstable middle branch dashed."""
    amp, freqs = 8.0, np.arange(30.0, 70.1, 2.0)
    system = HBMSystem(QUAD, [0], (1, 3, 5))
    sweep = system.sweep(freqs, [amp])                   # natural continuation: jumps
    meas = LevelFRF(label="8 N", level=amp, excitation="stepped-sine",
                    response_kind="displacement", force_dofs=np.array([0]), freqs=freqs,
                    H=sweep.frf(0, amp)[:, None, None])
    curve = model_curve(system, freqs, amp, "displacement")
    assert (~curve.stable).any() and np.any(np.diff(curve.freqs) < 0)   # bends back
    fig = figures.fitted_frfs([meas], [curve], 0)
    mag, ph = fig.axes
    assert mag.get_yscale() == "log" and mag.get_ylabel() == "|H| [m/N]"
    assert ph.get_ylabel() == "Phase [deg]" and ph.get_xlabel() == "Frequency [Hz]"
    markers = [ln for ln in mag.get_lines() if ln.get_linestyle() == "None"
               and ln.get_marker() == "o" and ln.get_label() == "8 N"]
    assert len(markers) == 1 and markers[0].get_xdata().size == freqs.size
    dashed = [ln for ln in lines_with_data(mag) if ln.get_linestyle() == "--"]
    solid = [ln for ln in lines_with_data(mag) if ln.get_linestyle() == "-"]
    assert dashed and solid
    legend = [t.get_text() for t in mag.get_legend().get_texts()]
    assert legend == ["8 N", "measured", "model, stable", "model, unstable",
                      "model fold (jump)"]
    assert_limits_hold(mag)
    # the measured jump (largest drop between neighbouring steps) lies inside the model's
    # fold interval, where the dashed branch is
    drop = np.argmax(-np.diff(np.abs(meas.H[:, 0, 0])))
    folds = curve.freqs[np.flatnonzero(np.diff(curve.stable.astype(int)) != 0) + 1]
    assert folds.size == 2
    assert folds.min() - 2.0 <= freqs[drop] and freqs[drop + 1] >= folds.max() - 2.0
    assert freqs[drop] <= folds.max() <= freqs[drop + 1]
    assert_text_inside(fig)


def test_diagnosis_bars_per_level_one_title_and_nothing_cut():
    metric = ("coherence-weighted relative FRF error (rms over the analysis band) on the "
              "held-back recording")
    levels = [figures.LevelBars("5 N rms", 0.41, 0.03),
              figures.LevelBars("10 N rms", 0.52, 0.05, held_back=True),
              figures.LevelBars("20 N rms", 0.77, 0.04)]
    fig = figures.diagnosis_fit(metric, 0.52, 0.05, "FRF error before and after", levels)
    (ax,) = fig.axes
    assert ax.get_title() == "FRF error before and after"
    assert ax.get_ylabel() == "relative error [-]"
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    assert ticks == ["5 N rms", "10 N rms (held back)", "20 N rms"]
    heights = sorted(p.get_height() for p in ax.patches)
    assert heights == sorted([0.41, 0.03, 0.52, 0.05, 0.77, 0.04])
    assert ax.get_ylim()[1] > max(heights)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["model as given",
                                                                 "corrected model"]
    assert all(len(line) <= 80 for line in fig._suptitle.get_text().split("\n"))
    assert_text_inside(fig)


def test_diagnosis_overlay_rows_are_readable():
    n, n_dof = 300, 3
    f = np.linspace(5, 100, n)
    h = (1.0 / (1e5 - (2 * np.pi * f) ** 2))[:, None, None] * np.ones((1, n_dof, 1))
    t = np.linspace(0, 1, 500)
    rep = Replay(np.full(n_dof, 0.1), t, np.sin(40 * t)[:, None] * np.ones(n_dof),
                 0.9 * np.sin(40 * t)[:, None] * np.ones(n_dof))
    curve = SimpleNamespace(freqs=f, measured=h, before=1.2 * h, after=1.01 * h,
                            replay_before=rep, replay_after=rep)
    fig = figures.diagnosis_overlay(curve, "10 N rms (held back)")
    render(fig)
    axes = np.array(fig.axes).reshape(n_dof, 2)
    for dof in range(n_dof):
        assert axes[dof, 0].get_yscale() == "log"
        assert axes[dof, 0].get_ylabel() == f"|H| DOF {dof} [m/N]"
        assert axes[dof, 1].get_ylabel() == f"x DOF {dof} [m]"
        for ax in axes[dof]:
            assert ax.get_window_extent().height > 150             # not a strip
    assert axes[-1, 0].get_xlabel() == "Frequency [Hz]"
    assert axes[-1, 1].get_xlabel() == "Time [s]"
    assert [t.get_text() for t in axes[0, 0].get_legend().get_texts()] == \
        ["measured", "model before", "model after"]
    assert_text_inside(fig)
    # a steady-state replay of accelerometer data is shown in the recorded kind
    acc = Replay(rep.residual, t, rep.measured, rep.predicted, "acceleration")
    fig = figures.diagnosis_overlay(SimpleNamespace(**{**vars(curve), "replay_before": acc,
                                                        "replay_after": acc}), "4 N rms")
    assert np.array(fig.axes).reshape(n_dof, 2)[0, 1].get_ylabel() == "a DOF 0 [m/s²]"


@pytest.mark.parametrize("n_levels", [2, 8])
def test_bla_and_coherence_figures_label_their_axes(n_levels):
    frfs = [sdof_frf(2.0 * (k + 1)) for k in range(n_levels)]
    for frf in frfs:
        g = frf.H[:, :, 0]
        frf.bla = SimpleNamespace(freqs=frf.freqs, G=g, var_total=np.abs(g) ** 2 * 1e-2,
                                  var_noise=np.abs(g) ** 2 * 1e-4)
    fig = figures.bla_levels(frfs, 0)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log" and ax.get_ylabel() == "|G| [m/N]"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "std, total (noise + distortion)" in labels and "std, noise" in labels
    assert ("2 N rms" in labels) == (n_levels <= figures.MAX_LEGEND_LEVELS)
    assert_limits_hold(ax)
    coh = figures.multiple_coherence_levels(frfs, 0).axes[0]
    assert coh.get_ylabel() == "Coherence γ² [-]" and coh.get_ylim() == (0, 1.05)
    assert_text_inside(fig)


def test_phase_axis_is_plus_minus_180_and_levels_without_a_value_are_named_by_their_force():
    """Phase in [-180, 180] (a receptance's -180 above the mode stays there); a level read
    from a file that names none is its measured force in the legend, not "level 1"."""
    from analysis.recordings import Recording
    from analysis.spectral import level_label
    h = sdof_frf(2.0).H[:, 0, 0]
    ph = figures.phase_deg(np.r_[h, -h, 1j * h])
    assert ph.min() >= -180.0 and ph.max() <= 180.0
    fig = figures.frf_levels([sdof_frf(2.0), sdof_frf(8.0)], 0)
    assert fig.axes[1].get_ylim() == (-190.0, 190.0)
    force = 12.4 * np.sqrt(2) * np.sin(np.linspace(0, 200 * np.pi, 4000))[:, None] + 3.0
    rec = Recording(100.0, "random", [0], force, force.copy())
    assert level_label(rec, 0) == "12.4 N rms"               # DC removed, rms of the force


def test_phase_lines_break_at_the_wrap():
    """A phase near 180 degrees that noise takes across the wrap is drawn with a gap there,
    not a full-height line; away from the wrap nothing changes."""
    from nlid_lab.reports import phase_deg, phase_lines

    f = np.arange(5.0)
    h = np.exp(1j * np.radians([179.0, -179.0, 178.0, 90.0, 0.0]))
    x, y = phase_lines(f, h)
    assert np.isnan(x).sum() == 2 and np.isnan(y).sum() == 2
    np.testing.assert_allclose(y[np.isfinite(y)], phase_deg(h))
    assert np.all(np.abs(np.diff(y[np.isfinite(y)][2:])) < 180)
