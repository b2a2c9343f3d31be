"""Backbones of a Jenkins-joint SDOF twin (`jenkins_twin`): response-controlled levels give
the exact backbone up to the viscous fit of a rate-independent loss; force-controlled levels
read at phase resonance recover it at the reported amplitude; with noise the 95 % intervals
cover the truth."""

import numpy as np
import pytest

from analysis.backbone import backbone, fit_single_mode
from analysis.errors import RecordingError
from analysis.recordings import StepTable
from jenkins_twin import JenkinsSDOF

TWIN = JenkinsSDOF(kd=1.25e4, fd=0.5)          # slips above 40 um, fn 82 -> 80 Hz
#: displacement amplitudes: two below slip (linear), four slipping
AMPLITUDES = [1e-5, 3e-5, 6e-5, 1.2e-4, 2.5e-4, 5e-4]


def held_displacement(a: float, seed: int | None = None, noise: float = 0.0) -> StepTable:
    """A level holding displacement amplitude ``a`` over +-1 Hz about its resonance."""
    fn = TWIN.backbone_at(np.array([a]))[0][0]
    f = np.arange(fn - 1.0, fn + 1.0, 0.05)
    w = 2 * np.pi * f
    force = TWIN.dynamic_stiffness(w, np.full(w.shape, a)) * a
    x = np.full(w.shape, a, complex)
    if noise:
        rng = np.random.default_rng(seed)
        x = x + noise * a * (rng.standard_normal(w.size) + 1j * rng.standard_normal(w.size))
    return StepTable(f, force[:, None], x[:, None], [0], "response", a, control_dof=0)


def test_single_mode_fit_is_exact_on_a_linear_mode_with_residual():
    f = np.linspace(75, 85, 60)
    w = 2 * np.pi * f
    wn, zeta, A, R = 2 * np.pi * 80.0, 0.004, 0.7 - 0.02j, 3.0 + 1.0j
    H = -(w**2) * A / (wn**2 - w**2 + 2j * zeta * wn * w) + R       # accelerance
    fit = fit_single_mode(f, H, 2)
    assert fit.frequency_hz == pytest.approx(80.0, rel=1e-10)
    assert fit.damping_ratio == pytest.approx(zeta, rel=1e-8)
    assert fit.modal_constant == pytest.approx(A, rel=1e-8)
    assert fit.residual == pytest.approx(R, rel=1e-7)
    assert fit.fit_error < 1e-10


def test_response_controlled_levels_give_the_exact_backbone():
    bb = backbone([held_displacement(a) for a in AMPLITUDES])
    for a, p in zip(AMPLITUDES, bb.points):
        fn, zeta = (v[0] for v in TWIN.backbone_at(np.array([a])))
        assert p.displacement_amplitude == pytest.approx(a, rel=1e-12)
        if a < TWIN.fd / TWIN.kd:        # no slip: a linear viscous mode, exact
            assert p.frequency_hz == pytest.approx(fn, rel=1e-10)
            assert p.damping_ratio == pytest.approx(zeta, rel=1e-8)
            continue
        # slipping: a rate-independent loss fitted by a viscous mode peaks at wn (1 + zeta^2)
        # instead of wn, and its damping differs across the resonance by |w/wn - 1| <= zeta
        assert abs(p.frequency_hz / fn - 1) <= 1.1 * zeta**2
        assert abs(p.damping_ratio / zeta - 1) <= zeta
    freqs = [p.frequency_hz for p in bb.points]
    damping = [p.damping_ratio for p in bb.points]
    assert freqs[-1] < freqs[1] - 1.0 and max(damping) > 5 * damping[0]   # softening, losses


def test_force_controlled_curves_read_at_phase_resonance():
    f = np.arange(79.0, 83.0, 0.05)
    levels = (0.01, 0.1, 0.3, 0.6, 1.0)
    bb = backbone([TWIN.held_force(F, f) for F in levels])
    assert bb.points[0].method.startswith("phase resonance")
    for p in bb.points:
        fn, zeta = (v[0] for v in TWIN.backbone_at(np.array([p.displacement_amplitude])))
        assert p.frequency_ci95[0] <= fn <= p.frequency_ci95[1]
        assert p.damping_ci95[0] <= zeta <= p.damping_ci95[1]
        assert p.damping_ci95[1] - p.damping_ci95[0] < 0.02 * zeta       # and informative
    assert bb.points[0].fit_error < 1e-9                   # the lowest level does not slip


