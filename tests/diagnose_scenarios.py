"""Concealed-effect scenarios for the mismatch diagnosis (shared by tests and the benchmark).

Each scenario simulates a *true* structure with the plant at several levels and hands the
diagnosis a *starting* model that lacks one effect (or none). Systems, DOF counts, locations
and levels are our own (not the paper's examples).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from analysis.plant import (Plant, add_relative_noise, multisine, periodic, random_gaussian,
                            sine_block)
from analysis.models import Element, Model
from analysis.recordings import PeriodicLayout, Recording


@dataclass
class Scenario:
    """A true model, the incomplete starting model, recordings and the expected answer."""

    name: str
    truth: Model
    start: Model
    recordings: list[Recording]
    verdict: str
    kind: str | None = None
    dofs: list[int] = field(default_factory=list)
    params: dict[str, float] = field(default_factory=dict)
    level_dependent: bool | None = None


def chain(masses, springs, grounds, zeta_k: float = 2e-4) -> Model:
    """Chain of masses: ``springs[i]`` joins DOF i and i+1, ``grounds[i]`` DOF i to ground;
    stiffness-proportional damping ``C = zeta_k K`` plus a little mass-proportional part."""
    k = np.diag(np.asarray(grounds, dtype=float))
    for i, s in enumerate(springs):
        k[i, i] += s
        k[i + 1, i + 1] += s
        k[i, i + 1] -= s
        k[i + 1, i] -= s
    m = np.diag(np.asarray(masses, dtype=float))
    return Model(m, zeta_k * k + 0.5 * m, k, [], "chain")


def random_runs(truth: Model, force_dof: int, levels, *, fs: float = 256.0, n: int = 1 << 16,
                band=(2.0, 60.0), noise: float = 0.01, response_kind: str = "displacement",
                seed: int = 1, sim_factor: int = 4) -> list[Recording]:
    """One random recording per force rms level, with relative sensor noise.

    The plant holds the drive linearly between samples (first-order hold), which scales the
    sampled-force FRF by ``sinc^2(f / fs)``; the drive is therefore generated and simulated
    ``sim_factor`` times faster and both channels are taken at every ``sim_factor``-th sample,
    as a DAQ samples a continuous force.
    """
    out = []
    for j, rms in enumerate(levels):
        f = random_gaussian(n * sim_factor, fs * sim_factor, band, rms, seed=seed + j)[:, None]
        plant = Plant(truth, fs * sim_factor, [force_dof], response_kind=response_kind)
        resp = plant.run(f).response[::sim_factor]
        resp = add_relative_noise(resp, noise, seed + 100 + j)
        out.append(Recording(fs, "random", [force_dof], f[::sim_factor], resp, response_kind,
                             level=rms))
    return out


def hidden_cubic(n: int = 1 << 16, seed: int = 11) -> Scenario:
    """3-DOF chain, hardening cubic spring from DOF 2 (not forced) to ground; force at DOF 0."""
    base = chain([2.0, 1.5, 1.0], [3.0e4, 2.0e4], [1.5e4, 0.0, 1.0e4])
    p = 4.0e9
    truth = base.with_elements([Element("cubic_spring", [0, 0, 1.0], {"p": p})])
    recs = random_runs(truth, 0, [1.0, 6.0, 12.0], n=n, seed=seed)
    return Scenario("hidden grounded cubic stiffness", truth, base, recs, "discrepancy",
                    "cubic_spring", [2], {"p": p}, True)


def relative_damping(n: int = 1 << 16, seed: int = 21) -> Scenario:
    """4-DOF chain, quadratic damper between DOFs 1 and 2; force at DOF 3."""
    base = chain([1.0, 1.2, 0.8, 1.5], [2.5e4, 1.8e4, 3.0e4], [4.0e4, 0.0, 0.0, 1.5e4])
    p = 80.0
    truth = base.with_elements([Element("quadratic_damping", [0, -1.0, 1.0, 0], {"p": p})])
    recs = random_runs(truth, 3, [2.0, 10.0, 25.0], n=n, seed=seed)
    return Scenario("relative quadratic damping", truth, base, recs, "discrepancy",
                    "quadratic_damping", [1, 2], {"p": p}, True)


def linear_mass_error(n: int = 1 << 16, response_kind: str = "displacement",
                      seed: int = 31) -> Scenario:
    """3-DOF chain whose DOF 1 is 12 % heavier than the model says (level independent)."""
    truth = chain([1.0, 1.12, 0.7], [2.2e4, 1.6e4], [0.9e4, 0.0, 0.6e4])
    start = chain([1.0, 1.0, 0.7], [2.2e4, 1.6e4], [0.9e4, 0.0, 0.6e4])
    start.damping = truth.damping.copy()
    recs = random_runs(truth, 2, [3.0, 9.0, 27.0], n=n, seed=seed,
                       response_kind=response_kind)
    return Scenario("level-independent mass error", truth, start, recs, "discrepancy",
                    "mass_error", [1], {"delta_mass": 0.12}, False)


def no_discrepancy(n: int = 1 << 16, seed: int = 41) -> Scenario:
    """2-DOF system whose model is right, including its known cubic spring between DOFs."""
    base = chain([1.3, 0.9], [2.8e4], [1.6e4, 0.0])
    truth = base.with_elements([Element("cubic_spring", [-1.0, 1.0], {"p": 2.0e9})])
    recs = random_runs(truth, 1, [2.0, 8.0, 16.0], n=n, seed=seed)
    return Scenario("no discrepancy", truth, truth, recs, "adequate", level_dependent=True)


def multisine_runs(truth: Model, force_dof: int, levels, *, fs: float = 256.0,
                   n_period: int = 4096, n_periods: int = 9, dc: float = 0.5,
                   response_kind: str = "acceleration", noise: float = 0.01,
                   seed: int = 5, sim_factor: int = 4) -> list[Recording]:
    """Periodic multisine runs with a start-up transient, DC offsets on every channel and an
    acceleration (or velocity) response: what real recordings look like."""
    out = []
    for j, rms in enumerate(levels):
        one = multisine(n_period * sim_factor, fs * sim_factor, (2.0, 60.0), rms, seed=seed)
        f = periodic(one, n_periods)[:, None]
        resp = Plant(truth, fs * sim_factor, [force_dof],
                     response_kind=response_kind).run(f).response[::sim_factor]
        f = f[::sim_factor]
        resp = add_relative_noise(resp, noise, seed + 10 + j)
        resp = resp + dc * np.std(resp, axis=0) * (1 + np.arange(resp.shape[1]))
        out.append(Recording(fs, "random", [force_dof], f + dc * rms, resp, response_kind,
                             level=rms, layout=PeriodicLayout(n_period, 1, n_periods - 1, 1)))
    return out


def stepped_runs(truth: Model, force_dof: int, amplitudes, freqs, *, fs: float = 1024.0,
                 settle: int = 40, measure: int = 24, noise: float = 0.10,
                 seed: int = 3) -> list[Recording]:
    """Stepped-sine runs (one per amplitude), steady-state blocks with relative noise."""
    out = []
    for j, amp in enumerate(amplitudes):
        plant = Plant(truth, fs, [force_dof])
        n_meas = int(np.ceil(measure * fs / freqs.min()))
        forces, resps = [], []
        for fr in freqs:
            n_set = int(np.ceil(settle * fs / fr))
            drive = sine_block(fr, amp, n_set + n_meas, fs)[:, None]
            x = plant.run(drive).displacement
            forces.append(drive[n_set:])
            resps.append(x[n_set:])
        resp = add_relative_noise(np.array(resps), noise, seed + j)
        out.append(Recording(fs, "stepped-sine", [force_dof], np.array(forces), resp,
                             freqs=np.asarray(freqs, dtype=float), level=amp))
    return out


def masked_friction(noise: float = 0.10, seed: int = 3) -> Scenario:
    """2-DOF, stick-slip (Jenkins) joint between DOFs 0 and 1, stepped sine with 10 % noise."""
    base = chain([1.5, 0.6], [1.0e4], [2.5e4, 0.0], zeta_k=1e-4)
    kd, fd = 8.0e3, 4.0
    truth = base.with_elements([Element("stick_slip", [-1.0, 1.0], {"kd": kd, "fd": fd})])
    freqs = np.linspace(12.0, 40.0, 15)
    recs = stepped_runs(truth, 0, [5.0, 15.0, 40.0], freqs, noise=noise, seed=seed)
    return Scenario("friction masked by 10 % noise", truth, base, recs, "discrepancy",
                    "stick_slip", [0, 1], {"kd": kd, "fd": fd}, True)


def stepped_stiffness_error(noise: float = 0.05, seed: int = 7) -> Scenario:
    """3-DOF chain, stepped sine at DOF 0: the spring between DOFs 1 and 2 is 10 % stiffer
    than the model says (level independent)."""
    truth = chain([1.2, 0.8, 1.0], [2.0e4, 1.5e4], [1.0e4, 0.0, 0.8e4])
    start = chain([1.2, 0.8, 1.0], [2.0e4, 1.5e4 / 1.1], [1.0e4, 0.0, 0.8e4])
    start.damping = truth.damping.copy()
    freqs = np.linspace(10.0, 45.0, 16)
    recs = stepped_runs(truth, 0, [3.0, 12.0], freqs, settle=60, measure=16, noise=noise,
                        seed=seed)
    return Scenario("level-independent stiffness error (stepped sine)", truth, start, recs,
                    "discrepancy", "stiffness_error", [1, 2],
                    {"delta_stiffness": 1.5e4 - 1.5e4 / 1.1}, False)


def two_effects(n: int = 1 << 15, seed: int = 51) -> Scenario:
    """3-DOF chain missing two effects: a cubic spring between DOFs 0 and 1 and a 2e3 N/m
    stiffer ground spring at DOF 2 (the forced DOF). ``kind``/``dofs``/``params`` describe
    the cubic spring; `TWO_EFFECTS_STIFFNESS` the linear error."""
    start = chain([0.8, 1.4, 1.1], [1.8e4, 2.6e4], [1.2e4, 0.0, 0.7e4])
    lin = chain([0.8, 1.4, 1.1], [1.8e4, 2.6e4], [1.2e4, 0.0, 0.7e4 + TWO_EFFECTS_STIFFNESS])
    lin.damping = start.damping.copy()
    truth = lin.with_elements([Element("cubic_spring", [-1.0, 1.0, 0.0], {"p": 3.0e9})])
    recs = random_runs(truth, 2, [1.5, 6.0, 15.0], n=n, seed=seed)
    return Scenario("two missing effects", truth, start, recs, "discrepancy", "cubic_spring",
                    [0, 1], {"p": 3.0e9}, True)


TWO_EFFECTS_STIFFNESS = 2.0e3


def three_effects(n: int = 1 << 15, seed: int = 51) -> Scenario:
    """`two_effects` plus quadratic damping (p = 30) between DOFs 1 and 2."""
    two = two_effects(n, seed)
    truth = two.truth.with_elements(two.truth.elements + [
        Element("quadratic_damping", [0.0, -1.0, 1.0], {"p": 30.0})])
    recs = random_runs(truth, 2, [1.5, 6.0, 15.0], n=n, seed=seed)
    return Scenario("three missing effects", truth, two.start, recs, "discrepancy",
                    "cubic_spring", [0, 1], {"p": 3.0e9}, True)

SCENARIOS = {"hidden_cubic": hidden_cubic, "relative_damping": relative_damping,
             "linear_mass_error": linear_mass_error, "no_discrepancy": no_discrepancy}


def hidden_absorber(n: int = 1 << 15, seed: int = 61) -> Scenario:
    """Physics outside the library: a small mass (6 % of DOF 1's) on a spring and dashpot
    hangs from DOF 1, tuned to 24 Hz, and is not measured. Seen from the two measured DOFs
    it is a frequency-dependent stiffness (an extra resonance/antiresonance pair) that no
    element, mass, stiffness or damping error reproduces. Linear, so level independent."""
    start = chain([1.0, 0.8], [2.0e4], [1.2e4, 0.0])
    m_a, f_a = 0.05, 24.0
    k_a = m_a * (2 * np.pi * f_a) ** 2
    truth = chain([1.0, 0.8, m_a], [2.0e4, k_a], [1.2e4, 0.0, 0.0])
    truth.damping[:2, :2] = start.damping
    truth.damping[1:, 1:] += 0.02 * k_a / (2 * np.pi * f_a) * np.array([[1.0, -1.0],
                                                                         [-1.0, 1.0]])
    full = random_runs(truth, 0, [2.0, 6.0, 18.0], n=n, seed=seed)
    recs = [Recording(r.fs, "random", r.force_dofs, r.force, r.response[:, :2],
                      r.response_kind, level=r.level) for r in full]
    return Scenario("hidden absorber (outside the library)", truth, start, recs,
                    "unexplained", level_dependent=False)


def drifting_structure(n: int = 1 << 15, seed: int = 71) -> Scenario:
    """Four levels of a 2-DOF chain whose ground spring at DOF 0 was 20 % stiffer during
    the lowest and the highest run than during the two middle ones (the model's value): a
    stiffness error fitted to the fitting levels (lowest, third, highest) helps the outer
    two and harms the middle ones, the held-back second level among them."""
    start = chain([1.0, 0.8], [2.0e4], [1.2e4, 0.0])
    stiff = chain([1.0, 0.8], [2.0e4], [1.2e4 * 1.2, 0.0])
    stiff.damping = start.damping.copy()
    levels = [2.0, 4.0, 8.0, 16.0]
    recs = [random_runs(stiff if lv in (2.0, 16.0) else start, 1, [lv], n=n,
                        seed=seed + i)[0] for i, lv in enumerate(levels)]
    return Scenario("structure changed between runs", stiff, start, recs, "unexplained")
