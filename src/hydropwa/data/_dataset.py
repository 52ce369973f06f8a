"""Datasets: a folder of run files with a ``manifest.json``.

Manifest (``manifest.json``, UTF-8 JSON)::

    {
      "format": "hydropwa-dataset",
      "format_version": 1,
      "meta": {...},                       # dataset metadata
      "runs": [
        {"name": "step_01", "file": "step_01.parquet", "format": "parquet",
         "kind": "step", "fs": 1000.0, "n_samples": 2001, "duration": 2.0,
         "channels": {"t": "s", "x": "m"}, "meta": {...}},
        ...
      ]
    }

Run files are written first and the manifest after each run, both atomically, so an
interrupted writer leaves a valid dataset of the runs finished so far.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from hydropwa._errors import DataError
from hydropwa._io import atomic_write_text, decode_text, read_bytes

from .._display import html_table
from ._channel_map import ChannelMap, resolve_channel_map
from ._formats import FORMATS, format_of, read_run, suffix_of, write_run
from ._run import Run
from ._validate import Issue, check_run

__all__ = [
    "Dataset",
    "read_dataset",
    "write_dataset",
    "check_dataset",
    "convert",
    "MANIFEST",
    "manifest_problems",
    "contained_path",
]

#: File name of the dataset manifest.
MANIFEST = "manifest.json"
_FORMAT = "hydropwa-dataset"
_VERSION = 1
#: The most runs a manifest may list: a rig campaign has tens, a long test programme a few
#: thousand; more is refused before the entries are checked (a million took minutes).
MAX_RUNS = 10_000


def _empty_manifest(meta: Mapping | None) -> dict[str, Any]:
    return {"format": _FORMAT, "format_version": _VERSION, "meta": dict(meta or {}), "runs": []}


def _read_manifest(root: Path) -> dict[str, Any]:
    path = root / MANIFEST
    if not path.is_file():
        if root.exists() and not root.is_dir():
            raise DataError(
                f"{str(root)!r}: is a file, not a dataset folder; hint: give the folder that "
                f"holds {MANIFEST}"
            )
        raise DataError(
            f"{str(root)!r}: no {MANIFEST}, so it is not a hydropwa dataset; hint: "
            "create one with write_dataset() or `hydropwa data convert SRC_DIR DST_DIR`"
        )
    try:
        doc = json.loads(decode_text(read_bytes(path, "manifest", DataError), path, DataError))
    except RecursionError:
        raise DataError(
            f"{str(path)!r}: the JSON is nested too deeply to be a manifest; hint: rewrite the "
            "dataset with write_dataset()"
        ) from None
    except (OSError, ValueError) as exc:
        raise DataError(
            f"{str(path)!r}: manifest unreadable ({exc}); hint: fix the JSON or rewrite the dataset"
        ) from exc
    problems = manifest_problems(doc, root)
    if problems:
        listed = "; ".join(f"({i}) {p}" for i, p in enumerate(problems[:10], start=1))
        more = f"; and {len(problems) - 10} more" if len(problems) > 10 else ""
        raise DataError(
            f"{str(path)!r}: {len(problems)} problem(s) in the manifest: {listed}{more}; "
            "hint: fix the entries or rewrite the dataset with write_dataset()"
        )
    return doc


#: Manifest entry field -> accepted JSON types (``None``: the field may be null or absent).
_ENTRY_FIELDS: dict[str, tuple[type, ...]] = {
    "format": (str, type(None)),
    "kind": (str, type(None)),
    "fs": (int, float, type(None)),
    "n_samples": (int, type(None)),
    "duration": (int, float, type(None)),
    "channels": (dict, type(None)),
    "meta": (dict, type(None)),
}


def manifest_problems(doc: Any, root: str | os.PathLike) -> list[str]:
    """Check a manifest document against the schema; one message per problem (empty: valid).

    The schema: an object with ``"format": "hydropwa-dataset"``, an integer
    ``format_version`` not newer than this package's, an optional ``meta`` object, and a
    ``runs`` list of objects, each with a unique non-empty ``name`` and a unique ``file``:
    a relative path with a run-file suffix that resolves (symbolic links followed) to a
    file inside the dataset folder. Optional entry fields must have their JSON types
    (``fs``, ``duration`` numbers; ``n_samples`` an integer; ``channels``, ``meta`` objects).
    """
    if not isinstance(doc, dict):
        return [f"the document is a JSON {type(doc).__name__}, expected an object with a runs list"]
    problems = _head_problems(doc)
    runs = doc.get("runs")
    if not isinstance(runs, list):
        problems.append('"runs" must be a list of run entries')
        return problems
    if len(runs) > MAX_RUNS:
        problems.append(
            f'"runs" lists {len(runs)} runs, more than the {MAX_RUNS} a dataset may hold; split '
            "it into several datasets"
        )
        return problems
    names: dict[str, int] = {}
    files: dict[str, int] = {}
    for i, e in enumerate(runs):
        problems += _entry_problems(i, e, root, names, files)
    return problems


def _head_problems(doc: dict) -> list[str]:
    """The problems of the manifest's top-level fields (all but ``runs``)."""
    problems = []
    if doc.get("format") != _FORMAT:
        problems.append(f'"format" is {doc.get("format")!r:.40}, expected "{_FORMAT}"')
    version = doc.get("format_version", _VERSION)
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        problems.append(f'"format_version" {version!r:.40} is not a positive integer')
    elif version > _VERSION:
        problems.append(
            f'"format_version" {version} is newer than this hydropwa reads ({_VERSION}); update hydropwa'
        )
    if not isinstance(doc.get("meta", {}), dict):
        problems.append('"meta" must be an object')
    return problems


