"""The results table and output folder of a study.

Reading and writing results.csv, its rows, study.json and the lock on the folder.

Results: `<out>/results.csv` (default out: marl_social_out/studies/<name>/), one row per run,
appended as soon as the run finishes (flushed and fsynced), columns: key, seed, planner,
pedestrian, each [fixed]/[grid]/[random] parameter, each metric, error, elapsed_s. The key is a
canonical string of the scenario, the run's parameters (planner and pedestrian included) and
the seed. Every column except elapsed_s (the run's wall time [s]) is deterministic: the same
spec and seeds give the same rows from any backend and number of workers. Floats are written
with repr precision, bools as true/false; a failed run has empty metric cells. When a study
completes, the table is rewritten in the spec's order (planner, pedestrian, point, seed); runs
execute seed-major, so an interrupted study has every cell covered by its first seeds.
`<out>/study.json` records the resolved spec. A completed study also writes the same rows with
typed columns to `<out>/results.parquet` (`marl_social/studies/table.py`; read it with
`marl_social.studies.load`).

Resume: with `existing="resume"` (`--resume`) every finished row is kept and only the missing keys
run; a truncated last line (the process was killed while writing it) is dropped. A run that
raised is recorded with its error ("TypeName: message") and counts as finished: resume does not
retry it unless `existing="retry_failed"` (`--resume --retry-failed`), which removes its row and runs it again.
No key is ever written twice, and a lock on the folder (.study.lock) keeps a second process
from running a study into it at the same time. Without resume an existing results.csv is an
error (pass --resume or --overwrite); resuming into a folder whose study differs in scenario,
max_cycles, randomize, parameters or metrics is an error too.
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from marl_social.data import strict_json
from marl_social.data.file_limits import GB, MB, check_file_size
from marl_social.studies.runs import axes, format_value
from marl_social.studies.spec import Run, StudySpec

DEFAULT_OUT_ROOT = Path("marl_social_out") / "studies"
RESULTS_FILE = "results.csv"
PARQUET_FILE = "results.parquet"  # the typed table of a completed study (studies/table.py)
META_FILE = "study.json"
META_REQUIRED = ("name", "scenario", "source", "max_cycles", "randomize", "params", "metrics", "columns")
PLOTS_DIR = "plots"
SUMMARY_MD = "summary.md"
SUMMARY_CSV = "summary.csv"
LOCK_FILE = ".study.lock"
HEAD_COLUMNS = ("key", "seed", "planner", "pedestrian")
TAIL_COLUMNS = ("error", "elapsed_s")


def result_columns(spec: StudySpec) -> list[str]:
    """Columns of results.csv."""
    return [*HEAD_COLUMNS, *spec.param_names, *spec.metrics, *TAIL_COLUMNS]


def default_out(name: str) -> Path:
    """Default output folder of a study: marl_social_out/studies/<name>/."""
    return DEFAULT_OUT_ROOT / name


MAX_RESULTS_BYTES = GB  # largest results.csv read (a million runs take ~0.3 GB)
MAX_META_BYTES = 10 * MB  # largest study.json read


def read_results(path: str | os.PathLike, repair: bool = False) -> tuple[list[str], list[dict]]:
    """Read results.csv: (columns, rows as dicts of strings).

    A last line without its newline (the writer was killed mid-row) is ignored; with
    repair=True it is also cut from the file.

    Raises:
        ValueError: a row with the wrong number of fields or a duplicate key.
    """
    path = Path(path)
    check_file_size(path, MAX_RESULTS_BYTES, "a study's results table")
    data = path.read_bytes()
    cut = data.rfind(b"\n") + 1
    if repair and cut < len(data):
        with open(path, "r+b") as f:
            f.truncate(cut)
            f.flush()
            os.fsync(f.fileno())
    try:
        text = data[:cut].decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text (CSV) file") from None
    reader = csv.reader(io.StringIO(text, newline=""))
    header = next(reader, [])
    if not header:
        raise ValueError(f"{path}: empty file, no header line (columns key, ...)")
    if "key" not in header:
        raise ValueError(f"{path}: missing column 'key' (header: {header[:12]})")
    rows, keys = [], set()
    for line, fields in enumerate(reader, start=2):
        if len(fields) != len(header):
            raise ValueError(f"{path}:{line}: {len(fields)} fields, the header has "
                             f"{len(header)}")
        row = dict(zip(header, fields))
        if row["key"] in keys:
            raise ValueError(f"{path}:{line}: duplicate key {row['key']!r}")
        keys.add(row["key"])
        rows.append(row)
    return header, rows


def _write_table(path: Path, columns: list[str], rows: Iterable[dict]) -> None:
    """Replace the table atomically (temporary file, fsync, rename)."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


@contextmanager
def _appender(path: Path, columns: list[str], keys: Iterable[str]) -> Iterator:
    """Yields write(row), which appends a row to results.csv.

    Each row is flushed and fsynced; a key written before is refused. Writes the header into a
    new (or empty) file.
    """
    new = not path.exists() or path.stat().st_size == 0
    written = set(keys)
    with open(path, "a", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns, lineterminator="\n")

        def sync() -> None:
            f.flush()
            os.fsync(f.fileno())

        def write(row: dict) -> None:
            if row["key"] in written:
                raise RuntimeError(f"duplicate key {row['key']!r} (a bug: already written)")
            writer.writerow(row)
            sync()
            written.add(row["key"])

        if new:
            writer.writeheader()
            sync()
        yield write


def _row(spec: StudySpec, run: Run, values: dict | None, error: str | None,
         elapsed_s: float) -> dict:
    row = {"key": run.key, "seed": str(run.seed), "planner": run.overrides["robot_planner"],
           "pedestrian": run.overrides.get("pedestrian", "")}
    row.update({p: format_value(run.overrides[p]) for p in spec.param_names})
    row.update({m: format_value(values[m]) if values else "" for m in spec.metrics})
    row["error"] = error or ""
    row["elapsed_s"] = f"{elapsed_s:.3f}"
    return row


