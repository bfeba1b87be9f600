"""Where the compiled kernels are cached, keyed to the source they were compiled from.

rangeproc's filters, smoothers and editing loops are compiled by numba on first use and
cached on disk, so only the first run of an installation pays the compilation. numba keys a
cached kernel on its own file's modification time only: a kernel whose *helper* in another
module changed would be loaded stale. rangeproc therefore keys the whole cache folder to
the source of every module that compiled code can reach: the modules that define compiled
functions and, transitively, the rangeproc modules they import (where their helpers and
constants live). An edit to any of them selects a fresh folder; nothing needs cleaning.

The folder is ``<base>/kernels-<key>``, with ``<base>`` the first of:
``RANGEPROC_CACHE_DIR``; ``NUMBA_CACHE_DIR``; ``$XDG_CACHE_HOME/rangeproc``;
``~/.cache/rangeproc``. :func:`configure` (run when ``rangeproc`` is imported, before any
kernel module) points numba there, marks the folder as used, and removes the folders of other
keys under the same base that no run has used for two weeks (:data:`UNUSED_S`).
:func:`announce_compilation` prints one line when the first kernel of a run is compiled
rather than loaded (:func:`compilation_announced`: while a command runs).

numba saves a new cache entry by reading the function's index, picking the first free data
file number, writing the index, then the data, with no lock: two processes that compile two
specialisations of one function at once (the pipeline's forked workers, or ``make demo``
beside a test run in the same checkout) can both pick the same number, so that one
specialisation's entry is lost and the index may map the other to the wrong compiled code.
:func:`configure` therefore makes each save exclusive (:func:`lock_saves`: an ``flock`` on
``<index>.lock`` around numba's ``IndexDataCacheFile.save``), installed when numba's
caching module is first imported.
"""
from __future__ import annotations

import hashlib
import importlib.abc
import importlib.util
import os
import re
import shutil
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

#: Environment variable naming the base folder of the kernel cache.
CACHE_ENV = "RANGEPROC_CACHE_DIR"
#: Prefix of the keyed cache folder under the base.
FOLDER_PREFIX = "kernels-"
#: Hex digits of the source key in the folder name.
KEY_DIGITS = 16

PACKAGE_ROOT = Path(__file__).resolve().parent


def _module_file(root: Path, module: str) -> Path | None:
    """The source file of ``rangeproc.<...>`` module ``module`` under ``root`` (the package
    folder), or None when it is not a module of the package."""
    parts = module.split(".")
    if parts[0] != root.name:
        return None
    base = root.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


_FROM = re.compile(r"^\s*from\s+(rangeproc[\w.]*)\s+import\s+(\([^)]*\)|[^\n]*)", re.M)
_IMPORT = re.compile(r"^\s*import\s+(rangeproc[\w.]*)", re.M)
_USES_NUMBA = re.compile(r"^\s*(from\s+numba[\w.]*\s+import|import\s+numba)", re.M)


def _imports(root: Path, text: str) -> set[Path]:
    """The package's source files that the source ``text`` imports (absolute imports, the
    package's convention), including submodules named in a ``from ... import`` list."""
    out: set[Path] = set()
    names = [m.group(1) for m in _IMPORT.finditer(text)]
    for m in _FROM.finditer(text):
        names.append(m.group(1))
        for item in m.group(2).strip("()").split(","):
            word = item.split("#")[0].split(" as ")[0].strip()
            if word.isidentifier():
                names.append(f"{m.group(1)}.{word}")
    for name in names:
        f = _module_file(root, name)
        if f is not None:
            out.add(f)
    return out


def kernel_sources(root: Path = PACKAGE_ROOT) -> list[Path]:
    """Every source file compiled code can reach: the modules that import numba and,
    transitively, the package modules they import. Sorted by path."""
    texts = {p: p.read_text(encoding="utf-8") for p in root.rglob("*.py")}
    todo = [p for p, text in texts.items() if _USES_NUMBA.search(text)]
    seen: set[Path] = set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        text = texts.get(path)
        if text is not None:
            todo.extend(_imports(root, text) - seen)
    return sorted(seen)


def source_key(root: Path = PACKAGE_ROOT) -> str:
    """Hex digest of the kernel sources' paths and contents and the numba version."""
    h = hashlib.sha256()
    try:
        from importlib.metadata import version
        h.update(version("numba").encode())
    except Exception:  # noqa: BLE001 - an unknown version still keys on the sources
        pass
    for path in kernel_sources(root):
        h.update(str(path.relative_to(root)).encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:KEY_DIGITS]


def default_base(environ: Mapping[str, str] = os.environ) -> Path:
    """The cache's base folder when neither environment variable names one."""
    xdg = environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "rangeproc"


def cache_folder(key: str, environ: Mapping[str, str] = os.environ) -> Path:
    """The keyed folder for ``key`` (module docstring); an environment whose
    ``NUMBA_CACHE_DIR`` already is that folder (a child process) keeps it."""
    leaf = FOLDER_PREFIX + key
    numba_dir = environ.get("NUMBA_CACHE_DIR")
    if numba_dir and Path(numba_dir).name == leaf:
        return Path(numba_dir)
    base = environ.get(CACHE_ENV) or numba_dir
    return (Path(base) if base else default_base(environ)) / leaf


#: A key's folder unused (no run started with it) for this many seconds is removed: two
#: weeks, so that checkouts or installations of different versions side by side keep theirs.
UNUSED_S = 14 * 24 * 3600.0


