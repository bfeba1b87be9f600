"""The compiled-kernel cache: keyed to every source compiled code can reach, so an edited helper
never loads a stale kernel; its folder follows the environment; the first compilation of a
process is announced once."""
from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import pytest
from numba.core import event

from conftest import compile_fresh_kernels

from rangeproc import kernel_cache
from rangeproc.kernel_cache import (
    CACHE_ENV,
    FOLDER_PREFIX,
    announce_compilation,
    cache_folder,
    kernel_sources,
    source_key,
)

ROOT = kernel_cache.PACKAGE_ROOT


@pytest.fixture()
def package_copy(tmp_path: Path) -> Path:
    """The package's Python sources copied to ``tmp_path / "rangeproc"``."""
    dest = tmp_path / "rangeproc"
    shutil.copytree(ROOT, dest, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    return dest


def _rel(paths: list[Path], root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in paths}


def test_the_key_covers_the_helpers_of_the_forward_kernels() -> None:
    """The kernels' own module, the helper modules they call and the constants' modules."""
    rel = _rel(kernel_sources(), ROOT)
    for name in ("estimation/forward_loop.py", "families/__init__.py", "families/base.py",
                 "estimation/update.py",
                 "estimation/linalg.py", "estimation/kernels.py", "estimation/moments.py",
                 "estimation/divergence.py", "models/measurement.py", "models/motion.py",
                 "estimation/rts.py", "tracking/score.py"):
        assert name in rel, name
    assert "report/page.py" not in rel                 # pure Python, no kernel reaches it


def test_every_module_that_imports_numba_is_keyed() -> None:
    rel = _rel(kernel_sources(), ROOT)
    for path in ROOT.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        if "from numba import" in text or "\nimport numba" in text:
            assert path.relative_to(ROOT).as_posix() in rel


def test_editing_a_helper_changes_the_key_and_a_report_module_does_not(
        package_copy: Path) -> None:
    before = source_key(package_copy)
    assert before == source_key(package_copy)         # deterministic
    page = package_copy / "report" / "page.py"
    page.write_text(page.read_text() + "\n# a report edit\n")
    assert source_key(package_copy) == before
    helper = package_copy / "estimation" / "linalg.py"  # inlined into every forward kernel
    helper.write_text(helper.read_text().replace("0.5 * (P[i, j] + P[j, i])",
                                                 "0.5 * (P[j, i] + P[i, j])"))
    assert source_key(package_copy) != before


def test_a_submodule_named_in_an_import_list_is_followed(package_copy: Path) -> None:
    """``from rangeproc.estimation import forward_loop as fl`` reaches forward_loop."""
    user = package_copy / "uses_kernels.py"
    user.write_text("import numba\nfrom rangeproc.estimation import (\n    forward_loop as fl,"
                    "\n)\n")
    rel = _rel(kernel_sources(package_copy), package_copy)
    assert {"uses_kernels.py", "estimation/forward_loop.py"} <= rel


def test_the_folder_follows_the_environment(tmp_path: Path) -> None:
    key = "0123456789abcdef"
    leaf = FOLDER_PREFIX + key
    assert cache_folder(key, {CACHE_ENV: str(tmp_path)}) == tmp_path / leaf
    assert cache_folder(key, {"NUMBA_CACHE_DIR": str(tmp_path)}) == tmp_path / leaf
    assert cache_folder(key, {CACHE_ENV: str(tmp_path / "a"),
                              "NUMBA_CACHE_DIR": str(tmp_path / "b")}) == tmp_path / "a" / leaf
    # a child process inherits the keyed folder itself: it is kept, not nested
    assert cache_folder(key, {"NUMBA_CACHE_DIR": str(tmp_path / leaf)}) == tmp_path / leaf
    assert cache_folder(key, {"XDG_CACHE_HOME": str(tmp_path)}) == tmp_path / "rangeproc" / leaf
    assert cache_folder(key, {}) == Path.home() / ".cache" / "rangeproc" / leaf


def test_configure_points_numba_at_the_keyed_folder_and_prunes_unused_keys(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from numba.core import config
    stale = tmp_path / (FOLDER_PREFIX + "stale")
    stale.mkdir()
    (stale / "old.nbi").write_text("x")
    month_ago = time.time() - 30 * 24 * 3600
    os.utime(stale, (month_ago, month_ago))
    recent = tmp_path / (FOLDER_PREFIX + "other-checkout")      # used yesterday: kept
    recent.mkdir()
    day_ago = time.time() - 24 * 3600
    os.utime(recent, (day_ago, day_ago))
    keep_dir, keep_folder = config.CACHE_DIR, kernel_cache.FOLDER
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    monkeypatch.setenv("NUMBA_CACHE_DIR", "")
    try:
        folder = kernel_cache.configure()
        assert folder == tmp_path / (FOLDER_PREFIX + source_key())
        assert folder.is_dir() and not stale.exists() and recent.is_dir()
        assert config.CACHE_DIR == str(folder) and os.environ["NUMBA_CACHE_DIR"] == str(folder)
    finally:
        config.CACHE_DIR = keep_dir
        kernel_cache.FOLDER = keep_folder


def test_the_first_compilation_is_announced_once() -> None:
    said: list[str] = []
    listener = announce_compilation(said.append)
    try:
        compile_fresh_kernels()
    finally:
        event.unregister("numba:compile", listener)
    assert len(said) == 1 and "compiling the filter kernels" in said[0]


def _interleaved_saves(tmp_path: Path, save) -> dict:  # type: ignore[no-untyped-def]
    """Two threads save two keys to one numba cache index, the first held between its read
    of the index and its writes until the second has read it too (or 1 s has passed: a
    lock keeps the second out). Returns {key: the data each key loads}."""
    import threading

    from numba.core.caching import IndexDataCacheFile

    files = [IndexDataCacheFile(str(tmp_path), "kernel", "stamp") for _ in range(2)]
    second_read = threading.Event()
    original_load = IndexDataCacheFile._load_index

    def held_load(self):  # type: ignore[no-untyped-def]
        out = original_load(self)
        if self is files[0]:
            second_read.wait(1.0)
        else:
            second_read.set()
        return out

    files[0]._load_index = held_load.__get__(files[0])
    files[1]._load_index = held_load.__get__(files[1])
    first = threading.Thread(target=save, args=(files[0], "ekf", b"ekf code"))
    first.start()
    time.sleep(0.1)
    second = threading.Thread(target=save, args=(files[1], "ukf", b"ukf code"))
    second.start()
    first.join()
    second.join()
    reader = IndexDataCacheFile(str(tmp_path), "kernel", "stamp")
    return {key: reader.load(key) for key in ("ekf", "ukf")}


def test_cache_saves_are_exclusive(tmp_path: Path) -> None:
    """numba's save reads the index, picks a free data file and writes both with no lock:
    two saves interleaved lose a key or cross their data (negative control, numba's own
    save); with :func:`kernel_cache.lock_saves` each key loads its own data."""
    from numba.core import caching

    assert kernel_cache.lock_saves(caching)             # configure() installed it already
    locked = caching.IndexDataCacheFile.save
    assert locked.locked_by_rangeproc
    raw = locked.__closure__[next(i for i, name in enumerate(locked.__code__.co_freevars)
                                  if name == "original")].cell_contents
    (tmp_path / "raw").mkdir()
    (tmp_path / "locked").mkdir()
    assert _interleaved_saves(tmp_path / "raw", raw) != {"ekf": b"ekf code", "ukf": b"ukf code"}
    assert _interleaved_saves(tmp_path / "locked", locked) == {"ekf": b"ekf code",
                                                               "ukf": b"ukf code"}


_FACTORY = '''
import sys
from numba import njit
from rangeproc.kernel_cache import specialisation

def make(c, named):
    C = c
    def kern(x):
        return x + C
    return njit(kern if not named else specialisation(kern, "plus", c))

kernel = make(int(sys.argv[1]), sys.argv[2] == "1")
kernel(0)
print(next(iter(kernel.overloads.values())).fndesc.mangled_name)
'''


def test_specialisations_compiled_in_two_processes_get_two_names(tmp_path: Path) -> None:
    """numba names a compiled function by its qualified name and a per-process counter, and
    a cached one keeps that name: two specialisations of one factory, each compiled first
    in its own process, get the same name (negative control), and a process that loaded
    both from the cache ran the first one's code for the second (main's forward loop:
    EKF cached, UKF cached by a process that had loaded the EKF, both loaded: "returned a
    result with an exception set"). :func:`kernel_cache.specialisation` names them apart."""
    import subprocess
    import sys

    script = tmp_path / "factory.py"
    script.write_text(_FACTORY)

    def name(c: int, named: bool) -> str:
        out = subprocess.run([sys.executable, str(script), str(c), "1" if named else "0"],
                             capture_output=True, text=True, check=True,
                             env=dict(os.environ, PYTHONPATH=str(ROOT.parent)))
        return out.stdout.strip().splitlines()[-1]

    assert name(1, False) == name(2, False)
    assert name(1, True) != name(2, True)
