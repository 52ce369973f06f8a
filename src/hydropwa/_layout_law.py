"""The compiled control law's packed vectors, declared once: controller, memory, log, references.

The discrete control law (:mod:`hydropwa.simulation._controller`) reads one float vector
``ctl`` (the controller packed by :meth:`~hydropwa.control.PIController.pack`), keeps its
memory in ``cst``, writes one column of ``log`` per sample and reads the reference channels
``rch`` (one column per sample). Every slot of them is declared here once, as the kernel's
parameter, signal and statistics vectors are in :mod:`hydropwa._layout`: a block is a table
of ``(name, width, unit, what)`` rows, and the indices the compiled law and the exported C
use (``C_TS``, ``X_DZQ``, ``S_INT``, ``RC_DR``, …) are generated from the rows by
:func:`offsets`. Adding a law element is its rows here plus its stage in the law.

``ctl`` holds the header (:data:`CTL_HEADER`), then ``ctl[C_NROWS]`` gain rows of
:data:`CTL_ROW`; schema 2 adds the extension header (:data:`CTL_EXT`, from
e0 = C_ROWS + ROW·n), one :data:`CTL_XROW` row per gain row, and with the per-cell Kalman
filter one :data:`CTL_EROW` row per gain row (and with it measuring the spool NZ values per
row, the spool column of its gain).

This module is a leaf: it imports nothing from the package.
"""

from __future__ import annotations

#: a block of a packed vector: (name, width, SI unit, what it is)
Block = tuple[tuple[str, int, str, str], ...]

#: states of the per-cell Kalman filter [P_L, v, x, ν, ν̇, d_a, d_p]
NZ = 7

