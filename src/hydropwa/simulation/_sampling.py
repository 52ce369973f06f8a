"""Controller sampling in the step loop, resolved while typing (no-ops in open loop)."""

from __future__ import annotations

from numba import types
from numba.extending import overload

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ._controller import controller_sample
from ._kcommon import (
    I_AA,
    I_AB,
)


# Closed-loop hooks of the step loop, resolved while typing: in open loop (``ctl`` None) they
# compile to constants and no-ops, so an open-loop kernel holds none of the controller's code.
def _closed(ctl):
    """True in closed loop (compiled code only)."""


def _n_samples(log):
    """Number of controller samples of the run (compiled code only)."""


def _sample_time(ctl):
    """Controller sample time [s] (compiled code only)."""


def _sample(kind, k, t, y, p, ctl, cst, ref, dref, sg, log):
    """Controller sample k at time t (compiled code only)."""


@overload(_closed)
def _ol_closed(ctl):
    if isinstance(ctl, types.NoneType):
        return lambda ctl: False
    return lambda ctl: ctl.shape[0] > 0


@overload(_n_samples)
def _ol_n_samples(log):
    if isinstance(log, types.NoneType):
        return lambda log: 0
    return lambda log: log.shape[1]


@overload(_sample_time)
def _ol_sample_time(ctl):
    if isinstance(ctl, types.NoneType):
        return lambda ctl: 1.0
    return lambda ctl: ctl[0]


@overload(_sample)
def _ol_sample(kind, k, t, y, p, ctl, cst, ref, dref, sg, log):
    if isinstance(ctl, types.NoneType):
        return lambda kind, k, t, y, p, ctl, cst, ref, dref, sg, log: None

    def sample(kind, k, t, y, p, ctl, cst, ref, dref, sg, log):
        controller_sample(kind, k, t, y, p[I_AA], p[I_AB], ctl, cst, ref, dref, sg, log)

    return sample
