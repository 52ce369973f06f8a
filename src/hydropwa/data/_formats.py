"""Readers and writers of single runs: CSV, Parquet and MATLAB ``.mat``.

CSV
    Leading comment line ``# hydropwa: {json}`` with ``format_version``, ``name``,
    ``fs`` [Hz] and ``meta``; other ``#`` lines are ignored. Header ``name [unit]``.
    Values written with the shortest round-trip representation; NaN as ``nan``.
Parquet
    One float64 column per channel; field metadata ``unit``; schema metadata key
    ``hydropwa`` holds the same JSON as the CSV comment plus ``units``.
MAT (v5)
    One column vector (N, 1) per channel plus a char variable ``hydropwa`` holding the
    JSON (with ``units`` and ``channels``). Files without it (real-time target logs)
    need a :class:`~hydropwa.data.ChannelMap`.
"""

from __future__ import annotations

import io
import json
import os
import re
import struct
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from hydropwa._errors import DataError
from hydropwa._io import atomic_path, atomic_write_text, check_read_size, read_bytes, read_text

from ._channel_map import ChannelMap, resolve_channel_map
from ._run import Run, format_column_label, parse_column_label
from ._units import from_si, normalize_unit
from ._validate import validate_run

__all__ = ["read_run", "write_run", "FORMATS", "format_of"]

FORMAT_VERSION = 1
#: File formats by suffix.
FORMATS = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet", ".mat": "mat"}
_SUFFIX = {"csv": ".csv", "parquet": ".parquet", "mat": ".mat"}
_META_PREFIX = "# hydropwa:"
_MATLAB_NAME = re.compile(r"^[A-Za-z]\w{0,62}$")


def format_of(path, format: str | None = None) -> str:
    """Return ``"csv"``, ``"parquet"`` or ``"mat"`` from ``format`` or the file suffix."""
    if format is not None:
        fmt = str(format).lower().lstrip(".")
        if fmt not in _SUFFIX:
            raise DataError(f"unknown format {format!r}; hint: use one of csv, parquet, mat")
        return fmt
    found = FORMATS.get(Path(path).suffix.lower())
    if found is None:
        raise DataError(
            f"{str(path)!r}: cannot tell the format from suffix "
            f"{Path(path).suffix!r}; hint: use .csv, .parquet or .mat, or pass format="
        )
    return found


def suffix_of(format: str) -> str:
    """File suffix of a format name."""
    return _SUFFIX[format_of("", format)]


def _header(run: Run, units: Mapping[str, str]) -> dict[str, Any]:
    fs = run.fs if run.fs is not None and np.isfinite(run.fs) else None
    return {
        "format_version": FORMAT_VERSION,
        "name": run.name,
        "fs": fs,
        "meta": run.meta,
        "units": dict(units),
    }


def _file_columns(run: Run, units: Mapping[str, str] | None) -> tuple[dict, dict]:
    """Channels converted to the units requested for the file."""
    units = {k: normalize_unit(v) for k, v in (units or {}).items()}
    unknown = sorted(set(units) - set(run.channels))
    if unknown:
        raise DataError(
            f"run {run.name!r}: units given for missing channels {unknown}; "
            "hint: drop them from units="
        )
    cols, file_units = {}, {}
    for ch, v in run.channels.items():
        unit = units.get(ch, run.units[ch])
        cols[ch] = from_si(v, ch, run.units[ch], unit, f"run {run.name!r}, channel {ch!r}")
        file_units[ch] = unit
    return cols, file_units


# ---------------------------------------------------------------------- CSV
def _write_csv(run: Run, path: Path, units, overwrite: bool = True) -> None:
    cols, file_units = _file_columns(run, units)
    buf = io.StringIO()
    buf.write(f"{_META_PREFIX} {json.dumps(_header(run, file_units), allow_nan=False)}\n")
    buf.write(",".join(format_column_label(k, file_units[k]) for k in cols) + "\n")
    for row in zip(*(c.tolist() for c in cols.values()), strict=True):
        buf.write(",".join(map(repr, row)) + "\n")
    atomic_write_text(path, buf.getvalue(), overwrite=overwrite)


