"""Figures of the identification: valve Bode plot (Fig. 5), dead zone (Fig. 6), Stribeck
friction (Fig. 8), the inverse-dynamics force fit and the grey-box fit.

Each function takes plain arrays or the fitted objects of :mod:`hydropwa.identification`
(the attributes read are declared as protocols in ``_shapes``; nothing is imported from there) and an optional ``ax``; it returns the
figure. Nothing here computes physics: fitted curves come from the objects' own methods.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes

from ._base import new_figure
from ._shapes import (
    Columns,
    EstimateShape,
    FittedCurve,
    FittedFrf,
    FittedPoints,
    ForceFit,
    ForceModel,
    FrequencyResponseShape,
    FrictionPoints,
    HoldsForceFit,
    TracedFit,
    TracedRun,
    VelocityModel,
    require,
)

__all__ = [
    "plot_bode",
    "plot_dead_zone",
    "plot_stribeck",
    "plot_inverse_dynamics",
    "plot_greybox_fit",
    "plot_greybox_residuals",
    "plot_greybox_profiles",
    "plot_estimates",
]

_AxesArg = Axes | Sequence[Axes] | None


def plot_bode(
    frf: Mapping[float, FrequencyResponseShape] | FittedFrf,
    fits: Mapping[float, Any] | None = None,
    *,
    min_coherence: float | None = None,
    ax: _AxesArg = None,
) -> Any:
    """Measured valve FRFs per command amplitude and the fitted model (1), Fig. 5.

    Parameters
    ----------
    frf : dict[float, FrequencyResponse] or ValveFrfIdentifier
        Command amplitude [1] → an object with ``frequency`` [Hz], complex ``response`` and
        optionally ``coherence`` [1] (H1 estimates: a coherence panel is added). A fitted
        estimator gives its ``frf_``, ``fits_`` and ``min_coherence``.
    fits : dict[float, SecondOrderFit], optional
        Amplitude → anything with ``response(omega)`` (ω in rad/s), drawn as lines.
    min_coherence : float, optional
        Coherence threshold drawn in the coherence panel [1] (default 0.8).
    ax : sequence of Axes, optional
        Two axes (magnitude, phase), or three with coherence, to draw into.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if isinstance(frf, FittedFrf):
        fits = getattr(frf, "fits_", None) if fits is None else fits
        if min_coherence is None:
            min_coherence = getattr(frf, "min_coherence", None)
        frf = frf.frf_
    min_coherence = 0.8 if min_coherence is None else float(min_coherence)
    broadband = any(getattr(r, "coherence", None) is not None for r in frf.values())
    if broadband:  # H1 estimates: a coherence panel shows which bins the fit could trust
        fig, axes = new_figure(
            3, 1, ax=ax, sharex=True, figsize=(7.0, 6.5), height_ratios=[3, 3, 1.5]
        )
    else:
        fig, axes = new_figure(2, 1, ax=ax, sharex=True)
    am, ph = axes[0, 0], axes[1, 0]
    for i, (amp, r) in enumerate(sorted(frf.items())):
        c = f"C{i % 10}"
        f = np.asarray(r.frequency, dtype=float)
        h = np.asarray(r.response)
        coh = getattr(r, "coherence", None)
        style: dict[str, Any] = (
            {"ls": "-", "lw": 0.8, "alpha": 0.7}
            if coh is not None
            else {"ls": "", "marker": "o", "ms": 3}
        )
        am.semilogx(
            f,
            20 * np.log10(np.abs(h)),
            color=c,
            label=f"measured, |u| = {100 * amp:.3g} %",
            **style,
        )
        ph.semilogx(f, np.degrees(np.unwrap(np.angle(h))), color=c, **style)
        if coh is not None:
            axes[2, 0].semilogx(f, coh, color=c, lw=0.8)
        fit = (fits or {}).get(amp)
        if fit is not None:
            ff = np.geomspace(f.min(), f.max(), 300)
            g = fit.response(2 * np.pi * ff)
            label = "fitted model (1)"
            if hasattr(fit, "omega0") and hasattr(fit, "zeta"):
                label = f"fit ω0 = {fit.omega0.value:.0f} rad/s, ζ = {fit.zeta.value:.2f}"
            am.semilogx(ff, 20 * np.log10(np.abs(g)), "-", color=c, lw=1.0, label=label)
            ph.semilogx(ff, np.degrees(np.unwrap(np.angle(g))), "-", color=c, lw=1.0)
    am.set_ylabel("magnitude [dB]")
    ph.set_ylabel("phase [°]")
    last = ph
    if broadband:
        last = axes[2, 0]
        last.set_ylabel("coherence γ²")
        last.set_ylim(0.0, 1.05)
        last.axhline(min_coherence, color="k", lw=0.6, ls="--")
    last.set_xlabel("frequency [Hz]")
    for a in axes[:, 0]:
        a.grid(True, which="both", alpha=0.3)
    am.legend(fontsize=7)
    am.set_title("Servo valve FRFs and the second-order fit (Eq. (1), Fig. 5)", fontsize=10)
    return fig


