"""Recording format: round trips and one-line errors for every malformed input."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from simgap.recordings import (
    MIN_SAMPLES,
    RecordingError,
    read_recording,
    recording_from_arrays,
    write_recording,
)

COLS = ("q1", "q2", "dq1", "dq2", "tau1", "tau2")


def _table(n: int = 80) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    data = {"t": np.arange(n) * 0.002}
    for c in COLS:
        data[c] = rng.normal(size=n)
    return data


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip(tmp_path, suffix):
    data = _table()
    data["extra"] = np.ones(80)
    path = write_recording(tmp_path / f"rec{suffix}", data)
    rec = read_recording(path, COLS)
    assert rec.n == 80 and rec.name == f"rec{suffix}"
    assert "extra" not in rec.columns
    for c in ("t",) + COLS:
        np.testing.assert_allclose(rec[c], data[c], rtol=1e-8)


def _write_csv(tmp_path, text: str, name: str = "bad.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _csv_lines(n: int = 60, cols=("t",) + COLS) -> list[str]:
    lines = [",".join(cols)]
    for i in range(n):
        lines.append(",".join([f"{i * 0.002:.4f}"] + ["0.5"] * (len(cols) - 1)))
    return lines


def _assert_one_line(err: Exception, *words: str) -> None:
    msg = str(err)
    assert "\n" not in msg
    for w in words:
        assert w in msg, msg


def test_missing_column(tmp_path):
    p = _write_csv(tmp_path, "\n".join(_csv_lines(cols=("t", "q1", "q2", "dq1", "dq2",
                                                        "tau1"))))
    with pytest.raises(RecordingError) as e:
        read_recording(p, COLS)
    _assert_one_line(e.value, "bad.csv", "missing column 'tau2'")


def test_non_numeric(tmp_path):
    lines = _csv_lines()
    lines[6] = lines[6].replace("0.5", "abc", 1)
    p = _write_csv(tmp_path, "\n".join(lines))
    with pytest.raises(RecordingError) as e:
        read_recording(p, COLS)
    _assert_one_line(e.value, "bad.csv", "column 'q1'", "row 6", "line 7", "'abc'")


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "NaN"])
def test_not_finite(tmp_path, value):
    lines = _csv_lines()
    lines[10] = lines[10].rsplit(",", 1)[0] + "," + value
    p = _write_csv(tmp_path, "\n".join(lines))
    with pytest.raises(RecordingError) as e:
        read_recording(p, COLS)
    _assert_one_line(e.value, "column 'tau2'", "row 10", "not finite")


def test_empty_cell(tmp_path):
    lines = _csv_lines()
    lines[3] = lines[3].rsplit(",", 1)[0] + ","
    p = _write_csv(tmp_path, "\n".join(lines))
    with pytest.raises(RecordingError) as e:
        read_recording(p, COLS)
    _assert_one_line(e.value, "column 'tau2'", "row 3", "empty value")


@pytest.mark.parametrize("swap", [True, False])
def test_time_not_increasing(tmp_path, swap):
    lines = _csv_lines()
    if swap:
        lines[20], lines[21] = lines[21], lines[20]
    else:
        lines[21] = lines[20]
    p = _write_csv(tmp_path, "\n".join(lines))
    with pytest.raises(RecordingError) as e:
        read_recording(p, COLS)
    _assert_one_line(e.value, "column 't'", "row 21", "strictly increase")


def test_too_few_samples(tmp_path):
    p = _write_csv(tmp_path, "\n".join(_csv_lines(n=MIN_SAMPLES - 1)))
    with pytest.raises(RecordingError) as e:
        read_recording(p, COLS)
    _assert_one_line(e.value, "too few samples")


@pytest.mark.parametrize("content,words", [
    ("", "empty"),
    ("t,q1\n1,2,3,4\n", "bad.csv"),
])
def test_unreadable(tmp_path, content, words):
    p = _write_csv(tmp_path, content)
    with pytest.raises(RecordingError) as e:
        read_recording(p, COLS)
    _assert_one_line(e.value, words)


def test_bad_paths(tmp_path):
    with pytest.raises(RecordingError, match="does not exist"):
        read_recording(tmp_path / "nope.csv", COLS)
    (tmp_path / "x.txt").write_text("t\n1\n")
    with pytest.raises(RecordingError, match="unknown file type"):
        read_recording(tmp_path / "x.txt", COLS)
    (tmp_path / "x.parquet").write_bytes(b"not parquet at all")
    with pytest.raises(RecordingError, match="cannot be read as parquet"):
        read_recording(tmp_path / "x.parquet", COLS)
    (tmp_path / "bin.csv").write_bytes(bytes(range(256)) * 4)
    with pytest.raises(RecordingError):
        read_recording(tmp_path / "bin.csv", COLS)


def test_duplicate_column(tmp_path):
    lines = _csv_lines()
    lines[0] = lines[0].replace("dq1", "q1")
    p = _write_csv(tmp_path, "\n".join(lines))
    with pytest.raises(RecordingError, match="more than once"):
        read_recording(p, COLS)


def test_parquet_non_numeric(tmp_path):
    df = pd.DataFrame(_table())
    df["q1"] = df["q1"].astype(str)
    df.loc[5, "q1"] = "oops"
    df.to_parquet(tmp_path / "r.parquet")
    with pytest.raises(RecordingError) as e:
        read_recording(tmp_path / "r.parquet", COLS)
    _assert_one_line(e.value, "column 'q1'", "row 6", "'oops'")


def test_in_memory_validation():
    data = _table()
    data["q2"][4] = np.nan
    with pytest.raises(RecordingError, match="column 'q2' row 5"):
        recording_from_arrays("mem", data, COLS)


def test_write_is_atomic(tmp_path):
    with pytest.raises(KeyError):
        write_recording(tmp_path / "r.csv", {"t": np.arange(3.0)}, columns=["t", "q1"])
    assert list(tmp_path.iterdir()) == []


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(st.binary(max_size=400) | st.text(alphabet="t,q12dau.-e0123456789\n nainf",
                                         max_size=600))
def test_fuzz_loader(tmp_path, blob):
    """Any content either loads as a valid recording or raises a one-line RecordingError."""
    p = tmp_path / "fuzz.csv"
    p.write_bytes(blob if isinstance(blob, bytes) else blob.encode())
    try:
        rec = read_recording(p, ("q1",), min_samples=2)
    except RecordingError as err:
        assert "\n" not in str(err) and "fuzz.csv" in str(err)
    else:
        assert np.all(np.isfinite(rec["q1"])) and np.all(np.diff(rec.t) > 0)
