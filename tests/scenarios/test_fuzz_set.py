"""`--set NAME=VALUE` on any leaf with any text: validated overrides or one ValueError line."""

from __future__ import annotations

import warnings

from hypothesis import example, given, settings
from hypothesis import strategies as st

from marl_social.cli.overrides import parse_overrides
from marl_social.scenarios import SCENARIOS
from marl_social.scenarios.settings_tree import settings_leaves

SCENES = ("occluded_crosswalk", "t_intersection")
VALUES = st.one_of(
    st.text(max_size=12), st.integers().map(str), st.floats().map(repr),
    st.lists(st.floats(allow_nan=False, width=32), max_size=7).map(str),
    st.sampled_from(["true", "false", "nan", "inf", "-inf", "1e400", "[1,2", "", "none",
                     "crossing", "social", "2**64", "0x10", "1_000"]))


@st.composite
def assignments(draw):
    scene = draw(st.sampled_from(SCENES))
    leaves = sorted(settings_leaves(SCENARIOS[scene].params_cls))
    names = draw(st.lists(st.one_of(st.sampled_from(leaves), st.text(max_size=10)),
                          min_size=1, max_size=3))
    return scene, [f"{name}={draw(VALUES)}" for name in names]


@settings(max_examples=150, deadline=None)
@given(assignments())
@example(("occluded_crosswalk", ["robot.belief.accel_noise_mps2=0\n0"]))  # a newline in a value
@example(("occluded_crosswalk", ["robot.belief.beta_grid_hat=0\n0"]))
def test_any_assignment_is_a_setting_or_one_error_line(case):
    scene, texts = case
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # flat names: tested elsewhere
        try:
            overrides = parse_overrides(scene, texts)
        except ValueError as err:
            message = str(err)
            assert message and "\n" not in message and len(message) < 600, message
            return
    assert isinstance(overrides, dict) and len(overrides) <= len(texts)
