"""``vibroimpact bench --peers``: every problem of :mod:`vibroimpact.benchmarks.peers.problems`
through our integrators, SciPy ``solve_ivp`` with contact events, OpenSeesPy and Exudyn, in
this process, in one table: tool, method, step or tolerance, wall time (median), ratio to our
Newmark, and the errors against one converged reference per problem
(:mod:`vibroimpact.benchmarks.peers.reference`).

A peer that is not installed (or fails) gives a row ``not available: reason``; a problem a peer
cannot express gives a row ``cannot express: reason``; nothing here fails because a peer is
missing."""

from __future__ import annotations

import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from datetime import datetime, timezone
from typing import Any

import numpy as np

from vibroimpact.benchmarks.peers import equal_accuracy as eqacc
from vibroimpact.benchmarks.peers import exudyn_peer, opensees_peer, scipy_peer
from vibroimpact.benchmarks.peers.equal_accuracy import ours_contacts
from vibroimpact.benchmarks.peers.problems import (
    BeamProblem,
    SdofProblem,
    forced_sdof,
    hollow_shaft,
    paper_sdof,
)
from vibroimpact.benchmarks.peers.reference import converged

__all__ = ["TARGETS", "format_markdown", "format_readme", "format_text", "machine", "run",
           "targets"]

#: Issue 9's targets: the peer must be at least this many times slower than our Newmark.
TARGETS = {("SciPy", "Radau"): 100.0, ("SciPy", "LSODA"): 100.0, ("SciPy", "DOP853"): 30.0,
           ("OpenSeesPy", "Newmark"): 50.0, ("OpenSeesPy", "HHT"): 50.0}

#: Adaptive stepping of our Newmark: tolerances that reach about fixed-step Newmark's accuracy
#: on both SDOF problems.
ADAPTIVE = {"rtol": 1e-8, "atol": 1e-12}

#: A first (warm-up) run at least this long (s) counts as one of the timed runs: one-off costs
#: (imports, caches) are negligible beside it, and the median of the runs absorbs them.
LONG_RUN_S = 1.0


def _once(fn: Callable[[], Any]) -> tuple[float, Any]:
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def _warm_once(fn: Callable[[], Any]) -> float:
    """The wall time of ``fn``'s second call of two in a row."""
    fn()
    return _once(fn)[0]


def _timed(fn: Callable[[], Any], repeats: int, base: Callable[[], Any] | None = None
           ) -> tuple[float, Any, float | None]:
    """Median wall time of ``repeats`` calls, the last result, and, with ``base`` (ours),
    the median of one ``base`` call timed beside each counted call: the two medians are then
    measured under the same machine load. A first warm-up call is not counted unless it took
    :data:`LONG_RUN_S` or more; ``repeats <= 1``: one call. Each timed ``base`` call follows
    an untimed one, so that ours is timed warm as ``fn``'s counted calls are: right after a
    peer's long run, caches and branch predictors are cold, which made a 0.2 ms run of ours
    take 1.5× its warm time (paper case, our DOP853 after SciPy's 80 ms)."""
    first, out = _once(fn)
    runs = [first] if first >= LONG_RUN_S or repeats <= 1 else []
    base_runs = [_warm_once(base)] if base is not None and runs else []
    while len(runs) < repeats:
        if base is not None:
            base_runs.append(_warm_once(base))
        t, out = _once(fn)
        runs.append(t)
    return statistics.median(runs), out, statistics.median(base_runs) if base_runs else None


def _row(problem: str, tool: str, method: str, setting: str, **kw: Any) -> dict[str, Any]:
    row = {"problem": problem, "tool": tool, "method": method, "setting": setting,
           "time_s": None, "repeats": 0, "ratio": None, "peak_error": None,
           "impact_time_error_s": None, "contacts": None, "note": ""}
    row.update(kw)
    return row


def _unavailable(problem: str, tool: str, method: str, setting: str, reason: str
                 ) -> dict[str, Any]:
    return _row(problem, tool, method, setting, note=f"not available: {reason}")


def _measured(problem: str, tool: str, method: str, setting: str,
              timing: tuple[float, Any, float | None], repeats: int, ref: dict[str, Any],
              *notes: str, **kw: Any) -> dict[str, Any]:
    """A timed row from ``_timed``'s ``(seconds, out, our Newmark's seconds beside it)``:
    ``out`` (``peak``, ``impacts``) against the reference ``ref``; the ratio is to our Newmark
    timed beside it (set by :func:`run` for our Newmark itself)."""
    secs, out, base_s = timing
    pe, te, cnote = scipy_peer.errors(out, ref)
    return _row(problem, tool, method, setting, time_s=secs, repeats=repeats, peak_error=pe,
                impact_time_error_s=te, contacts=len(out["impacts"]),
                ratio=None if base_s is None else secs / base_s, newmark_beside_s=base_s,
                note="; ".join(x for x in (cnote, *notes) if x), **kw)


def newmark_run(model: Any, t_end: float, dt: float) -> Callable[[], Any]:
    """Our fixed-step Newmark on ``model``: the base of every ratio."""
    from vibroimpact.integrators import Newmark
    from vibroimpact.simulate import simulate

    return lambda: simulate(model, t_end=t_end, dt=dt, method=Newmark())


