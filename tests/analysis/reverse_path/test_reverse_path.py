"""Reverse path on the simulated plant: paper sections 3.3.1 and 3.3.2 (issue 3)."""

import numpy as np
import pytest

from analysis.errors import EstimationError, InputError
from analysis.plant import Plant, add_relative_noise, multisine, periodic, random_gaussian
from analysis.models import Element, Model
from analysis.recordings import PeriodicLayout, Recording
from analysis.reverse_path import ReversePathOptions, noise_floor, reverse_path

SDOF = "examples/models/sdof-cubic-quaddamp.toml"
MDOF = "examples/models/three-dof-paper.toml"


def _candidate(model: Model) -> Model:
    return model.with_elements([Element(e.kind, e.w, {}) for e in model.elements])


def _run(path, fs, n, rms, force_dofs, oversample, band=(5, 150)):
    model = Model.load(path)
    force = np.column_stack([random_gaussian(n, fs, band, rms, seed=11 + i)
                             for i in range(len(force_dofs))])
    out = Plant(model, fs, force_dofs, oversample=oversample).run(force)
    return model, force, out


@pytest.fixture(scope="module")
def sdof():
    return _run(SDOF, 1024.0, 2**19, 20.0, [0], 2)


@pytest.fixture(scope="module")
def mdof():
    return _run(MDOF, 4096.0, 2**18, 8.0, [0], 4, band=(5, 400))


def _check(result, model, tol):
    # Noise-free: the residual error is systematic (plant discretisation, leakage), so only
    # the accuracy target is asserted, not the coverage of the random-error interval.
    for c in result.coefficients:
        truth = model.elements[c.element].params[c.param]
        assert c.value == pytest.approx(truth, rel=tol), (c.kind, c.value, truth)
        assert c.ci95[0] < c.value < c.ci95[1]


def test_sdof_paper_331_noise_free(sdof):
    model, force, out = sdof
    res = reverse_path((force, out.displacement), _candidate(model),
                       ReversePathOptions(nperseg=65536), fs=1024.0, force_dofs=[0],
                       force_hold="linear")
    _check(res, model, 1e-3)
    assert res.coherence_nonlinear.min() >= 0.99
    assert res.coherence_linear.min() < 0.5          # the linear analysis fails (fig 3.9)
    # underlying linear FRF = model receptance
    h = model.linear_frf(res.freqs, [0])
    err = np.abs(res.H_linear - h) / np.abs(h).max()
    assert np.median(err) < 2e-3
    js = res.to_json()
    assert js["elements"][0]["kind"] == "cubic_spring" and "p" in js["elements"][0]["ci95"]
    assert js["multiple_coherence"]["min"] >= 0.99


def test_mdof_paper_332_noise_free(mdof):
    model, force, out = mdof
    res = reverse_path((force, out.displacement), _candidate(model),
                       ReversePathOptions(nperseg=16384), fs=4096.0, force_dofs=[0],
                       force_hold="linear")
    _check(res, model, 1e-3)
    assert res.coherence_nonlinear.min() >= 0.99
    assert res.H_linear.shape == (res.freqs.size, 3, 1)
    # neither element lies on the forced DOF: nothing can be fixed, sequential = joint
    with pytest.warns(UserWarning, match="refine='sequential' changes nothing"):
        seq = reverse_path((force, out.displacement), _candidate(model),
                           ReversePathOptions(nperseg=16384, refine="sequential"), fs=4096.0,
                           force_dofs=[0], force_hold="linear")
    assert [c.value for c in seq.coefficients] == [c.value for c in res.coefficients]
    assert res.to_json()["refine"] == {"method": "joint"}


def test_conditioned_equals_correlated_inputs(mdof):
    model, force, out = mdof
    kw = dict(fs=4096.0, force_dofs=[0], force_hold="linear")
    direct = reverse_path((force[: 2**16], out.displacement[: 2**16]), _candidate(model),
                          ReversePathOptions(nperseg=4096, method="direct"), **kw)
    cond = reverse_path((force[: 2**16], out.displacement[: 2**16]), _candidate(model),
                        ReversePathOptions(nperseg=4096, method="conditioned"), **kw)
    # the inputs are partially correlated: force and x^3 are coherent somewhere
    s = direct.spectra.S
    nd = 3
    coh = np.abs(s[:, nd, nd + 1]) ** 2 / (s[:, nd, nd].real * s[:, nd + 1, nd + 1].real)
    assert coh.max() > 0.1
    for a, b in zip(direct.coefficients, cond.coefficients):
        assert b.value == pytest.approx(a.value, rel=1e-9)
    # conditioned ordinary coherences add up to the multiple coherence
    np.testing.assert_allclose(direct.conditioned_coherence.sum(axis=2),
                               direct.coherence_nonlinear, atol=1e-12)