def _column(points: Any, name: str) -> np.ndarray | None:
    try:
        col = points[name]
    except (KeyError, IndexError, TypeError):
        return None
    return np.asarray(col, dtype=float)


def plot_dead_zone(
    points: Columns | FittedPoints,
    fit: VelocityModel | Callable[[np.ndarray], Any] | None = None,
    *,
    ax: Axes | None = None,
) -> Any:
    """Steady rod velocity over constant commands and the fitted dead zone, Fig. 6.

    Parameters
    ----------
    points : mapping or DataFrame or DeadZoneIdentifier
        Columns ``u`` (command [1]), ``v`` (velocity [m/s]) and optionally ``v_std``
        (its standard deviation [m/s], drawn as error bars) and ``v_valve`` (the velocity
        with the fitted piston leakage removed [m/s], open squares: the points the hinge
        curve fits). A fitted estimator gives its ``points_`` and ``fit_``.
    fit : DeadZoneFit or callable, optional
        The fitted curve: ``fit.velocity(u)`` or ``fit(u)`` [m/s]; a fit with ``beta``,
        ``beta_pos``, ``beta_neg`` and ``creep_slope`` has them in the legend and its
        dead-zone edges drawn.
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    if isinstance(points, FittedPoints):
        fit = getattr(points, "fit_", None) if fit is None else fit
        points = points.points_
    u, v, v_std = _column(points, "u"), _column(points, "v"), _column(points, "v_std")
    if u is None or v is None:
        raise ValueError("plot_dead_zone: points need columns 'u' [1] and 'v' [m/s]")
    fig, axes = new_figure(ax=ax, figsize=(6.5, 4.0))
    a = axes[0, 0]
    a.errorbar(
        100 * u,
        1e3 * v,
        yerr=None if v_std is None else 1e3 * v_std,
        fmt="o",
        ms=3,
        label="measured (slope of x)",
    )
    v_valve = _column(points, "v_valve")
    if v_valve is not None:  # the fitted leakage flow removed: the points the hinge describes
        a.plot(
            100 * u,
            1e3 * v_valve,
            "s",
            ms=4,
            mfc="none",
            label="valve alone (fitted leakage removed)",
        )
    model: Any = fit  # a fit (its hinge parameters read where it has them) or a callable
    if model is not None:
        curve: Callable[[np.ndarray], Any] = getattr(model, "velocity", model)
        uu = np.linspace(u.min(), u.max(), 800)
        label = "PWA dead-zone fit (16)"
        if all(hasattr(model, k) for k in ("beta", "beta_pos", "beta_neg", "creep_slope")):
            b = model.beta
            label = (
                f"hinge fit, β = {100 * b.value:.2f} % [{100 * b.ci[0]:.2f}, {100 * b.ci[1]:.2f}],"
                f" k_g = {model.creep_slope.value:.3f}"
            )
            for edge in (model.beta_pos.value, -model.beta_neg.value):
                a.axvline(100 * edge, color="0.6", ls=":")
        a.plot(100 * uu, 1e3 * np.asarray(curve(uu)), "r-", lw=1.2, label=label)
    a.set_xlabel("valve command u [%]")
    a.set_ylabel("rod velocity [mm/s]")
    a.set_title("Dead zone from constant commands (Sec. VI-B, Fig. 6)", fontsize=10)
    a.grid(True, alpha=0.3)
    a.legend(fontsize=8)
    return fig


def plot_stribeck(
    points: Columns | FrictionPoints | FittedCurve,
    fit: ForceModel | Callable[[np.ndarray], Any] | None = None,
    *,
    cells: Callable[[np.ndarray], Any] | None = None,
    reference: Callable[[np.ndarray], Any] | None = None,
    ax: _AxesArg = None,
) -> Any:
    """Friction points, the fitted Stribeck curve (11), its PWA cells (22) and the residuals, Fig. 8.

    Parameters
    ----------
    points : mapping or DataFrame or StribeckFit or StribeckIdentifier
        Columns ``v`` (steady velocity [m/s]) and ``f`` (friction force [N]). A fit
        (``velocity``, ``force``, ``force_at``) is its own points and curve; a fitted
        estimator gives its ``fit_``.
    fit : StribeckFit or callable, optional
        The fitted curve, ``fit.force_at(v)`` or ``fit(v)`` [N]; a fit's ``friction``
        parameters are named in the legend and its ``weak`` parameters in the title.
    cells : PiecewiseAffine or callable, optional
        PWA friction cells, v [m/s] → N.
    reference : callable, optional
        A reference curve v [m/s] → N (the true friction of the virtual rig), drawn thin.
    ax : Axes or sequence of two Axes, optional
        One axes draws the curves only; two (curves, residuals), or none, add the residual
        panel when there is a fit.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if isinstance(points, FittedCurve):
        points = points.fit_
    weak: tuple[str, ...] = ()
    model: Any = fit  # a fit (its friction parameters in the legend) or a callable
    if isinstance(points, FrictionPoints):
        model = points if fit is None else fit
        weak = tuple(getattr(points, "weak", ()))
        v, f = np.asarray(points.velocity, dtype=float), np.asarray(points.force, dtype=float)
    else:
        v_col, f_col = _column(points, "v"), _column(points, "f")
        if v_col is None or f_col is None:
            raise ValueError("plot_stribeck: points need columns 'v' [m/s] and 'f' [N]")
        v, f = v_col, f_col
    curve: Callable[[np.ndarray], Any] | None = None
    if model is not None:
        curve = getattr(model, "force_at", model)
    n_ax = 1 if ax is not None and isinstance(ax, Axes) else 2 if curve is not None else 1
    fig, axes = new_figure(
        n_ax,
        1,
        ax=ax,
        sharex=True,
        figsize=(6.5, 5.0 if n_ax == 2 else 4.0),
        **({"height_ratios": [3, 1]} if n_ax == 2 and ax is None else {}),
    )
    a = axes[0, 0]
    a.plot(1e3 * v, f, "o", ms=3.5, label="steady-state points, Eq. (10)")
    vmax = 1.1 * max(float(np.max(np.abs(v))), 1e-3) if v.size else 0.2
    vv = np.linspace(-vmax, vmax, 1200)
    if curve is not None:
        label = "fitted Stribeck model (11)"
        fc = getattr(model, "friction", None)
        if fc is not None:
            label = (
                f"Eq. (11): F_c = {fc.coulomb:.1f} N, F_s = {fc.static:.1f} N,"
                f" σ = {fc.viscous:.0f} N·s/m"
            )
        a.plot(1e3 * vv, curve(vv), "k-", lw=1.3, label=label)
    if cells is not None:
        n_cells = getattr(cells, "n_cells", None)
        a.plot(1e3 * vv, cells(vv), "r--", lw=1.1, label=f"PWA, {n_cells} cells (22)")
    if reference is not None:
        a.plot(1e3 * vv, reference(vv), color="gray", lw=0.8, label="true (virtual rig)")
    a.set_ylabel("friction force [N]")
    a.grid(True, alpha=0.3)
    a.legend(fontsize=8)
    title = "Stribeck friction (Sec. VI-C, Fig. 8)"
    if weak:
        title += f"\nweakly identified: {', '.join(weak)}"
    a.set_title(title, fontsize=10)
    if n_ax == 2 and curve is not None:
        r = axes[1, 0]
        r.plot(1e3 * v, f - np.asarray(curve(v), dtype=float), "o", ms=3)
        r.axhline(0.0, color="0.5")
        r.set_ylabel("residual [N]")
        r.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("rod velocity [mm/s]")
    return fig


