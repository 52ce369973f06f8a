"""Fuzz every subcommand of the ``hydropwa`` command line and the dataset/sweep loaders.

Each example builds a command line from a grammar of the subcommand's options, with values
drawn from valid and hostile sets: numbers out of range, NaN/inf, quantities with wrong or
missing units, existing outputs, a file where a folder is expected, a folder where a file
is expected, manifests that point out of their dataset (``..``, absolute paths, symbolic
links), malformed TOML/JSON, unknown options; and optionally an injected ``OSError``
(read-only file system, disk full) in every temporary file the package creates.

Contract (``_fuzzutil.cli_violation``): exit 0, exit 1 only for ``data check`` listing
issues, or exit 2 with exactly one ``error: ...`` line on stderr; never a traceback or an
internal error. Beyond the contract, each example checks that no protected file changed
without ``--force`` (data loss) and that no command accepted a dataset that reaches
outside its folder (path escape).

Long profile: ``HYPOTHESIS_PROFILE=long`` (see ``docs/robustness.md``).
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import itertools
import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from _fuzzutil import check_cli, load_or_reject, violation
from hypothesis import given, settings
from hypothesis import strategies as st
from robust_support import PROFILE

from hydropwa import DataError, HydropwaError
from hydropwa.data import Run, check_dataset, read_dataset, write_dataset, write_run
from hydropwa.params import get_preset, save_params
from hydropwa.sweep import load_sweep

#: Examples per CLI target: each is one in-process command (some simulate briefly).
CLI_EXAMPLES = {"ci": 25, "dev": 8, "long": 400}.get(PROFILE, 25)
#: Examples per loader target (no simulation).
LOADER_EXAMPLES = {"ci": 100, "dev": 20, "long": 3000}.get(PROFILE, 100)

_CLI = settings(max_examples=CLI_EXAMPLES, deadline=None)
_LOADER = settings(max_examples=LOADER_EXAMPLES, deadline=None)

_W: dict = {}
_COUNTER = itertools.count()

#: Files whose bytes no command may change without --force.
_PROTECTED = (
    "keep.csv",
    "keep.toml",
    "keep.json",
    "keep.md",
    "keepdir/k.txt",
    "ds/manifest.json",
    "secret/secret.csv",
)


def _run(n: int = 64) -> Run:
    t = np.arange(n) / 1000.0
    return Run(
        name="seed",
        channels={
            "t": t,
            "u": 0.3 * np.sin(40 * t),
            "x": 0.1 + 0.01 * t,
            "p_a": np.full(n, 50e5),
            "p_b": np.linspace(30e5, 31e5, n),
        },
        fs=1000.0,
        meta={"kind": "sine"},
    )


def _manifest(entries) -> str:
    return json.dumps(
        {"format": "hydropwa-dataset", "format_version": 1, "meta": {}, "runs": entries}
    )


def _entry(file: str, name: str = "r") -> dict:
    return {"name": name, "file": file, "format": "csv", "kind": "sine", "fs": 1000.0}


def _build(root: Path) -> None:
    run = _run()
    for fmt in ("csv", "parquet", "mat"):
        write_run(run, root / f"good.{fmt}")
    write_dataset([run], root / "ds")
    write_run(run, root / "secret" / "secret.csv")
    secret = (root / "secret" / "secret.csv").resolve()
    for name, file in (
        ("evil_rel", "../secret/secret.csv"),
        ("evil_abs", str(secret)),
        ("evilroot/sine", "../../secret/secret.csv"),
    ):
        (root / name).mkdir(parents=True)
        (root / name / "manifest.json").write_text(_manifest([_entry(file)]))
    (root / "evil_link").mkdir()
    (root / "evil_link" / "r.csv").symlink_to(secret)
    (root / "evil_link" / "manifest.json").write_text(_manifest([_entry("r.csv")]))
    (root / "raw_link").mkdir()
    (root / "raw_link" / "r.csv").symlink_to(secret)
    for name, text in (
        ("man_list", "[]"),
        ("man_noname", _manifest([{"file": "x.csv"}])),
        ("man_types", _manifest([{"name": 5, "file": ["x"], "fs": "fast"}])),
        ("man_deep", "[" * 100000 + "]" * 100000),
        ("man_dup", _manifest([_entry("a.csv"), _entry("a.csv")])),
    ):
        (root / name).mkdir()
        (root / name / "manifest.json").write_text(text)
    (root / "man_bytes").mkdir()
    (root / "man_bytes" / "manifest.json").write_bytes(b'{"format": "\xff"}')
    (root / "afile").write_text("a file\n")
    (root / "adir").mkdir()
    (root / "adir" / "x.txt").write_text("x\n")
    (root / "empty").mkdir()
    save_params(get_preset("paper"), root / "params.toml")
    (root / "deep.toml").write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    (root / "binary.toml").write_bytes(b"\xff\xfe\x00junk")
    sweeps = {
        "sweep_ok": '[grid]\n"load.mass" = [1.0, 2.0]\n[input]\nduration = 0.02\nmodel = "reduced"\nfs = 500\n',
        "sweep_gird": '[gird]\n"load.mass" = [1.0, 2.0]\n',
        "sweep_rev": '[random]\nn = 3\n"friction.coulomb" = {uniform = [40, 10]}\n',
        "sweep_empty": '[grid]\n"load.mass" = []\n',
        "sweep_syntax": '[grid\n"load.mass" = [1.0\n',
        "sweep_big": '[random]\nn = 100000000\n"load.mass" = {uniform = [1, 2]}\n',
        "sweep_dup": "[input]\nduration = 1\nduration = 2\n",
        "sweep_key": "[input]\ndurration = 1\n",
        "sweep_ps": '[input]\nsupply_pressure = "-5 bar"\nduration = 0.02\n',
        "sweep_long": "[input]\nduration = 1e9\nfs = 1e6\n",
    }
    for name, text in sweeps.items():  # each names its machine (no default machine)
        (root / f"{name}.toml").write_text('base = "paper"\n' + text)
    _protect(root)


def _protect(root: Path) -> None:
    (root / "keepdir").mkdir(exist_ok=True)
    for name in _PROTECTED[:5]:
        src = root / "good.csv" if name.endswith(".csv") else None
        (root / name).write_bytes(src.read_bytes() if src else f"protected {name}\n".encode())


def _hashes(root: Path) -> dict[str, str]:
    return {n: hashlib.sha256((root / n).read_bytes()).hexdigest() for n in _PROTECTED}


@pytest.fixture(scope="module", autouse=True)
def _workspace(tmp_path_factory):
    root = tmp_path_factory.mktemp("cli")
    _build(root)
    _W.clear()
    _W.update(root=root, hashes=_hashes(root))
    yield
    _W.clear()


# ------------------------------------------------------------------- value pools
_NUM = ["0", "-1", "1e9", "1e308", "nan", "inf", "-inf", "abc", "", "1e-300", "0x10", "2"]
_QTY = [
    "95 bar",
    "-5 bar",
    "0 bar",
    "1e9 bar",
    "100",
    "5 m",
    "nan bar",
    "bar",
    "1e5 Pa",
    "sine:offset=95e5,amplitude=1e5,frequency=1",
    "step:after=-1e6",
    "sine:amplitude=",
    "95 barr",
]
_SIGNALS = [
    "sine:amplitude=0.4,frequency=1",
    "sine:amplitude=0.4,amplitude=0.5",
    "step:after=0.2",
    "0.1",
    "40 %",
    "chirp:",
    "bogus:x=1",
    "1e308",
    "nan",
    "",
]
_OUT_FILE = [
    "NEW.csv",
    "NEW.parquet",
    "NEW.txt",
    "NEW",
    "keep.csv",
    "afile/x.csv",
    "adir",
    "deep/er/NEW.csv",
    "keepdir",
    ".",
    "NEW.csv/",
]
_OUT_DIR = ["NEWDIR", "keepdir", "afile", "afile/sub", "empty", "adir", "NEWDIR/sub"]
_IN_RUN = [
    "good.csv",
    "good.parquet",
    "good.mat",
    "afile",
    "adir",
    "nosuch.csv",
    "keep.json",
    "binary.toml",
    "ds",
    "evil_rel",
    "evil_abs",
    "evil_link",
    "raw_link",
    "secret/secret.csv",
]
_IN_DS = [
    "ds",
    "evil_rel",
    "evil_abs",
    "evil_link",
    "raw_link",
    "evilroot",
    "man_list",
    "man_noname",
    "man_types",
    "man_deep",
    "man_dup",
    "man_bytes",
    "afile",
    "nosuch",
    "empty",
    "adir",
    "good.csv",
]
_PARAMS = [
    "paper",
    "symmetric",
    "params.toml",
    "deep.toml",
    "binary.toml",
    "afile",
    "adir",
    "nosuch",
    "keep.toml",
    "sweep_ok.toml",
]
_FAULTS = [None, None, None, errno.EROFS, errno.ENOSPC, errno.EACCES]

_ESCAPES = {"evil_rel", "evil_abs", "evil_link", "raw_link", "evilroot"}


def _opt(name, values):
    return st.one_of(st.just([]), st.sampled_from(values).map(lambda v: [name, v]))


def _flag(name):
    return st.sampled_from([[], [name]])


@st.composite
def _argv(draw, fixed, options, flags=()):
    args = list(fixed)
    parts = [draw(_opt(n, v)) for n, v in options] + [draw(_flag(f)) for f in flags]
    for p in draw(st.permutations(parts)):
        args += p
    return args


def _fresh(argv: list[str]) -> list[str]:
    """Give every NEW placeholder a name no earlier example used."""
    k = next(_COUNTER)
    return [a.replace("NEWDIR", f"d{k}").replace("NEW", f"n{k}") for a in argv]


@contextlib.contextmanager
def _fault(code):
    """Every temporary file the package creates fails with ``code`` (read-only FS, disk full)."""
    if code is None:
        yield
        return
    real = tempfile.mkstemp

    def broken(*args, **kwargs):
        raise OSError(code, os.strerror(code), kwargs.get("dir") or "tmp")

    tempfile.mkstemp = broken
    try:
        yield
    finally:
        tempfile.mkstemp = real


def _check(target: str, argv: list[str], fault=None) -> int:
    root = _W["root"]
    argv = _fresh(argv)
    with _fault(fault):
        code, _out, _err = check_cli(target, argv, root)
    forced = "--force" in argv or "--overwrite" in argv
    now = _hashes(root)
    if forced:
        _protect(root)
        _W["hashes"] = _hashes(root)
    else:
        changed = [n for n in _PROTECTED if now[n] != _W["hashes"][n]]
        if changed:
            violation(target, argv, f"data loss: changed {changed} without --force")
            _protect(root)
            _W["hashes"] = _hashes(root)
    sources = [a for a in argv if a.split("/")[0] in _ESCAPES]
    if sources and code in (0, 1) and argv[0] in ("data", "paper", "identify", "simulate"):
        violation(target, argv, f"path escape: accepted {sources} (exit {code})")
    return code


# ------------------------------------------------------------------- subcommands
def _with_machine(argv: list[str]) -> list[str]:
    """The machine, where the drawn options name none (no machine is its own test:
    tests/cli/test_no_default_machine.py), so the fuzz reaches past that first check."""
    return argv if "--params" in argv else [*argv, "--params", "paper"]


@_CLI
@given(
    argv=st.one_of(
        _argv(["params", "show"], []).flatmap(
            lambda a: st.sampled_from(_PARAMS + [""]).map(lambda p: a + [p])
        ),
        _argv(
            ["params", "export"],
            [("--out", ["NEW.toml", "keep.toml", "NEW.txt", "afile/x.toml", "adir"])],
            ["--force"],
        ).flatmap(lambda a: st.sampled_from(_PARAMS).map(lambda p: a + [p])),
    ),
    fault=st.sampled_from(_FAULTS),
)
def test_fuzz_cli_params(argv, fault):
    _check("cli params", argv, fault)


@_CLI
@given(
    argv=_argv(
        ["simulate"],
        [
            ("--model", ["full", "reduced", "pwa", "bogus"]),
            ("--params", _PARAMS),
            ("--input", _SIGNALS),
            ("--input-file", _IN_RUN),
            ("--duration", ["0.02", "0.05"] + _NUM),
            ("--sample-time", ["2 ms", "1e-12", "1 kHz"] + _NUM),
            ("--rtol", ["1e-3", "1e-12", "0.5"] + _NUM),
            ("--supply-pressure", _QTY),
            ("--load-force", ["500 N", "1e30 N", "nan", "5 bar", "sine:amplitude=100,frequency=1"]),
            ("--x0", ["100 mm", "-1 m", "5 m", "nan", "1 bar"]),
            ("--out", _OUT_FILE),
            ("--plot", ["NEW.png", "NEW.xyz", "keep.csv", "afile/x.png", "adir", "NEW.pdf"]),
        ],
        ["--force"],
    )
    .map(lambda a: a if "--duration" in a else a + ["--duration", "0.02"])
    .map(_with_machine),
    fault=st.sampled_from(_FAULTS),
)
def test_fuzz_cli_simulate(argv, fault):
    _check("cli simulate", argv, fault)


#: simulate options: (valid values, hostile values). A valid command with at most one hostile
#: option: the valid path runs often, and each error is met alone.
_SIM_OPTIONS = {
    "--model": (["full", "reduced"], ["bogus", "", "FULL "]),  # pwa: a linearization per run, slow
    "--params": (
        ["paper", "symmetric", "params.toml"],
        ["deep.toml", "binary.toml", "afile", "nosuch"],
    ),
    "--input": (_SIGNALS[:5], _SIGNALS[5:]),
    "--duration": (["0.02", "0.05", "20 ms"], ["0", "-1", "nan", "1e9", "1e308", "1e-9", "x"]),
    "--sample-time": (["2 ms", "1 kHz", "5e-4"], ["0", "-5 ms", "inf", "1e-12", "x", "2 bar"]),
    "--rtol": (["1e-3", "1e-5", "0.01"], ["0", "-1", "2", "nan"]),
    "--supply-pressure": (
        ["95 bar", "1e7", "sine:offset=95e5,amplitude=1e5,frequency=1"],
        _QTY[1:4] + _QTY[6:9],
    ),
    "--load-force": (["500 N", "-1 kN", "step:after=200"], ["nan", "5 bar", "x"]),
    "--x0": (["100 mm", "0.05 m"], ["-1 m", "5 m", "1 bar"]),
    "--plot": (["NEW.png", "NEW.svg"], ["NEW.xyz", "keep.csv", "afile/x.png", "adir"]),
}


@st.composite
def _simulate_one_bad(draw):
    names = draw(st.lists(st.sampled_from(sorted(_SIM_OPTIONS)), unique=True, max_size=5))
    bad = draw(st.sampled_from([None, *names]))
    argv = ["simulate", "--out", draw(st.sampled_from(["NEW.csv", "NEW.parquet"]))]
    if "--duration" not in names:
        argv += ["--duration", "0.02"]
    for n in names:
        good, hostile = _SIM_OPTIONS[n]
        argv += [n, draw(st.sampled_from(hostile if n == bad else good))]
    return _with_machine(argv)


@_CLI
@given(argv=_simulate_one_bad())
def test_fuzz_cli_simulate_valid_or_one_bad(argv):
    argv = _fresh(argv)
    code = _check("cli simulate (one bad option)", argv)
    out = _W["root"] / argv[2]
    assert (code == 0) == out.is_file(), (
        f"hydropwa {argv}: exit {code}, output written: {out.is_file()}"
    )


@_CLI
@given(
    argv=st.one_of(
        st.tuples(
            st.sampled_from(_IN_DS + _IN_RUN),
            _argv([], [("--channel-map", ["emps", "afile", "nosuch", "params.toml"])], ["--plain"]),
        ).map(lambda t: ["data", "check", t[0], *t[1]]),
        st.tuples(
            st.sampled_from(_IN_DS + _IN_RUN),
            st.sampled_from(_OUT_FILE + _OUT_DIR + ["NEW.mat", "good.csv"]),
            _argv(
                [], [("--format", ["csv", "parquet", "mat", "xls", ""])], ["--force", "--resample"]
            ),
        ).map(lambda t: ["data", "convert", t[0], t[1], *t[2]]),
    ),
    fault=st.sampled_from(_FAULTS),
)
def test_fuzz_cli_data(argv, fault):
    _check("cli data", argv, fault)


@_CLI
@given(
    argv=st.tuples(
        st.sampled_from(
            [
                f"sweep_{n}.toml"
                for n in (
                    "ok",
                    "ok",
                    "gird",
                    "rev",
                    "empty",
                    "syntax",
                    "big",
                    "dup",
                    "key",
                    "ps",
                    "long",
                )
            ]
            + ["afile", "nosuch.toml", "adir", "deep.toml", "binary.toml"]
        ),
        _argv(
            [],
            [
                ("--out", _OUT_FILE),
                ("--trajectories", _OUT_DIR),
                (
                    "--scheduler",
                    ["tcp://127.0.0.1:1", "tcp://", "nonsense", "tcp://host:99999", "[::1]:x"],
                ),
                ("--jobs", ["1", "2", "0", "-1", "x"]),
            ],
            ["--force"],
        ),
    ).map(lambda t: ["sweep", t[0], "-q", *t[1]]),
    fault=st.sampled_from(_FAULTS),
)
def test_fuzz_cli_sweep(argv, fault):
    _check("cli sweep", argv, fault)


@_CLI
@given(
    argv=_argv(
        ["linearize"],
        [
            ("--out", ["NEW.json", "keep.json", "NEW.txt", "afile/x.json", "adir"]),
            ("--params", _PARAMS),
            ("--supply-pressure", _QTY[:9]),
            (
                "--cells",
                ["cq=5,cqp=5,friction=7", "cq=0", "cq=x", "cq=-3", "=", "bogus=3", "cq=100000"],
            ),
            ("--breakpoints", ["paper", "tangent", "bogus"]),
            ("--form", ["consistent", "paper", "bogus"]),
            ("--sample-time", ["1 ms", "-1 s", "0", "1 bar", "nan"]),
            ("--figures", _OUT_DIR),
            ("--tables", _OUT_DIR),
        ],
        ["--force", "--scheduled"],
    )
    .map(lambda a: a if "--out" in a else a + ["--out", "NEW.json"])
    .map(_with_machine),
    fault=st.sampled_from(_FAULTS),
)
def test_fuzz_cli_linearize(argv, fault):
    _check("cli linearize", argv, fault)


# Commands that run for minutes on valid input (a campaign, the study, identification) get
# at least one hostile argument each: the fuzz is about their error paths.
@_CLI
@given(
    argv=st.one_of(
        st.tuples(
            st.sampled_from(["frf", "deadzone", "friction", "all"]),
            st.sampled_from(_IN_DS),
            _argv(
                [],
                [
                    ("--out", ["NEW.toml", "keep.toml", "NEW.txt", "adir"]),
                    ("--figures", _OUT_DIR),
                    ("--summary", ["NEW.md", "keep.md", "keep.toml", "adir"]),
                    ("--params", _PARAMS),
                ],
                ["--force"],
            ),
        ).map(lambda t: ["identify", t[0], t[1], *t[2]]),
        st.tuples(
            st.sampled_from(["good.mat", "afile", "nosuch.mat", "adir", "good.csv", "binary.toml"]),
            _argv(
                [],
                [
                    ("--summary", ["NEW.md", "keep.md", "adir"]),
                    ("--figures", _OUT_DIR),
                    ("--validation", ["good.mat", "nosuch.mat", "afile"]),
                ],
                ["--force", "--asymmetric"],
            ),
        ).map(lambda t: ["identify", "emps", t[0], *t[1]]),
        st.tuples(
            st.sampled_from(["frf", "deadzone", "friction", "sine", "all", "bogus"]),
            st.sampled_from(
                ["afile", "nosuch", "deep.toml", "binary.toml", "sweep_ok.toml", "keep.toml"]
            ),
            _argv(
                [],
                [
                    ("--out", _OUT_DIR),
                    ("--params", _PARAMS),
                    ("--seed", ["-1", "0", "x", "99999999999999999999999"]),
                    ("--jobs", ["0", "1", "-2"]),
                ],
                ["--force"],
            ),
        ).map(lambda t: ["rig", "run", t[0], "--campaign", t[1], "-q", *t[2]]),
        st.tuples(
            st.sampled_from(
                sorted(_ESCAPES) + ["afile", "nosuch", "empty", "ds", "man_list", "adir"]
            ),
            _argv([], [("--out", _OUT_DIR), ("--params", _PARAMS)], ["--force", "--fresh"]),
        ).map(lambda t: ["paper", "--data", t[0], "-q", *t[1]]),
        _argv(["paper", "-q"], [("--out", _OUT_DIR), ("--params", _PARAMS)], ["--force"]).map(
            lambda a: a + ["--campaign", "nosuch"]
        ),
    ),
    fault=st.sampled_from(_FAULTS),
)
def test_fuzz_cli_long_commands(argv, fault):
    _check("cli identify/rig/paper", argv, fault)


_WORDS = [
    "simulate",
    "params",
    "show",
    "export",
    "data",
    "check",
    "convert",
    "sweep",
    "linearize",
    "identify",
    "frf",
    "rig",
    "run",
    "paper",
    "--out",
    "-o",
    "--force",
    "--bogus",
    "-x",
    "--duration",
    "--help",
    "--sample-time",
    "--fs",
    "=",
    "--",
    "-",
    "afile",
    "ds",
    "\x00",
    "é",
    "--rtol=-1",
    "--jobs=0",
    "campaigns",
]


@_CLI
@given(
    argv=st.lists(st.sampled_from(_WORDS) | st.text(max_size=8), max_size=6).filter(
        lambda a: (
            not ({"run", "paper", "identify", "sweep", "simulate", "linearize"} & set(a))
            or {"--bogus", "-x", "=", "--rtol=-1", "--jobs=0"} & set(a)
        )
    )
)
def test_fuzz_cli_random_words(argv):
    """Random words: usage errors (unknown options, missing arguments) are one line too."""
    _check("cli random argv", [a.replace("\x00", "") for a in argv])


# ------------------------------------------------------------------- loaders
_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12),
    lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=8), c, max_size=4),
    max_leaves=12,
)
_FILES = [
    "s.csv",
    "sub/s.csv",
    "./s.csv",
    "r.csv",
    "../secret/secret.csv",
    "/etc/passwd",
    "sub/../r.csv",
    "sub/../../x.csv",
    "link.csv",
    "r.txt",
    "",
    ".",
    "..",
    "r.csv\x00",
    "\\..\\x.csv",
    "C:/x.csv",
]


@st.composite
def _manifest_doc(draw):
    doc = {"format": "hydropwa-dataset", "format_version": 1, "meta": {}, "runs": [_entry("r.csv")]}
    for _ in range(draw(st.integers(0, 3))):
        where = draw(st.sampled_from(["top", "entry", "file", "whole", "add"]))
        if not isinstance(doc, dict):
            break
        if where == "top":
            doc[draw(st.sampled_from(["format", "format_version", "meta", "runs", "x"]))] = draw(
                _JSON
            )
        elif where == "entry" and isinstance(doc.get("runs"), list) and doc["runs"]:
            e = doc["runs"][0]
            if isinstance(e, dict):
                e[
                    draw(
                        st.sampled_from(
                            [
                                "name",
                                "file",
                                "format",
                                "kind",
                                "fs",
                                "n_samples",
                                "channels",
                                "meta",
                            ]
                        )
                    )
                ] = draw(_JSON)
        elif where == "file" and isinstance(doc.get("runs"), list):
            name = draw(st.sampled_from(["s", "t"]) | st.text(max_size=4))
            doc["runs"].append(_entry(draw(st.sampled_from(_FILES)), name=name))
        elif where == "add" and isinstance(doc.get("runs"), list):
            doc["runs"].append(draw(_JSON))
        else:
            doc = draw(_JSON)
    return doc


def _secret_read(ds) -> bool:
    return any(
        Path(p).resolve() == (_W["root"] / "secret" / "secret.csv").resolve()
        for p in (ds.path_of(n) for n in ds.names)
    )


@_LOADER
@given(doc=_manifest_doc())
def test_fuzz_manifest(doc):
    """Manifests of any shape: load only runs inside the folder, or raise DataError."""
    d = _W["root"] / "mf" / "ds"
    d.mkdir(parents=True, exist_ok=True)
    for f in ("r.csv", "s.csv", "sub/s.csv"):
        if not (d / f).exists():
            write_run(_run(), d / f)
    with contextlib.suppress(FileExistsError):
        (d / "link.csv").symlink_to(_W["root"] / "secret" / "secret.csv")
    (d / "manifest.json").write_text(json.dumps(doc))
    ds = load_or_reject("read_dataset (manifest)", DataError, read_dataset, d, validate=False)
    if ds is not None and _secret_read(ds):
        violation(
            "read_dataset (manifest)", doc, "path escape: a run file outside the dataset loaded"
        )
    issues = load_or_reject("check_dataset (manifest)", DataError, check_dataset, d)
    if issues is not None:
        assert isinstance(issues, list)


_SPEC_LINES = [
    "[grid]",
    '"load.mass" = [1.0, 2.0]',
    '"load.mass" = []',
    '"supply.pressure" = ["80 bar", "-1 bar"]',
    "[random]",
    "n = 3",
    "n = -1",
    "n = 1e9",
    'seed = "x"',
    '"friction.coulomb" = {uniform = [10, 40]}',
    '"friction.coulomb" = {uniform = [40, 10]}',
    '"load.mass" = {loguniform = [-1, 2]}',
    '"load.mass" = {normal = [1, -1]}',
    "[input]",
    "duration = 0.02",
    "duration = -1",
    "fs = 0",
    "rtol = 2",
    'model = "bogus"',
    'u = "sine:amplitude=0.4"',
    'u = "x:"',
    "solver = 5",
    'supply_pressure = "0 bar"',
    'load_force = "nan"',
    'base = "nosuch"',
    "base = 5",
    "[gird]",
    "bogus = 1",
    '"nosuch.field" = [1]',
    "[input",
    "x = ",
    '"a.b" = {uniform = [1]}',
]


#: Lines of _SPEC_LINES that are valid where they stand; every other one is invalid in any
#: section (unknown section or key, bad bound, value or type), so a sweep holding one must fail.
_SPEC_VALID = {
    "[grid]",
    '"load.mass" = [1.0, 2.0]',
    "[random]",
    "n = 3",
    '"friction.coulomb" = {uniform = [10, 40]}',
    "[input]",
    "duration = 0.02",
    'u = "sine:amplitude=0.4"',
}


@_LOADER
@given(lines=st.lists(st.sampled_from(_SPEC_LINES) | st.text(max_size=20), max_size=8))
def test_fuzz_sweep_spec(lines):
    """Sweep files: load a sweep that passes every check, or raise one documented error."""
    path = _W["root"] / "spec_fuzz.toml"
    # the machine first (a sweep without base is refused); a second base line is a TOML error
    path.write_bytes(('base = "paper"\n' + "\n".join(lines)).encode("utf-8", "surrogatepass"))
    spec = load_or_reject("load_sweep", HydropwaError, load_sweep, path)
    bad = [ln for ln in lines if ln in _SPEC_LINES and ln not in _SPEC_VALID]
    if spec is not None and bad:
        violation("load_sweep", lines, f"silently accepted: {bad}")
