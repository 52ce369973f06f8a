"""The full-order axis as an FMU, its C generated from the kernel's source (issue 35).

FMPy validates it and drives it (its FMI 2.0 co-simulation API, first-order hold of the
inputs through their derivatives) on the paper's sine inputs; the outputs must be within
0.01 mm and 0.05 bar of ``simulate`` at rtol 1e-8. The emitted C is checked against the
kernel function by function on random states (the translation, not only the end result).
"""

from __future__ import annotations

import ctypes
import math
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from hydropwa import OutputExistsError, load_params
from hydropwa._layout import FULL_STATES
from hydropwa.simulation import _kernel as K
from hydropwa.simulation import export_axis_fmu, simulate
from hydropwa.simulation._axis_fmu import axis_rhs_c
from hydropwa.simulation._emit_c import EmitError, emit_functions, emit_unit

GCC = shutil.which("gcc")
pytestmark = pytest.mark.skipif(GCC is None, reason="gcc is not installed")
MACHINES = Path(__file__).parents[1] / "machines"


def _run_fmu(path: Path, t: np.ndarray, u, start: dict[str, float]) -> np.ndarray:
    """Drive the FMU with FMPy's FMI 2.0 API: the inputs ramp linearly between the points of ``t``.

    ``u``: the command at ``t``, or a dict of input name → values at ``t`` (u, p_s, f_l).

    (``fmpy.simulate_fmu(set_input_derivatives=True)`` sizes its derivative buffer for nine
    inputs in FMPy 0.3.32, so the loop is written out.)
    """
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(str(path))
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzipped,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="axis",
    )
    outs = [vr[k] for k in ("x", "v", "p_a", "p_b")]
    try:
        fmu.instantiate()
        fmu.setupExperiment(startTime=float(t[0]))
        fmu.setReal([vr[k] for k in start], list(start.values()))
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        y = np.empty((len(t), 4))
        y[0] = fmu.getReal(outs)
        inputs = u if isinstance(u, dict) else {"u": u}
        refs = [vr[n] for n in inputs]
        values = np.array([np.asarray(v, dtype=float) for v in inputs.values()])
        vr_in = (ctypes.c_uint32 * len(refs))(*refs)
        order = (ctypes.c_int * len(refs))(*([1] * len(refs)))
        for k in range(len(t) - 1):
            h = float(t[k + 1] - t[k])
            fmu.setReal(refs, [float(v) for v in values[:, k]])
            rate = (ctypes.c_double * len(refs))(*((values[:, k + 1] - values[:, k]) / h))
            assert (
                fmu.fmi2SetRealInputDerivatives(fmu.component, vr_in, len(refs), order, rate) == 0
            )
            fmu.doStep(currentCommunicationPoint=float(t[k]), communicationStepSize=h)
            y[k + 1] = fmu.getReal(outs)
        fmu.terminate()
    finally:
        fmu.freeInstance()
        shutil.rmtree(unzipped, ignore_errors=True)
    return y


