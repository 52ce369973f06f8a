"""One on-disk cache stamp for all compiled modules of hydropwa.

numba keys each cached function on the contents of its *own* source file. The kernels
(``simulation/_march.py`` and the modules it calls, see ``simulation/_kernel.py``) inline
the physics of ``components/_physics.py`` and the signal code of ``simulation/_signals.py``
across files, and compile in the slot and state indices of
the layout table ``_layout.py``; after a change to one of those files alone
(an edit in a development checkout, or an upgrade that touches only that file) numba
would load the old kernels from ``__pycache__`` and silently run the old physics.

:class:`PackageCacheLocator` keeps numba's in-tree cache folders but stamps every
entry of these modules with one hash over all of them, so a change to any one of them
recompiles all. Each compiled module imports this module before its first
``@njit(cache=True)``. With a numba whose caching internals differ the locator is not
installed and numba's own per-file stamps apply (see docs/architecture_performance.md).

**Shipped entries.** The package carries compiled entries for a generic x86-64 CPU in
``_prebuilt/`` (built by ``python -m hydropwa.simulation._prebuild`` from the current sources;
``tests/performance/test_prebuilt.py`` fails when they are stale). numba keys an entry on the
host CPU's name and features, so it would never look at them on the user's machine; where the
in-tree cache has no entry, :func:`_load_prebuilt` looks one up in ``_prebuilt/`` under the generic
CPU's key (same signature, same bytecode and closure hashes, same source stamp, same numba and
Python versions — anything else is a miss). Generic x86-64 machine code runs on every x86-64 CPU;
on another architecture, Python or numba the key differs and the kernel compiles as before.
``HYDROPWA_PREBUILT=0`` ignores the shipped entries (every kernel then compiles for this CPU).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

#: The modules holding ``@njit(cache=True)`` functions, relative to the package.
COMPILED_MODULES = (
    "components/_physics.py",
    "simulation/_signals.py",
    "simulation/_kcommon.py",
    "simulation/_rhs_full.py",
    "simulation/_rhs_load.py",
    "simulation/_rhs_chamber.py",
    "simulation/_rhs_lines.py",
    "simulation/_dispatch.py",
    "simulation/_rosenbrock.py",
    "simulation/_stepcontrol.py",
    "simulation/_outputs.py",
    "simulation/_march.py",
    "simulation/_entries.py",
    "simulation/_controller.py",
    "monitor/_residuals.py",  # its valve terms inline the physics of components/_physics.py
)

#: What the compiled code depends on: those modules, the controller-sampling hooks (numba
#: overloads whose implementations compile into the step loop) and the layout table whose slot
#: and state indices the kernels compile in as constants.
STAMPED_MODULES = (*COMPILED_MODULES, "simulation/_sampling.py", "_layout.py", "_layout_law.py")

_ROOT = Path(__file__).resolve().parent
_FILES = frozenset(str(_ROOT / m) for m in COMPILED_MODULES)


def source_stamp(root: str | os.PathLike = _ROOT) -> bytes:
    """SHA-256 over the compiled modules' and the layout table's sources under ``root``."""
    h = hashlib.sha256()
    for m in STAMPED_MODULES:
        h.update(m.encode())
        h.update((Path(root) / m).read_bytes())
    return h.digest()


_STAMP = source_stamp()

#: The shipped entries' folder (see the module's docstring).
PREBUILT_DIR = _ROOT / "_prebuilt"
#: Environment variable set by the build (``hydropwa.simulation._prebuild``): ``1`` writes the
#: entries compiled in the process to :data:`PREBUILT_DIR` (with ``NUMBA_CPU_NAME=generic``).
ENV_PREBUILD = "HYDROPWA_PREBUILD"
#: The CPU name and features of the shipped entries' key (numba's ``NUMBA_CPU_NAME=generic``).
GENERIC_CPU = ("generic", "")


def prebuilt_path(py_file: str | os.PathLike) -> Path:
    """The folder of the shipped entries of the compiled module ``py_file``."""
    return PREBUILT_DIR / Path(os.path.realpath(py_file)).parent.relative_to(_ROOT)


try:
    from numba.core.caching import Cache, CacheImpl, IndexDataCacheFile, InTreeCacheLocator
except ImportError:  # pragma: no cover - numba without these names: keep its own stamps
    Cache = CacheImpl = IndexDataCacheFile = InTreeCacheLocator = None  # type: ignore[assignment,misc]

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: no inter-process lock
    fcntl = None  # type: ignore[assignment]


def _lock_saves() -> bool:
    """Make numba's cache save (read index, pick a data file, write both) one locked step.

    numba saves a new entry by reading the index, taking the first free data-file name and
    writing the index and then the data, with no lock. Two processes that compile different
    overloads of one function at once (the background warm-up compiles the other models'
    kernels while this process compiles its own; ``_march`` and ``_jacobian`` have one overload
    per model kind) both take ``….1.nbc``; the last index and the last data written can belong
    to different overloads, and a later process then loads one overload's machine code for
    another's signature (numba does not check; ``tests/performance/test_jit_cache.py`` forces the
    interleaving). An exclusive ``flock`` on ``<index>.lock`` around the save orders them.
    """
    if IndexDataCacheFile is None or fcntl is None:  # pragma: no cover
        return False
    save = IndexDataCacheFile.save
    if getattr(save, "_hydropwa_locked", False):
        return True

    def locked_save(self, key, data):
        with open(self._index_path + ".lock", "a") as fh:
            fcntl.flock(fh, fcntl.LOCK_EX)
            try:
                save(self, key, data)
            finally:
                fcntl.flock(fh, fcntl.LOCK_UN)

    locked_save._hydropwa_locked = True  # type: ignore[attr-defined]
    IndexDataCacheFile.save = locked_save  # type: ignore[method-assign]
    return True


#: Whether numba's cache saves are serialised across processes (:func:`_lock_saves`).
SAVES_LOCKED = _lock_saves()


if InTreeCacheLocator is not None:

    class PackageCacheLocator(InTreeCacheLocator):
        """numba's in-tree cache locator with a stamp over all compiled hydropwa modules."""

        @classmethod
        def from_function(cls, py_func, py_file):
            if os.path.realpath(py_file) not in _FILES:
                return None
            return super().from_function(py_func, py_file)

        def __init__(self, py_func, py_file):
            super().__init__(py_func, py_file)
            self.prebuilt_path = str(prebuilt_path(py_file))
            if os.environ.get(ENV_PREBUILD) == "1":  # the build writes the shipped entries
                self._cache_path = self.prebuilt_path

        def get_source_stamp(self):
            return _STAMP

    def _install() -> bool:
        classes = getattr(CacheImpl, "_locator_classes", None)
        if not isinstance(classes, list):  # pragma: no cover
            return False
        if PackageCacheLocator not in classes:
            # after NUMBA_CACHE_DIR's locator (a user's explicit choice), before the in-tree one
            user = [i for i, c in enumerate(classes) if c.__name__ == "UserProvidedCacheLocator"]
            classes.insert(user[0] + 1 if user else 0, PackageCacheLocator)
        return True

    INSTALLED = _install()
