"""The loop certificate (issue 51): two independent assemblies of the certified loop agree, an
invariant ellipsoid found for a loop is accepted by the checker and a wrong one rejected, and
the default design's verdict says why it is not certified."""

import dataclasses
import tomllib

import numpy as np
import pytest
from scipy.linalg import expm
from typer.testing import CliRunner

from hydropwa.cli import app
from hydropwa.control import controller_schema, load_controller, save_controller
from hydropwa.control._certcheck import _expm, check_certificate, row_matrices
from hydropwa.control._certify import (
    CertificateStatus,
    _row_loop,
    _scaled,
    _unchecked,
    certify,
    loop_data,
)


@pytest.fixture(scope="module")
def data(default, paper_pwa):
    return loop_data(default, paper_pwa)


@pytest.fixture(scope="module")
def quiet_row(default, paper_pwa):
    """One gain row of the default design without friction and with 1/100 of the noise: a loop
    whose invariant ellipsoid lies inside its linear region (certified in ~10 s)."""
    d = loop_data(default, paper_pwa)
    w3 = [c for c in d.cells if c["label"].startswith("s=+1 o=0 w=3")]
    bounds = {k: v / 100 for k, v in d.bounds.items()} | {"friction": 0.0}
    return dataclasses.replace(d, cells=tuple(w3), bounds=bounds, integral_band=0.0)


def test_checker_exponential_matches_scipy():
    # the checker's own expm against scipy's Padé up to the sampled valve's stiffness
    # (‖A T_s‖ ≈ 200): agreement to 1e-10 of the norm
    rng = np.random.default_rng(1)
    for scale in (0.1, 3.0, 40.0):
        M = rng.normal(size=(9, 9)) * scale / 3 - np.eye(9) * scale
        ref = expm(M)
        assert np.abs(_expm(M) - ref).max() <= 1e-10 * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("delay", [1, 3])
def test_two_assemblies_of_the_loop_agree(default, paper_pwa, delay):
    # the certifier's loop (scipy's expm, its assembly) and the checker's (its own series,
    # assembled from the law's text) share no code: they agree to 1e-9 of each matrix's size
    d = loop_data(default, paper_pwa, delay_samples=delay)
    assert d.n_states == 9 + delay
    for cell in d.cells:
        Mi, Ml, E, a, _k, _h = _row_loop(d, cell)
        Mi2, Ml2, EA = row_matrices(d, cell)
        for x, y in ((Mi, Mi2), (Ml, Ml2), (E, EA[:, :6])):
            assert np.abs(x - y).max() <= 1e-9 * np.abs(x).max()
        assert np.abs(a - EA[:, 6]).max() <= 1e-9 * (1.0 + np.abs(a).max())


def test_rows_are_stable_alone_with_the_friction_bounded(data):
    # with the Stribeck drop as a bounded force (not the falling branch's slope, 1.42 per
    # sample on the paper rig) every row's loop contracts in both integral modes; the slowest
    # mode is the integral's, ≈ 0.995 per sample
    for Mi, Ml in _scaled(data).modes:
        for M in (Mi, Ml):
            assert 0.98 < np.abs(np.linalg.eigvals(M)).max() < 1.0


def test_default_design_is_not_certified_and_says_why(default, paper_pwa):
    cert = certify(default, paper_pwa)
    assert not cert.success and cert.status is CertificateStatus.INTEGRAL_HOLD
    assert "integral_band = 0" in cert.message and cert.e_bar == np.inf
    assert cert.to_dict()["verdict"] == "not certified"


def test_a_flipped_position_gain_names_its_rows(default, paper_pwa):
    flipped = dataclasses.replace(
        default, rows=tuple(dataclasses.replace(r, k_x=-r.k_x) for r in default.rows)
    )
    cert = certify(flipped, paper_pwa)
    assert cert.status is CertificateStatus.NO_LYAPUNOV
    assert len(cert.failing_rows) == len(loop_data(flipped, paper_pwa).cells)


def _certify_data(data):
    """:func:`certify`'s path on prepared loop data (the rows, bounds and modes given)."""
    from hydropwa.control._certify import (
        _levels,
        _solve_lyapunov,
    )

    sc = _scaled(data)
    P, mus, taus, sigmas = _solve_lyapunov(sc, data, 0.995)
    lv = _levels(P, mus, sc, data, 0.995)
    assert lv["status"] is CertificateStatus.CERTIFIED, lv["status"]
    return _unchecked(data, P, 0.995, {**lv, "mu": mus, "tau": taus, "sigma": sigmas})


