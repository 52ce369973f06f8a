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
STAMPED_MODULES = (*COMPILED_MODULES, "simulation/_sampling.py", "_layout.py")

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

try:
    from numba.core.caching import CacheImpl, IndexDataCacheFile, InTreeCacheLocator
except ImportError:  # pragma: no cover - numba without these names: keep its own stamps
    CacheImpl = IndexDataCacheFile = InTreeCacheLocator = None  # type: ignore[assignment,misc]

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
