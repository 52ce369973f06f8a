"""A load that pushes back: the specimen spring–damper in the physics, every model and its Jacobian.

Closed forms: the static deflection of a specimen the rod presses with the full supply
pressure (A_A P_S = F_0 + k (x − x_c) once the metering flow has stopped), and the natural
frequency of the rod locked between its two trapped oil columns and an attached spring,
√((k + k_h)/m) with the hydraulic stiffness k_h = E (A_A²/V_A + A_B²/V_B). Exact Jacobians
against central differences with the rod in contact.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hydropwa import ParameterError
from hydropwa.components import specimen_force, specimen_force_slope
from hydropwa.linearization import linearize
from hydropwa.models import as_model
from hydropwa.params import Friction, Load, get_preset
from hydropwa.simulation import _kernel as K
from hydropwa.simulation import simulate

K_SPEC, C_SPEC, X_C = 1e7, 2e3, 0.15


def _with_specimen(k=K_SPEC, c=C_SPEC, x_c=X_C, f_0=0.0, friction=True):
    prm = get_preset("paper")
    load = dataclasses.replace(
        prm.load, specimen_stiffness=k, specimen_damping=c, contact_position=x_c, preload=f_0
    )
    prm = dataclasses.replace(prm, load=load)
    if not friction:
        prm = dataclasses.replace(prm, friction=Friction(coulomb=0.0, static=0.0, viscous=0.0))
    return prm


def test_specimen_force_contact_is_one_sided_and_attached_spring_pulls():
    k, c, x_c, f_0 = 2e6, 500.0, 0.1, 300.0
    assert specimen_force(0.0999, 0.5, k, c, x_c, f_0) == 0.0  # before contact
    assert specimen_force(0.101, 0.2, k, c, x_c, f_0) == pytest.approx(f_0 + 2e3 + 100.0)
    # leaving fast: the damper would pull, the contact does not
    assert specimen_force(0.1001, -5.0, k, c, x_c, f_0) == 0.0
    assert specimen_force_slope(0.1001, -5.0, k, c, x_c, f_0) == (0.0, 0.0)
    # attached (x_c <= 0): a spring return with its rest at x_c - F_0/k = 0.05 m pulls and pushes
    assert specimen_force(0.04, 0.0, k, c, 0.0, -1e5) == pytest.approx(-2e4)
    assert specimen_force(0.06, -0.1, k, c, 0.0, -1e5) == pytest.approx(2e4 - 50.0)
    assert specimen_force_slope(0.04, 0.0, k, c, 0.0, -1e5) == (k, c)


@pytest.mark.parametrize(("x", "v"), [(0.1005, 0.01), (0.13, -0.02), (0.02, 0.3), (0.09, -0.1)])
def test_specimen_force_slope_matches_differences(x, v):
    args = (2e6, 500.0, 0.1, 300.0)
    hx, hv = 1e-7, 1e-6
    dx = (specimen_force(x + hx, v, *args) - specimen_force(x - hx, v, *args)) / (2 * hx)
    dv = (specimen_force(x, v + hv, *args) - specimen_force(x, v - hv, *args)) / (2 * hv)
    sx, sv = specimen_force_slope(x, v, *args)
    assert sx == pytest.approx(dx, rel=1e-6, abs=1e-6)
    assert sv == pytest.approx(dv, rel=1e-6, abs=1e-6)


def test_a_pulling_contact_is_refused_in_one_line():
    with pytest.raises(ParameterError, match="preload .* negative .* contact only pushes"):
        Load(specimen_stiffness=1e6, contact_position=0.1, preload=-10.0)
    with pytest.raises(ParameterError, match="specimen_stiffness"):
        Load(specimen_stiffness=-1.0)


def test_no_specimen_packs_zeros_and_reads_zero_force():
    prm = get_preset("paper")
    p = as_model("full", prm).pack()
    assert (p[K.I_KSPEC], p[K.I_CSPEC], p[K.I_XSPEC], p[K.I_FSPEC]) == (0.0, 0.0, 0.0, 0.0)
    res = simulate(as_model("reduced", prm), 0.2, duration=0.05, fs=2000.0)
    assert np.all(res["f_spec"] == 0.0)


@pytest.mark.parametrize("name", ["full", "reduced"])
def test_static_deflection_pressing_with_the_supply_pressure(name):
    """Valve open: the rod stops where A_A P_S (P_A = P_S, P_B = P_T = 0) balances the specimen.

    Closed form x = x_c + (A_A P_S − F_0)/k; friction vanishes at rest (tanh law) and there
    is no leakage, so the equilibrium is exact. The rod meets the specimen after about 0.3 s;
    the rest is approached exponentially through the metering edges' laminar band, to 1e-15 m
    by 1 s (measured), so 1e-4 of the deflection is a margin of ten orders.
    """
    f_0 = 2e3
    prm = _with_specimen(f_0=f_0)
    model = as_model(name, prm)
    res = simulate(model, 0.3, duration=1.0, fs=1000.0, initial_position=0.12, rtol=1e-6)
    assert res.success
    c = prm.cylinder
    deflection = (c.area_a * prm.supply.pressure - f_0) / K_SPEC
    assert res["x"][-1] == pytest.approx(X_C + deflection, abs=1e-4 * deflection)
    f_expected = f_0 + K_SPEC * deflection  # the damper is at rest
    assert res["f_spec"][-1] == pytest.approx(f_expected, rel=1e-4)


def test_natural_frequency_of_the_locked_rod_against_an_attached_spring():
    """u = 0 inside the dead band (z = 0): sealed chambers plus the spring, ω = √((k + k_h)/m)."""
    x0, k = 0.1, 5e6
    prm = _with_specimen(k=k, c=0.0, x_c=0.0, f_0=-k * x0, friction=False)  # rest at x0
    prm = dataclasses.replace(prm, load=dataclasses.replace(prm.load, mass=5.0))
    model = as_model("full", prm)
    y0 = model.initial_state(x0)
    y0[K.Y_X] += 1e-6  # 1 µm off the rest: the trapped oil stays linear
    c = prm.cylinder
    e = prm.oil.bulk_modulus
    va, vb = c.dead_volume_a + c.area_a * x0, c.dead_volume_b + c.area_b * (c.stroke - x0)
    k_h = e * (c.area_a**2 / va + c.area_b**2 / vb)
    omega = np.sqrt((k + k_h) / prm.load.mass)
    periods = 20
    duration = periods * 2 * np.pi / omega
    res = simulate(model, 0.0, duration=duration, fs=200 * omega, initial_state=y0, rtol=1e-9)
    assert res.success
    d = res["x"] - x0
    up = np.flatnonzero((d[:-1] < 0) & (d[1:] >= 0))
    tc = res.t[up] - d[up] * (res.t[up + 1] - res.t[up]) / (d[up + 1] - d[up])
    measured = 2 * np.pi / np.mean(np.diff(tc))
    # the zero crossings from linear interpolation on 1/(200 ω) samples: far below 1e-3
    assert measured == pytest.approx(omega, rel=1e-3)


def _fd(rhs, y, u, ps, fl, p, h):
    n = y.size
    num, fp, fm = np.empty((n, n)), np.empty(n), np.empty(n)
    for j in range(n):
        yp, ym = y.copy(), y.copy()
        yp[j] += h[j]
        ym[j] -= h[j]
        rhs(yp, u, ps, fl, p, fp)
        rhs(ym, u, ps, fl, p, fm)
        num[:, j] = (fp - fm) / (2 * h[j])
    return num


def _check(J, num):
    row = np.abs(J).max(axis=1, keepdims=True) + 1e-300
    assert np.all(np.abs(J - num) <= 1e-5 * row + 1e-9), (J - num) / row


@pytest.mark.parametrize(("x", "v"), [(0.1502, 0.01), (0.16, -0.002), (0.107, 0.05)])
def test_full_and_chamber_jacobians_in_contact_match_differences(x, v):
    """Rows ẍ carry −k/m and −c/m in contact (and nothing out of it), as differences say."""
    prm = _with_specimen(f_0=500.0)
    full = as_model("full", prm)
    scale = full.state_scale()
    for model, rhs, jac in (
        (full, K.rhs_full, K.jac_full),
        (linearize(prm, form="chamber"), K.rhs_chamber, K.jac_chamber),
    ):
        p = model.pack(command_amplitude=0.3)
        y = full.initial_state(0.1)
        y[[K.Y_NU, K.Y_PA, K.Y_PB, K.Y_X, K.Y_V]] = 0.2, 6e6, 3e6, x, v
        h = 1e-7 * np.maximum(np.abs(y), scale)
        J = np.empty((y.size, y.size))
        assert jac(y, 0.3, 1e7, 100.0, p, J)
        _check(J, _fd(rhs, y, 0.3, 1e7, 100.0, p, h))
        in_contact = x > X_C
        assert J[K.Y_V, K.Y_X] == pytest.approx(-K_SPEC / prm.load.mass if in_contact else 0.0)


@pytest.mark.parametrize(("x", "v"), [(0.1502, 0.01), (0.17, -0.003)])
def test_reduced_and_pwa_jacobians_in_contact_match_differences(x, v):
    prm = _with_specimen(f_0=500.0)
    for model, rhs, jac in (
        (as_model("reduced", prm), K.rhs_reduced, K.jac_reduced),
        (linearize(prm), K.rhs_pwa, K.jac_pwa),
    ):
        p = model.pack(command_amplitude=0.3)
        y = np.array([2e6, v, x])
        h = 1e-7 * np.maximum(np.abs(y), (1e5, 1e-3, 1e-3))
        J = np.empty((3, 3))
        jac(y, 0.3, 1e7, 0.0, p, J)
        _check(J, _fd(rhs, y, 0.3, 1e7, 0.0, p, h))
        assert J[K.L_V, K.L_X] == pytest.approx(-K_SPEC / prm.load.mass)