#: the controller header, ctl[0 : C_ROWS]
CTL_HEADER: Block = (
    ("ts", 1, "s", "sample time T_s"),
    ("delay", 1, "1", "one-sample computation delay (1) or none (0)"),
    ("umin", 1, "1", "lower valve command limit"),
    ("umax", 1, "1", "upper valve command limit"),
    ("aw", 1, "1", "anti-windup: 0 none, 1 clamping, 2 back-calculation"),
    ("kt", 1, "1/s", "back-calculation tracking gain"),
    ("dzinv", 1, "1", "dead-zone inverse on (1) / off (0)"),
    ("dzoff", 1, "1", "dead-zone inverse's outer offset"),
    ("dzw", 1, "1", "dead-zone inverse's blend width z_w"),
    ("filt", 1, "1", "pressure-rate filter coefficient exp(-T_s/T_f) (0: none)"),
    ("nrows", 1, "1", "number of gain rows"),
    ("wash", 1, "1", "pressure washout coefficient exp(-T_s/T_w) (0: none)"),
    ("plmean", 1, "1", "load pressure form: 0 asymmetric, 1 mean-area"),
    ("scale", 4, "Pa, m/s, m, 1", "scales of the box distance over [P_L, v, x, c_prev]"),
)
#: one gain row (ROW values), from C_ROWS on
CTL_ROW: Block = (
    ("lo", 4, "Pa, m/s, m, 1", "box lower bounds over [P_L, v, x, c_prev]"),
    ("hi", 4, "Pa, m/s, m, 1", "box upper bounds"),
    ("kp", 1, "1/m", "position gain k_p"),
    ("ki", 1, "1/(m s)", "integral gain k_i"),
    ("kff", 1, "s/m", "velocity feed-forward gain k_ff"),
    ("kv", 1, "s/m", "velocity feedback gain k_v"),
    ("kpl", 1, "1/Pa", "load-pressure feedback gain k_pl"),
    ("kdpl", 1, "s/Pa", "load-pressure rate gain k_dpl"),
    ("uff", 1, "1", "constant command u_ff"),
)
#: the schema-2 extension header (N_EXT values from e0)
CTL_EXT: Block = (
    ("ff", 1, "1", "flow feed-forward on (1) / off (0)"),
    ("k", 1, "m^3/(s Pa^0.5)", "valve flow coefficient K per metering edge"),
    ("ptr", 1, "Pa", "transition pressure of the regularised root"),
    ("aa", 1, "m^2", "piston area A_A"),
    ("alpha", 1, "1", "area ratio A_B/A_A"),
    ("ps", 1, "Pa", "supply pressure of the design"),
    ("pt", 1, "Pa", "tank pressure"),
    ("dpmin", 1, "Pa", "smallest drop of the flow inversion"),
    ("refst", 1, "1", "reference state in the k_v, k_pl feedback (1)"),
    ("mass", 1, "kg", "moving mass m of P_ref"),
    ("bv", 1, "N s/m", "viscous slope b of P_ref"),
    ("lead", 1, "s", "look-ahead of the feed-forward rate (read by the sampler)"),
    ("vest", 1, "1", "velocity filter exp(-T_s/T_v) (0: the measured velocity)"),
    ("spool", 1, "1", "spool feedback: 0 off, 1 measured, 2 estimated"),
    ("phi", 4, "1, s, 1/s, 1", "valve model's transition matrix (row-major)"),
    ("gam", 2, "1, 1/s", "valve model's input vector"),
    ("kf", 1, "1", "position observer on (1)"),
    ("kf_x", 1, "1", "observer gain L_x"),
    ("kf_v", 1, "1/s", "observer gain L_v"),
    ("dz_hyst", 1, "1", "dead-zone hysteresis h (0: none)"),
    ("est", 1, "1", "per-cell Kalman filter on (1)"),
    ("dz_quiet", 1, "1", "quiet band q (0: none)"),
    ("int_leak", 1, "1", "integral leak exp(-T_s/T_l) (0: none)"),
    ("int_band", 1, "m", "integral band e_I (0: none)"),
    ("dz_quiet_rest", 1, "1", "quiet band only at rest (1)"),
    ("dz_pre_open", 1, "s", "pre-opening look-ahead (read by the sampler; 0: none)"),
    ("spool_l_nu", 1, "1", "spool filter gain L_nu"),
    ("spool_l_dnu", 1, "1/s", "spool filter gain L_dnu"),
    ("est_spool", 1, "1", "the per-cell Kalman filter measures the spool (1)"),
    ("dz_vent", 1, "1", "pressure vent exp(-T_s/T_p) (0: none)"),
    ("dz_quiet_open", 1, "1", "quiet band's opening delay n in samples (0: none)"),
    ("output", 1, "1", "controlled output: 0 position x, 1 cylinder force, 2 load pressure P_L"),
    ("ff_compliance", 1, "m/(output unit)", "feed-forward velocity per unit of output rate"),
    ("transfer", 1, "1", "start from a transfer (1): the next three slots set the memory at k = 0"),
    ("int0", 1, "(output unit) s", "integral at the first sample (the command continuous)"),
    ("u0", 1, "1", "command pending at the first sample (the other law's last)"),
    ("c0", 1, "1", "opening pending at the first sample (the other law's last)"),
)
#: per gain row after the extension header (XROW values each)
CTL_XROW: Block = (
    ("k_nu", 1, "1", "spool gain k_nu"),
    ("k_dnu", 1, "s", "spool rate gain k_dnu"),
    ("k_up", 1, "1", "pending-command gain k_up"),
)
#: per gain row of the per-cell Kalman filter (EROW values each)
CTL_EROW: Block = (
    ("phi", NZ * NZ, "SI", "transition matrix (row-major)"),
    ("gam", NZ, "SI", "input vector of the opening command"),
    ("aff", NZ, "SI", "affine term"),
    ("l", 2 * NZ, "SI", "gain over [P_L, x] (row-major NZ x 2)"),
    ("init", 4, "SI", "initial values' coefficients (a_vp, a_pp, f_a, f_p)"),
)
#: the law's memory cst (N_CST values)
MEMORY: Block = (
    ("int", 1, "m s", "integral of r - x"),
    ("pl", 1, "Pa", "P_L of the last sample"),
    ("dpl", 1, "Pa/s", "filtered rate of P_L"),
    ("pend", 1, "1", "command pending for the next sample (delay)"),
    ("cprev", 1, "1", "last saturated opening command c"),
    ("row", 1, "1", "gain row of the last sample"),
    ("plbar", 1, "Pa", "low-pass of P_L (washout)"),
    ("xprev", 1, "m", "position of the last sample (velocity filter)"),
    ("vhat", 1, "m/s", "velocity from the position samples"),
    ("prbar", 1, "Pa", "low-pass of P_ref (washout)"),
    ("nu", 1, "1", "spool estimate"),
    ("dnu", 1, "1/s", "its rate"),
    ("cpend", 1, "1", "opening command pending for the next sample (delay)"),
    ("xkf", 1, "m", "position observer's position"),
    ("vkf", 1, "m/s", "position observer's velocity"),
    ("dzs", 1, "1", "side of the dead-zone inverse with hysteresis"),
    ("z", NZ, "SI", "per-cell Kalman filter's state"),
    ("capp", 1, "1", "opening command the valve held over the last sample"),
    ("zp", NZ, "SI", "per-cell Kalman filter's prediction (scratch)"),
    ("pdev", 1, "Pa", "pressure vent's low-pass of the load-pressure deviation"),
    ("dzqn", 1, "1", "quiet band's run of samples beyond q"),
    ("ddr", 1, "m/s^2", "reference acceleration of the last sample (the observer's input)"),
)
#: the per-sample log (one column per sample, N_LOG rows)
LOG: Block = (
    ("t", 1, "s", "sample time"),
    ("u", 1, "1", "command applied from t on"),
    ("r", 1, "m", "reference"),
    ("e", 1, "m", "error r - x"),
    ("c", 1, "1", "command before the dead-zone inverse and the limits"),
    ("row", 1, "1", "gain row"),
    ("int", 1, "m s", "integral before this sample's update"),
    ("unew", 1, "1", "saturated command computed at t"),
    ("uff", 1, "1", "schema-2 part of c"),
)
#: the reference channels (one row of rch each, N_RCH rows)
REFERENCE_CHANNELS: Block = (
    ("dr", 1, "m/s", "reference rate r'(t_k)"),
    ("drff", 1, "m/s", "look-ahead rate r'(t_k + lead)"),
    ("ddr", 1, "m/s^2", "reference acceleration r''(t_k)"),
    ("nx", 1, "m", "sensor noise on x"),
    ("npa", 1, "Pa", "sensor noise on P_A (P_L on the load-state models)"),
    ("npb", 1, "Pa", "sensor noise on P_B"),
    ("drpo", 1, "m/s", "pre-opening look-ahead rate r'(t_k + tau_o)"),
    ("nnu", 1, "1", "sensor noise on the measured spool"),
)


