"""Shared fixtures for the CLI tests: copies of the bundled sample scenario and one pipeline run.

``sample_data/`` and ``configs/`` are never written: every test works on copies in a temporary
folder. One full run of the 120 s sample takes a few seconds, so it is done once per session
(``sample_run``) and shared by the read-only checks.
"""
from __future__ import annotations

import os
import shutil
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from rangeproc.cli import main

REPO = Path(__file__).resolve().parents[1]
SAMPLE_DATA = REPO / "sample_data"
SAMPLE_CONFIG = "scenario.toml"  # inside a copy of sample_data; output.dir = "out"


def describe(result: Result) -> str:
    """Exit code, stdout, stderr and any escaped traceback of a CliRunner result (for asserts)."""
    text = (f"exit code {result.exit_code}\n--- stdout ---\n{result.stdout}"
            f"--- stderr ---\n{result.stderr}")
    if result.exc_info is not None and not isinstance(result.exception, SystemExit):
        text += "--- exception ---\n" + "".join(traceback.format_exception(*result.exc_info))
    return text


def invoke(args: list[str]) -> Result:
    """Run the ``rangeproc`` click group in-process with ``args`` (stdout/stderr kept apart)."""
    return CliRunner().invoke(main, [str(a) for a in args])


def compile_fresh_kernels() -> None:
    """Compile two new numba kernels, as a first run does (the compile notice's tests)."""
    import numpy as np
    from numba import njit

    @njit
    def twice(x):  # type: ignore[no-untyped-def]
        return 2.0 * x

    @njit
    def thrice(x):  # type: ignore[no-untyped-def]
        return 3.0 * x

    assert twice(np.float64(1.0)) == 2.0 and thrice(np.float64(1.0)) == 3.0


def copy_sample(dest: Path) -> Path:
    """Copy the bundled sample_data folder (sensor files, scenario.toml, truth.csv) to ``dest``;
    returns ``dest``. Any ``out`` folder in the source is not copied."""
    shutil.copytree(SAMPLE_DATA, dest, ignore=shutil.ignore_patterns("out", ".*"))
    return dest


@dataclass(frozen=True)
class SampleRun:
    """The session's one ``rangeproc run --quiet`` of the copied sample scenario."""

    folder: Path        # the copied sample_data (inputs; not to be modified)
    config: Path        # folder / scenario.toml
    out_dir: Path       # folder / out
    result: Result      # the CliRunner result


def gps_line_batch(t, rng, *, noise: float = 2.0, sigma: float = 2.0,
                   velocity=(100.0, 50.0, 0.0), accel=(0.0, 0.0, 0.0)):
    """A one-sensor ("G1") MeasurementBatch of GPS position rows at times ``t`` (s) along
    ``(0, 0, 3000) + velocity t + accel t^2 / 2`` (range ENU m), with N(0, noise^2) errors
    and stated ``sigma`` (m)."""
    import numpy as np

    from rangeproc.fusion.batch import SensorRows, empty_rows, merge
    from rangeproc.models.measurement import CARTESIAN

    t = np.asarray(t, dtype=float)
    rows = empty_rows(t.size, CARTESIAN)
    truth = np.array([0.0, 0.0, 3000.0]) + np.outer(t, velocity) + 0.5 * np.outer(t * t, accel)
    rows["z"][:, :3] = truth + rng.normal(0.0, noise, (t.size, 3))
    rows["sigma"][:, :3] = sigma
    return merge([(0, SensorRows(t=t, source_row=np.arange(t.size), station=np.full(t.size, -1),
                                 track=np.full(t.size, -1), **rows))], ("G1",))


def filter_parts(args: tuple):  # type: ignore[no-untyped-def]
    """``(FilterRows, FilterPrior, settings keywords)`` of ``run_filter`` from the 16
    positional arguments the compiled kernels (``imm_forward``) start with: the rows, ``x0``,
    ``P0``, ``q_steps``, ``gate``, ``reset_after``, ``reset_inflation``, ``x_lin``."""
    from rangeproc.estimation.forward import FilterPrior, FilterRows
    x_lin = args[15] if len(args) > 15 and len(args[15]) else None
    return (FilterRows(*args[:9]), FilterPrior(args[9], args[10], args[11], x_lin),
            {"gate": args[12], "reset_after": args[13], "reset_inflation": args[14]})


