"""File writing shared by every writer of the package: atomic, no-clobber, locked.

- :func:`atomic_path` / :func:`atomic_write_text` / :func:`atomic_write_bytes`: files are
  written to a temporary file in the destination folder and renamed into place, so an
  interrupted run never leaves a half-written file behind. With ``overwrite=False`` the
  final step is a hard link, which fails atomically when the target appeared meanwhile.
- :func:`check_output`: refuse an existing file, a non-empty folder, or a file where a
  folder is expected (and the reverse) unless ``force``.
- :func:`output_lock`: one writer per output folder (a lock file held with ``flock``; a
  lock left by a killed process is stale and taken over), which also removes the
  temporary files such a process left behind (:func:`remove_stale_temps`).
- :func:`target_lock`: one writer per output file or folder (every command's outputs, taken
  by the CLI before the command runs), so two runs into one ``--out`` cannot both succeed.
- :func:`scratch_folder`: the package's temporary folders (``hydropwa-KIND-*``, locked while
  used); those a killed run left are removed by the next run (:func:`remove_stale_scratch`).
- :func:`os_error_message`: one line naming the path and what to do, for every ``OSError``.
- :func:`read_text` / :func:`read_bytes` / :func:`check_read_size`: every file the package
  reads, with a size ceiling per kind of file (:data:`READ_LIMITS`) and one decoding rule
  (UTF-8, a byte-order mark allowed); both refused in one line in the caller's error class.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import socket
import tempfile
import time
from collections.abc import Iterator, Mapping
from pathlib import Path

from ._errors import HydropwaError, OutputExistsError, OutputLockedError

__all__ = [
    "atomic_folder",
    "atomic_path",
    "atomic_write_text",
    "atomic_write_bytes",
    "check_output",
    "output_lock",
    "target_lock",
    "TARGET_LOCK_SUFFIX",
    "remove_stale_temps",
    "os_error_message",
    "remove_stale_scratch",
    "scratch_folder",
    "SCRATCH_PREFIX",
    "LOCK_NAME",
    "READ_LIMITS",
    "check_read_size",
    "decode_text",
    "human_bytes",
    "read_bytes",
    "read_text",
]

#: Name of the lock file that :func:`output_lock` keeps in an output folder.
LOCK_NAME = ".hydropwa.lock"

#: Temporary files of :func:`atomic_path`: ``.{name}.{8 random chars}.tmp{suffix}``.
_TEMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp(\.[A-Za-z0-9]+)?$")


def _named(exc: OSError, path: Path) -> OSError:
    """The same OSError, naming ``path`` (the target) instead of a temporary file."""
    if exc.errno is None:
        return exc
    new = type(exc)(exc.errno, exc.strerror or os.strerror(exc.errno), str(path))
    new.__cause__ = exc
    return new


@contextlib.contextmanager
def atomic_path(
    path: str | os.PathLike, suffix: str | None = None, *, overwrite: bool = True
) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` on success.

    Use for writers that need a file name (pandas, pyarrow, matplotlib)::

        with atomic_path("out.parquet") as tmp:
            df.to_parquet(tmp)

    Parameters
    ----------
    path : path-like
        The target file.
    suffix : str, optional
        Suffix of the temporary file (default: the target's, so writers that pick the
        format from the name pick the right one).
    overwrite : bool
        Replace an existing target (default). With False, an existing target raises
        :class:`~hydropwa.OutputExistsError` and nothing is changed, even if the target
        appears while the file is written.

    Raises
    ------
    OSError
        Naming the target (not the temporary file): read-only file system, disk full, ...
    """
    path = Path(path)
    if not overwrite and os.path.lexists(path):
        raise OutputExistsError(_exists_message(path))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        sfx = suffix if suffix is not None else path.suffix
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{sfx}", dir=path.parent)
        os.close(fd)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual permissions
    except FileExistsError as exc:  # a file where a folder of the path should be
        raise _named(exc, path.parent) from None
    except NotADirectoryError as exc:
        raise _named(exc, path.parent) from None
    except OSError as exc:
        raise _named(exc, path) from None
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        if overwrite:
            os.replace(tmp_path, path)
        else:
            try:
                os.link(tmp_path, path)  # fails if the target exists, atomically
            except FileExistsError:
                raise OutputExistsError(_exists_message(path)) from None
            tmp_path.unlink()
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        if isinstance(exc, FileExistsError) and not exc.errno:
            raise
        raise _named(exc, path) from None
    except BaseException:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        raise


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary folder beside ``path``; it becomes ``path`` when the block succeeds.

    A writer that fails half-way leaves nothing at ``path`` (the temporary folder is removed).
    An existing empty folder is replaced; a non-empty one only with ``overwrite`` (else
    :class:`~hydropwa.OutputExistsError` before anything is written). The rename is atomic;
    replacing an existing folder is two renames (the old one is moved aside, then deleted).
    """
    import shutil  # deferred: only folder writers need it

    path = Path(path)
    check_output(path, overwrite, folder=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    try:
        yield tmp
        old = None
        if path.is_dir():
            old = path.with_name(f"{tmp.name}.old")
            os.replace(path, old)
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes, *, overwrite: bool = True) -> Path:
    """Write ``data`` to ``path`` atomically and return the path (see :func:`atomic_path`)."""
    with atomic_path(path, overwrite=overwrite) as tmp:
        try:
            with open(tmp, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        except OSError as exc:
            raise _named(exc, Path(path)) from None
    return Path(path)


def atomic_write_text(
    path: str | os.PathLike, text: str, encoding: str = "utf-8", *, overwrite: bool = True
) -> Path:
    """Write ``text`` to ``path`` atomically and return the path (see :func:`atomic_path`)."""
    return atomic_write_bytes(path, text.encode(encoding), overwrite=overwrite)


# ----------------------------------------------------------------------------- targets
def write_text_files(
    directory: str | os.PathLike, texts: Mapping[str, str], *, overwrite: bool = False
) -> Path:
    """Write ``texts`` (file name → text) into ``directory``, each file atomically; a folder
    that holds files is refused (:func:`check_output`) unless ``overwrite``. Returns the folder.
    """
    directory = Path(directory)
    check_output(directory, overwrite, folder=True)
    directory.mkdir(parents=True, exist_ok=True)
    for name, text in texts.items():
        atomic_write_text(directory / name, text)
    return directory


def overwrite_flag(overwrite: bool, force: bool | None, where: str) -> bool:
    """The library's one overwrite keyword: ``overwrite``; ``force=`` of older releases still works.

    ``force`` (the CLI's word, which some writers took before) is honoured with a
    ``DeprecationWarning`` naming ``where``, so a caller sees the one keyword to use.
    """
    if force is None:
        return bool(overwrite)
    import warnings  # deferred: only for the old keyword

    warnings.warn(
        f"{where}(force=...) is renamed {where}(overwrite=...); force= will be removed",
        DeprecationWarning,
        stacklevel=3,
    )
    return bool(force or overwrite)


def _exists_message(path: Path, option: str | None = None) -> str:
    what = "folder" if path.is_dir() else "file"
    alt = f"choose another {option}" if option else "choose another path"
    return f"{path}: the {what} exists; pass --force (overwrite=True) to overwrite it, or {alt}"


def check_output(
    path: str | os.PathLike,
    force: bool = False,
    *,
    folder: bool = False,
    option: str | None = None,
    files: tuple[str, ...] | None = None,
) -> None:
    """Refuse to write over an existing output unless ``force``.

    Parameters
    ----------
    path : path-like
        The output file, or folder with ``folder=True``.
    force : bool
        Allow replacing an existing file / writing into a non-empty folder.
    folder : bool
        The output is a folder: an empty folder is fine, a non-empty one needs ``force``.
    option : str, optional
        The command-line option that named the path (for the message).
    files : tuple of str, optional
        With ``folder=True``: the names (glob patterns) the writer puts into the folder; only
        these need ``force``, so one folder can collect the figures of several commands.
        Default: any entry makes the folder occupied.

    Raises
    ------
    OutputExistsError
        The target exists (a file, or a non-empty folder) and ``force`` is False.
    HydropwaError
        A folder is where a file is expected, or a file where a folder is expected
        (also for any parent folder of the path): ``force`` does not change this.
    """
    path = Path(path)
    where = f"{option} {path}" if option else str(path)
    for parent in path.parents:
        if parent.exists() and not parent.is_dir():
            raise HydropwaError(
                f"{where}: {parent} is a file, where a folder is expected; remove it or choose "
                "another path"
            )
    if folder:
        if path.exists() and not path.is_dir():
            raise HydropwaError(
                f"{where}: is a file, where a folder is expected; remove it or choose another path"
            )
        if force or not path.is_dir():
            return
        if files is None:
            taken = sorted(p.name for p in path.iterdir() if p.name != LOCK_NAME)
        else:
            taken = sorted({p.name for pattern in files for p in path.glob(pattern)})
        if taken:
            shown = ", ".join(taken[:3]) + (", ..." if len(taken) > 3 else "")
            raise OutputExistsError(
                f"{where}: the folder already holds {shown}; pass --force (overwrite=True) to "
                "overwrite, or choose another folder"
            )
        return
    if path.is_dir():
        raise HydropwaError(f"{where}: is a folder, where a file is expected; give a file name")
    if not force and os.path.lexists(path):
        raise OutputExistsError(_exists_message(path, option))


# ----------------------------------------------------------------------------- locks
def remove_stale_temps(
    folder: str | os.PathLike, recursive: bool = True, target: str | None = None
) -> list[Path]:
    """Remove the temporary files of :func:`atomic_path` that a killed writer left.

    Call only while no other writer can be active in ``folder`` (under
    :func:`output_lock`). With ``target``, only the temporary files of that file name.
    Returns the removed paths.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return []
    pattern = f".{target}.*" if target is not None else ".*"
    found = folder.rglob(pattern) if recursive else folder.glob(pattern)
    removed = []
    for p in found:
        if _TEMP.match(p.name) and p.is_file() and not p.is_symlink():
            with contextlib.suppress(OSError):
                p.unlink()
                removed.append(p)
    return removed


def _lock_owner(path: Path) -> str:
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
        return f"process {info['pid']} on {info['host']} since {info['started']}"
    except (OSError, ValueError, KeyError, TypeError):
        return "another process"


@contextlib.contextmanager
def output_lock(
    folder: str | os.PathLike,
    command: str = "hydropwa",
    *,
    name: str = LOCK_NAME,
    clean: bool = True,
    target: Path | None = None,
) -> Iterator[Path]:
    """Hold the lock of an output folder for the duration of the block.

    The lock file ``folder/.hydropwa.lock`` (or ``name``) records the owner (pid, host,
    start) and is held with ``flock``, which the kernel releases when the owner dies: a lock
    left by a killed run is stale and is taken over. With ``clean``, taking the lock removes
    the temporary files of earlier, interrupted writers in the folder tree
    (:func:`remove_stale_temps`).

    With ``target`` (see :func:`target_lock`) the lock guards that one output in
    ``folder`` and the message names it.

    Raises
    ------
    OutputLockedError
        Another live process holds the lock.
    """
    import fcntl  # deferred: POSIX only

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    for _attempt in range(5):
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise _named(exc, path) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise OutputLockedError(_locked_message(folder, path, target)) from None
        except OSError:  # a file system without flock: fall back to the pid check
            os.close(fd)
            if _pid_lock_taken(path):
                raise OutputLockedError(_locked_message(folder, path, target)) from None
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if not same:  # the previous owner removed the file between our open and flock
            os.close(fd)
            continue
        break
    else:  # pragma: no cover - five races in a row
        raise OutputLockedError(f"{folder}: could not take the lock {path}; try again")
    try:
        info = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "command": command,
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        }
        os.ftruncate(fd, 0)
        os.write(fd, (json.dumps(info) + "\n").encode())
        if clean:
            remove_stale_temps(folder)
    except OSError as exc:
        os.close(fd)
        raise _named(exc, path) from None
    try:
        yield path
    finally:
        with contextlib.suppress(OSError):
            path.unlink()
        os.close(fd)


