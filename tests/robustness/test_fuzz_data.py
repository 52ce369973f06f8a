"""Fuzz the measurement readers: CSV, Parquet and MAT via ``hydropwa.data.read_run``.

Seeds are valid files written by the package (``write_run``) and a raw real-time-target
style MAT log read through a channel map. Inputs are the seeds with random byte edits,
line/cell edits of the CSV, random JSON in the metadata header, random unit strings, random
channel maps, and random bytes. Contract (``_fuzzutil``): load, or raise ``DataError``.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from _fuzzutil import load_or_reject
from hypothesis import given
from hypothesis import strategies as st

from hydropwa import DataError
from hydropwa.data import ChannelMap, Run, read_run, write_run

pytestmark = pytest.mark.usefixtures("_seed_dir")


def _seed_run() -> Run:
    n = 16
    t = np.arange(n) / 1000.0
    return Run(
        name="seed",
        channels={
            "t": t,
            "u": 0.3 * np.sin(40 * t),
            "x": 0.1 + 0.01 * t,
            "p_a": np.full(n, 50e5),
            "p_b": np.linspace(30e5, 31e5, n),
            "temp_oil": np.full(n, 313.15),
        },
        units={"temp_oil": "K"},
        fs=1000.0,
        meta={"kind": "step", "rig": "virtual"},
    )


_SEEDS: dict = {}


@pytest.fixture(scope="module")
def _seed_dir(tmp_path_factory):
    _SEEDS.clear()
    _SEEDS.update(_make_seeds(tmp_path_factory.mktemp("seeds")))
    yield
    _SEEDS.clear()


def _make_seeds(d):
    run = _seed_run()
    units = {"p_a": "bar", "x": "mm", "u": "%", "temp_oil": "degC"}
    out = {}
    for fmt in ("csv", "parquet", "mat"):
        out[fmt] = write_run(run, d / f"seed.{fmt}").read_bytes()
        out[fmt + "-units"] = write_run(run, d / f"seedu.{fmt}", units=units).read_bytes()
    # a raw log without hydropwa metadata: matrix + scalars + struct, as dSPACE exports it
    buf = io.BytesIO()
    n = 16
    scipy.io.savemat(
        buf,
        {
            "data": np.column_stack([np.arange(n) / 1e3, np.linspace(0, 1, n), np.full(n, 2.0)]),
            "qm": np.linspace(0.0, 0.1, n).reshape(-1, 1),
            "gtau": np.array([[35.15]]),
            "rec": {
                "X": {"Data": np.arange(n) / 1e3},
                "Y": [{"Name": "p_A", "Data": np.full(n, 40.0)}],
            },
        },
    )
    out["raw-mat"] = buf.getvalue()
    out["dir"] = d
    return out


RAW_DOC = {
    "map": {"name": "fuzz", "keep_unmapped": True},
    "channels": {
        "t": {"source": "rec.X.Data", "unit": "s"},
        "x": {"source": "qm", "unit": "m"},
        "u": {"source": "data", "column": 2, "unit": "1", "gain": 0.5},
        "f_l": {"source": "data", "column": 3, "unit": "N", "gain": "@gtau"},
        "p_a": {"source": "rec.Y{p_A}.Data", "unit": "bar"},
    },
}
RAW_MAP = ChannelMap.from_dict(RAW_DOC)


# ----------------------------------------------------------------------- mutations
_edit = st.tuples(
    st.sampled_from(["flip", "insert", "delete", "set", "truncate", "dup"]),
    st.floats(0.0, 1.0, allow_nan=False),
    st.integers(0, 255),
    st.integers(1, 64),
)


def _mutate(data: bytes, edits) -> bytes:
    b = bytearray(data)
    for op, where, byte, length in edits:
        if not b:
            b = bytearray([byte])
            continue
        i = min(int(where * len(b)), len(b) - 1)
        if op == "flip":
            b[i] ^= 1 << (byte % 8)
        elif op == "insert":
            b[i:i] = bytes([byte]) * length
        elif op == "delete":
            del b[i : i + length]
        elif op == "set":
            b[i] = byte
        elif op == "truncate":
            del b[i:]
        else:
            b[i:i] = b[i : i + length]
    return bytes(b)


def _read(target, path, **kw):
    run = load_or_reject(target, DataError, read_run, path, **kw)
    if run is not None:
        assert isinstance(run, Run) and "t" in run.channels
    return run


def _write(name: str, data: bytes):
    path = _SEEDS["dir"] / name
    path.write_bytes(data)
    return path


# ----------------------------------------------------------------------- targets
@pytest.mark.parametrize("fmt", ["csv", "parquet", "mat"])
@given(
    seed=st.sampled_from(["", "-units"]),
    edits=st.lists(_edit, min_size=1, max_size=6),
    validate=st.booleans(),
)
def test_fuzz_bytes(fmt, seed, edits, validate):
    """Byte-level edits of valid files written by the package."""
    path = _write(f"mut.{fmt}", _mutate(_SEEDS[fmt + seed], edits))
    _read(f"read_run[{fmt}] bytes", path, validate=validate)


@pytest.mark.parametrize("fmt", ["csv", "parquet", "mat"])
@given(data=st.binary(max_size=2048))
def test_fuzz_random_bytes(fmt, data):
    path = _write(f"rnd.{fmt}", data)
    _read(f"read_run[{fmt}] random bytes", path)


_TOKENS = st.one_of(
    st.sampled_from(
        [
            "",
            "nan",
            "NaN",
            "inf",
            "-inf",
            "1e400",
            "-1e-400",
            "0x10",
            "1_000",
            "−1",
            " ",
            '"',
            "'",
            "[bar]",
            "1,2",
            "1;2",
            "#",
            "é",
            "\x00",
            "1e5",
            "-0.0",
            "None",
        ]
    ),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=12),
)
_UNITS = st.one_of(
    st.sampled_from(
        [
            "bar",
            "Pa",
            "mm",
            "%",
            "",
            "-",
            "1",
            "degC",
            "K",
            "psi",
            "L/min",
            "lpm",
            "m/s",
            "kg",
            "bar**2",
            "1/0",
            "m**m",
            "m^",
            "(",
            ")",
            "*",
            "**",
            "bar bar",
            "e",
            "pi",
            "nan",
            "inf",
            "1e999 m",
            "__class__",
            "m_",
            "[",
            "]",
            "delta_degC",
            "0",
            "-1",
            "2 bar",
            "bar/0",
            "s**-1.5",
            "m**1e9",
            "dimensionless",
        ]
    ),
    st.text(max_size=10),
)


@given(
    line_edits=st.lists(
        st.tuples(
            st.sampled_from(["delete", "dup", "swap", "cell", "unit", "cols"]),
            st.integers(0, 40),
            st.integers(0, 10),
            _TOKENS,
            _UNITS,
        ),
        min_size=1,
        max_size=5,
    ),
    seed=st.sampled_from(["", "-units"]),
    validate=st.booleans(),
)
def test_fuzz_csv_lines(line_edits, seed, validate):
    """Line- and cell-level edits of a valid CSV: bad numbers, units, row lengths."""
    lines = _SEEDS["csv" + seed].decode().splitlines()
    for op, i, j, tok, unit in line_edits:
        if not lines:
            break
        i %= len(lines)
        if op == "delete":
            del lines[i]
        elif op == "dup":
            lines.insert(i, lines[i])
        elif op == "swap":
            k = (i + 1) % len(lines)
            lines[i], lines[k] = lines[k], lines[i]
        elif op == "cols":
            lines[i] = lines[i] + "," + tok
        else:
            row = lines[i].split(",")
            j %= len(row)
            if op == "unit":
                hdr = [k for k, s in enumerate(lines) if not s.startswith("#")]
                if hdr:
                    cells = lines[hdr[0]].split(",")
                    j %= len(cells)
                    cells[j] = cells[j].split("[")[0] + f"[{unit}]"
                    lines[hdr[0]] = ",".join(cells)
                continue
            row[j] = tok
            lines[i] = ",".join(row)
    path = _write("lines.csv", ("\n".join(lines) + "\n").encode("utf-8", "surrogatepass"))
    _read("read_run[csv] lines/cells/units", path, validate=validate)


_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=8,
)
_HEADER_KEYS = ["format_version", "name", "fs", "meta", "units", "channels"]


@pytest.mark.parametrize("fmt", ["csv", "parquet", "mat"])
@given(
    changes=st.dictionaries(st.sampled_from(_HEADER_KEYS), _JSON, max_size=3),
    whole=st.none() | _JSON,
    validate=st.booleans(),
)
def test_fuzz_metadata_header(fmt, changes, whole, validate):
    """Random JSON values in the ``hydropwa`` metadata (name, fs, meta, units, channels)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    run = _seed_run()
    header = {
        "format_version": 1,
        "name": "seed",
        "fs": 1000.0,
        "meta": {},
        "units": dict(run.units),
        "channels": list(run.channels),
    }
    header.update(changes)
    doc = header if whole is None else whole
    text = json.dumps(doc)
    path = _SEEDS["dir"] / f"hdr.{fmt}"
    cols = {k: np.asarray(v) for k, v in run.channels.items()}
    if fmt == "csv":
        body = _SEEDS["csv"].decode().splitlines()[1:]
        path.write_text(f"# hydropwa: {text}\n" + "\n".join(body) + "\n", encoding="utf-8")
    elif fmt == "parquet":
        table = pa.table(cols).replace_schema_metadata({"hydropwa": text})
        pq.write_table(table, path)
    else:
        scipy.io.savemat(path, {**{k: v.reshape(-1, 1) for k, v in cols.items()}, "hydropwa": text})
    _read(f"read_run[{fmt}] metadata JSON", path, validate=validate)


