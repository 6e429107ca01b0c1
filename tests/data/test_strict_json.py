"""Every JSON the project writes parses with a strict parser (no NaN or Infinity tokens)."""

from __future__ import annotations

import json
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.data import strict_json


def _strict_loads(text: str):
    def refuse(token):
        raise ValueError(f"non-standard JSON token {token}")
    return json.loads(text, parse_constant=refuse)


NUMBERS = st.one_of(st.floats(), st.integers(-2**70, 2**70),
                    st.floats().map(np.float64), st.floats(width=32).map(np.float32),
                    st.integers(-2**31, 2**31 - 1).map(np.int64))
DOCUMENTS = st.recursive(
    st.one_of(NUMBERS, st.none(), st.booleans(), st.text(max_size=4)),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(max_size=4), inner, max_size=4)),
    max_leaves=20)


@settings(max_examples=200, deadline=None)
@given(DOCUMENTS)
def test_what_dumps_writes_a_strict_parser_reads(document):
    parsed = _strict_loads(strict_json.dumps(document, indent=1))
    assert strict_json.nulls_as_nan(parsed) is not None


def test_non_finite_numbers_are_null_and_read_back_as_nan():
    text = strict_json.dumps({"a": math.nan, "b": [np.inf, -np.inf, 1.5], "c": np.arange(2)})
    assert _strict_loads(text) == {"a": None, "b": [None, None, 1.5], "c": [0, 1]}
    back = strict_json.nulls_as_nan(_strict_loads(text))
    assert math.isnan(back["a"]) and back["b"][2] == 1.5


def test_an_irl_fit_with_nan_fields_is_strict_json(tmp_path):
    from marl_social.agents.irl.laplace import IrlResult

    fields = IrlResult.__dataclass_fields__
    values = {name: math.nan for name in fields}
    values.update(theta=np.array([1.0, np.nan]), direction=np.array([np.inf, 0.0]),
                  fitted=("a",), n_demos=1, n_regularized=0, converged=False, message="m",
                  extra={"note": np.nan})
    result = IrlResult(**{k: v for k, v in values.items() if k in fields})
    text = result.save(tmp_path / "theta.json").read_text()
    assert _strict_loads(text)["theta"] == [1.0, None]
