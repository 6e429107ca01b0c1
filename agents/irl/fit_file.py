"""The `marl-social irl fit` result file (theta.json): reading and checking it.

`load_fit(path)` reads one; `check_fit(data, source)` raises a one-line ValueError naming the
file and the field unless the parsed JSON is a usable result.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from marl_social.data.file_limits import MB, check_file_size
from marl_social.sim.costs import FEATURE_NAMES


def check_fit(data, source) -> None:
    """Raise a ValueError naming `source` and the field unless `data` is a usable fit result.

    Needed: format "marl-social-irl/1"; "fitted", a non-empty list of distinct feature names;
    "direction", one entry per feature of FEATURE_NAMES, finite numbers at the fitted ones;
    "scale", a real number.

    Args:
        data: the parsed JSON.
        source: the file (or a description) for the messages.
    """
    if not isinstance(data, dict):  # a bad file is a ValueError, like every other file error
        raise ValueError(f"{source}: not a marl-social IRL result (a JSON object), got a "  # noqa: TRY004
                         f"JSON {type(data).__name__}")
    if data.get("format") != "marl-social-irl/1":
        raise ValueError(f"{source}: not a marl-social IRL result (format marl-social-irl/1)")
    missing = [k for k in ("fitted", "direction", "scale") if k not in data]
    if missing:
        raise ValueError(f"{source}: missing field(s) {missing}")
    fitted, direction, scale = data["fitted"], data["direction"], data["scale"]
    if (not isinstance(fitted, list) or not fitted or len(set(map(str, fitted))) != len(fitted)
            or any(f not in FEATURE_NAMES for f in fitted)):
        raise ValueError(f"{source}: field 'fitted' must be a non-empty list of distinct names "
                         f"from {list(FEATURE_NAMES)}, got {str(fitted)[:80]}")
    if not isinstance(direction, list) or len(direction) != len(FEATURE_NAMES):
        raise ValueError(f"{source}: field 'direction' must be a list of {len(FEATURE_NAMES)} "
                         f"numbers (one per feature), got {str(direction)[:80]}")
    for name in fitted:
        value = direction[FEATURE_NAMES.index(name)]
        if not _is_real(value) or not math.isfinite(value):
            raise ValueError(f"{source}: field 'direction' has {value!r} for fitted feature "
                             f"{name!r} (a finite number is needed)")
    if not _is_real(scale):
        raise ValueError(f"{source}: field 'scale' must be a number, got {str(scale)[:80]}")


def _is_real(value) -> bool:
    """True for an int or float (not a bool) within float range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    return isinstance(value, float) or abs(value) <= sys.float_info.max


MAX_FIT_BYTES = MB  # largest theta.json read [bytes]


def load_fit(path) -> dict:
    """Read a theta.json written by `marl-social irl fit`; a one-line ValueError otherwise.

    Args:
        path: the file; missing, a directory, not UTF-8, not JSON or a bad field: an error
            naming it.
    """
    path = Path(path)
    check_file_size(path, MAX_FIT_BYTES, "a theta.json file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FileNotFoundError(f"learned model file {path} does not exist") from None
    except IsADirectoryError:
        raise ValueError(f"{path}: is a directory, not a theta.json file") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file (a theta.json is expected)") from None
    except OSError as err:
        raise ValueError(f"{path}: cannot read ({err.strerror or err})") from None
    except json.JSONDecodeError as err:
        raise ValueError(f"{path}: not a JSON file ({err})") from None
    except RecursionError:
        raise ValueError(f"{path}: JSON nested too deeply") from None
    check_fit(data, path)
    return data