def ours_rows(key: str, model: Any, t_end: float, dt: float, adaptive: dict[str, float],
              ref: dict[str, Any], repeats: int, peak_dof: int) -> list[dict[str, Any]]:
    """Our Newmark (first: the base of every ratio), generalized-α, precise integration and
    adaptive Newmark on ``model``; the peak is ``|x|`` of ``peak_dof``."""
    from vibroimpact.integrators import Adaptive, GeneralizedAlpha, Newmark, PreciseIntegration
    from vibroimpact.simulate import simulate

    base = newmark_run(model, t_end, dt)
    methods = [
        ("generalized-α ρ∞ 0.8", f"dt {dt:g} s", GeneralizedAlpha(rho_inf=0.8)),
        ("precise (Adams)", f"dt {dt:g} s", PreciseIntegration()),
        ("Newmark adaptive", f"rtol {adaptive['rtol']:g}, atol {adaptive['atol']:g} m",
         Newmark(adaptive=Adaptive(**adaptive))),
    ]
    rows = []
    for name, setting, fn, beside in [("Newmark", f"dt {dt:g} s", base, None)] + [
            (n, st, lambda m=m: simulate(model, t_end=t_end, dt=dt, method=m), base)
            for n, st, m in methods]:
        secs, res, base_s = _timed(fn, repeats, beside)
        out = {"peak": float(res.max_abs_displacement[peak_dof]),
               **ours_contacts(res, model)}
        rows.append(_measured(key, "vibroimpact", name, setting, (secs, out, base_s), repeats,
                              ref, f"{res.stats.steps} steps"))
    return rows


def scipy_rows(key: str, run: Callable[[str, float], dict[str, Any]], ref: dict[str, Any],
               repeats: int, base: dict[str, Any], newmark: Callable[[], Any], quick: bool,
               rtols: tuple[float, ...], how: str) -> list[dict[str, Any]]:
    """Radau, LSODA and DOP853 (``run(method, rtol)``), each at the loosest of ``rtols`` whose
    errors are at most our Newmark's (``base``, its row; ``newmark``, its run, timed beside),
    or at rtol 1e-6 with ``quick``; with the run one decade looser beside it (a bracket: there
    the peer is less accurate than ours)."""
    rows = []
    for method in scipy_peer.METHODS:
        if quick:
            rtol, found, why = 1e-6, True, "rtol fixed (--quick)"
        else:
            rtol, found = scipy_peer.matching_tolerance(
                lambda r, m=method: run(m, r), ref, base["peak_error"],
                base["impact_time_error_s"], abs(base["contacts"] - len(ref["impacts"])),
                rtols)
            why = ("loosest rtol with errors <= our Newmark's" if found
                   else "tightest rtol tried; still less accurate than our Newmark")
        try:
            timing = _timed(lambda m=method, r=rtol: run(m, r), repeats, newmark)
        except Exception as e:  # a SciPy failure is reported, not raised
            rows.append(_unavailable(key, "SciPy", method, f"rtol {rtol:g}", f"failed: {e}"))
            continue
        looser = ""
        extra: dict[str, Any] = {}
        i = rtols.index(rtol) if rtol in rtols else 0
        if not quick and found and i > 0:
            r2 = rtols[i - 1]
            secs2, out2, base2 = _timed(lambda m=method, r=r2: run(m, r), repeats, newmark)
            pe2, te2, note2 = scipy_peer.errors(out2, ref)
            ratio2 = secs2 / base2 if base2 else math.nan
            extra = {"looser": {"rtol": r2, "time_s": secs2, "peak_error": pe2,
                                "impact_time_error_s": te2, "ratio": ratio2}}
            looser = (f"at rtol {r2:g}: {_fmt_time(secs2)} = {ratio2:.3g}x, "
                      f"errors {pe2:.1e} / {_fmt_err(te2, 's')}{' ' + note2 if note2 else ''}")
        rows.append(_measured(key, "SciPy", method, f"rtol {rtol:g}", timing, repeats, ref,
                              why, how, f"{timing[1]['steps']} steps", looser, **extra))
    return rows


def peer_rows(key: str, tool: str, reason: str | None,
              runs: list[tuple[str, str, Callable[[], dict[str, Any]]]], ref: dict[str, Any],
              repeats: int, note: str, newmark: Callable[[], Any] | None
              ) -> list[dict[str, Any]]:
    """One row per ``(label, setting, run)`` of a peer, with our Newmark (``newmark``) timed
    beside it; ``reason``: why it is not available (None if it is). The peer's C-level output
    is silenced while it runs."""
    rows = []
    for label, setting, fn in runs:
        if reason:
            rows.append(_unavailable(key, tool, label, setting, reason))
            continue
        try:
            with _quiet_fds():
                timing = _timed(fn, repeats, newmark)
        except Exception as e:
            rows.append(_unavailable(key, tool, label, setting,
                                     f"failed: {type(e).__name__}: {e}"))
            continue
        rows.append(_measured(key, tool, label, setting, timing, repeats, ref, note))
    return rows


def _quiet_fds() -> Any:
    """Silence the C-level stdout/stderr (OpenSees prints every impact) while peers run."""
    import contextlib

    @contextlib.contextmanager
    def quiet() -> Any:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = [os.dup(1), os.dup(2)]
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 1)
            os.dup2(null, 2)
            yield
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in (*saved, null):
                os.close(fd)

    return quiet()


