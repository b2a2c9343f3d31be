"""The ``elements`` of a stored or printed estimate (contracts section 4), read as typed records.

Every estimator writes its elements as ``{"kind", "w", "params", "ci95"}`` (harmonic balance
also lists the model's known elements and names the estimated parameters in ``"estimated"``);
the report, the reanalysis rows and the harmonic-balance report sections read them through
`elements_from_json`, which reads both layouts and results stored before ``"estimated"``
existed (every parameter taken as estimated).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping


@dataclass(frozen=True)
class EstimatedElement:
    """One element of an estimate.

    ``kind`` is ``"?"`` and ``w`` empty where an old result left them out; ``ci95`` holds the
    parameters that have an interval; ``estimated`` names the parameters the estimator
    estimated (all of ``params`` where the result does not say).
    """

    kind: str
    w: tuple[float, ...]
    params: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    estimated: tuple[str, ...]

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> EstimatedElement:
        """One entry of an estimate's ``elements``."""
        params = dict(data.get("params") or {})
        ci95 = {name: (float(lo_hi[0]), float(lo_hi[1]))
                for name, lo_hi in (data.get("ci95") or {}).items() if lo_hi}
        return cls(str(data.get("kind", "?")), tuple(float(v) for v in data.get("w", ())),
                   params, ci95, tuple(data.get("estimated", params)))


def elements_from_json(result: Mapping[str, Any]) -> tuple[EstimatedElement, ...]:
    """The elements of an estimator's result (none where it holds no ``elements``)."""
    return tuple(EstimatedElement.from_json(el) for el in result.get("elements") or ())