def sensor_subset(config_text: str, ids) -> str:  # type: ignore[no-untyped-def]
    """A config's text with only the [[sensors]] blocks of these ids (a faster run); every id
    must be there."""
    head, *blocks = config_text.split("[[sensors]]")
    kept = [b for b in blocks if any(f'id = "{i}"\n' in b for i in ids)]
    assert len(kept) == len(set(ids)), f"sensors {sorted(ids)} not all in the config"
    return head + "".join("[[sensors]]" + b for b in kept)


def keep_sensors(folder: Path, ids) -> None:  # type: ignore[no-untyped-def]
    """Trim ``folder``'s scenario.toml to the [[sensors]] blocks with these ids."""
    path = folder / SAMPLE_CONFIG
    path.write_text(sensor_subset(path.read_text(), ids))


@pytest.fixture(scope="session")
def sample_copy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A pristine copy of sample_data shared by the session (read-only for tests)."""
    return copy_sample(tmp_path_factory.mktemp("shared") / "sample_data")


@pytest.fixture(scope="session")
def sample_run(sample_copy: Path) -> SampleRun:
    """``rangeproc run --quiet scenario.toml`` on the shared copy, run once per session."""
    config = sample_copy / SAMPLE_CONFIG
    result = invoke(["run", "--quiet", config])
    assert result.exit_code == 0, describe(result)
    return SampleRun(folder=sample_copy, config=config, out_dir=sample_copy / "out",
                     result=result)


@pytest.fixture
def scenario(tmp_path: Path) -> Path:
    """A fresh, mutable copy of sample_data for one test; returns the folder."""
    return copy_sample(tmp_path / "scenario")


@pytest.fixture
def cli() -> Callable[[list[str]], Result]:
    """The in-process CLI runner: ``cli(["run", config])`` -> click Result."""
    return invoke


@pytest.fixture
def explain() -> Callable[[Result], str]:
    """``explain(result)``: exit code, stdout, stderr and traceback text for assert messages."""
    return describe


def _plot_batch(t, rae, sigma):
    """Radar plots (N,) times ``t`` s, ``rae`` (N, 3) range m / azimuth / elevation rad with
    1-sigma ``sigma`` (3,), from a site at the range origin with ENU axes: a one-sensor
    MeasurementBatch."""
    import numpy as np

    from rangeproc.fusion.batch import MeasurementBatch
    from rangeproc.models.measurement import SPHERICAL

    n = t.size
    z = np.full((n, 6), np.nan)
    z[:, :3] = rae
    sig = np.zeros((n, 6))
    sig[:, :3] = sigma
    return MeasurementBatch(t, np.full(n, SPHERICAL), z, sig, np.zeros((n, 3)),
                            np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
                            np.zeros(n, np.int64), np.arange(n), np.full(n, -1),
                            np.full(n, -1), ("SR1",))


@pytest.fixture
def plot_batch():
    """``plot_batch(t, rae, sigma)``: radar plots as a MeasurementBatch (``_plot_batch``)."""
    return _plot_batch


# ------------------------------------------------------------------ a real headless browser
#: Debian's chromium + chromium-driver (report pages are tested in them, through Selenium).
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


def _browser():  # type: ignore[no-untyped-def]
    if not (CHROMIUM and CHROMEDRIVER):
        if os.environ.get("RANGEPROC_REQUIRE_BROWSER") == "1":
            pytest.fail("RANGEPROC_REQUIRE_BROWSER=1 but chromium/chromedriver are not installed")
        pytest.skip("no chromium + chromedriver (Debian: apt-get install chromium "
                    "chromium-driver)")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--window-size=1280,1600"):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=opts)


@pytest.fixture(scope="session")
def browser():  # type: ignore[no-untyped-def]
    driver = _browser()
    yield driver
    driver.quit()


@pytest.fixture
def open_page(browser):  # type: ignore[no-untyped-def]
    """``open_page(path)`` -> (console errors, images): loads ``path`` in the browser and
    returns its SEVERE console entries and, per ``<img>``, [alt, complete, naturalWidth]."""
    def load(path: Path) -> tuple[list[dict], list[list]]:
        browser.get(Path(path).as_uri())
        errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
        images = browser.execute_script(
            "return Array.from(document.images).map(i => [i.alt, i.complete, i.naturalWidth])")
        return errors, images
    return load


