"""``vibroimpact bench --peers``: every problem of :mod:`vibroimpact.peers.problems` through our
integrators, SciPy ``solve_ivp`` with contact events, OpenSeesPy and Exudyn, in this process,
in one table: tool, method, step or tolerance, wall time (median), ratio to our Newmark, and
the errors against one converged reference per problem (:mod:`vibroimpact.peers.reference`).

A peer that is not installed (or fails) gives a row ``not available: reason``; nothing here
fails because a peer is missing."""

from __future__ import annotations

import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from datetime import datetime, timezone
from typing import Any

import numpy as np

from vibroimpact.peers import exudyn_peer, opensees_peer, scipy_peer
from vibroimpact.peers.problems import (
    BeamProblem,
    SdofProblem,
    forced_sdof,
    hollow_shaft,
    paper_sdof,
)
from vibroimpact.peers.reference import converged, impact_time_error

__all__ = ["TARGETS", "format_markdown", "format_text", "machine", "run", "targets"]

#: Issue 9's targets: the peer must be at least this many times slower than our Newmark.
TARGETS = {("SciPy", "Radau"): 100.0, ("SciPy", "LSODA"): 100.0, ("SciPy", "DOP853"): 30.0,
           ("OpenSeesPy", "Newmark"): 50.0, ("OpenSeesPy", "HHT"): 50.0}

#: Adaptive stepping of our Newmark: tolerances that reach about fixed-step Newmark's accuracy
#: on both SDOF problems.
ADAPTIVE = {"rtol": 1e-8, "atol": 1e-12}


