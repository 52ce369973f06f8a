"""Write ``examples/rig_log/chirp_log.mat``: a log of the virtual rig in volts, as a real rig writes it.

A 3 s chirp of the valve command (20 % amplitude, 1 → 40 Hz) on the paper's rig, measured by its
sensors and 16-bit converters (Table I), stored as the raw converter voltages in a MATLAB v5
file, one (N, 1) variable per input channel, like a Speedgoat/dSPACE recording. The channel map
``hydraulic_rig.toml`` beside it turns the voltages back into SI channels; its gains and offsets
are the sensors' (range mapped onto the converter span).

Run from the repository root: ``python examples/make_rig_log.py`` (a few seconds once compiled).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.io

from hydropwa.rig import Rig, RunSpec, execute, run_seed
from hydropwa.simulation import Chirp

OUT = Path(__file__).resolve().parent / "rig_log"
#: channel -> variable name in the log
VARIABLES = {"u": "U_cmd", "spool": "U_spool", "p_a": "U_pA", "p_b": "U_pB", "p_s": "U_pS", "x": "U_pos", "f_l": "U_force"}


def volts(sensor, value):
    """Converter input voltage [V] for ``value`` [SI] (the sensor's range onto its span)."""
    lo, hi = sensor.range
    vlo, vhi = sensor.adc_span
    gain = sensor.gain if sensor.gain is not None else (vhi - vlo) / (hi - lo)
    return vlo + (np.asarray(value) - lo) * gain


def main() -> None:
    rig = Rig.from_params("paper")
    spec = RunSpec(
        name="chirp_log",
        experiment="sine",
        command=Chirp(amplitude=0.2, f0=1.0, f1=40.0, duration=3.0),
        duration=3.0,
        start_position=0.5 * rig.params.cylinder.stroke,
        meta={"signal": "chirp 20 %, 1-40 Hz"},
    )
    run = execute(rig, spec, run_seed(1, "example", "chirp_log"))
    data = {"Time": run.t[:, None]}
    for ch, var in VARIABLES.items():
        if ch == "u":  # the command is recorded as sent: +-10 V = +-100 %
            v = 10.0 * run[ch]
        else:
            v = volts(rig.sensors[ch], run[ch])
        data[var] = np.round(v, 5)[:, None]  # the converters' 0.3 mV step; 5 decimals keep it
    OUT.mkdir(exist_ok=True)
    scipy.io.savemat(OUT / "chirp_log.mat", data, do_compression=True, format="5")
    print(f"wrote {OUT / 'chirp_log.mat'} ({run.t.size} samples)")
    for ch in VARIABLES:
        if ch != "u":
            s = rig.sensors[ch]
            print(ch, s.range, s.adc_span, s.gain)


if __name__ == "__main__":
    main()