def _compiles_from_its_sources(fmu: Path, tmp_path: Path) -> None:
    """The FMU's sources build it on another platform: strict C99, no warning."""
    src = tmp_path / "unzipped"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(src)
    cmd = [GCC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-shared", "-fPIC"]
    proc = subprocess.run(
        [*cmd, "-o", str(src / "re.so"), str(src / "sources" / "hydropwa_axis_fmi2.c"), "-lm"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr


@pytest.mark.parametrize(("amplitude", "frequency"), [(0.4, 2.0), (0.6, 1.0), (0.2, 3.0)])
def test_axis_fmu_follows_simulate_on_the_paper_sines(paper, tmp_path, amplitude, frequency):
    """Sec. VII's sine inputs (three of the nine): within 0.01 mm and 0.05 bar of simulate.

    Measured: 6e-6 / 7e-6 / 1.4e-5 mm and at most 1.2e-4 bar (the FMU's Dormand–Prince and
    the package's Rosenbrock method both at rtol 1e-8). ω0 is set to the Table II schedule at
    the amplitude, as ``simulate`` does in open loop (the FMU's default is the nominal ω0).
    """
    pytest.importorskip("fmpy")
    from fmpy.validation import validate_fmu

    fmu = export_axis_fmu(paper, tmp_path / "axis.fmu")
    assert validate_fmu(str(fmu)) == []
    _compiles_from_its_sources(fmu, tmp_path)
    t = np.arange(0.0, 1.0 + 1e-9, 1e-4)
    res = simulate(
        "full",
        f"sine:amplitude={amplitude},frequency={frequency}",
        params=paper,
        timepts=t,
        rtol=1e-8,
    )
    u = amplitude * np.sin(2 * np.pi * frequency * t)
    y = _run_fmu(fmu, t, u, {"valve.omega0": paper.valve.omega0_at(amplitude), "rtol": 1e-8})
    assert np.ptp(res["x"]) > 5e-3  # the rod moves millimetres, not microns
    assert np.max(np.abs(y[:, 0] - res["x"])) < 1e-5
    assert np.max(np.abs(y[:, 2] - res["p_a"])) < 0.05e5
    assert np.max(np.abs(y[:, 3] - res["p_b"])) < 0.05e5


def test_axis_fmu_follows_varying_supply_pressure_and_load_force(paper, tmp_path):
    """The other two inputs: P_S swinging 80-100 bar at 3 Hz and a 4 Hz, 300 N load force.

    Measured: 9.7e-6 mm, 1.8e-4 bar (same bars as the sine test)."""
    pytest.importorskip("fmpy")
    from hydropwa.simulation import as_signal

    fmu = export_axis_fmu(paper, tmp_path / "axis.fmu")
    t = np.arange(0.0, 0.5 + 1e-9, 1e-4)
    ps = as_signal("sine:amplitude=10 bar,frequency=3,offset=90 bar", "Pa", "supply_pressure")
    fl = as_signal("sine:amplitude=300 N,frequency=4", "N", "load_force")
    u = "sine:amplitude=0.3,frequency=2"
    res = simulate("full", u, params=paper, timepts=t, rtol=1e-8, supply_pressure=ps, load_force=fl)
    inputs = {"u": as_signal(u, "", "u")(t), "p_s": ps(t), "f_l": fl(t)}
    # simulate starts at rest against P_S(0) = 90 bar; the FMU's default rest is at 100 bar
    start = {f"{n}_0": float(v) for (n, _u, _s), v in zip(FULL_STATES, res.states[0], strict=True)}
    start.update({"valve.omega0": paper.valve.omega0_at(0.3), "rtol": 1e-8})
    y = _run_fmu(fmu, t, inputs, start)
    assert np.max(np.abs(y[:, 0] - res["x"])) < 1e-5
    assert np.max(np.abs(y[:, 2] - res["p_a"])) < 0.05e5
    assert np.max(np.abs(y[:, 3] - res["p_b"])) < 0.05e5


def test_axis_fmu_hits_the_end_stop_like_simulate(tmp_path):
    """The heavy industrial axis driven into its end stop: same rest position and pressures."""
    pytest.importorskip("fmpy")
    prm = load_params(MACHINES / "industrial.toml")
    fmu = export_axis_fmu(prm, tmp_path / "axis.fmu", initial_position=0.45)
    with pytest.raises(OutputExistsError):
        export_axis_fmu(prm, fmu)
    t = np.arange(0.0, 0.6 + 1e-9, 2e-4)
    res = simulate("full", "0.5", params=prm, timepts=t, rtol=1e-8, initial_position=0.45)
    y = _run_fmu(
        fmu, t, np.full(t.size, 0.5), {"valve.omega0": prm.valve.omega0_at(0.5), "rtol": 1e-8}
    )
    assert res["x"][-1] > prm.cylinder.stroke  # pressed into the stop
    assert np.max(np.abs(y[:, 0] - res["x"])) < 1e-5
    assert np.max(np.abs(y[:, 2] - res["p_a"])) < 0.05e5


def test_emitted_rhs_is_the_kernel_on_random_states(paper, tmp_path):
    """The C of rhs_full against the compiled kernel at 2000 random states and inputs.

    Covers every branch the emitter translates (flow directions, cavitation, end stops on
    both sides, the pump and the accumulator slots, a specimen in and out of contact and an
    attached spring): relative 1e-12 of each rate's scale.
    """
    rhs, names = axis_rhs_c()
    assert {"rhs_full", "stribeck_friction", "orifice_flows", "chamber_pressure_rates"} <= set(
        names
    )
    src = tmp_path / "rhs.c"
    src.write_text(
        "#include <math.h>\n" + rhs + "\nvoid rhs(const double *y, double u, double ps, double fl,"
        " const double *p, double *dy) { hp_rhs_full(y, u, ps, fl, p, dy); }\n"
    )
    lib_path = tmp_path / "librhs.so"
    cmd = [GCC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off"]
    proc = subprocess.run(
        [*cmd, "-shared", "-fPIC", "-o", str(lib_path), str(src), "-lm"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    lib = ctypes.CDLL(str(lib_path))
    dbl = ctypes.POINTER(ctypes.c_double)
    lib.rhs.argtypes = [dbl, ctypes.c_double, ctypes.c_double, ctypes.c_double, dbl, dbl]
    rng = np.random.default_rng(35)
    from hydropwa.models import FullOrderModel

    variants = [
        paper,
        paper.replace(**{"supply.model": "pump"}),
        paper.replace(**{"accumulator.gas_volume": 0.5e-3, "accumulator.precharge_pressure": 30e5}),
        # a specimen met at mid-stroke with a preload (one-sided), and an attached spring
        paper.replace(
            **{
                "load.specimen_stiffness": 2e6,
                "load.specimen_damping": 3e3,
                "load.contact_position": 0.1,
                "load.preload": 500.0,
            }
        ),
        paper.replace(**{"load.specimen_stiffness": 1e6, "load.preload": -5e4}),
    ]
    n = len(FULL_STATES)
    scale = np.array([s for _n, _u, s in FULL_STATES])
    for prm in variants:
        p = np.ascontiguousarray(FullOrderModel(prm).pack())
        for _ in range(700):
            y = np.empty(n)
            y[:] = scale * rng.normal(0.0, 3.0, n)
            y[2:4] = rng.uniform(-1.2e5, 1.3 * prm.supply.pressure, 2)  # cavitation to above P_S
            y[4] = rng.uniform(-0.01, prm.cylinder.stroke + 0.01)  # both end stops
            y[6] = rng.uniform(0.5, 1.2) * prm.supply.pressure
            y[7] = rng.uniform(0.0, 1.2) * prm.supply.pressure
            u, ps, fl = rng.uniform(-1.2, 1.2), prm.supply.pressure, rng.normal(0, 500)
            want = np.zeros(n)
            K.rhs_full(y, u, ps, fl, p, want)
            got = np.zeros(n)
            lib.rhs(
                y.ctypes.data_as(dbl), u, ps, fl, p.ctypes.data_as(dbl), got.ctypes.data_as(dbl)
            )
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_emitter_refuses_python_it_cannot_translate():
    """A construct outside the subset fails the export with the function and line named."""
    from numba import njit

    @njit
    def looped(x):
        s = 0.0
        while s < x:
            s += 1.0
        return s

    with pytest.raises(EmitError, match=r"looped .*line \d+.*statement While"):
        emit_functions(looped, {})

    @njit
    def two_d(a, k):
        return a[0, k]

    with pytest.raises(EmitError, match=r"two_d .*more than one index"):
        emit_functions(two_d, {})


@njit
def _emit_accumulate(a, n, lo):
    """A callee that writes the array it is given (the caller passes it on without indexing)."""
    for i in range(int(n) - 1):
        a[i + 1] += max(a[i], lo)


@njit
def _emit_entry(a, n, lo, hi):
    _emit_accumulate(a, n, lo)
    s = 0.0
    for j in range(1, int(n)):
        s += min(a[j] * 2.0, hi) if a[j] > -math.inf else 0.0
    return s


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_emitter_translates_loops_index_expressions_min_max_and_int(tmp_path):
    """The subset the control law uses (range loops, computed indices, min/max, int, an array
    written through a callee): the C gives numba's numbers on random inputs."""
    text, names = emit_unit([_emit_entry])
    assert names == ["_emit_accumulate", "_emit_entry"]
    src = tmp_path / "unit.c"
    src.write_text(
        "#include <math.h>\n" + text + "double run(double *a, double n, double lo, double hi)\n"
        "{\n    return hp_emit_entry(a, n, lo, hi);\n}\n",
        encoding="utf-8",
    )
    lib_path = tmp_path / "unit.so"
    flags = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off"]
    subprocess.run(
        ["gcc", *flags, "-shared", "-fPIC", "-o", str(lib_path), str(src), "-lm"], check=True
    )
    lib = ctypes.CDLL(str(lib_path))
    lib.run.restype = ctypes.c_double
    lib.run.argtypes = [ctypes.POINTER(ctypes.c_double)] + [ctypes.c_double] * 3
    rng = np.random.default_rng(3)
    for _ in range(20):
        a = rng.normal(size=9)
        lo, hi = rng.normal(), rng.normal()
        want_a = a.copy()
        want = _emit_entry(want_a, 9.0, lo, hi)
        got_a = a.copy()
        got = lib.run(got_a.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), 9.0, lo, hi)
        assert got == want
        np.testing.assert_array_equal(got_a, want_a)
