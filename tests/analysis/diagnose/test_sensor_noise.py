"""White sensor noise read below the drive band and carried through the integration
(`analysis.diagnose._sensor_noise`), on synthetic records whose noise is known."""

import numpy as np

from analysis.diagnose._prepare import EDGE_FRACTION
from analysis.diagnose._sensor_noise import floor_below_band, kinematic_noise, noise_bias
from analysis.plant import random_gaussian
from analysis.recordings import change_kind

FS, N, BAND = 256.0, 1 << 16, (2.0, 60.0)
SIGMA = 0.05                       # white noise std of the acceleration channel


def _record(seed: int, below: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A band-limited force (``below``: rms of extra drive at 0.3-1.5 Hz) and an
    acceleration that is a filtered copy of it plus white noise of std `SIGMA`."""
    f = random_gaussian(N, FS, BAND, 1.0, seed=seed)
    if below:
        f = f + random_gaussian(N, FS, (0.3, 1.5), below, seed=seed + 1)
    a = np.convolve(f, [0.5, 0.3, 0.2], mode="same")
    a = a + SIGMA * np.random.default_rng(seed + 2).standard_normal(N)
    return f[:, None], a[:, None]


def test_floor_below_the_band_is_the_white_noise():
    """The one-sided PSD of white noise of std ``s`` at rate ``fs`` is ``2 s^2 / fs``; the
    read floor averages about 11 lines of about 60 Welch segments (relative spread about
    4 %): within 15 %."""
    f, a = _record(3)
    floor = floor_below_band(f, a - a.mean(0), FS, BAND)
    assert floor is not None
    assert abs(floor[0] / (2 * SIGMA ** 2 / FS) - 1) < 0.15


def test_no_floor_where_the_force_drives_below_the_band():
    f, a = _record(3, below=0.3)
    assert floor_below_band(f, a - a.mean(0), FS, BAND) is None


def test_integrated_noise_variance_is_what_change_kind_leaves():
    """White acceleration noise integrated twice by `change_kind` (high-pass 2 Hz, low-pass
    115 Hz): its variance is the floor times the integral of ``(2 pi f)^-4`` over the kept
    lines (within 10 %: the 1/f^4 weight puts it on the few hundred lines near 2 Hz), and
    its rate's the integral of ``(2 pi f)^-2``; away from the record's ends, which the
    diagnosis drops (`analysis.diagnose._prepare.EDGE_FRACTION`: the integration's end
    effects: over the whole record 3.4x the variance)."""
    e = SIGMA * np.random.default_rng(5).standard_normal((N, 1))
    hp, lp = BAND[0], 115.0
    edge = slice(int(EDGE_FRACTION * N), -int(EDGE_FRACTION * N))
    x = change_kind(e, FS, -2, highpass=hp, lowpass=lp)[edge]
    v = change_kind(e, FS, -1, highpass=hp, lowpass=lp)[edge]
    x_var, v_var = kinematic_noise(np.array([2 * SIGMA ** 2 / FS]), "acceleration", hp, lp)
    assert abs(x_var[0] / np.var(x) - 1) < 0.1
    assert abs(v_var[0] / np.var(v) - 1) < 0.1


def test_cubic_bias_is_three_s2_u():
    """``E[(u + e)^3 | u] = u^3 + 3 s2 u``: the noisy cubic less the bias averages to the
    clean one; a gap (no known correction) and unread noise get none."""
    rng = np.random.default_rng(1)
    u = np.linspace(-1.0, 1.0, 201)
    s2 = 0.04
    noise = (np.array([s2, 0.0]), np.array([0.0, 0.0]))        # DOF 0 noisy, DOF 1 clean
    w = np.array([1.0, -1.0])
    e = np.sqrt(s2) * rng.standard_normal((20000, u.size))
    noisy = (u + e) ** 3
    debiased = noisy - noise_bias("cubic_spring", {"p": 1.0}, w, u + e, u + e, noise)
    assert np.max(np.abs(debiased.mean(axis=0) - u ** 3)) < 5 * np.std(debiased) / np.sqrt(
        e.shape[0])
    assert np.allclose(noise_bias("cubic_spring", {"p": 2.0}, w, u, u, noise), 6 * s2 * u)
    assert noise_bias("gap", {"k": 1.0, "g": 0.1}, w, u, u, noise) == 0.0
    assert noise_bias("cubic_spring", {"p": 1.0}, w, u, u, None) == 0.0