def _read_csv(path: Path) -> tuple[dict, dict, dict]:
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    header: dict[str, Any] = {}
    n_comment = 0
    text = read_text(path, "measurement file", DataError)  # UTF-8, a byte-order mark dropped
    for line in io.StringIO(text, newline=None):  # universal newlines, as open() reads
        if not line.startswith("#"):
            break
        n_comment += 1
        if line.startswith(_META_PREFIX):
            try:
                header = json.loads(line[len(_META_PREFIX) :])
            except json.JSONDecodeError as exc:
                raise DataError(
                    f"{str(path)!r}, line {n_comment}: the '# hydropwa:' metadata "
                    f"is not valid JSON ({exc.msg}); hint: fix or delete that line"
                ) from exc
            header = _check_header(header, path)
    try:
        df = pd.read_csv(
            path,
            encoding="utf-8-sig",
            skiprows=n_comment,
            skipinitialspace=True,
            dtype=str,
            keep_default_na=False,
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        raise DataError(
            f"{str(path)!r}: not a readable CSV table ({exc}); "
            "hint: one header line 'name [unit],...' then one row per sample"
        ) from exc
    raw, units = {}, {}
    for label in df.columns:
        ch, unit = parse_column_label(label)
        raw[ch] = _numeric_column(df[label].to_numpy(), path, ch, n_comment)
        if unit is not None:
            units[ch] = unit
    return raw, units, header


def _numeric_column(text: np.ndarray, path: Path, ch: str, n_comment: int) -> np.ndarray:
    # Text is parsed by Python's float(): correctly rounded, so CSV round trips are exact.
    cells = [str(s).strip() for s in text]
    try:
        return np.array([float(s) if s else np.nan for s in cells], dtype=float)
    except ValueError:
        pass
    out = np.empty(len(cells), dtype=float)
    for i, s in enumerate(cells):
        try:
            out[i] = float(s) if s else np.nan
        except ValueError:
            raise DataError(
                f"{str(path)!r}, channel {ch!r}, sample {i} (line {i + n_comment + 2}): "
                f"{s!r} is not a number; hint: fix the cell or leave it empty for NaN"
            ) from None
    return out


# ---------------------------------------------------------------------- Parquet
def _write_parquet(run: Run, path: Path, units, overwrite: bool = True) -> None:
    import pyarrow as pa  # deferred: pyarrow costs ~0.2 s at import
    import pyarrow.parquet as pq  # deferred: pyarrow costs ~0.2 s at import

    cols, file_units = _file_columns(run, units)
    fields = [pa.field(k, pa.float64(), metadata={"unit": file_units[k]}) for k in cols]
    schema = pa.schema(
        fields, metadata={"hydropwa": json.dumps(_header(run, file_units), allow_nan=False)}
    )
    table = pa.table({k: pa.array(v, type=pa.float64()) for k, v in cols.items()}, schema=schema)
    with atomic_path(path, overwrite=overwrite) as tmp:
        pq.write_table(table, tmp)


def _read_parquet(path: Path) -> tuple[dict, dict, dict]:
    import pyarrow as pa  # deferred: pyarrow costs ~0.2 s at import
    import pyarrow.parquet as pq  # deferred: pyarrow costs ~0.2 s at import

    check_read_size(path, "measurement file", DataError)
    try:
        table = pq.read_table(path)
    except (pa.ArrowException, OSError, ValueError) as exc:
        # Corrupted files surface as any ArrowException subclass (ArrowInvalid,
        # ArrowNotImplementedError, ArrowTypeError, ...) or as OSError.
        raise DataError(
            f"{str(path)!r}: not a readable Parquet file ({exc}); "
            "hint: check that the file is complete"
        ) from exc
    meta = table.schema.metadata or {}
    header = _parse_header(meta[b"hydropwa"], path) if b"hydropwa" in meta else {}
    raw, units = {}, {}
    try:
        # pyarrow decodes column names lazily: a corrupted name fails here, not in read_table
        fields = list(table.schema)
        names = [f.name for f in fields]
    except UnicodeDecodeError:
        raise DataError(
            f"{str(path)!r}: a column name is not UTF-8 text; hint: check that the file is complete"
        ) from None
    for field, name, col in zip(fields, names, table.columns, strict=True):
        ch, unit = parse_column_label(name)
        fmeta = field.metadata or {}
        if b"unit" in fmeta:
            try:
                unit = fmeta[b"unit"].decode("utf-8")
            except UnicodeDecodeError:
                raise DataError(
                    f"{str(path)!r}, channel {ch!r}: the unit metadata is not UTF-8 text; "
                    "hint: re-write the file with a readable unit"
                ) from None
        try:
            raw[ch] = _parquet_column(pa, col, field, path, ch)
        except (TypeError, ValueError, pa.ArrowInvalid) as exc:
            raise DataError(
                f"{str(path)!r}, channel {ch!r}: column of type {field.type} is not "
                "numeric; hint: store signals as float64"
            ) from exc
        if unit is not None:
            units[ch] = unit
    units = {**units, **(header.get("units") or {})}
    return raw, units, header


_TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}


