"""A study's results as a typed table: results.parquet and `load` (a pandas DataFrame).

results.csv (`marl_social/studies/results.py`) is text, written row by row while the study runs.
When a study completes (and on `--analyze-only`) the same rows are written to
`<out>/results.parquet` with typed columns, for analysts (pandas, polars, DuckDB, Arrow):

* key, planner, pedestrian (the pedestrian variant; "" for scenarios without pedestrians): text.
* seed: int64.
* each parameter ([fixed], [grid], [random]): bool, int64 or float64 if every value of the
  column is one (true/false, integers, numbers), else text (e.g. a sequence "[1.0 2.0]").
* each metric: bool for true/false metrics (e.g. robot_collision), else float64 (int64 if every
  value is an integer). NaN is the metric's own "no value" (time_to_pass_s NaN: the robot did not
  pass); null marks a failed run, which has no metric value at all.
* error: the failed run's error text ("TypeName: message"), null for a run that finished.
* elapsed_s: the run's wall time [s] (the one column that is not deterministic).

The file's schema metadata holds study.json under the key b"marl_social.study".

`load(folder)` reads results.parquet (or, if it is missing or older than results.csv, e.g. an
interrupted study, the same table built from results.csv) as a pandas DataFrame: bool metrics
with failed runs use pandas' nullable "boolean" dtype, integer ones "Int64".
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from marl_social.data import strict_json
from marl_social.studies.results import (
    META_FILE,
    PARQUET_FILE,
    RESULTS_FILE,
    read_meta,
    read_results,
)

META_KEY = b"marl_social.study"
_BOOL_TEXT = {"true": True, "false": False}
TEXT_COLUMNS = ("key", "planner", "pedestrian")


def _is_int_text(text: str) -> bool:
    return text.lstrip("+-").isdigit()


def _is_float_text(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def column_type(texts: list[str], missing: list[bool] | None = None) -> str:
    """The type of a results.csv column from its texts: "bool", "int", "float" or "text".

    Args:
        texts: the column's cells, (N,).
        missing: (N,) True where the cell holds no value (a failed run's metric); those cells
            do not decide the type. A column without any value is "float".
    """
    present = [t for t, m in zip(texts, missing or [False] * len(texts)) if not m]
    if not present:
        return "float"
    if all(t in _BOOL_TEXT for t in present):
        return "bool"
    if all(_is_int_text(t) for t in present):
        return "int"
    if all(_is_float_text(t) for t in present):
        return "float"
    return "text"


def _array(texts: list[str], missing: list[bool], kind: str):
    """One typed pyarrow array of a column; missing cells are null."""
    import pyarrow as pa

    convert = {"bool": _BOOL_TEXT.__getitem__, "int": int, "float": float, "text": str}[kind]
    arrow_type = {"bool": pa.bool_(), "int": pa.int64(), "float": pa.float64(),
                  "text": pa.string()}[kind]
    values = [None if m else convert(t) for t, m in zip(texts, missing)]
    return pa.array(values, type=arrow_type)


def arrow_table(out_dir: str | os.PathLike):
    """The typed results of the study in out_dir as a pyarrow Table (see the module docstring).

    Raises:
        FileNotFoundError: no study.json or results.csv in out_dir.
        ValueError: a broken results.csv or study.json (naming the file).
    """
    import pyarrow as pa

    out_dir = Path(out_dir)
    meta = read_meta(out_dir / META_FILE)
    path = out_dir / RESULTS_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: the study has no results (run it first)")
    header, rows = read_results(path)
    missing_columns = [c for c in meta["columns"] if c not in header]
    if missing_columns:
        raise ValueError(f"{path}: missing column(s) {missing_columns} named by {META_FILE}")
    failed = [bool(r["error"]) for r in rows]
    none = [False] * len(rows)
    arrays, names = [], []
    for column in header:
        texts = [r[column] for r in rows]
        if column in TEXT_COLUMNS:
            kind, missing = "text", none
        elif column == "seed":
            kind, missing = "int", none
        elif column == "error":
            kind, missing = "text", [not t for t in texts]
        elif column == "elapsed_s":
            kind, missing = "float", none
        elif column in meta["metrics"]:
            missing = [f or not t for f, t in zip(failed, texts)]
            kind = column_type(texts, missing)
        else:  # a parameter
            kind, missing = column_type(texts), none
        try:
            arrays.append(_array(texts, missing, kind))
        except ValueError as err:
            raise ValueError(f"{path}: column {column!r}: {err}") from None
        names.append(column)
    schema_meta = {META_KEY: strict_json.dumps(meta, default=str).encode()}
    return pa.Table.from_arrays(arrays, names=names).replace_schema_metadata(schema_meta)


def write_parquet(out_dir: str | os.PathLike) -> Path:
    """Write <out_dir>/results.parquet from results.csv and study.json; returns its path.

    Written to a temporary file and renamed, so a reader never sees half a file.
    """
    import pyarrow.parquet as pq

    out_dir = Path(out_dir)
    table = arrow_table(out_dir)
    path = out_dir / PARQUET_FILE
    tmp = path.with_name(path.name + ".tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)
    return path


def _parquet_is_current(out_dir: Path) -> bool:
    parquet, csv_path = out_dir / PARQUET_FILE, out_dir / RESULTS_FILE
    if not parquet.is_file():
        return False
    return not csv_path.is_file() or parquet.stat().st_mtime_ns >= csv_path.stat().st_mtime_ns


def load(folder: str | os.PathLike):
    """A study's results as a pandas DataFrame, one row per run, typed columns.

    Columns: key, seed, planner, pedestrian (the pedestrian variant), every swept or fixed
    parameter, every metric, error (None for a run that finished) and elapsed_s [s]; see the
    module docstring for the types and the meaning of NaN and missing values. The study's
    resolved spec (study.json) is in `df.attrs["study"]`.

    Args:
        folder: a study's output folder (holding study.json and results.csv / results.parquet).

    Returns:
        pandas.DataFrame with one row per run, in the table's order.

    Raises:
        FileNotFoundError: folder holds no study.
        ValueError: its files are broken (naming the file).

    Example:
        >>> df = load("docs/studies/epsilon")                          # doctest: +SKIP
        >>> ok = df[df.error.isna()]
        >>> ok.groupby(["planner", "pedestrian", "robot_epsilon"]).time_to_pass_s.agg(
        ...     passed="count", runs="size", mean_s="mean")            # count skips NaN
    """
    import pyarrow.parquet as pq

    out_dir = Path(folder)
    if not out_dir.is_dir():
        raise FileNotFoundError(f"{out_dir}: no such study folder")
    if _parquet_is_current(out_dir):
        try:
            table = pq.read_table(out_dir / PARQUET_FILE)
        except Exception as err:  # noqa: BLE001  (pyarrow raises several kinds)
            raise ValueError(f"{out_dir / PARQUET_FILE}: not a readable Parquet file "
                             f"({str(err)[:120]})") from None
    else:
        table = arrow_table(out_dir)
    df = _nullable(table.to_pandas(), table)
    raw = (table.schema.metadata or {}).get(META_KEY)
    df.attrs["study"] = json.loads(raw) if raw else {}
    return df


def _nullable(df, table):
    """Bool and int columns with nulls as pandas' nullable "boolean" / "Int64" dtypes."""
    import pyarrow as pa

    for name in table.column_names:
        column = table.column(name)
        if column.null_count == 0:
            continue
        if pa.types.is_boolean(column.type):
            df[name] = df[name].astype("boolean")
        elif pa.types.is_integer(column.type):
            df[name] = df[name].astype("Int64")
    return df