def _entry_problems(
    i: int, e: Any, root: str | os.PathLike, names: dict[str, int], files: dict[str, int]
) -> list[str]:
    """The problems of run entry ``i``; records its name and file in ``names``/``files``
    (first index of each) for the duplicate checks of the entries after it."""
    where = f"runs[{i}]"
    if not isinstance(e, dict):
        return [f"{where} is a JSON {type(e).__name__}, expected an object"]
    problems = []
    name, file = e.get("name"), e.get("file")
    if not isinstance(name, str) or not name.strip():
        problems.append(f'{where} needs a "name" (a non-empty string), has {name!r:.40}')
    else:
        where = f"runs[{i}] ({name!r:.40})"
        if name in names:
            problems.append(f"{where}: the name is also runs[{names[name]}]'s")
        names.setdefault(name, i)
    if not isinstance(file, str) or not file.strip():
        problems.append(f'{where} needs a "file" (a path in the folder), has {file!r:.40}')
    else:
        problems += _file_problems(where, i, file, root, files)
    return problems + _field_problems(where, e)


def _file_problems(
    where: str, i: int, file: str, root: str | os.PathLike, files: dict[str, int]
) -> list[str]:
    """The problems of entry ``i``'s ``file`` (a non-empty string): outside the folder, no
    run-file suffix, another entry's file."""
    problems = []
    try:
        contained_path(root, file, what=f"{where} file")
    except DataError as exc:
        problems.append(str(exc).partition("; hint: ")[0])
    if Path(file).suffix.lower() not in FORMATS:
        problems.append(f"{where}: file {file!r:.60} has no run-file suffix (.csv, .parquet, .mat)")
    if file in files:
        problems.append(f"{where}: file {file!r:.60} is also runs[{files[file]}]'s")
    files.setdefault(file, i)
    return problems


def _field_problems(where: str, e: dict) -> list[str]:
    """The problems of an entry's optional fields: JSON types, the format name."""
    problems = []
    for key, types in _ENTRY_FIELDS.items():
        v = e.get(key)
        if not isinstance(v, types) or isinstance(v, bool):
            problems.append(f"{where}: {key!r} = {v!r:.40} has the wrong type ({type(v).__name__})")
    fmt = e.get("format")
    if isinstance(fmt, str) and fmt.lower() not in ("csv", "parquet", "mat"):
        problems.append(f"{where}: format {fmt!r:.20} is not csv, parquet or mat")
    return problems


