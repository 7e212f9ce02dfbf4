"""The strict CSV reader of recorded data (geomfdi.deployment.csvfile) and the files of
``geomfdi evaluate``: malformed input refused with file, line and column; BOM and quoted
numbers accepted; missing samples counted; memory per row bounded."""

from __future__ import annotations

import os
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from geomfdi.deployment.csvfile import CSVFormatError, read_record
from geomfdi.errors import GeomFDIError

HEADER = "t,y0,y1,u0\n"
GOOD = ["0,1,2,3", "0.1,1.5,2,3", "0.2,1,2e-1,-3"]


def _write(tmp: Path, text: str | bytes, name: str = "d.csv") -> Path:
    path = tmp / name
    if isinstance(text, str):
        text = text.encode("utf-8")
    path.write_bytes(text)
    return path


def _rows(rows: list[str]) -> str:
    return HEADER + "\n".join(rows) + "\n"


@pytest.mark.parametrize("cell", ["abc", "true", "0x1p3", "\x00", "1\x002", "NA", "1_0", "1,5"])
def test_unparseable_cells_are_refused_with_line_and_column(tmp_path: Path, cell: str) -> None:
    rows = [*GOOD, f"0.3,1,{cell},3"]
    if "," in cell:  # (a comma makes a ragged row unless quoted)
        rows[-1] = f'0.3,1,"{cell}",3'
    path = _write(tmp_path, _rows(rows))
    with pytest.raises(CSVFormatError) as info:
        read_record(path, 2, 1)
    assert info.value.line == 5 and info.value.column == "y1"
    assert str(path) in str(info.value) and "line 5" in str(info.value)


@pytest.mark.parametrize("row, line", [("0.3,1,2", 5), ("0.3,1,2,3,4", 5), ("", 5), ("0.3", 5)])
def test_ragged_rows_and_blank_lines_are_refused(tmp_path: Path, row: str, line: int) -> None:
    path = _write(tmp_path, _rows([*GOOD, row, "0.4,1,2,3"]))
    with pytest.raises(CSVFormatError, match=f"line {line}") as info:
        read_record(path, 2, 1)
    assert info.value.line == line


def test_ragged_last_line_without_line_end(tmp_path: Path) -> None:
    path = _write(tmp_path, HEADER + "\n".join([*GOOD, "0.3,1"]))
    with pytest.raises(CSVFormatError, match="line 5"):
        read_record(path, 2, 1)


def test_duplicated_column_is_refused(tmp_path: Path) -> None:
    path = _write(tmp_path, "t,y0,y1,y1,u0\n0,1,2,3,4\n")
    with pytest.raises(CSVFormatError, match="'y1' appears twice") as info:
        read_record(path, 2, 1)
    assert info.value.column == "y1" and info.value.line == 1


def test_latin1_is_refused_with_its_line(tmp_path: Path) -> None:
    text = _rows(GOOD).encode() + "0.3,1,2,3 \xe9\n".encode("latin-1")
    path = _write(tmp_path, text)
    with pytest.raises(CSVFormatError, match="not UTF-8") as info:
        read_record(path, 2, 1)
    assert info.value.line == 5
    path = _write(tmp_path, "t,y0,y1,u\xe9\n0,1,2,3\n".encode("latin-1"), "h.csv")
    with pytest.raises(CSVFormatError, match="not UTF-8"):
        read_record(path, 2, 1)


def test_bom_and_quoted_numbers_are_read(tmp_path: Path) -> None:
    text = "\ufeff" + HEADER + '0,"1.5",2,3\n0.1," 2.5 ",2,3\n"0.2",3,"1e-3",-4\n'
    rec = read_record(_write(tmp_path, text), 2, 1)
    np.testing.assert_array_equal(rec.t, [0, 0.1, 0.2])
    np.testing.assert_array_equal(rec.y, [[1.5, 2.5, 3], [2, 2, 1e-3]])
    np.testing.assert_array_equal(rec.u, [[3, 3, -4]])
    assert (rec.missing, rec.missing_samples) == (0, 0)


def test_quoted_comma_inside_a_header_name_keeps_the_field_count(tmp_path: Path) -> None:
    text = 't,y0,y1,u0,"note, free text"\n0,1,2,3,"a, b"\n0.1,1,2,3,""\n'
    rec = read_record(_write(tmp_path, text), 2, 1)
    assert rec.t.size == 2


def test_missing_cells_are_counted(tmp_path: Path) -> None:
    text = _rows(["0,1,,3", "0.1,nan,NaN,3", "0.2,1,2,3", "0.3,1,2,"])
    rec = read_record(_write(tmp_path, text), 2, 1)
    assert (rec.missing, rec.missing_samples) == (4, 3)
    assert np.isnan(rec.y[1, 0]) and np.isnan(rec.u[0, 3]) and rec.y[0, 2] == 1


def test_chunks_give_the_same_record(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    data = rng.standard_normal((1000, 4))
    data[:, 0] = np.arange(1000) * 0.01
    path = tmp_path / "big.csv"
    np.savetxt(path, data, delimiter=",", header=HEADER.strip(), comments="", fmt="%.17g")
    whole = read_record(path, 2, 1)
    parts = read_record(path, 2, 1, chunk_rows=7)
    np.testing.assert_array_equal(whole.y, parts.y)
    np.testing.assert_array_equal(whole.y, data[:, 1:3].T)
    np.testing.assert_array_equal(whole.t, data[:, 0])


def test_reader_errors_are_named(tmp_path: Path) -> None:
    for text in ["", 't,y0,y1,u0\n0,1,2,"3\n', "y0,y1,u0\n1,2,3\n"]:
        with pytest.raises(GeomFDIError):
            read_record(_write(tmp_path, text), 2, 1)


def _peak_bytes(path: Path) -> int:
    tracemalloc.start()
    try:
        read_record(path, 2, 1)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_reader_memory_per_row_is_bounded(tmp_path: Path) -> None:
    """The signals (8 bytes per cell) plus one chunk: the peak per row falls towards
    ``8 (1 + q + m)`` = 32 bytes as the file grows (the text-based reader took about
    1 kB per row)."""
    peaks = {}
    for N in (100_000, 300_000):
        path = tmp_path / f"{N}.csv"
        t = np.arange(N) * 0.01
        data = np.column_stack([t, np.sin(t), np.cos(t), t % 1.0])
        np.savetxt(path, data, delimiter=",", header=HEADER.strip(), comments="", fmt="%.9g")
        peaks[N] = _peak_bytes(path)
        os.remove(path)
    per_row = (peaks[300_000] - peaks[100_000]) / 200_000
    assert per_row < 64, peaks
