"""Tests of rangeproc.io.writers: atomicity, JSON conversion, Parquet round trip, hashing."""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from rangeproc.io import writers
from rangeproc.io.writers import atomic_path, file_sha256, write_json, write_parquet, write_text


class Boom(RuntimeError):
    pass


def test_atomic_path_renames_on_success(tmp_path: Path) -> None:
    final = tmp_path / "out" / "x.txt"          # parent created on demand
    with atomic_path(final) as tmp:
        assert tmp.parent == final.parent and tmp.name.startswith(".")
        assert tmp != final
        tmp.write_text("hello")
        assert not final.exists()
    assert final.read_text() == "hello"
    assert sorted(p.name for p in final.parent.iterdir()) == ["x.txt"]


def test_failing_write_leaves_no_file_and_no_temp(tmp_path: Path) -> None:
    final = tmp_path / "fused.parquet"
    with pytest.raises(Boom), atomic_path(final) as tmp:
        tmp.write_bytes(b"half a file")
        raise Boom("disk full")
    assert list(tmp_path.iterdir()) == []


def test_failing_write_keeps_previous_file(tmp_path: Path) -> None:
    final = tmp_path / "summary.json"
    write_json({"v": 1}, final)
    with pytest.raises(Boom), atomic_path(final) as tmp:
        tmp.write_text('{"v": 2, "trunc')
        raise Boom()
    assert json.loads(final.read_text()) == {"v": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]


def test_write_parquet_failure_mid_write_leaves_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def broken_write_table(table: object, where: Path, **options: object) -> None:
        Path(where).write_bytes(b"PAR1 partial")
        raise OSError("No space left on device")

    monkeypatch.setattr(writers.pq, "write_table", broken_write_table)
    with pytest.raises(OSError, match="No space left"):
        write_parquet(pd.DataFrame({"a": [1.0]}), tmp_path / "fused.parquet")
    assert list(tmp_path.iterdir()) == []


def test_write_parquet_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    df = pd.DataFrame({"target_id": ["T1"] * 4 + ["T2"] * 4, "time": np.arange(8) * 0.1,
                       "e": rng.normal(size=8), "n_sensors": np.arange(8, dtype=np.int64)},
                      index=np.arange(10, 18))
    path = write_parquet(df, tmp_path / "fused.parquet")
    back = pd.read_parquet(path)
    pd.testing.assert_frame_equal(back, df.reset_index(drop=True))
    assert list(back.columns) == ["target_id", "time", "e", "n_sensors"]  # no index column


def test_write_json_converts_numpy_and_nan(tmp_path: Path) -> None:
    obj = {
        "count": np.int64(7), "ok": np.bool_(True), "rms": np.float32(0.5),
        "nan": float("nan"), "inf": np.float64(np.inf),
        "arr": np.array([[1.0, np.nan], [3.0, -np.inf]]),
        "ids": ("a", "b"), "proxy": MappingProxyType({1: np.float64(2.5)}),
        "path": Path("/x/y.csv"), "none": None,
    }
    path = write_json(obj, tmp_path / "summary.json")
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert text.startswith('{\n  "count": 7')   # indent 2
    back = json.loads(text)
    assert back == {"count": 7, "ok": True, "rms": 0.5, "nan": None, "inf": None,
                    "arr": [[1.0, None], [3.0, None]], "ids": ["a", "b"],
                    "proxy": {"1": 2.5}, "path": "/x/y.csv", "none": None}


def test_write_json_of_dataclass(tmp_path: Path) -> None:
    from rangeproc.config import Geodetic
    back = json.loads(write_json([Geodetic(lat=1.0, lon=2.0, height=math.nan)],
                                 tmp_path / "g.json").read_text())
    assert back == [{"lat": 1.0, "lon": 2.0, "height": None}]


def test_write_text_overwrites_atomically(tmp_path: Path) -> None:
    path = tmp_path / "a.txt"
    write_text("one\n", path)
    write_text("two ü\n", path)
    assert path.read_text(encoding="utf-8") == "two ü\n"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


@pytest.mark.parametrize("size", [0, 1, 4096, 10_000])
def test_file_sha256_matches_hashlib(tmp_path: Path, size: int) -> None:
    data = np.random.default_rng(size).integers(0, 256, size, dtype=np.uint8).tobytes()
    path = tmp_path / "blob.bin"
    path.write_bytes(data)
    expected = hashlib.sha256(data).hexdigest()
    assert file_sha256(path, chunk_size=1000) == expected   # several chunks
    assert file_sha256(path) == expected


def test_write_parquet_dictionary_encodes_only_text_columns(tmp_path: Path) -> None:
    """Float columns are written plain (no dictionary attempt), text columns with a
    dictionary; the values read back are the ones written."""
    df = pd.DataFrame({"target_id": ["T1", "O1"] * 500, "e": np.arange(1000) * 0.1,
                       "n": np.linspace(-1.0, 1.0, 1000)})
    path = write_parquet(df, tmp_path / "fused.parquet")
    pd.testing.assert_frame_equal(pd.read_parquet(path), df, check_dtype=False)
    meta = pq.ParquetFile(path).metadata.row_group(0)
    encodings = {meta.column(k).path_in_schema: meta.column(k).encodings
                 for k in range(meta.num_columns)}
    assert "RLE_DICTIONARY" in encodings["target_id"]
    assert "RLE_DICTIONARY" not in encodings["e"] and "RLE_DICTIONARY" not in encodings["n"]