def _locked_message(folder: Path, path: Path, target: Path | None) -> str:
    if target is not None:
        return (
            f"{target}: another run writes this output ({_lock_owner(path)}); wait for it to "
            f"finish or choose another name (if no run is active, delete {path})"
        )
    return (
        f"{folder}: another run writes into this folder ({_lock_owner(path)}); wait for it to "
        f"finish or choose another folder (if no run is active, delete {path})"
    )


#: Ending of the lock file of one output (:func:`target_lock`): ``.{name}.hydropwa.lock``.
TARGET_LOCK_SUFFIX = ".hydropwa.lock"


@contextlib.contextmanager
def target_lock(path: str | os.PathLike, command: str = "hydropwa") -> Iterator[Path | None]:
    """Hold the lock of one output, a file or a folder, for the duration of the block.

    The lock file ``.{name}.hydropwa.lock`` beside the output (held as :func:`output_lock`
    holds a folder's) makes a second run that writes the same output, at the same time, fail
    with one line instead of silently replacing the first one's result; a run that comes
    after finds the output and needs ``--force``. Taking it removes the temporary files an
    interrupted writer of this output left (:func:`remove_stale_temps`). Folders created for
    the lock are removed again if they are still empty at the end. Where no lock file can be
    made (a read-only folder, a file where a folder should be) the block runs unlocked, so
    the writer reports the problem in its own words.

    Raises
    ------
    OutputLockedError
        Another live process writes the same output.
    """
    target = Path(path).resolve()
    parent = target.parent
    if not target.name or any(p.exists() and not p.is_dir() for p in (parent, *parent.parents)):
        yield None
        return
    created = [p for p in (parent, *parent.parents) if not p.exists()]
    stack = contextlib.ExitStack()
    try:
        try:
            lock: Path | None = stack.enter_context(
                output_lock(
                    parent,
                    command,
                    name=f".{target.name}{TARGET_LOCK_SUFFIX}",
                    clean=False,
                    target=Path(path),
                )
            )
        except OSError:
            lock = None
        with stack:
            if lock is not None:
                remove_stale_temps(parent, recursive=False, target=target.name)
            yield lock
    finally:
        for p in created:  # innermost first
            with contextlib.suppress(OSError):
                p.rmdir()


