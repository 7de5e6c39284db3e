"""Measurement of a time-domain run: growth fit, linear window, outcome, exact prediction.

Pure numpy (no FE stack): everything that :mod:`forms.timedomain.model` and the time-domain scene
compute from the *recorded* run, i.e. from the time series of the ``exp(-i k x)`` Fourier
component ``c(t)`` of the interface slip rate and from the interface frames
(``workflows/time_domain.py`` writes them; docs/time_domain.md).

- :func:`excited_branch`: the branch to excite and its exact eigenvalue
  (:func:`analytic.follow_branch`); :func:`mode_period`: its period ``2 pi / |Im Lambda|``.
- :func:`fit_growth`: least-squares ``Re Lambda`` (through ``ln |c|``) and ``Im Lambda``
  (through the unwrapped phase) with standard errors; :func:`linear_window`: where to fit.
- :func:`nonlinear_outcome`: what the instability became (last frame, tail of the run).
- :func:`summarise_run`: fit, relative difference to the exact eigenvalue, energy balance and
  nonlinear outcome of a recorded run; :func:`figure_data`: the curves and space-time windows
  the scene's figures draw.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from analytic.numerics.branches import follow_branch, parse_branch_label
from analytic.params import ParameterError, Params


def excited_branch(params: Params, k: float, branch: str,
                   most_unstable: bool = False) -> tuple[str, complex]:
    """``(label, exact Lambda)`` of ``branch`` or of the most unstable branch (n = 0..2) at ``k``.

    Args:
        params: Linear parameters (rigid substrate, finite ``H``).
        k: Wavenumber.
        branch: Branch label (``"0-"``, ``"1+"``, ...); with ``most_unstable`` only named in
            the error message.
        most_unstable: Choose among ``n = 0..2``, both signs, the root of largest real part.

    Raises:
        ParameterError: No exact root found (one line naming ``branch``).
    """
    labels = ([f"{n}{s}" for n in range(3) for s in "-+"] if most_unstable else [branch])
    found = []
    for label in labels:
        n, sign = parse_branch_label(label)
        res = follow_branch(params, n, sign, [k])
        if res.ok[0]:
            found.append((label, complex(res.Lambda[0])))
    if not found:
        raise ParameterError(f"branch = {branch!r}: no exact root found at k = {k}")
    return max(found, key=lambda t: t[1].real)


def mode_period(exact: complex) -> float:
    """Period ``2 pi / |Im Lambda|`` of a mode (1 for a non-oscillating one)."""
    return 2.0 * math.pi / abs(exact.imag) if exact.imag != 0 else 1.0


@dataclass
class Fit:
    """Least-squares fit ``c(t) ~ A exp(Lambda t)`` of a Fourier coefficient over a window.

    ``Re Lambda`` from a straight line through ``ln |c|``, ``Im Lambda`` through the unwrapped
    phase (``c ~ exp(Lambda t)``); uncertainties are the standard errors of the slopes
    (residual variance / ``sum (t - mean t)^2``), which include any contamination by other modes.
    """

    re_lambda: float
    im_lambda: float
    re_uncertainty: float
    im_uncertainty: float
    t_start: float
    t_end: float
    points: int

    def as_dict(self) -> dict[str, float | int]:
        """Plain dict for JSON."""
        return asdict(self)


def fit_growth(t: np.ndarray, c: np.ndarray, t_start: float, t_end: float) -> Fit:
    """Fit growth rate and angular frequency of ``c(t)`` on ``t_start <= t <= t_end``.

    Raises:
        ValueError: With fewer than 3 samples in the window.
    """
    t = np.asarray(t, float)
    c = np.asarray(c, complex)
    sel = (t >= t_start) & (t <= t_end) & (np.abs(c) > 0)
    if sel.sum() < 3:
        raise ValueError(f"fit window [{t_start}, {t_end}] holds {int(sel.sum())} samples (< 3)")
    ts, cs = t[sel], c[sel]
    out = []
    for y in (np.log(np.abs(cs)), np.unwrap(np.angle(cs))):
        A = np.column_stack([np.ones_like(ts), ts])
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        resid = y - A @ coef
        dof = max(len(ts) - 2, 1)
        s2 = float(resid @ resid) / dof
        se = math.sqrt(s2 / float(np.sum((ts - ts.mean()) ** 2)))
        out.append((float(coef[1]), se))
    return Fit(out[0][0], out[1][0], out[0][1], out[1][1], float(ts[0]), float(ts[-1]),
               int(sel.sum()))


def linear_window(t: np.ndarray, c: np.ndarray, max_dv: np.ndarray, re_predicted: float,
                  start: float, limit: float, end: float | None = None) -> tuple[float, float]:
    """The linear fit window ``[start, end]``.

    Without an explicit ``end``: the last sample before ``max |v/v0 - 1|`` first exceeds
    ``limit`` (nonlinearity ``~ limit`` relative), and for a decaying prediction
    (``re_predicted <= 0``) also before ``|c|`` has dropped by ``e^2`` from its value at
    ``start`` (later, faster-growing modes excited at round-off level take over).
    """
    t = np.asarray(t, float)
    if end is not None:
        return float(start), float(end)
    stop = float(t[-1]) if len(t) else float(start)
    over = np.flatnonzero(np.asarray(max_dv) > limit)
    if len(over):
        stop = min(stop, float(t[max(over[0] - 1, 0)]))
    if re_predicted <= 0 and len(t):
        i0 = min(int(np.searchsorted(t, start)), len(t) - 1)
        low = np.flatnonzero((np.abs(c) < np.exp(-2.0) * abs(c[i0])) & (t > t[i0]))
        if len(low):
            stop = min(stop, float(t[low[0]]))
    return float(start), stop


def nonlinear_outcome(frames: dict[str, np.ndarray], series: np.ndarray, k: float,
                      tail: float = 0.25, f0: float | None = None) -> dict[str, object]:
    """What the instability became: numbers from the interface frames and the time series.

    Args:
        frames: ``t`` (nf,), ``x`` (nx,), ``v``, ``tau``, ``sigma``, ``theta`` (nf, nx) as
            written by the scene (``v/v0``, ``(tau - tau0)/sigma0``, ``(sigma - sigma0)/sigma0``).
        series: Time series with fields ``t``, ``energy``, ``max_dv``.
        k: Wavenumber of the excited mode.
        tail: Fraction of the run (at its end) over which saturation is judged.
        f0: Steady friction coefficient (for the macroscopic friction ``<tau>/<sigma>``).

    Returns:
        A dict: last-frame extremes, arrested fraction (``v/v0 < 0.01``), slipping regions
        (``v/v0 > 1``), harmonic content of ``v`` (``m k``, ``m = 1..4``, relative to ``m = 1``),
        energy over the tail (mean, relative spread), and the speed of the slip-rate maximum.
    """
    t, x = frames["t"], frames["x"]
    v = frames["v"]
    last = v[-1]
    length = float(x[-1] - x[0] + (x[1] - x[0])) if len(x) > 1 else 1.0
    coef = {m: abs(np.mean((last - last.mean()) * np.exp(1j * m * k * x))) * 2
            for m in range(1, 5)}
    slipping = last > 1.0
    regions = int(np.sum(slipping & ~np.roll(slipping, 1))) if slipping.any() else 0
    ts = series["t"]
    in_tail = ts >= ts[-1] - tail * (ts[-1] - ts[0])
    energy = series["energy"][in_tail]
    out: dict[str, object] = {
        "t_last_frame": float(t[-1]),
        "v_max": float(last.max()), "v_min": float(last.min()), "v_mean": float(last.mean()),
        "arrested_fraction": float(np.mean(last < 0.01)),
        "slipping_regions": regions,
        "sigma_min": float(frames["sigma"][-1].min()),
        "sigma_max": float(frames["sigma"][-1].max()),
        "tau_min": float(frames["tau"][-1].min()), "tau_max": float(frames["tau"][-1].max()),
        "harmonics_v": {str(m): float(coef[m] / coef[1]) if coef[1] > 0 else None
                        for m in range(1, 5)},
        "amplitude_k": float(coef[1]),
        "energy_tail_mean": float(energy.mean()),
        "energy_tail_relative_spread": float(energy.std() / energy.mean())
        if energy.mean() > 0 else None,
        "max_dv_tail_mean": float(np.mean(series["max_dv"][in_tail])),
    }
    tail_frames = t >= t[-1] - tail * (t[-1] - t[0])
    # Space-time means over the tail: the macroscopic friction of the sliding strip,
    # mean(tau)/mean(sigma) = (f0 + <dtau>/sigma0) / (1 + <dsigma>/sigma0) in units of f0.
    mean_dtau = float(frames["tau"][tail_frames].mean())
    mean_dsig = float(frames["sigma"][tail_frames].mean())
    out["tail_mean_v"] = float(v[tail_frames].mean())
    out["tail_mean_dtau_over_sigma0"] = mean_dtau
    out["tail_mean_dsigma_over_sigma0"] = mean_dsig
    out["tail_arrested_fraction"] = float(np.mean(v[tail_frames] < 0.01))
    out["tail_max_v"] = float(v[tail_frames].max())
    if "top_force" in (series.dtype.names or ()):
        out["tail_mean_top_force_over_sigma0_L"] = float(np.mean(series["top_force"][in_tail]))
    out["tail_min_sigma"] = float(frames["sigma"][tail_frames].min())
    if f0 is not None:
        out["macroscopic_friction"] = (f0 + mean_dtau) / (1.0 + mean_dsig)
    if tail_frames.sum() >= 4:
        pos = x[np.argmax(v[tail_frames], axis=1)]
        unwrapped = np.unwrap(pos * 2 * np.pi / length) * length / (2 * np.pi)
        speed = np.polyfit(t[tail_frames], unwrapped, 1)[0]
        out["peak_speed"] = float(speed)
    return out


def summarise_run(series: np.ndarray, frames: dict[str, np.ndarray], exact: complex, k: float,
                  f0: float, fit_start: float, linear_limit: float,
                  fit_end: float | None = None) -> dict[str, object]:
    """Measured eigenvalue, its relative difference to ``exact``, energy balance, outcome.

    Args:
        series: Time series (structured array) with fields ``step``, ``t``, ``re_c``,
            ``im_c``, ``energy``, ``energy_change``, ``work_friction``, ``max_dv`` (and
            optionally ``top_force``).
        frames: Interface frames (``t`` missing if none were recorded; see
            :func:`nonlinear_outcome`).
        exact: The predicted eigenvalue.
        k: Wavenumber of the excited mode.
        f0: Steady friction coefficient.
        fit_start: Start of the fit window.
        linear_limit: The linear window ends when ``max |v/v0 - 1|`` exceeds this.
        fit_end: Explicit end of the fit window (default: :func:`linear_window`'s rule).

    Returns:
        A dict with ``measured`` (``re_lambda``, ``im_lambda`` and their standard errors;
        ``None`` if the window holds fewer than 3 samples), ``relative_difference`` (``re``,
        ``im``: ``(measured - exact) / |exact|``, or ``None``), ``window`` (``t_start``,
        ``t_end``, ``points``, and a ``note`` if the fit failed), ``steps`` (steps recorded),
        ``energy_balance`` (``max_abs_residual`` of ``energy_change - work_friction`` and it
        relative to ``max |energy_change|``), ``nonlinear`` (:func:`nonlinear_outcome` or
        ``None`` without frames).
    """
    t = series["t"]
    c = series["re_c"] + 1j * series["im_c"]
    t0, t1 = linear_window(t, c, series["max_dv"], exact.real, fit_start, linear_limit, fit_end)
    measured, rel = None, None
    try:
        fit = fit_growth(t, c, t0, t1)
        measured = {"re_lambda": fit.re_lambda, "im_lambda": fit.im_lambda,
                    "re_uncertainty": fit.re_uncertainty, "im_uncertainty": fit.im_uncertainty}
        rel = {"re": (fit.re_lambda - exact.real) / abs(exact.real),
               "im": (fit.im_lambda - exact.imag) / abs(exact.imag)}
        window = {"t_start": fit.t_start, "t_end": fit.t_end, "points": fit.points}
    except ValueError as err:
        window = {"t_start": t0, "t_end": t1, "points": 0, "note": str(err)}
    balance = series["energy_change"] - series["work_friction"]
    scale = max(float(np.max(np.abs(series["energy_change"]))), 1e-300)
    return {
        "measured": measured,
        "relative_difference": rel,
        "window": window,
        "steps": int(series["step"][-1]) + 1 if len(series) else 0,
        "energy_balance": {"max_abs_residual": float(np.max(np.abs(balance))),
                           "relative": float(np.max(np.abs(balance))) / scale},
        "nonlinear": (nonlinear_outcome(frames, series, k, f0=f0)
                      if frames.get("t") is not None else None),
    }


def figure_data(series: np.ndarray, frames: dict[str, np.ndarray], exact: complex,
                window: dict[str, float], measured: dict[str, float] | None,
                late_periods: float = 6.0, points: int = 50) -> dict[str, object]:
    """What the time-domain figures draw, computed from a recorded run.

    Args:
        series: Time series as in :func:`summarise_run`.
        frames: Interface frames as in :func:`nonlinear_outcome` (``t`` missing if none).
        exact: The predicted eigenvalue.
        window: The fit window (``t_start``, ``t_end``) of :func:`summarise_run`.
        measured: The measured eigenvalue of :func:`summarise_run` (or ``None``).
        late_periods: Length of the nonlinear view (the run's last periods).
        points: Samples of the fitted and exact growth curves.

    Returns:
        A dict: ``t``, ``abs_c`` (``|c(t)|``); ``growth`` (``t``, ``fit``, ``exact``: the two
        exponentials through ``|c|`` at the window's start, over the window; ``None`` without a
        measurement); ``energy``, ``work_friction``, ``balance`` (``energy_change -
        work_friction``) and ``linthresh`` (symlog threshold: ``1e-12`` of the largest energy);
        ``linear`` (``x``, ``t``, ``scaled``: ``(v/v0 - 1) exp(-Re Lambda t)`` normalised to a
        maximum of 1, frames in ``[0, t_end of the window]``; ``None`` with fewer than 2);
        ``whole`` and ``late`` (boolean masks of the frames: all, and the last
        ``late_periods`` periods but not before the window's end; ``None`` with fewer than 2
        frames selected).
    """
    t = series["t"]
    c = np.abs(series["re_c"] + 1j * series["im_c"])
    growth = None
    if measured:
        i0 = int(np.searchsorted(t, window["t_start"]))
        tt = np.linspace(window["t_start"], window["t_end"], points)
        growth = {"t": tt, "fit": c[i0] * np.exp(measured["re_lambda"] * (tt - t[i0])),
                  "exact": c[i0] * np.exp(exact.real * (tt - t[i0]))}
    out: dict[str, object] = {
        "t": t, "abs_c": c, "growth": growth,
        "energy": series["energy"], "work_friction": series["work_friction"],
        "balance": series["energy_change"] - series["work_friction"],
        "linthresh": max(1e-30, float(np.max(np.abs(series["energy"]))) * 1e-12),
        "linear": None, "whole": None, "late": None,
    }
    if frames.get("t") is None or len(frames["t"]) < 2:
        return out
    ft = frames["t"]
    sel = (ft >= 0) & (ft <= window["t_end"])
    if sel.sum() >= 2:
        scaled = (frames["v"][sel] - 1.0) * np.exp(-exact.real * ft[sel])[:, None]
        scaled /= max(float(np.max(np.abs(scaled))), 1e-300)
        out["linear"] = {"x": frames["x"], "t": ft[sel], "scaled": scaled}
    out["whole"] = np.ones_like(ft, dtype=bool)
    late = ft >= max(window["t_end"], ft[-1] - late_periods * mode_period(exact))
    out["late"] = late if late.sum() >= 2 else None
    return out
