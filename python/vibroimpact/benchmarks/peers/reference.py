"""The converged reference of ``vibroimpact bench --peers``: one per problem, the same for every
tool. Independent of the engine: numpy and SciPy only, the contact law from its formula
(:meth:`SdofProblem.contact_force`), the same method as ``tests/reference.py`` (whose logic
this follows; the tests are not a dependency of the package):

* ``solve_ivp`` DOP853 at rtol 1e-12, piecewise: free flight and each contact phase are
  separate calls, ended by terminal events where a wall's gap closes or opens, so the
  high-order method only ever integrates smooth pieces; ``v_imp`` is the speed at the located
  closing instant;
* the peak ``|x|`` is taken at located ``x' = 0`` events (and the ends of the run);
* ``max_step`` = 1/64 of the structure's period and of the forcing period.

The force clamp at zero (a damped law pulling near separation) is not an event here: for
Lankarani–Nikravesh with ce = 0.9 the bracket ``1 + χ δ̇/v_imp`` stays positive unless the
rebound is 7× faster than the approach; :func:`converged` checks it did not turn.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from vibroimpact.benchmarks.peers.problems import SdofProblem

__all__ = ["contact_pairs", "converged", "impact_time_error", "sdof_piecewise"]


def _event(fun: Any, direction: float, terminal: bool) -> Any:
    fun.direction = direction
    fun.terminal = terminal
    return fun


def sdof_piecewise(
    p: SdofProblem,
    method: str = "DOP853",
    rtol: float = 1e-12,
    atol: Any = None,
    *,
    keep_steps: bool = True,
    max_step: float | None = None,
) -> dict[str, Any]:
    """Integrate ``p`` phase by phase with ``solve_ivp(method)``. Returns ``peak`` (max |x|,
    located at ``x' = 0`` events), ``impacts`` (list of ``[t_start, t_end]``, ``t_end`` None
    if still closed), ``contact_peaks`` (max |x| of each contact, located likewise),
    ``t``/``x`` (every solver step if ``keep_steps``), ``bracket_min``."""
    m, k, c, d = p.mass, p.stiffness, p.damping, p.clearance
    if atol is None:
        atol = [rtol * 0.1 * p.length_scale, rtol * 0.1 * p.speed_scale]
    if max_step is None:
        periods = []
        if k > 0:
            periods.append(2 * math.pi * math.sqrt(m / k))
        if p.force_frequency > 0:
            periods.append(1.0 / p.force_frequency)
        max_step = min(periods) / 64 if periods else math.inf
    amp, w = p.force_amplitude, 2 * math.pi * p.force_frequency

    def rhs_free(t: float, y: np.ndarray) -> np.ndarray:
        return np.array([y[1], (amp * math.sin(w * t) - c * y[1] - k * y[0]) / m])

    def make_rhs_contact(s: int, v_imp: float) -> Any:
        chi, kc, n = p.chi, p.contact_stiffness, p.exponent

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            delta = s * y[0] - d
            f = kc * delta**n * (1.0 + chi * s * y[1] / v_imp) if delta > 0.0 else 0.0
            f = max(f, 0.0)
            return np.array([y[1], (amp * math.sin(w * t) - c * y[1] - k * y[0] - s * f) / m])

        return rhs

    ev_turn = _event(lambda t, y: y[1], 0.0, False)
    closes = {s: _event(lambda t, y, s=s: s * y[0] - d, 1.0, True) for s in p.sides}
    t, y = 0.0, np.array([p.x0, p.v0], dtype=float)
    side, v_imp = 0, 0.0
    impacts: list[list[Any]] = []
    contact_peaks: list[float] = []
    peaks = [abs(p.x0)]
    ts, xs = [np.array([0.0])], [np.array([p.x0])]
    bracket_min = math.inf
    while t < p.t_end:
        if side == 0:
            rhs = rhs_free
            events = [closes[s] for s in p.sides] + [ev_turn]
        else:
            rhs = make_rhs_contact(side, v_imp)
            events = [_event(lambda t, y, s=side: s * y[0] - d, -1.0, True), ev_turn]
        sol = solve_ivp(rhs, (t, p.t_end), y, method=method, rtol=rtol, atol=atol,
                        events=events, max_step=max_step)
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp {method} failed at t = {t}: {sol.message}")
        turns = [abs(float(ye[0])) for ye in sol.y_events[-1]]
        peaks.extend(turns)
        if side:
            contact_peaks[-1] = max(contact_peaks[-1], *turns, abs(float(sol.y[0, -1])))
        if keep_steps:
            ts.append(sol.t[1:])
            xs.append(sol.y[0, 1:])
        if side and p.chi:
            bracket_min = min(bracket_min, float(np.min(1 + p.chi * side * sol.y[1] / v_imp)))
        t, y = float(sol.t[-1]), sol.y[:, -1].copy()
        peaks.append(abs(float(y[0])))
        if sol.status != 1:
            break
        if side == 0:
            fired = [s for i, s in enumerate(p.sides) if len(sol.t_events[i])]
            side = fired[0]
            y[0] = side * d
            v_imp = side * y[1]
            impacts.append([t, None])
            contact_peaks.append(d)
        else:
            y[0] = side * d
            impacts[-1][1] = t
            side = 0
    return {
        "peak": max(peaks),
        "impacts": impacts,
        "contact_peaks": contact_peaks,
        "t": np.concatenate(ts) if keep_steps else None,
        "x": np.concatenate(xs) if keep_steps else None,
        "bracket_min": bracket_min,
    }


_CACHE: dict[str, dict[str, Any]] = {}


def converged(p: SdofProblem) -> dict[str, Any]:
    """The reference for ``p`` (cached): DOP853 at rtol 1e-12, checked against rtol 1e-11
    (the difference is returned as ``self_check``: peak relative, impact times in s)."""
    key = f"{p.key}@{p.t_end}"
    if key not in _CACHE:
        ref = sdof_piecewise(p, rtol=1e-12, keep_steps=False)
        if ref["bracket_min"] <= 0.0:  # pragma: no cover - not for the problems here
            raise RuntimeError(f"{p.key}: the contact force clamped; the reference needs events")
        check = sdof_piecewise(p, rtol=1e-11, keep_steps=False)
        ref["self_check"] = (abs(check["peak"] / ref["peak"] - 1),
                             impact_time_error(check["impacts"], ref["impacts"])[0])
        _CACHE[key] = ref
    return _CACHE[key]


def contact_pairs(impacts: Any, ref: Any) -> list[tuple[int, int]]:
    """``(i, j)`` pairs matching each contact ``j`` of ``ref`` with a contact ``i`` of
    ``impacts`` (lists of ``[t_start, t_end]``): in order when the numbers agree, else the one
    that starts nearest to it; none if either is empty."""
    if not len(impacts) or not len(ref):
        return []
    if len(impacts) == len(ref):
        return [(j, j) for j in range(len(ref))]
    starts = np.array([float(r[0]) for r in impacts])
    return [(int(np.argmin(np.abs(starts - float(r[0])))), j) for j, r in enumerate(ref)]


def impact_time_error(impacts: Any, ref: Any) -> tuple[float, str]:
    """Largest |difference| of the contacts' start and end times (s), over the pairs of
    :func:`contact_pairs`. A different number of contacts is stated in the note; the extra
    (grazing) contacts are then left out of the error."""
    a = [list(r) for r in impacts]
    b = [list(r) for r in ref]
    if not a or not b:
        return math.nan, f"{len(a)} contacts vs {len(b)} in the reference"
    err = 0.0
    for i, j in contact_pairs(a, b):
        for k in (0, 1):
            if a[i][k] is not None and b[j][k] is not None:
                err = max(err, abs(float(a[i][k]) - float(b[j][k])))
    note = "" if len(a) == len(b) else f"{len(a)} contacts vs {len(b)} in the reference"
    return err, note