def _pid_lock_taken(path: Path) -> bool:
    """Without flock: the lock is taken if it names a live process on this host."""
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
        pid, host = int(info["pid"]), str(info["host"])
    except (OSError, ValueError, KeyError, TypeError):
        return False
    if host != socket.gethostname():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return pid != os.getpid()


# ----------------------------------------------------------------------------- scratch folders
#: Prefix of every temporary folder the package makes (:func:`scratch_folder`).
SCRATCH_PREFIX = "hydropwa-"
#: A scratch folder younger than this [s] is never removed as stale (its owner may be between
#: creating it and taking its lock).
SCRATCH_GRACE_S = 120.0
_SCRATCH_LOCK = ".owner.lock"


def remove_stale_scratch(kind: str, root: str | os.PathLike | None = None) -> list[Path]:
    """Remove the scratch folders of ``kind`` that killed runs left (their lock is free).

    A folder ``{root}/hydropwa-{kind}-*`` is stale when it is older than
    :data:`SCRATCH_GRACE_S` and no live process holds its lock (``flock``, which the kernel
    drops when its holder dies). Returns the removed folders.
    """
    import fcntl  # deferred: POSIX only
    import shutil  # deferred: only to remove a folder

    base = Path(root if root is not None else tempfile.gettempdir())
    removed = []
    now = time.time()
    for folder in base.glob(f"{SCRATCH_PREFIX}{kind}-*"):
        try:
            if not folder.is_dir() or folder.is_symlink():
                continue
            if now - folder.stat().st_mtime < SCRATCH_GRACE_S:
                continue
            fd = os.open(folder / _SCRATCH_LOCK, os.O_RDWR | os.O_CREAT, 0o600)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # held: its owner is alive
            os.close(fd)
            continue
        shutil.rmtree(folder, ignore_errors=True)
        os.close(fd)
        removed.append(folder)
    return removed


