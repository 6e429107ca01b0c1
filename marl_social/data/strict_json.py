"""JSON the project writes: strict (no NaN or Infinity tokens), so any JSON parser reads it.

A non-finite number is written as null; `nulls_as_nan` turns the nulls of an all-numeric
document back into NaN when the project reads its own file.
"""

from __future__ import annotations

import json
import math

import numpy as np


def dumps(value, **kwargs) -> str:
    """json.dumps of `value` with NaN and +-inf as null.

    Numpy scalars and arrays are written as Python numbers and lists; `kwargs` as json.dumps
    takes them (indent, default, ...).
    """
    return json.dumps(_finite(value), allow_nan=False, **kwargs)


def nulls_as_nan(value):
    """`value` (parsed JSON) with every null, at any depth, as float NaN."""
    if value is None:
        return math.nan
    if isinstance(value, dict):
        return {k: nulls_as_nan(v) for k, v in value.items()}
    if isinstance(value, list):
        return [nulls_as_nan(v) for v in value]
    return value


def _finite(value):
    """`value` with non-finite floats as None, numpy scalars and arrays as Python values."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value
