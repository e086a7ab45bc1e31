"""``vibroimpact bench --peers``: the paper's SDOF case at equal accuracy (issue 20, item 3).

Every tool runs a ladder of settings (a step ``dt`` or a tolerance ``rtol``, loosest first);
each setting's run is timed (median of repeats, in this process) and measured against ONE
converged reference: the largest error of the contacts' peaks ``|x|`` (m) and of their start
and end times (s). A tool's row is the loosest setting of its ladder that meets
:data:`PEAK_TARGET_M` and :data:`TIME_TARGET_S` with the reference's number of contacts
(:func:`loosest_passing`), timed again beside ours (ours: the fastest of our methods at its
own loosest passing setting); a tool no setting of whose ladder meets them is listed with its
best errors. Every point of every ladder is also the Pareto figure (:func:`pareto_figure`).

The reference: our DOP853 at rtol 1e-13 (contacts located on its dense output), checked
against SciPy's DOP853 with events at rtol 1e-12, the tightest of its ladder
(:func:`vibroimpact.benchmarks.peers.reference.converged`, independent of the engine)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vibroimpact.benchmarks.peers import exudyn_peer, opensees_peer, scipy_peer
from vibroimpact.benchmarks.peers.problems import SdofProblem
from vibroimpact.benchmarks.peers.reference import (
    contact_pairs,
    converged,
    impact_time_error,
)

__all__ = ["PEAK_TARGET_M", "TIME_TARGET_S", "Ladder", "contact_errors", "equal_accuracy",
           "loosest_passing", "ours_contacts", "pareto_figure", "reference"]

#: Issue 20's accuracy: the contacts' peaks within this (m) and their times within
#: :data:`TIME_TARGET_S` (s) of the converged reference.
PEAK_TARGET_M = 1e-7
TIME_TARGET_S = 1e-8

#: The ladders, loosest first: fixed steps (s) and relative tolerances.
DT_LADDER = (4e-6, 2e-6, 1e-6, 5e-7, 2.5e-7, 1.25e-7, 6.25e-8)
RTOL_LADDER = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
#: ``--quick`` (a smoke test): two rungs each.
QUICK_DT_LADDER = (2e-6, 1e-6)
QUICK_RTOL_LADDER = (1e-6, 1e-8)

#: Our reference's tolerance, and how close (as a fraction of the targets) it must agree with
#: SciPy's tightest run for the table to be meaningful.
REFERENCE_RTOL = 1e-13
REFERENCE_AGREEMENT = 0.01

#: The largest step of our adaptive methods (s) and their first step.
DT_MAX = 1e-3
FIRST_DT = 1e-5


@dataclass(frozen=True)
class Ladder:
    """One tool's settings: ``run(value)`` (one run, model build included, every step kept)
    returns ``impacts`` (``[t_start, t_end]`` rows) and ``contact_peaks`` (max |x| of each);
    ``kind`` is ``"dt"`` (s) or ``"rtol"``; ``missing``: why the tool cannot run (None if it
    can)."""

    tool: str
    method: str
    kind: str
    values: tuple[float, ...]
    run: Callable[[float], dict[str, Any]]
    missing: str | None = None
    ours: bool = False

    def setting(self, value: float) -> str:
        return f"dt {value:g} s" if self.kind == "dt" else f"rtol {value:g}"


def contact_errors(out: dict[str, Any], ref: dict[str, Any]) -> tuple[float, float, str]:
    """(largest |peak − reference peak| over the contacts, m; largest impact-time error, s;
    note) of a run ``out`` against ``ref``, contacts paired as
    :func:`~vibroimpact.benchmarks.peers.reference.contact_pairs` pairs them (infinite errors if
    there is no contact to pair)."""
    pairs = contact_pairs(out["impacts"], ref["impacts"])
    if not pairs:
        return math.inf, math.inf, f"{len(out['impacts'])} contacts vs {len(ref['impacts'])}"
    peak = max(abs(float(out["contact_peaks"][i]) - float(ref["contact_peaks"][j]))
               for i, j in pairs)
    time, note = impact_time_error(out["impacts"], ref["impacts"])
    return peak, time, note


def meets(point: dict[str, Any], contacts: int) -> bool:
    """Whether a measured ``point`` meets both targets with ``contacts`` contacts."""
    return (point.get("time_s") is not None and point["contacts"] == contacts
            and point["peak_error_m"] <= PEAK_TARGET_M
            and point["impact_time_error_s"] <= TIME_TARGET_S)


def loosest_passing(points: Sequence[dict[str, Any]], contacts: int) -> int | None:
    """Index of the loosest point (``points`` are loosest first) that :func:`meets` the
    targets, or None."""
    return next((i for i, pt in enumerate(points) if meets(pt, contacts)), None)


def _best(points: Sequence[dict[str, Any]]) -> int | None:
    """Index of the point nearest to the targets (smallest worse ratio of error to target)."""
    timed = [i for i, pt in enumerate(points) if pt.get("time_s") is not None]
    return min(timed, default=None, key=lambda i: max(
        points[i]["peak_error_m"] / PEAK_TARGET_M,
        points[i]["impact_time_error_s"] / TIME_TARGET_S))


def ours_contacts(result: Any, model: Any) -> dict[str, Any]:
    """Our run's contacts in start order: ``impacts`` (``[t_start, t_end]``, ``t_end`` None if
    still closed) and ``contact_peaks`` (clearance + largest penetration: max |x| of the gap
    DOF in that contact)."""
    imp = result.impacts
    rows = sorted(zip(imp.t_start, imp.t_end, imp.delta_max, imp.gap, strict=True),
                  key=lambda r: r[0])
    return {"impacts": [[float(a), float(b) if math.isfinite(b) else None]
                        for a, b, _, _ in rows],
            "contact_peaks": [float(model.gaps[int(g)].clearance) + float(dm)
                              for _, _, dm, g in rows]}


def _ours_run(model: Any, t_end: float, method: Callable[[float], Any], fixed: bool
              ) -> Callable[[float], dict[str, Any]]:
    from vibroimpact.simulate import simulate

    def run(value: float) -> dict[str, Any]:
        res = simulate(model, t_end=t_end, dt=value if fixed else FIRST_DT, method=method(value))
        return ours_contacts(res, model)

    return run


def reference(p: SdofProblem) -> dict[str, Any]:
    """Our DOP853 at :data:`REFERENCE_RTOL` on ``p``, with ``check``: its peak and time errors
    against SciPy's DOP853 with events at rtol 1e-12; raises if they are not within
    :data:`REFERENCE_AGREEMENT` of the targets or the contacts differ in number."""
    from vibroimpact.integrators import Adaptive, Dop853

    model = p.model()
    run = _ours_run(model, p.t_end, lambda r: Dop853(adaptive=Adaptive(
        rtol=r, atol=r * 0.1 * p.length_scale, dt_max=DT_MAX)), fixed=False)
    ours = run(REFERENCE_RTOL)
    scipy_ref = converged(p)
    pe, te, note = contact_errors(ours, scipy_ref)
    if (note or pe > REFERENCE_AGREEMENT * PEAK_TARGET_M
            or te > REFERENCE_AGREEMENT * TIME_TARGET_S):
        raise RuntimeError(f"{p.key}: the reference (our DOP853 rtol {REFERENCE_RTOL:g}) is "
                           f"{pe:.1e} m / {te:.1e} s from SciPy DOP853 rtol 1e-12 {note}; "
                           "expected agreement well within the targets")
    return {**ours, "check": (pe, te)}


def ladders(p: SdofProblem, quick: bool) -> list[Ladder]:
    """Our DOP853, adaptive Newmark, Newmark and precise integration; SciPy DOP853 with
    events; OpenSeesPy Newmark; Exudyn Newmark (``--quick``: two rungs each)."""
    from vibroimpact.integrators import Adaptive, Dop853, Newmark, PreciseIntegration

    dts = QUICK_DT_LADDER if quick else DT_LADDER
    rtols = QUICK_RTOL_LADDER if quick else RTOL_LADDER
    model = p.model()

    def adaptive(r: float) -> Any:
        return Adaptive(rtol=r, atol=r * 0.1 * p.length_scale, dt_max=DT_MAX)

    def ours(method: str, kind: str, values: tuple[float, ...],
             make: Callable[[float], Any]) -> Ladder:
        return Ladder("vibroimpact", method, kind, values,
                      _ours_run(model, p.t_end, make, fixed=kind == "dt"), ours=True)

    return [
        ours("DOP853", "rtol", rtols, lambda r: Dop853(adaptive=adaptive(r))),
        ours("Newmark adaptive", "rtol", rtols[:-2] if not quick else rtols,
             lambda r: Newmark(adaptive=adaptive(r))),
        ours("Newmark", "dt", dts, lambda _dt: Newmark()),
        ours("precise (Adams)", "dt", dts, lambda _dt: PreciseIntegration()),
        Ladder("SciPy", "DOP853 with events", "rtol", rtols,
               lambda r: scipy_peer.run_sdof(p, "DOP853", r)),
        Ladder("OpenSeesPy", "Newmark", "dt", dts,
               lambda dt: opensees_peer.run_sdof(p, "newmark", dt), opensees_peer.available()),
        Ladder("Exudyn", "Newmark", "dt", dts,
               lambda dt: exudyn_peer.run_sdof(p, "newmark", dt), exudyn_peer.available()),
    ]


def measure(ladder: Ladder, ref: dict[str, Any], repeats: int) -> list[dict[str, Any]]:
    """Every setting of ``ladder``: median wall time of ``repeats`` runs and the errors
    against ``ref`` (a run that fails gives a point with its reason and no time)."""
    from vibroimpact.benchmarks.peers.table import _quiet_fds, _timed

    points = []
    for value in ladder.values:
        point: dict[str, Any] = {"tool": ladder.tool, "method": ladder.method,
                                 "setting": ladder.setting(value), "kind": ladder.kind,
                                 "value": value, "time_s": None, "repeats": 0, "note": ""}
        try:
            with _quiet_fds():
                secs, out, _ = _timed(lambda v=value: ladder.run(v), repeats)
        except Exception as e:  # a peer's failure at one setting is reported, not raised
            point["note"] = f"failed: {type(e).__name__}: {e}"
            points.append(point)
            continue
        pe, te, note = contact_errors(out, ref)
        point.update(time_s=secs, repeats=repeats, peak_error_m=pe, impact_time_error_s=te,
                     contacts=len(out["impacts"]), note=note)
        point["meets"] = meets(point, len(ref["impacts"]))
        points.append(point)
    return points


def equal_accuracy(p: SdofProblem, quick: bool, repeats: int, ours_repeats: int,
                   log: Callable[[str], None]) -> dict[str, Any]:
    """The table and the figure's points on ``p``: ``rows`` (one per ladder, ours first: the
    fastest of ours is the base of every ratio), ``points`` (every setting) and
    ``reference`` (what it is and its check against SciPy)."""
    from vibroimpact.benchmarks.peers.table import _quiet_fds, _timed

    log(f"{p.key} at equal accuracy: reference (our DOP853 rtol {REFERENCE_RTOL:g}, checked "
        "against SciPy DOP853 rtol 1e-12)")
    ref = reference(p)
    contacts = len(ref["impacts"])
    measured = []
    for ladder in ladders(p, quick):
        if ladder.missing:
            measured.append((ladder, []))
            continue
        log(f"{p.key} at equal accuracy: {ladder.tool} {ladder.method}, "
            f"{len(ladder.values)} settings")
        measured.append((ladder, measure(ladder, ref, ours_repeats if ladder.ours else repeats)))
    chosen = [(ladder, pts, loosest_passing(pts, contacts)) for ladder, pts in measured]
    ours = [(ladder, pts[i]) for ladder, pts, i in chosen if ladder.ours and i is not None]
    if not ours:
        raise RuntimeError(f"{p.key}: none of our methods meets {PEAK_TARGET_M:g} m / "
                           f"{TIME_TARGET_S:g} s on its ladder")
    base_ladder, base_point = min(ours, key=lambda lp: lp[1]["time_s"])

    def base_run() -> Any:
        return base_ladder.run(base_point["value"])

    rows = []
    for ladder, pts, i in sorted(chosen, key=lambda c: (c[0] is not base_ladder,
                                                        not c[0].ours)):
        row: dict[str, Any] = {"tool": ladder.tool, "method": ladder.method}
        if ladder.missing:
            rows.append({**row, "setting": "", "time_s": None, "ratio": None, "meets": False,
                         "note": f"not available: {ladder.missing}"})
            continue
        j = i if i is not None else _best(pts)
        if j is None:
            rows.append({**row, "setting": "", "time_s": None, "ratio": None, "meets": False,
                         "note": "; ".join(dict.fromkeys(pt["note"] for pt in pts))})
            continue
        pt = pts[j]
        if ladder is base_ladder:
            secs, ratio = pt["time_s"], 1.0
            n = pt["repeats"]
        else:
            n = ours_repeats if ladder.ours else repeats
            with _quiet_fds():
                secs, _, base_s = _timed(lambda v=pt["value"], lad=ladder: lad.run(v), n,
                                         base_run)
            ratio = secs / base_s if base_s else None
        why = ("the loosest setting of its ladder that meets both" if i is not None else
               f"no setting of its ladder ({ladder.setting(ladder.values[0])} ... "
               f"{ladder.setting(ladder.values[-1])}) meets both: its best errors")
        rows.append({**row, "setting": pt["setting"], "value": pt["value"], "meets": i is not None,
                     "peak_error_m": pt["peak_error_m"],
                     "impact_time_error_s": pt["impact_time_error_s"],
                     "contacts": pt["contacts"], "time_s": secs, "repeats": n, "ratio": ratio,
                     "note": "; ".join(x for x in (why, pt["note"]) if x)})
    return {"problem": p.key, "rows": rows,
            "points": [pt for _, pts in measured for pt in pts],
            "missing": {f"{lad.tool} {lad.method}": lad.missing
                        for lad, _ in measured if lad.missing},
            "reference": {"what": f"our DOP853 rtol {REFERENCE_RTOL:g} (atol "
                                  f"{REFERENCE_RTOL * 0.1 * p.length_scale:g} m)",
                          "contacts": contacts, "peak_m": max(ref["contact_peaks"]),
                          "scipy_check_peak_m": ref["check"][0],
                          "scipy_check_time_s": ref["check"][1]},
            "targets": {"peak_m": PEAK_TARGET_M, "time_s": TIME_TARGET_S}}


def pareto_figure(eq: dict[str, Any], path: Path) -> None:
    """Error against wall time (log–log), one line per tool and method through its ladder
    (every setting; the row's setting circled), the peaks' and the impact times' errors side
    by side, the targets dashed; written to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5), constrained_layout=True)
    chosen = {(r["tool"], r["method"], r.get("setting")) for r in eq["rows"] if r.get("meets")}
    series: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for pt in eq["points"]:
        if pt["time_s"] is not None:
            series.setdefault((pt["tool"], pt["method"]), []).append(pt)
    floor = 1e-16  # an error of exactly zero is drawn here, on the log axis
    for ax, key, target, label in (
            (axes[0], "peak_error_m", PEAK_TARGET_M, "largest error of the contacts' peaks |x|, m"),
            (axes[1], "impact_time_error_s", TIME_TARGET_S,
             "largest error of the contacts' start/end times, s")):
        for (tool, method), pts in series.items():
            t = np.array([pt["time_s"] for pt in pts])
            e = np.maximum([pt[key] for pt in pts], floor)
            style = "-" if tool == "vibroimpact" else "--"
            (line,) = ax.loglog(t, e, style, marker="o", ms=4, label=f"{tool} {method}")
            for pt, ti, ei in zip(pts, t, e, strict=True):
                if (tool, method, pt["setting"]) in chosen:
                    ax.loglog([ti], [ei], "o", ms=11, mfc="none", color=line.get_color())
        ax.axhline(target, color="k", ls=":", lw=1)
        ax.set_xlabel("wall time per run (median), s")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{eq['problem']}: error against wall time, every tool and setting (target "
                 f"{PEAK_TARGET_M:g} m / {TIME_TARGET_S:g} s dotted; circled: the loosest "
                 "setting that meets both)", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


HEADER = ["tool", "method", "loosest setting that meets", "meets", "peak error",
          "impact-time error", "wall time (median)", "runs", "vs ours", "note"]
POINT_HEADER = ["tool", "method", "setting", "meets", "peak error", "impact-time error",
                "contacts", "wall time (median)", "runs", "note"]


def _time(s: float | None) -> str:
    if s is None:
        return "-"
    return f"{s * 1e3:.3g} ms" if s < 1 else f"{s:.3g} s"


def _err(x: float | None, unit: str) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.1e} {unit}"


