"""Bad input files for `irl fit`: one-line errors naming the file (and field), exit 2."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.cli import main
from marl_social.data.decisions import is_decision_file, load_decisions
from marl_social.data.demonstrations import load_demonstrations

HEADER = "track_id,frame_id,timestamp_ms,agent_type,x,y,vx,vy,psi_rad,length,width\n"


@pytest.fixture(scope="module")
def demos_npz(tmp_path_factory):
    path = tmp_path_factory.mktemp("demos") / "demos.npz"
    assert main(["record", "--synthetic", "--segments", "3", "-o", str(path)]) == 0
    return path


def _fit(capsys, *argv) -> str:
    """Run `irl fit`; assert exit 2 and a one-line error without a traceback; return it."""
    assert main(["irl", "fit", *map(str, argv)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert len(err) < 400, err
    return err


@pytest.mark.parametrize("name", ["empty.npz", "empty.csv", "empty.bin", "empty"])
def test_empty_file(tmp_path, capsys, name):
    path = tmp_path / name
    path.write_bytes(b"")
    assert not is_decision_file(path)
    err = _fit(capsys, path, "-o", tmp_path / "theta.json")
    assert name in err


def test_truncated_and_corrupted_npz(tmp_path, capsys, demos_npz):
    data = demos_npz.read_bytes()
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(data[:len(data) // 2])
    assert "truncated.npz: not a demonstrations .npz file (unreadable" in _fit(capsys, truncated)
    corrupted = tmp_path / "corrupted.npz"
    flipped = bytearray(data)
    for i in range(200, 400):
        flipped[i] ^= 0xFF
    corrupted.write_bytes(bytes(flipped))
    assert "corrupted.npz: not a demonstrations .npz file (unreadable" in _fit(capsys, corrupted)


@pytest.mark.parametrize("field", ["path_offsets", "controls_mps2", "format"])
def test_npz_missing_a_key(tmp_path, capsys, demos_npz, field):
    with np.load(demos_npz) as z:
        arrays = {k: z[k] for k in z.files if k != field}
    path = tmp_path / "missing.npz"
    np.savez(path, **arrays)
    err = _fit(capsys, path, "-o", tmp_path / "theta.json")
    assert "missing.npz" in err and (field in err or "format" in err), err
    with pytest.raises(ValueError, match="missing.npz"):
        load_demonstrations(path)


def test_npz_with_inconsistent_arrays(tmp_path, capsys, demos_npz):
    with np.load(demos_npz) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["path_offsets"] = arrays["path_offsets"][:-1]
    path = tmp_path / "inconsistent.npz"
    np.savez(path, **arrays)
    assert "path_offsets" in _fit(capsys, path)


def test_decision_file_missing_a_key(tmp_path):
    np.savez(tmp_path / "d.npz", format=np.array("marl-social-decisions/1"))
    assert is_decision_file(tmp_path / "d.npz")
    with pytest.raises(ValueError, match=r"d.npz: missing field\(s\) \['features'"):
        load_decisions(tmp_path / "d.npz")


def test_single_npy_array_and_json_list(tmp_path, capsys):
    npy = tmp_path / "array.npz"
    with open(npy, "wb") as f:
        np.save(f, np.zeros(3))
    assert "single .npy" in _fit(capsys, npy)
    listing = tmp_path / "list.json"
    listing.write_text("[1, 2]")
    assert "list.json: not a demonstrations .npz file (unreadable" in _fit(capsys, listing)


@pytest.mark.parametrize("x", ["1e300", "-1e300", "1e200"])
def test_csv_with_huge_coordinates(tmp_path, capsys, x):
    rows = [f"1,{f},{f * 100},car,{x if f == 5 else f},0,10,0,0,4.5,1.9" for f in range(1, 40)]
    path = tmp_path / "vehicle_tracks_000.csv"
    path.write_text(HEADER + "\n".join(rows) + "\n")
    err = _fit(capsys, path)
    assert "vehicle_tracks_000.csv line 6" in err and "'x'" in err, err


def test_csv_with_a_jump(tmp_path, capsys):
    rows = [f"1,{f},{f * 100},car,{f + (9e7 if f > 20 else 0)},0,10,0,0,4.5,1.9"
            for f in range(1, 40)]
    path = tmp_path / "vehicle_tracks_000.csv"
    path.write_text(HEADER + "\n".join(rows) + "\n")
    assert "jump" in _fit(capsys, path)


def test_csv_not_utf8(tmp_path, capsys):
    path = tmp_path / "vehicle_tracks_000.csv"
    path.write_bytes(HEADER.encode() + b"\xff\xfe\x81\n")
    assert "not a UTF-8" in _fit(capsys, path)


def test_output_or_input_a_directory(tmp_path, capsys, demos_npz):
    assert "-o/--out" in _fit(capsys, demos_npz, "-o", tmp_path)
    assert "is a directory" in _fit(capsys, tmp_path)
    assert main(["record", "--synthetic", "--segments", "1", "-o", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err


def test_a_fit_that_does_not_converge_exits_1_with_a_summary(tmp_path, capsys, demos_npz,
                                                             monkeypatch):
    import functools

    from marl_social.agents.irl import laplace

    monkeypatch.setattr(laplace, "fit_theta", functools.partial(laplace.fit_theta, max_iter=1))
    out = tmp_path / "theta.json"
    assert main(["irl", "fit", str(demos_npz), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: the fit did not converge") and len(err.splitlines()) == 1
    assert '"converged": false' in out.read_text()