_SPEC = st.fixed_dictionaries(
    {},
    optional={
        "source": st.sampled_from(
            [
                "qm",
                "data",
                "gtau",
                "rec.X.Data",
                "rec.Y(1).Data",
                "rec.Y(9).Data",
                "rec.Y{p_A}.Data",
                "rec.Y{zz}.Data",
                "rec",
                "rec.Y",
                "missing",
                "qm.x",
                "data(2)",
                "1bad",
                "",
                "a..b",
            ]
        )
        | st.text(max_size=8),
        "column": st.none() | st.integers(-2, 5) | st.floats(allow_nan=True) | st.text(max_size=3),
        "unit": _UNITS | st.integers(),
        "gain": st.floats(allow_nan=True)
        | st.sampled_from(["@gtau", "@qm", "@missing", "@", "x", "@rec.X.Data"])
        | st.integers()
        | st.lists(st.integers(), max_size=2),
        "offset": st.floats(allow_nan=True)
        | st.sampled_from(["@gtau", "1 bar", ""])
        | st.booleans(),
        "other": _JSON,
    },
)
_MAP_DOC = st.fixed_dictionaries(
    {
        "channels": st.dictionaries(
            st.sampled_from(["t", "x", "u", "p_a", "f_l", "extra", "v"]),
            _SPEC | st.text(max_size=6) | _JSON,
            max_size=5,
        )
    },
    optional={
        "map": st.fixed_dictionaries(
            {},
            optional={
                "fs": st.floats(allow_nan=True) | st.integers(-5, 5) | st.text(max_size=4) | _JSON,
                "name": _JSON,
                "keep_unmapped": _JSON,
            },
        )
        | _JSON,
        "meta": _JSON,
    },
)