def contained_path(root: str | os.PathLike, file: str | os.PathLike, what: str = "file") -> Path:
    """``root / file``, refused unless it resolves (symbolic links followed) inside ``root``.

    Raises
    ------
    DataError
        An absolute path, a path with ``..`` that leaves the folder, or a symbolic link that
        points out of it.
    """
    root = Path(root)
    rel = Path(file)
    if rel.is_absolute() or "\\" in str(file) or Path(str(file)).drive:
        raise DataError(
            f"{what} {str(file)!r:.80} is an absolute path or uses '\\'; a dataset may only name "
            "files inside its folder; hint: give the path relative to the dataset folder, with '/'"
        )
    path = root / rel
    try:
        inside = path.resolve().is_relative_to(root.resolve())
    except (OSError, RuntimeError, ValueError):  # a symlink loop, a NUL byte
        inside = False
    if not inside:
        raise DataError(
            f"{what} {str(file)!r:.80} leads out of the dataset folder {str(root)!r} (via '..' or "
            "a symbolic link); a dataset may only read files inside its folder; hint: copy the "
            "file into the folder"
        )
    return path


def _entry(run: Run, file: str, fmt: str) -> dict[str, Any]:
    return {
        "name": run.name,
        "file": file,
        "format": fmt,
        "kind": run.kind,
        "fs": run.fs,
        "n_samples": run.n_samples,
        "duration": run.duration,
        "channels": dict(run.units),
        "meta": run.meta,
    }


def _manifest_text(manifest: Mapping[str, Any]) -> str:
    """The manifest as JSON: indented, with one line per run.

    The manifest is rewritten after every run (finished runs survive a crash), so its
    encoding must stay cheap as it grows: the runs go through json's C encoder (one compact
    line each) instead of the pure-Python indenting one, which made a 300-run campaign spend
    7 s on its manifests.
    """
    runs = manifest.get("runs")
    head = {k: v for k, v in manifest.items() if k != "runs"}
    if not isinstance(runs, list) or not head:
        return json.dumps(manifest, indent=2, allow_nan=False) + "\n"
    text = json.dumps(head, indent=2, allow_nan=False)
    lines = ",\n    ".join(json.dumps(r, allow_nan=False) for r in runs)
    body = f"[\n    {lines}\n  ]" if runs else "[]"
    return f'{text[:-2]},\n  "runs": {body}\n}}\n'