def plot_inverse_dynamics(result: ForceFit | HoldsForceFit, *, ax: Axes | None = None) -> Any:
    """Measured and predicted force of an inverse-dynamics (IDIM-LS) fit.

    Parameters
    ----------
    result : InverseDynamicsResult or EmpsResult
        Anything with ``time`` [s], ``force`` and ``predicted`` [N] and ``relative_error``
        [1], or holding such an object as ``fit``.
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fit: Any = result if isinstance(result, ForceFit) else getattr(result, "fit", result)
    require(fit, ForceFit, "plot_inverse_dynamics")
    fig, axes = new_figure(ax=ax)
    a = axes[0, 0]
    a.plot(fit.time, fit.force, "-", lw=1.2, label="measured (decimated)")
    a.plot(fit.time, fit.predicted, "--", lw=1.0, label="IDIM-LS model")
    a.plot(fit.time, fit.force - fit.predicted, "-", lw=0.6, color="0.3", label="error")
    a.set_xlabel("time [s]")
    a.set_ylabel("force [N]")
    a.grid(True, alpha=0.3)
    a.legend(fontsize=8)
    a.set_title(f"Inverse dynamics: relative error {100 * fit.relative_error:.2f} %")
    return fig


_GB_SCALE = {
    "x": (1e3, "x [mm]"),
    "v": (1e3, "v [mm/s]"),
    "p_a": (1e-5, "p_A [bar]"),
    "p_b": (1e-5, "p_B [bar]"),
    "p_l": (1e-5, "p_L [bar]"),
}


def _greybox_run(fit: TracedFit, run: str | None, who: str) -> TracedRun:
    require(fit, TracedFit, who)
    if run is None:
        return fit.runs_[0]
    for r in fit.runs_:
        if r.name == run:
            return r
    raise KeyError(f"no run {run!r} in the fit; runs: {', '.join(r.name for r in fit.runs_)}")


def plot_greybox_fit(fit: TracedFit, run: str | None = None, *, ax: _AxesArg = None) -> Any:
    """Measured and fitted channels of one run of a grey-box fit.

    Parameters
    ----------
    fit : GreyBoxFit
        ``runs_``: objects with ``name``, ``t`` [s], ``measured``, ``simulated`` (channel →
        SI array) and ``method``.
    run : str, optional
        Run name (default the first run).
    ax : sequence of Axes, optional
        One per measured channel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    r = _greybox_run(fit, run, "plot_greybox_fit")
    chans = list(r.measured)
    fig, axes = new_figure(len(chans), 1, ax=ax, sharex=True, figsize=(7.0, 1.8 + 1.6 * len(chans)))
    for a, c in zip(axes[:, 0], chans, strict=True):
        k, label = _GB_SCALE.get(c, (1.0, c))
        a.plot(r.t, k * r.measured[c], "-", lw=0.8, color="0.4", label="measured")
        a.plot(
            r.t, k * r.simulated[c], "-", lw=0.9, color="C3", label=f"fitted ({r.method} shooting)"
        )
        a.set_ylabel(label)
        a.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title(f"Grey-box fit, run {r.name}")
    return fig