def _parquet_column(pa, col, field, path: Path, ch: str) -> np.ndarray:
    """A Parquet column as float64 in the file's unit; timestamps and durations as seconds.

    A timestamp column becomes seconds since its first sample; reading its raw integer
    ticks (ms, µs or ns) would put the time base 1e3-1e9 times off.
    """
    typ = field.type
    if pa.types.is_timestamp(typ) or pa.types.is_duration(typ):
        ticks = np.asarray(col.cast(pa.int64()).fill_null(0).to_numpy(zero_copy_only=False))
        if pa.types.is_timestamp(typ) and ticks.size:
            ticks = ticks - ticks[0]  # in integers: epoch ns do not fit a float64 exactly
        sec = ticks.astype(float) * _TIME_UNITS[typ.unit]
        if col.null_count:
            sec[np.asarray(col.is_null().to_numpy(zero_copy_only=False))] = np.nan
        return sec
    if pa.types.is_date(typ) or pa.types.is_time(typ) or pa.types.is_interval(typ):
        raise DataError(
            f"{str(path)!r}, channel {ch!r}: column of type {typ} is a calendar value, not a "
            "signal; hint: store time as float64 seconds or as a timestamp"
        )
    if not (
        pa.types.is_integer(typ)
        or pa.types.is_floating(typ)
        or pa.types.is_decimal(typ)
        or pa.types.is_null(typ)
        or pa.types.is_dictionary(typ)
        or pa.types.is_boolean(typ)
    ):
        raise TypeError(f"type {typ}")
    return np.asarray(col.to_numpy(zero_copy_only=False), dtype=float)


_HEADER_TYPES: dict[str, tuple[type, ...]] = {
    "format_version": (int, float, str, type(None)),
    "name": (str, int, float, type(None)),
    "fs": (int, float, type(None)),
    "meta": (dict, type(None)),
    "units": (dict, type(None)),
    "channels": (list, type(None)),
}


def _parse_header(text, path: Path) -> dict[str, Any]:
    """Parse and check the ``hydropwa`` metadata JSON (a dict of known field types)."""
    try:
        header = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataError(
            f"{str(path)!r}: the 'hydropwa' metadata is not valid JSON ({exc}); "
            "hint: fix or remove the metadata"
        ) from None
    return _check_header(header, path)


def _check_header(header: Any, path: Path) -> dict[str, Any]:
    """Reject metadata of the wrong shape with a DataError instead of failing later."""
    if not isinstance(header, dict):
        raise DataError(
            f"{str(path)!r}: the 'hydropwa' metadata is a JSON {type(header).__name__}, "
            "expected an object; hint: fix or remove the metadata"
        )
    for key, types in _HEADER_TYPES.items():
        value = header.get(key)
        if not isinstance(value, types) or isinstance(value, bool):
            raise DataError(
                f"{str(path)!r}: metadata field {key!r} = {value!r:.60} has the wrong type "
                f"({type(value).__name__}); hint: fix or remove the field"
            )
    version = header.get("format_version")
    if version is not None and not (
        isinstance(version, int | float) and float(version).is_integer() and version >= 1
    ):
        raise DataError(
            f"{str(path)!r}: metadata field 'format_version' = {version!r:.40} is not a "
            "version this package knows (a positive integer); hint: fix or remove the field"
        )
    if version is not None and version > FORMAT_VERSION:
        raise DataError(
            f"{str(path)!r}: 'format_version' {int(version)} is newer than this hydropwa reads "
            f"({FORMAT_VERSION}); hint: update hydropwa"
        )
    for key in ("units",):
        if not all(isinstance(v, str) for v in (header.get(key) or {}).values()):
            raise DataError(
                f"{str(path)!r}: metadata 'units' must map channel names to unit strings; "
                "hint: fix or remove the field"
            )
    if not all(isinstance(v, str) for v in header.get("channels") or []):
        raise DataError(
            f"{str(path)!r}: metadata 'channels' must be a list of names; "
            "hint: fix or remove the field"
        )
    return header


