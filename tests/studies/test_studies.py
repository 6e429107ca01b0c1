"""Sensitivity studies (marl_social/studies/): spec validation,
identical tables from every backend, kill-and-resume, failed runs, the analysis' numbers."""

from __future__ import annotations

import argparse
import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import marl_social.evaluation.run
from marl_social.studies import runner as studies
from marl_social.studies.analysis import analyze, wilson_interval

MAX_CYCLES = 25
TINY = f"""
name = "tiny"
seeds = 3
planners = ["social", "aggressive"]
pedestrians = ["crossing"]
max_cycles = {MAX_CYCLES}
metrics = ["robot_collision", "yielded", "time_to_pass_s", "mean_speed_mps",
           "p_pedestrian_before_seen"]

[grid]
human_speed_mps = [10.5, 12]
"""


def _content(path: Path, seeds=None) -> list[tuple]:
    """A results table's rows without the wall-time column, sorted by key."""
    _, rows = studies.read_results(path)
    return sorted(tuple((k, v) for k, v in row.items() if k != "elapsed_s") for row in rows
                  if seeds is None or int(row["seed"]) in seeds)


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    return _write(tmp_path_factory.mktemp("spec") / "tiny.toml", TINY)


@pytest.fixture(scope="module")
def reference(tiny, tmp_path_factory) -> Path:
    """The tiny study, uninterrupted, in process (1 worker)."""
    out = tmp_path_factory.mktemp("reference")
    outcome = studies.run_study(tiny, out, workers=1, progress=False, summary="none")
    assert (outcome.n_runs, outcome.n_executed, outcome.n_errors) == (12, 12, 0)
    return outcome.results_path


@pytest.fixture
def episode_calls(monkeypatch):
    """Record (key-relevant overrides, seed) of every study episode run in this process."""
    calls = []
    original = marl_social.evaluation.run.run_episode

    def counting(scenario="occluded_crosswalk", seed=0, max_cycles=200, **overrides):
        if max_cycles == MAX_CYCLES:  # not the one-step metric probe
            calls.append((seed, overrides["robot_planner"], overrides["human_speed_mps"]))
        return original(scenario, seed=seed, max_cycles=max_cycles, **overrides)

    monkeypatch.setattr(marl_social.evaluation.run, "run_episode", counting)
    return calls


def _keys_of(calls, spec_path: Path) -> list[str]:
    by_call = {(r.seed, r.overrides["robot_planner"], r.overrides["human_speed_mps"]): r.key
               for r in studies.expand(studies.load_spec(spec_path))}
    return [by_call[c] for c in calls]


# ------------------------------------------------------------------------------ expansion


def test_expand_keys_overrides_and_random_axes(tiny, tmp_path):
    from marl_social.evaluation.run import randomized_overrides

    runs = studies.expand(studies.load_spec(tiny))
    assert len(runs) == 2 * 2 * 3 and len({r.key for r in runs}) == len(runs)
    first = runs[0]
    # the key is canonical: scenario, sorted parameters (12 -> 12.0), seed
    assert first.key == ("occluded_crosswalk|human_speed_mps=10.5|pedestrian=crossing|"
                         "robot_planner=social|seed=0")
    assert {r.key.split("|")[1] for r in runs} == {"human_speed_mps=10.5", "human_speed_mps=12.0"}
    # randomized overrides first, the spec's parameters win
    randomized = randomized_overrides(first.seed)
    assert first.overrides["human_speed_mps"] == 10.5 != randomized["human_speed_mps"]
    assert first.overrides["pedestrian_start_delay_s"] == randomized["pedestrian_start_delay_s"]

    spec = _write(tmp_path / "random.toml", """
        seeds = [4, 7]
        planners = ["oracle"]
        pedestrians = ["none"]
        sample_seed = 3
        [random]
        human_lead_m = {low = 17, high = 23, n = 3}
        n_slots = {low = 4, high = 12, n = 3}
        pedestrian_speed_mps = {choices = [1.1, 1.2, 1.3, 1.4], n = 2}
    """)
    axes = dict(studies.axes(studies.load_spec(spec)))
    assert axes == dict(studies.axes(studies.load_spec(spec)))  # deterministic
    assert all(17 <= v <= 23 for v in axes["human_lead_m"]) and len(set(axes["human_lead_m"])) == 3
    assert all(isinstance(v, int) and 4 <= v <= 12 for v in axes["n_slots"])
    assert len(set(axes["n_slots"])) == 3
    assert set(axes["pedestrian_speed_mps"]) < {1.1, 1.2, 1.3, 1.4}
    assert len(studies.expand(studies.load_spec(spec))) == 3 * 3 * 2 * 2
    other = _write(tmp_path / "other.toml", spec.read_text().replace("sample_seed = 3",
                                                                     "sample_seed = 4"))
    assert dict(studies.axes(studies.load_spec(other)))["human_lead_m"] != axes["human_lead_m"]


