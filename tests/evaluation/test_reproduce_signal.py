"""`marl-social reproduce --scenario signalized_intersection`: randomization, table, figures."""

from __future__ import annotations

import numpy as np

from marl_social.evaluation import reproduce_signal as rep
from marl_social.evaluation.run import RANDOMIZATIONS, run_episode


def test_randomization_covers_the_ranges_and_is_seeded():
    draws = [rep.randomized_overrides(s) for s in range(200)]
    assert rep.randomized_overrides(3) == rep.randomized_overrides(3)
    for key, (lo, hi) in RANDOMIZATIONS["signalized_intersection"].items():
        values = np.array([d[key] for d in draws])
        assert values.min() >= lo and values.max() <= hi
        assert values.max() - values.min() > 0.8 * (hi - lo)  # spread over the range
    assert {d["n_humans"] for d in draws} == {1, 2, 3}
    assert {d["n_cross"] for d in draws} == {1, 2}


def test_pulling_out_is_entering_the_merge_zone():
    """turn_s is when the robot's front crosses into the merge zone: after it has come to rest
    at its red line, and never for an episode too short to get there."""
    res = run_episode("signalized_intersection", seed=0, robot_planner="oracle", max_cycles=100)
    t = rep.turn_time_s(res)
    assert 0.5 <= t <= 10.0
    short = run_episode("signalized_intersection", seed=0, robot_planner="oracle", max_cycles=5)
    assert np.isnan(rep.turn_time_s(short))


def test_table_row_and_figure(tmp_path, monkeypatch):
    rows = rep.run_table(1, workers=1, planners=("oracle",), variants=("protected_left",),
                         progress=False, max_cycles=60)
    assert rows[0]["n"] == 1 and not rows[0]["errors"]
    table = rep.format_table(rows)
    assert table.count("\n") == 2 and "| oracle | protected_left | 1 |" in table
    monkeypatch.setattr(rep, "FIGURES", (("sig_social", "social", "protected_left"),))
    monkeypatch.setattr(rep, "MAX_CYCLES", 30)
    paths = rep.write_figures(tmp_path)
    assert [p.name for p in paths] == ["sig_social.png"] and paths[0].stat().st_size > 10_000