@contextlib.contextmanager
def scratch_folder(kind: str, root: str | os.PathLike | None = None) -> Iterator[Path]:
    """A temporary folder ``hydropwa-{kind}-XXXX`` for the block, removed after it.

    Its lock is held while the block runs; a folder left by a run that was killed (so that
    its clean-up never ran) is removed by the next run of the same ``kind``
    (:func:`remove_stale_scratch`).
    """
    import fcntl  # deferred: POSIX only
    import shutil  # deferred: only to remove a folder

    remove_stale_scratch(kind, root)
    folder = Path(tempfile.mkdtemp(prefix=f"{SCRATCH_PREFIX}{kind}-", dir=root))
    fd = os.open(folder / _SCRATCH_LOCK, os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)
        os.close(fd)


# ----------------------------------------------------------------------------- messages
_HINTS = {
    errno.EROFS: "the file system is read-only; choose an output on a writable disk",
    errno.ENOSPC: "no space left on the device; free some space or choose another disk",
    errno.EDQUOT: "the disk quota is exhausted; free some space or choose another disk",
    errno.EACCES: "permission denied; choose a path you may write to (or read)",
    errno.EPERM: "operation not permitted; choose another path",
    errno.ENOENT: "no such file or folder; check the path",
    errno.EEXIST: "a file is where a folder is expected; remove it or choose another path",
    errno.ENOTDIR: "a file is where a folder is expected; remove it or choose another path",
    errno.EISDIR: "is a folder, where a file is expected; give a file name",
    errno.ENAMETOOLONG: "the name is too long; choose a shorter path",
    errno.ELOOP: "too many levels of symbolic links; check the links",
    errno.EMFILE: "too many open files; raise the limit (ulimit -n) or use fewer jobs",
    errno.EIO: "input/output error; check the disk",
    errno.ENOTEMPTY: "the folder is not empty; remove it or choose another path",
}


