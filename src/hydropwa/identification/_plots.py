"""Figures of the identification (Figs. 5, 6, 8 of the paper and the EMPS force fit).

Each function takes a fitted estimator (or result), returns a matplotlib
``Figure`` built without pyplot (no global state, no display needed) and, given
a path, writes it atomically. Plotting is kept apart from computing.
"""

from __future__ import annotations

import os

import numpy as np

from .._io import atomic_path

__all__ = [
    "plot_bode",
    "plot_dead_zone",
    "plot_stribeck",
    "plot_inverse_dynamics",
    "plot_greybox_fit",
    "plot_greybox_residuals",
    "plot_greybox_profiles",
    "save_figure",
]


def _figure(nrows: int = 1, ncols: int = 1, **kw):
    from matplotlib.figure import Figure

    fig = Figure(figsize=kw.pop("figsize", (7.0, 5.0)), layout="constrained")
    axes = fig.subplots(nrows, ncols, **kw)
    return fig, axes


def save_figure(fig, path: str | os.PathLike) -> None:
    """Write a figure atomically (format from the suffix, default PNG)."""
    from pathlib import Path

    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format=path.suffix.lstrip(".") or "png")


def plot_bode(valve, path: str | os.PathLike | None = None):
    """Bode plot of the measured valve FRFs and the fitted model (1), Fig. 5.

    Parameters
    ----------
    valve : ValveFrfIdentifier
        A fitted estimator (``frf_``, ``fits_``).
    path : path-like, optional
        Where to write the figure.
    """
    broadband = any(frf.coherence is not None for frf in valve.frf_.values())
    if broadband:  # H1 estimates: a coherence panel shows which bins the fit could trust
        fig, (ax_m, ax_p, ax_c) = _figure(
            3, 1, sharex=True, figsize=(7.0, 6.5), gridspec_kw={"height_ratios": [3, 3, 1.5]}
        )
    else:
        fig, (ax_m, ax_p) = _figure(2, 1, sharex=True)
    colors = ["C0", "C1", "C2", "C3", "C4", "C5"]
    for k, (amp, frf) in enumerate(valve.frf_.items()):
        c = colors[k % len(colors)]
        label = f"|u| = {100 * amp:.3g} %"
        style = (
            dict(ls="-", lw=0.8, alpha=0.7)
            if frf.coherence is not None
            else dict(ls="", marker="o", ms=3)
        )
        ax_m.semilogx(frf.frequency, frf.magnitude_db, color=c, label=f"{label} data", **style)
        ax_p.semilogx(frf.frequency, frf.phase_deg, color=c, **style)
        if broadband and frf.coherence is not None:
            ax_c.semilogx(frf.frequency, frf.coherence, color=c, lw=0.8)
        fit = valve.fits_.get(amp)
        if fit is not None:
            f = np.geomspace(frf.frequency.min(), frf.frequency.max(), 200)
            g = fit.response(2 * np.pi * f)
            ax_m.semilogx(
                f,
                20 * np.log10(np.abs(g)),
                "-",
                color=c,
                label=f"fit ω0 = {fit.omega0.value:.0f} rad/s, ζ = {fit.zeta.value:.2f}",
            )
            ax_p.semilogx(f, np.degrees(np.unwrap(np.angle(g))), "-", color=c)
    ax_m.set_ylabel("magnitude [dB]")
    ax_p.set_ylabel("phase [deg]")
    if broadband:
        ax_c.set_ylabel("coherence γ²")
        ax_c.set_ylim(0.0, 1.05)
        ax_c.axhline(getattr(valve, "min_coherence", 0.8), color="k", lw=0.6, ls="--")
        ax_c.grid(True, which="both", alpha=0.3)
        ax_c.set_xlabel("frequency [Hz]")
    else:
        ax_p.set_xlabel("frequency [Hz]")
    ax_m.legend(fontsize=7)
    ax_m.grid(True, which="both", alpha=0.3)
    ax_p.grid(True, which="both", alpha=0.3)
    fig.suptitle("Servo valve FRF and second-order fit (Eq. (1), Fig. 5)")
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_dead_zone(dz, path: str | os.PathLike | None = None):
    """Rod velocity against command with the hinge fit, Fig. 6.

    Parameters
    ----------
    dz : DeadZoneIdentifier
        A fitted estimator (``points_``, ``fit_``).
    path : path-like, optional
        Where to write the figure.
    """
    fig, ax = _figure()
    pts = dz.points_
    ax.errorbar(
        100 * pts["u"], 1e3 * pts["v"], yerr=1e3 * pts["v_std"], fmt="o", ms=3, label="runs"
    )
    u = np.linspace(pts["u"].min(), pts["u"].max(), 800)
    f = dz.fit_
    ax.plot(
        100 * u,
        1e3 * f.velocity(u),
        "-",
        label=f"hinge fit, β = {100 * f.beta.value:.2f} % "
        f"[{100 * f.beta.ci[0]:.2f}, {100 * f.beta.ci[1]:.2f}], k_g = {f.creep_slope.value:.3f}",
    )
    for b in (f.beta_pos.value, -f.beta_neg.value):
        ax.axvline(100 * b, color="0.6", ls=":")
    ax.set_xlabel("command u [%]")
    ax.set_ylabel("rod velocity [mm/s]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Dead zone from constant inputs (Sec. VI-B, Fig. 6)")
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_stribeck(fr, path: str | os.PathLike | None = None):
    """Friction points, the fitted Stribeck curve (11) and the residuals, Fig. 8.

    Parameters
    ----------
    fr : StribeckIdentifier or StribeckFit
        A fitted estimator or a fit.
    path : path-like, optional
        Where to write the figure.
    """
    fit = getattr(fr, "fit_", fr)
    fig, (ax, ax_r) = _figure(2, 1, sharex=True, height_ratios=[3, 1])
    v, f = fit.velocity, fit.force
    ax.plot(1e3 * v, f, "o", ms=3, label="steady-state points, Eq. (10)")
    vv = np.linspace(v.min(), v.max(), 1000)
    fc = fit.friction
    ax.plot(
        1e3 * vv,
        fit.force_at(vv),
        "-",
        label=f"Eq. (11): F_c = {fc.coulomb:.1f} N, F_s = {fc.static:.1f} N, σ = {fc.viscous:.0f} N·s/m",
    )
    ax.set_ylabel("friction force [N]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    if fit.weak:
        ax.set_title(f"weakly identified: {', '.join(fit.weak)}", fontsize=8)
    ax_r.plot(1e3 * v, fit.residuals, "o", ms=3)
    ax_r.axhline(0.0, color="0.5")
    ax_r.set_xlabel("velocity [mm/s]")
    ax_r.set_ylabel("residual [N]")
    ax_r.grid(True, alpha=0.3)
    fig.suptitle("Stribeck friction (Sec. VI-C, Fig. 8)")
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_inverse_dynamics(result, path: str | os.PathLike | None = None):
    """Measured and predicted force of an IDIM-LS fit.

    Parameters
    ----------
    result : InverseDynamicsResult or EmpsResult
    path : path-like, optional
        Where to write the figure.
    """
    fit = getattr(result, "fit", result)
    fig, ax = _figure()
    ax.plot(fit.time, fit.force, "-", lw=1.2, label="measured (decimated)")
    ax.plot(fit.time, fit.predicted, "--", lw=1.0, label="IDIM-LS model")
    ax.plot(fit.time, fit.force - fit.predicted, "-", lw=0.6, color="0.3", label="error")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("force [N]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Inverse dynamics: relative error {100 * fit.relative_error:.2f} %")
    if path is not None:
        save_figure(fig, path)
    return fig


# --------------------------------------------------------------------------- grey-box fit
_GB_SCALE = {
    "x": (1e3, "x [mm]"),
    "v": (1e3, "v [mm/s]"),
    "p_a": (1e-5, "p_A [bar]"),
    "p_b": (1e-5, "p_B [bar]"),
    "p_l": (1e-5, "p_L [bar]"),
}


def _greybox_run(fit, run):
    if run is None:
        return fit.runs_[0]
    for r in fit.runs_:
        if r.name == run:
            return r
    raise KeyError(f"no run {run!r} in the fit; runs: {', '.join(r.name for r in fit.runs_)}")


def plot_greybox_fit(fit, run: str | None = None, path: str | os.PathLike | None = None):
    """Measured and fitted channels of one run of a grey-box fit.

    Parameters
    ----------
    fit : GreyBoxFit
    run : str, optional
        Run name (default the first run).
    path : path-like, optional
        Where to write the figure.
    """
    r = _greybox_run(fit, run)
    chans = list(r.measured)
    fig, axes = _figure(
        len(chans), 1, sharex=True, squeeze=False, figsize=(7.0, 1.8 + 1.6 * len(chans))
    )
    for ax, c in zip(axes[:, 0], chans, strict=True):
        k, label = _GB_SCALE.get(c, (1.0, c))
        ax.plot(r.t, k * r.measured[c], "-", lw=0.8, color="0.4", label="measured")
        ax.plot(
            r.t, k * r.simulated[c], "-", lw=0.9, color="C3", label=f"fitted ({r.method} shooting)"
        )
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"Grey-box fit, run {r.name}")
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_greybox_residuals(
    fit, run: str | None = None, path: str | os.PathLike | None = None, max_lag: float = 0.1
):
    """Noise-scaled residuals of one run and their autocorrelation.

    Parameters
    ----------
    fit : GreyBoxFit
    run : str, optional
        Run name (default the first run).
    path : path-like, optional
        Where to write the figure.
    max_lag : float
        Longest lag of the autocorrelation [s].
    """
    r = _greybox_run(fit, run)
    fig, (ax, ax_c) = _figure(2, 1, figsize=(7.0, 5.5))
    dt = float(np.nanmedian(np.diff(r.t)))
    for c in r.measured:
        e = (r.simulated[c] - r.measured[c]) / r.sigma[c]
        ax.plot(r.t, e, "-", lw=0.6, label=f"{c} (σ = {r.sigma[c]:.3g})")
        z = e[np.isfinite(e)]
        z = z - z.mean()
        n = max(2, min(z.size, int(round(max_lag / dt))))
        f = np.fft.rfft(z, 2 * z.size)
        ac = np.fft.irfft(f * np.conj(f))[:n]
        if ac[0] > 0:
            ax_c.plot(
                1e3 * dt * np.arange(n),
                ac / ac[0],
                "-",
                lw=0.9,
                label=f"{c}: n_eff = {r.n_eff.get(c, float('nan')):.0f}",
            )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("residual / σ")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    ax_c.axhline(0.0, color="0.5")
    ax_c.set_xlabel("lag [ms]")
    ax_c.set_ylabel("autocorrelation")
    ax_c.grid(True, alpha=0.3)
    ax_c.legend(fontsize=7)
    fig.suptitle(f"Residuals of run {r.name}")
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_greybox_profiles(fit, path: str | os.PathLike | None = None):
    """Profile likelihoods of the profiled parameters (χ² scale, 95 % threshold 3.84).

    Parameters
    ----------
    fit : GreyBoxFit
    path : path-like, optional
        Where to write the figure.
    """
    profs = list(fit.profiles_.values())
    n = max(1, len(profs))
    fig, axes = _figure(1, n, squeeze=False, figsize=(3.2 * n, 3.2))
    for ax, p in zip(axes[0], profs, strict=False):
        ax.plot(p.values, p.cost, "o-", ms=3)
        ax.axhline(3.84, color="C3", ls="--", lw=0.8)
        ax.axvline(fit.estimates_[p.name].value, color="0.5", ls=":")
        ax.set_xscale("log")
        ax.set_xlabel(p.name)
        ax.grid(True, alpha=0.3)
    axes[0, 0].set_ylabel("Δχ² (variance-corrected)")
    if not profs:
        axes[0, 0].text(
            0.5, 0.5, "no parameter was profiled", ha="center", transform=axes[0, 0].transAxes
        )
    fig.suptitle("Profile likelihoods")
    if path is not None:
        save_figure(fig, path)
    return fig
