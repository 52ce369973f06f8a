"""The compiled control law's packed vectors, declared once in ``_layout_law`` (issue 47, item 3).

Every index the law reads (controller header ``C_*``, gain row ``R_*``, extension ``X_*`` and
``XR_*``, Kalman-filter rows ``E_*``, memory ``S_*``, log ``L_*``, reference channels ``RC_*``)
is the offset the layout's table gives, and the controllers pack their settings at those slots.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from hydropwa import _layout_law as LL
from hydropwa.control import FlowFeedForward, PIController
from hydropwa.params import get_preset
from hydropwa.simulation import _controller as C


@pytest.mark.parametrize("prefix", sorted(LL.BLOCKS))
def test_each_block_is_contiguous_with_unique_names_units_and_descriptions(prefix):
    _what, block = LL.BLOCKS[prefix]
    names = [n for n, _w, _u, _d in block]
    assert len(set(names)) == len(names)
    start = 0
    for name, width, unit, what in block:
        assert width >= 1 and unit and what, name
        assert LL.offsets(block)[name] == start
        start += width
    assert LL.width(block) == start == len(LL.flat_names(block))


def test_the_law_reads_every_slot_at_the_layout_offset():
    """Each index constant of the compiled law is one declared slot's offset, and every declared
    slot of the blocks the law indexes has its constant (none hand-numbered)."""
    offsets = {p: LL.offsets(b) for p, (_w, b) in LL.BLOCKS.items()}
    consts = {n: v for n, v in vars(C).items() if re.fullmatch(r"(C|R|X|XR|E|S|L|RC)_[A-Z]+", n)}
    consts.pop("C_ROWS")  # the header's length, a size
    for name, value in consts.items():
        prefix = name.split("_")[0] + "_"
        assert value in offsets[prefix].values(), name
    for prefix, table in offsets.items():
        found = {v for n, v in consts.items() if n.startswith(prefix) and n.count("_") == 1}
        assert found == set(table.values()), prefix
    assert (C.C_ROWS, C.ROW, C.N_EXT, C.XROW, C.EROW, C.N_CST, C.N_LOG, C.N_RCH) == (
        17,
        15,
        41,  # issue 52: + the controlled output, its feed-forward compliance, the transfer
        3,
        C.NZ * C.NZ + 4 * C.NZ + 4,
        34,
        9,
        8,
    )


def test_controllers_pack_their_settings_at_the_declared_slots():
    """A PI controller's settings and a flow feed-forward's machine data land where the layout
    says, and the lengths are the blocks' widths (schema 1: header + one row; schema 2: + the
    extension header + one per-row block)."""
    pi = PIController(kp=150.0, ki=600.0, kv=0.05, kpl=2e-8, sample_time=5e-4, u_min=-0.8)
    ctl = np.asarray(pi.pack())
    assert ctl.size == LL.C_ROWS + LL.ROW
    assert ctl[LL.CTL["ts"]] == 5e-4 and ctl[LL.CTL["umin"]] == -0.8 and ctl[LL.CTL["nrows"]] == 1
    row = LL.C_ROWS
    for name, value in (("kp", 150.0), ("ki", 600.0), ("kv", 0.05), ("kpl", 2e-8)):
        assert ctl[row + LL.ROW_SLOT[name]] == value, name
    paper = get_preset("paper")
    ff = FlowFeedForward.from_params(paper, sample_time=5e-4, delay=False)
    ctl2 = np.asarray(PIController(kp=150.0, feedforward=ff, sample_time=5e-4).pack())
    e0 = LL.C_ROWS + LL.ROW
    assert ctl2.size == e0 + LL.N_EXT + LL.XROW
    assert ctl2[e0 + LL.EXT["ff"]] == 1.0
    assert ctl2[e0 + LL.EXT["aa"]] == paper.cylinder.area_a
    assert ctl2[e0 + LL.EXT["alpha"]] == pytest.approx(
        paper.cylinder.area_b / paper.cylinder.area_a
    )
    assert ctl2[e0 + LL.EXT["ps"]] == paper.supply.pressure
