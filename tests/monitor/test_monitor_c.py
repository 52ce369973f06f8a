"""The monitor's residual generator as C (issue 53, point 4), in lockstep with the package.

The C is generated from the numba source of hydropwa/monitor/_residuals.py (the row and result
functions and the component physics they call); the package runs that source over the same
filtered rows. Truths: the package's own generator (same source: residuals, indicators ≤ 1e-12
relative, identical alarms), the offline monitor's least squares (the same indicators from the
same rows by another algorithm), and scipy's Savitzky–Golay filter (the header's coefficients).
"""

from __future__ import annotations

import ctypes
import dataclasses
import importlib.util
import subprocess
from pathlib import Path

import numpy as np
import pytest

from hydropwa import OutputExistsError
from hydropwa.monitor import HealthMonitor
from hydropwa.monitor import _residuals as R
from hydropwa.monitor._target import (
    c_sources,
    export_c,
    online_check,
    pack_online,
    target_thresholds,
)
from hydropwa.params import get_preset
from hydropwa.rig import Fault, Rig, execute, inject, load_campaign, plan, run_seed

_spec = importlib.util.spec_from_file_location(
    "c_support", Path(__file__).resolve().parents[1] / "control" / "c_support.py"
)
assert _spec is not None and _spec.loader is not None
c_support = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(c_support)

pytestmark = pytest.mark.skipif(c_support.GCC is None, reason="needs gcc")

D = ctypes.c_double
DP = ctypes.POINTER(ctypes.c_double)


