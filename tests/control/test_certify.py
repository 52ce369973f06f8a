"""The loop certificate (issue 51): two independent assemblies of the certified loop agree, the
checker rejects a wrong certificate, and the default design's verdict states why it fails."""

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
    Certificate,
    CertificateStatus,
    _row_loop,
    _scaled,
    _scales,
    _solve_lyapunov,
    certify,
    loop_data,
)


@pytest.fixture(scope="module")
def data(default, paper_pwa):
    return loop_data(default, paper_pwa)


def test_checker_exponential_matches_scipy():
    # the checker's own expm against scipy's Padé on matrices up to the loop's stiffness
    # (‖A T_s‖ ≈ 400 for the valve's ω0² T_s): agreement to 1e-10 of the norm
    rng = np.random.default_rng(1)
    for scale in (0.1, 3.0, 40.0):
        M = rng.normal(size=(9, 9)) * scale / 3
        M -= np.eye(9) * scale  # stable, as the sampled plants are
        ref = expm(M)
        assert np.abs(_expm(M) - ref).max() <= 1e-10 * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("delay", [1, 3])
def test_two_assemblies_of_the_loop_agree(default, paper_pwa, delay):
    # the certifier's loop (scipy expm, its own assembly) and the checker's (its own series,
    # assembled from the law's text) share no code: they agree to 1e-9 of each matrix's size
    d = loop_data(default, paper_pwa, delay_samples=delay)
    for cell in d.cells:
        Mi, Ml, E, a, _k, _h = _row_loop(d, cell)
        Mi2, Ml2, EA = row_matrices(d, cell)
        for x, y in ((Mi, Mi2), (Ml, Ml2), (E, EA[:, :5]), (a, EA[:, 5])):
            assert np.abs(x - y).max() <= 1e-9 * np.abs(x).max()


def test_rows_are_stable_alone_with_the_friction_bounded(data):
    # with the Stribeck drop as a bounded force (not the falling branch's slope) every row's
    # loop contracts in both integral modes; its slowest mode is the integral's (≈ 0.995)
    S = _scales(data)
    for Mi, Ml in _scaled(data).modes:
        for M in (Mi, Ml):
            r = np.abs(np.linalg.eigvals(M)).max()
            assert 0.98 < r < 1.0
    assert S.shape == (data.n_states,)


def _one_row_certificate(data, P, lam):
    return Certificate(
        status=CertificateStatus.CERTIFIED,
        success=False,
        message="",
        e_bar=1.0,
        box=(0.0, 0.0, 0.0),
        reach_time=0.0,
        P=P,
        scales=_scales(data),
        lam=lam,
        level_ultimate=0.0,
        level_region=1.0,
        rho=np.zeros(1),
        rho_hold=0.0,
        disturbance={},
        failing_rows=(),
        not_modelled=(),
        model_hash="",
        law_hash="",
        data=data,
    )


def test_checker_rejects_a_wrong_lyapunov_matrix(data):
    one = dataclasses.replace(data, cells=(data.cells[0],))
    lam = 0.999
    P = _solve_lyapunov(_scaled(one), one, lam)
    assert P is not None

    def lmi_failures(Pm):
        res = check_certificate(_one_row_certificate(one, Pm, lam), one)
        return [f for f in res.failures if "λP" in f]

    assert lmi_failures(P) == []
    assert lmi_failures(7.0 * P) == []  # MᵀPM ≼ λP is invariant under P → αP
    D = np.diag(np.geomspace(1.0, 30.0, one.n_states))
    assert lmi_failures(D @ P @ D)  # a distorted P: the decrease fails
    assert check_certificate(_one_row_certificate(one, -P, lam), one).failures == (
        "P is not symmetric positive definite",
    )


def test_default_paper_design_is_not_certified_and_says_why(default, paper_pwa):
    cert = certify(default, paper_pwa)
    # measured: the integral band's hold (I frozen while |e| > e_I) is a perturbation of the
    # slow integral mode larger than its contraction; the verdict says so with the numbers
    assert not cert.success
    assert cert.status is CertificateStatus.NO_BOUND
    assert cert.rho_hold > 1.0 - np.sqrt(cert.lam) > 0
    assert "ρ₁" in cert.message and cert.e_bar == np.inf
    assert "not certified" in cert.to_dict()["verdict"]


def test_a_flipped_position_gain_names_its_rows(default, paper_pwa):
    flipped = dataclasses.replace(
        default, rows=tuple(dataclasses.replace(r, k_x=-r.k_x) for r in default.rows)
    )
    cert = certify(flipped, paper_pwa)
    assert cert.status is CertificateStatus.NO_LYAPUNOV
    assert len(cert.failing_rows) == len(loop_data(flipped, paper_pwa).cells)


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
