"""results.parquet and marl_social.studies.load: typed columns an analyst can group and count,
failed runs and runs without a value kept apart, and a table that follows results.csv."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

import marl_social.studies
from marl_social.studies import runner as studies

METRICS = ("robot_collision", "time_to_pass_s", "min_gap_pedestrian_m")


def _write_study(folder, rng) -> list[dict]:
    """A synthetic study folder (study.json, results.csv): 2 planners x 3 n_slots x 2 speeds x
    3 seeds, random metric values, one failed run and some runs that did not pass."""
    spec = studies.StudySpec(name="typed", seeds=(0, 1, 2), planners=("social", "oracle"),
                             pedestrians=("crossing",), fixed={"human_blind": True},
                             grid={"n_slots": (4, 6, 9), "human_speed_mps": (10.0, 12.5)},
                             metrics=METRICS)
    truth = []
    for run in studies.expand(spec):
        failed = bool(rng.random() < 0.1) or not truth
        values = None if failed else {
            "robot_collision": bool(rng.random() < 0.3),
            "time_to_pass_s": float(rng.uniform(5, 15)) if rng.random() < 0.7 else math.nan,
            "min_gap_pedestrian_m": float(rng.uniform(0, 10))}
        truth.append({"run": run, "values": values})
    folder.mkdir(exist_ok=True)
    (folder / studies.META_FILE).write_text(json.dumps(studies.study_metadata(spec)))
    with open(folder / studies.RESULTS_FILE, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=studies.result_columns(spec), lineterminator="\n")
        writer.writeheader()
        writer.writerows(studies._row(spec, t["run"], t["values"],
                                      None if t["values"] else "RuntimeError: boom", 0.5)
                         for t in truth)
    return truth


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_load_gives_typed_columns_with_failed_runs_apart(tmp_path, seed):
    import pandas as pd  # here, not at collection: a slow import
    import pyarrow.parquet as pq
    truth = _write_study(tmp_path, np.random.default_rng(seed))
    path = studies.write_parquet(tmp_path)
    assert path == tmp_path / "results.parquet"
    schema = pq.read_schema(path)
    assert {n: str(schema.field(n).type) for n in
            ("seed", "planner", "n_slots", "human_speed_mps", "human_blind", "robot_collision",
             "time_to_pass_s", "error", "elapsed_s")} == {
        "seed": "int64", "planner": "string", "n_slots": "int64", "human_speed_mps": "double",
        "human_blind": "bool", "robot_collision": "bool", "time_to_pass_s": "double",
        "error": "string", "elapsed_s": "double"}

    df = marl_social.studies.load(tmp_path)
    assert df.attrs["study"]["name"] == "typed" and len(df) == len(truth)
    assert list(df.key) == [t["run"].key for t in truth]
    assert str(df.robot_collision.dtype) == "boolean"  # a failed run has no value: <NA>
    assert (df.seed.dtype, df.n_slots.dtype, df.human_blind.dtype) == (
        np.dtype("int64"), np.dtype("int64"), np.dtype("bool"))
    for row, t in zip(df.itertuples(), truth):
        assert (row.planner, row.seed, row.n_slots, row.human_speed_mps) == (
            t["run"].overrides["robot_planner"], t["run"].seed, t["run"].overrides["n_slots"],
            t["run"].overrides["human_speed_mps"])
        if t["values"] is None:
            assert row.error == "RuntimeError: boom"
            assert pd.isna(row.robot_collision)
            assert math.isnan(row.time_to_pass_s)
        else:
            assert pd.isna(row.error)
            assert bool(row.robot_collision) == t["values"]["robot_collision"]
            assert np.array_equal(row.time_to_pass_s, t["values"]["time_to_pass_s"],
                                  equal_nan=True)
    # what an analyst does: among the finished runs, how many passed and their mean time
    finished = df[df.error.isna()]
    counts = finished.groupby("planner").time_to_pass_s.agg(["count", "size"])
    for planner, (passed, runs) in counts.iterrows():
        mine = [t for t in truth if t["values"] and t["run"].overrides["robot_planner"] == planner]
        assert runs == len(mine)
        assert passed == sum(math.isfinite(t["values"]["time_to_pass_s"]) for t in mine)


def test_load_follows_results_csv_when_the_parquet_is_stale(tmp_path):
    truth = _write_study(tmp_path, np.random.default_rng(5))
    studies.write_parquet(tmp_path)
    lines = (tmp_path / studies.RESULTS_FILE).read_text().splitlines(keepends=True)
    (tmp_path / studies.RESULTS_FILE).write_text("".join(lines[:-3]))  # as if resumed/cut
    assert len(marl_social.studies.load(tmp_path)) == len(truth) - 3
    (tmp_path / studies.PARQUET_FILE).unlink()
    assert len(marl_social.studies.load(tmp_path)) == len(truth) - 3


def test_load_errors_name_the_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such study folder"):
        marl_social.studies.load(tmp_path / "nope")
    with pytest.raises(FileNotFoundError, match="study.json"):
        marl_social.studies.load(tmp_path)
    _write_study(tmp_path, np.random.default_rng(1))
    studies.write_parquet(tmp_path)
    (tmp_path / studies.PARQUET_FILE).write_bytes(b"not parquet")
    with pytest.raises(ValueError, match="results.parquet: not a readable Parquet file"):
        marl_social.studies.load(tmp_path)