# ---------------------------------------------------------------------- MAT
def _write_mat(run: Run, path: Path, units, overwrite: bool = True) -> None:
    import scipy.io  # deferred: scipy submodules cost 0.1-0.5 s at import

    cols, file_units = _file_columns(run, units)
    bad = [k for k in cols if not _MATLAB_NAME.match(k) or k == "hydropwa"]
    if bad:
        raise DataError(
            f"run {run.name!r}: channel names {bad} are not valid MATLAB variable "
            "names; hint: rename them (letters, digits, underscores) or write CSV/Parquet"
        )
    header = _header(run, file_units)
    header["channels"] = list(cols)
    variables = {k: v.reshape(-1, 1) for k, v in cols.items()}
    variables["hydropwa"] = json.dumps(header, allow_nan=False)
    with atomic_path(path, overwrite=overwrite) as tmp:
        scipy.io.savemat(tmp, variables, do_compression=True, oned_as="column")


#: MAT v5 data types → bytes per value (miINT8 … miUTF32); 14 = miMATRIX, 15 = miCOMPRESSED
_MAT_ITEMSIZE = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8, 16: 1, 17: 2, 18: 4}


def _mat_elements(
    buf: bytes, pos: int, end: int, fmt: str, top: bool, depth: int = 0
) -> list[tuple[int, int, int]]:
    """Walk the tagged data elements of ``buf[pos:end]`` (MAT v5); raise ValueError on one
    whose type is unknown or whose declared size does not fit in its parent, and on a matrix
    whose parts do not match its class, dimensions and complex flag.

    scipy's compiled MAT reader trusts all of these: a corrupted length or flag crashes the
    process (segmentation fault, found by the fuzz tests) instead of raising. Compressed
    elements (top level only) are inflated and walked; matrices are checked recursively.
    Returns the elements found, as (type, offset of the data, bytes).
    """
    if depth > 32:
        raise ValueError("MAT elements nested deeper than 32 levels")
    found = []
    while pos < end:
        if end - pos < 8:
            if top and not any(buf[pos:end]):
                break  # zero padding at the end of the file
            raise ValueError(f"truncated element tag at byte {pos}")
        typ, nbytes = struct.unpack_from(fmt, buf, pos)
        if typ >> 16:  # small data element: type and size packed in 4 bytes, data in 4
            small = (typ & 0xFFFF, pos + 4, typ >> 16)
            if small[2] > 4 or small[0] not in _MAT_ITEMSIZE:
                raise ValueError(f"bad small element at byte {pos}")
            found.append(small)
            pos += 8
            continue
        if nbytes > end - pos - 8:
            raise ValueError(f"element at byte {pos} declares {nbytes} bytes, {end - pos - 8} left")
        body = pos + 8
        if typ == 14:
            _mat_matrix(buf, _mat_elements(buf, body, body + nbytes, fmt, False, depth + 1), fmt)
        elif typ == 15 and top:
            raw = zlib.decompressobj().decompress(buf[body : body + nbytes], 1 << 31)
            _mat_elements(raw, 0, len(raw), fmt, True, depth + 1)
        elif typ not in _MAT_ITEMSIZE:
            raise ValueError(f"unknown element type {typ} at byte {pos}")
        found.append((typ, body, nbytes))
        pos = body + nbytes + (0 if typ in (14, 15) else (-nbytes) % 8)
    return found


