"""One settings tree: every leaf listed with its type, default and meaning, reachable by --set."""

from __future__ import annotations

import json
import warnings

import pytest

import marl_social
from marl_social.cli import main
from marl_social.scenarios import SCENARIOS


@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
def test_params_json_lists_every_leaf_with_type_default_and_doc(scenario, capsys):
    assert main(["params", scenario, "--json"]) == 0
    leaves = json.loads(capsys.readouterr().out)
    prefixes = ["env.", "robot.planner", "robot.mpc.", "robot.belief.", "robot.curb."]
    prefixes += [] if scenario == "long_road" else ["human.", "robot.epsilon"]  # all cruise
    prefixes += ["pedestrian."] if scenario == "occluded_crosswalk" else []
    for prefix in prefixes:
        assert any(name.startswith(prefix) for name in leaves), prefix
    for name, leaf in leaves.items():
        assert set(leaf) == {"type", "unit", "default", "doc"}, name
        assert leaf["type"] in ("bool", "int", "float", "str", "list"), name
    documented = sum(bool(leaf["doc"]) for leaf in leaves.values())
    assert documented == len(leaves), [n for n, leaf in leaves.items() if not leaf["doc"]]
    # each setting declared once: the robot's epsilon is robot.epsilon, not a copy per part
    assert "robot.mpc.epsilon" not in leaves and "robot.belief.epsilon" not in leaves
    assert leaves["robot.mpc.horizon_s"] == {"type": "float", "unit": "s", "default": 6.0,
                                             "doc": "planning horizon [s] (holds a comfortable "
                                                    "stop from the speed limit)"}


def test_a_robot_part_leaf_reaches_the_planner_and_changes_the_episode():
    env = marl_social.parallel_env(**{"robot.mpc.w_speed": 3.0, "robot.curb.p_step_off": 0.4})
    robot = marl_social.policies(env)["robot_0"]
    assert robot.mpc.w_speed == 3.0 and robot.settings.curb.p_step_off == 0.4
    base = marl_social.run_episode(seed=0, max_cycles=60)
    keen = marl_social.run_episode(seed=0, max_cycles=60, **{"robot.mpc.w_speed": 20.0})
    assert (keen.trace.accel_mps2 != base.trace.accel_mps2).any()


def test_dotted_and_flat_names_set_the_same_parameter():
    dotted = marl_social.parallel_env(**{"robot.epsilon": 0.07, "human.beta": 2.0})
    flat = marl_social.parallel_env(robot_epsilon=0.07, human_beta=2.0)
    assert dotted.unwrapped.scenario.params == flat.unwrapped.scenario.params


def test_bad_leaves_are_one_line_errors_naming_them():
    with pytest.raises(ValueError, match="did you mean 'robot.epsilon'"):
        marl_social.parallel_env(**{"robot.epsilom": 0.05})
    with pytest.raises(ValueError, match="did you mean 'robot.belief.p_detect'"):
        marl_social.parallel_env(**{"robot.belief.p_detct": 0.9})
    with pytest.raises(ValueError, match="robot.mpc: MpcConfig: need horizon_s"):
        marl_social.parallel_env(**{"robot.mpc.horizon_s": 0.1})
    with pytest.raises(ValueError, match="robot.stop_line.hold_s='x': expected a number"):
        marl_social.parallel_env(**{"robot.stop_line.hold_s": "x"})


def test_a_flat_name_on_the_command_line_still_works_with_a_deprecation_warning(capsys):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["params", "occluded_crosswalk"]) == 0  # the listing names the new leaves
        from marl_social.cli.overrides import parse_overrides

        assert parse_overrides("occluded_crosswalk", ["robot_epsilon=0.05"]) == {
            "robot_epsilon": 0.05}
    assert any(issubclass(w.category, FutureWarning) and "use --set robot.epsilon=0.05"
               in str(w.message) for w in caught)
    assert "robot.mpc.w_speed" in capsys.readouterr().out


def test_a_study_sweeps_any_leaf(tmp_path):
    from marl_social.studies.runs import expand, load_spec

    spec_file = tmp_path / "sweep.toml"
    spec_file.write_text('name = "w"\nscenario = "occluded_crosswalk"\nseeds = 2\n'
                         'planners = ["social"]\npedestrians = ["crossing"]\n\n'
                         '[grid]\n"robot.mpc.w_speed" = [0.5, 4.0]\n'
                         '"robot.curb.p_step_off" = [0.1, 0.3]\n')
    runs = expand(load_spec(spec_file))
    assert len(runs) == 8
    assert {(r.overrides["robot.mpc.w_speed"], r.overrides["robot.curb.p_step_off"])
            for r in runs} == {
        (0.5, 0.1), (0.5, 0.3), (4.0, 0.1), (4.0, 0.3)}
    spec_file.write_text(spec_file.read_text().replace("w_speed", "w_sped"))
    with pytest.raises(ValueError, match="did you mean 'robot.mpc.w_speed'"):
        load_spec(spec_file)