def test_aliasing_warning_and_correction():
    fs = 512.0
    model, force, out = _run(SDOF, fs, 2**17, 20.0, [0], 8)
    kw = dict(fs=fs, force_dofs=[0], force_hold="linear")
    off = reverse_path((force, out.displacement), _candidate(model),
                       ReversePathOptions(nperseg=16384, antialias="off"), **kw)
    warn = reverse_path((force, out.displacement), _candidate(model),
                        ReversePathOptions(nperseg=16384, antialias="warn"), **kw)
    auto = reverse_path((force, out.displacement), _candidate(model),
                        ReversePathOptions(nperseg=16384), **kw)
    assert not off.warnings or not any("aliasing" in w for w in off.warnings)
    assert any("aliasing" in w and "v|v|" in w for w in warn.warnings)
    assert any("upsampled" in w for w in auto.warnings)
    truth = model.elements[1].params["p"]
    err_off = abs(off.coefficients[1].value / truth - 1)
    err_auto = abs(auto.coefficients[1].value / truth - 1)
    assert err_auto < 0.5 * err_off


@pytest.fixture(scope="module")
def mdof_two_forces():
    return _run(MDOF, 4096.0, 2**17, 6.0, [0, 2], 4, band=(5, 400))


def _rec(run, kind):
    model, force, out = run
    resp = {"displacement": out.displacement, "velocity": out.velocity,
            "acceleration": out.acceleration}[kind]
    return Recording(4096.0, "random", [0, 2], force, resp, kind, force_hold="linear")


def test_several_force_inputs(mdof_two_forces):
    model = mdof_two_forces[0]
    res = reverse_path(_rec(mdof_two_forces, "displacement"), _candidate(model),
                       ReversePathOptions(nperseg=8192, band=(10, 400)))
    assert res.H_linear.shape[2] == 2
    _check(res, model, 1e-3)


def test_velocity_and_acceleration_records(mdof_two_forces):
    """Displacement by frequency-domain integration.

    The simulated sensor samples without an anti-alias filter, so the acceleration record
    carries the folded higher harmonics of the x|x| element (acceleration weights them by
    (3 f)^2); its budget is wider than the velocity one.
    """
    model = mdof_two_forces[0]
    for kind, tol in (("velocity", 5e-3), ("acceleration", 2e-2)):
        res = reverse_path(_rec(mdof_two_forces, kind), _candidate(model),
                           ReversePathOptions(nperseg=8192, band=(10, 400)))
        for c in res.coefficients:
            assert c.value == pytest.approx(model.elements[c.element].params["p"], rel=tol)


def test_known_element_is_subtracted(sdof):
    model, force, out = sdof
    cand = model.with_elements([Element("cubic_spring", [1.0], dict(model.elements[0].params)),
                                Element("quadratic_damping", [1.0], {})])
    res = reverse_path((force[: 2**17], out.displacement[: 2**17]), cand,
                       ReversePathOptions(nperseg=16384), fs=1024.0, force_dofs=[0],
                       force_hold="linear")
    assert [c.kind for c in res.coefficients] == ["quadratic_damping"]
    assert res.coefficients[0].value == pytest.approx(20.0, rel=0.02)


def test_bad_inputs(sdof):
    model, force, out = sdof
    ss = Model.load("examples/models/sdof-stick-slip.toml")
    mem = ss.with_elements([Element("stick_slip", [1.0], {})])
    with pytest.raises(EstimationError, match="analyze hbm"):
        reverse_path((force, out.displacement), mem, fs=1024.0, force_dofs=[0])
    with pytest.raises(InputError, match="no unknown parameter"):
        reverse_path((force, out.displacement), model, fs=1024.0, force_dofs=[0])
    with pytest.raises(InputError, match="DOFs"):
        reverse_path((force, np.c_[out.displacement, out.displacement]), _candidate(model),
                     fs=1024.0, force_dofs=[0])
    with pytest.raises(InputError, match="refine must be joint or sequential"):
        ReversePathOptions(refine="two-stage")
    with pytest.raises(InputError, match="not both"):
        reverse_path((force, out.displacement), _candidate(model), ReversePathOptions(),
                     fs=1024.0, force_dofs=[0], nperseg=4096)


