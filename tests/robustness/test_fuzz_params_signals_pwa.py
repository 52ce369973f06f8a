"""Fuzz the parameter TOML loader, the signal-spec parser and the PWA JSON loader.

Seeds: ``save_params`` output of the presets, specs the docs show, and a PWA document from
``PwaModel.to_json`` / ``save_pwa``. Inputs: those seeds with mutated lines, values and bytes,
random TOML/JSON-shaped dicts and random text. Contract (``_fuzzutil``): load, or raise the
documented error (ParameterError, SignalError, PwaError).
"""

from __future__ import annotations

import copy
import json
import warnings

import pytest
from _fuzzutil import load_or_reject
from hypothesis import given
from hypothesis import strategies as st

from hydropwa import ParameterError, PwaError, SignalError, SystemParams, get_preset, parse_signal
from hydropwa.params import load_params, params_from_dict, params_to_toml
from hydropwa.simulation import Signal

_SEEDS: dict = {}


@pytest.fixture(scope="module", autouse=True)
def _seeds(tmp_path_factory):
    from hydropwa.linearization import linearize, save_pwa

    d = tmp_path_factory.mktemp("seeds")
    paper = get_preset("paper")
    model = linearize(paper)
    _SEEDS.update(
        dir=d,
        toml=params_to_toml(paper),
        toml_sym=params_to_toml(get_preset("symmetric")),
        dict=paper.to_dict(),
        pwa_json=model.to_json(),
        pwa_export=save_pwa(model, d / "seed.json").read_text(),
    )
    yield
    _SEEDS.clear()


def _quiet(fn, *args, **kwargs):
    # Cylinder warns (UserWarning, documented) when a dead volume looks like litres given as m³;
    # that is a valid load, not a contract violation.
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Cylinder\.dead_volume", category=UserWarning)
        return fn(*args, **kwargs)


_VALUES = st.one_of(
    st.sampled_from(
        [
            "100 bar",
            "40 L/min",
            "0.7 L",
            "10 %",
            "1e400",
            "nan",
            "inf",
            "-inf",
            "0",
            "-1",
            "1 m",
            "2 Hz",
            "100 rad/s",
            "1/0",
            "bar**bar",
            "1e9999 Pa",
            "3 kg*m",
            "__import__('os')",
            "degC",
            "5 degC",
            "1 percent_opening",
            "",
            " ",
            "1e-400",
            "10 kN",
            "True",
            "[1]",
            "0x10",
            "1_0",
            "½",
            "1 bar bar",
            "m^-2",
            "(",
            "e",
            "pi",
        ]
    ),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.booleans(),
    st.text(max_size=12),
    st.lists(st.floats(-2, 2) | st.text(max_size=3), max_size=3),
    st.lists(st.lists(st.floats(-2, 1e4) | st.text(max_size=4), max_size=3), max_size=3),
    st.dictionaries(
        st.sampled_from(["flow", "pressure_drop", "x"]),
        st.sampled_from(["40 L/min", "70 bar", "-1 bar", 0, "x"]),
        max_size=3,
    ),
)
_SECTIONS = ["valve", "dead_zone", "flow", "cylinder", "oil", "friction", "supply", "load"]


@st.composite
def _mutated_params(draw):
    doc = copy.deepcopy(_SEEDS["dict"])
    for _ in range(draw(st.integers(1, 4))):
        sec = draw(st.sampled_from(_SECTIONS + ["meta", "base", "uncertainty", "bogus"]))
        if sec in doc and isinstance(doc[sec], dict) and draw(st.booleans()):
            key = draw(st.sampled_from(sorted(doc[sec]) + ["rating", "bogus"]))
            doc[sec][key] = draw(_VALUES)
        else:
            doc[sec] = draw(_VALUES | st.sampled_from(["paper", "symmetric", "nope"]))
    return doc


@given(doc=_mutated_params())
def test_fuzz_params_from_dict(doc):
    p = load_or_reject("params_from_dict", ParameterError, _quiet, params_from_dict, doc)
    if p is not None:
        assert isinstance(p, SystemParams)


@given(
    edits=st.lists(
        st.tuples(
            st.sampled_from(["value", "delete", "dup", "swap", "text", "bytes"]),
            st.integers(0, 200),
            _VALUES.map(repr) | st.text(max_size=20),
            st.binary(max_size=8),
        ),
        min_size=1,
        max_size=4,
    ),
    which=st.sampled_from(["toml", "toml_sym"]),
)
def test_fuzz_load_params_toml(edits, which):
    """Line edits of a saved parameter file: values replaced by junk, lines lost or repeated."""
    lines = _SEEDS[which].splitlines()
    raw = b""
    for op, i, text, junk in edits:
        i %= len(lines)
        if op == "value" and "=" in lines[i]:
            lines[i] = lines[i].split("=", 1)[0] + "= " + text
        elif op == "delete":
            del lines[i]
        elif op == "dup":
            lines.insert(i, lines[i])
        elif op == "swap":
            k = (i + 1) % len(lines)
            lines[i], lines[k] = lines[k], lines[i]
        elif op == "text":
            lines.insert(i, text)
        else:
            raw = junk
        if not lines:
            lines = [""]
    path = _SEEDS["dir"] / "p.toml"
    path.write_bytes("\n".join(lines).encode("utf-8", "surrogatepass") + raw)
    p = load_or_reject("load_params (mutated TOML)", ParameterError, _quiet, load_params, path)
    if p is not None:
        assert isinstance(p, SystemParams)