def test_noisy_levels_have_covering_intervals():
    covered, n = 0, 0
    for seed in range(20):
        bb = backbone([held_displacement(a, seed * 10 + i, noise=0.01)
                       for i, a in enumerate(AMPLITUDES)])
        for a, p in zip(AMPLITUDES, bb.points):
            fn, zeta = (v[0] for v in TWIN.backbone_at(np.array([a])))
            covered += p.frequency_ci95[0] <= fn <= p.frequency_ci95[1]
            covered += p.damping_ci95[0] <= zeta <= p.damping_ci95[1]
            n += 2
    # 95 % intervals: 240 of them miss about 12 times; 85 % is beyond chance (p < 1e-6)
    assert covered / n >= 0.85, covered / n


def test_json_follows_the_contract():
    out = backbone([held_displacement(a) for a in AMPLITUDES[:3]]).to_json()
    assert out["schema_version"] == 1 and len(out["levels"]) == 3
    for key in ("level", "amplitude", "amplitude_kind", "frequency_hz", "damping_ratio",
                "modal_constant", "fit_error"):
        assert all(isinstance(lv[key], (int, float, str)) for lv in out["levels"]), key
    assert out["levels"][0]["amplitude_kind"] == "displacement"
    assert out["mode"]["frequency_hz"] == pytest.approx(out["levels"][0]["frequency_hz"])


@pytest.mark.parametrize("change, message", [
    (dict(force_phasor=np.ones((3, 1))), "steps"),
    (dict(control="position"), "control"),
    (dict(force_dofs=[1]), "force_dofs"),
    (dict(level=0.0), "level"),
    (dict(harmonics=(3,)), "harmonics"),
])
def test_bad_tables_are_refused(change, message):
    good = dict(freqs=[1.0, 2.0], force_phasor=np.ones((2, 1)), response_phasor=np.ones((2, 1)),
                force_dofs=[0], control="force", level=1.0)
    StepTable(**good)
    with pytest.raises(RecordingError, match=message):
        StepTable(**{**good, **change})


def test_time_blocks_give_the_tables_backbone():
    """A stepped-sine recording (time blocks, no whole number of cycles) sine-fitted into a
    table (`recording_table`) gives the backbone of the table it was sampled from."""
    from analysis.recordings import Recording
    from analysis.spectral import recording_table

    f = np.arange(79.0, 83.0, 0.05)
    fs, n = 2000.0, 1500
    t = np.arange(n) / fs
    tables, recs = [TWIN.held_force(F, f) for F in (0.01, 0.3, 1.0)], []
    for tab in tables:
        wave = np.exp(2j * np.pi * f[:, None] * t[None, :])          # (n_steps, n)
        force = (tab.force_phasor[:, :1] * wave).real[:, :, None]
        resp = (tab.response_phasor[:, :1] * wave).real[:, :, None]
        recs.append(Recording(fs, "stepped-sine", [0], force, resp, "acceleration", freqs=f,
                              level=tab.level))
    direct, sampled = backbone(tables), backbone([recording_table(r) for r in recs])
    for a, b in zip(direct.points, sampled.points):
        assert b.frequency_hz == pytest.approx(a.frequency_hz, rel=1e-9)
        assert b.damping_ratio == pytest.approx(a.damping_ratio, rel=1e-6)
        assert b.amplitude == pytest.approx(a.amplitude, rel=1e-9)


def test_describing_function_of_a_slider_is_the_closed_form():
    from analysis.backbone import describing
    a = np.geomspace(1e-5, 1e-3, 9)
    N = describing("stick_slip", {"kd": TWIN.kd, "fd": TWIN.fd}, a)
    # 512 samples per period: the slip onset is located within one sample
    np.testing.assert_allclose(N, TWIN.describing(a), rtol=2e-3)


def _exact_points(a, f, z):
    """Backbone points of an exact backbone (displacement amplitudes ``a``, frequencies
    ``f``, damping ratios ``z``) with intervals narrow enough to weigh them alike."""
    from analysis.backbone import BackbonePoint
    return [BackbonePoint(level=1.0, amplitude=x, amplitude_kind="displacement",
                          displacement_amplitude=x, frequency_hz=fi,
                          frequency_ci95=(fi * (1 - 1e-6), fi * (1 + 1e-6)), damping_ratio=zi,
                          damping_ci95=(zi * 0.99, zi * 1.01), modal_constant=1.0,
                          fit_error=0.0, method="exact", n_steps=1)
            for x, fi, zi in zip(a, f, z)]