def row_cells(r: dict[str, Any]) -> list[str]:
    """A table row's cells (:data:`HEADER`)."""
    timed = r["time_s"] is not None
    return [r["tool"], r["method"], r["setting"] or "-",
            ("yes" if r["meets"] else "no") if timed else "-",
            _err(r.get("peak_error_m"), "m"), _err(r.get("impact_time_error_s"), "s"),
            _time(r["time_s"]), str(r.get("repeats", "-")) if timed else "-",
            "-" if r["ratio"] is None else f"{r['ratio']:.3g}x", r["note"]]


def point_cells(pt: dict[str, Any]) -> list[str]:
    """A ladder point's cells (:data:`POINT_HEADER`)."""
    timed = pt["time_s"] is not None
    return [pt["tool"], pt["method"], pt["setting"],
            ("yes" if pt["meets"] else "no") if timed else "-",
            _err(pt.get("peak_error_m"), "m"), _err(pt.get("impact_time_error_s"), "s"),
            str(pt["contacts"]) if timed else "-", _time(pt["time_s"]),
            str(pt["repeats"]) if timed else "-", pt["note"]]


def describe(eq: dict[str, Any]) -> str:
    """One sentence: the targets, the reference and its check."""
    ref = eq["reference"]
    return (f"{eq['problem']} at equal accuracy: each tool at the loosest setting of its ladder "
            f"whose contacts' peaks are within {PEAK_TARGET_M:g} m and whose impact times are "
            f"within {TIME_TARGET_S:g} s of the reference ({ref['what']}: {ref['contacts']} "
            f"contacts, peak {ref['peak_m'] * 1e3:.6f} mm; against SciPy DOP853 with events "
            f"at rtol 1e-12: {ref['scipy_check_peak_m']:.1e} m, "
            f"{ref['scipy_check_time_s']:.1e} s); ratios to our fastest method there, timed "
            "beside it")