def _run(rig, faults=(), seed=1):
    (spec,) = [
        s for s in plan(load_campaign("paper")["sine"], rig) if s.name == "sine_load_retract_u20"
    ]
    params, offset, _ = inject(rig.params, faults, 0, 1)
    faulty = dataclasses.replace(rig, params=params, supply=params.supply)
    return execute(
        faulty, dataclasses.replace(spec, command_offset=offset), run_seed(seed, "sine", spec.name)
    )


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    rig = Rig(get_preset("paper"))
    mon = HealthMonitor().fit(rig.params)
    healthy = _run(rig)
    report = mon.check_dataset([healthy])
    (h,) = report.runs
    P = pack_online(mon, target_thresholds(report), h.sliding_speed, h.logged)
    out = tmp_path_factory.mktemp("monc")
    for name, text in c_sources(mon, P, float(healthy.fs)).items():
        (out / name).write_text(text)
    so = out / "libmon.so"
    cmd = [c_support.GCC, *c_support.STRICT, "-shared", "-fPIC", "-o", str(so)]
    proc = subprocess.run(
        [*cmd, str(out / "hydropwa_monitor.c"), "-lm"], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr  # no warning at all
    lib = ctypes.CDLL(str(so))
    lib.hydropwa_monitor_row.argtypes = [DP, *([D] * 11), DP]
    lib.hydropwa_monitor_result.argtypes = [DP, DP, ctypes.POINTER(ctypes.c_int), DP]
    lib.hydropwa_monitor_result.restype = ctypes.c_int
    lib.hydropwa_monitor_continuity.argtypes = [DP, DP, ctypes.POINTER(ctypes.c_int)]
    lib.hydropwa_monitor_continuity.restype = ctypes.c_int
    return rig, mon, healthy, h, P, lib


def _replay_c(lib, mon, run):
    """The C over the run's filtered rows (the package's filter): residuals, values, alarms."""
    sig = R.prepare(run.channels, float(run.fs), mon.params_, mon.window)
    n = sig.t.size
    sums = (D * R.N_S)()
    lib.hydropwa_monitor_init(sums)
    r3 = (D * 3)()
    res = np.empty((n, 3))
    for k in range(n):
        args = (sig.nu, sig.nu_model, sig.x, sig.v, sig.a, sig.p_a, sig.p_b, sig.dp_a, sig.dp_b)
        extra = (
            sig.p_s[k] if sig.p_s is not None else 0.0,
            sig.f_l[k] if sig.f_l is not None else 0.0,
        )
        lib.hydropwa_monitor_row(sums, *(float(a[k]) for a in args), *map(float, extra), r3)
        res[k] = list(r3)
    value, rms = (D * 3)(), (D * 3)()
    alarm = (ctypes.c_int * 3)()
    n_alarms = lib.hydropwa_monitor_result(sums, value, alarm, rms)
    value4, alarm4 = (D * 4)(), (ctypes.c_int * 4)()
    n_alarms += lib.hydropwa_monitor_continuity(sums, value4, alarm4)
    values = np.array([*value, *value4])
    return res, values, [bool(a) for a in (*alarm, *alarm4)], n_alarms


def _close(a, b, rel=1e-12):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert np.array_equal(np.isnan(a), np.isnan(b))
    ok = ~np.isnan(a)
    assert np.all(np.abs(a[ok] - b[ok]) <= rel * np.maximum(np.abs(b[ok]), 1e-300)), (a, b)


#: 0.1 L/min at 50 bar (the issue's smallest leakage) [m³/s]
LEAK = 0.1 / 6e4


@pytest.mark.parametrize(
    "faults",
    [
        (),
        (Fault("friction", 0.30),),
        (Fault("supply", 0.10),),
        (Fault("valve_null", 0.005),),
        (Fault("internal_leakage", LEAK),),
        (Fault("external_leakage_a", 5 * LEAK),),
    ],
    ids=["healthy", "friction", "supply", "valve_null", "internal_leakage", "external_leakage_a"],
)
def test_c_and_package_in_lockstep(setup, faults):
    rig, mon, _healthy, _h, P, lib = setup
    run = _run(rig, faults, seed=2)
    pkg = online_check(mon, run, P)
    res, value, alarm, n_alarms = _replay_c(lib, mon, run)
    # residuals: same source, same operations; relative to each column's largest value
    scale = np.max(np.abs(pkg.residuals), axis=0)
    assert np.all(np.abs(res - pkg.residuals) <= 1e-12 * scale)
    _close(value, list(pkg.values.values()))
    assert alarm == list(pkg.alarms.values()) and n_alarms == sum(alarm)
    # the fault injected is the one that alarms (thresholds of the healthy commissioning run)
    expected = {
        f.kind.replace("friction", "friction_scale").replace("supply", "supply_pressure")
        for f in faults
    }
    assert {n for n, a in pkg.alarms.items() if a} == expected


def test_the_target_indicators_are_the_offline_monitors(setup):
    rig, mon, healthy, h, P, _lib = setup
    pkg = online_check(mon, healthy, P)
    for name, v in pkg.values.items():
        # the same rows and equations; least squares by SVD there, running sums here
        assert v == pytest.approx(h.indicators[name].value, rel=1e-10, abs=1e-14), name
        assert not pkg.alarms[name] and not h.indicators[name].alarm


def test_the_headers_filter_is_the_packages(setup, tmp_path):
    rig, mon, healthy, _h, P, _lib = setup
    from hydropwa.monitor._target import _savgol_rows

    fs = float(healthy.fs)
    w = max(7, int(round(mon.window * fs)) | 1)
    sg = _savgol_rows(w, fs)
    sig = R.prepare(healthy.channels, fs, mon.params_, mon.window)
    x = np.asarray(healthy.channels["x"], float)
    t = np.asarray(healthy.channels["t"], float)
    k = int(np.searchsorted(t, sig.t[5]))  # a row's sample: its window centred there
    win = x[k - w // 2 : k + w // 2 + 1]
    got = sg @ win
    assert got == pytest.approx([sig.x[5], sig.v[5], sig.a[5]], rel=1e-9)
    assert f"#define HYDROPWA_MONITOR_WINDOW {w}" in c_sources(mon, P, fs)["hydropwa_monitor.h"]


def test_export_writes_the_files_and_refuses_to_overwrite(setup, tmp_path):
    _rig, mon, healthy, _h, _P, _lib = setup
    report = mon.check_dataset([healthy])
    export_c(mon, report, float(healthy.fs), tmp_path / "c")
    names = sorted(p.name for p in (tmp_path / "c").iterdir())
    assert names == ["README.md", "hydropwa_monitor.c", "hydropwa_monitor.h"]
    thr = target_thresholds(report)["friction_scale"][1]
    assert (
        f"#define HYDROPWA_MONITOR_FRICTION_HIGH {thr!r}"
        in (tmp_path / "c" / "hydropwa_monitor.h").read_text()
    )
    with pytest.raises(OutputExistsError):
        export_c(mon, report, float(healthy.fs), tmp_path / "c")


def test_cli_writes_the_c_beside_the_report(setup, tmp_path):
    from typer.testing import CliRunner

    from hydropwa.cli import app, main
    from hydropwa.data import Dataset
    from hydropwa.params import save_params

    rig, _mon, healthy, _h, _P, _lib = setup
    ds = Dataset.create(tmp_path / "data")
    ds.add_run(healthy)
    save_params(rig.params, tmp_path / "identified.toml")
    argv = ["monitor", str(tmp_path / "data"), "--params", str(tmp_path / "identified.toml")]
    argv += ["--out", str(tmp_path / "h"), "--c", str(tmp_path / "c")]
    res = CliRunner().invoke(app, argv)
    assert res.exit_code == 0, res.output
    assert (tmp_path / "c" / "hydropwa_monitor.c").is_file()
    (tmp_path / "h2").mkdir()
    argv[argv.index(str(tmp_path / "h"))] = str(tmp_path / "h2")
    assert main(argv) == 2  # the C folder exists: one error line, exit 2, nothing written
    assert not (tmp_path / "h2" / "health.json").exists()
