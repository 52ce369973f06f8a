"""Gas accumulator on port A: a component with a state of its own, in the full-order model.

Physics checked against closed forms:

* the hydraulic natural frequency of the rod, with the accumulator's gas compliance added to
  chamber A (the mode of the linearised full model against √(k/m));
* the equalisation of chamber A and the accumulator through the hose: the final pressure
  from conservation of oil volume, and the time constant R·C of the two capacitances in
  series;
* an accumulator of zero size leaves every trajectory of the full model unchanged.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import hydropwa as hp
from hydropwa._layout import FULL_STATES, Y_FULL
from hydropwa.components import accumulator_pressure_rate, hose_flow
from hydropwa.params import Accumulator
from hydropwa.simulation import _kernel as K

P_ATM = 1e5  # the gas law works on absolute pressure; the package's pressures are gauge


def _axis(**acc) -> hp.SystemParams:
    """Paper geometry, no friction, no leakage, closed-centre valve (no creep), 50 kg."""
    p = hp.get_preset("paper").replace(
        **{
            "friction.coulomb": 0.0,
            "friction.static": 0.0,
            "friction.viscous": 0.0,
            "dead_zone.creep_slope": 0.0,
            "cylinder.leakage": 0.0,
            "load.mass": 50.0,
        }
    )
    return p.replace(accumulator=Accumulator(**acc)) if acc else p


def _gas_capacitance(acc: Accumulator, p: float) -> float:
    """dV_oil/dP of the gas [m³/Pa] above the precharge (polytropic, absolute pressures)."""
    pabs = p + P_ATM
    v_gas = acc.gas_volume * ((acc.precharge_pressure + P_ATM) / pabs) ** (
        1.0 / acc.polytropic_index
    )
    return v_gas / (acc.polytropic_index * pabs)


def _oil_in_gas_part(acc: Accumulator, p: float) -> float:
    """Oil volume [m³] the gas has let in at pressure p (0 below the precharge)."""
    if p <= acc.precharge_pressure:
        return 0.0
    ratio = (acc.precharge_pressure + P_ATM) / (p + P_ATM)
    return acc.gas_volume * (1.0 - ratio ** (1.0 / acc.polytropic_index))


def _jacobian(params: hp.SystemParams, y: np.ndarray) -> np.ndarray:
    """∂f/∂y of the compiled full-model right-hand side, central differences."""
    pk = hp.FullOrderModel(params).pack()
    ps, n = params.supply.pressure, len(y)
    scale = np.array([s for _n, _u, s in FULL_STATES])
    J = np.zeros((n, n))
    fp, fm = np.zeros(n), np.zeros(n)
    for j in range(n):
        h = 1e-6 * scale[j]
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        K.rhs_full(yp, 0.0, ps, 0.0, pk, fp)
        K.rhs_full(ym, 0.0, ps, 0.0, pk, fm)
        J[:, j] = (fp - fm) / (2 * h)
    return J


def _rod_mode(params: hp.SystemParams) -> float:
    """|λ| [rad/s] of the complex pair of the hydraulic-mechanical block at rest."""
    y = hp.FullOrderModel(params).initial_state()
    J = _jacobian(params, y)
    # the valve's spool states drive the rest but nothing drives them (block triangular):
    # the rod's mode is an eigenvalue of the block without them and without P_S (an input)
    keep = [Y_FULL[k] for k in ("p_a", "p_b", "x", "v", "p_acc")]
    lam = np.linalg.eigvals(J[np.ix_(keep, keep)])
    pair = lam[np.abs(lam.imag) > 1e-6 * np.abs(lam)]
    assert pair.size == 2, lam
    return float(np.abs(pair[0]))


@pytest.mark.parametrize("gas_volume", [0.0, 0.1e-3, 0.5e-3, 2e-3])
def test_natural_frequency_with_accumulator_gas_compliance(gas_volume):
    """ω = √(k/m), k = A_A²/(C_A + C_acc) + A_B²/C_B, C = V/E of each chamber (Eq. (9)).

    A wide, short hose couples the accumulator quasi-statically (its own pole is far above
    the rod's), so its capacitance adds to chamber A's. Tolerance 1 %: the coupling through
    the hose shifts the pair by (ω·R·C)² ≈ 1e-6, the central differences by less than 1e-6.
    """
    acc = {"hose_length": 0.3, "hose_diameter": 0.025, "precharge_pressure": 20e5}
    params = _axis(gas_volume=gas_volume, **acc) if gas_volume else _axis()
    c, e = params.cylinder, params.oil.bulk_modulus
    y = hp.FullOrderModel(params).initial_state()
    x, pa = y[Y_FULL["x"]], y[Y_FULL["p_a"]]
    c_a = (c.dead_volume_a + c.area_a * x) / e
    c_b = (c.dead_volume_b + c.area_b * (c.stroke - x)) / e
    if gas_volume:
        a = params.accumulator
        c_a += a.hose_volume / e + _gas_capacitance(a, pa)
    k = c.area_a**2 / c_a + c.area_b**2 / c_b
    omega = math.sqrt(k / params.load.mass)
    assert _rod_mode(params) == pytest.approx(omega, rel=1e-2)
    if gas_volume >= 0.5e-3:  # the accumulator makes the axis markedly softer
        assert omega < 0.6 * _rod_mode(_axis())


def test_chamber_and_accumulator_equalise_to_the_volume_balance():
    """Chamber A at 30 bar, accumulator at 80 bar, valve closed, rod held (heavy, damped).

    Oil volume is conserved: (V_A/E)(P_f − P_A0) + [V_oil(P_f) − V_oil(P_acc0)]
    + (V_h/E)(P_f − P_acc0) = 0 gives P_f. Tolerance 0.2 % of the 50 bar step: the rod
    (10⁶ kg, 10⁹ N·s/m) creeps ~1 µm, which changes P_A by under 0.1 % of it (checked).
    Then the small-signal time constant: τ = R C_A C_acc / (C_A + C_acc) with the hose
    resistance R = 128 μ L / (π d⁴), checked on the first e-fold of the pressure difference
    (5 %, the capacitance varies over the step).
    """
    acc = dict(gas_volume=0.2e-3, precharge_pressure=20e5, hose_length=3.0, hose_diameter=0.004)
    params = _axis(**acc).replace(**{"load.mass": 1e6, "friction.viscous": 1e9})
    a, c, e = params.accumulator, params.cylinder, params.oil.bulk_modulus
    model = hp.FullOrderModel(params)
    y0 = model.initial_state()
    pa0, pacc0 = 30e5, 80e5
    y0[Y_FULL["p_a"]] = pa0
    y0[Y_FULL["p_acc"]] = pacc0
    x = y0[Y_FULL["x"]]
    v_a = c.dead_volume_a + c.area_a * x

    def balance(pf):
        return (
            v_a / e * (pf - pa0)
            + _oil_in_gas_part(a, pf)
            - _oil_in_gas_part(a, pacc0)
            + a.hose_volume / e * (pf - pacc0)
        )

    pf = brentq(balance, pa0, pacc0, xtol=1e-3)
    c_a = v_a / e
    c_acc = a.hose_volume / e + _gas_capacitance(a, pf)
    r_hose = 128 * a.viscosity * a.hose_length / (math.pi * a.hose_diameter**4)
    tau = r_hose * c_a * c_acc / (c_a + c_acc)
    run = hp.simulate(model, 0.0, duration=20 * tau, fs=200 / tau, initial_state=y0, rtol=1e-8)
    pa = run.channels["p_a"]
    pacc = run.states[:, Y_FULL["p_acc"]]
    assert pa[-1] == pytest.approx(pf, abs=0.002 * (pacc0 - pa0))
    assert pacc[-1] == pytest.approx(pf, abs=0.002 * (pacc0 - pa0))
    # the rod's creep changes chamber A's pressure by less than half the tolerance
    assert c.area_a * abs(run.channels["x"][-1] - x) * e / v_a < 0.001 * (pacc0 - pa0)
    gap = pacc - pa
    k = np.argmax(gap <= gap[0] / math.e)
    assert run.t[k] == pytest.approx(tau, rel=0.05)


def test_no_accumulator_leaves_the_model_unchanged():
    """gas_volume = 0: P_acc is inert and the run is bit-for-bit the model without it."""
    base = hp.get_preset("paper")
    tiny_hose = base.replace(accumulator=Accumulator(gas_volume=0.0, hose_diameter=0.05))
    r0 = hp.simulate(hp.FullOrderModel(base), "sine:amplitude=0.3,frequency=2", duration=1.0)
    r1 = hp.simulate(hp.FullOrderModel(tiny_hose), "sine:amplitude=0.3,frequency=2", duration=1.0)
    np.testing.assert_array_equal(r0.channels["x"], r1.channels["x"])
    # P_acc stays at its initial value (to the last bit but the dense output's rounding)
    pacc = r0.states[:, Y_FULL["p_acc"]]
    np.testing.assert_allclose(pacc, pacc[0], rtol=4 * np.finfo(float).eps, atol=0)


def test_component_functions_closed_forms():
    """hose_flow is Hagen–Poiseuille; below the precharge only the hose oil is compliant."""
    q = hose_flow(2e5, 1e5, 2.0, 0.01, 0.04)
    assert q == pytest.approx(math.pi * 0.01**4 * 1e5 / (128 * 0.04 * 2.0), rel=1e-12)
    e, vh = 1.5e9, 1e-4
    assert accumulator_pressure_rate(1e-5, 10e5, 1e-3, 20e5, 1.4, vh, e, -0.95e5, 0.0) == (
        pytest.approx(e / vh * 1e-5, rel=1e-12)
    )
    a = Accumulator(gas_volume=1e-3, precharge_pressure=20e5, hose_length=1.0, hose_diameter=0.01)
    rate = accumulator_pressure_rate(1e-5, 50e5, 1e-3, 20e5, 1.4, a.hose_volume, e, -0.95e5, 0.0)
    assert rate == pytest.approx(1e-5 / (a.hose_volume / e + _gas_capacitance(a, 50e5)), rel=1e-12)


@pytest.mark.parametrize(
    "field, value",
    [
        ("gas_volume", -1e-3),
        ("precharge_pressure", 0.0),
        ("polytropic_index", 2.0),
        ("hose_diameter", 0.0),
    ],
)
def test_accumulator_parameters_are_validated(field, value):
    with pytest.raises(hp.ParameterError, match=f"Accumulator.{field}"):
        Accumulator(**{field: value})


def test_accumulator_reads_from_toml_with_units(tmp_path):
    text = (
        'base = "paper"\n[accumulator]\ngas_volume = "0.75 L"\nprecharge_pressure = "40 bar"\n'
        'hose_length = "2.5 m"\nhose_diameter = "10 mm"\n'
    )
    f = tmp_path / "axis.toml"
    f.write_text(text)
    p = hp.load_params(f)
    assert p.accumulator.gas_volume == pytest.approx(0.75e-3)
    assert p.accumulator.precharge_pressure == pytest.approx(40e5)
    back = tmp_path / "back.toml"
    hp.save_params(p, back)
    assert hp.load_params(back).accumulator == p.accumulator


def test_a_complete_file_without_the_accumulator_still_loads(tmp_path):
    """The accumulator is optional: a complete parameter file written before it existed
    (every other section, no ``base``) loads, with no accumulator."""
    p = hp.get_preset("paper")
    f = tmp_path / "full.toml"
    hp.save_params(p, f)
    text = f.read_text()
    start = text.index("[accumulator]")
    end = text.find("\n[", start + 1)
    f.write_text(text[:start] + (text[end + 1 :] if end > 0 else ""))
    assert "[accumulator]" not in f.read_text()
    assert hp.load_params(f).accumulator.gas_volume == 0.0
