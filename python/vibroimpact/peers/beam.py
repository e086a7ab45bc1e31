"""The hollow shaft (paper §3.2) in ``vibroimpact bench --peers``: our integrators on
:func:`vibroimpact.cases.hollow_shaft_model`, and SciPy ``solve_ivp`` on the full beam
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

from vibroimpact.peers.problems import BeamProblem
from vibroimpact.peers.reference import impact_time_error

__all__ = ["beam_rows", "scipy_beam"]


def _matrices(b: BeamProblem) -> dict[str, Any]:
    model = b.model()
    s = model.structure
    m, k, c = (np.asarray(a, dtype=float) for a in (s.mass, s.stiffness, s.damping))
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

#: The SciPy peers' tolerance on the beam (one run each: Radau takes about a minute).
BEAM_RTOL = 1e-6

_REF: dict[str, Any] = {}


def reference(b: BeamProblem) -> dict[str, Any]:
    if "ref" not in _REF:
        mats = _matrices(b)
        ref = scipy_beam(b, "DOP853", 1e-10, mats)
        check = scipy_beam(b, "DOP853", 1e-9, mats)
        ref["self_check"] = (abs(check["peak"] / ref["peak"] - 1),
                             impact_time_error(check["impacts"], ref["impacts"]))
        _REF["ref"] = ref
    return _REF["ref"]


def beam_rows(b: BeamProblem, quick: bool, repeats: int, log: Callable[[str], None]
              ) -> list[dict[str, Any]]:
    from vibroimpact.integrators import Adaptive, GeneralizedAlpha, Newmark, PreciseIntegration
    from vibroimpact.peers.table import _ours_impacts, _row, _timed, _unavailable
    from vibroimpact.simulate import simulate

    key = b.key
    if quick:
        ref = None
    else:
        log(f"{key}: reference (SciPy DOP853 rtol 1e-10, full beam)")
        ref = reference(b)
    model = b.model()
    mid = model.gaps[1].dofs[0]
    rows = []
    log(f"{key}: vibroimpact")
    methods = [
        ("Newmark", f"dt {b.dt:g} s", Newmark()),
        ("generalized-α ρ∞ 0.8", f"dt {b.dt:g} s", GeneralizedAlpha(rho_inf=0.8)),
        ("precise (Adams)", f"dt {b.dt:g} s", PreciseIntegration()),
        ("Newmark adaptive", f"rtol {BEAM_ADAPTIVE['rtol']:g}, atol {BEAM_ADAPTIVE['atol']:g} m",
         Newmark(adaptive=Adaptive(**BEAM_ADAPTIVE))),
    ]
    for name, setting, method in methods:
        try:
            secs, res = _timed(
                lambda m=method: simulate(model, t_end=b.t_end, dt=b.dt, method=m), repeats)
        except Exception as e:
            rows.append(_unavailable(key, "vibroimpact", name, setting, f"failed: {e}"))
            continue
        steps = f"{res.stats.steps} steps"
        if ref is None:
            rows.append(_row(key, "vibroimpact", name, setting, time_s=secs, repeats=repeats,
                             note=f"{steps}; accuracy not computed with --quick (the beam's "
                             "reference takes minutes)"))
            continue
        te, note = impact_time_error(_ours_impacts(res), ref["impacts"])
        rows.append(_row(key, "vibroimpact", name, setting, time_s=secs, repeats=repeats,
                         peak_error=abs(float(res.max_abs_displacement[mid]) / ref["peak"] - 1),
                         impact_time_error_s=te,
                         note="; ".join(x for x in (note, steps) if x)))
    log(f"{key}: SciPy solve_ivp (full beam)")
    mats = _matrices(b)
    for method in ("Radau", "LSODA", "DOP853"):
        if ref is None:
            rows.append(_unavailable(key, "SciPy", method, "", "skipped with --quick (runs of "
                                     "seconds each on the full beam)"))
            continue
        rtol = BEAM_RTOL
        try:
            secs, out = _timed(lambda m=method: scipy_beam(b, m, BEAM_RTOL, mats), 1)
        except Exception as e:
            rows.append(_unavailable(key, "SciPy", method, f"rtol {rtol:g}", f"failed: {e}"))
            continue
        te, note = impact_time_error(out["impacts"], ref["impacts"])
        rows.append(_row(key, "SciPy", method, f"rtol {rtol:g}", time_s=secs, repeats=1,
                         peak_error=abs(out["peak"] / ref["peak"] - 1), impact_time_error_s=te,
                         note="; ".join(x for x in (
                             note, "ONE timed run; one call, Hertz force (C1), events only to "
                             "locate crossings; analytic Jacobian for Radau/LSODA; tolerance "
                             "not matched to ours (loose)",
                             f"{out['steps']} steps") if x)))
    log(f"{key}: OpenSeesPy (ElasticTimoshenkoBeam)")
    from vibroimpact.peers import opensees_peer
    from vibroimpact.peers.table import _quiet_fds

    reason = opensees_peer.available()
    for ikey, label in (("newmark", "Newmark"), ("hht", "HHT")):
        setting = f"dt {b.dt:g} s"
        if reason:
            rows.append(_unavailable(key, "OpenSeesPy", label, setting, reason))
            continue
        try:
            with _quiet_fds():
                secs, out = _timed(lambda k=ikey: opensees_peer.run_beam(b, k), 1)
        except Exception as e:
            rows.append(_unavailable(key, "OpenSeesPy", label, setting,
                                     f"failed: {type(e).__name__}: {e}"))
            continue
        what = ("ElasticTimoshenkoBeam -cMass (the same model: same frequencies) + Hertzdamp "
                "sliders; ONE timed run")
        if ref is None:
            rows.append(_row(key, "OpenSeesPy", label, setting, time_s=secs, repeats=1,
                             note=what))
            continue
        te, note = impact_time_error(out["impacts"], ref["impacts"])
        rows.append(_row(key, "OpenSeesPy", label, setting, time_s=secs, repeats=1,
                         peak_error=abs(out["peak"] / ref["peak"] - 1), impact_time_error_s=te,
                         note="; ".join(x for x in (note, what) if x)))
    log(f"{key}: Exudyn (ObjectGenericODE2 with our matrices)")
    from vibroimpact.peers import exudyn_peer

    reason = exudyn_peer.available()
    setting = f"dt {b.dt:g} s"
    if reason:
        rows.append(_unavailable(key, "Exudyn", "Newmark", setting, reason))
    else:
        what = ("ObjectGenericODE2 with our M, K (the same model) + ObjectContactCoordinate "
                "Hertz sliders, load by Python forceUserFunction; ONE timed run")
        try:
            with _quiet_fds():
                secs, out = _timed(lambda: exudyn_peer.run_beam(b, "newmark"), 1)
        except Exception as e:
            rows.append(_unavailable(key, "Exudyn", "Newmark", setting,
                                     f"failed: {type(e).__name__}: {e}"))
        else:
            if ref is None:
                rows.append(_row(key, "Exudyn", "Newmark", setting, time_s=secs, repeats=1,
                                 note=what))
            else:
                te, note = impact_time_error(out["impacts"], ref["impacts"])
                rows.append(_row(key, "Exudyn", "Newmark", setting, time_s=secs, repeats=1,
                                 peak_error=abs(out["peak"] / ref["peak"] - 1),
                                 impact_time_error_s=te,
                                 note="; ".join(x for x in (note, what) if x)))
    rows.append(_unavailable(key, "Exudyn", "generalized-α ρ∞ 0.8", setting,
                             "not run: one Exudyn run of the beam takes about 70 s here; "
                             "its Newmark row shows the cost"))
    base = rows[0]["time_s"]
    for r in rows:
        if r["time_s"] is not None and base:
            r["ratio"] = r["time_s"] / base
        if ref is None:
            continue
        r["reference"] = (f"SciPy DOP853 rtol 1e-10 on the full beam (42 DOFs), one call, "
                          f"events at every gap crossing: middle-slider peak "
                          f"{ref['peak'] * 1e3:.6f} mm, {len(ref['impacts'])} contacts; vs "
                          f"rtol 1e-9: {ref['self_check'][0]:.1e} peak, "
                          f"{ref['self_check'][1][0]:.1e} s"
                          + (f" ({ref['self_check'][1][1]})" if ref["self_check"][1][1] else ""))
    return rows
