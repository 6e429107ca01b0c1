"""Bad study specs and result folders: one-line errors naming the file and key, exit 2."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from marl_social.cli import main
from marl_social.studies import runner as studies

BASE = 'seeds = 2\nplanners = ["cruise"]\npedestrians = ["crossing"]\nmax_cycles = 5\n'


def _spec(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(BASE + text)
    return path


@pytest.mark.parametrize(("text", "where", "what"), [
    ("[grid]\nhuman_beta = [1979-05-27]", "[grid] human_beta", "date"),
    ("[grid]\npedestrian_speed_mps = [07:32:00]", "[grid] pedestrian_speed_mps", "time"),
    ("[fixed]\nhuman_beta = 1979-05-27T07:32:00Z", "[fixed] human_beta", "datetime"),
    ("[random]\nhuman_beta = {choices = [1979-05-27], n = 1}", "[random] human_beta", "date"),
    ("[random]\nn_humans = {low = 0, high = 1e18, n = 1}", "[random] n_humans", ""),
    ("[random]\nn_humans = {low = 0, high = 1e300, n = 1}", "[random] n_humans", "spans"),
    ("[random]\nhuman_beta = {low = 0, high = 1, n = 1000000000}", "[random] human_beta", "n"),
])
def test_spec_values_name_the_key(tmp_path, text, where, what):
    path = _spec(tmp_path, text)
    start = time.perf_counter()
    with pytest.raises(ValueError) as info:
        studies.load_spec(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and where in message and what in message, message
    assert time.perf_counter() - start < 5.0


def test_huge_seed_count_is_rejected_fast(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('seeds = 1000000000\nplanners = ["cruise"]\n')
    start = time.perf_counter()
    with pytest.raises(ValueError, match="seeds.*<= 100000"):
        studies.load_spec(path)
    assert time.perf_counter() - start < 1.0


@pytest.mark.slow
def test_too_many_runs_is_rejected(tmp_path):
    path = _spec(tmp_path, "[random]\nhuman_beta = {low = 0, high = 10, n = 10000}\n"
                 "robot_beta_hat = {low = 0, high = 10, n = 10000}\n")
    with pytest.raises(ValueError, match="runs.*at most"):
        studies.load_spec(path)


def _study_dir(tmp_path: Path, meta, results: bytes | None) -> Path:
    out = tmp_path / "out"
    out.mkdir()
    (out / "study.json").write_text(meta if isinstance(meta, str) else json.dumps(meta))
    if results is not None:
        (out / "results.csv").write_bytes(results)
    return out


META = {"name": "bad", "scenario": "occluded_crosswalk", "source": "bad.toml", "max_cycles": 5,
        "randomize": False, "params": ["human_beta"], "metrics": ["robot_collision"],
        "columns": ["key", "planner", "pedestrian", "human_beta", "seed", "robot_collision",
                    "error", "elapsed_s"]}


@pytest.mark.parametrize(("meta", "results", "message"), [
    (META, b"", "results.csv: empty file"),
    (META, b"key,planner\n", "results.csv: missing column"),
    (META, b"planner,pedestrian\n", "results.csv: missing column 'key'"),
    (META, b"\xff\xfe\x00\n", "results.csv: not a UTF-8"),
    ({"params": []}, b"", "study.json: missing field"),
    (META, None, "results.csv not found"),
    ([1, 2], b"", "study.json: expected a JSON object.*list"),
    ("{", b"", "study.json: not a JSON file"),
    ({**META, "params": "x"}, b"", "study.json: field 'params'"),
])
def test_analyze_only_on_bad_folders(tmp_path, capsys, meta, results, message):
    out = _study_dir(tmp_path, meta, results)
    assert main(["study", str(_spec(tmp_path, "")), "--analyze-only", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert __import__("re").search(message, err), err


def test_analyze_only_on_header_only_results(tmp_path, capsys):
    header = ",".join(META["columns"]) + "\n"
    out = _study_dir(tmp_path, META, header.encode())
    assert main(["study", str(_spec(tmp_path, "")), "--analyze-only", "--out", str(out),
                 "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert "results.csv: no result rows" in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize(("text", "where", "what"), [
    ("", "spec", "empty"),
    ("max_cycles = 10000000000", "max_cycles", "[1, 1000000000]"),
    ("[grid]\nhuman_beta = [" + ", ".join(["1.0"] * 200_000) + "]", "[grid] human_beta",
     "at most 10000 values"),
])
def test_absurd_or_empty_specs_are_refused_up_front(tmp_path, text, where, what):
    path = tmp_path / "spec.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as info:
        studies.load_spec(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {where}: ") and what in message, message


def test_a_study_whose_runs_failed_exits_1_with_a_summary(tmp_path, monkeypatch, capsys):
    import marl_social.evaluation.run

    def failing(*args, **kwargs):
        raise RuntimeError("planner diverged")

    monkeypatch.setattr(marl_social.evaluation.run, "run_episode", failing)
    path = _spec(tmp_path, "")
    code = studies.main([str(path), "--out", str(tmp_path / "out"), "--no-progress",
                         "--no-plots", "--workers", "1"])
    err = capsys.readouterr().err
    assert code == 1
    assert "error: 2 of the 2 runs run now failed" in err and "Traceback" not in err