def plot_greybox_residuals(
    fit: TracedFit, run: str | None = None, *, max_lag: float = 0.1, ax: _AxesArg = None
) -> Any:
    """Noise-scaled residuals of one run of a grey-box fit and their autocorrelation.

    Parameters
    ----------
    fit : GreyBoxFit
        As in :func:`plot_greybox_fit`, with ``sigma`` and ``n_eff`` per channel.
    run : str, optional
        Run name (default the first run).
    max_lag : float
        Longest lag of the autocorrelation [s].
    ax : sequence of two Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    r = _greybox_run(fit, run, "plot_greybox_residuals")
    fig, axes = new_figure(2, 1, ax=ax, figsize=(7.0, 5.5))
    a, a_c = axes[0, 0], axes[1, 0]
    dt = float(np.nanmedian(np.diff(r.t)))
    for c in r.measured:
        e = (r.simulated[c] - r.measured[c]) / r.sigma[c]
        a.plot(r.t, e, "-", lw=0.6, label=f"{c} (σ = {r.sigma[c]:.3g})")
        z = e[np.isfinite(e)]
        z = z - z.mean()
        n = max(2, min(z.size, int(round(max_lag / dt))))
        spec = np.fft.rfft(z, 2 * z.size)
        ac = np.fft.irfft(spec * np.conj(spec))[:n]
        if ac[0] > 0:
            a_c.plot(
                1e3 * dt * np.arange(n),
                ac / ac[0],
                "-",
                lw=0.9,
                label=f"{c}: n_eff = {r.n_eff.get(c, float('nan')):.0f}",
            )
    a.set_xlabel("time [s]")
    a.set_ylabel("residual / σ")
    a.grid(True, alpha=0.3)
    a.legend(fontsize=7)
    a.set_title(f"Residuals of run {r.name}")
    a_c.axhline(0.0, color="0.5")
    a_c.set_xlabel("lag [ms]")
    a_c.set_ylabel("autocorrelation")
    a_c.grid(True, alpha=0.3)
    a_c.legend(fontsize=7)
    return fig


def plot_greybox_profiles(fit: TracedFit, *, ax: _AxesArg = None) -> Any:
    """Profile likelihoods of the profiled parameters (χ² scale, 95 % threshold 3.84).

    Parameters
    ----------
    fit : GreyBoxFit
        ``profiles_`` (name → object with ``name``, ``values``, ``cost``) and ``estimates_``.
    ax : sequence of Axes, optional
        One per profile (at least one).

    Returns
    -------
    matplotlib.figure.Figure
    """
    require(fit, TracedFit, "plot_greybox_profiles")
    profs = list(fit.profiles_.values())
    n = max(1, len(profs))
    fig, axes = new_figure(1, n, ax=ax, figsize=(3.2 * n, 3.2))
    for a, p in zip(axes[0], profs, strict=False):
        a.plot(p.values, p.cost, "o-", ms=3)
        a.axhline(3.84, color="C3", ls="--", lw=0.8)
        a.axvline(fit.estimates_[p.name].value, color="0.5", ls=":")
        a.set_xscale("log")
        a.set_xlabel(p.name)
        a.grid(True, alpha=0.3)
    axes[0, 0].set_ylabel("Δχ² (variance-corrected)")
    if not profs:
        axes[0, 0].text(
            0.5, 0.5, "no parameter was profiled", ha="center", transform=axes[0, 0].transAxes
        )
    axes[0, 0].set_title("Profile likelihoods")
    return fig


def plot_estimates(
    estimates: Mapping[str, EstimateShape], title: str = "", *, ax: Axes | None = None
) -> Any:
    """Each parameter estimate with its confidence interval, relative to its value.

    Parameters
    ----------
    estimates : dict[str, ParameterEstimate]
        Name → ``value``, ``ci`` (low, high) [SI] and ``unit``.
    title : str
        Axes title (for instance the fit's class).
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
        One row per estimate: the interval as a bar around 100 % of the value, labelled with
        the value and its SI unit.
    """
    names = list(estimates)
    for n in names:
        require(estimates[n], EstimateShape, "plot_estimates")
    fig, axes = new_figure(ax=ax, figsize=(6.0, 0.8 + 0.35 * max(1, len(names))))
    a = axes[0, 0]
    for i, n in enumerate(names):
        e = estimates[n]
        scale = abs(e.value) if e.value else 1.0
        lo, hi = 100 * e.ci[0] / scale, 100 * e.ci[1] / scale
        ref = 100.0 if e.value >= 0 else -100.0
        a.plot([lo, hi], [i, i], "-", lw=3, color="C0", alpha=0.6)
        a.plot([ref], [i], "o", color="C3")
    a.set_yticks(range(len(names)))
    a.set_yticklabels([f"{n} = {estimates[n].value:.4g} {estimates[n].unit}" for n in names])
    a.set_xlabel("confidence interval [% of the estimate]")
    a.set_title(title or "Parameter estimates", fontsize=10)
    a.grid(True, axis="x", alpha=0.3)
    return fig