def _noisy_estimates(run, fs, fraction, noise, nperseg=8192, n=2**18):
    model, force, out = run
    x = add_relative_noise(out.displacement[:n], fraction, 1)
    return model, reverse_path((force[:n], x), _candidate(model),
                               ReversePathOptions(nperseg=nperseg, noise=noise), fs=fs,
                               force_dofs=[0], force_hold="linear")


def _errors(model, res):
    return {c.kind: (c.value / model.elements[c.element].params[c.param] - 1,
                     c.ci95[0] <= model.elements[c.element].params[c.param] <= c.ci95[1])
            for c in res.coefficients}


def test_noise_floor_reads_white_density():
    """White density read off segments spread over a long record (a median over ~360 lines
    of 128 averages: std ~0.7 %, min of two halves ~-0.4 %): within 3 %."""
    fs, n = 4096.0, 2**20
    sigma = np.array([1e-3, 2e-3])
    structure = np.sin(2 * np.pi * 50 * np.arange(n) / fs)[:, None] * [1.0, 0.5]
    x = structure + sigma * np.random.default_rng(3).standard_normal((n, 2))
    floor, cutoff, std = noise_floor(x, fs, band_hi=400.0)
    assert floor == pytest.approx(2 * sigma**2 / fs, rel=0.03)
    assert std == pytest.approx(np.sqrt([0.5, 0.125] + sigma**2), rel=0.01)
    assert cutoff == 400.0          # nothing but noise above the band
    assert noise_floor(x, fs, band_hi=2000.0)[0] is None     # no room above the band


def test_output_noise_1pct_instrumental_variables(sdof, mdof):
    """1 % white output noise: IV estimates within 1 % with intervals covering the truth."""
    model, res = _noisy_estimates(sdof, 1024.0, 0.01, "auto")
    assert res.noise["method"] == "iv"
    assert res.noise["relative_std"][0] == pytest.approx(0.01, rel=0.1)
    err = _errors(model, res)
    assert abs(err["cubic_spring"][0]) < 0.01 and err["cubic_spring"][1]
    assert err["quadratic_damping"][1]        # damping: +-16 % interval at this noise
    model, res = _noisy_estimates(mdof, 4096.0, 0.01, "auto")
    for kind, (e, covered) in _errors(model, res).items():
        assert abs(e) < 0.01 and covered, (kind, e)


def test_output_noise_biases_h1_and_warns(sdof):
    model, res = _noisy_estimates(sdof, 1024.0, 0.05, "none")
    assert any("sensor noise" in w and "noise='iv'" in w for w in res.warnings)
    e_h1 = _errors(model, res)["cubic_spring"][0]
    assert e_h1 < -0.05                         # errors in variables: biased low
    model, res = _noisy_estimates(sdof, 1024.0, 0.05, "iv")
    e_iv, covered = _errors(model, res)["cubic_spring"]
    assert abs(e_iv) < 0.25 * abs(e_h1) and covered
    assert res.to_json()["noise"]["method"] == "iv"


# --- periodic random (multisine, several realizations) ----------------------------------------

def _periodic_run(path, fs, rms, band, oversample, *, realizations, periods, transient,
                  seed=0, n=8192):
    """Realizations of a random-phase multisine applied back to back to one plant (state
    carried), each for ``transient + periods`` periods; a Recording marked periodic."""
    model = Model.load(path)
    force = np.concatenate([periodic(multisine(n, fs, band, rms, seed=100 * seed + k),
                                     transient + periods) for k in range(realizations)])
    x = Plant(model, fs, [0], oversample=oversample).run(force[:, None]).displacement
    layout = PeriodicLayout(n, transient, periods, realizations)
    return model, Recording(fs, "random", [0], force[:, None], x, force_hold="linear",
                            layout=layout)


def _noisy(rec, fraction, seed):
    return Recording(rec.fs, "random", rec.force_dofs, rec.force,
                     add_relative_noise(rec.response, fraction, seed),
                     force_hold=rec.force_hold, layout=rec.layout)


# SDOF at 15 N rms: at 20 N some phase realizations give no periodic steady state (the
# transient check below fires), so the periodic tests drive a little lower.
SDOF_P = (SDOF, 1024.0, 15.0, (5, 150), 2)
MDOF_P = (MDOF, 4096.0, 8.0, (5, 400), 4)


def test_periodic_noise_free():
    for path, fs, rms, band, os_ in (SDOF_P, MDOF_P):
        model, rec = _periodic_run(path, fs, rms, band, os_, realizations=6, periods=2,
                                   transient=2)
        res = reverse_path(rec, _candidate(model))
        assert res.noise["method"] == "periodic-iv" and res.noise["realizations"] == 6
        _check(res, model, 1e-3)
        assert res.coherence_nonlinear.min() >= 0.99
        h = model.linear_frf(res.freqs, [0])
        assert np.median(np.abs(res.H_linear - h) / np.abs(h).max()) < 2e-3