# --------------------------------------------------------------------------- determinism


@pytest.mark.slow
def test_two_workers_give_the_same_table(tiny, reference, tmp_path):
    outcome = studies.run_study(tiny, tmp_path, workers=2, progress=False, summary="none")
    assert _content(outcome.results_path) == _content(reference)
    # the finished table is in the spec's order (planner, pedestrian, point, seed)
    _, rows = studies.read_results(outcome.results_path)
    assert [r["key"] for r in rows] == [r.key for r in studies.expand(studies.load_spec(tiny))]
    # the typed Parquet table is written when the study completes, and is the same too
    assert (tmp_path / studies.PARQUET_FILE).is_file()
    assert studies.load(tmp_path).drop(columns="elapsed_s").equals(
        studies.load(reference.parent).drop(columns="elapsed_s"))


@pytest.mark.slow
def test_ray_gives_the_same_table(tiny, reference, tmp_path):
    import ray

    assert not ray.is_initialized()
    outcome = studies.run_study(tiny, tmp_path, workers=2, backend="ray", progress=False,
                                summary="none")  # starts a local ray.init(num_cpus=2)
    assert not ray.is_initialized()  # and shuts it down
    assert _content(outcome.results_path) == _content(reference)


# -------------------------------------------------------------------- resume, failed runs


