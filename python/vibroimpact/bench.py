"""Benchmarks (``vibroimpact bench``): wall times measured in this process, with ratios to a
SciPy ``solve_ivp`` peer run on the same problem in the same process. Never used in tests."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from vibroimpact import cases
from vibroimpact.contact import ContactLaw
from vibroimpact.simulate import simulate

__all__ = ["median_time", "scipy_bilateral_sdof", "sdof_benchmark"]


def median_time(fn: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    """Median wall time of ``repeats`` calls (after one warm-up call) and the last result."""
    out = fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def scipy_bilateral_sdof(
    law: ContactLaw,
    mass: float,
    clearance: float,
    velocity: float,
    t_end: float,
    *,
    method: str = "DOP853",
    rtol: float = 1e-8,
) -> dict[str, Any]:
    """The SDOF case as a SciPy user writes it: ``solve_ivp`` phase by phase, free flight and
    contact, each ended by a terminal event where a wall's gap closes or opens, with the
    approach speed stored at closing, and an event where the velocity turns inside a contact
    to catch the peak. Every solver step is kept. The law's force comes from
    :meth:`ContactLaw.force`. Returns the time history and the peak |x|."""
    atol = [1e-12, 1e-9]
    t, y = 0.0, np.array([0.0, velocity])
    ts, xs = [np.array([0.0])], [np.array([0.0])]
    wall = 0  # 0: free flight; +1/-1: in contact with that wall
    v_imp = 0.0
    impacts = []
    peaks = [0.0]  # |x| where the velocity turns inside a contact

    def free(_t: float, s: np.ndarray) -> np.ndarray:
        return np.array([s[1], 0.0])

    def contact(_t: float, s: np.ndarray) -> np.ndarray:
        delta = wall * s[0] - clearance
        f = law.force(delta, wall * s[1], v_imp)[0]
        return np.array([s[1], -wall * f / mass])

    def hits_positive(_t: float, s: np.ndarray) -> float:
        return s[0] - clearance

    def hits_negative(_t: float, s: np.ndarray) -> float:
        return -s[0] - clearance

    def leaves(_t: float, s: np.ndarray) -> float:
        return wall * s[0] - clearance

    def turns(_t: float, s: np.ndarray) -> float:
        return s[1]

    for event in (hits_positive, hits_negative, leaves):
        event.terminal = True  # type: ignore[attr-defined]
    hits_positive.direction = 1  # type: ignore[attr-defined]
    hits_negative.direction = 1  # type: ignore[attr-defined]
    leaves.direction = -1  # type: ignore[attr-defined]

    while t < t_end:
        if wall == 0:
            sol = solve_ivp(free, (t, t_end), y, method=method, rtol=rtol, atol=atol,
                            events=[hits_positive, hits_negative])
        else:
            sol = solve_ivp(contact, (t, t_end), y, method=method, rtol=rtol, atol=atol,
                            events=[leaves, turns])
            peaks.extend(abs(float(ye[0])) for ye in sol.y_events[1])
        ts.append(sol.t[1:])
        xs.append(sol.y[0, 1:])
        t, y = float(sol.t[-1]), sol.y[:, -1].copy()
        if sol.status != 1:
            break
        if wall == 0:
            wall = 1 if len(sol.t_events[0]) else -1
            v_imp = abs(y[1])
            impacts.append(t)
        else:
            wall = 0
    x = np.concatenate(xs)
    return {"t": np.concatenate(ts), "x": x, "impact_times": impacts,
            "max_abs_displacement": max(float(np.abs(x).max()), max(peaks))}


def sdof_benchmark(repeats: int = 20, laws: tuple[str, ...] = ("hertz", "lankarani-nikravesh"),
                   peer_repeats: int = 5) -> list[dict[str, Any]]:
    """The paper's SDOF case, 0.02 s at dt = 1 µs (20,000 steps), through the Python API,
    against SciPy DOP853 with contact events at rtol 1e-8."""
    rows = []
    for name in laws:
        model = cases.sdof_model(name, 0.9)
        ours, result = median_time(
            lambda model=model: simulate(model, t_end=cases.SDOF_T_END, dt=cases.SDOF_DT),
            repeats,
        )
        law = model.gaps[0].law
        peer, ref = median_time(
            lambda law=law: scipy_bilateral_sdof(law, 100.0, 0.005, 8.0, cases.SDOF_T_END),
            peer_repeats,
        )
        rows.append({
            "problem": "sdof 0.02 s",
            "law": name,
            "steps": result.stats.steps,
            "median_s": ours,
            "steps_per_s": result.stats.steps / ours,
            "scipy_dop853_s": peer,
            "speedup_vs_scipy": peer / ours,
            "peak_displacement_m": float(result.max_abs_displacement[0]),
            "scipy_peak_displacement_m": ref["max_abs_displacement"],
        })
    return rows
