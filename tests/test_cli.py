"""The `marl-social` command line: version, help, --set, suggestions, closed pipes."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import pytest

from marl_social import __version__
from marl_social.cli import build_parser, main
from marl_social.cli.overrides import parse_overrides
from marl_social.scenarios import make_scenario

REPO_ROOT = Path(__file__).resolve().parents[1]
SUBCOMMANDS = ("demo", "reproduce", "record", "irl", "study", "bench", "params")


def _run(*args, shell: str | None = None):
    cmd = shell if shell is not None else [sys.executable, "-m", "marl_social", *args]
    return subprocess.run(cmd, check=False, capture_output=True, text=True, cwd=REPO_ROOT, timeout=300,
                          shell=shell is not None)


def test_version_and_python_m_help_list_every_subcommand():
    out = _run("--version")
    assert out.returncode == 0 and out.stdout.strip() == f"marl-social {__version__}"
    out = _run("--help")
    assert out.returncode == 0
    for name in SUBCOMMANDS:
        assert f"\n    {name}" in out.stdout, name


def _subparsers(parser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield name, sub
                yield from _subparsers(sub)


def test_every_option_shows_its_default():
    for name, sub in _subparsers(build_parser()):
        text = sub.format_help()
        options = [a for a in sub._actions if a.option_strings and a.dest != "help"]
        for action in options:
            assert action.help, (name, action.dest)
        assert sub.formatter_class is argparse.ArgumentDefaultsHelpFormatter, name
        assert not options or "(default:" in text, name


def test_set_values_are_typed_by_the_scenario_parameters():
    got = parse_overrides("occluded_crosswalk", [
        "human_blind=true", "n_humans=2", "human_beta=2.5", "pedestrian=waiting",
        "human_theta=0,1,0.1,0.1,1,1000", "robot_planner=social+beta", "human_beta=3"])
    assert got == {"human_blind": True, "n_humans": 2, "human_beta": 3.0,
                   "pedestrian": "waiting", "human_theta": (0.0, 1.0, 0.1, 0.1, 1.0, 1000.0),
                   "robot_planner": "social+beta"}
    params = make_scenario("occluded_crosswalk", **got).params
    assert (params.human_blind, params.n_humans, params.human_beta) == (True, 2, 3.0)
    assert parse_overrides("occluded_crosswalk", ["human_blind=off"]) == {"human_blind": False}
    assert parse_overrides("long_road", ["n_vehicles=5"]) == {"n_vehicles": 5}


@pytest.mark.parametrize(("assignment", "message"), [
    ("human.blind=maybe", "human_blind is a bool"),
    ("human.beta=-1", "human_beta=-1.0: must be"),
    ("n_humans=1.5", "n_humans: expected an integer"),
    ("human.blnd=true", "did you mean 'human.blind'"),
    ("robot.planner=socail", "did you mean 'social'"),
    ("pedestrian=crosing", "did you mean 'crossing'"),
    ("human.theta=1,x", "list of numbers"),
    ("human.blind", "expected KEY=VALUE"),
    ("robot.belief.p_detct=0.9", "did you mean 'robot.belief.p_detect'"),
    ("robot.mpc.w_speed=fast", "robot.mpc.w_speed=fast: expected a number"),
    ("robot.mpc.horizon_s=0.1", "MpcConfig: need horizon_s > trunk_s"),
    ("robot.mcp.w_speed=1", "did you mean 'robot.mpc.w_speed'"),
])
def test_bad_set_is_one_line_naming_the_field(assignment, message, capsys):
    assert main(["demo", "--set", assignment, "--no-animation"]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


@pytest.mark.parametrize(("argv", "suggestion"), [
    (["demo", "--planner", "socal"], "did you mean 'social'"),
    (["demo", "--scenario", "long_rod"], "did you mean 'long_road'"),
    (["demo", "--pedestrian", "wating"], "did you mean 'waiting'"),
    (["record", "--robot-planner", "cruis"], "did you mean 'cruise'"),
    (["study", "blind-humn"], "did you mean 'blind-human'"),
    (["params", "occluded"], "did you mean 'occluded_crosswalk'"),
])
def test_misspelled_names_get_a_suggestion(argv, suggestion, capsys):
    try:
        code = main(argv)
    except SystemExit as stop:  # argparse rejects a bad choice with exit code 2
        code = stop.code
    assert code == 2
    assert suggestion in capsys.readouterr().err


def test_demo_with_set_runs_the_blind_human_and_the_rationality_planner(tmp_path, capsys):
    assert main(["demo", "--set", "human_blind=true", "--set", "robot_planner=social+beta",
                 "--no-animation", "--max-cycles", "20", "--out", str(tmp_path)]) == 0
    metrics = tmp_path / "occluded_crosswalk_crossing_social_beta_metrics.json"
    assert json.loads(metrics.read_text())["mean_speed_mps"] > 0  # the social+beta robot ran
    assert f"metrics:   {metrics}" in capsys.readouterr().out


def test_demo_uses_a_fitted_theta_file(tmp_path, capsys):
    demos, theta = tmp_path / "demos.npz", tmp_path / "theta.json"
    assert main(["record", "--synthetic", "--segments", "20", "-o", str(demos)]) == 0
    assert main(["irl", "fit", str(demos), "-o", str(theta)]) == 0
    overrides = parse_overrides("occluded_crosswalk", [f"robot_theta_hat={theta}"])
    learned = overrides["robot_theta_hat"]  # the weights the scenario loaded from the file
    assert len(learned) == 6 and learned != make_scenario("occluded_crosswalk").params.robot_theta_hat
    assert main(["demo", "--set", f"robot_theta_hat={theta}", "--no-animation",
                 "--max-cycles", "10", "--out", str(tmp_path)]) == 0
    assert main(["demo", "--set", f"robot_theta_hat={tmp_path / 'missing.json'}"]) == 2
    assert "missing.json does not exist" in capsys.readouterr().err


def test_reproduce_and_study_refuse_to_fix_what_they_sweep(capsys):
    assert main(["reproduce", "--seeds", "1", "--set", "pedestrian=none"]) == 2
    assert "sweeps robot_planner and pedestrian" in capsys.readouterr().err
    assert main(["study", "blind-human", "--set", "human_blind=false"]) == 2
    assert "sweeps it" in capsys.readouterr().err


def test_study_set_goes_into_the_specs_fixed_parameters(monkeypatch):
    from marl_social.studies import runner

    seen = {}

    def fake_cli(args):
        seen["spec"] = args.spec
        return 0

    monkeypatch.setattr(runner, "cli", fake_cli)
    assert main(["study", "epsilon", "--set", "human_blind=true", "--set", "n_humans=2"]) == 0
    assert seen["spec"].fixed["human_blind"] is True and seen["spec"].fixed["n_humans"] == 2


def test_closed_pipe_is_quiet():
    out = _run(shell=f"{sys.executable} -m marl_social study --list | head -1")
    assert out.returncode == 0 and len(out.stdout.splitlines()) == 1
    assert "Traceback" not in out.stderr and "BrokenPipe" not in out.stderr


def test_bench_planners_times_the_intersections_without_a_pedestrian_line(monkeypatch):
    """`bench planners --scenario t_intersection` reaches bench_planners with that scenario;
    an unknown scenario is a clear error, not a KeyError from deep inside."""
    from marl_social.bench import env_bench

    seen = {}
    monkeypatch.setattr(env_bench, "bench_planners",
                        lambda **kw: seen.update(kw) or {"robot_0_decision_ms_median": 1.0})
    assert main(["bench", "planners", "--scenario", "t_intersection"]) == 0
    assert seen == {"scenario": "t_intersection"}
    monkeypatch.undo()
    with pytest.raises(ValueError, match="bench planners: scenario 'long_road'"):
        env_bench.bench_planners(n_episodes=1, scenario="long_road")


@pytest.mark.parametrize("scenario, knob", [("t_intersection", "hidden_speed_mps"),
                                            ("signalized_intersection", "cross_speed_mps")])
def test_record_randomizes_an_intersection_with_its_own_range(tmp_path, scenario, knob):
    """`record --scenario` at an intersection draws that scenario's randomization (not the
    crosswalk's, whose knobs it does not have) and records its humans' decisions."""
    from marl_social.data.decisions import load_decisions
    from marl_social.evaluation.run import RANDOMIZATIONS, scenario_randomized_overrides

    out = tmp_path / "decisions.npz"
    assert main(["record", "--scenario", scenario, "--decisions", "--episodes", "1",
                 "--robot-planner", "cruise", "--max-cycles", "15", "-o", str(out)]) == 0
    assert len(load_decisions(out).chosen) > 0
    drawn = scenario_randomized_overrides(3, scenario)
    lo, hi = RANDOMIZATIONS[scenario][knob]
    assert set(drawn) == set(RANDOMIZATIONS[scenario]) and lo <= drawn[knob] <= hi
    assert scenario_randomized_overrides(3, "long_road") == {}