def study_metadata(spec: StudySpec) -> dict:
    """The resolved spec as written to study.json (read by the analysis and by resume)."""
    return {
        "name": spec.name, "source": spec.source, "description": spec.description,
        "scenario": spec.scenario, "max_cycles": spec.max_cycles, "randomize": spec.randomize,
        "sample_seed": spec.sample_seed, "seeds": list(spec.seeds),
        "planners": list(spec.planners),
        "pedestrians": None if spec.pedestrians is None else list(spec.pedestrians),
        "fixed": spec.fixed, "grid": spec.grid, "random": spec.random,
        "axes": {name: list(values) for name, values in axes(spec)},
        "params": spec.param_names, "metrics": list(spec.metrics),
        "columns": result_columns(spec),
    }


def read_meta(path: Path) -> dict:
    """study.json as a dict; a one-line ValueError naming the file and field otherwise."""
    check_file_size(path, MAX_META_BYTES, "a study.json file")
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FileNotFoundError(f"{path} not found: no study in {path.parent} "
                                "(run it first)") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text (JSON) file") from None
    except (json.JSONDecodeError, RecursionError) as err:
        raise ValueError(f"{path}: not a JSON file ({str(err)[:80]})") from None
    except OSError as err:
        raise ValueError(f"{path}: cannot read ({err.strerror or err})") from None
    if not isinstance(meta, dict):
        raise ValueError(f"{path}: expected a JSON object (the resolved study spec), got a "  # noqa: TRY004
                         f"JSON {type(meta).__name__}")
    missing = [k for k in META_REQUIRED if k not in meta]
    if missing:
        raise ValueError(f"{path}: missing field(s) {missing}")
    for key in ("params", "metrics", "columns"):
        value = meta.get(key)
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ValueError(f"{path}: field {key!r} must be a list of names, got "
                             f"{str(value)[:80]}")
    return meta


def _check_meta(out_dir: Path, meta: dict) -> None:
    """Refuse to resume into a folder holding a different study."""
    path = out_dir / META_FILE
    if not path.exists():
        return
    old = read_meta(path)
    for key in ("scenario", "max_cycles", "randomize", "columns"):
        if old.get(key) != meta[key]:
            raise ValueError(f"{path}: this folder holds a study with {key}={old.get(key)!r}, "
                             f"the spec gives {meta[key]!r}; use another --out or --overwrite")


def _clear_outputs(out_dir: Path) -> None:
    """Delete what a study writes into out_dir (--overwrite)."""
    for name in (RESULTS_FILE, PARQUET_FILE, META_FILE, SUMMARY_MD, SUMMARY_CSV):
        (out_dir / name).unlink(missing_ok=True)
    plots = out_dir / PLOTS_DIR
    if plots.is_dir():
        for png in plots.glob("*.png"):
            png.unlink()


def _prepare_table(path: Path, columns: list[str], retry_failed: bool) -> dict[str, dict]:
    """Finished rows of an existing table by key (failed ones removed if retry_failed)."""
    if not path.exists():
        return {}
    header, rows = read_results(path, repair=True)
    if header and header != columns:
        raise ValueError(f"{path}: its columns {header} differ from the spec's {columns}; use "
                         "another --out or --overwrite")
    if retry_failed and any(r["error"] for r in rows):
        rows = [r for r in rows if not r["error"]]
        _write_table(path, columns, rows)
    return {r["key"]: r for r in rows}


def _finalize(path: Path, columns: list[str], runs: list[Run]) -> None:
    """Rewrite the table in the spec's run order.

    Rows of other runs (e.g. more seeds from an earlier resume) follow, sorted by key.
    """
    _, rows = read_results(path)
    order = {r.key: i for i, r in enumerate(runs)}
    rows.sort(key=lambda r: (order.get(r["key"], len(order)), r["key"]))
    _write_table(path, columns, rows)


@contextmanager
def _exclusive(out_dir: Path) -> Iterator[None]:
    """Hold an exclusive lock on out_dir so that two processes never run a study into it.

    The lock is a POSIX flock on .study.lock, released even on SIGKILL.
    """
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    with open(out_dir / LOCK_FILE, "a") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RuntimeError(f"{out_dir}: another process is running a study into this "
                               "folder") from None
        yield


def _has_rows(table: Path) -> bool:
    """True unless the table holds a header only (an unreadable table counts as rows)."""
    try:
        return bool(read_results(table)[1])
    except (ValueError, OSError):
        return True


def _prepare_out(spec: StudySpec, out_dir: Path, existing: str) -> dict[str, dict]:
    """Prepare out_dir for a run of the spec; returns the finished rows by key.

    Checks out_dir against the spec, clears it (overwrite) or reads its finished rows (resume),
    and writes study.json. A table without rows (a study that stopped before its first run
    finished, e.g. it could not reach its Ray cluster) is cleared as if overwrite were set.
    """
    table = out_dir / RESULTS_FILE
    overwrite = existing == "overwrite"
    if table.exists() and existing == "refuse":
        if _has_rows(table):
            raise FileExistsError(f"{table} exists: pass --resume to continue the study or "
                                  "--overwrite to start it again")
        overwrite = True  # nothing to keep
    if overwrite:
        _clear_outputs(out_dir)
    meta = study_metadata(spec)
    _check_meta(out_dir, meta)
    done = _prepare_table(table, meta["columns"], existing == "retry_failed")
    (out_dir / META_FILE).write_text(strict_json.dumps(meta, indent=2, default=str) + "\n")
    return done