@pytest.fixture(scope="module")
def sdof_periodic():
    return [_periodic_run(*SDOF_P, realizations=8, periods=8, transient=2, seed=s)
            for s in (1, 2, 3)]


def test_periodic_output_noise_5pct_sdof_cubic(sdof_periodic):
    """5 % output noise, 8 realizations x 8 periods: the cubic spring within 1 % on every
    seed. The quadratic damping needs far more data (below); here it is only unbiased
    within its wide interval. 95 % intervals: at most one miss in three per coefficient
    (measured coverage 9/10 for each, docs)."""
    covered = {"cubic_spring": 0, "quadratic_damping": 0}
    for seed, (model, rec) in enumerate(sdof_periodic):
        res = reverse_path(_noisy(rec, 0.05, seed), _candidate(model))
        assert res.noise["method"] == "periodic-iv"
        assert res.noise["relative_std"][0] == pytest.approx(0.05, rel=0.1)
        err = _errors(model, res)
        assert abs(err["cubic_spring"][0]) < 0.01, err
        for kind in covered:
            covered[kind] += err[kind][1]
    assert min(covered.values()) >= 2, covered


# Data for the 1 % target at 5 % output noise (measured, docs/reverse-path.md "How much
# data"): the 3-DOF cubic element (deformation ~60 % noise per sample) needs 16 realizations
# x 32 periods. The SDOF quadratic damping estimated jointly with the cubic spring stays at
# +-1.3 % rms with 64 x 32 periods (18 M samples): per line both coefficients are free
# complex numbers, and the distortion of v|v| is nearly collinear with a phase-rotated x^3
# distortion. Re-estimating it with the (0.2 %-accurate) spring fixed reaches the target
# with 24 x 16 periods (SDOF_DAMPING_5PCT).
MDOF_5PCT = dict(realizations=16, periods=32, transient=1)
SDOF_5PCT = dict(realizations=64, periods=32, transient=2)


def _errors_5pct(case, layout, seed):
    model, rec = _periodic_run(*case, **layout, seed=seed)
    res = reverse_path(_noisy(rec, 0.05, seed), _candidate(model))
    assert res.noise["realizations"] == layout["realizations"]
    return {c.kind: (*_errors(model, res)[c.kind],
                     (c.ci95[1] - c.ci95[0]) / 2 / model.elements[c.element].params[c.param])
            for c in res.coefficients}


def _mdof_target(seed):
    for kind, (e, covered, _) in _errors_5pct(MDOF_P, MDOF_5PCT, seed).items():
        assert abs(e) < 0.01 and covered, (kind, e, seed)


def test_periodic_output_noise_5pct_mdof():
    """3-DOF at 5 %, 16 realizations x 32 periods: both elements within 1 %, covered."""
    _mdof_target(1)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3, 4, 5])
def test_periodic_output_noise_5pct_mdof_seeds(seed):
    _mdof_target(seed)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
def test_periodic_output_noise_5pct_sdof_damping(seed):
    """SDOF at 5 %, 64 x 32 periods: cubic spring within 0.2 %, damping covered by its
    +-2.5 % interval (the 1 % target is not reached at this data size, docs)."""
    err = _errors_5pct(SDOF_P, SDOF_5PCT, seed)
    assert abs(err["cubic_spring"][0]) < 2e-3 and err["cubic_spring"][1], err
    e, covered, half = err["quadratic_damping"]
    assert covered and half < 0.03, err


SDOF_DAMPING_5PCT = dict(realizations=24, periods=16, transient=2)


def _damping_two_stage(seed):
    """``refine="sequential"``: each coefficient re-estimated with the other fixed at its
    joint estimate (both elements act on the forced DOF), uncertainty propagated."""
    model, rec = _periodic_run(*SDOF_P, **SDOF_DAMPING_5PCT, seed=seed)
    rec = _noisy(rec, 0.05, seed)
    res = reverse_path(rec, _candidate(model), ReversePathOptions(refine="sequential"))
    assert res.refine["method"] == "sequential"
    for c, joint in zip(res.coefficients, res.refine["joint"]):
        truth = model.elements[c.element].params[c.param]
        half = (c.ci95[1] - c.ci95[0]) / 2 / truth
        half_joint = (joint["ci95"][1] - joint["ci95"][0]) / 2 / truth
        assert abs(c.value / truth - 1) < 0.01, (seed, c.kind, c.value)
        assert c.ci95[0] <= truth <= c.ci95[1] and half < 0.015, (seed, c.kind, c.ci95)
        # measured: damping 0.93 % vs 5.6 % joint (mean, seeds 1-4); spring 0.05 vs 0.3 %
        assert half < 0.5 * half_joint, (seed, c.kind, half, half_joint)