@given(text=st.text(max_size=300) | st.binary(max_size=300))
def test_fuzz_load_params_random(text):
    path = _SEEDS["dir"] / "r.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass"))
    load_or_reject("load_params (random)", ParameterError, _quiet, load_params, path)


# ----------------------------------------------------------------------- signals
_KINDS = ["constant", "step", "ramp", "sine", "chirp", "Sine", " sine ", "sampled", "", "x"]
_KEYS = [
    "value",
    "time",
    "before",
    "after",
    "t0",
    "t1",
    "v0",
    "v1",
    "amplitude",
    "frequency",
    "offset",
    "phase",
    "start",
    "f0",
    "f1",
    "duration",
    "bogus",
    "",
    "_kind",
]
_SIG_VALUES = st.one_of(
    _VALUES.map(str),
    st.sampled_from(
        ["0.4", "1", "95 bar", "40 %", "2 Hz", "0.1 s", "90 deg", "-1", "0", "1e308", "-1e308"]
    ),
)


@st.composite
def _spec(draw):
    kind = draw(st.sampled_from(_KINDS))
    items = draw(
        st.lists(
            st.tuples(st.sampled_from(_KEYS), _SIG_VALUES, st.sampled_from(["=", "", "==", ":"])),
            max_size=5,
        )
    )
    body = ",".join(f"{k}{sep}{v}" if sep else v for k, v, sep in items)
    return f"{kind}:{body}" if draw(st.booleans()) else (body or kind)


@given(
    spec=_spec() | st.text(max_size=60), unit=st.sampled_from(["", "Pa", "N", "m", "bogus", "1/0"])
)
def test_fuzz_parse_signal(spec, unit):
    sig = load_or_reject("parse_signal", SignalError, parse_signal, spec, unit=unit, name="--input")
    if sig is not None:
        assert isinstance(sig, Signal)
        # a parsed signal must be usable: evaluation and peak give finite numbers or inf/nan
        # from the user's own huge values, never an exception
        sig(0.25)
        sig.peak(0.5)


# ----------------------------------------------------------------------- PWA JSON
_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=12,
)


def _paths(doc, prefix=()):
    """Every (path) into a nested JSON document."""
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc[:6]):
            out += _paths(v, prefix + (i,))
    return out


@st.composite
def _mutated_pwa(draw):
    doc = json.loads(_SEEDS[draw(st.sampled_from(["pwa_json", "pwa_export"]))])
    paths = [p for p in _paths(doc) if p]
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(paths))
        node = doc
        try:
            for k in path[:-1]:
                node = node[k]
            if draw(st.booleans()) and isinstance(node, dict):
                node.pop(path[-1], None)
            else:
                node[path[-1]] = draw(
                    _JSON
                    | st.floats(allow_nan=True, allow_infinity=True)
                    | st.sampled_from([[], [0.0], [1e308, -1e308], "nan", -1.0, 0.0])
                )
        except (KeyError, IndexError, TypeError):
            pass
    return json.dumps(doc)


def _from_json(text):
    from hydropwa.linearization import PwaModel

    return PwaModel.from_json(text)


@given(text=_mutated_pwa())
def test_fuzz_pwa_json_values(text):
    m = load_or_reject("PwaModel.from_json (mutated values)", PwaError, _quiet, _from_json, text)
    if m is not None:
        from hydropwa.linearization import PwaModel

        assert isinstance(m, PwaModel)


@given(
    edits=st.lists(
        st.tuples(
            st.floats(0, 1), st.sampled_from(["delete", "insert", "truncate"]), st.text(max_size=4)
        ),
        min_size=1,
        max_size=3,
    )
)
def test_fuzz_pwa_json_text(edits):
    text = _SEEDS["pwa_json"]
    for where, op, ins in edits:
        i = int(where * len(text))
        text = text[:i] + ins + text[i + 1 :] if op != "truncate" else text[:i]
    load_or_reject("PwaModel.from_json (mutated text)", PwaError, _quiet, _from_json, text)


@given(doc=_JSON | st.text(max_size=100))
def test_fuzz_load_pwa_random(doc):
    from hydropwa.linearization import load_pwa

    path = _SEEDS["dir"] / "r.json"
    path.write_text(
        doc if isinstance(doc, str) else json.dumps(doc), encoding="utf-8", errors="surrogatepass"
    )
    load_or_reject("load_pwa (random)", PwaError, _quiet, load_pwa, path)


def test_seeds_load():
    params_from_dict(_SEEDS["dict"])
    path = _SEEDS["dir"] / "ok.toml"
    path.write_text(_SEEDS["toml"])
    assert load_params(path) == get_preset("paper")
    assert _from_json(_SEEDS["pwa_json"]).params == get_preset("paper")
    assert _from_json(_SEEDS["pwa_export"]).params == get_preset("paper")
    assert parse_signal("sine:amplitude=0.4,frequency=1").amplitude == 0.4