def _timed(fn: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    """Median wall time of ``repeats`` calls after one warm-up call (one call, no warm-up, if
    ``repeats <= 1``), and the last result."""
    if repeats <= 1:
        t0 = time.perf_counter()
        out = fn()
        return time.perf_counter() - t0, out
    out = fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def _row(problem: str, tool: str, method: str, setting: str, **kw: Any) -> dict[str, Any]:
    row = {"problem": problem, "tool": tool, "method": method, "setting": setting,
           "time_s": None, "repeats": 0, "ratio": None, "peak_error": None,
           "impact_time_error_s": None, "note": ""}
    row.update(kw)
    return row


def _unavailable(problem: str, tool: str, method: str, setting: str, reason: str
                 ) -> dict[str, Any]:
    return _row(problem, tool, method, setting, note=f"not available: {reason}")


def _ours_impacts(result: Any, gaps: list[int] | None = None) -> list[list[Any]]:
    imp = result.impacts
    rows = []
    for g, a, b in zip(imp.gap, imp.t_start, imp.t_end, strict=True):
        if gaps is None or int(g) in gaps:
            rows.append([float(a), None if not math.isfinite(b) else float(b)])
    return sorted(rows, key=lambda r: r[0])


def _ours(p: SdofProblem, ref: dict[str, Any], repeats: int) -> list[dict[str, Any]]:
    from vibroimpact.integrators import Adaptive, GeneralizedAlpha, Newmark, PreciseIntegration
    from vibroimpact.simulate import simulate

    model = p.model()
    methods = [
        ("Newmark", f"dt {p.dt:g} s", Newmark()),
        ("generalized-α ρ∞ 0.8", f"dt {p.dt:g} s", GeneralizedAlpha(rho_inf=0.8)),
        ("precise (Adams)", f"dt {p.dt:g} s", PreciseIntegration()),
        ("Newmark adaptive", f"rtol {ADAPTIVE['rtol']:g}, atol {ADAPTIVE['atol']:g} m",
         Newmark(adaptive=Adaptive(**ADAPTIVE))),
    ]
    rows = []
    for name, setting, method in methods:
        secs, res = _timed(lambda m=method: simulate(model, t_end=p.t_end, dt=p.dt, method=m),
                           repeats)
        te, note = impact_time_error(_ours_impacts(res), ref["impacts"])
        rows.append(_row(p.key, "vibroimpact", name, setting, time_s=secs, repeats=repeats,
                         peak_error=abs(float(res.max_abs_displacement[0]) / ref["peak"] - 1),
                         impact_time_error_s=te, note=note or f"{res.stats.steps} steps"))
    return rows


def _scipy(p: SdofProblem, ref: dict[str, Any], repeats: int, base: dict[str, Any],
           quick: bool) -> list[dict[str, Any]]:
    rows = []
    for method in scipy_peer.METHODS:
        if quick:
            rtol, found = 1e-6, True
            how = "rtol fixed (--quick)"
        else:
            rtol, found = scipy_peer.matching_tolerance(
                p, method, ref, base["peak_error"], base["impact_time_error_s"])
            how = ("loosest rtol with errors <= our Newmark's" if found
                   else "tightest rtol tried; still less accurate than our Newmark")
        try:
            secs, out = _timed(lambda m=method, r=rtol: scipy_peer.run_sdof(p, m, r), repeats)
        except Exception as e:  # pragma: no cover - a SciPy failure is reported, not raised
            rows.append(_unavailable(p.key, "SciPy", method, f"rtol {rtol:g}", f"failed: {e}"))
            continue
        pe, te, note = scipy_peer.errors(out, ref)
        looser = ""
        extra: dict[str, Any] = {}
        i = scipy_peer.RTOLS.index(rtol) if rtol in scipy_peer.RTOLS else 0
        if not quick and found and i > 0:
            # one decade looser: the peer is then less accurate than our Newmark (a bracket)
            r2 = scipy_peer.RTOLS[i - 1]
            secs2, out2 = _timed(lambda m=method, r=r2: scipy_peer.run_sdof(p, m, r), repeats)
            pe2, te2, note2 = scipy_peer.errors(out2, ref)
            extra = {"looser": {"rtol": r2, "time_s": secs2, "peak_error": pe2,
                                "impact_time_error_s": te2,
                                "ratio": secs2 / base["time_s"]}}
            looser = (f"at rtol {r2:g}: {_fmt_time(secs2)} = {secs2 / base['time_s']:.3g}x, "
                      f"errors {pe2:.1e} / {_fmt_err(te2, 's')}{' ' + note2 if note2 else ''}")
        rows.append(_row(p.key, "SciPy", method, f"rtol {rtol:g}", time_s=secs, repeats=repeats,
                         peak_error=pe, impact_time_error_s=te,
                         note="; ".join(x for x in (note, how, f"{len(out['t']) - 1} steps",
                                                    looser) if x), **extra))
    return rows


def _fixed_step_peer(p: SdofProblem, ref: dict[str, Any], repeats: int, tool: str,
                     module: Any, methods: list[tuple[str, str]], note: str
                     ) -> list[dict[str, Any]]:
    reason = module.available()
    rows = []
    for key, label in methods:
        if reason:
            rows.append(_unavailable(p.key, tool, label, f"dt {p.dt:g} s", reason))
            continue
        try:
            secs, out = _timed(lambda k=key: module.run_sdof(p, k), repeats)
        except Exception as e:
            rows.append(_unavailable(p.key, tool, label, f"dt {p.dt:g} s",
                                     f"failed: {type(e).__name__}: {e}"))
            continue
        te, cnote = impact_time_error(out["impacts"], ref["impacts"])
        rows.append(_row(p.key, tool, label, f"dt {p.dt:g} s", time_s=secs, repeats=repeats,
                         peak_error=abs(out["peak"] / ref["peak"] - 1), impact_time_error_s=te,
                         note="; ".join(x for x in (cnote, note) if x)))
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
    rows = _ours(p, ref, ours_repeats)
    base = rows[0]
    log(f"{p.key}: SciPy solve_ivp")
    rows += _scipy(p, ref, repeats, base, quick)
    log(f"{p.key}: OpenSeesPy")
    with _quiet_fds():
        rows += _fixed_step_peer(
            p, ref, repeats, "OpenSeesPy", opensees_peer,
            [("newmark", "Newmark"), ("hht", "HHT")],
            "Hertzdamp zeroLength (same law; v_imp from its step), no event location")
    log(f"{p.key}: Exudyn")
    with _quiet_fds():
        rows += _fixed_step_peer(
            p, ref, repeats, "Exudyn", exudyn_peer,
            [("newmark", "Newmark"), ("generalized-alpha", "generalized-α ρ∞ 0.8")],
            "ObjectContactCoordinate impactModel 1 (Hunt-Crossley form = LN here), "
            "no event location" + ("; load by Python user function" if p.force_amplitude
                                   else ""))
    for r in rows:
        r["reference"] = (f"SciPy DOP853 rtol 1e-12, piecewise with events: peak "
                          f"{ref['peak'] * 1e3:.6f} mm, {len(ref['impacts'])} contacts; vs rtol "
                          f"1e-11: {ref['self_check'][0]:.1e} peak, "
                          f"{ref['self_check'][1]:.1e} s")
    return rows


def _beam_rows(b: Any, quick: bool, repeats: int,
               log: Callable[[str], None]) -> list[dict[str, Any]]:
    key = "hollow-shaft"
    if b is None:
        return [_unavailable(key, "vibroimpact", "all", "",
                             "vibroimpact.cases has no hollow-shaft builder in this version")]
    from vibroimpact.peers.beam import beam_rows

    return beam_rows(b, quick, repeats, log)


def run(quick: bool = False, repeats: int | None = None,
        log: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """Every row of the table. ``repeats``: timed runs per peer (default 5; 1 with ``quick``,
    which also fixes the SciPy tolerance at 1e-6 instead of searching for the matching one and
    runs the beam's peers not at all)."""
    log = log or (lambda s: None)
    if repeats is None:
        repeats = 1 if quick else 5
    ours_repeats = max(repeats, 3 if quick else 20)
    rows: list[dict[str, Any]] = []
    for p in problem_list(quick):
        if isinstance(p, BeamProblem):
            continue
        prows = _sdof_rows(p, quick, repeats, ours_repeats, log)
        base = prows[0]["time_s"]
        for r in prows:
            if r["time_s"] is not None:
                r["ratio"] = r["time_s"] / base
        rows += prows
    rows += _beam_rows(problem_list(quick)[2], quick, repeats, log)
    return rows


def problem_list(quick: bool) -> list[Any]:
    """The problems; with ``quick`` the forced SDOF runs 0.2 s and the beam 0.02 s (the paper's
    SDOF case is short already)."""
    import dataclasses

    beam = hollow_shaft()
    if not quick:
        return [paper_sdof(), forced_sdof(), beam]
    forced = forced_sdof()
    forced = dataclasses.replace(forced, t_end=0.2, title=forced.title.replace("1 s", "0.2 s"))
    if beam is not None:
        beam = dataclasses.replace(beam, t_end=0.02,
                                   title=beam.title.replace("0.2 s", "0.02 s"))
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


def machine() -> dict[str, str]:
    """CPU, cores and versions of everything that ran."""
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
        "load average (1/5/15 min) when written": " / ".join(
            f"{x:.2f}" for x in (os.getloadavg() if hasattr(os, "getloadavg") else ())),
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
    return [r["problem"], r["tool"], r["method"], r["setting"], _fmt_time(r["time_s"]), ratio,
            _fmt_err(r["peak_error"]), _fmt_err(r["impact_time_error_s"], "s"), r["note"]]


HEADER = ["problem", "tool", "method", "step / tolerance", "wall time", "vs our Newmark",
          "peak displacement error (rel.)", "impact-time error", "note"]


def format_text(rows: list[dict[str, Any]]) -> str:
    cells = [HEADER] + [_cells(r) for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(HEADER) - 1)]
    lines = []
    for c in cells:
        lines.append("  ".join(c[i].ljust(widths[i]) for i in range(len(widths))) + "  " + c[-1])
    lines.append("")
    lines += targets(rows)
    return "\n".join(lines)


def format_markdown(rows: list[dict[str, Any]], info: dict[str, str], quick: bool) -> str:
    problems = problem_list(quick)
    refs = {}
    for r in rows:
        if "reference" in r:
            refs[r["problem"]] = r["reference"]
    out = ["# Benchmark against peers (issue 9)", "",
           "Generated by `vibroimpact bench --peers --write benchmarks/results.md`"
           + (" (`--quick`: one run per peer, SciPy tolerance fixed)" if quick else "")
           + "; every tool runs in the same Python process, one after the other.", "",
           "## Machine", "", "| | |", "|---|---|"]
    out += [f"| {k} | {v} |" for k, v in info.items()]
    out += ["", "## Problems and the reference", ""]
    for p in problems:
        if p is None:
            continue
        out.append(f"* **{p.key}** — {p.describe()}.")
        if p.key in refs:
            out.append(f"  Reference: {refs[p.key]}.")
    out += ["", "## Results", "",
            "| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    out += ["| " + " | ".join(c.replace("|", "/") for c in _cells(r)) + " |" for r in rows]
    out += ["", "## Targets (issue 9: at equal or better accuracy)", ""]
    out += [f"* {t}" for t in targets(rows)]
    out += ["", "## How it was measured", "", *NOTES]
    return "\n".join(out) + "\n"


NOTES = [
    "* Wall time: median of the repeats after one warm-up run (ours: at least 20 repeats, peers "
    "5; `--quick`: 1 run, no warm-up), model build included, every step kept, in this "
    "process. 'vs our Newmark' is the row's time over our fixed-step Newmark's on the same "
    "problem.",
    "* Accuracy: against ONE converged reference per problem, the same for every tool: peak "
    "|x| relative error (the SDOF mass; the beam's middle slider), and the largest error of "
    "any contact's start or end time (each reference contact matched with the contact that "
    "starts nearest to it; a different number of contacts is stated in the note).",
    "* vibroimpact: the Python API (`vibroimpact.simulate`), Rust core; impact times and the peak "
    "are located inside the step.",
    "* SciPy: `solve_ivp` phase by phase with terminal events where a gap closes or opens and "
    "a non-terminal event at x' = 0 for the peaks (`vibroimpact.peers.scipy_peer`); its "
    "tolerance is the loosest of 1e-3 ... 1e-11 whose peak and impact-time errors are both at "
    "most our Newmark's, so each SciPy row is at least as accurate as our Newmark.",
    "* OpenSeesPy: `Hertzdamp` (force K δ^n (1 + ξ δ̇/v_imp) with ξ = 3(1 − ce²)/4, i.e. "
    "Lankarani–Nikravesh; its v_imp is the velocity at the step where contact is detected, "
    "not a located crossing) in `zeroLength` elements, Newton, `NormDispIncr` 1e-12, at our "
    "dt; `analyze(1, dt)` in a loop reading `nodeDisp` (a `recorder` with `analyze(N, dt)` "
    "took the same time). Its `GeneralizedAlpha` is not used (PEERS.md: wrong on a linear "
    "SDOF in this version). Peak = largest step value; impact times = linear interpolation "
    "of the clearance crossing between steps.",
    "* Exudyn: `ObjectContactCoordinate` with `impactModel = 1` (restitution chosen so that "
    "its 1.5(1 − e) equals 3(1 − ce²)/4), fixed step, full Newton; peak and impact times from "
    "the stored steps as for OpenSees.",
    "* The hollow shaft: OpenSeesPy with `ElasticTimoshenkoBeam` elements and `-cMass` (its "
    "free-free frequencies equal ours to 9 digits: the same model) and Hertzdamp sliders; "
    "Exudyn with our M and K in an `ObjectGenericODE2`; SciPy on our M and K. These runs are "
    "timed ONCE each (tens of seconds), ours as the median of the repeats.",
]


def cli_main(quick: bool = False, repeats: int | None = None, write: str | None = None,
             as_json: bool = False) -> int:
    """``vibroimpact bench --peers [--quick] [--write FILE.md] [--json]``."""
    import json
    from pathlib import Path

    def log(msg: str) -> None:
        print(f"[bench --peers] {msg}", file=sys.stderr, flush=True)

    rows = run(quick=quick, repeats=repeats, log=log)
    if as_json:
        print(json.dumps({"machine": machine(), "rows": rows, "targets": targets(rows)},
                         default=float))
    else:
        print(format_text(rows))
    if write:
        path = Path(write)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(format_markdown(rows, machine(), quick), encoding="utf-8")
        log(f"wrote {path}")
    return 0