else:  # pragma: no cover
    PackageCacheLocator = None  # type: ignore[assignment,misc]
    INSTALLED = False


def _prebuilt_file(cache):
    """The shipped entries' index of numba ``cache``'s function, or None where it has none."""
    py_file = getattr(getattr(cache, "_py_func", None), "__code__", None)
    if py_file is None or IndexDataCacheFile is None:
        return None
    py_file = os.path.realpath(py_file.co_filename)
    if py_file not in _FILES:  # not hydropwa's (or NUMBA_CACHE_DIR's copy of) a kernel
        return None
    path = prebuilt_path(py_file)
    if not path.is_dir():
        return None
    return IndexDataCacheFile(
        cache_path=path, filename_base=cache._impl.filename_base, source_stamp=_STAMP
    )


def _generic_key(cache, sig, codegen):
    """numba's index key of ``sig`` with the generic CPU in place of the host's."""
    sig_key, magic, code = cache._index_key(sig, codegen)
    return (sig_key, (magic[0], *GENERIC_CPU), code)


def holds_prebuilt(cache) -> bool:
    """Whether the shipped entries hold any current entry of numba ``cache``'s function."""
    if not PREBUILT_LOADS:
        return False
    try:
        index = _prebuilt_file(cache)
        return index is not None and bool(index._load_index())
    except Exception:  # pragma: no cover - numba internals differ
        return False


def _load_prebuilt() -> bool:
    """Make numba's cache fall back to the shipped generic-CPU entries (module docstring)."""
    if Cache is None:  # pragma: no cover
        return False
    load = Cache._load_overload
    if getattr(load, "_hydropwa_prebuilt", False):
        return True

    def load_overload(self, sig, target_context):
        data = load(self, sig, target_context)
        if data is not None or not self._enabled:
            return data
        index = _prebuilt_file(self)
        if index is None:
            return None
        found = index.load(_generic_key(self, sig, target_context.codegen()))
        return None if found is None else self._impl.rebuild(target_context, found)

    load_overload._hydropwa_prebuilt = True  # type: ignore[attr-defined]
    Cache._load_overload = load_overload  # type: ignore[method-assign]
    return True


#: Environment variable: ``0`` ignores the shipped entries (every kernel compiles for this CPU).
ENV_PREBUILT = "HYDROPWA_PREBUILT"
#: Whether the shipped entries are looked up (a build writes them instead).
PREBUILT_LOADS = (
    os.environ.get(ENV_PREBUILD) != "1"
    and os.environ.get(ENV_PREBUILT, "1").strip() != "0"
    and INSTALLED
    and _load_prebuilt()
)
