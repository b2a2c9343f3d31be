"""The reverse path's dictionaries by name: what its JSON carries and the Welch settings its
passes share.

They stay dicts because each is written as it stands into the estimate's JSON (``noise``,
``screening.ranking``; `ReversePathResult.to_json`, `ScreeningResult.to_json`) or passed as
keyword arguments (`WelchSettings` to `analysis.spectral.spectral_matrix`); the `TypedDict`
names their keys once, so the JSON stays what it was byte for byte.
"""

from __future__ import annotations

from typing import TypedDict


class WelchSettings(TypedDict):
    """Keyword arguments of `analysis.spectral.spectral_matrix` every pass of one estimate
    uses (`._estimator`)."""

    nperseg: int
    window: str
    overlap: float
    band: tuple[float, float]


class NoiseInfo(TypedDict, total=False):
    """``noise`` of the estimate's JSON (`._noise.noise_info`): the treatment chosen
    (``method``: ``"none"`` or ``"iv"``), the white-noise std over rms per DOF, the
    instruments' low-pass; added on the way: ``buried`` (noise over signal of each unknown
    element's deformation, period-averaged runs) and ``instrument_coherence`` (``"iv"``)."""

    method: str
    relative_std: list[float] | None
    lowpass_hz: float | None
    buried: list[float]
    instrument_coherence: list[float]


class IvNoise(TypedDict):
    """What the instrumental-variable solution (`._iv._iv_solution`) adds to `NoiseInfo`:
    the median coherence of each estimated input with its instrument."""

    instrument_coherence: list[float]


class PeriodicStats(TypedDict):
    """What one period-averaged record tells the multisine route
    (`._periodic_lines._periodic_inputs`): its input labels, the noise std over rms per DOF
    from the spread across periods (None with one period) and each unknown element's
    deformation noise over signal (`NoiseInfo` ``buried``)."""

    labels: list[str]
    relative_std: list[float] | None
    buried: list[float]


class CandidateCoefficient(TypedDict):
    """A screened candidate's coefficient estimated with the selected set
    (`._screening._consistency`): value, 95 % interval, ``|p|/sigma``, ``|Im p|/|Re p|`` and
    the relative 95 % half-width."""

    p: float
    ci95: list[float]
    z: float
    imag_ratio: float
    rel_ci: float


class ScreeningRow(TypedDict):
    """One candidate of the screening's ranking (`ScreeningResult.rows`, the JSON's
    ``screening.ranking``), keys in the JSON's order: ``rank``, the candidate, its selection
    and coherence gain, its coefficient (`CandidateCoefficient`'s keys) and ``in_model``
    (the screened model holds this kind at this ``w``)."""

    rank: int
    kind: str | None
    where: str
    label: str
    basis: str
    w: list[float]
    selected: bool
    significant: bool
    conditioned_coherence: float
    coherence_gain: float
    param: str
    p: float
    ci95: list[float]
    z: float
    imag_ratio: float
    rel_ci: float
    in_model: bool
