"""Output files written by geomfdi: never through a link, never half-written, and safe
to open in a spreadsheet.

Every file a command writes (reports, tables, figures, codes) is first written to a
fresh temporary file in the target directory and then renamed over the target name
(:func:`os.replace`).  The rename replaces a symbolic link planted at the target name by
a regular file: the link's target is never written to, and a reader never sees a
half-written file.

Text cells of a CSV file that a spreadsheet would take for a formula (starting with
``=``, ``+``, ``-``, ``@``, a tab or a carriage return) are written with a leading
apostrophe (:func:`csv_text`), the usual defence against formula injection; numbers
are written as numbers.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["replace_file", "write_text", "csv_text", "csv_texts"]

_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def csv_text(value: Any) -> Any:
    """A text cell safe for spreadsheets: ``"'=..."`` for a cell starting like a formula;
    other values unchanged.

    Examples
    --------
    >>> csv_text("=HYPERLINK(1)"), csv_text("sensor 0"), csv_text(1.5)
    ("'=HYPERLINK(1)", 'sensor 0', 1.5)
    """
    if isinstance(value, str) and value.startswith(_FORMULA_START):
        return "'" + value
    return value


def csv_texts(values: Any) -> list[Any]:
    """:func:`csv_text` of every entry."""
    return [csv_text(v) for v in values]


def replace_file(path: str | Path, write: Callable[[Path], Any]) -> Path:
    """Create ``path`` by ``write(tmp)`` on a new temporary file, then rename it over
    ``path`` (a link at ``path`` is replaced, never followed); returns ``path``.

    The temporary file is removed when ``write`` fails.
    """
    path = Path(path)
    if path.is_dir() and not path.is_symlink():
        raise IsADirectoryError(f"{path}: is a directory")
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name[:40]}.", suffix=".tmp")
    os.close(fd)
    tmp = Path(name)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_UMASK)  # (mkstemp makes it 0o600)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def write_text(path: str | Path, text: str) -> Path:
    """``path.write_text(text)`` through :func:`replace_file` (UTF-8)."""
    return replace_file(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_UMASK = _umask()  # read once, at import
