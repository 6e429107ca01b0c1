"""Every file the project reads goes through a guard: sizes, dtypes and plausible values;
whatever the bytes, the answer is the data or a one-line ValueError naming the file."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from marl_social.cli import main
from marl_social.data import archive
from marl_social.data.demonstrations import ARCHIVE_FIELDS, Demonstration, load_demonstrations
from marl_social.data.interaction import tracks
from marl_social.data.interaction.tracks import read_interaction_csv

FIXTURES = [HealthCheck.function_scoped_fixture]  # tmp_path is reused: each example overwrites


@pytest.fixture(scope="module")
def demos_npz(tmp_path_factory):
    path = tmp_path_factory.mktemp("demos") / "demos.npz"
    assert main(["record", "--synthetic", "--segments", "3", "-o", str(path)]) == 0
    return path


def _arrays(path) -> dict:
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


@settings(max_examples=40, deadline=None, suppress_health_check=FIXTURES)
@given(field=st.sampled_from(sorted(ARCHIVE_FIELDS)),
       replacement=st.sampled_from(["text", "bool", "object-free complex", "datetime"]))
def test_a_field_of_the_wrong_dtype_names_the_field(tmp_path, demos_npz, field, replacement):
    arrays = _arrays(demos_npz)
    shape = arrays[field].shape
    arrays[field] = {"text": np.full(shape, "x"), "bool": np.ones(shape, bool),
                     "object-free complex": np.ones(shape, complex),
                     "datetime": np.zeros(shape, "datetime64[s]")}[replacement]
    if arrays[field].dtype.kind in ARCHIVE_FIELDS[field]:
        return  # the same kind the field holds anyway (a flag field given booleans)
    path = tmp_path / "wrong.npz"
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match=rf"wrong\.npz: field '{field}' holds .* expected"):
        load_demonstrations(path)


def test_an_archive_that_unpacks_beyond_the_limit_is_refused_before_it_is_read(
        tmp_path, demos_npz, monkeypatch):
    arrays = _arrays(demos_npz)
    arrays["others_xy"] = np.zeros((3, 400, 30, 2))  # 576 kB of zeros, a few kB compressed
    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, **arrays)
    monkeypatch.setattr(archive, "MAX_ARCHIVE_BYTES", 500_000)
    loads = []
    monkeypatch.setattr(np, "load", lambda *a, **k: loads.append(a))
    with pytest.raises(ValueError, match=r"bomb\.npz: unpacks to .* GB, more than the limit"):
        load_demonstrations(path)
    assert loads == []  # refused from the zip's directory alone


@settings(max_examples=60, deadline=None, suppress_health_check=FIXTURES)
@given(st.binary(max_size=2000))
def test_any_bytes_are_an_archive_or_a_one_line_error(tmp_path, data):
    path = tmp_path / "any.npz"
    path.write_bytes(data)
    with pytest.raises(ValueError, match=r"any\.npz: ") as err:
        load_demonstrations(path)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("change", "what"), [
    ({"controls_mps2": np.full(5, 2.0**62)}, "controls_mps2 must lie within"),
    ({"dt_s": True}, "dt_s must be a number"),
    ({"width_m": np.inf}, "width_m must be a number"),
    ({"others_width_m": [np.inf]}, "others_width_m must lie in"),
])
def test_implausible_demonstrations_are_refused(change, what):
    fields = {"controls_mps2": np.zeros(5), "dt_s": 0.1, "s0_m": 0.0, "v0_mps": 5.0,
              "prev_accel_mps2": 0.0, "v_ref_mps": 10.0,
              "path_xy": [[0.0, 0.0], [100.0, 0.0]], "length_m": 4.5, "width_m": 1.8,
              "others_xy": np.zeros((1, 5, 2)), "others_heading": np.zeros((1, 5)),
              "others_length_m": [4.5], "others_width_m": [1.8], "others_is_pedestrian": [False]}
    Demonstration(**fields)  # the unchanged one is fine
    with pytest.raises(ValueError, match=what):
        Demonstration(**{**fields, **change})


def test_a_track_file_beyond_the_limit_is_refused_by_its_size(tmp_path, monkeypatch):
    path = tmp_path / "vehicle_tracks_000.csv"
    path.write_text("track_id,frame_id,timestamp_ms,agent_type,x,y,vx,vy,psi_rad,length,width\n"
                    + "1,1,100,car,0,0,1,0,0,4,2\n" * 100)
    monkeypatch.setattr(tracks, "MAX_CSV_BYTES", 1000)
    with pytest.raises(ValueError, match=r"000\.csv: .* kB, more than the limit of 1 kB"):
        read_interaction_csv(path)


@pytest.mark.parametrize(("module", "limit", "reader"), [
    ("marl_social.studies.results", "MAX_RESULTS_BYTES", "read_results"),
    ("marl_social.studies.results", "MAX_META_BYTES", "read_meta"),
    ("marl_social.studies.runs", "MAX_SPEC_BYTES", "load_spec"),
    ("marl_social.agents.irl.fit_file", "MAX_FIT_BYTES", "load_fit"),
])
def test_every_reader_refuses_a_file_beyond_its_limit_by_its_size(tmp_path, monkeypatch,
                                                                  module, limit, reader):
    import importlib

    mod = importlib.import_module(module)
    path = tmp_path / "big.toml"
    path.write_text("x" * 5000)
    monkeypatch.setattr(mod, limit, 1000)
    with pytest.raises(ValueError, match=r"big\.toml: 5 kB, more than the limit of 1 kB"):
        getattr(mod, reader)(path)
