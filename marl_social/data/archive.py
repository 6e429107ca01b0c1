"""Reading the project's .npz archives: every failure a one-line ValueError naming the file.

Limits: MAX_FILE_BYTES on disk, MAX_ARCHIVE_BYTES unpacked, each field of its dtype kind.

An empty, truncated or corrupted archive (EOFError, zipfile.BadZipFile, zlib.error, ...), a
directory, an archive of another kind or one missing a field all become
`ValueError("<path>: ...")`; a missing file stays a FileNotFoundError.
"""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path

import numpy as np

from marl_social.data.file_limits import GB, check_file_size

# what np.load raises on a damaged or foreign file
READ_ERRORS = (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error,
               UnicodeDecodeError, MemoryError, OverflowError)
MAX_REASON_CHARS = 120  # some errors quote whole binary headers
MAX_FILE_BYTES = GB  # largest archive read [bytes on disk]
MAX_ARCHIVE_BYTES = GB  # largest total of an archive's arrays once unpacked [bytes]
NUMBERS, FLAGS, TEXT = "iuf", "b", "U"  # the dtype kinds a field may hold
_KIND_NAMES = {NUMBERS: "numbers", FLAGS: "booleans", TEXT: "text", "iu": "integers"}


def short_reason(err: BaseException) -> str:
    """The error's type and message, cut to MAX_REASON_CHARS characters."""
    text = f"{type(err).__name__}: {err}"
    return text if len(text) <= MAX_REASON_CHARS else text[:MAX_REASON_CHARS] + "..."


def read_npz(path, kind: str, file_format: str, fields: dict[str, str]) -> dict[str, np.ndarray]:
    """Every array of an .npz archive of `file_format`, after checking its fields and sizes.

    The guard every archive the project reads goes through: at most MAX_FILE_BYTES on disk and
    MAX_ARCHIVE_BYTES unpacked (checked from the zip's directory before anything is unpacked),
    the `fields` present, each of one of its allowed dtype kinds.

    Args:
        path: the archive.
        kind: what it should be, for messages ("demonstrations", "decision").
        file_format: the value its "format" array must hold.
        fields: {name: allowed numpy dtype kinds} of the arrays it must have (besides
            "format"): NUMBERS, FLAGS or TEXT.

    Returns:
        {name: array} of every array in the archive (loaded, the file closed).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{kind} file {path} does not exist")
    if path.is_dir():
        raise ValueError(f"{path}: is a directory, not a {kind} .npz file")
    _check_sizes(path, kind)
    try:
        data = np.load(path, allow_pickle=False)
        if isinstance(data, np.lib.npyio.NpzFile):
            with data:
                arrays = {name: data[name] for name in data.files}
    except READ_ERRORS as err:
        raise ValueError(f"{path}: not a {kind} .npz file (unreadable: "
                         f"{short_reason(err)})") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise ValueError(f"{path}: a single .npy array, not a {kind} .npz archive")  # noqa: TRY004
    if "format" not in arrays or str(arrays["format"]) != file_format:
        raise ValueError(f"{path}: not a {kind} file (format {file_format})")
    missing = [f for f in fields if f not in arrays]
    if missing:
        raise ValueError(f"{path}: missing field(s) {missing}")
    for name, kinds in fields.items():
        if arrays[name].dtype.kind not in kinds:
            raise ValueError(f"{path}: field {name!r} holds {arrays[name].dtype} values, "
                             f"expected {_KIND_NAMES[kinds]}")
    return arrays


def _check_sizes(path: Path, kind: str) -> None:
    """A ValueError if the file, or what it unpacks to, is larger than the limits."""
    check_file_size(path, MAX_FILE_BYTES, f"a {kind} file")
    try:
        with zipfile.ZipFile(path) as archive:
            unpacked = sum(info.file_size for info in archive.infolist())
    except (zipfile.BadZipFile, OSError, EOFError, ValueError):
        return  # not a zip: np.load says what it is
    if unpacked > MAX_ARCHIVE_BYTES:
        raise ValueError(f"{path}: unpacks to {unpacked / 1e9:.2f} GB, more than the limit of "
                         f"{MAX_ARCHIVE_BYTES / 1e9:g} GB")


def is_archive_of(path, file_format: str) -> bool:
    """True for a readable .npz archive whose "format" array holds `file_format`."""
    try:
        data = np.load(path, allow_pickle=False)
        if not isinstance(data, np.lib.npyio.NpzFile):
            return False
        with data:
            return "format" in data.files and str(data["format"]) == file_format
    except READ_ERRORS:
        return False
