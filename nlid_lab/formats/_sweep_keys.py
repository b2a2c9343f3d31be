"""The sweep of a swept-sine recording file: its keys, or the law estimated from the force.

A file that names its sweep (all of ``sweep_start_hz``, ``sweep_stop_hz``, ``sweep_law``,
``sweep_rate``) is taken as it is. One that names none or only some (an acquisition system's
export: arrays and ``Fs`` only) gets the law read off its force
(`analysis.recordings.estimate_sweep`): the lead-in before the sweep and the trailing zeros
are trimmed (counts kept in ``sweep_trimmed_lead``/``sweep_trimmed_tail``), the keys it does
give override the estimate, and ``sweep_estimated`` is set.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from analysis.errors import InputError
from analysis.recordings import (LAW_KEYS, SWEEP_LAWS, RecordingKeys, Sweep, SweepLaw,
                                 estimate_sweep)

_SPEC = re.compile(r"^\s*([^:]+):([^:]+)(?::(linear|log))?(?::([^:]+))?\s*$")


@dataclass(frozen=True)
class SweepOption:
    """``--sweep START:STOP[:LAW[:RATE]]`` parsed: Hz, Hz, linear|log (None: estimated),
    Hz/s or octaves/min (None: estimated from the force)."""

    start_hz: float
    stop_hz: float
    law: str | None = None
    rate: float | None = None

    def keys(self) -> RecordingKeys:
        """The sweep keys of a recording file this option gives (the others estimated)."""
        out: RecordingKeys = {"sweep_start_hz": self.start_hz, "sweep_stop_hz": self.stop_hz}
        if self.law is not None:
            out["sweep_law"] = self.law
        if self.rate is not None:
            out["sweep_rate"] = self.rate
        return out


def parse_sweep_option(text: str) -> SweepOption:
    """``--sweep START:STOP[:LAW[:RATE]]`` (Hz, Hz, linear|log, Hz/s or oct/min)."""
    m = _SPEC.match(text)
    try:
        if not m:
            raise ValueError
        return SweepOption(float(m[1]), float(m[2]), m[3] or None,
                           float(m[4]) if m[4] else None)
    except ValueError:
        raise InputError(f"--sweep {text!r}: write START:STOP[:LAW[:RATE]], e.g. 15:2:linear:0.05 "
                         f"(Hz, Hz, {' or '.join(SWEEP_LAWS)}, Hz/s or octaves/min)") from None


def sweep_fields(keys: RecordingKeys, force: np.ndarray, response: np.ndarray, fs: float
                 ) -> tuple[Sweep, np.ndarray, np.ndarray, float | None]:
    """The sweep of a swept-sine file and its record, trimmed when the law is estimated.

    Parameters
    ----------
    keys : dict
        The file's keys (sweep keys among them, all, some or none).
    force, response : ndarray, shape (n, channels)
    fs : float

    Returns
    -------
    sweep, force, response, amplitude
        ``amplitude`` is the force amplitude estimated with the law (None when the file
        names the whole law).
    """
    if all(k in keys for k in LAW_KEYS):
        return Sweep.from_keys(keys), force, response, None
    given = {k: keys[k] for k in LAW_KEYS if k in keys}
    law = str(np.asarray(given["sweep_law"])) if "sweep_law" in given else None
    if force.ndim != 2 or force.shape[0] < 2:
        raise InputError(f"swept-sine force of shape {force.shape}: expected (n, channels)")
    est, amplitude = estimate_sweep(force[:, 0], fs, law=law)
    merged = {**est.keys(), **given}
    try:
        lw = SweepLaw(float(merged["sweep_start_hz"]), float(merged["sweep_stop_hz"]),
                      str(merged["sweep_law"]), float(merged["sweep_rate"]))
    except (TypeError, ValueError) as exc:
        raise InputError(f"swept-sine keys: {exc}") from None
    sweep = Sweep(lw, True, est.trimmed_lead, est.trimmed_tail)
    span = slice(est.trimmed_lead, force.shape[0] - est.trimmed_tail)
    return sweep, force[span], response[span], amplitude


def describe(sweep: Sweep) -> str:
    """One line: the law, and whether and how it was estimated."""
    lw = sweep.law
    unit = "Hz/s" if lw.law == "linear" else "oct/min"
    text = (f"{lw.law} sweep {lw.start_hz:.4g} -> {lw.stop_hz:.4g} Hz at "
            f"{lw.rate:.4g} {unit}")
    if sweep.estimated:
        text += (f" (estimated from the force; {sweep.trimmed_lead} lead-in and "
                 f"{sweep.trimmed_tail} trailing samples trimmed)")
    return text