def _prune(folder: Path, now: float) -> None:
    """Remove the other keys' folders beside ``folder`` unused for :data:`UNUSED_S`."""
    try:
        for other in folder.parent.glob(FOLDER_PREFIX + "*"):
            if other != folder and other.is_dir() and other.stat().st_mtime < now - UNUSED_S:
                shutil.rmtree(other, ignore_errors=True)
    except OSError:
        pass


#: The folder :func:`configure` chose (None before it ran).
FOLDER: Path | None = None


def configure() -> Path:
    """Point numba's cache at the keyed folder (before any kernel module is imported; also
    when numba is already imported), mark it used, and prune the other keys' folders unused
    for :data:`UNUSED_S`. Returns the folder."""
    global FOLDER
    folder = cache_folder(source_key())
    os.environ["NUMBA_CACHE_DIR"] = str(folder)       # child processes and numba's reload
    config = sys.modules.get("numba.core.config")
    if config is not None:
        config.CACHE_DIR = str(folder)
    new = not folder.is_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)                                  # in use: not pruned by others
    except OSError:
        pass                          # numba falls back to its own locations
    if new:
        _prune(folder, time.time())
    _lock_numba_saves()
    FOLDER = folder
    return folder


def specialisation(py_func: Callable, *parts: object) -> Callable:
    """``py_func`` (a function a factory makes, one per specialisation, before numba compiles
    it) named for its specialisation: ``parts`` appended to its ``__qualname__``.

    numba names a compiled function by its qualified name and a counter of the compiling
    process, and a cached one keeps that name. Two specialisations of one factory function
    compiled in different processes can get the same name; a process that loads both from
    the cache then runs the first one's code for the second (a UKF loop cached after an EKF
    loop, run after it: "returned a result with an exception set"). A name per
    specialisation keeps them apart (and gives each its own cache index)."""
    tag = "_".join(re.sub(r"\W", "_", str(p)) for p in parts)
    py_func.__qualname__ = f"{py_func.__qualname__}_{tag}"
    py_func.__name__ = f"{py_func.__name__}_{tag}"
    return py_func


#: Suffix of the lock file beside a numba cache index that serialises the index's updates.
LOCK_SUFFIX = ".lock"


def lock_saves(caching: object) -> bool:
    """Wrap ``caching.IndexDataCacheFile.save`` (``caching``: the module
    ``numba.core.caching``) so that each save holds an exclusive ``flock`` on the index's
    lock file across its read of the index, its choice of data file and both writes (module
    docstring). Idempotent; False where ``fcntl`` is missing (not POSIX: numba's own
    behaviour) or numba's class has no ``save``."""
    try:
        import fcntl
    except ImportError:
        return False
    cls = getattr(caching, "IndexDataCacheFile", None)
    original = getattr(cls, "save", None)
    if original is None:
        return False
    if getattr(original, "locked_by_rangeproc", False):
        return True

    def save(self, key, data):  # type: ignore[no-untyped-def]
        with open(self._index_path + LOCK_SUFFIX, "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                original(self, key, data)
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)

    save.locked_by_rangeproc = True  # type: ignore[attr-defined]
    save.__doc__ = original.__doc__
    cls.save = save
    return True


class _LockOnImport(importlib.abc.MetaPathFinder):
    """One-shot import hook: :func:`lock_saves` as soon as ``numba.core.caching`` is
    executed (importing numba at ``import rangeproc`` would slow every command)."""

    NAME = "numba.core.caching"

    def find_spec(self, name, path, target=None):  # type: ignore[no-untyped-def]
        if name != self.NAME:
            return None
        if self in sys.meta_path:
            sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        loader = getattr(spec, "loader", None)
        if loader is None or not hasattr(loader, "exec_module"):
            return spec
        exec_module = loader.exec_module

        def exec_and_lock(module):  # type: ignore[no-untyped-def]
            exec_module(module)
            lock_saves(module)

        loader.exec_module = exec_and_lock
        return spec


def _lock_numba_saves() -> None:
    """:func:`lock_saves` now if numba's caching module is loaded, else at its import."""
    caching = sys.modules.get(_LockOnImport.NAME)
    if caching is not None:
        lock_saves(caching)
    elif not any(isinstance(f, _LockOnImport) for f in sys.meta_path):
        sys.meta_path.insert(0, _LockOnImport())


def announce_compilation(say: Callable[[str], None]) -> object:
    """Call ``say`` with one line the first time, in this process, that a kernel is compiled
    rather than loaded from the cache (the first run of an installation, or of a filter
    family not run before). Returns the registered numba event listener (for
    ``numba.core.event.unregister``)."""
    from numba.core import event

    class _Once(event.Listener):
        done = False

        def on_start(self, ev: event.Event) -> None:
            if not self.done:
                self.done = True
                say("compiling the filter kernels for their first run (once; cached in "
                    f"{FOLDER or os.environ.get('NUMBA_CACHE_DIR', 'the numba cache')})")

        def on_end(self, ev: event.Event) -> None:
            pass

    listener = _Once()
    event.register("numba:compile", listener)
    return listener


@contextmanager
def compilation_announced(say: Callable[[str], None]) -> Iterator[None]:
    """:func:`announce_compilation` for the duration of the ``with`` block: ``say`` is
    called at most once, and the listener is removed afterwards (a later command in the same
    process announces its own first compilation, and no stale ``say`` is left behind)."""
    from numba.core import event

    listener = announce_compilation(say)
    try:
        yield
    finally:
        event.unregister("numba:compile", listener)