class Dataset:
    """A folder of runs described by ``manifest.json``.

    Parameters
    ----------
    root : path-like
        Dataset folder.
    manifest : dict, optional
        Manifest document (read from ``root`` when omitted).
    validate : bool
        Validate runs when they are loaded (see :func:`~hydropwa.data.validate_run`).

    Notes
    -----
    Runs load lazily and are cached; ``runs`` loads all of them. Iteration yields
    :class:`Run` objects in manifest order.
    """

    def __init__(
        self, root: str | os.PathLike, manifest: Mapping | None = None, validate: bool = True
    ) -> None:
        self.root = Path(root)
        self.manifest: dict[str, Any] = (
            dict(manifest) if manifest is not None else _read_manifest(self.root)
        )
        self.validate = validate
        self._cache: dict[str, Run] = {}

    # ------------------------------------------------------------------ create
    @classmethod
    def create(
        cls, root: str | os.PathLike, meta: Mapping | None = None, overwrite: bool = False
    ) -> Dataset:
        """Create an empty dataset (writes the manifest).

        Raises
        ------
        DataError
            If ``root`` already holds a manifest and ``overwrite`` is false.
        """
        root = Path(root)
        if (root / MANIFEST).exists() and not overwrite:
            raise DataError(
                f"{str(root)!r}: already holds a dataset; hint: choose another folder, "
                "pass overwrite=True, or open it with read_dataset() and add_run()"
            )
        ds = cls(root, _empty_manifest(meta))
        ds._write_manifest()
        return ds

    def _write_manifest(self) -> None:
        atomic_write_text(self.root / MANIFEST, _manifest_text(self.manifest))

    def add_run(
        self,
        run: Run,
        format: str = "parquet",
        units: Mapping[str, str] | None = None,
        overwrite: bool = False,
    ) -> Path:
        """Write ``run`` into the dataset, then update the manifest (both atomically).

        Parameters
        ----------
        run : Run
            The run; its name becomes the file stem.
        format : {"parquet", "csv", "mat"}
            File format of the run.
        units : dict[str, str], optional
            Units to write per channel (SI otherwise).
        overwrite : bool
            Replace a run of the same name.

        Returns
        -------
        pathlib.Path
            Path of the run file.
        """
        fmt = format_of("", format)
        if run.name in self.names and not overwrite:
            raise DataError(
                f"dataset {str(self.root)!r}: run {run.name!r} exists; hint: rename "
                "the run or pass overwrite=True"
            )
        file = run.name + suffix_of(fmt)
        if Path(file).name != file or run.name in (".", ".."):
            raise DataError(
                f"dataset {str(self.root)!r}: run name {run.name!r} is not a file name; hint: "
                "rename the run (no '/' or '\\')"
            )
        contained_path(self.root, file, what=f"run {run.name!r}: file")
        path = write_run(run, self.root / file, fmt, units)
        runs = [e for e in self.manifest["runs"] if e["name"] != run.name]
        runs.append(_entry(run, file, fmt))
        self.manifest["runs"] = runs
        self._write_manifest()
        self._cache[run.name] = run
        return path

    def write(
        self,
        runs: Iterable[Run],
        format: str = "parquet",
        units: Mapping[str, str] | None = None,
        overwrite: bool = False,
    ) -> Dataset:
        """Add several runs, one after the other (see :meth:`add_run`)."""
        for run in runs:
            self.add_run(run, format=format, units=units, overwrite=overwrite)
        return self

    # ------------------------------------------------------------------ access
    @property
    def names(self) -> list[str]:
        """Run names in manifest order."""
        return [e["name"] for e in self.manifest["runs"]]

    @property
    def meta(self) -> dict[str, Any]:
        """Dataset metadata."""
        return self.manifest.get("meta", {})

    def entry(self, name: str) -> dict[str, Any]:
        """Manifest entry of run ``name``."""
        for e in self.manifest["runs"]:
            if e["name"] == name:
                return e
        raise DataError(
            f"dataset {str(self.root)!r}: no run {name!r} (has {self.names}); "
            "hint: check the run name"
        )

    def path_of(self, name: str) -> Path:
        """Path of the file of run ``name`` (refused unless it lies inside the folder)."""
        return contained_path(self.root, self.entry(name)["file"], what=f"run {name!r}: file")

    def __getitem__(self, name: str) -> Run:
        if name not in self._cache:
            path = self.path_of(name)
            if not path.is_file():
                raise DataError(
                    f"dataset {str(self.root)!r}, run {name!r}: file "
                    f"{path.name!r} listed in {MANIFEST} is missing; hint: restore it "
                    f"or remove the entry from {MANIFEST}"
                )
            self._cache[name] = read_run(path, name=name, validate=self.validate)
        return self._cache[name]

    @property
    def runs(self) -> dict[str, Run]:
        """All runs by name (loads every file)."""
        return {n: self[n] for n in self.names}

    def __iter__(self) -> Iterator[Run]:
        return (self[n] for n in self.names)

    def __len__(self) -> int:
        return len(self.manifest["runs"])

    def __contains__(self, name: object) -> bool:
        return name in self.names

    def filter(self, kind: str | None = None, **meta) -> Dataset:
        """Runs of one experiment ``kind`` (and matching metadata), as a new in-memory view."""
        keep = [
            e
            for e in self.manifest["runs"]
            if (kind is None or e.get("kind") == kind)
            and all(e.get("meta", {}).get(k) == v for k, v in meta.items())
        ]
        ds = Dataset(self.root, {**self.manifest, "runs": keep}, validate=self.validate)
        ds._cache = {n: r for n, r in self._cache.items() if n in ds.names}
        return ds

    def __repr__(self) -> str:
        return f"Dataset({str(self.root)!r}, {len(self)} runs)"

    def _repr_html_(self) -> str:
        rows = []
        for e in self.manifest.get("runs", [])[:50]:
            rows.append(
                (
                    e.get("name", ""),
                    e.get("kind") or "",
                    e.get("n_samples", ""),
                    f"{e.get('duration', float('nan')):.4g}",
                    ", ".join(e.get("channels", {})),
                )
            )
        more = len(self) - len(rows)
        return html_table(
            f"Dataset {self.root}: {len(self)} runs",
            ("run", "kind", "samples", "duration [s]", "channels"),
            rows,
            note=f"… and {more} more" if more > 0 else "",
        )


def read_dataset(root: str | os.PathLike, *, validate: bool = True, lazy: bool = False) -> Dataset:
    """Open a dataset folder.

    Parameters
    ----------
    root : path-like
        Folder holding ``manifest.json``.
    validate : bool
        Validate each run when loaded; raises :class:`DataError` on errors.
    lazy : bool
        Load runs on first access instead of now.

    Returns
    -------
    Dataset
    """
    ds = Dataset(root, validate=validate)
    if not lazy:
        ds.runs  # noqa: B018 - loading now surfaces file and validation errors here
    return ds


