"""Fuzz of the file and command-line surfaces of ``geomfdi evaluate`` / ``campaign``:
mutated CSV records and bad option values give a named error (exit code 2, one
``geomfdi: error:`` line) or a correct run; never an internal error."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from geomfdi.deployment.csvfile import read_record
from geomfdi.errors import GeomFDIError
from geomfdi.io.cli import main

ROWS = [f"{0.1 * k!r},{np.sin(k):.6f},{np.cos(k):.6f},0.5" for k in range(20)]
HEADER = "t,y0,y1,u0"
CELLS = ["abc", "true", "0x1p3", "\x00", "", "nan", "inf", "-inf", "1e400", '"1.5"', "' 1'",
         "1,5", '"', "NA", "--1", "1e", "١", "\ufeff1", "1 2", "\t", "None", "0b1"]  # fmt: skip
MUTATIONS = {
    "drop column": lambda rows: [r.rsplit(",", 1)[0] for r in rows],
    "extra column": lambda rows: [r + ",1" for r in rows],
    "blank line": lambda rows: rows[:5] + [""] + rows[5:],
    "crlf": lambda rows: [r + "\r" for r in rows],
    "no rows": lambda rows: [],
    "one row": lambda rows: rows[:1],
    "unsorted time": lambda rows: rows[5:] + rows[:5],
    "duplicated header": lambda rows: [HEADER] + rows,
}


def _record(tmp: Path, header: str, rows: list[str], raw: bytes | None = None) -> Path:
    path = tmp / "rec.csv"
    path.write_bytes(raw if raw is not None else (header + "\n" + "\n".join(rows) + "\n").encode())
    return path


def _outcome(path: Path) -> str:
    try:
        rec = read_record(path, 2, 1)
    except GeomFDIError:
        return "named"
    except Exception as exc:  # noqa: BLE001 - the point of the fuzz
        return f"raw {type(exc).__name__}: {exc}"
    if rec.y.shape != (2, rec.t.size) or rec.u.shape != (1, rec.t.size):
        return "wrong shape"
    return "correct"


@pytest.mark.parametrize("col", range(4))
def test_every_cell_value_in_every_column(tmp_path: Path, col: int) -> None:
    bad = []
    for cell in CELLS:
        rows = list(ROWS)
        parts = rows[7].split(",")
        parts[col] = cell
        rows[7] = ",".join(parts)
        got = _outcome(_record(tmp_path, HEADER, rows))
        if got not in ("named", "correct"):
            bad.append(f"{cell!r}: {got}")
        if got == "correct" and cell not in ("", "nan", "inf", "-inf", "1e400", '"1.5"'):
            bad.append(f"{cell!r}: accepted")
    assert bad == []


@pytest.mark.parametrize("name", sorted(MUTATIONS))
def test_mutated_records(tmp_path: Path, name: str) -> None:
    assert _outcome(_record(tmp_path, HEADER, MUTATIONS[name](list(ROWS)))) in ("named", "correct")


@pytest.mark.parametrize("encoding", ["latin-1", "utf-16", "cp1252"])
def test_other_encodings(tmp_path: Path, encoding: str) -> None:
    text = HEADER + ",é\n" + "\n".join(r + ",é" for r in ROWS) + "\n"
    assert _outcome(_record(tmp_path, "", [], raw=text.encode(encoding))) == "named"


def test_random_bytes(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    base = (HEADER + "\n" + "\n".join(ROWS) + "\n").encode()
    for _ in range(60):
        data = bytearray(base)
        for k in rng.integers(len(HEADER) + 1, len(data), size=3):
            data[k] = int(rng.integers(0, 256))
        got = _outcome(_record(tmp_path, "", [], raw=bytes(data)))
        assert got in ("named", "correct"), (bytes(data), got)


MODEL = """name = "m"
[plant]
A = [[0.5, 0.0], [0.0, 0.2]]
B = [[1.0], [0.5]]
C = [[1.0, 0.0], [0.0, 1.0]]
dt = 0.1
[simulation]
t_end = 1.9
step = 0.1
threshold = 0.5
"""
OPTIONS = {
    "--persistence": ["0", "-1", "1/0", "3/2", "1/1000000000", "a", "1/2/3/4", "1.5", "", "1/2/0"],
    "--threshold": ["nan", "-1", "0", "inf", "abc"],
    "--settle": ["-1", "nan", "inf", "soon", "1e308"],
    "--initial": ["warm"],
    "--method": ["nope", ""],
}


@pytest.mark.parametrize("option", sorted(OPTIONS))
def test_evaluate_options(tmp_path: Path, option: str, capsys: pytest.CaptureFixture) -> None:
    model = tmp_path / "m.toml"
    model.write_text(MODEL)
    data = _record(tmp_path, HEADER, ROWS)
    bad = []
    for value in OPTIONS[option]:
        args = ["evaluate", str(model), str(data), "--out", str(tmp_path / "o"), "--no-plots"]
        try:
            code = main([*args, option, value, "--quiet"])
        except SystemExit as exc:  # argparse refuses it: a usage error, exit 2
            code = exc.code
        err = capsys.readouterr().err
        if code not in (0, 2) or "internal error" in err:
            bad.append(f"{value!r}: exit {code}: {err.strip()[-200:]}")
    assert bad == []


@pytest.mark.parametrize("runs", ["0", "-1", "2.7", "1000000000", "x"])
def test_campaign_runs_option(tmp_path: Path, runs: str, capsys: pytest.CaptureFixture) -> None:
    model = Path(__file__).resolve().parents[2] / "examples" / "discrete_disturbance.toml"
    try:
        code = main(["campaign", str(model), "--runs", runs, "--out", str(tmp_path), "--quiet"])
    except SystemExit as exc:
        code = exc.code
    assert code == 2 and "internal error" not in capsys.readouterr().err


def test_option_table_size() -> None:
    assert sum(len(v) for v in OPTIONS.values()) >= 20 and len(CELLS) * 4 >= 80
    assert len(list(itertools.chain(MUTATIONS))) >= 8
