"""The hollow shaft (paper §3.2) in ``vibroimpact bench --peers``: our integrators on
:func:`vibroimpact.paper.cases.hollow_shaft_model`, and SciPy ``solve_ivp`` on the full beam
(42 DOFs, undamped, ω_max ≈ 1.7e5 rad/s).

The contact law of this case is Hertz (``K δ^1.5``, no ``v_imp``): the force is C¹ in the
displacement, so one ``solve_ivp`` call over the whole run, with non-terminal events only to
locate each gap's closing and opening and the middle slider's extrema, is a correct
formulation (PEERS.md's warning about single calls concerns laws that need ``v_imp``).

Reference: DOP853 at rtol 1e-10, checked against rtol 1e-9 (Radau at 1e-8 took 3 minutes:
the undamped high modes excited by the impacts keep its steps short). The
response measured: the peak |x| of the middle slider and every contact's start and end time
(all three sliders, both sides, sorted by start)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from vibroimpact.benchmarks.peers.problems import BeamProblem
from vibroimpact.benchmarks.peers.reference import impact_time_error

__all__ = ["beam_rows", "scipy_beam"]


def _matrices(b: BeamProblem) -> dict[str, Any]:
    model = b.model()
    s = model.structure
    m, k, c = s.dense_matrices()
    n = m.shape[0]
    minv = np.linalg.inv(m)
    walls = []  # (dof, side, clearance, K, exponent)
    for g in model.gaps:
        assert len(g.dofs) == 1 and g.coefficients == (1.0,)
        sides = (1, -1) if g.side == "both" else ((1,) if g.side == "positive" else (-1,))
        for sd in sides:
            walls.append((g.dofs[0], sd, float(g.clearance), g.law.contact_stiffness,
                          float(g.law.exponent)))
    fvec = np.zeros(n)
    (load,) = model.loads
    for d in load.dofs:
        fvec[d] = 1.0
    return {"M": m, "K": k, "C": c, "Minv": minv, "n": n, "walls": walls, "load": load,
            "fvec": fvec, "middle": model.gaps[1].dofs[0]}


def scipy_beam(b: BeamProblem, method: str, rtol: float, mats: dict[str, Any] | None = None,
               ) -> dict[str, Any]:
    """One ``solve_ivp`` run of the beam (every step kept): ``peak`` of the middle slider,
    ``impacts`` (all walls, sorted), ``steps``."""
    mt = mats or _matrices(b)
    n, minv, k, c, walls, fvec = mt["n"], mt["Minv"], mt["K"], mt["C"], mt["walls"], mt["fvec"]
    amp, w = mt["load"].amplitude, 2 * math.pi * mt["load"].frequency
    mk, mc = minv @ k, minv @ c
    mf = minv @ fvec
    dofs = np.array([wl[0] for wl in walls])
    sides = np.array([wl[1] for wl in walls], dtype=float)
    clear = np.array([wl[2] for wl in walls])
    kc = np.array([wl[3] for wl in walls])
    expo = np.array([wl[4] for wl in walls])

    def contact(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        delta = np.maximum(sides * x[dofs] - clear, 0.0)
        f = kc * delta**expo
        df = kc * expo * delta ** (expo - 1)
        return f, df

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        x, v = y[:n], y[n:]
        f, _ = contact(x)
        g = np.zeros(n)
        np.add.at(g, dofs, -sides * f)
        a = amp * math.sin(w * t) * mf - mk @ x - mc @ v + minv @ g
        return np.concatenate([v, a])

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        x = y[:n]
        _, df = contact(x)
        kt = np.zeros((n, n))
        np.add.at(kt, (dofs, dofs), df)  # d(-s f)/dx = -s * df * s = -df
        jj = np.zeros((2 * n, 2 * n))
        jj[:n, n:] = np.eye(n)
        jj[n:, :n] = -mk - minv @ kt
        jj[n:, n:] = -mc
        return jj

    events: list[Callable[..., float]] = []
    for i in range(len(walls)):
        def ev(t: float, y: np.ndarray, i: int = i) -> float:
            return float(sides[i] * y[dofs[i]] - clear[i])
        events.append(ev)
    mid = mt["middle"]
    events.append(lambda t, y: float(y[n + mid]))
    y0 = np.zeros(2 * n)
    kw: dict[str, Any] = {"jac": jac} if method in ("Radau", "BDF", "LSODA") else {}
    atol = np.concatenate([np.full(n, rtol * 1e-4), np.full(n, rtol * 1e-1)])
    sol = solve_ivp(rhs, (0.0, b.t_end), y0, method=method, rtol=rtol, atol=atol,
                    events=events, **kw)
    if sol.status < 0:
        raise RuntimeError(f"solve_ivp {method} failed: {sol.message}")
    impacts = []
    for i in range(len(walls)):
        te = sol.t_events[i]
        ye = sol.y_events[i]
        start = None
        for tt, yy in zip(te, ye, strict=True):
            closing = sides[i] * yy[n + dofs[i]] > 0
            if closing:
                start = float(tt)
            elif start is not None:
                impacts.append([start, float(tt)])
                start = None
        if start is not None:
            impacts.append([start, None])
    peaks = [abs(float(yy[mid])) for yy in sol.y_events[-1]]
    peaks += [float(np.abs(sol.y[mid]).max())]
    return {"peak": max(peaks), "impacts": sorted(impacts, key=lambda r: r[0]),
            "steps": len(sol.t) - 1}


#: Adaptive stepping on the beam: its error estimate follows the undamped high modes that the
#: impacts excite, so the steps stay short; at the SDOF problems' tolerances (1e-8) it takes
#: 2.7 million steps (74 s), at the default (1e-6) 570,000 (15 s).
BEAM_ADAPTIVE = {"rtol": 1e-5, "atol": 1e-9}

#: The SciPy tolerances tried on the beam, loosest first (Radau at 1e-6 takes about 50 s here,
#: at 1e-7 minutes).
BEAM_RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)

_REF: dict[float, dict[str, Any]] = {}


def reference(b: BeamProblem) -> dict[str, Any]:
    """The beam's converged reference (cached per ``t_end``): DOP853 at rtol 1e-10, with its
    difference to rtol 1e-9 as ``self_check``."""
    if b.t_end not in _REF:
        mats = _matrices(b)
        ref = scipy_beam(b, "DOP853", 1e-10, mats)
        check = scipy_beam(b, "DOP853", 1e-9, mats)
        ref["self_check"] = (abs(check["peak"] / ref["peak"] - 1),
                             impact_time_error(check["impacts"], ref["impacts"]))
        _REF[b.t_end] = ref
    return _REF[b.t_end]


def beam_rows(b: BeamProblem, quick: bool, repeats: int, ours_repeats: int,
              log: Callable[[str], None]) -> list[dict[str, Any]]:
    """The beam's rows: ours, SciPy on the full beam, OpenSeesPy and Exudyn on the same model,
    all against :func:`reference`."""
    from vibroimpact.benchmarks.peers import exudyn_peer, opensees_peer
    from vibroimpact.benchmarks.peers.table import newmark_run, ours_rows, peer_rows, scipy_rows

    key = b.key
    log(f"{key}: reference (SciPy DOP853 rtol 1e-10, full beam)")
    ref = reference(b)
    model = b.model()
    newmark = newmark_run(model, b.t_end, b.dt)
    log(f"{key}: vibroimpact")
    rows = ours_rows(key, model, b.t_end, b.dt, BEAM_ADAPTIVE, ref, ours_repeats,
                     model.gaps[1].dofs[0])
    log(f"{key}: SciPy solve_ivp (full beam)")
    mats = _matrices(b)
    rows += scipy_rows(key, lambda m, r: scipy_beam(b, m, r, mats), ref, repeats, rows[0],
                       newmark, quick, BEAM_RTOLS,
                       "one call (the Hertz force is C1), events only to locate crossings; "
                       "analytic Jacobian for Radau/LSODA")
    setting = f"dt {b.dt:g} s"
    log(f"{key}: OpenSeesPy (ElasticTimoshenkoBeam)")
    rows += peer_rows(
        key, "OpenSeesPy", opensees_peer.available(),
        [(label, setting, lambda k=k: opensees_peer.run_beam(b, k))
         for k, label in (("newmark", "Newmark"), ("hht", "HHT"))], ref, repeats,
        "ElasticTimoshenkoBeam -cMass (the same model: same frequencies) + Hertzdamp (xi 0 = "
        "Hertz, the same law) zeroLength sliders; no event location", newmark)
    log(f"{key}: Exudyn (ObjectGenericODE2 with our matrices)")
    rows += peer_rows(
        key, "Exudyn", exudyn_peer.available(),
        [(label, setting, lambda k=k: exudyn_peer.run_beam(b, k))
         for k, label in (("newmark", "Newmark"), ("generalized-alpha", "generalized-α ρ∞ 0.8"))],
        ref, repeats,
        "ObjectGenericODE2 with our M, K (the same model; Exudyn's own beam elements are a "
        "different discretisation) + ObjectContactCoordinate Hertz sliders (the same law), "
        "load by LoadCoordinate Python user functions; no event location", newmark)
    for r in rows:
        r["reference"] = (f"SciPy DOP853 rtol 1e-10 on the full beam (42 DOFs), one call, "
                          f"events at every gap crossing: middle-slider peak "
                          f"{ref['peak'] * 1e3:.6f} mm, {len(ref['impacts'])} contacts; vs "
                          f"rtol 1e-9: {ref['self_check'][0]:.1e} peak, "
                          f"{ref['self_check'][1][0]:.1e} s"
                          + (f" ({ref['self_check'][1][1]})" if ref["self_check"][1][1] else ""))
    return rows
