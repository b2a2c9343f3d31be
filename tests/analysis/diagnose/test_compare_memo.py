"""The memory law along the measured motion computed once per record, location and parameters
(`_compare._Memo`), bitwise what a fresh evaluation gives, within its memory bound."""

import numpy as np

from analysis.diagnose._compare import _Memo, deformation, law_force
from analysis.diagnose._prepare import Prepared

PARAMS = {"kd": 1.0, "fd": 2e-3, "n": 2.0}


def _prepared(period: int | None, n: int = 4096) -> Prepared:
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.standard_normal((n, 2)), axis=0) * 1e-4
    return Prepared(x, np.gradient(x, axis=0) * 512.0, rng.standard_normal((n, 1)),
                    np.array([0]), 512.0, 1.0, period, "level")


def test_repeated_evaluation_is_the_first():
    for period in (None, 512):
        p, w = _prepared(period), np.array([1.0, -1.0])
        u, v = deformation(p, w)
        assert deformation(p, w.copy())[0] is u                  # one motion per location
        g = law_force("hysteresis", PARAMS, u, v, period)
        assert law_force("hysteresis", dict(PARAMS), u, v, period) is g
        assert not g.flags.writeable                             # shared: nobody may edit it
        fresh = law_force("hysteresis", PARAMS, u.copy(), v.copy(), period)
        np.testing.assert_array_equal(fresh, g)
        other = law_force("hysteresis", dict(PARAMS, fd=3e-3), u, v, period)
        assert not np.array_equal(other, g)


def test_bounded_and_keyed_on_living_objects():
    made = []
    memo = _Memo(3 * 800)

    def make(k):
        made.append(k)
        return np.full(100, float(k))                            # 800 bytes each
    objs = [np.zeros(1) for _ in range(5)]
    for k, o in enumerate(objs):
        assert memo.get((o,), "d", lambda: make(k))[0] == k
    assert memo.nbytes <= 3 * 800 and len(memo.items) == 3
    assert memo.get((objs[4],), "d", lambda: make(-1))[0] == 4   # a recent one: kept
    assert memo.get((objs[0],), "d", lambda: make(-2))[0] == -2  # the oldest: dropped
    dead = np.zeros(1)
    memo.get((dead,), "d", lambda: make(7))
    del dead
    born = np.zeros(1)                                           # may reuse the id
    assert memo.get((born,), "d", lambda: make(8))[0] == 8
