"""Negative controls of the loop certificate (issue 51, item 4): on a loop the certifier
certifies (one gain row of the paper rig's default design, friction 0 and 1/100 of the noise,
the band's and the inverse's command terms in full), mutated laws are answered "not
certified", and the checker rejects a certifier that always says yes or claims an empty
region."""

import dataclasses

import pytest

from hydropwa.control._certcheck import check_certificate
from hydropwa.control._certify import (
    CertificateStatus,
    _levels,
    _scaled,
    _solve_lyapunov,
    _unchecked,
    certify_data,
    loop_data,
)


def _reduced(data):
    w3 = [c for c in data.cells if c["label"].startswith("s=+1 o=0 w=3")]
    b = data.bounds | {
        "friction": 0.0,
        "x_noise": data.bounds["x_noise"] / 100,
        "p_noise": data.bounds["p_noise"] / 100,
    }
    return dataclasses.replace(data, cells=tuple(w3), bounds=b, integral_band=0.0)


def _rows(ctrl, **scale):
    return dataclasses.replace(
        ctrl,
        rows=tuple(
            dataclasses.replace(r, **{k: f * getattr(r, k) for k, f in scale.items()})
            for r in ctrl.rows
        ),
    )


@pytest.fixture(scope="module")
def base(default, paper_pwa):
    cert = certify_data(_reduced(loop_data(default, paper_pwa)))
    # measured: ē 0.68 mm, region level 4.1 against 1.21
    assert cert.success and cert.status is CertificateStatus.CERTIFIED, cert.message
    assert 0 < cert.e_bar < 1e-3 and min(cert.box) > 0
    return cert


@pytest.mark.parametrize(
    ("mutation", "status"),
    [
        ({"k_i": 5.0}, CertificateStatus.EMPTY_REGION),  # ē 3.0 mm, region level 0.28
        ({"k_x": 0.2}, CertificateStatus.NO_LYAPUNOV),  # a row unstable alone
        ({"k_x": -1.0}, CertificateStatus.NO_LYAPUNOV),  # the sign flipped
    ],
)
def test_mutated_gains_are_not_certified(base, default, paper_pwa, mutation, status):
    cert = certify_data(_reduced(loop_data(_rows(default, **mutation), paper_pwa)))
    assert not cert.success and cert.status is status


def test_a_doubled_dead_zone_offset_is_not_certified(base, default, paper_pwa, paper):
    # the inverse's offset 2β against the machine's β opens the valve by β = 10 % at every
    # command (and the creep's share of the wider blend, 0.04·β): a command disturbance of
    # 0.12 instead of 0.017, and the region is empty
    dz = dataclasses.replace(default.dead_zone_inverse, offset=2 * default.dead_zone_inverse.offset)
    data = _reduced(loop_data(dataclasses.replace(default, dead_zone_inverse=dz), paper_pwa))
    beta, creep = paper.dead_zone.beta, paper.dead_zone.creep_slope
    assert data.bounds["command"] == pytest.approx(base.disturbance["command"] + beta * (1 + creep))
    cert = certify_data(data)
    assert not cert.success and cert.status is CertificateStatus.EMPTY_REGION


def test_the_checker_rejects_a_yes_sayer_and_an_empty_region(base, default, paper_pwa):
    data = _reduced(loop_data(_rows(default, k_i=5.0), paper_pwa))
    # a certifier that says yes: the base's certificate claimed for the mutated loop
    yes = dataclasses.replace(base, data=data)
    res = check_certificate(yes, data)
    assert not res.passed and any("≼" in f for f in res.failures)
    # the mutant's own ellipsoid (its region empty) declared certified with a region level
    # above the ultimate set's: the region then reaches saturation
    sc = _scaled(data)
    P, mus, taus, sigmas = _solve_lyapunov(sc, data, 0.995) or _solve_lyapunov(
        sc, data, 0.995, sectors=False
    )
    lv = _levels(P, mus, sc, data, 0.995)
    assert lv["status"] is CertificateStatus.EMPTY_REGION
    lv |= {"status": CertificateStatus.CERTIFIED, "level_region": 2.0 * lv["level_ultimate"]}
    lv |= {"box": base.box, "reach_time": 1.0, "mu": mus, "tau": taus, "sigma": sigmas}
    failures = check_certificate(_unchecked(data, P, 0.995, lv), data).failures
    assert any("saturation" in f for f in failures), failures
    # a region shrunk to nothing
    base_data = base.data
    empty = dataclasses.replace(base, level_region=0.0, box=(0.0, 0.0, 0.0))
    assert any("region's level" in f for f in check_certificate(empty, base_data).failures)