def test_joint_fitted_to_an_exact_backbone_is_the_twins():
    """The exact backbone of the twin (stuck mode, compensated slider): kd and fd back
    within the describing function's sampling error, from the grid's starts."""
    from analysis.backbone import LinearMode, fit_joint
    a = np.array([2e-5, 5e-5, 1e-4, 2e-4, 4e-4, 8e-4])
    f, z = TWIN.backbone_at(a)
    pts = _exact_points(a, f, z)
    w0 = np.sqrt((TWIN.k + TWIN.kd) / TWIN.m)
    mode = LinearMode(w0 / (2 * np.pi), TWIN.c / (2 * TWIN.m * w0), 1 / TWIN.m)
    fit = fit_joint(pts, mode, "stick_slip", compensated=True, kd_max=0.9 * w0**2)
    assert fit.params["kd"] == pytest.approx(TWIN.kd, rel=2e-3)
    assert fit.params["fd"] == pytest.approx(TWIN.fd, rel=2e-3)
    assert fit.damping_rms < 2e-3


def test_model_through_the_same_held_steps_gives_the_measured_backbone():
    """The twin as a model (stick-slip element) run through its own response-controlled
    tables holds their amplitudes and gives their backbone (harmonics 1, 3, 5, 7 against the
    single-harmonic twin: frequencies within 1e-5, damping within 1 %)."""
    from analysis.backbone import model_tables
    from analysis.models import Element, Model
    model = Model(np.eye(1), np.array([[TWIN.c]]), np.array([[TWIN.k]]),
                  [Element("stick_slip", np.array([1.0]), {"kd": TWIN.kd, "fd": TWIN.fd})])
    tables = [held_displacement(a) for a in (1e-5, 6e-5, 2.5e-4)]
    run = model_tables(model, tables)
    sim = run.tables
    assert not run.unconverged and run.summary() == ""
    for t, s in zip(tables, sim):
        np.testing.assert_allclose(np.abs(s.response_phasor), np.abs(t.response_phasor),
                                   rtol=1e-5)
    for p, q in zip(backbone(tables).points, backbone(sim).points):
        assert q.frequency_hz == pytest.approx(p.frequency_hz, rel=1e-5)
        assert q.damping_ratio == pytest.approx(p.damping_ratio, rel=0.01)


M, K, C = 1.0, (2 * np.pi * 80.0) ** 2, 2 * 0.003 * 2 * np.pi * 80.0
GAP = {"k": 0.2 * K, "g": 2e-5}
GAP_LEVELS = (1e-5, 3e-5, 6e-5, 1.2e-4, 2.4e-4)
GAP_STEPS = np.arange(78.0, 90.0, 0.05)


def gap_tables() -> list:
    """Held displacements of a mode with a gap (contact stiffness 0.2 of the mode's beyond
    20 um), exact in one harmonic: force ``(k + N(a) - m w^2 + i c w) a`` per step."""
    from analysis.backbone import describing
    w = 2 * np.pi * GAP_STEPS
    out = []
    for a in GAP_LEVELS:
        N = describing("gap", GAP, np.array([a]))[0]
        force = (K + N - M * w**2 + 1j * C * w) * a
        out.append(StepTable(GAP_STEPS, force[:, None], np.full((w.size, 1), a + 0j), [0],
                             "response", a, control_dof=0))
    return out


def test_a_stiffening_joint_is_fitted_from_its_backbone():
    """Hardening (issue 25 item 4): the backbone of a mode with a gap stiffens, and
    `fit_joint` of a gap on it gives the gap back (one harmonic throughout: each level is
    exactly one quasi-linear mode, the only error the single-mode fit's)."""
    from analysis.backbone import LinearMode, fit_joint
    points = list(backbone(gap_tables()).points)
    fn = [p.frequency_hz for p in points]
    assert fn[0] == pytest.approx(80.0, rel=1e-6)             # below the gap: linear
    assert np.all(np.diff(fn) > 0) and fn[-1] > 84.0           # the frequency rises
    fit = fit_joint(points, LinearMode(80.0, 0.003, 1 / M), "gap", compensated=False,
                    kd_max=0.9 * K)
    assert fit.params["k"] == pytest.approx(GAP["k"], rel=1e-3)
    assert fit.params["g"] == pytest.approx(GAP["g"], rel=1e-3)
    assert fit.frequency_rms < 1e-5


