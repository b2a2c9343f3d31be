"""Random records: the deformation's sensor-noise ratio, read off the noise floor above the
band and carried through the integration, and the warning when it buries the deformation."""

import numpy as np
import pytest

from analysis.plant import Plant, add_relative_noise, random_gaussian
from analysis.models import Element, Model
from analysis.reverse_path import ReversePathOptions, reverse_path
from analysis.reverse_path._noise import BURIED_RANDOM

SDOF = "examples/models/sdof-cubic-quaddamp.toml"
FS, N = 1024.0, 2**18


@pytest.fixture(scope="module")
def sdof():
    model = Model.load(SDOF)
    force = random_gaussian(N, FS, (5, 150), 20.0, seed=11)[:, None]
    return model, force, Plant(model, FS, [0], oversample=2).run(force)


def _estimate(sdof, kind: str, fraction: float):
    model, force, out = sdof
    y = add_relative_noise(getattr(out, kind), fraction, 1)
    cand = model.with_elements([Element(e.kind, e.w, {}) for e in model.elements])
    res = reverse_path((force, y), cand, ReversePathOptions(noise="iv"), fs=FS,
                       force_dofs=[0], force_hold="linear", response_kind=kind)
    [cubic] = [c for c in res.coefficients if c.kind == "cubic_spring"]
    truth = model.elements[cubic.element].params[cubic.param]
    return res, cubic, truth


def test_quiet_displacement_sensor_no_warning_and_the_ratio_is_the_noise(sdof):
    """One DOF, displacement sensor: the deformation is the response, so its noise ratio is
    the relative noise added (5 %), within the floor's few-percent accuracy."""
    res, cubic, truth = _estimate(sdof, "displacement", 0.05)
    assert res.noise["buried"][0] == pytest.approx(0.05, rel=0.05)
    assert not any("buried" in w for w in res.warnings)
    assert cubic.ci95[0] <= truth <= cubic.ci95[1]


def test_noisy_accelerometer_integrated_only_where_it_is_coherent(sdof):
    """3 % accelerometer noise integrated twice grows as 1/f^2: integrated from the band's
    edge (2.5 Hz) it buried the deformation (noise 56 % of its rms, cubic -98 %). The
    integration now starts where the record stands 10x above its white noise floor
    (`noise_edge`, here capped at 1/8 of the band's top, 18.8 Hz) and says so: noise 2.8 %
    of the deformation's rms, cubic -3.1 % (the random-record IV's own limit at this noise:
    its interval ends 0.3 % short of the truth)."""
    res, cubic, truth = _estimate(sdof, "acceleration", 0.03)
    assert res.noise["buried"][0] < BURIED_RANDOM
    assert any(w.startswith("the integrated response is below 10x its sensor noise under")
               for w in res.warnings)
    assert cubic.value == pytest.approx(truth, rel=0.05)


def test_very_noisy_accelerometer_buries_the_deformation_and_warns(sdof):
    """30 % accelerometer noise: even above the coherent edge the deformation is buried, the
    warning says so and the cubic term is far off its interval."""
    res, cubic, truth = _estimate(sdof, "acceleration", 0.3)
    assert res.noise["buried"][0] > 2 * BURIED_RANDOM
    assert any("element 0 (cubic_spring): deformation buried in sensor noise" in w
               for w in res.warnings)
    assert not cubic.ci95[0] <= truth <= cubic.ci95[1]
