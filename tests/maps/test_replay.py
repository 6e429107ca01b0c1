"""map_replay: an INTERACTION recording's vehicles replayed on their map, the robot planning."""

import numpy as np
import pytest

pytest.importorskip("lanelet2")

from marl_social.cli.app import EXIT_BAD_INPUT, main
from marl_social.envs.parallel import parallel_env
from marl_social.evaluation.map_replay import ReplayRun, run_replay
from tests.maps.synthetic_tracks import HEADER, replay_osm, synthetic_tracks

pytestmark = pytest.mark.filterwarnings("ignore::marl_social.maps.MapConversionWarning")


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    folder = tmp_path_factory.mktemp("recording")
    (folder / "map.osm").write_text(replay_osm())
    (folder / "vehicle_tracks_000.csv").write_text(synthetic_tracks())
    return folder


@pytest.fixture(scope="module")
def replayed(recording):
    run = ReplayRun(str(recording / "map.osm"), str(recording / "vehicle_tracks_000.csv"),
                    max_steps=50)
    return run_replay(run)


def test_recorded_vehicles_replayed_with_the_robot(replayed):
    assert replayed.track_ids == {"human_0": "1", "human_1": "2"}
    assert replayed.late_vehicles == 1
    assert replayed.trace.names == ["robot_0", "human_0", "human_1"]
    assert len(replayed.trace.times_s) == 51
    assert not replayed.metrics["collision"]
    assert 0.0 <= replayed.max_belief <= 1.0


def test_replayed_vehicles_follow_their_recording(replayed):
    # car 1: x = 70 + recorded arc length, 8 m/s braking at 1 m/s^2 from t = 2 s
    assert replayed.max_tracking_error_m < 0.3
    states = np.asarray(replayed.trace.states)
    t = np.asarray(replayed.trace.times_s) - replayed.trace.times_s[0]
    recorded_speed = np.where(t < 2.0, 8.0, 8.0 - (t - 2.0))
    assert np.max(np.abs(states[:, 1, 3] - recorded_speed)) < 0.3
    assert np.max(np.abs(states[:, 2, 0] - 150.0)) < 0.2  # car 2 stays on x = 150


def test_replayed_vehicles_have_their_own_footprints_and_fields_of_view(recording, replayed):
    visible = np.asarray(replayed.trace.visible)
    assert visible[:, 1].any()  # human_0 sees others through its own field of view
    env = parallel_env(scenario="map_replay", map=str(recording / "map.osm"),
                       tracks=str(recording / "vehicle_tracks_000.csv"))
    spec = env.agent_specs["human_1"]
    assert spec.role == "human"
    assert (spec.vehicle.length_m, spec.vehicle.width_m) == pytest.approx((4.2, 1.7))
    assert spec.sensor == env.agent_specs["human_0"].sensor


def test_cli_summary_and_figure(recording, capsys):
    out = recording / "replay.png"
    code = main(["replay", str(recording / "map.osm"), str(recording / "vehicle_tracks_000.csv"),
                 "--steps", "20", "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0
    assert "replayed:  2 vehicles (tracks 1, 2); 1 enter later" in printed
    assert "steps:     20 (2.0 s)" in printed
    assert "max p_pedestrian" in printed
    assert out.stat().st_size > 0


@pytest.mark.parametrize("name, text, words", [
    ("missing.csv", HEADER.rsplit(",", 3)[0] + "\n1,1,100,car,0,0,1,0\n", "missing column"),
    ("empty.csv", "", "empty file"),
    ("pedestrians.csv", HEADER + "\nP1,1,100,pedestrian/bicycle,0,0,1,0,,,\n",
     "no vehicle track"),
])
def test_bad_track_files_are_one_line_errors(recording, capsys, name, text, words):
    (recording / name).write_text(text)
    code = main(["replay", str(recording / "map.osm"), str(recording / name)])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT
    assert words in err and len(err.splitlines()) == 1


def test_unknown_map_is_a_one_line_error(recording, capsys):
    code = main(["replay", "no_such_map", str(recording / "vehicle_tracks_000.csv")])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT
    assert "unknown map" in err and len(err.splitlines()) == 1


def test_parallel_api(recording):
    from pettingzoo.test import parallel_api_test

    env = parallel_env(scenario="map_replay", map=str(recording / "map.osm"),
                       tracks=str(recording / "vehicle_tracks_000.csv"), max_cycles=30)
    parallel_api_test(env, num_cycles=30)
