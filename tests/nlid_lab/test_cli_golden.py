"""`simulate`, `analyze reverse-path`, `analyze hbm`, `backbone` and `predict` write the JSON
main wrote before their results became typed (``tests/data/cli_golden``, written by
`cli_golden_cases`): every key, its order and the layout identical, only ``schema_version``
keys added; numbers equal to `RTOL`."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cli_golden_cases import CASES, GOLDEN, NUMBER, outputs, without_schema_versions

RTOL = 1e-6
"""The numbers follow least squares, FFTs and LAPACK set-up whose rounding may move with the
BLAS thread count: these cases came out identical with one thread (`make test`) and the default
count on the machine that wrote them, while the detect goldens of the same kind of estimates
measured up to 5.2e-8 (`test_result_json`). 1e-6 leaves a factor 19 over that; a change of a
method moves these numbers by far more."""


@pytest.fixture(scope="module")
def produced(tmp_path_factory):
    return outputs(tmp_path_factory.mktemp("cli_golden"))


def _same(text: str, golden: str) -> None:
    if text == golden:
        return
    assert NUMBER.sub("#", text) == NUMBER.sub("#", golden), "keys or layout differ"
    a = np.array([float(x) for x in NUMBER.findall(text)])
    b = np.array([float(x) for x in NUMBER.findall(golden)])
    np.testing.assert_allclose(a, b, rtol=RTOL, atol=1e-300)


@pytest.mark.parametrize("case", sorted(CASES))
def test_command_json_is_the_golden_one_but_for_schema_versions(produced, case):
    text = produced[case]
    _same(without_schema_versions(text), (GOLDEN / f"{case}.json").read_text())
    # the command's own text: the golden's formatting (indent 2, key order)
    assert text == json.dumps(json.loads(text), indent=2, allow_nan=False) + "\n"
