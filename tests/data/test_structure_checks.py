"""Table tests of the two structure checks: the manifest schema (``manifest_problems``) and
the MAT v5 matrix check (``_check_mat_v5`` → ``_mat_matrix``).

Every message each check can give, from a hand-built input that has exactly that fault (the
fuzz tests reach them only by chance), and the order in which several problems are reported.
"""

from __future__ import annotations

import os
import re
import struct

import pytest

from hydropwa.data import manifest_problems
from hydropwa.data._formats import _check_mat_v5

# ---------------------------------------------------------------------------- manifest
OK_RUN = {"name": "a", "file": "a.csv"}


def _doc(*runs, **head):
    return {"format": "hydropwa-dataset", **head, "runs": list(runs)}


@pytest.fixture
def root(tmp_path):
    (tmp_path / "a.csv").write_text("t\n0\n")
    return tmp_path


@pytest.mark.parametrize(
    "doc, expected",
    [
        (_doc(OK_RUN), []),
        (
            _doc(
                {
                    **OK_RUN,
                    "format": "CSV",
                    "kind": "step",
                    "fs": 1000,
                    "n_samples": 5,
                    "duration": 0.004,
                    "channels": {"x": "mm"},
                    "meta": {},
                }
            ),
            [],
        ),
        ([1, 2], ["the document is a JSON list, expected an object with a runs list"]),
        (
            {"format": "other", "format_version": 0, "meta": [], "runs": {}},
            [
                '"format" is \'other\', expected "hydropwa-dataset"',
                '"format_version" 0 is not a positive integer',
                '"meta" must be an object',
                '"runs" must be a list of run entries',
            ],
        ),
        (
            _doc(OK_RUN, format_version=True),
            ['"format_version" True is not a positive integer'],
        ),
        (
            _doc(OK_RUN, format_version=2),
            ['"format_version" 2 is newer than this hydropwa reads (1); update hydropwa'],
        ),
        (_doc(OK_RUN, 5), ["runs[1] is a JSON int, expected an object"]),
        (
            _doc({"file": "a.csv"}),
            ['runs[0] needs a "name" (a non-empty string), has None'],
        ),
        (
            _doc(OK_RUN, {"name": "a", "file": "b.csv"}),
            ["runs[1] ('a'): the name is also runs[0]'s"],
        ),
        (
            _doc({"name": "a", "file": " "}),
            ["runs[0] ('a') needs a \"file\" (a path in the folder), has ' '"],
        ),
        (
            _doc({"name": "a", "file": "../a.csv"}),
            [
                "runs[0] ('a') file '../a.csv' leads out of the dataset folder {root!r} (via "
                "'..' or a symbolic link); a dataset may only read files inside its folder"
            ],
        ),
        (
            _doc({"name": "a", "file": "a.txt"}),
            ["runs[0] ('a'): file 'a.txt' has no run-file suffix (.csv, .parquet, .mat)"],
        ),
        (
            _doc(OK_RUN, {"name": "b", "file": "a.csv"}),
            ["runs[1] ('b'): file 'a.csv' is also runs[0]'s"],
        ),
        (
            _doc({**OK_RUN, "fs": "fast", "n_samples": 2.0, "channels": True}),
            [
                "runs[0] ('a'): 'fs' = 'fast' has the wrong type (str)",
                "runs[0] ('a'): 'n_samples' = 2.0 has the wrong type (float)",
                "runs[0] ('a'): 'channels' = True has the wrong type (bool)",
            ],
        ),
        (
            _doc({**OK_RUN, "format": "hdf5"}),
            ["runs[0] ('a'): format 'hdf5' is not csv, parquet or mat"],
        ),
        (  # all of one entry's problems, in the order the schema lists them
            _doc(
                OK_RUN,
                {"name": "a", "file": "../a.csv", "format": "xls", "meta": 1},
                {"name": "", "file": "/abs.csv"},
            ),
            [
                "runs[1] ('a'): the name is also runs[0]'s",
                "runs[1] ('a') file '../a.csv' leads out of the dataset folder {root!r} (via "
                "'..' or a symbolic link); a dataset may only read files inside its folder",
                "runs[1] ('a'): 'meta' = 1 has the wrong type (int)",
                "runs[1] ('a'): format 'xls' is not csv, parquet or mat",
                "runs[2] needs a \"name\" (a non-empty string), has ''",
                "runs[2] file '/abs.csv' is an absolute path or uses '\\'; a dataset may only "
                "name files inside its folder",
            ],
        ),
    ],
)
def test_each_manifest_problem_is_named_in_schema_order(root, doc, expected):
    expected = [e.replace("{root!r}", repr(str(root))) for e in expected]
    assert manifest_problems(doc, root) == expected


# ---------------------------------------------------------------------------- MAT v5
#: A little-endian MAT v5 header: text, subsystem offset, version 0x0100, "IM".
_HEADER = b"MATLAB 5.0 MAT-file".ljust(116, b" ") + bytes(8) + struct.pack("<H", 0x0100) + b"IM"
DOUBLE, INT32, UINT32, INT8, UTF8, MATRIX = 9, 5, 6, 1, 16, 14


def _element(typ: int, data: bytes) -> bytes:
    """A tagged data element padded to 8 bytes."""
    return struct.pack("<II", typ, len(data)) + data + bytes(-len(data) % 8)