def _sdof_rows(p: SdofProblem, quick: bool, repeats: int, ours_repeats: int,
               log: Callable[[str], None]) -> list[dict[str, Any]]:
    log(f"{p.key}: converged reference (SciPy DOP853, rtol 1e-12)")
    ref = converged(p)
    log(f"{p.key}: vibroimpact")
    model = p.model()
    newmark = newmark_run(model, p.t_end, p.dt)
    rows = ours_rows(p.key, model, p.t_end, p.dt, ADAPTIVE, ref, ours_repeats, 0)
    log(f"{p.key}: SciPy solve_ivp")
    rows += scipy_rows(p.key, lambda m, r: scipy_peer.run_sdof(p, m, r), ref, repeats, rows[0],
                       newmark, quick, scipy_peer.RTOLS, "")
    setting = f"dt {p.dt:g} s"
    log(f"{p.key}: OpenSeesPy")
    rows += peer_rows(
        p.key, "OpenSeesPy", opensees_peer.available(),
        [(label, setting, lambda k=k: opensees_peer.run_sdof(p, k))
         for k, label in (("newmark", "Newmark"), ("hht", "HHT"))], ref, repeats,
        "Hertzdamp zeroLength (the same law, but its v_imp is the speed at the step where "
        "contact is detected); no event location", newmark)
    log(f"{p.key}: Exudyn")
    rows += peer_rows(
        p.key, "Exudyn", exudyn_peer.available(),
        [(label, setting, lambda k=k: exudyn_peer.run_sdof(p, k))
         for k, label in (("newmark", "Newmark"), ("generalized-alpha", "generalized-α ρ∞ 0.8"))],
        ref, repeats,
        "ObjectContactCoordinate impactModel 1 (its Hunt-Crossley form with e chosen = LN); "
        "no event location" + ("; load by Python user function" if p.force_amplitude else ""),
        newmark)
    for r in rows:
        r["reference"] = (f"SciPy DOP853 rtol 1e-12, piecewise with events: peak "
                          f"{ref['peak'] * 1e3:.6f} mm, {len(ref['impacts'])} contacts; vs rtol "
                          f"1e-11: {ref['self_check'][0]:.1e} peak, "
                          f"{ref['self_check'][1]:.1e} s")
    return rows