def _mat_matrix(buf: bytes, parts: list[tuple[int, int, int]], fmt: str) -> None:
    """Check one matrix's parts (flags, dimensions, name, data) against its class."""
    if not parts:
        return  # an empty matrix (an empty struct field or cell)
    cls, complex_, dims = _mat_header(buf, parts, fmt)
    count = int(np.prod(dims))
    rest = parts[3:]
    if cls in (4, *range(6, 16)):  # char, numeric
        _mat_numeric(rest, complex_, count, dims)
    elif cls == 5:  # sparse: row indices, column starts, values (and imaginary values)
        if len(rest) != 3 + complex_ or any(t == 14 for t, _, _ in rest):
            raise ValueError("sparse matrix parts malformed")
    elif cls == 1:  # cell: one matrix per element
        if len(rest) != count or any(t != 14 for t, _, _ in rest):
            raise ValueError("cell array parts do not match its dimensions")
    elif cls in (2, 3):  # struct, object (class name first)
        _mat_struct(buf, rest[1:] if cls == 3 else rest, count, fmt)
    elif cls not in (16, 17):  # function handles and opaque (MCOS) objects: left to scipy
        raise ValueError(f"unknown matrix class {cls}")


def _mat_header(
    buf: bytes, parts: list[tuple[int, int, int]], fmt: str
) -> tuple[int, bool, tuple[int, ...]]:
    """A matrix's class, complex flag and dimensions, from its array flags and dimensions."""
    if len(parts) < 3 or parts[0][0] != 6 or parts[0][2] != 8 or parts[1][0] != 5:
        raise ValueError("matrix without array flags, dimensions and name")
    word = struct.unpack_from(fmt[0] + "I", buf, parts[0][1])[0]
    cls, complex_ = word & 0xFF, bool(word & 0x0800)
    n_dims = parts[1][2] // 4
    if n_dims < 2 or parts[1][2] % 4:
        raise ValueError("matrix dimensions malformed")
    dims = struct.unpack_from(f"{fmt[0]}{n_dims}i", buf, parts[1][1])
    if min(dims) < 0 or float(np.prod(np.asarray(dims, dtype=float))) > 2**31:
        raise ValueError(f"matrix dimensions {dims} invalid")
    return cls, complex_, dims


def _mat_numeric(
    rest: list[tuple[int, int, int]], complex_: bool, count: int, dims: tuple[int, ...]
) -> None:
    """Check a char or numeric matrix's data parts (real, and imaginary if complex)."""
    if len(rest) != 1 + complex_ or any(t == 14 for t, _, _ in rest):
        raise ValueError("numeric matrix parts do not match its complex flag")
    for t, _, nb in rest:
        if t != 16 and nb != count * _MAT_ITEMSIZE[t]:
            raise ValueError(f"matrix data of {nb} bytes for dimensions {dims}")


def _mat_struct(buf: bytes, rest: list[tuple[int, int, int]], count: int, fmt: str) -> None:
    """Check a struct's (or, after its class name, an object's) parts: field-name length,
    names, then one matrix per field of each element."""
    if len(rest) < 2 or rest[0][0] != 5 or rest[0][2] != 4 or rest[1][0] != 1:
        raise ValueError("struct without field names")
    fnl = struct.unpack_from(fmt[0] + "i", buf, rest[0][1])[0]
    if fnl <= 0 or rest[1][2] % fnl:
        raise ValueError("struct field names malformed")
    n_fields = rest[1][2] // fnl
    if len(rest) - 2 != count * n_fields or any(t != 14 for t, _, _ in rest[2:]):
        raise ValueError("struct parts do not match its dimensions and fields")


def _check_mat_v5(buf: bytes) -> None:
    """Raise ValueError if a MAT v5 file's element structure is inconsistent (see above)."""
    if len(buf) < 128:
        raise ValueError("shorter than the 128-byte MAT header")
    fmt = "<II" if buf[126:128] == b"IM" else ">II"
    _mat_elements(buf, 128, len(buf), fmt, True)