def test_a_stiffening_model_holds_its_amplitudes_through_the_held_steps():
    """The gap mode as a model through its own held tables (issue 25 item 4): every step of
    every level holds its amplitude, the middle branch of a stiffening curve included, and
    needs the force of the balance's own describing function (one harmonic: the AFT's 32
    samples of ``a cos θ``, so each level is exactly one quasi-linear mode of stiffness
    ``K + N_32(a)``; `N_32` differs from the closed form by up to 1e-4 of K)."""
    from analysis.backbone import model_tables
    from analysis.models import Element, Model, restoring_force
    model = Model(np.eye(1), np.array([[C]]), np.array([[K]]),
                  [Element("gap", np.array([1.0]), GAP)])
    tables = gap_tables()
    run = model_tables(model, tables, harmonics=(1,))
    assert not run.unconverged
    sim = run.tables
    theta = 2 * np.pi * np.arange(32) / 32
    w = 2 * np.pi * GAP_STEPS
    for a, t, s, q in zip(GAP_LEVELS, tables, sim, backbone(sim).points):
        np.testing.assert_allclose(np.abs(s.response_phasor), np.abs(t.response_phasor),
                                   rtol=1e-8)
        g, _ = restoring_force("gap", GAP, a * np.cos(theta), -a * np.sin(theta))
        n32 = 2 * np.mean(g * np.cos(theta)) / a
        force = np.abs(K + n32 - M * w**2 + 1j * C * w) * a
        np.testing.assert_allclose(np.abs(s.force_phasor[:, 0]), force, rtol=1e-7)
        assert q.frequency_hz == pytest.approx(np.sqrt((K + n32) / M) / (2 * np.pi), rel=1e-8)
        assert q.damping_ratio == pytest.approx(C / (2 * np.sqrt(M * (K + n32))), rel=1e-6)


def test_a_held_step_that_does_not_converge_is_left_out_and_reported(monkeypatch):
    """A step whose held balance does not converge is not kept as its last iterate: the
    model's table leaves it out and `ModelTables` names it (level and frequency), for the
    summary line and the JSON of `backbone --model`."""
    import analysis.backbone._simulated as simulated
    from analysis.backbone import model_tables
    from analysis.models import Element, Model
    model = Model(np.eye(1), np.array([[TWIN.c]]), np.array([[TWIN.k]]),
                  [Element("stick_slip", np.array([1.0]), {"kd": TWIN.kd, "fd": TWIN.fd})])
    tables = [held_displacement(a) for a in (1e-5, 6e-5)]
    real = simulated.sweep_held

    def failing(system, freqs, force, dof, amplitude):
        res, F = real(system, freqs, force, dof, amplitude)
        if amplitude[0] > 3e-5:                      # the second level's third step fails
            res.converged[2] = False
        return res, F
    monkeypatch.setattr(simulated, "sweep_held", failing)
    run = model_tables(model, tables)
    assert [t.freqs.size for t in run.tables] == [tables[0].freqs.size,
                                                  tables[1].freqs.size - 1]
    assert run.unconverged == ((tables[1].level, tables[1].freqs[2]),)
    assert tables[1].freqs[2] not in run.tables[1].freqs
    assert run.summary().startswith("warning: 1 held step(s)")
    assert f"{tables[1].freqs[2]:.2f} Hz" in run.summary()


SOFT = {"p": -3e11}                  # a softening cubic spring: -0.4 Hz at 0.1 mm
WIDE_GAP = {"k": 0.2 * K, "g": 1e-4}
PAIR_LEVELS = (1e-5, 6e-5, 1e-4, 1.6e-4, 2.4e-4)


def pair_tables() -> list:
    """Held displacements of a mode with a softening cubic spring and a gap beside it: the
    frequency falls, then rises (exact in one harmonic, as `gap_tables`)."""
    from analysis.backbone import describing
    w = 2 * np.pi * GAP_STEPS
    out = []
    for a in PAIR_LEVELS:
        N = describing("gap", WIDE_GAP, np.array([a]))[0] + describing("cubic_spring", SOFT,
                                                                       np.array([a]))[0]
        force = (K + N - M * w**2 + 1j * C * w) * a
        out.append(StepTable(GAP_STEPS, force[:, None], np.full((w.size, 1), a + 0j), [0],
                             "response", a, control_dof=0))
    return out


