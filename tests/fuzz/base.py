"""The fuzz suite's base scenario: the bundled 120 s sample cut to its first 15 seconds.

Every fuzz case mutates a fresh copy of this small folder, so one case runs in about a second.
The base keeps each file's format (``TH1.parquet`` stays Parquet, the others CSV), its column
order and every value bit for bit: CSV files keep their original text lines (header plus the
data lines whose time is inside the window), the Parquet file keeps its schema. The config
``scenario.toml`` is copied unchanged (``[output] dir = "out"``).

The window is ``time < t_min + WINDOW_S`` with ``t_min`` the earliest time over all sensor
files (seconds on the range time scale of the sample).
"""
from __future__ import annotations

import functools
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]
SAMPLE_DATA = REPO / "sample_data"
CONFIG_NAME = "scenario.toml"
OUTPUT_DIR = "out"          # the sample config's [output].dir
WINDOW_S = 15.0             # seconds of data kept from the earliest time stamp


@dataclass(frozen=True, slots=True)
class SensorFile:
    """One sensor file of the base scenario.

    ``sensor``: config id; ``kind``: contract sensor kind; ``name``: file name in the folder;
    ``columns``: header names in file order; ``n_rows``: data rows (header excluded);
    ``index``: position of the sensor in the config's ``[[sensors]]`` array.
    """

    sensor: str
    kind: str
    name: str
    columns: tuple[str, ...]
    n_rows: int
    index: int

    @property
    def is_parquet(self) -> bool:
        """True when the file is Parquet (by extension, as the reader decides)."""
        return self.name.lower().endswith((".parquet", ".pq"))


@dataclass(frozen=True, slots=True)
class BaseLayout:
    """What the base scenario holds, known before any folder is written.

    ``config_text``: the config file's text (copied unchanged); ``files``: sensor files in
    config order; ``t_min``: earliest time stamp over all files (s); ``t_cut``: exclusive end
    of the kept window (s).
    """

    config_text: str
    files: tuple[SensorFile, ...]
    t_min: float
    t_cut: float

    def file(self, name: str) -> SensorFile:
        """The sensor file called ``name``."""
        for f in self.files:
            if f.name == name:
                return f
        raise KeyError(name)

    @property
    def n_rows(self) -> int:
        """Data rows over every sensor file."""
        return sum(f.n_rows for f in self.files)


@dataclass(frozen=True, slots=True)
class BaseScenario:
    """A written base folder: ``folder/scenario.toml`` plus the cut sensor files."""

    folder: Path
    layout: BaseLayout

    def __repr__(self) -> str:  # short: hypothesis prints it with every falsifying example
        return f"BaseScenario(folder={str(self.folder)!r})"

    @property
    def config_path(self) -> Path:
        return self.folder / CONFIG_NAME


def _csv_lines(path: Path) -> tuple[list[str], int]:
    """Lines of a CSV file (line ends kept) and the position of its ``time`` column."""
    lines = path.read_bytes().decode("utf-8").splitlines(keepends=True)
    return lines, lines[0].rstrip("\r\n").split(",").index("time")


def _kept_csv(path: Path, t_cut: float) -> list[str]:
    """Header line and the data lines with time < ``t_cut``, unchanged."""
    lines, j = _csv_lines(path)
    return [lines[0]] + [x for x in lines[1:] if x.strip() and float(x.split(",")[j]) < t_cut]


def _kept_parquet(path: Path, t_cut: float) -> pa.Table:
    """The rows with time < ``t_cut`` (source schema)."""
    table = pq.read_table(path)
    return table.filter(pc.less(table.column("time"), t_cut))


def _earliest(path: Path) -> float:
    """Earliest time stamp of one sensor file (s)."""
    if path.suffix == ".parquet":
        return float(pc.min(pq.read_table(path, columns=["time"]).column("time")).as_py())
    lines, j = _csv_lines(path)
    return min(float(x.split(",")[j]) for x in lines[1:] if x.strip())


@functools.cache
def plan_base(sample: Path = SAMPLE_DATA, window_s: float = WINDOW_S) -> BaseLayout:
    """The layout of the base scenario cut from ``sample`` (reads, writes nothing)."""
    config_text = (sample / CONFIG_NAME).read_text(encoding="utf-8")
    sensors = tomllib.loads(config_text)["sensors"]
    t_min = min(_earliest(sample / s["file"]) for s in sensors)
    t_cut = t_min + window_s
    files = []
    for index, s in enumerate(sensors):
        path = sample / s["file"]
        if path.suffix == ".parquet":
            table = _kept_parquet(path, t_cut)
            columns, n = tuple(table.column_names), table.num_rows
        else:
            lines = _kept_csv(path, t_cut)
            columns, n = tuple(lines[0].rstrip("\r\n").split(",")), len(lines) - 1
        files.append(SensorFile(sensor=s["id"], kind=s["kind"], name=s["file"],
                                columns=columns, n_rows=n, index=index))
    return BaseLayout(config_text=config_text, files=tuple(files), t_min=t_min, t_cut=t_cut)


def build_base(dest: Path, sample: Path = SAMPLE_DATA, window_s: float = WINDOW_S
               ) -> BaseScenario:
    """Write the base scenario into the empty or missing folder ``dest``.

    Only the config and the files named by its ``[[sensors]]`` are written (no ``truth.csv``,
    no ``out/``): CSV files as their header plus the kept original lines, Parquet files with
    the source schema.
    """
    layout = plan_base(sample, window_s)
    dest.mkdir(parents=True, exist_ok=True)
    for f in layout.files:
        if f.is_parquet:
            pq.write_table(_kept_parquet(sample / f.name, layout.t_cut), dest / f.name)
        else:
            (dest / f.name).write_bytes("".join(_kept_csv(sample / f.name, layout.t_cut))
                                        .encode("utf-8"))
    (dest / CONFIG_NAME).write_bytes((sample / CONFIG_NAME).read_bytes())
    return BaseScenario(folder=dest, layout=layout)


def copy_base(base: BaseScenario, dest: Path) -> Path:
    """A fresh copy of the base folder at ``dest`` (must not exist); returns the config path."""
    shutil.copytree(base.folder, dest)
    return dest / CONFIG_NAME