def offsets(block: Block) -> dict[str, int]:
    """Start index of each row of ``block`` (the rows one after the other)."""
    out: dict[str, int] = {}
    i = 0
    for name, width, _unit, _what in block:
        out[name] = i
        i += width
    return out


def width(block: Block) -> int:
    """Number of values of ``block``."""
    return sum(w for _n, w, _u, _d in block)


def flat_names(block: Block) -> tuple[str, ...]:
    """One name per value of ``block``: ``name`` for width 1, ``name[i]`` beyond."""
    return tuple(n if w == 1 else f"{n}[{i}]" for n, w, _u, _d in block for i in range(w))


#: the blocks, with the prefix of their generated index constants
BLOCKS: dict[str, tuple[str, Block]] = {
    "C_": ("controller header", CTL_HEADER),
    "R_": ("gain row", CTL_ROW),
    "X_": ("schema-2 extension header", CTL_EXT),
    "XR_": ("schema-2 per-row slots", CTL_XROW),
    "E_": ("per-cell Kalman filter row", CTL_EROW),
    "S_": ("memory", MEMORY),
    "L_": ("log", LOG),
    "RC_": ("reference channels", REFERENCE_CHANNELS),
}

C_ROWS = width(CTL_HEADER)
ROW = width(CTL_ROW)
N_EXT = width(CTL_EXT)
XROW = width(CTL_XROW)
EROW = width(CTL_EROW)
N_CST = width(MEMORY)
N_LOG = width(LOG)
N_RCH = width(REFERENCE_CHANNELS)
#: the sizes, by their constant names (the exported C's header generates its arrays from them)
SIZES: dict[str, int] = {
    "C_ROWS": C_ROWS,
    "ROW": ROW,
    "N_EXT": N_EXT,
    "XROW": XROW,
    "EROW": EROW,
    "NZ": NZ,
    "N_CST": N_CST,
    "N_LOG": N_LOG,
    "N_RCH": N_RCH,
}

CTL: dict[str, int] = offsets(CTL_HEADER)
ROW_SLOT: dict[str, int] = offsets(CTL_ROW)
EXT: dict[str, int] = offsets(CTL_EXT)
XROW_SLOT: dict[str, int] = offsets(CTL_XROW)
EROW_SLOT: dict[str, int] = offsets(CTL_EROW)
CST: dict[str, int] = offsets(MEMORY)
LOG_ROW: dict[str, int] = offsets(LOG)
RCH: dict[str, int] = offsets(REFERENCE_CHANNELS)