_FIELD_VALUES = {
    "source": _SPEC.map(lambda d: d.get("source", "qm")),
    "column": st.none() | st.integers(-2, 5) | st.floats(allow_nan=True) | st.booleans(),
    "unit": _UNITS | st.integers(),
    "gain": st.floats(allow_nan=True)
    | st.sampled_from(["@gtau", "@qm", "@rec", "@missing", "@", "x"])
    | st.integers()
    | st.lists(st.integers(), max_size=2),
    "offset": st.floats(allow_nan=True) | st.sampled_from(["@gtau", "1 bar", ""]) | st.booleans(),
}


@st.composite
def _mutated_map(draw):
    """The valid raw-log map with a few fields replaced, channels dropped or added."""
    import copy

    doc = copy.deepcopy(RAW_DOC)
    for _ in range(draw(st.integers(0, 3))):
        op = draw(st.sampled_from(["field", "field", "drop", "add", "head"]))
        chans = doc["channels"]
        if op == "field" and chans:
            ch = draw(st.sampled_from(sorted(chans)))
            key = draw(st.sampled_from(sorted(_FIELD_VALUES)))
            chans[ch][key] = draw(_FIELD_VALUES[key])
        elif op == "drop" and chans:
            del chans[draw(st.sampled_from(sorted(chans)))]
        elif op == "add":
            chans[draw(st.sampled_from(["v", "p_b", "extra", "z"]))] = draw(_SPEC)
        else:
            doc["map"][draw(st.sampled_from(["fs", "keep_unmapped", "name"]))] = draw(
                st.floats(allow_nan=True) | st.integers(-5, 5) | st.booleans() | st.text(max_size=4)
            )
    return doc


