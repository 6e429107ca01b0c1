"""Property-based: random or damaged bytes as input files give a ValueError naming the file (or
a valid result); never another exception, never a hang."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from marl_social.agents.irl.laplace import load_fit
from marl_social.data.decisions import is_decision_file, load_decisions
from marl_social.data.demonstrations import load_demonstrations, save_demonstrations
from marl_social.data.interaction import read_interaction_csv
from marl_social.studies.results import read_meta, read_results
from marl_social.studies.runs import load_spec
from tests.fuzzing import fuzz

CSV_HEADER = b"track_id,frame_id,timestamp_ms,agent_type,x,y,vx,vy,psi_rad,length,width\n"
CSV_ROW = st.lists(st.one_of(st.sampled_from([b"1", b"car", b"0", b"1e300", b"-5", b"nan",
                                              b"", b"pedestrian", b"100", b"2"]),
                             st.binary(max_size=4)), min_size=1, max_size=12)


@pytest.fixture(scope="module")
def valid_npz(tmp_path_factory) -> bytes:
    from marl_social.agents.irl.synthetic import near_rational_demonstrations

    demos = near_rational_demonstrations(np.array([0.0, 1.0, 0.1, 0.1, 1.0, 1000.0]) * 10, 2,
                                         seed=0, n_steps=10)
    path = save_demonstrations(tmp_path_factory.mktemp("npz") / "demos.npz", demos)
    return path.read_bytes()


def _write(data: bytes, name: str) -> Path:
    folder = Path(tempfile.mkdtemp(prefix="fuzz_"))
    path = folder / name
    path.write_bytes(data)
    return path


def _rejects_or_reads(read, path: Path) -> None:
    try:
        read(path)
    except ValueError as err:
        text = str(err)
        assert path.name in text, text
        assert "\n" not in text and len(text) < 600, text


@fuzz(150)
@given(data=st.binary(max_size=300))
def test_random_bytes(data):
    for name, read in (("demos.npz", load_demonstrations), ("decisions.npz", load_decisions),
                       ("theta.json", load_fit), ("study.json", read_meta),
                       ("results.csv", read_results), ("vehicle_tracks_000.csv",
                                                       read_interaction_csv),
                       ("spec.toml", load_spec)):
        _rejects_or_reads(read, _write(data, name))
    assert is_decision_file(_write(data, "x.npz")) in (True, False)


@fuzz(100)
@given(offset=st.integers(0, 10**6), length=st.integers(1, 64), value=st.integers(0, 255),
       cut=st.one_of(st.none(), st.integers(0, 10**6)))
def test_damaged_demonstrations_archive(valid_npz, offset, length, value, cut):
    data = bytearray(valid_npz)
    start = offset % len(data)
    data[start:start + length] = bytes([value]) * len(data[start:start + length])
    if cut is not None:
        data = data[:cut % len(data)]
    _rejects_or_reads(load_demonstrations, _write(bytes(data), "demos.npz"))


@fuzz(100)
@given(rows=st.lists(CSV_ROW, max_size=8))
def test_random_interaction_csv_rows(rows):
    data = CSV_HEADER + b"".join(b",".join(r) + b"\n" for r in rows)
    _rejects_or_reads(read_interaction_csv, _write(data, "vehicle_tracks_000.csv"))
