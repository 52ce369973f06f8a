"""Another tool's rig for the dry run (issue 50): the axis FMU played through FMPy.

Not hydropwa's simulate: FMPy's FMI 2.0 co-simulation API steps the FMU from one sample of the
plan's command file to the next (inputs ramped through their derivatives). Sensors are added
here, outside the FMU: white noise and quantisation (a 16-bit converter on ±10 V for the
analogue transmitters, 1 µm steps of a digital SSI position transducer); the vendor's log has
its own column names, pressures, spool and load in volts, the position in mm and the command
in %, a time offset, a pre-trigger and a recording delay of ``delay`` samples.
"""

from __future__ import annotations

import ctypes
import shutil

import numpy as np

_LSB = 20.0 / 2**16  # [V] a 16-bit converter on ±10 V
#: vendor column -> (FMU output, log unit per SI unit, noise std [SI unit], quantum [log unit])
VENDOR = {
    "Pos_mm": ("x", 1e3, 2e-6, 1e-3),  # SSI transducer: 1 µm steps, logged in mm
    "Spool_V": ("spool", 10.0, 2e-3, _LSB),  # ±1 on ±10 V
    "PA_V": ("p_a", 10.0 / 250e5, 0.05e5, _LSB),  # 0-250 bar on 0-10 V
    "PB_V": ("p_b", 10.0 / 250e5, 0.05e5, _LSB),
    "PS_V": ("p_s", 10.0 / 250e5, 0.05e5, _LSB),
    "Load_V": ("f_l", 10.0 / 20e3, 5.0, _LSB),  # ±20 kN on ±10 V
}
#: The vendor's channel map, as a user writes it (volts through gains in engineering units).
CHANNEL_MAP = {
    "map": {"name": "vendor"},
    "channels": {
        "t": {"source": "Zeit", "unit": "s"},
        "u": {"source": "Cmd_pct", "unit": "%"},
        "x": {"source": "Pos_mm", "unit": "mm"},
        "spool": {"source": "Spool_V", "unit": "1", "gain": 0.1},
        "p_a": {"source": "PA_V", "unit": "bar", "gain": 25.0},
        "p_b": {"source": "PB_V", "unit": "bar", "gain": 25.0},
        "p_s": {"source": "PS_V", "unit": "bar", "gain": 25.0},
        "f_l": {"source": "Load_V", "unit": "kN", "gain": 2.0},
    },
}


def play(
    fmu_path: str, t: np.ndarray, u: np.ndarray, f_l: np.ndarray, x0: float, start: dict
) -> dict:
    """Drive the FMU through the command at its sample times; its outputs at those times."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(fmu_path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(fmu_path)
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzipped,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="rig",
    )
    names = ("x", "v", "p_a", "p_b", "spool", "p_s_out")
    outs = [vr[k] for k in names]
    y = np.empty((t.size, len(names)))
    try:
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        init = {"x_0": x0, **start}
        fmu.setReal([vr[k] for k in init], list(init.values()))
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        refs = [vr["u"], vr["f_l"]]
        vr_in = (ctypes.c_uint32 * 2)(*refs)
        order = (ctypes.c_int * 2)(1, 1)
        y[0] = fmu.getReal(outs)
        for k in range(t.size - 1):
            h = float(t[k + 1] - t[k])
            fmu.setReal(refs, [float(u[k]), float(f_l[k])])
            rate = (ctypes.c_double * 2)((u[k + 1] - u[k]) / h, (f_l[k + 1] - f_l[k]) / h)
            fmu.fmi2SetRealInputDerivatives(fmu.component, vr_in, 2, order, rate)
            fmu.doStep(currentCommunicationPoint=float(t[k]), communicationStepSize=h)
            y[k + 1] = fmu.getReal(outs)
        fmu.terminate()
    finally:
        fmu.freeInstance()
        shutil.rmtree(unzipped, ignore_errors=True)
    out = dict(zip(names, y.T, strict=True))
    out["p_s"] = out.pop("p_s_out")
    return out


def vendor_log(
    t: np.ndarray, u: np.ndarray, f_meas: np.ndarray, y: dict, rng, delay: int, pre: int = 50
) -> dict[str, np.ndarray]:
    """The vendor's log: volts with noise and 16-bit steps, ``pre`` samples before the command,
    every channel ``delay`` samples late, time stamps from 1000.0 s (the controller's clock)."""
    chans = {"f_l": f_meas, **y}
    n = t.size + pre + delay
    rate = 1.0 / (t[1] - t[0])
    cols = {"Zeit": 1000.0 + np.arange(n) / rate, "Cmd_pct": 100 * _late(u, pre + delay, 0.0)}
    for col, (ch, gain, std, quantum) in VENDOR.items():
        si = chans[ch] + rng.normal(0.0, std, t.size)
        logged = np.round(gain * si / quantum) * quantum
        cols[col] = _late(logged, pre + delay, logged[0])
    return cols


def _late(a: np.ndarray, n: int, fill: float) -> np.ndarray:
    return np.concatenate([np.full(n, fill), a])