def os_error_message(exc: OSError) -> str:
    """One line for an ``OSError``: the path(s), what went wrong and what to do."""
    paths = [str(p) for p in (exc.filename, getattr(exc, "filename2", None)) if p is not None]
    where = " -> ".join(paths) if paths else "file system"
    hint = _HINTS.get(exc.errno) if exc.errno is not None else None
    text = hint or (exc.strerror or str(exc) or type(exc).__name__)
    if hint is None and exc.errno is not None:
        text = f"{text} (errno {exc.errno})"
    return " ".join(f"{where}: {text}".split())


# ----------------------------------------------------------------------------- reading
#: The largest file of each kind the package reads [bytes], and what the kind is. A file
#: above its ceiling is refused before it is read (a few hundred times the largest such file
#: the package writes for a real machine, so no genuine file comes near it).
READ_LIMITS: dict[str, tuple[int, str]] = {
    "parameter file": (1_000_000, "a machine's TOML/JSON parameter file (a few kB)"),
    "controller file": (10_000_000, "a controller file (~3 MB for 5000 gain rows)"),
    "manifest": (50_000_000, "a dataset manifest (~300 B per run)"),
    "channel map": (1_000_000, "a channel map (a few kB)"),
    "sweep file": (1_000_000, "a sweep specification (a few kB)"),
    "campaign file": (1_000_000, "a campaign file (a few kB)"),
    "PWA document": (200_000_000, "a PWA JSON export (~1 kB per cell)"),
    "C header": (10_000_000, "a C header (a few kB)"),
    "measurement file": (2_000_000_000, "a measured run (CSV/Parquet/MAT)"),
    "sweep results": (2_000_000_000, "a sweep's results file (~200 B per case)"),
}


def human_bytes(n: float) -> str:
    """``1.2 GB``-style size."""
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"  # pragma: no cover


def _size_error(error: type[Exception], path: Path, size: int, kind: str) -> Exception:
    limit, what = READ_LIMITS[kind]
    return error(
        f"{path}: the {kind} is {human_bytes(size)}, more than the {human_bytes(limit)} "
        f"{what} may be; check that it is the file you meant"
    )


def check_read_size(
    path: str | os.PathLike, kind: str, error: type[Exception] = HydropwaError
) -> int:
    """The size of ``path`` [bytes]; ``error`` (one line) above the ceiling of ``kind``.

    For readers that take a path (pyarrow, pandas); :func:`read_bytes` and :func:`read_text`
    check it themselves. ``kind`` is a key of :data:`READ_LIMITS`.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise _named(exc, path) from None
    if size > READ_LIMITS[kind][0]:
        raise _size_error(error, path, size, kind)
    return size


def read_bytes(path: str | os.PathLike, kind: str, error: type[Exception] = HydropwaError) -> bytes:
    """The bytes of ``path``, refused with one line above the ceiling of ``kind``.

    The size is checked on the open file and the read is bounded by the ceiling, so a file
    that grows meanwhile (or a device that never ends) is refused the same way.
    """
    path = Path(path)
    limit = READ_LIMITS[kind][0]
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if size > limit:
                raise _size_error(error, path, size, kind)
            data = fh.read(limit + 1)
    except OSError as exc:
        raise _named(exc, path) from None
    if len(data) > limit:
        raise _size_error(error, path, len(data), kind)
    return data


def decode_text(
    data: bytes, path: str | os.PathLike, error: type[Exception] = HydropwaError
) -> str:
    """``data`` as UTF-8 text (a byte-order mark is dropped); one line naming the bad byte."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        bad = data[exc.start]
        raise error(
            f"{path} is not UTF-8 text (byte 0x{bad:02x} at offset {exc.start}): save it as UTF-8"
        ) from None


def read_text(path: str | os.PathLike, kind: str, error: type[Exception] = HydropwaError) -> str:
    """The text of ``path``: the one decoding rule (UTF-8, BOM allowed) and size ceiling.

    Parameters
    ----------
    path : path-like
        The file.
    kind : str
        What the file is, a key of :data:`READ_LIMITS` (its size ceiling and the message).
    error : exception class
        The calling layer's error (``DataError``, ``ControlError``...), raised with one line
        for a file above the ceiling or not UTF-8 text.

    Raises
    ------
    OSError
        The file cannot be read (naming it).
    """
    return decode_text(read_bytes(path, kind, error), path, error)