def _load_mat(path: Path) -> dict[str, Any]:
    import scipy.io  # deferred: scipy submodules cost 0.1-0.5 s at import

    buf = read_bytes(path, "measurement file", DataError)  # read once: checked, then parsed
    try:
        if scipy.io.matlab.matfile_version(io.BytesIO(buf))[0] == 1:
            _check_mat_v5(buf)
        return scipy.io.loadmat(io.BytesIO(buf), simplify_cells=True)
    except NotImplementedError as exc:
        raise DataError(
            f"{str(path)!r}: MATLAB v7.3 (HDF5) files are not supported; "
            "hint: re-save with save(..., '-v7') in MATLAB"
        ) from exc
    except Exception as exc:
        # scipy's MAT parser reports corrupted bytes as MatReadError, zlib.error,
        # struct.error, IndexError, ValueError, ... : all mean "not a readable file".
        raise DataError(
            f"{str(path)!r}: not a readable MAT file ({type(exc).__name__}: {exc}); "
            "hint: check that the file is complete"
        ) from exc


def _read_mat(path: Path) -> tuple[dict, dict, dict]:
    variables = _load_mat(path)
    raw = {k: v for k, v in variables.items() if not k.startswith("__")}
    text = raw.pop("hydropwa", None)
    if text is None:
        return raw, {}, {}
    header = _parse_header(str(text), path)
    chans = {k: raw[k] for k in header.get("channels") or [] if k in raw}
    return chans, dict(header.get("units") or {}), header


_READERS = {"csv": _read_csv, "parquet": _read_parquet, "mat": _read_mat}
_WRITERS = {"csv": _write_csv, "parquet": _write_parquet, "mat": _write_mat}


# ---------------------------------------------------------------------- public
def read_run(
    path: str | os.PathLike,
    channel_map: ChannelMap | str | os.PathLike | None = None,
    name: str | None = None,
    *,
    validate: bool = True,
    **validate_options,
) -> Run:
    """Read one run from a CSV, Parquet or MAT file, converting units to SI.

    Parameters
    ----------
    path : path-like
        File with suffix ``.csv``, ``.parquet`` or ``.mat``.
    channel_map : ChannelMap or path-like, optional
        Map from the file's variables/columns to channels. Required for MAT files not
        written by hydropwa. With a map, units come from the map, not from the header.
    name : str, optional
        Run name (default: the name stored in the file, else the file stem).
    validate : bool
        Run :func:`~hydropwa.data.validate_run` and raise :class:`DataError` on errors.
    **validate_options
        Passed to ``validate_run`` (e.g. ``resample=True``); the repaired run is returned.

    Returns
    -------
    Run
        Channels in SI units.

    Raises
    ------
    DataError
        If the file cannot be read, a unit is unknown, or validation fails.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{str(path)!r}: no such file; hint: check the path")
    fmt = format_of(path)
    raw, units, header = _READERS[fmt](path)
    run_name = str(name or header.get("name") or path.stem)
    meta = dict(header.get("meta") or {})
    cmap = resolve_channel_map(channel_map)
    if cmap is not None:
        meta.setdefault("source", path.name)
        run = cmap.apply(raw, run_name, meta, where=f"{str(path)!r}")
    elif fmt == "mat" and not header:
        raise DataError(
            f"{str(path)!r}: MAT file without hydropwa metadata (variables "
            f"{sorted(raw)}); hint: pass a channel map (--channel-map map.toml)"
        )
    else:
        run = Run.from_arrays(run_name, raw, units, fs=header.get("fs"), meta=meta)
    if validate:
        run = validate_run(run, **validate_options).run
    return run


def write_run(
    run: Run,
    path: str | os.PathLike,
    format: str | None = None,
    units: Mapping[str, str] | None = None,
    *,
    overwrite: bool = True,
) -> Path:
    """Write a run atomically as CSV, Parquet or MAT.

    Parameters
    ----------
    run : Run
        The run (SI units).
    path : path-like
        Destination; the format follows the suffix unless ``format`` is given.
    format : str, optional
        File format: ``"csv"``, ``"parquet"`` or ``"mat"``.
    units : dict[str, str], optional
        Units to write per channel (e.g. ``{"p_a": "bar", "x": "mm"}``); SI otherwise.
    overwrite : bool
        Replace an existing file (default). With False an existing ``path`` raises
        :class:`~hydropwa.OutputExistsError`, also when it appears while the run is written.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    path = Path(path)
    fmt = format_of(path, format)
    _WRITERS[fmt](run, path, units, overwrite)
    return path