def test_periodic_output_noise_5pct_sdof_damping_two_stage():
    """SDOF at 5 %, 24 x 16 periods (3.5 M samples): damping within 1 %, covered."""
    _damping_two_stage(1)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3, 4, 5])
def test_periodic_output_noise_5pct_sdof_damping_two_stage_seeds(seed):
    _damping_two_stage(seed)


def test_periodic_transient_warning_and_inputs():
    model, rec = _periodic_run(*SDOF_P[:3], (5, 150), 2, realizations=4, periods=3,
                               transient=0, n=4096)
    cand = _candidate(model)
    with pytest.raises(InputError, match="at least 4 realizations"):
        reverse_path(rec, cand, realizations=2, transient_periods=1)
    res = reverse_path(rec, cand, transient_periods=0)     # first period from rest
    assert any("not settled" in w for w in res.warnings)
    with pytest.raises(InputError, match="whole 5000-sample periods"):
        reverse_path(rec, cand, period=5000)
    with pytest.raises(InputError, match="some records are periodic"):
        reverse_path([rec, Recording(rec.fs, "random", [0], rec.force, rec.response)], cand)
    with pytest.raises(InputError, match="2 or more steady periods"):
        reverse_path(rec, cand, ReversePathOptions(noise="iv"), transient_periods=2)


def test_periodic_basis_upsampling_is_exact():
    from analysis.models import LIBRARY, evaluate
    n = 256
    t = np.arange(n) / n
    s = np.cos(2 * np.pi * 50 * t) + np.sin(2 * np.pi * 70 * t)     # cube spans 210 > n/2
    exact = np.fft.rfft(evaluate(LIBRARY["x^3"], s, 3, periodic=True))
    plain = np.fft.rfft(evaluate(LIBRARY["x^3"], s))
    folded = [46, 66, 86, 106]               # 256 - (210, 190, 170, 150)
    assert np.abs(plain[folded]).min() > 1.0
    assert np.abs(exact[folded]).max() < 1e-9 * np.abs(exact).max()
    kept = [30, 50, 70, 90]                  # true lines of the cube below n/2
    np.testing.assert_allclose(exact[kept], plain[kept], atol=1e-9 * np.abs(exact).max())


def test_aliasing_warnings_merge_per_basis():
    from analysis.reverse_path._estimator import _merge_alias_warnings
    w = ["noise note",
         "aliasing: basis v|v| of element 1 spans 1000 Hz and folds into the band (0.09 % "
         "in-band error) at fs = 1024 Hz; upsampled x2 before forming it",
         "aliasing: basis v|v| of element 1 spans 1200 Hz and folds into the band (0.15 % "
         "in-band error) at fs = 1024 Hz; upsampled x3 before forming it",
         "noise note"]
    out = _merge_alias_warnings(w)
    assert out[0] == "noise note" and len(out) == 2
    assert "up to 1200 Hz" in out[1] and "up to 0.15 %" in out[1] and "2 records" in out[1]
    assert "x2-x3" in out[1]


def test_options_that_do_not_apply_warn_and_keywords_still_work():
    """Welch settings on periodic records are named in a warning (period averaging uses no
    segments); option fields given as keywords still work, with a DeprecationWarning, and give
    the same estimate as ``options=``."""
    model, rec = _periodic_run(*SDOF_P[:3], (5, 150), 2, realizations=4, periods=3,
                               transient=1, n=4096)
    cand = _candidate(model)
    plain = reverse_path(rec, cand)
    with pytest.warns(UserWarning, match="nperseg, window ignored: the records are periodic"):
        res = reverse_path(rec, cand, ReversePathOptions(nperseg=1024, window="boxcar"))
    assert [c.value for c in res.coefficients] == [c.value for c in plain.coefficients]
    with pytest.warns(DeprecationWarning, match="noise=...\\) is deprecated"):
        old = reverse_path(rec, cand, noise="none")
    new = reverse_path(rec, cand, ReversePathOptions(noise="none"))
    assert [c.value for c in old.coefficients] == [c.value for c in new.coefficients]
    with pytest.raises(TypeError, match="nperseeg"):
        reverse_path(rec, cand, nperseeg=1024)
