"""Resumable stages of the paper study: a stage is finished when its outputs exist unchanged
and its manifest ``.stages/<name>.json`` records the hash of the inputs it was made from."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from ... import _interrupt
from ..._io import atomic_write_text

__all__ = ["STAGE_DIR", "file_hash", "text_hash", "tree_files", "StageRunner", "prefetch"]

#: Environment variable: ``0`` runs the paper study's stages one after another in one process
#: (no second process for the stages that do not depend on each other, :func:`prefetch`).
ENV_OVERLAP = "HYDROPWA_STUDY_OVERLAP"

#: Folder (inside the report folder) holding the stage manifests.
STAGE_DIR = ".stages"


def text_hash(*parts: Any) -> str:
    """SHA-256 (hex, 16 digits) of the JSON rendering of ``parts``."""
    text = json.dumps(parts, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def file_hash(path: Path) -> str:
    """SHA-256 (hex, 16 digits) of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()[:16]


def tree_files(root: Path) -> list[Path]:
    """Every regular file under ``root`` (sorted), skipping hidden and temporary files."""
    return sorted(
        p
        for p in root.rglob("*")
        if p.is_file() and not any(s.startswith(".") for s in p.relative_to(root).parts)
    )


class StageRunner:
    """Runs named stages in a report folder, reusing those already finished.

    Parameters
    ----------
    out : Path
        Report folder.
    fresh : bool
        Recompute every stage.
    on_stage : callable, optional
        ``on_stage(name, reused, seconds)`` after each stage.
    """

    def __init__(self, out: Path, fresh: bool = False, on_stage: Callable | None = None) -> None:
        self.out = out
        self.fresh = fresh
        self.on_stage = on_stage
        self.record: dict[str, dict[str, Any]] = {}
        #: records of stages a second process ran (:func:`prefetch`), taken over on reuse
        self.elsewhere: dict[str, dict[str, Any]] = {}

    def manifest_path(self, name: str) -> Path:
        return self.out / STAGE_DIR / f"{name}.json"

    def _load(self, name: str) -> dict[str, Any] | None:
        try:
            return json.loads(self.manifest_path(name).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None

    def finished(self, name: str, inputs: str) -> dict[str, Any] | None:
        """The stage's manifest if it finished from ``inputs`` and its outputs are unchanged."""
        if self.fresh:
            return None
        m = self._load(name)
        if not m or m.get("inputs") != inputs:
            return None
        for rel, h in m.get("outputs", {}).items():
            p = self.out / rel
            if not p.is_file() or file_hash(p) != h:
                return None
        return m

    def outputs_hash(self, name: str) -> str:
        """Hash of a finished stage's outputs (the inputs of the stages after it)."""
        m = self._load(name) or {}
        return text_hash(m.get("outputs", {}))

    def run(
        self, name: str, inputs: str, work: Callable[[], tuple[Iterable[Path], dict]]
    ) -> dict[str, Any]:
        """Run ``work`` unless the stage is finished; returns the stage manifest.

        ``work()`` returns (output files, extra manifest entries such as ``notes``).
        """
        _interrupt.checkpoint()  # a Ctrl-C a finalizer swallowed stops before the next stage
        t0 = time.perf_counter()
        m = self.finished(name, inputs)
        reused = m is not None
        if m is None:
            files, extra = work()
            outputs = {p.relative_to(self.out).as_posix(): file_hash(p) for p in sorted(set(files))}
            m = {
                "stage": name,
                "inputs": inputs,
                "outputs": outputs,
                "seconds": time.perf_counter() - t0,
                "finished": time.strftime("%Y-%m-%dT%H:%M:%S"),
                **extra,
            }
            atomic_write_text(self.manifest_path(name), json.dumps(m, indent=1, default=str) + "\n")
        if reused and name in self.record:  # run earlier in this study (ahead of its turn)
            return m
        record = {
            "reused": reused,
            "seconds": time.perf_counter() - t0,
            "work_seconds": m["seconds"],
        }
        if reused and name in self.elsewhere:  # a second process ran it for this study
            record = self.elsewhere.pop(name)
        self.record[name] = record
        if self.on_stage is not None:
            self.on_stage(name, record["reused"], record["seconds"])
        return m


def prefetch(
    runner: StageRunner, work: Callable[[], Any], here: bool = False
) -> Callable[..., None]:
    """Run ``work`` (stage calls through ``runner``) in a forked second process meanwhile.

    Returns ``join(abort=False)``, which waits for that process (``abort``: stops it first)
    and takes over the records of the stages it ran; the caller then calls those stages
    again in their order, and they reuse what the second process wrote. A second process
    that fails leaves its stages unfinished, so those calls compute them here (and raise
    what they raise). With ``here``, without ``os.fork``, or with ``HYDROPWA_STUDY_OVERLAP=0``,
    ``work`` runs here at once.
    """
    if here or not hasattr(os, "fork") or os.environ.get(ENV_OVERLAP, "1").strip() == "0":
        work()
        return lambda abort=False: None
    sys.stdout.flush()
    sys.stderr.flush()
    before = set(runner.record)
    rfd, wfd = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child's coverage is not collected
        os.close(rfd)
        code = 1
        try:
            _die_with_parent()
            runner.on_stage = None  # the parent's progress display is the parent's
            work()
            done = {k: v for k, v in runner.record.items() if k not in before}
            os.write(wfd, json.dumps(done).encode())
            code = 0
        except BaseException:  # noqa: BLE001 - the parent computes the stage and raises
            pass
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)
    os.close(wfd)

    def join(abort: bool = False) -> None:
        if abort:
            os.kill(pid, signal.SIGTERM)
        try:
            with os.fdopen(rfd, "rb") as fh:
                data = fh.read()
        except BaseException:  # Ctrl-C while waiting: the second process stops too
            os.kill(pid, signal.SIGTERM)
            os.waitpid(pid, 0)
            raise
        _, status = os.waitpid(pid, 0)
        if not abort and os.waitstatus_to_exitcode(status) == 0 and data:
            runner.elsewhere.update(json.loads(data))

    return join


def _die_with_parent() -> None:  # pragma: no cover - runs in the forked child
    """Linux: this (forked) process gets SIGTERM when its parent dies (a killed study leaves
    no second process writing into its folder); elsewhere nothing."""
    try:
        import ctypes  # deferred: only a forked second process needs it

        ctypes.CDLL(None).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
