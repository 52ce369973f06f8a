"""The packed contracts between Python and the compiled kernel, declared once in ``_layout``.

Every index the compiled code reads (parameter slots ``I_*``, states ``Y_*``/``L_*``, output
rows ``O_*``, input-signal slots ``S_*``, statistics ``ST_*``, PWA cell sections) must be the
one the layout table gives, and every compiled module must carry the package's cache stamp.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

import hydropwa
from hydropwa import _jitcache, _layout
from hydropwa.params import get_preset
from hydropwa.simulation import Constant, Sampled, Sine, _kcommon, pack_signals, simulate
from hydropwa.simulation import _kernel as K
from hydropwa.simulation._status import SolverStats

PKG = Path(hydropwa.__file__).parent

# state name -> kernel constant (the short names are the kernel's symbols)
_FULL_NAMES = {"spool": "NU", "spool_rate": "DNU", "p_a": "PA", "p_b": "PB", "x": "X", "v": "V"}
_FULL_NAMES |= {"p_s": "PS", "p_acc": "PACC"}
_LOAD_NAMES = {"p_l": "PL", "v": "V", "x": "X"}


def test_every_parameter_slot_has_its_kernel_index():
    for name, _src in _layout.BASE_SLOTS:
        assert getattr(_kcommon, f"I_{name.upper()}") == _layout.SLOT[name], name
    for name in _layout.PWA_SLOTS:
        assert getattr(_kcommon, f"I_{name.upper()}") == _layout.PWA_SLOT[name], name
    # and no I_ constant that the table does not declare
    declared = {f"I_{n.upper()}" for n, _s in _layout.BASE_SLOTS} | {
        f"I_{n.upper()}" for n in _layout.PWA_SLOTS
    }
    assert {n for n in vars(_kcommon) if re.fullmatch(r"I_[A-Z0-9_]+", n)} == declared


def test_state_and_output_indices_follow_the_tables():
    assert set(_FULL_NAMES) == set(_layout.Y_FULL)
    for name, short in _FULL_NAMES.items():
        assert getattr(_kcommon, f"Y_{short}") == _layout.Y_FULL[name]
    for name, short in _LOAD_NAMES.items():
        assert getattr(_kcommon, f"L_{short}") == _layout.Y_LOAD[name]
    for name, _unit in _layout.OUTPUT_CHANNELS:
        assert getattr(_kcommon, f"O_{name.upper()}") == _layout.OUT[name]
    assert _kcommon.N_OUT_PWA == len(_layout.OUTPUT_CHANNELS + _layout.PWA_OUTPUT_CHANNELS)
    assert K.N_STATES == tuple(len(row.states) for row in _layout.MODEL_KINDS.values())


def test_signal_slots_are_where_pack_signals_writes():
    ts = np.linspace(0.0, 1.0, 5)
    sg = pack_signals([Constant(0.25), Sampled(ts, ts**2), Sine(2.0, 1.0)])
    assert (_kcommon.S_KIND_U, _kcommon.S_KIND_PS, _kcommon.S_KIND_FL) == (0, 1, 2)
    assert sg[_kcommon.S_KIND_U] == 0.0 and sg[_kcommon.S_U] == 0.25
    assert sg[_kcommon.S_KIND_PS] != 0.0 and sg[_kcommon.S_KIND_FL] != 0.0
    first = int(sg[_layout.SG["first"] + 1])
    count = int(sg[_layout.SG["count"] + 1])
    assert first == _layout.SG_DATA and count == ts.size
    np.testing.assert_array_equal(sg[first : first + count], ts)
    np.testing.assert_array_equal(sg[first + count : first + 2 * count], ts**2)
    # the compiled input evaluation reads those slots: u constant, P_S interpolated, F_L a sine
    u, ps, fl = K._inputs(0.5, sg)
    assert u == 0.25 and ps == pytest.approx(0.25) and fl == pytest.approx(0.0, abs=1e-12)


def test_solver_stats_order_is_the_layouts():
    names = {f.name for f in dataclasses.fields(SolverStats)}
    assert set(_layout.SOLVER_STATS) <= names
    assert (K.ST_STEPS, K.ST_REJECTED, K.ST_RHS, K.ST_JAC) == tuple(
        _layout.STAT[n] for n in ("steps", "rejected", "rhs_evaluations", "jacobians")
    )
    res = simulate(
        "reduced", "step:time=0.01", duration=0.05, fs=1000.0, params=get_preset("paper")
    )
    s = res.stats
    # every accepted or rejected ROS34PW2 step costs at least 3 rhs calls, and the counts land
    # in their own fields (a swapped index would break one of these)
    assert (
        s["steps"] > 0 and s["rejected"] >= 0 and 1 <= s["jacobians"] <= s["steps"] + s["rejected"]
    )
    assert s["rhs_evaluations"] >= 3 * (s["steps"] + s["rejected"])


def test_pwa_cell_sections_match_the_compiled_layouts():
    from hydropwa.linearization import linearize

    params = get_preset("paper")
    pwa = linearize(params)
    p = pwa.pack()
    counts = tuple(int(p[_layout.PWA_SLOT[k]]) for k in ("ng", "no", "nn", "nw"))
    starts = _layout.cell_sections(counts)
    assert starts[-1] == p.size
    no, nn, nw, s_o, s_n, s_w = K._pwa_layout(p)
    assert (no, nn, nw) == counts[1:] and [s_o, s_n, s_w] == starts[1:4]
    chamber = linearize(params, form="chamber")
    pc = chamber.pack()
    counts = tuple(int(pc[_layout.PWA_SLOT[k]]) for k in ("ng", "no", "nn", "nw"))
    starts = _layout.cell_sections(counts)
    assert starts[-1] == pc.size
    assert tuple(K._chamber_layout(pc)) == (*counts, *starts[:4])


def test_every_compiled_module_carries_the_package_stamp():
    """A module whose numba code compiles into the kernels is in the stamp; one with njit is cached."""
    uses = re.compile(r"^from numba(?:\.extending)? import .*\b(njit|overload)\b", re.M)
    compiled, stamped = set(), set()
    for f in PKG.rglob("*.py"):
        m = uses.findall(f.read_text(encoding="utf-8"))
        if m:
            stamped.add(str(f.relative_to(PKG)))
            if "njit" in m:
                compiled.add(str(f.relative_to(PKG)))
    assert compiled == set(_jitcache.COMPILED_MODULES)
    # plus the layout tables whose slot indices the kernels compile in as constants
    assert stamped | {"_layout.py", "_layout_law.py"} == set(_jitcache.STAMPED_MODULES)


def test_entry_points_are_generated_for_every_model_and_method():
    kinds = {row.kernel for row in _layout.MODEL_KINDS.values()}
    assert set(K.ENTRIES) == set(K.SOLVERS.values())
    tables = [t for pair in K.ENTRIES.values() for t in pair]
    for table in tables:
        assert set(table) == kinds
    names = {d.__name__ for t in tables for d in t.values()}
    assert len(names) == 2 * len(K.SOLVERS) * len(kinds)  # one cache file each
    assert K._ENTRY[K.FULL] is K._integrate_full and K._CLOSED_ROS23[K.PWA] is K._closed_pwa_ros23
    assert K.ENTRIES[K.ROS4LS][0][K.FULL] is K._integrate_full_ros4ls
