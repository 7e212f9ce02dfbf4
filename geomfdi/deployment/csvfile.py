"""Recorded data from CSV files: a strict reader for :func:`geomfdi.evaluate`.

The file has a header row naming the columns (time ``t`` or ``time``, outputs
``y0, y1, ...``, inputs ``u0, ...``; other columns are ignored) and one row of numbers
per sample, comma separated, UTF-8 (a byte-order mark is accepted), numbers possibly
quoted.  A cell is a number (decimal, with exponent; ``inf`` allowed) or *missing*:
empty or ``nan``.  Anything else is refused with a :class:`CSVFormatError` naming the
file, the line and the column: text (``abc``, ``true``, ``NA``), hexadecimal or other
non-decimal numbers (``0x1p3``), NUL bytes, rows with more or fewer cells than the
header (a blank line is such a row), duplicated column names, bytes that are not UTF-8.

The file is read in chunks of :data:`CHUNK_ROWS` rows by :func:`pandas.read_csv`; the
field count of every line is checked on the raw bytes beforehand (quote aware), which
also gives the number of rows, so the signals are filled into arrays of their final
size: the memory is ``8 (1 + q + m)`` bytes per row plus one chunk.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi.deployment.recorded import channel_columns
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = ["CSVFormatError", "Record", "read_record", "CHUNK_ROWS"]

CHUNK_ROWS = 65_536
"""Rows parsed at once (the reader's working memory is one chunk of text cells)."""

_BLOCK_BYTES = 1 << 20  # raw bytes scanned at once for the field counts
_MISSING = frozenset({"", "nan"})
_NUMBER_BYTES = b'0123456789.+-eE," \t\r\nInNfFtTyYaA'
"""The bytes of decimal numbers, ``inf``, ``infinity`` and ``nan`` cells: a file of only
these is parsed by pandas' float converter directly (fast); any other byte (text columns,
``true``, ``0x1p3``) and every cell is checked as text."""


class CSVFormatError(GeomFDIError):
    """A CSV file of recorded data is malformed.

    Attributes
    ----------
    path : str
    line : int or None
        1-based line of the file.
    column : str or None
        Name of the column.
    """

    def __init__(
        self, message: str, *, path: str, line: int | None = None, column: str | None = None
    ) -> None:
        where = str(path) + (f", line {line}" if line is not None else "")
        where += f", column {column!r}" if column is not None else ""
        super().__init__(f"{where}: {message}", argument="data")
        self.path = str(path)
        self.line = line
        self.column = column


@dataclass
class Record:
    """Signals read from a CSV file: ``t (N,)``, ``y (q, N)``, ``u (m, N)``; ``missing``:
    the missing (empty or ``nan``) cells of ``y`` and ``u``, ``missing_samples``: the rows
    holding one."""

    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    missing: int
    missing_samples: int


def _header(path: Path) -> list[str]:
    try:
        with path.open("rb") as fh:
            first = fh.readline().decode("utf-8-sig")
        header = next(csv.reader([first]), None)
    except UnicodeDecodeError as exc:
        raise CSVFormatError(f"not UTF-8 text ({exc.reason})", path=str(path), line=1) from exc
    except csv.Error as exc:
        raise CSVFormatError(f"unreadable header ({exc})", path=str(path), line=1) from exc
    if not header:
        raise CSVFormatError("empty file (expected a header row)", path=str(path), line=1)
    names = [h.strip() for h in header]
    if any("\x00" in h for h in names):
        raise CSVFormatError("NUL byte in the header", path=str(path), line=1)
    seen: set[str] = set()
    for j, name in enumerate(names):
        if name in seen:
            raise CSVFormatError(
                f"column name {name!r} appears twice (columns {names.index(name)} and {j})",
                path=str(path),
                line=1,
                column=name,
            )
        seen.add(name)
    return names


def _field_counts(path: Path, width: int) -> tuple[int, bool]:
    """Check that every line has ``width`` fields (commas outside quotes + 1); return the
    number of data rows and whether the data hold only the bytes of decimal numbers,
    ``inf`` and ``nan`` (:data:`_NUMBER_BYTES`).  Vectorised over blocks of raw bytes,
    on the positions of the commas, line ends and quotes only: a comma or line end is
    inside a quoted cell when an odd number of quotes precedes it (a doubled quote inside
    a quoted cell keeps the parity)."""
    line = 0  # lines completed so far (the header is line 1)
    commas = 0  # commas outside quotes on the current line
    quotes = 0  # parity of the quotes seen before the block
    last = b"\n"
    plain = True
    allowed = np.zeros(256, dtype=bool)
    allowed[np.frombuffer(_NUMBER_BYTES, dtype=np.uint8)] = True
    with path.open("rb") as fh:
        if not fh.readline().endswith(b"\n"):  # (the header's fields are its names)
            return 0, True
        line = 1
        while block := fh.read(_BLOCK_BYTES):
            b = np.frombuffer(block, dtype=np.uint8)
            plain = plain and bool(allowed[b].all())
            cpos = np.flatnonzero(b == 44)  # ","
            npos = np.flatnonzero(b == 10)  # "\n"
            qpos = np.flatnonzero(b == 34)  # '"'
            if qpos.size or quotes:
                cpos = cpos[(np.searchsorted(qpos, cpos) + quotes) % 2 == 0]
                npos = npos[(np.searchsorted(qpos, npos) + quotes) % 2 == 0]
            before = np.searchsorted(cpos, npos)  # commas of the block before each line end
            per_line = np.diff(before, prepend=0)
            if per_line.size:
                per_line[0] += commas
                bad = np.flatnonzero(per_line != width - 1)
                if bad.size:
                    k = int(bad[0])
                    _ragged(path, line + k + 1, int(per_line[k]) + 1, width)
                commas = int(cpos.size - before[-1])
            else:
                commas += int(cpos.size)
            line += npos.size
            quotes = (quotes + qpos.size) % 2
            last = block[-1:]
    if last != b"\n":  # a last line without a line end
        line += 1
        if commas != width - 1:
            _ragged(path, line, commas + 1, width)
    if quotes:
        raise CSVFormatError("a quoted cell is not closed", path=str(path), line=line)
    return max(line - 1, 0), plain


def _ragged(path: Path, line: int, got: int, width: int) -> None:
    what = "a blank line" if got == 1 and width > 1 else f"{got} cells"
    raise CSVFormatError(f"{what}, the header has {width} columns", path=str(path), line=line)


def _numbers(cells: Any, path: Path, first_line: int, name: str) -> np.ndarray:
    """One column of text cells as floats; missing cells ``nan``; anything else refused."""
    import pandas as pd

    values = pd.to_numeric(cells, errors="coerce").to_numpy(dtype=float)
    nan = np.isnan(values)
    if nan.any():
        text = cells[nan].str.strip().str.lower()
        bad = ~text.isin(_MISSING).to_numpy()
        if bad.any():
            k = int(np.flatnonzero(nan)[np.flatnonzero(bad)[0]])
            raise CSVFormatError(
                f"{cells.iloc[k]!r:.40} is not a number (numbers are decimal; empty or nan "
                "cells are missing samples)",
                path=str(path),
                line=first_line + k,
                column=name,
            )
    return values


def read_record(
    path: str | Path,
    q: int,
    m: int,
    *,
    names: tuple[Any, Any] | None = None,
    chunk_rows: int = CHUNK_ROWS,
    check_text: bool = False,
) -> Record:
    """``t, y (q, N), u (m, N)`` from a CSV file of recorded data (module docstring).

    A file holding only the bytes of numbers (:data:`_NUMBER_BYTES`) is parsed by the
    float converter of :func:`pandas.read_csv`; otherwise, or with ``check_text``, every
    cell is parsed from its text (slower) so that a bad one is named.

    Raises
    ------
    CSVFormatError
        A malformed file (naming the file, line and column).
    ShapeError
        No time column, or output/input columns that do not match the bank's ``q`` and
        ``m``.
    """
    import pandas as pd

    path = Path(path)
    header = _header(path)
    ys, us = channel_columns(header, "y"), channel_columns(header, "u")
    if names is not None:
        if list(names[0]) and set(names[0]) <= set(header):
            ys = list(names[0])
        if list(names[1]) and set(names[1]) <= set(header):
            us = list(names[1])
    tcol = next((c for c in ("t", "time") if c in header), None)
    if tcol is None:
        raise ShapeError(f"{path}: no time column (name it t or time)", argument="data")
    if len(ys) != q or len(us) != m:
        raise ShapeError(
            f"{path}: the bank reads {q} outputs and {m} inputs; the header has "
            f"{len(ys)} output columns {ys} and {len(us)} input columns {us}",
            argument="data",
        )
    N, plain = _field_counts(path, len(header))
    plain = plain and not check_text
    wanted = [tcol, *ys, *us]
    where = [header.index(c) for c in wanted]
    order = [sorted(where).index(j) for j in where]  # (pandas keeps the file's order)
    out = np.empty((len(wanted), N))
    options: dict[str, Any] = {
        "keep_default_na": False,
        "skip_blank_lines": False,
        "encoding": "utf-8-sig",
        "usecols": where,
        "chunksize": max(int(chunk_rows), 1),
        "engine": "c",
    }
    if plain:  # numbers only: pandas' float converter, strict on these bytes
        options.update(dtype=float, na_values=["", "nan", "NaN", "NAN", "Nan"])
    else:  # every cell checked as text
        options.update(dtype=str, na_filter=False)
    row = 0
    try:
        with pd.read_csv(path, **options) as reader:
            for chunk in reader:
                L = len(chunk)
                for i, (c, k) in enumerate(zip(wanted, order, strict=True)):
                    cells = chunk.iloc[:, k]
                    if plain:
                        out[i, row : row + L] = cells.to_numpy(dtype=float)
                    else:
                        out[i, row : row + L] = _numbers(cells, path, row + 2, c)
                row += L
    except UnicodeDecodeError as exc:
        raise CSVFormatError(
            f"not UTF-8 text ({exc.reason})", path=str(path), line=_bad_utf8_line(path)
        ) from exc
    except pd.errors.ParserError as exc:
        raise CSVFormatError(f"malformed ({exc})", path=str(path)) from exc
    except ValueError as exc:
        if not plain or isinstance(exc, CSVFormatError):
            raise
        # a cell the float converter refuses: the text path names its line and column
        read_record(path, q, m, chunk_rows=chunk_rows, check_text=True)
        raise CSVFormatError(f"unreadable ({exc})", path=str(path)) from exc
    if row != N:  # (the field scan and the parser agree on well-formed files)
        raise CSVFormatError(f"{row} rows parsed, {N} lines of data", path=str(path))
    t, y, u = out[0], out[1 : 1 + q], out[1 + q :]
    miss = np.isnan(out[1:])
    return Record(t, y, u, int(miss.sum()), int(miss.any(axis=0).sum()))


def _bad_utf8_line(path: Path) -> int | None:
    """The first line that is not UTF-8 (the error path only)."""
    with path.open("rb") as fh:
        for k, raw in enumerate(fh, start=1):
            try:
                raw.decode("utf-8")
            except UnicodeDecodeError:
                return k
    return None