def write_dataset(
    runs: Iterable[Run],
    root: str | os.PathLike,
    *,
    format: str = "parquet",
    units: Mapping[str, str] | None = None,
    meta: Mapping | None = None,
    overwrite: bool = False,
) -> Dataset:
    """Write runs as a new dataset, updating the manifest after each run.

    Parameters
    ----------
    runs : iterable of Run
        Runs to write (a generator is consumed one run at a time).
    root : path-like
        Destination folder (created).
    format : {"parquet", "csv", "mat"}
        File format of the runs.
    units : dict[str, str], optional
        Units to write per channel (SI otherwise).
    meta : dict, optional
        Dataset metadata.
    overwrite : bool
        Replace an existing manifest in ``root``.

    Returns
    -------
    Dataset
    """
    return Dataset.create(root, meta=meta, overwrite=overwrite).write(runs, format, units)


def _unreadable(run: str, error: DataError) -> Issue:
    message, _, hint = str(error).partition("; hint: ")
    return Issue("error", "unreadable", run, None, None, None, message, hint or "check the file")


def check_dataset(
    source: str | os.PathLike | Dataset,
    channel_map: ChannelMap | str | os.PathLike | None = None,
    **check_options,
) -> list[Issue]:
    """Check every run of a dataset, a folder of raw files, or one file; return all findings.

    Parameters
    ----------
    source : path-like or Dataset
        Dataset folder, run file, an open :class:`Dataset`, or a campaign folder whose
        sub-folders are datasets (as ``hydropwa rig`` writes; each is checked).
    channel_map : ChannelMap or path-like, optional
        Map for raw files (single-file sources).
    **check_options
        Passed to :func:`~hydropwa.data.check_run`.

    Returns
    -------
    list[Issue]
        Empty for a clean dataset. Unreadable runs are reported with code ``"unreadable"``.

    Raises
    ------
    DataError
        If ``source`` itself cannot be read (no manifest, unreadable file).
    """
    if not isinstance(source, Dataset) and not Path(source).exists():
        raise DataError(f"{str(source)!r}: no such file or folder; hint: check the path")
    if not isinstance(source, Dataset) and Path(source).is_file():
        return check_run(read_run(source, channel_map, validate=False), **check_options)
    if not isinstance(source, Dataset) and not (Path(source) / MANIFEST).exists():
        files = _raw_files(Path(source))
        subs = sorted(p for p in Path(source).iterdir() if (p / MANIFEST).is_file())
        if not files and subs:  # a campaign folder: one dataset per experiment
            return [i for sub in subs for i in check_dataset(sub, channel_map, **check_options)]
        if not files:
            _read_manifest(Path(source))  # raises the "not a dataset" error
        return _check_files(files, resolve_channel_map(channel_map), check_options)
    ds = source if isinstance(source, Dataset) else Dataset(source, validate=False)
    ds = Dataset(ds.root, ds.manifest, validate=False)
    issues: list[Issue] = []
    for name in ds.names:
        try:
            run = ds[name]
        except DataError as exc:
            issues.append(_unreadable(name, exc))
            continue
        issues += check_run(run, **check_options)
    return issues


def _check_files(files: list[Path], cmap: ChannelMap | None, options: dict) -> list[Issue]:
    issues: list[Issue] = []
    for path in files:
        try:
            run = read_run(path, cmap, validate=False)
        except DataError as exc:
            issues.append(_unreadable(path.stem, exc))
            continue
        issues += check_run(run, **options)
    return issues


def _raw_files(folder: Path) -> list[Path]:
    """Run files of a folder without manifest; one that links out of the folder is refused."""
    files = sorted(
        p
        for p in folder.iterdir()
        if p.is_file() and p.suffix.lower() in FORMATS and not p.name.startswith(".")
    )
    for p in files:
        contained_path(folder, p.name, what=f"{str(folder)!r}:")
    return files


