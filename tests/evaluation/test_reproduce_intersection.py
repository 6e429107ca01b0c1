"""`marl-social reproduce --scenario t_intersection`: the table's cells and the figures."""

from __future__ import annotations

import numpy as np

from marl_social.evaluation import reproduce_intersection as rep
from marl_social.evaluation.run import RANDOMIZATIONS


def test_randomization_covers_the_ranges_and_is_seeded():
    draws = [rep.randomized_overrides(s) for s in range(200)]
    assert rep.randomized_overrides(3) == rep.randomized_overrides(3)
    for key, (lo, hi) in RANDOMIZATIONS["t_intersection"].items():
        values = np.array([d[key] for d in draws])
        assert values.min() >= lo and values.max() <= hi
        assert values.max() - values.min() > 0.8 * (hi - lo)  # spread over the range
    n_humans = [d["n_humans"] for d in draws]
    assert all(isinstance(n, int) for n in n_humans) and set(n_humans) == {1, 2, 3}


def test_table_row_for_a_near_car():
    """One cell, one episode: the first left-turner lets the near car pass; the row has every
    column and formats."""
    rows = rep.run_table(1, workers=1, planners=("cruise",), variants=("near",), progress=False)
    assert rows[0]["n"] == 1 and not rows[0]["errors"]
    assert rows[0]["human_0_waited_rate"] == 1.0
    assert rows[0]["others_max_decel_mps2"] >= 0.0
    table = rep.format_table(rows)
    assert table.count("\n") == 2 and "| cruise | near | 1 |" in table


def test_figures_are_written(tmp_path, monkeypatch):
    monkeypatch.setattr(rep, "FIGURES", (("t_cruise_near", "cruise", "near"),))
    monkeypatch.setattr(rep, "MAX_CYCLES", 30)
    paths = rep.write_figures(tmp_path)
    assert [p.name for p in paths] == ["t_cruise_near.png"]
    assert paths[0].stat().st_size > 10_000


def test_trace_records_the_belief_in_a_hidden_car():
    """The social robot's belief in a hidden car (trace extra p_vehicle) is a probability per
    state; in the default scenario the waiting left-turner raises it above 0.9 before the robot
    sees V3 (the 50-seed claim is in test_intersection_claims.py)."""
    from marl_social.evaluation.run import run_episode

    res = run_episode("t_intersection", seed=0, robot_planner="social", hidden_vehicle="near",
                      max_cycles=40)
    p = res.trace.extras["p_vehicle"]
    assert p.shape == (len(res.trace.times_s),)
    assert np.all((p >= 0.0) & (p <= 1.0))
    timings = rep.hidden_vehicle_timings(res)
    assert timings["belief_09_s"] < timings["robot_first_sees_v3_s"], timings
