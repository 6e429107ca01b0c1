"""The size guard every file the project reads passes first: a one-line error, not a swap storm."""

from __future__ import annotations

from pathlib import Path

GB = 10**9
MB = 10**6


def check_file_size(path, limit_bytes: int, what: str) -> None:
    """A ValueError naming `path` if the file is larger than `limit_bytes` (`what` it is).

    Files that do not exist (or are not regular files) pass: their readers say so.
    """
    path = Path(path)
    if not path.is_file():
        return
    size = path.stat().st_size
    if size > limit_bytes:
        raise ValueError(f"{path}: {_size(size)}, more than the limit of {_size(limit_bytes)} "
                         f"for {what}")


def _size(n_bytes: int) -> str:
    """Bytes as a short text: '1.2 GB', '350 MB', '12 kB'."""
    if n_bytes >= GB:
        return f"{n_bytes / GB:.3g} GB"
    if n_bytes >= MB:
        return f"{n_bytes / MB:.3g} MB"
    return f"{n_bytes / 1e3:.3g} kB"
