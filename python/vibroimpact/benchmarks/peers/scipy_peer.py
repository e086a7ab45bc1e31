"""SciPy peer: ``solve_ivp`` (Radau, LSODA, DOP853) as a SciPy user writes an impact problem
(PEERS.md): free flight and each contact phase are separate calls ended by terminal events
where a wall's gap closes or opens (``v_imp`` stored at the closing event), a non-terminal
event at ``x' = 0`` to catch the peaks, every solver step kept, ``max_step`` 1/64 of the
structural and forcing periods, ``atol = rtol/10 ×`` (penetration, speed) scales.

This is the integration of :func:`vibroimpact.benchmarks.peers.reference.sdof_piecewise`, at the
tolerance chosen by :func:`matching_tolerance`: the loosest of :data:`RTOLS` whose peak and
impact-time errors against the converged reference are both at most ours."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from vibroimpact.benchmarks.peers.problems import SdofProblem
from vibroimpact.benchmarks.peers.reference import impact_time_error, sdof_piecewise

__all__ = ["METHODS", "RTOLS", "errors", "matching_tolerance", "run_sdof"]

METHODS = ("Radau", "LSODA", "DOP853")

#: Tolerances tried, loosest first.
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)


def run_sdof(p: SdofProblem, method: str, rtol: float) -> dict[str, Any]:
    """One run, every step kept: ``t``, ``x``, ``peak``, ``impacts``, ``steps``."""
    out = sdof_piecewise(p, method, rtol, keep_steps=True)
    out["steps"] = len(out["t"]) - 1
    return out


def errors(out: dict[str, Any], ref: dict[str, Any]) -> tuple[float, float, str]:
    """(peak relative error, impact-time error in s, note) of a run against the reference."""
    te, note = impact_time_error(out["impacts"], ref["impacts"])
    return abs(out["peak"] / ref["peak"] - 1.0), te, note


def matching_tolerance(run: Callable[[float], dict[str, Any]], ref: dict[str, Any],
                       peak_target: float, time_target: float, contacts_off: int = 0,
                       rtols: tuple[float, ...] = RTOLS) -> tuple[float, bool]:
    """The loosest ``rtol`` of ``rtols`` whose run (``run(rtol)``) has peak and impact-time
    errors within the targets and a number of contacts at most ``contacts_off`` away from the
    reference's, and whether one was found (if not, the tightest tried)."""
    for rtol in rtols:
        out = run(rtol)
        pe, te, _ = errors(out, ref)
        if (pe <= peak_target and te <= time_target
                and abs(len(out["impacts"]) - len(ref["impacts"])) <= contacts_off):
            return rtol, True
    return rtols[-1], False