def _check_suffix(dst: Path, format: str | None) -> None:
    """A destination file's suffix must name its format (``format`` only confirms it)."""
    by_suffix = FORMATS.get(dst.suffix.lower())
    if by_suffix is None:
        raise DataError(
            f"{str(dst)!r}: cannot tell the format from suffix {dst.suffix!r}; hint: name the "
            "file with .csv, .parquet or .mat"
        )
    if format is not None and format_of("", format) != by_suffix:
        raise DataError(
            f"{str(dst)!r}: the suffix says {by_suffix} but format={format!r}; hint: name the "
            f"file with {suffix_of(format)} or drop --format"
        )


def convert(
    src: str | os.PathLike,
    dst: str | os.PathLike,
    *,
    channel_map: ChannelMap | str | os.PathLike | None = None,
    format: str | None = None,
    units: Mapping[str, str] | None = None,
    overwrite: bool = False,
    meta: Mapping[str, Any] | None = None,
    **validate_options,
) -> Path:
    """Convert a run file or a whole folder to another format, validating on the way.

    Parameters
    ----------
    src : path-like
        A run file, a dataset folder (with manifest), or a folder of raw files (each
        ``.csv``/``.parquet``/``.mat`` becomes a run).
    dst : path-like
        Destination file (for a file ``src``) or folder.
    channel_map : ChannelMap or path-like, optional
        Map for raw files.
    format : str, optional
        Output format, ``"csv"``, ``"parquet"`` or ``"mat"``; default from ``dst``'s suffix for files, ``"parquet"`` for folders.
    units : dict[str, str], optional
        Units to write per channel (SI otherwise).
    overwrite : bool
        Replace an existing destination dataset.
    meta : mapping, optional
        Entries added to the destination manifest's ``meta`` (a folder only), e.g.
        ``{"machine": params.to_dict()}``: the machine the runs were measured on, which
        identification then reads (``hydropwa data convert --params``).
    **validate_options
        Passed to :func:`~hydropwa.data.validate_run` (e.g. ``resample=True``).

    Returns
    -------
    pathlib.Path
        The written file or folder.
    """
    src, dst = Path(src), Path(dst)
    cmap = resolve_channel_map(channel_map)
    if src.is_file() and meta:
        raise DataError(
            f"{str(src)!r}: a single run file has no manifest to record {', '.join(meta)} in; "
            "hint: convert its folder into a dataset"
        )
    if src.is_file():
        if dst.is_dir():
            dst = dst / (src.stem + suffix_of(format or "parquet"))
        _check_suffix(dst, format)
        if dst.exists() and not overwrite:
            raise DataError(
                f"{str(dst)!r}: the file exists; hint: pass --force (overwrite=True) to replace "
                "it, or choose another destination"
            )
        if dst.exists() and dst.resolve() == src.resolve():
            raise DataError(f"{str(dst)!r}: is the source file; hint: choose another destination")
        run = read_run(src, cmap, **validate_options)
        return write_run(run, dst, format, units, overwrite=overwrite)
    if not src.is_dir():
        raise DataError(f"{str(src)!r}: no such file or folder; hint: check the path")
    if dst.exists() and not dst.is_dir():
        raise DataError(
            f"{str(dst)!r}: is a file, where the destination folder of a dataset is expected; "
            "hint: choose a folder"
        )
    if dst.is_dir() and dst.resolve() == src.resolve():
        raise DataError(f"{str(dst)!r}: is the source folder; hint: choose another destination")
    if dst.is_dir() and any(dst.iterdir()) and not overwrite:
        raise DataError(
            f"{str(dst)!r}: the folder is not empty; hint: pass --force (overwrite=True) to "
            "write into it, or choose an empty or new folder"
        )
    fmt = format or "parquet"
    if (src / MANIFEST).is_file():
        ds = Dataset(src, validate=False)
        runs = (read_run(ds.path_of(n), cmap, name=n, **validate_options) for n in ds.names)
        meta_out = ds.meta
    else:
        files = _raw_files(src)
        if not files:
            raise DataError(
                f"{str(src)!r}: no {MANIFEST} and no .csv/.parquet/.mat files; "
                "hint: point at a dataset folder or a run file"
            )
        runs = (read_run(p, cmap, **validate_options) for p in files)
        meta_out = {"source": str(src)}
    write_dataset(
        runs, dst, format=fmt, units=units, meta={**meta_out, **(meta or {})}, overwrite=overwrite
    )
    return dst
