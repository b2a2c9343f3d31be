"""`elements_from_json` reads an estimate's elements in every layout nlid-lab wrote."""

from __future__ import annotations

from nlid_lab.store import EstimatedElement, elements_from_json


def test_harmonic_balance_layout_names_the_estimated_parameters():
    result = {"estimator": "hbm", "elements": [
        {"kind": "cubic_spring", "w": [1.0], "params": {"k3": 2e9}, "ci95": {},
         "estimated": []},                                       # known: listed, not estimated
        {"kind": "jenkins", "w": [1.0, -1.0], "params": {"kd": 5e4, "fd": 3.0},
         "ci95": {"fd": [2.9, 3.1]}, "estimated": ["fd"]}]}
    known, slider = elements_from_json(result)
    assert known.estimated == () and known.params == {"k3": 2e9}
    assert slider == EstimatedElement("jenkins", (1.0, -1.0), {"kd": 5e4, "fd": 3.0},
                                      {"fd": (2.9, 3.1)}, ("fd",))


def test_old_layout_takes_every_parameter_as_estimated():
    # a reverse-path result stored before "estimator" and "estimated" existed
    (el,) = elements_from_json({"elements": [{"kind": "quad_damper", "w": [1.0],
                                              "params": {"c2": 0.5},
                                              "ci95": {"c2": [0.4, 0.6]}}],
                                "multiple_coherence": {"min": 0.99}})
    assert el.estimated == ("c2",) and el.ci95 == {"c2": (0.4, 0.6)}
    assert elements_from_json({"warnings": []}) == ()