@given(
    doc=_mutated_map() | _MAP_DOC | _JSON,
    mutate=st.none() | st.lists(_edit, min_size=1, max_size=3),
    validate=st.booleans(),
)
def test_fuzz_channel_map(doc, mutate, validate):
    """Random and mutated channel maps applied to a raw MAT log (optionally byte-mutated)."""
    data = _SEEDS["raw-mat"] if mutate is None else _mutate(_SEEDS["raw-mat"], mutate)
    path = _write("raw.mat", data)
    cmap = load_or_reject("ChannelMap.from_dict", DataError, ChannelMap.from_dict, doc)
    if cmap is None:
        return
    _read("read_run[mat] with channel map", path, channel_map=cmap, validate=validate)


@given(
    text=st.text(max_size=400)
    | st.sampled_from(
        ["[channels]\nx='qm'", "[channels.x]\nsource=1", "[map]\nfs='x'\n[channels.x]\nsource='qm'"]
    )
)
def test_fuzz_channel_map_toml(text):
    """Random TOML text as a channel-map file."""
    path = _SEEDS["dir"] / "map.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    cmap = load_or_reject("ChannelMap.from_toml", DataError, ChannelMap.from_toml, path)
    if cmap is not None:
        _read(
            "read_run[mat] with channel map",
            _write("raw2.mat", _SEEDS["raw-mat"]),
            channel_map=cmap,
        )


@pytest.mark.parametrize("fmt", ["csv", "parquet", "mat"])
@given(edits=st.lists(_edit, min_size=1, max_size=4))
def test_fuzz_with_builtin_map(fmt, edits):
    """Valid and mutated hydropwa files read through the built-in EMPS map."""
    path = _write(f"emps.{fmt}", _mutate(_SEEDS[fmt], edits))
    _read(f"read_run[{fmt}] emps map", path, channel_map="emps")


def test_seeds_load():
    """The unmutated seeds load (the fuzz targets start from valid files)."""
    for fmt in ("csv", "parquet", "mat"):
        for s in ("", "-units"):
            run = read_run(_write(f"ok.{fmt}", _SEEDS[fmt + s]))
            np.testing.assert_allclose(run["p_a"], 50e5)
    run = read_run(_write("ok-raw.mat", _SEEDS["raw-mat"]), channel_map=RAW_MAP)
    np.testing.assert_allclose(run["p_a"], 40e5)
    np.testing.assert_allclose(run["f_l"], 2.0 * 35.15)


# ----------------------------------------------------------------------- found by fuzzing
_CRASHES = Path(__file__).parent / "data"


@pytest.mark.parametrize(
    "name, why",
    [
        # an inserted byte run leaves a data element of reserved type 8 with 3.5e9 bytes
        ("segv_reserved_type.mat", "unknown element type 8"),
        # a flipped flag marks a real 16×3 double matrix complex: no imaginary part follows
        ("segv_complex_flag.mat", "complex flag"),
    ],
)
def test_mat_files_that_crashed_scipy_are_rejected(name, why):
    """Mutated MAT files on which ``scipy.io.loadmat`` ends the process (segmentation fault).

    ``read_run`` checks the element structure first (``_check_mat_v5``) and gives one
    DataError; a fuzz run of 36 000 such mutations of the seed files found no crash after it.
    """
    with pytest.raises(DataError, match=why):
        read_run(_CRASHES / name)


def test_mat_structure_check_accepts_every_shipped_and_written_file(_seed_dir):
    """The check rejects nothing scipy and MATLAB write: the package's own files (compressed),
    the raw dSPACE-like log (struct, cell, scalars) and the shipped example logs."""
    from hydropwa.data._formats import _check_mat_v5

    paths = [_write("ok.mat", _SEEDS["mat"]), _write("oku.mat", _SEEDS["mat-units"])]
    paths.append(_write("raw.mat", _SEEDS["raw-mat"]))
    root = Path(__file__).parents[2] / "examples"
    paths += [root / "rig_log" / "chirp_log.mat", root / "emps" / "DATA_EMPS.mat"]
    for p in paths:
        _check_mat_v5(p.read_bytes())