def _matrix(cls: int, dims=(1, 1), *parts: bytes, complex_=False, flags=None, dim_bytes=None):
    """A miMATRIX element: array flags, dimensions, name, then ``parts`` (not padded: its
    sub-elements are)."""
    flags = (
        _element(UINT32, struct.pack("<II", cls | (0x0800 * complex_), 0))
        if flags is None
        else flags
    )
    dim_bytes = struct.pack(f"<{len(dims)}i", *dims) if dim_bytes is None else dim_bytes
    body = flags + _element(INT32, dim_bytes) + _element(INT8, b"x") + b"".join(parts)
    return struct.pack("<II", MATRIX, len(body)) + body


def _doubles(n: int) -> bytes:
    return _element(DOUBLE, bytes(8 * n))


_EMPTY = struct.pack("<II", MATRIX, 0)  # an empty struct field or cell


def _struct_parts(names: bytes, length: int, *fields: bytes) -> tuple[bytes, ...]:
    return (_element(INT32, struct.pack("<i", length)), _element(INT8, names), *fields)


@pytest.mark.parametrize(
    "element, why",
    [
        (_matrix(6, (2, 3), _doubles(6)), None),
        (_matrix(6, (2, 1), _doubles(2), _doubles(2), complex_=True), None),
        (_matrix(4, (1, 3), _element(UTF8, b"abcd")), None),  # UTF-8: size not checked
        (_EMPTY, None),
        (
            _matrix(5, (3, 3), _element(INT32, bytes(4)), _element(INT32, bytes(16)), _doubles(1)),
            None,
        ),
        (_matrix(1, (1, 2), _EMPTY, _matrix(6, (1, 1), _doubles(1))), None),
        (_matrix(2, (1, 2), *_struct_parts(b"a".ljust(8, b"\0"), 8, _EMPTY, _EMPTY)), None),
        (_matrix(3, (1, 1), _element(INT8, b"cls"), *_struct_parts(bytes(8), 8, _EMPTY)), None),
        (_matrix(16, (1, 1)), None),  # function handle: left to scipy
        (_matrix(17, (1, 1), _EMPTY), None),  # opaque (MCOS) object: left to scipy
        (
            _matrix(6, flags=_element(INT32, bytes(8))),
            "matrix without array flags, dimensions and name",
        ),
        (_matrix(6, (3,), _doubles(3)), "matrix dimensions malformed"),
        (_matrix(6, dim_bytes=bytes(10)), "matrix dimensions malformed"),
        (_matrix(6, (2, -1)), "matrix dimensions (2, -1) invalid"),
        (_matrix(6, (65536, 65536)), "matrix dimensions (65536, 65536) invalid"),
        (_matrix(6, (2, 1), _doubles(2), complex_=True), "numeric matrix parts do not match"),
        (_matrix(6, (1, 1), _EMPTY), "numeric matrix parts do not match"),
        (_matrix(6, (2, 3), _doubles(5)), "matrix data of 40 bytes for dimensions (2, 3)"),
        (_matrix(5, (3, 3), _doubles(1)), "sparse matrix parts malformed"),
        (_matrix(1, (1, 2), _EMPTY), "cell array parts do not match its dimensions"),
        (_matrix(1, (1, 1), _doubles(1)), "cell array parts do not match its dimensions"),
        (_matrix(2, (1, 1), _element(INT32, bytes(4))), "struct without field names"),
        (
            _matrix(3, (1, 1), *_struct_parts(bytes(8), 8, _EMPTY)),  # no class name
            "struct without field names",
        ),
        (_matrix(2, (1, 1), *_struct_parts(bytes(8), 0)), "struct field names malformed"),
        (_matrix(2, (1, 1), *_struct_parts(bytes(12), 8)), "struct field names malformed"),
        (
            _matrix(2, (1, 2), *_struct_parts(bytes(8), 8, _EMPTY)),
            "struct parts do not match its dimensions and fields",
        ),
        (
            _matrix(2, (1, 1), *_struct_parts(bytes(8), 8, _doubles(1))),
            "struct parts do not match its dimensions and fields",
        ),
        (_matrix(99, (1, 1)), "unknown matrix class 99"),
    ],
    ids=[
        *("double complex char empty sparse cell struct object function-handle opaque".split()),
        *(
            "no-flags one-dim ragged-dims negative-dim too-large no-imaginary numeric-nested".split()
        ),
        *("data-size sparse-parts cell-count cell-data no-names no-class-name".split()),
        *("zero-name-length ragged-names struct-count struct-data unknown-class".split()),
    ],
)
def test_each_mat_matrix_fault_is_named(element, why):
    # at the top level, and nested one level down in a cell: the same verdict
    for buf in (_HEADER + element, _HEADER + _matrix(1, (1, 1), element)):
        if why is None:
            _check_mat_v5(buf)
        else:
            with pytest.raises(ValueError, match=re.escape(why)):
                _check_mat_v5(buf)


def test_the_hand_built_header_is_one_scipy_reads(tmp_path):
    """The table's files are real MAT v5: scipy reads a valid one to the value written."""
    import scipy.io

    path = tmp_path / "x.mat"
    data = struct.pack("<4d", 1.0, 2.0, 3.0, 4.0)
    path.write_bytes(_HEADER + _matrix(6, (2, 2), _element(DOUBLE, data)))
    _check_mat_v5(path.read_bytes())
    assert scipy.io.loadmat(os.fspath(path))["x"].tolist() == [[1.0, 3.0], [2.0, 4.0]]