def test_two_elements_at_one_point_are_fitted_from_their_backbone():
    """Issue 25: a backbone that softens and then stiffens needs two elements at the point;
    `fit_joint` with ``beside`` fits the pair jointly (each exact in one harmonic: the only
    error is the single-mode fit's, as for the gap alone), the second of them is found
    beside the first kept fixed (``fixed``, a later search pass), and their out-of-sample
    residuals (`held_out`) are those of an exact law."""
    from analysis.backbone import (LinearMode, fit_joint, held_out, joint_backbone,
                                   reference_residuals)
    from analysis.models import Element
    points = list(backbone(pair_tables()).points)
    fn = np.array([p.frequency_hz for p in points])
    assert fn[2] < fn[0] - 0.1 and fn[-1] > fn[2] + 0.5          # down, then up
    mode = LinearMode(80.0, 0.003, 1 / M)
    fit = fit_joint(points, mode, "gap", compensated=False, kd_max=0.9 * K,
                    beside="cubic_spring")
    assert fit.params["k"] == pytest.approx(WIDE_GAP["k"], rel=1e-3)
    assert fit.params["g"] == pytest.approx(WIDE_GAP["g"], rel=1e-3)
    assert fit.beside["p"] == pytest.approx(SOFT["p"], rel=1e-3)
    assert fit.frequency_rms < 1e-5
    rf, rz = held_out(points, mode, "gap", fit, compensated=False, kd_max=0.9 * K,
                      beside="cubic_spring")
    assert np.abs(rf).max() < 1e-5 and np.abs(rz).max() < 1e-3
    soft = Element("cubic_spring", np.array([1.0]), SOFT)
    alone = fit_joint(points, mode, "gap", compensated=False, kd_max=0.9 * K, fixed=[soft])
    assert alone.params["k"] == pytest.approx(WIDE_GAP["k"], rel=1e-3)
    f0, _ = reference_residuals(points, mode, [soft])        # the softening alone: the top
    assert f0[-1] < -0.02                                     # level's frequency far off
    fm, _ = joint_backbone(mode, "gap", fit.params, np.array([points[-1].displacement_amplitude]),
                           False, [Element("cubic_spring", np.array([1.0]), fit.beside)])
    assert fm[0] == pytest.approx(fn[-1], rel=1e-5)


def test_anchored_fit_takes_the_sliders_share_of_the_lowest_level_out_of_the_linear_mode():
    """A linear mode fitted at a level where the slider already slips (what `fit-linear` of
    the lowest level gives) holds the slider's share of that level. Anchored, the fit gives
    kd and fd back within the describing function's sampling error and the correction of the
    linear part is that share: ``kd - Re N(a_ref)`` and ``-Im N(a_ref) / w_ref``."""
    from analysis.backbone import LinearMode, fit_joint
    a = np.array([1e-4, 2e-4, 4e-4, 8e-4])
    f, z = TWIN.backbone_at(a)
    pts = _exact_points(a, f, z)
    mode = LinearMode(f[0], z[0], 1 / TWIN.m)        # the lowest level's own mode
    w0 = 2 * np.pi * f[0]
    fit = fit_joint(pts, mode, "stick_slip", compensated=True, kd_max=0.9 * w0**2,
                    anchored=True)
    assert fit.params["kd"] == pytest.approx(TWIN.kd, rel=2e-3)
    assert fit.params["fd"] == pytest.approx(TWIN.fd, rel=2e-3)
    N_ref = TWIN.describing(a[:1])[0]
    assert fit.correction[0] == pytest.approx(TWIN.kd - N_ref.real, rel=2e-3)
    assert fit.correction[1] == pytest.approx(-N_ref.imag / w0, rel=2e-3)
    # held by the lowest level's intervals instead, the slider takes the share the mode
    # already holds for its own (measured: kd 4994 against 12500)
    plain = fit_joint(pts, mode, "stick_slip", compensated=True, kd_max=0.9 * w0**2)
    assert plain.correction == (0.0, 0.0)
    assert abs(plain.params["kd"] / TWIN.kd - 1) > 0.1