def run(quick: bool = False, repeats: int | None = None,
        log: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """Every row of the table. ``repeats``: timed runs per peer (default 5; 1 with ``quick``,
    which also fixes the SciPy tolerance at 1e-6 instead of searching for the matching one and
    shortens the forced SDOF and the beam, :func:`problem_list`)."""
    log = log or (lambda s: None)
    if repeats is None:
        repeats = 1 if quick else 5
    ours_repeats = max(repeats, 3 if quick else 20)
    rows: list[dict[str, Any]] = []
    for p in problem_list(quick):
        if isinstance(p, BeamProblem):
            from vibroimpact.benchmarks.peers.beam import beam_rows

            prows = beam_rows(p, quick, repeats, ours_repeats, log)
        else:
            prows = _sdof_rows(p, quick, repeats, ours_repeats, log)
        prows[0]["ratio"] = 1.0  # our Newmark: the others are timed beside it
        rows += prows
    return rows


def problem_list(quick: bool) -> list[Any]:
    """The problems; with ``quick`` the forced SDOF runs 0.2 s and the beam 0.03 s (its first
    contacts, at 0.025 s; the paper's SDOF case is short already)."""
    import dataclasses

    beam = hollow_shaft()
    if not quick:
        return [paper_sdof(), forced_sdof(), beam]
    forced = forced_sdof()
    forced = dataclasses.replace(forced, t_end=0.2, title=forced.title.replace("1 s", "0.2 s"))
    beam = dataclasses.replace(beam, t_end=0.03, title=beam.title.replace("0.2 s", "0.03 s"))
    return [paper_sdof(), forced, beam]


def targets(rows: list[dict[str, Any]]) -> list[str]:
    """One line per target and problem: met or missed, by how much."""
    out = []
    for r in rows:
        goal = TARGETS.get((r["tool"], r["method"]))
        if goal is None:
            continue
        if r["ratio"] is None:
            out.append(f"{r['problem']}: {r['tool']} {r['method']}: not measured ({r['note']})")
            continue
        ours = next(x for x in rows if x["problem"] == r["problem"] and x["method"] == "Newmark"
                    and x["tool"] == "vibroimpact")
        if r["peak_error"] is None or ours["peak_error"] is None:
            acc = ""
        else:
            peer_ok = (r["peak_error"] <= ours["peak_error"]
                       and r["impact_time_error_s"] <= ours["impact_time_error_s"])
            acc = (f"; peer errors {r['peak_error']:.1e} / "
                   f"{_fmt_err(r['impact_time_error_s'], 's')} vs ours {ours['peak_error']:.1e} / "
                   f"{_fmt_err(ours['impact_time_error_s'], 's')}"
                   + (" (peer at least as accurate)" if peer_ok else " (peer less accurate in "
                      "at least one measure)"))
        verdict = "met" if r["ratio"] >= goal else f"MISSED by {goal / r['ratio']:.2g}x"
        lo = r.get("looser")
        if lo:
            lverdict = ("met" if lo["ratio"] >= goal
                        else f"missed by {goal / lo['ratio']:.2g}x")
            verdict += (f"; one decade looser (rtol {lo['rtol']:g}, peer less accurate than "
                        f"ours): {lo['ratio']:.3g}x, {lverdict}")
        out.append(f"{r['problem']}: {r['tool']} {r['method']} ({r['setting']}): "
                   f"{r['ratio']:.3g}x our Newmark, target >= {goal:g}x: {verdict}{acc}")
    return out


#: Issue 20's targets on the paper's SDOF case: (what, goal, "max" or "min").
ISSUE20 = {
    "newmark_vs_floor": ("fixed-step Newmark / the bare loop (wall time)", 1.7, "max"),
    "generalized_alpha_vs_newmark": ("generalized-α / Newmark", 1.3, "max"),
    "precise_vs_newmark": ("precise integration / Newmark", 1.5, "max"),
    "opensees_same_dt": ("same dt: OpenSeesPy Newmark / ours", 50.0, "min"),
    "exudyn_same_dt": ("same dt: Exudyn Newmark / ours", 30.0, "min"),
    "scipy_same_dt": ("same dt: SciPy DOP853 with events (loosest rtol with errors <= our "
                      "Newmark's) / ours", 30.0, "min"),
    "scipy_equal_accuracy": ("equal accuracy: SciPy DOP853 with events / ours", 150.0, "min"),
}


def issue20_targets(rows: list[dict[str, Any]], eq: dict[str, Any] | None,
                    floor: dict[str, Any] | None,
                    sweep: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Issue 20's targets (:data:`ISSUE20`) measured in this run, on the paper's SDOF case:
    per target ``key``, ``what``, ``goal``, ``value`` (None if not measured), ``met`` and
    ``detail``; the sweep-throughput target last, from ``sweep``
    (:func:`~vibroimpact.benchmarks.sweep.fixed_step_sweep_benchmark`) if measured."""
    def ratio(tool: str, method: str) -> tuple[float | None, str]:
        r = next((x for x in rows if x["problem"] == "paper-sdof" and x["tool"] == tool
                  and x["method"] == method), None)
        if r is None or r["ratio"] is None:
            return None, r["note"] if r else "no such row in this run"
        return r["ratio"], f"{r['setting']}, {_fmt_time(r['time_s'])}"

    found: dict[str, tuple[float | None, str]] = {
        "generalized_alpha_vs_newmark": ratio("vibroimpact", "generalized-α ρ∞ 0.8"),
        "precise_vs_newmark": ratio("vibroimpact", "precise (Adams)"),
        "opensees_same_dt": ratio("OpenSeesPy", "Newmark"),
        "exudyn_same_dt": ratio("Exudyn", "Newmark"),
        "scipy_same_dt": ratio("SciPy", "DOP853"),
    }
    found["newmark_vs_floor"] = (None, "not measured") if floor is None else (
        floor["ratio"], f"{_fmt_time(floor['ours_s'])} vs {_fmt_time(floor['floor_s'])}; CPU "
        f"time {floor['cpu_ratio']:.2f}x")
    scipy_eq = None if eq is None else next(
        (r for r in eq["rows"] if r["tool"] == "SciPy"), None)
    if scipy_eq is None or scipy_eq["ratio"] is None:
        found["scipy_equal_accuracy"] = (None, "not measured")
    else:
        ours = eq["rows"][0]
        found["scipy_equal_accuracy"] = (
            scipy_eq["ratio"],
            f"SciPy at {scipy_eq['setting']} ({_fmt_time(scipy_eq['time_s'])}"
            + ("" if scipy_eq["meets"] else ", which does NOT meet the accuracy")
            + f") vs our {ours['method']} at {ours['setting']} ({_fmt_time(ours['time_s'])})")
    out = []
    for key, (what, goal, sense) in ISSUE20.items():
        value, detail = found[key]
        met = None if value is None else (value <= goal if sense == "max" else value >= goal)
        if key == "scipy_equal_accuracy" and scipy_eq is not None and not scipy_eq["meets"]:
            met = None
        out.append({"key": key, "what": what, "goal": goal, "sense": sense, "value": value,
                    "met": met, "detail": detail})
    value = None if sweep is None else sweep["ratio"]
    out.append({"key": "sweep_throughput", "what": "fixed-step sweep throughput per core",
                "goal": 2.0, "sense": "min", "value": value,
                "met": None if value is None else value >= 2.0,
                "detail": "not measured" if sweep is None else _sweep_detail(sweep)})
    return out


def _sweep_detail(sweep: dict[str, Any]) -> str:
    return (f"{sweep['points']} frequencies x {sweep['periods']} periods, fixed-step Newmark, "
            f"one thread: {sweep['cpu_s']:.3f} s CPU ({sweep['steps']:,} steps, "
            f"{sweep['ns_per_step']:.0f} ns a step) against {sweep['baseline_cpu_s']:.3f} s "
            "before issue 20's per-step changes")


def format_per_step(floor: dict[str, Any], issue20: list[dict[str, Any]]) -> list[str]:
    """The section on issue 20's per-step path: the bare loop in CPU time (the steadier
    measure on a shared machine) and in wall time, the integrators against Newmark and the
    fixed-step sweep's throughput, all from this run."""
    found = {t["key"]: t for t in issue20}

    def verdict(t: dict[str, Any]) -> str:
        if t["value"] is None:
            return "not measured"
        return f"{t['value']:.3g}x, " + ("met" if t["met"] else "missed")

    cpu_met = "met" if floor["cpu_ratio"] <= floor["target_ratio"] else "missed"
    lines = [
        f"fixed-step Newmark / the bare loop (paper SDOF case, Lankarani-Nikravesh, "
        f"{floor['steps']:,} steps): {floor['cpu_ratio']:.2f}x in CPU time "
        f"({floor['ours_cpu_s'] * 1e3:.3f} / {floor['floor_cpu_s'] * 1e3:.3f} ms), "
        f"{floor['ratio']:.2f}x in wall time; target <= {floor['target_ratio']}x: {cpu_met} "
        f"(CPU time). Histories within {floor['max_displacement_difference_m']:.1e} m.",
    ]
    for key in ("generalized_alpha_vs_newmark", "precise_vs_newmark", "sweep_throughput"):
        t = found[key]
        goal = f"{'<=' if t['sense'] == 'max' else '>='} {t['goal']:g}x"
        lines.append(f"{t['what']}: {verdict(t)} (target {goal}); {t['detail']}.")
    return lines


def format_issue20(targets: list[dict[str, Any]]) -> list[str]:
    """One line per issue-20 target: the measured ratio, the goal, met or missed."""
    lines = []
    for t in targets:
        goal = f"{'<=' if t['sense'] == 'max' else '>='} {t['goal']:g}x"
        if t["value"] is None:
            verdict = "not measured"
            value = "-"
        else:
            value = f"{t['value']:.3g}x"
            verdict = ("met" if t["met"] else "not judged" if t["met"] is None
                       else "MISSED")
        lines.append(f"{t['what']}: {value} (target {goal}): {verdict}; {t['detail']}")
    return lines


def _loads(loads: Sequence[float]) -> str:
    return " / ".join(f"{x:.2f}" for x in loads)


def machine(start_load: Sequence[float] | None = None) -> dict[str, str]:
    """CPU, cores, the load average (when written and, with ``start_load``, at the start of
    the run) and versions of everything that ran."""
    from importlib.metadata import version

    import scipy

    cpu = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:  # pragma: no cover - not Linux
        cpu = platform.processor() or "unknown"
    info = {
        "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "cpu": cpu,
        "cores": str(os.cpu_count()),
        **({} if start_load is None else
           {"load average (1/5/15 min) at the start": _loads(start_load)}),
        "load average (1/5/15 min) when written": _loads(
            os.getloadavg() if hasattr(os, "getloadavg") else ()),
        "os": f"{platform.system()} {platform.release()} ({platform.machine()})",
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "vibroimpact": version("vibroimpact"),
        "openseespy": (opensees_peer.version() if opensees_peer.available() is None
                       else "not available"),
        "exudyn": exudyn_peer.version() if exudyn_peer.available() is None else "not available",
    }
    return info


def load_note(info: dict[str, str]) -> str:
    """A sentence if the machine was loaded (a 1-minute load average above its cores at the
    start or the end of the run), else ""."""
    def first(v: str) -> float:
        try:
            return float(v.split(" / ")[0])
        except ValueError:  # not measured on this OS
            return 0.0

    cores = first(info.get("cores") or "0")
    ones = [first(v) for k, v in info.items() if k.startswith("load average")]
    if not cores or not ones or max(ones) <= cores:
        return ""
    return (f"Measured on a shared, loaded machine (1-minute load average up to "
            f"{max(ones):.1f} on {cores:g} cores, other work running beside this run): every "
            "wall time is longer and noisier than on a quiet machine; the ratios are timed "
            "beside each other, which evens out part of it, not all.")


def _fmt_time(s: float | None) -> str:
    if s is None:
        return "-"
    return f"{s * 1e3:.3g} ms" if s < 1 else f"{s:.3g} s"


def _fmt_err(x: float | None, unit: str = "") -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if unit == "s":
        return f"{x * 1e9:.3g} ns" if x < 1e-6 else f"{x * 1e6:.3g} µs"
    return f"{x:.1e}"


def _cells(r: dict[str, Any]) -> list[str]:
    ratio = "-" if r["ratio"] is None else f"{r['ratio']:.3g}x"
    runs = str(r["repeats"]) if r["time_s"] is not None else "-"
    return [r["problem"], r["tool"], r["method"], r["setting"], _fmt_time(r["time_s"]), runs,
            ratio, _fmt_err(r["peak_error"]), _fmt_err(r["impact_time_error_s"], "s"), r["note"]]


HEADER = ["problem", "tool", "method", "step / tolerance", "wall time (median)", "runs",
          "vs our Newmark", "peak displacement error (rel.)", "impact-time error", "note"]

#: What ``--quick`` changes, stated above its tables.
QUICK = ("`--quick` (a smoke test, not the benchmark): ONE run per peer (ours: median of 3), "
         "SciPy at rtol 1e-6 (no tolerance search), the forced SDOF 0.2 s and the beam 0.03 s "
         "long")


def _columns(header: list[str], cells: list[list[str]]) -> list[str]:
    """Rows of text in aligned columns (the last, a note, left ragged)."""
    table = [header, *cells]
    widths = [max(len(c[i]) for c in table) for i in range(len(header) - 1)]
    return ["  ".join(c[i].ljust(widths[i]) for i in range(len(widths))) + "  " + c[-1]
            for c in table]


def format_text(rows: list[dict[str, Any]], quick: bool = False,
                eq: dict[str, Any] | None = None,
                issue20: list[dict[str, Any]] | None = None) -> str:
    """The same-dt table and issue 9's targets; with ``eq``, the equal-accuracy table; with
    ``issue20``, issue 20's targets."""
    lines = [QUICK.replace("`", "")] if quick else []
    lines += _columns(HEADER, [_cells(r) for r in rows])
    lines.append("")
    lines += targets(rows)
    if eq is not None:
        lines += ["", eqacc.describe(eq) + ":"]
        lines += _columns(eqacc.HEADER, [eqacc.row_cells(r) for r in eq["rows"]])
    if issue20 is not None:
        lines += ["", "Issue 20's targets (paper SDOF case, this run):"]
        lines += format_issue20(issue20)
    return "\n".join(lines)


def format_markdown(rows: list[dict[str, Any]], info: dict[str, str], quick: bool,
                    eq: dict[str, Any] | None = None,
                    issue20: list[dict[str, Any]] | None = None,
                    figure: str | None = None, floor: dict[str, Any] | None = None) -> str:
    """``benchmarks/results.md``: the machine, the problems, the same-dt table and issue 9's
    targets; with ``eq`` the equal-accuracy table (and ``figure``, its PNG's relative path)
    and every ladder point; with ``issue20`` issue 20's targets, and with ``floor`` too
    (:func:`~vibroimpact.benchmarks.sdof.floor_benchmark`) its per-step section."""
    problems = problem_list(quick)
    refs = {}
    for r in rows:
        if "reference" in r:
            refs[r["problem"]] = r["reference"]
    out = ["# Benchmark against peers (issues 9 and 20)", "",
           f"Generated by `{COMMAND}`"
           + (f" with {QUICK}" if quick else "")
           + "; every tool runs in the same Python process, one after the other.", "",
           "## Machine", "", "| | |", "|---|---|"]
    out += [f"| {k} | {v} |" for k, v in info.items()]
    if load_note(info):
        out += ["", f"**{load_note(info)}**"]
    out += ["", "## Problems and the reference", ""]
    for p in problems:
        out.append(f"* **{p.key}** — {p.describe()}.")
        if p.key in refs:
            out.append(f"  Reference: {refs[p.key]}.")
    out += ["", "## Results", "", *_markdown_table(HEADER, [_cells(r) for r in rows])]
    out += ["", "## Targets (issue 9: at equal or better accuracy)", ""]
    out += [f"* {t}" for t in targets(rows)]
    if eq is not None:
        out += ["", "## Equal accuracy (issue 20)", "", eqacc.describe(eq) + ".", "",
                *_markdown_table(eqacc.HEADER, [eqacc.row_cells(r) for r in eq["rows"]])]
        if figure:
            out += ["", f"![Error against wall time, every tool and setting]({figure})"]
        out += ["", "Every setting of every ladder (the points of the figure):", "",
                *_markdown_table(eqacc.POINT_HEADER,
                                 [eqacc.point_cells(pt) for pt in eq["points"]])]
    if issue20 is not None:
        out += ["", "## Issue 20's targets (paper SDOF case, measured in this run)", ""]
        out += [f"* {line}" for line in format_issue20(issue20)]
        if floor is not None:
            out += ["", "## Issue 20, item 1: the per-step path", "",
                    "Measured in this run, in CPU time where stated (on a shared machine the "
                    "steadier measure):", ""]
            out += [f"* {line}" for line in format_per_step(floor, issue20)]
    out += ["", "## How it was measured", "", *NOTES]
    return "\n".join(out) + "\n"


def _markdown_table(header: list[str], cells: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *("| " + " | ".join(c.replace("|", "/") for c in row) + " |" for row in cells)]


#: The command that writes ``benchmarks/results.md`` and the README's peer table.
COMMAND = "vibroimpact bench --peers --write benchmarks/results.md --readme README.md"

#: The markers around the generated block in the README.
README_START = "<!-- bench-peers:start -->"
README_END = "<!-- bench-peers:end -->"

#: The README table's columns: header, (tool, method) of each row shown in the cell.
_README_COLUMNS = [
    ("SciPy Radau", [("SciPy", "Radau")]),
    ("SciPy LSODA", [("SciPy", "LSODA")]),
    ("SciPy DOP853", [("SciPy", "DOP853")]),
    ("OpenSeesPy Newmark / HHT", [("OpenSeesPy", "Newmark"), ("OpenSeesPy", "HHT")]),
    ("Exudyn Newmark / gen.-α", [("Exudyn", "Newmark"), ("Exudyn", "generalized-α ρ∞ 0.8")]),
]


def format_readme(rows: list[dict[str, Any]], info: dict[str, str], quick: bool,
                  eq: dict[str, Any] | None = None,
                  issue20: list[dict[str, Any]] | None = None) -> str:
    """The README's peer table (between :data:`README_START` and :data:`README_END`): peer
    time over our Newmark's per problem, and the targets met or missed, by how much; with
    ``eq`` the equal-accuracy line, with ``issue20`` issue 20's targets."""
    def cell(r: dict[str, Any] | None) -> str:
        if r is None or r["ratio"] is None:
            return "not measured"
        tol = f" ({r['setting']})" if r["tool"] == "SciPy" else ""
        return f"{r['ratio']:.3g}×{tol}"

    out = [README_START,
           f"<!-- generated by `{COMMAND}`{' --quick' if quick else ''}: do not edit by hand -->",
           "",
           f"Measured {info['date']} on {info['cpu']} ({info['cores']} cores, load average "
           f"{info['load average (1/5/15 min) when written']}). Peer wall time ÷ our Newmark's "
           "on the same problem, timed beside it (medians of at least 5 runs; SciPy "
           "`solve_ivp` with contact events at the loosest tolerance whose errors are at most "
           "our Newmark's; OpenSeesPy and Exudyn at our dt). Errors, notes and the machine: "
           "[benchmarks/results.md](benchmarks/results.md)."
           + (f" {QUICK}." if quick else "") + (f" {load_note(info)}" if load_note(info)
                                                 else ""), "",
           "| problem | our Newmark | " + " | ".join(h for h, _ in _README_COLUMNS) + " |",
           "|---|---|" + "---|" * len(_README_COLUMNS)]
    for key in dict.fromkeys(r["problem"] for r in rows):
        prow = [r for r in rows if r["problem"] == key]

        def find(tool: str, method: str, prow: list[dict[str, Any]] = prow
                 ) -> dict[str, Any] | None:
            return next((r for r in prow if r["tool"] == tool and r["method"] == method), None)

        ours = find("vibroimpact", "Newmark")
        cells = [" / ".join(cell(find(*tm)) for tm in tms) for _, tms in _README_COLUMNS]
        out.append(f"| {key} | {_fmt_time(ours['time_s'] if ours else None)} | "
                   + " | ".join(cells) + " |")
    missed, met = [], 0
    for r in rows:
        goal = TARGETS.get((r["tool"], r["method"]))
        if goal is None:
            continue
        if r["ratio"] is not None and r["ratio"] >= goal:
            met += 1
        else:
            by = "not measured" if r["ratio"] is None else f"{r['ratio']:.3g}×, short by " \
                f"{goal / r['ratio']:.2g}×"
            missed.append(f"{r['problem']} {r['tool']} {r['method']} ({by} of ≥ {goal:g}×)")
    out += ["", f"**Targets** (issue 9: ≥ 100× SciPy Radau/LSODA, ≥ 30× DOP853, ≥ 50× "
            f"OpenSeesPy, at equal or better accuracy): met {met} of {met + len(missed)}."
            + (" Missed: " + "; ".join(missed) + "." if missed else "")]
    if eq is not None:
        out += ["", _readme_equal_accuracy(eq)]
    if issue20 is not None:
        out += ["", "**Issue 20's targets** (the paper's SDOF case, measured in the same run):", ""]
        out += [f"* {line}" for line in format_issue20(issue20)]
    return "\n".join([*out, README_END])


def _readme_equal_accuracy(eq: dict[str, Any]) -> str:
    """One paragraph: each tool's time at equal accuracy and its ratio to ours."""
    parts = []
    for r in eq["rows"]:
        name = f"{r['tool']} {r['method']}"
        if r["time_s"] is None:
            parts.append(f"{name}: {r['note']}")
        elif r["meets"]:
            parts.append(f"{name} at {r['setting']}: {_fmt_time(r['time_s'])}"
                         + ("" if r["ratio"] == 1.0 or r["ratio"] is None
                            else f" = {r['ratio']:.3g}× ours"))
        else:
            parts.append(f"{name}: meets it at no setting of its ladder (best: "
                         f"{r['peak_error_m']:.1e} m / {r['impact_time_error_s']:.1e} s at "
                         f"{r['setting']})")
    return (f"**At equal accuracy** ({eq['problem']}: peaks within {eqacc.PEAK_TARGET_M:g} m, "
            f"impact times within {eqacc.TIME_TARGET_S:g} s of the converged reference; each "
            "tool at the loosest setting of its ladder that meets both; ours: the fastest of "
            "our methods there): " + "; ".join(parts) + ". Every setting and the figure of "
            "error against wall time: [benchmarks/results.md](benchmarks/results.md).")


def replace_readme_block(text: str, block: str) -> str:
    """``text`` with the part from :data:`README_START` to :data:`README_END` replaced."""
    a, b = text.find(README_START), text.find(README_END)
    if a < 0 or b < a:
        raise ValueError(f"README: expected the markers {README_START!r} ... {README_END!r} "
                         "around the peer table")
    return text[:a] + block + text[b + len(README_END):]


NOTES = [
    "* Wall time: median of the runs in the 'runs' column (ours: at least 20, peers 5; "
    f"`--quick`: 1), after one warm-up run that is not counted unless it took "
    f"{LONG_RUN_S:g} s or more (then it is the first of the runs: one-off costs are "
    "negligible beside it and the median absorbs them); model build included, every step "
    "kept, in this process. 'vs our Newmark': the row's median over the median of our "
    "fixed-step Newmark on the same problem, run beside each of the row's runs (so that "
    "both medians see the same load on a shared machine), each timed call after an untimed "
    "one (warm, as the row's counted runs are); our Newmark's own row is its median of its "
    "runs in a block.",
    "* Accuracy: against ONE converged reference per problem, the same for every tool: peak "
    "|x| relative error (the SDOF mass; the beam's middle slider), and the largest error of "
    "any contact's start or end time (each reference contact matched with the contact that "
    "starts nearest to it; a different number of contacts is stated in the note).",
    "* vibroimpact: the Python API (`vibroimpact.simulate`), Rust core; impact times and the peak "
    "are located inside the step.",
    "* SciPy: SDOF problems: `solve_ivp` phase by phase with terminal events where a gap closes "
    "or opens and a non-terminal event at x' = 0 for the peaks "
    "(`vibroimpact.benchmarks.peers.scipy_peer`); the beam: one call on the full 42-DOF model "
    "(Hertz force, C1) with events at every gap crossing (`vibroimpact.benchmarks.peers.beam`). "
    "The tolerance is "
    "the loosest of 1e-3 ... 1e-11 (beam: 1e-3 ... 1e-7) whose peak and impact-time errors are "
    "both at most our Newmark's and whose number of contacts is as close to the reference's as "
    "ours, so each SciPy row is at least as accurate as our Newmark; the note gives the run one "
    "decade looser (less accurate than ours) as a bracket.",
    "* OpenSeesPy: `Hertzdamp` (force K δ^n (1 + ξ δ̇/v_imp) with ξ = 3(1 − ce²)/4, i.e. "
    "Lankarani–Nikravesh; ξ = 0 on the beam, i.e. Hertz; its v_imp is the velocity at the "
    "step where contact is detected, not a located crossing) in `zeroLength` elements, "
    "Newton, `NormDispIncr` 1e-12, at our dt; `analyze(1, dt)` in a loop reading `nodeDisp` "
    "(a `recorder` with `analyze(N, dt)` took the same time). Its `GeneralizedAlpha` is not "
    "used (PEERS.md: wrong on a linear SDOF in this version). Peak = largest step value; "
    "impact times = linear interpolation of the clearance crossing between steps. The beam: "
    "`ElasticTimoshenkoBeam` elements with `-cMass` (its free-free frequencies equal ours to 9 "
    "digits: the same model).",
    "* Exudyn: Newmark (β = 1/4, γ = 1/2) and generalized-α (spectral radius 0.8) on every "
    "problem (it can express all three), fixed step, full Newton. SDOF: "
    "`ObjectContactCoordinate` with `impactModel = 1` (restitution chosen so that its "
    "1.5(1 − e) equals 3(1 − ce²)/4: the Lankarani–Nikravesh force); the beam: our M and K in "
    "an `ObjectGenericODE2` (its own beam elements would be a different discretisation), "
    "`ObjectContactCoordinate` Hertz sliders, the load as `LoadCoordinate` Python user "
    "functions. Peak and impact times from the stored steps as for OpenSees.",
]


#: The Pareto figure's file, written beside the ``--write`` file.
FIGURE = "equal-accuracy.png"


def missing_peers() -> dict[str, str]:
    """The peers that cannot run here and why."""
    reasons = {"OpenSeesPy": opensees_peer.available(), "Exudyn": exudyn_peer.available()}
    return {tool: why for tool, why in reasons.items() if why}


def cli_main(quick: bool = False, repeats: int | None = None, write: str | None = None,
             as_json: bool = False, readme: str | None = None) -> int:
    """``vibroimpact bench --peers [--quick] [--write FILE.md] [--readme README.md] [--json]``:
    the same-dt table, the paper's SDOF case at equal accuracy, the bare loop and issue 20's
    targets, all in this run; ``--write`` also writes the Pareto figure beside FILE.md."""
    import json
    from pathlib import Path

    from vibroimpact.benchmarks.sdof import floor_benchmark
    from vibroimpact.benchmarks.sweep import fixed_step_sweep_benchmark

    def log(msg: str) -> None:
        print(f"[bench --peers] {msg}", file=sys.stderr, flush=True)

    if readme:  # fail before the long run, not after it
        replace_readme_block(Path(readme).read_text(encoding="utf-8"), "")
    start_load = os.getloadavg() if hasattr(os, "getloadavg") else None
    for tool, why in missing_peers().items():
        log(f"{tool} is not installed, its rows say 'not available': {why}")
    n = 1 if quick else (repeats or 5)
    rows = run(quick=quick, repeats=repeats, log=log)
    eq = eqacc.equal_accuracy(paper_sdof(), quick, n, max(n, 3 if quick else 20), log)
    log("paper-sdof: our Newmark against the bare loop")
    floor = floor_benchmark(repeats=3 if quick else 20)
    log("the fixed-step sweep's throughput on one thread")
    sweep = fixed_step_sweep_benchmark(repeats=1 if quick else 3)
    issue20 = issue20_targets(rows, eq, floor, sweep)
    info = machine(start_load)
    if as_json:
        print(json.dumps({"machine": info, "rows": rows, "targets": targets(rows),
                          "equal_accuracy": eq, "floor": floor, "fixed_step_sweep": sweep,
                          "issue20_targets": issue20},
                         default=float))
    else:
        print(format_text(rows, quick, eq, issue20))
    if write:
        path = Path(write)
        path.parent.mkdir(parents=True, exist_ok=True)
        eqacc.pareto_figure(eq, path.parent / FIGURE)
        path.write_text(format_markdown(rows, info, quick, eq, issue20, FIGURE, floor),
                        encoding="utf-8")
        log(f"wrote {path} and {path.parent / FIGURE}")
    if readme:
        path = Path(readme)
        path.write_text(replace_readme_block(path.read_text(encoding="utf-8"),
                                             format_readme(rows, info, quick, eq, issue20)),
                        encoding="utf-8")
        log(f"updated the peer table in {path}")
    return 0
