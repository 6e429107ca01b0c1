"""Seeds: every integer type a user passes seeds the same episode; anything else is one line."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import marl_social
from marl_social.evaluation.run import run_episode
from marl_social.sim.seeds import MAX_SEED, checked_seed

NUMPY_INTEGERS = (np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32,
                  np.uint64)
NOT_SEEDS = st.one_of(
    st.integers(max_value=-1), st.integers(min_value=MAX_SEED + 1),
    st.floats(allow_nan=True), st.text(max_size=5), st.booleans(),
    st.lists(st.integers(0, 9), max_size=2), st.just(np.float64(2.0)), st.just(np.bool_(True)))


@pytest.fixture(scope="module")
def env():
    return marl_social.parallel_env()


def _first_observations(env, seed) -> bytes:
    obs, _ = env.reset(seed=seed)
    return b"".join(obs[a].tobytes() for a in sorted(obs))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 127), st.sampled_from(NUMPY_INTEGERS))
def test_a_numpy_integer_seeds_the_episode_of_the_equal_python_int(env, seed, kind):
    assert _first_observations(env, kind(seed)) == _first_observations(env, seed)


@pytest.mark.parametrize("seed", [2**31, 2**32 + 5, MAX_SEED])
def test_python_ints_up_to_2_63_minus_1_are_seeds(env, seed):
    assert _first_observations(env, np.uint64(seed)) == _first_observations(env, seed)


@settings(max_examples=60, deadline=None)
@given(NOT_SEEDS)
def test_anything_else_is_a_one_line_error_naming_the_seed(env, seed):
    message = r"^seed must be an integer in \[0, 2\*\*63 - 1\], got "
    with pytest.raises(ValueError, match=message) as err:
        env.reset(seed=seed)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="^seed must be an integer"):
        checked_seed(seed)


@pytest.mark.parametrize("seed", ["3", 2.0, -1])
def test_run_episode_refuses_a_bad_seed_before_it_runs(seed):
    with pytest.raises(ValueError, match="seed must be an integer"):
        run_episode(seed=seed, max_cycles=2)


@pytest.mark.parametrize("args", [["demo", "--no-animation", "--seed", "-1"],
                                  ["record", "--seed0", "-1"],
                                  ["study", "blind-human", "--seeds", "1180591620717411303424"]])
def test_the_cli_refuses_a_bad_seed_in_one_line_and_exits_2(args):
    done = subprocess.run([sys.executable, "-m", "marl_social", *args], capture_output=True,
                          text=True, timeout=120, check=False)
    assert done.returncode == 2
    assert "Traceback" not in done.stderr
    assert done.stderr.strip().splitlines()[-1].count("error") == 1