@pytest.mark.slow
def test_kill_and_resume(tiny, reference, tmp_path, episode_calls):
    table = tmp_path / studies.RESULTS_FILE
    proc = subprocess.Popen([sys.executable, "-m", "marl_social.studies", str(tiny), "--out",
                             str(tmp_path), "--workers", "1", "--no-progress", "--no-plots"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if table.exists() and table.read_bytes().count(b"\n") >= 1 + 3:
            break
        time.sleep(0.02)
    assert proc.poll() is None, f"the study ended before the kill: {proc.stderr.read()}"
    with pytest.raises(RuntimeError, match="another process"):  # one study per folder
        studies.run_study(tiny, tmp_path, existing="resume", progress=False, summary="none")
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    _, before = studies.read_results(table)
    assert 3 <= len(before) < 12
    with open(table, "ab") as f:  # as if killed while writing a row
        f.write(b"occluded_crosswalk|human_speed_mps=12.0|pedestrian=crossing|robot_pl")

    outcome = studies.run_study(tiny, tmp_path, existing="resume", progress=False, summary="none")
    done_before = {r["key"] for r in before}
    ran_now = _keys_of(episode_calls, tiny)
    assert len(ran_now) == len(set(ran_now)) == 12 - len(before)  # nothing ran twice
    assert not done_before & set(ran_now)  # no finished key ran again
    assert (outcome.n_skipped, outcome.n_executed) == (len(before), 12 - len(before))
    _, after = studies.read_results(table)  # raises on a duplicate key or a broken row
    assert [r for r in after if r["key"] in done_before] == sorted(
        before, key=lambda r: [a["key"] for a in after].index(r["key"]))  # untouched
    assert _content(table) == _content(reference)

    episode_calls.clear()
    studies.run_study(tiny, tmp_path, existing="resume", progress=False, summary="none")
    assert episode_calls == []


@pytest.mark.slow
def test_failed_run_is_recorded_and_retried_only_on_request(tiny, reference, tmp_path,
                                                            monkeypatch, episode_calls):
    counting = marl_social.evaluation.run.run_episode

    def flaky(scenario="occluded_crosswalk", seed=0, max_cycles=200, **overrides):
        if seed == 1 and overrides.get("robot_planner") == "aggressive":
            raise RuntimeError("planner diverged\nat step 3")
        return counting(scenario, seed=seed, max_cycles=max_cycles, **overrides)

    monkeypatch.setattr(marl_social.evaluation.run, "run_episode", flaky)
    two_seeds = studies.with_seeds(studies.load_spec(tiny, validate=False), 2)
    outcome = studies.run_study(two_seeds, tmp_path, progress=False, summary="tables")
    assert (outcome.n_runs, outcome.n_errors) == (8, 2)
    _, rows = studies.read_results(outcome.results_path)
    failed = [r for r in rows if r["error"]]
    assert {r["error"] for r in failed} == {"RuntimeError: planner diverged at step 3"}
    assert {(r["planner"], r["seed"]) for r in failed} == {("aggressive", "1")}
    assert all(r["robot_collision"] == r["time_to_pass_s"] == "" for r in failed)
    ok_keys = {r["key"] for r in rows if not r["error"]}
    assert [r for r in _content(outcome.results_path) if dict(r)["key"] in ok_keys] == [
        r for r in _content(reference, seeds={0, 1}) if dict(r)["key"] in ok_keys]
    summary = outcome.analysis.summary_md.read_text()
    assert "| 2 | RuntimeError: planner diverged at step 3 |" in summary

    monkeypatch.setattr(marl_social.evaluation.run, "run_episode", counting)
    episode_calls.clear()
    studies.run_study(two_seeds, tmp_path, existing="resume", progress=False, summary="none")
    assert episode_calls == []  # failed runs count as finished
    studies.run_study(two_seeds, tmp_path, existing="retry_failed", progress=False,
                      summary="none")
    assert sorted(_keys_of(episode_calls, tiny)) == sorted(r["key"] for r in failed)
    assert _content(outcome.results_path) == _content(reference, seeds={0, 1})


def test_existing_table_needs_resume_or_overwrite(tiny, reference, tmp_path, capsys):
    with pytest.raises(FileExistsError, match="--resume .*--overwrite"):
        studies.run_study(tiny, reference.parent, progress=False)
    assert studies.main([str(tiny), "--out", str(reference.parent)]) == 2
    assert "--resume" in capsys.readouterr().err
    other = _write(tmp_path / "other.toml", TINY.replace(f"max_cycles = {MAX_CYCLES}",
                                                         "max_cycles = 30"))
    with pytest.raises(ValueError, match="study.json: .*max_cycles=25.* 30"):
        studies.run_study(other, reference.parent, existing="resume", progress=False)

    one = _write(tmp_path / "one.toml", TINY.replace("seeds = 3", "seeds = 1").replace(
        '"social", "aggressive"', '"aggressive"').replace("[10.5, 12]", "[12]"))
    studies.run_study(one, tmp_path / "out", progress=False, summary="tables")
    with open(tmp_path / "out" / studies.RESULTS_FILE, "a") as f:
        f.write("stale\n")
    studies.run_study(one, tmp_path / "out", existing="overwrite", progress=False,
                      summary="tables")
    _, rows = studies.read_results(tmp_path / "out" / studies.RESULTS_FILE)
    assert len(rows) == 1 and rows[0]["planner"] == "aggressive"


# ---------------------------------------------------------------------------- validation


@pytest.mark.parametrize("text, where, what", [
    ("[grid]\nhuman_betaa = [1, 2]", "[grid] human_betaa", "unknown parameter"),
    ("[fixed]\nplanet_radius_m = 3.0", "[fixed] planet_radius_m", "unknown parameter"),
    ("[grid]\nhuman_beta = [1, -2]", "[grid] human_beta", "must be >= 0"),
    ("[fixed]\nhuman_blind = 3", "[fixed] human_blind", "expected a bool"),
    ("[grid]\nhuman_beta = [1, 1.0]", "[grid] human_beta", "duplicate values"),
    ("[grid]\nhuman_beta = 3", "[grid] human_beta", "non-empty list"),
    ("[random]\nhuman_beta = {low = 3, high = 1, n = 2}", "[random] human_beta", "low < high"),
    ("[fixed]\nhuman_beta = 1\n[grid]\nhuman_beta = [2, 3]", "[grid] human_beta",
     "also set in [fixed]"),
    ('[grid]\nrobot_planner = ["social"]', "[grid] robot_planner", "`planners`"),
    ('planners = ["social", "psychic"]', "planners", "'psychic'"),
    ('pedestrians = ["crossing", "flying"]', "pedestrians", "flying"),
    ('metrics = ["robot_collision", "happiness"]', "metrics", "'happiness'"),
    ("seeds = 0", "seeds", "must be >= 1"),
    ("seed = 3", "seed", "unknown key"),
    ('scenario = "moon_base"', "scenario", "unknown scenario"),
    ("[grid\nhuman_beta = [1", "malformed TOML", "line"),
])
def test_spec_errors_name_the_file_and_key(tmp_path, text, where, what):
    path = _write(tmp_path / "bad.toml", text)
    with pytest.raises(ValueError) as info:
        studies.load_spec(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and where in message and what in message, message


def test_builtin_specs_are_valid():
    specs = studies.builtin_specs()
    assert set(specs) == {"rationality", "blind-human", "sensor-noise", "humans", "epsilon",
                          "yield-expectation"}
    swept = {}
    for name in specs:
        spec = studies.load_spec(name)  # validates every run's parameters
        assert spec.name == name
        if spec.scenario == "occluded_crosswalk":
            assert set(spec.pedestrians) >= {"crossing", "none"}
        assert set(spec.planners) >= {"social", "aggressive", "conservative", "oracle"}
        swept[name] = {p: len(v) for p, v in studies.axes(spec)}
    assert swept["rationality"] == {"human_beta": 6, "robot_beta_hat": 4}
    assert "social+beta" in studies.load_spec("rationality").planners
    assert swept["blind-human"] == {"human_blind": 2, "human_sensor_range_m": 3}
    assert swept["sensor-noise"] == {"robot_pos_noise_m": 3, "human_pos_noise_m": 3}
    assert swept["humans"] == {"n_humans": 5}
    assert swept["epsilon"] == {"robot_epsilon": 4}
    assert swept["yield-expectation"] == {"hidden_vehicle": 2, "human_expects_yield": 2}


def test_unknown_study_name_lists_the_builtins():
    with pytest.raises(ValueError, match="unknown study 'nope'.*rationality"):
        studies.load_spec("nope")


# ------------------------------------------------------------------------------ analysis


def test_wilson_interval_matches_scipy():
    from scipy import stats  # here, not at collection: a slow import
    for n in (1, 7, 20):
        k = np.arange(n + 1)
        low, high = wilson_interval(k, np.full(n + 1, n))
        expected = [stats.binomtest(int(i), n).proportion_ci(method="wilson") for i in k]
        np.testing.assert_allclose(low, [e.low for e in expected], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(high, [e.high for e in expected], rtol=1e-12, atol=1e-15)
    assert np.isnan(wilson_interval([0], [0])).all()


def test_analysis_writes_summary_with_right_intervals_and_plots(tmp_path):
    from scipy import stats  # here, not at collection: a slow import
    spec = studies.StudySpec(name="synthetic", seeds=(0,), planners=("social", "aggressive"),
                             pedestrians=("crossing",),
                             grid={"human_beta": (1.0, 10.0), "human_speed_mps": (10.0, 12.0)},
                             metrics=("robot_collision", "time_to_pass_s"))
    runs = studies.expand(spec)
    rng = np.random.default_rng(0)
    collisions = [True] * 3 + [False] * 7
    passing = [8.1, 9.4, float("nan"), 7.7, 8.8, 10.2, 9.0, 8.3, 7.9, 9.9]
    rows = []
    for run in runs:
        if run.overrides["human_beta"] == 1.0 and run.overrides["human_speed_mps"] == 10.0 \
                and run.overrides["robot_planner"] == "social":
            # the known cell: 10 runs plus a failed one
            for i in range(10):
                values = {"robot_collision": collisions[i], "time_to_pass_s": passing[i]}
                rows.append(studies._row(spec, run._replace(key=f"{run.key}#{i}"), values,
                                         None, 1.0))
            rows.append(studies._row(spec, run._replace(key=run.key + "#x"), None,
                                     "RuntimeError: boom", 1.0))
        elif run.overrides["human_beta"] == 10.0 and run.overrides["human_speed_mps"] == 12.0 \
                and run.overrides["robot_planner"] == "aggressive":  # did not pass
            rows.append(studies._row(spec, run, {"robot_collision": False,
                                                 "time_to_pass_s": float("nan")}, None, 1.0))
        else:
            values = {"robot_collision": bool(rng.random() < 0.2),
                      "time_to_pass_s": float(rng.uniform(7, 11))}
            rows.append(studies._row(spec, run, values, None, 1.0))
    (tmp_path / studies.META_FILE).write_text(json.dumps(studies.study_metadata(spec)))
    with open(tmp_path / studies.RESULTS_FILE, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=studies.result_columns(spec), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)

    out = analyze(tmp_path)
    with open(out.summary_csv, newline="") as f:
        summary = list(csv.DictReader(f))
    cell = next(r for r in summary if (r["planner"], r["human_beta"], r["human_speed_mps"])
                == ("social", "1.0", "10.0"))
    assert (cell["n_runs"], cell["n_errors"], cell["robot_collision_n"]) == ("11", "1", "10")
    wilson = stats.binomtest(3, 10).proportion_ci(method="wilson")
    assert float(cell["robot_collision_mean"]) == pytest.approx(0.3, abs=1e-15)
    assert float(cell["robot_collision_ci_low"]) == pytest.approx(wilson.low, rel=1e-12)
    assert float(cell["robot_collision_ci_high"]) == pytest.approx(wilson.high, rel=1e-12)
    finite = np.array([p for p in passing if np.isfinite(p)])
    low, high = stats.t.interval(0.95, len(finite) - 1, loc=finite.mean(),
                                 scale=stats.sem(finite))
    assert (cell["time_to_pass_s_n"], cell["time_to_pass_s_n_nan"]) == ("9", "1")
    assert float(cell["time_to_pass_s_mean"]) == pytest.approx(finite.mean(), rel=1e-12)
    assert float(cell["time_to_pass_s_ci_low"]) == pytest.approx(low, rel=1e-12)
    assert float(cell["time_to_pass_s_ci_high"]) == pytest.approx(high, rel=1e-12)
    assert len(summary) == 2 * 2 * 2

    never = next(r for r in summary if (r["planner"], r["human_beta"], r["human_speed_mps"])
                 == ("aggressive", "10.0", "12.0"))
    assert (never["time_to_pass_s_n"], never["time_to_pass_s_n_nan"]) == ("0", "1")
    assert never["time_to_pass_s_mean"] == "nan"

    md = out.summary_md.read_text()
    # every value says how many runs it rests on, of how many finished, and how many failed
    assert f"0.30 [{wilson.low:.2f}, {wilson.high:.2f}] (10, 1 failed)" in md
    assert f"{finite.mean():.3g} [{low:.3g}, {high:.3g}] (passed 9/10, 1 failed)" in md
    assert "| – (passed 0/1) |" in md
    assert "| 1 | RuntimeError: boom |" in md
    names = {p.name for p in out.figures}
    assert names == {"robot_collision_vs_human_beta.png", "time_to_pass_s_vs_human_beta.png",
                     "robot_collision_vs_human_speed_mps.png",
                     "time_to_pass_s_vs_human_speed_mps.png",
                     "heatmap_robot_collision_human_beta_x_human_speed_mps_crossing.png",
                     "heatmap_time_to_pass_s_human_beta_x_human_speed_mps_crossing.png"}
    assert all(p.stat().st_size > 5000 and p.read_bytes()[:4] == b"\x89PNG" for p in out.figures)


# ----------------------------------------------------------------------------------- CLI


def test_cli(tiny, reference, capsys):
    parser = argparse.ArgumentParser(prog="marl-social")
    sub = parser.add_subparsers(dest="command", required=True)
    studies.register_cli(sub)
    args = parser.parse_args(["study", str(tiny), "--workers", "2", "--backend", "ray",
                              "--resume", "--retry-failed", "--seeds", "3", "--no-plots"])
    assert args.func is studies.cli
    assert (args.workers, args.backend, args.resume, args.retry_failed, args.seeds,
            args.no_plots, args.overwrite) == (2, "ray", True, True, 3, True, False)

    from marl_social.cli import main as marl_social_main

    assert marl_social_main(["study", "--list"]) == 0
    listing = capsys.readouterr().out
    assert "invalid" not in listing
    assert all(name in listing for name in ("rationality", "blind-human", "sensor-noise",
                                            "humans", "epsilon"))
    assert studies.main([str(tiny), "--out", str(reference.parent), "--analyze-only",
                         "--no-plots"]) == 0
    assert (reference.parent / "summary.md").exists()
    assert (reference.parent / "summary.csv").exists()


def test_a_built_in_spec_is_recorded_without_this_machines_path():
    from marl_social.studies.runs import load_spec

    source = load_spec("rationality", validate=False).source
    assert source == "marl_social/studies/specs/rationality.toml"


def test_a_study_without_pedestrian_variants_has_no_pedestrian_column(tmp_path):
    """The committed T-intersection study (docs/studies/yield-expectation) analysed again:
    its tables' rows are the swept points alone, no empty pedestrian column."""
    import shutil

    from marl_social.studies.analysis import analyze

    source = Path(__file__).resolve().parents[2] / "docs" / "studies" / "yield-expectation"
    for name in ("results.csv", "study.json"):
        shutil.copy(source / name, tmp_path / name)
    analyze(tmp_path, plots=False)
    summary = (tmp_path / "summary.md").read_text()
    assert "| hidden_vehicle | human_expects_yield | social | aggressive |" in summary
    assert "pedestrian |" not in summary