def test_checker_accepts_the_ellipsoid_and_rejects_wrong_ones(quiet_row):
    cert = _certify_data(quiet_row)
    res = check_certificate(cert, quiet_row)
    assert res.passed, res.failures
    # the ellipsoid's extent in x is the bound: sub-millimetre without friction, and the
    # largest box of the region is not empty
    assert 0 < cert.e_bar < 1e-3 and min(cert.box) > 0
    # P scaled ×1e4 with ē / 100: the same shape, a set 100× smaller than the ellipsoid found;
    # one sample of the disturbances leaves it (a state on its boundary with the worst noise)
    wrong = dataclasses.replace(cert, P=1e4 * cert.P, e_bar=cert.e_bar / 100)
    assert any("≼" in f for f in check_certificate(wrong, quiet_row).failures)
    # a claimed ē below the ellipsoid's extent
    low = dataclasses.replace(cert, e_bar=0.9 * cert.e_bar)
    assert any("ē" in f for f in check_certificate(low, quiet_row).failures)
    # a box wider than the region
    wide = dataclasses.replace(cert, box=tuple(2 * b for b in cert.box))
    assert any("box corner" in f for f in check_certificate(wide, quiet_row).failures)
    # multipliers that overspend the contraction
    greedy = dataclasses.replace(cert, mu=tuple(m + 0.01 for m in cert.mu))
    assert not check_certificate(greedy, quiet_row).passed
    assert check_certificate(dataclasses.replace(cert, P=-cert.P), quiet_row).failures == (
        "P is not symmetric positive definite",
    )


def test_a_certificate_table_round_trips(tmp_path, quiet_row, default, paper):
    from hydropwa.control import write_certificate

    cert = _certify_data(quiet_row)
    res = check_certificate(cert, quiet_row)
    cert = dataclasses.replace(cert, success=res.passed, check=res)
    path = tmp_path / "ctrl.toml"
    save_controller(default, path, machine_parameters=paper)
    write_certificate(path, cert)
    table = tomllib.loads(path.read_text())["certificate"]
    assert table["verdict"] == "certified" and table["checker"] == "pass"
    assert table["e_bar"] == f"{cert.e_bar * 1e3:.6g} mm"
    P = np.array(table["sublevel"]["P"])
    assert np.array_equal(P, cert.P)  # TOML keeps the float64 matrix bit for bit


def test_cli_certify_writes_the_table(tmp_path, default, paper):
    jsonschema = pytest.importorskip("jsonschema")
    path = tmp_path / "ctrl.toml"
    save_controller(default, path, machine_parameters=paper)
    before = load_controller(path)
    res = CliRunner().invoke(app, ["control", "certify", str(path), "--write"])
    assert res.exit_code == 1, res.output  # not certified: exit 1, the table written
    doc = tomllib.loads(path.read_text())
    assert doc["certificate"]["verdict"] == "not certified"
    assert doc["certificate"]["law_hash"] and doc["certificate"]["model_hash"]
    jsonschema.validate(doc, controller_schema())
    assert load_controller(path).rows == before.rows  # the law is untouched
    again = CliRunner().invoke(app, ["control", "certify", str(path), "--write"])
    assert again.exit_code == 2 and "--force" in again.output


def test_design_certify_refuses_to_write_an_uncertified_design(tmp_path):
    out = tmp_path / "c.toml"
    argv = ["control", "design", "--params", "paper", "--no-verify", "--certify", "--out", str(out)]
    res = CliRunner().invoke(app, argv)
    assert res.exit_code == 1 and "cannot be certified (integral_hold)" in res.output
    assert not out.exists()
    pi = CliRunner().invoke(app, [*argv[:-2], "--method", "pi", "--out", str(out)])
    assert pi.exit_code == 2 and "--certify needs" in pi.output


def test_cli_soundness_samples_grow_the_bound(tmp_path, default, paper):
    """``control certify --soundness-samples N``: the disturbance set checked on the full model
    one sample at a time and grown (the band-free law); with samples the bound grows (the
    grown set holds the nominal one), and a negative count is one usage error (exit 2)."""
    dz = dataclasses.replace(default.dead_zone_inverse, integral_band=0.0)
    path = tmp_path / "ctrl.toml"
    save_controller(
        dataclasses.replace(default, dead_zone_inverse=dz), path, machine_parameters=paper
    )
    bounds = {}
    for n in (0, 6):
        argv = ["control", "certify", str(path), "--soundness-samples", str(n)]
        res = CliRunner().invoke(app, argv)
        assert res.exit_code in (0, 1), res.output
        line = next(ln for ln in res.output.splitlines() if "ultimate bound ē" in ln)
        bounds[n] = float(line.split("ē = ")[1].split(" mm")[0])
    # measured 2.975 → 3.978 mm: the one-step check grows the Ṗ_L row's bound, so a run
    # that ignored the option (equal bounds) fails
    assert np.isfinite(bounds[0]) and bounds[6] > 1.05 * bounds[0]
    bad = CliRunner().invoke(app, ["control", "certify", str(path), "--soundness-samples", "-1"])
    assert bad.exit_code == 2
