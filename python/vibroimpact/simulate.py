"""The one entry point that runs a model: :func:`simulate`."""

from __future__ import annotations

import _signal
import logging
import math
import os
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable, Sequence
from typing import IO, Any

import numpy as np

from vibroimpact import _core
from vibroimpact.errors import (
    ContactResolutionWarning,
    Interrupted,
    ModelError,
    PreRunWarning,
    SolverError,
    StepStabilityWarning,
    require,
)
from vibroimpact.integrators import Integrator, Newmark
from vibroimpact.model import Model, TableLoad, not_finite
from vibroimpact.result import Result

__all__ = [
    "MAX_STEPS",
    "ProgressBar",
    "check_run",
    "contact_periods",
    "pre_run_warnings",
    "simulate",
    "step_stability_messages",
]

#: The method of a run given none (integrators are immutable: one instance serves all runs).
_DEFAULT_METHOD = Newmark()

#: The most fixed steps a run may take (the core refuses more as well).
MAX_STEPS = 1e10

#: Fewer steps than this per estimated contact period draws a :class:`ContactResolutionWarning`.
STEPS_PER_CONTACT_PERIOD = 10


def contact_periods(model: Model) -> list[float | None]:
    """Estimated period (s) of the contact oscillation of each gap: ``2π √(m_eff / k)``, with
    the gap's effective mass ``m_eff = 1 / (b M⁻¹ bᵀ)`` and the secant stiffness
    ``k = K δⁿ⁻¹`` of the law's Hertz-like estimate (``law.contact_stiffness``,
    ``law.exponent``) at the penetration ``δ = ((n+1) E / K)^(1/(n+1))`` that stores the
    energy ``E`` the run can bring to a gap: the initial kinetic and strain energy plus, for
    each load, its amplitude times the largest clearance. (For a Hertz impact this is within 5 %
    of twice the contact duration.) ``None`` for a gap whose law has no stiffness, when no
    energy enters the model (or ``δ`` underflows to 0), or when the structure is stiff enough
    (positive definite ``K``) that this energy cannot close the gap:
    ``E < d² / (2 b K⁻¹ bᵀ)``. Raises :class:`~vibroimpact.ModelError` naming the gap's law
    if an estimate is not a finite number > 0 (absurd stiffness or masses).

    Kept on a model with a dense structure for its initial state (the only part of such a
    model that can change, its arrays being writable: see :meth:`Model.gap_flexibility`), so
    that the fixed-step runs of one model estimate them once."""
    if not model.gaps:
        return []
    st = model.structure
    x0 = np.asarray(model.initial_displacement, dtype=float)
    v0 = np.asarray(model.initial_velocity, dtype=float)
    state = (x0.tobytes(), v0.tobytes())
    kept = model.__dict__.get("_contact_periods")
    if kept is not None and kept[0] == state:
        return list(kept[1])
    reach = max(max(float(g.clearance) for g in model.gaps), 1e-3)
    flexibility, compliance = model.gap_flexibility()
    periods: list[float | None] = []
    # in doubles without warnings: an overflow is an inf (refused below), never an exception
    with np.errstate(all="ignore"):
        energy = 0.5 * np.float64(v0 @ (st.mass @ v0)) + 0.5 * np.float64(x0 @ (st.stiffness @ x0))
        for load in model.applied_loads:
            energy += np.float64(load.peak) * len(load.dofs) * reach
        for g, gap in enumerate(model.gaps):
            try:
                stiffness = np.float64(gap.law.contact_stiffness)
                exponent = np.float64(gap.law.exponent)
            except (AttributeError, NotImplementedError):
                periods.append(None)
                continue
            if not (energy > 0 and stiffness > 0 and flexibility[g] > 0):
                periods.append(None)
                continue
            if 0 < compliance[g] < math.inf and (
                    energy < np.float64(gap.clearance) ** 2 / (2.0 * compliance[g])):
                periods.append(None)  # the gap cannot close
                continue
            m_eff = 1.0 / flexibility[g]
            delta = ((exponent + 1.0) * energy / stiffness) ** (1.0 / (exponent + 1.0))
            if delta == 0:
                periods.append(None)  # too little energy to tell
                continue
            k = stiffness * delta ** (exponent - 1.0)
            period = 2.0 * np.pi * np.sqrt(m_eff / k)
            if not 0 < period < math.inf:
                raise ModelError(
                    f"gaps[{g}].law: the estimated contact period 2 pi sqrt(m_eff / k) = "
                    f"{float(period):g} s (law stiffness {float(stiffness):g}, exponent "
                    f"{float(exponent):g}, effective mass {float(m_eff):g} kg, energy "
                    f"{float(energy):g} J) is not a finite number > 0; expected a law "
                    "stiffness and masses whose contact time scale is a finite double")
            periods.append(float(period))
    if not st.is_sparse:
        object.__setattr__(model, "_contact_periods", (state, tuple(periods)))
    return periods


def check_run(model: Model, t_end: float, dt: float, method: Integrator) -> None:
    """Refuse (:class:`~vibroimpact.ModelError`, naming the field) a run of ``model`` whose
    time scale or loads' energy is not a finite double (``dt`` and ``t_end`` already finite
    and > 0): with fixed steps at most :data:`MAX_STEPS` steps ``t_end / dt``; for each load
    ``½ (F t_end)² Σ_d 1/M_dd`` finite, the kinetic energy its impulse over the run (peak
    force ``F``, :attr:`~vibroimpact.model.Load.peak`) would give the masses of its DOFs
    ``d`` if nothing held them."""
    steps = t_end / dt
    if method.adaptive is None and steps > MAX_STEPS:
        raise ModelError(
            f"solver.dt = {dt:g}: t_end / dt = {steps:.3g} steps (t_end = {t_end:g} s) is more "
            f"than {MAX_STEPS:g}; expected a time step giving at most {MAX_STEPS:g} steps")
    if not model.loads:
        return
    mass = model.structure.mass.diagonal().tolist()
    for i, load in enumerate(model.applied_loads):
        impulse = load.peak * t_end  # Python floats: an overflow is an inf, without a warning
        energy = 0.5 * impulse * impulse * sum(1.0 / mass[d] for d in load.dofs)
        if not math.isfinite(energy):
            key = "scale" if isinstance(load, TableLoad) else "amplitude"
            value = load.scale if isinstance(load, TableLoad) else load.amplitude
            raise not_finite(
                f"loads[{i}].{key}", f"{float(value):g}", f"the energy 1/2 (F t_end)^2 / m of "
                f"its impulse over the run (peak force F = {load.peak:g} N, t_end = "
                f"{t_end:g} s)", "a force whose energy over the run is finite")


def contact_resolution_messages(model: Model, dt: float) -> list[str]:
    """One line per gap whose estimated contact period (:func:`contact_periods`) is shorter
    than ``STEPS_PER_CONTACT_PERIOD`` steps of ``dt``."""
    lines = []
    for g, period in enumerate(contact_periods(model)):
        if period is not None and dt > period / STEPS_PER_CONTACT_PERIOD:
            lines.append(
                f"gap {g}: dt = {dt:.3e} s is larger than a tenth of the estimated contact "
                f"period {period:.3e} s (effective mass and law stiffness); the contact will "
                f"not be resolved: use dt <= {period / (2 * STEPS_PER_CONTACT_PERIOD):.1e} s "
                "or adaptive stepping"
            )
    return lines


def step_stability_messages(model: Model, method: Integrator, dt: float) -> list[str]:
    """One line if ``method`` is only conditionally stable (:class:`~vibroimpact.Newmark`
    with ``2β < γ``: :attr:`~vibroimpact.Newmark.critical_omega_dt`) and ``dt`` exceeds its
    critical step for the structure's highest natural frequency
    (:func:`vibroimpact.fe.modal.highest_angular_frequency`; computed only then)."""
    if not isinstance(method, Newmark) or math.isinf(method.critical_omega_dt):
        return []
    from vibroimpact.fe.modal import highest_angular_frequency

    omega = highest_angular_frequency(model.structure)
    if omega * dt <= method.critical_omega_dt:
        return []
    dt_crit = method.critical_omega_dt / omega
    return [
        f"solver.dt: {dt:.3e} s exceeds the critical step {dt_crit:.3e} s of Newmark with "
        f"gamma = {method.gamma:g}, beta = {method.beta:g} (stable only for beta >= gamma/2 "
        f"or omega*dt <= 1/sqrt(gamma/2 - beta) = {method.critical_omega_dt:.4g}) at the "
        f"structure's highest natural frequency {omega / (2 * math.pi):.4g} Hz: the response "
        f"will grow without bound; use dt <= {dt_crit:.3e} s or beta >= gamma/2 (the bound "
        "is the linear structure's, gaps open; a closed contact lowers it)"
    ]


def pre_run_warnings(model: Model, method: Integrator, dt: float) -> list[PreRunWarning]:
    """The warnings due before a fixed-step run of ``model`` by ``method`` at ``dt`` (none
    with adaptive stepping, whose error control chooses the steps): a step too long for a
    contact (:func:`contact_resolution_messages`) and one beyond a conditionally stable
    method's critical step (:func:`step_stability_messages`)."""
    if method.adaptive is not None:
        return []
    return [*map(ContactResolutionWarning, contact_resolution_messages(model, dt)),
            *map(StepStabilityWarning, step_stability_messages(model, method, dt))]


#: Seconds between two polls of a run in progress (signals, rows, events, progress).
POLL_S = 0.05
#: Wall time, s, after which a run shows its progress bar (``progress=True``).
PROGRESS_DELAY_S = 1.0

log = logging.getLogger("vibroimpact.solver")

#: Test hook (tests/test_interrupt.py): a signal name (``SIGTERM``) in this environment
#: variable makes the process send itself that signal as soon as the core has finished,
#: before the result is converted and written, so that a test can hit that moment exactly.
SIGNAL_AFTER_RUN_ENV = "VIBROIMPACT_TEST_SIGNAL_AFTER_RUN"
#: Its value, read once (``os.environ.get`` of an unset name raises and catches a KeyError).
_SIGNAL_AFTER_RUN = os.environ.get(SIGNAL_AFTER_RUN_ENV)

#: The signals that stop a run, as plain numbers for ``_signal.signal``: the C function that
#: ``signal.signal`` wraps only to convert numbers and handlers to and from enums, at ~4 µs a
#: call (a ``ValueError`` raised and caught for every handler that is a function).
_RUN_SIGNALS = (int(signal.SIGINT), int(signal.SIGTERM))


class ProgressBar:
    """A one-line progress bar on ``stream`` (default stderr) for a run of ``t_end`` s:
    ``[##########..........]  50.0 %  t = 1.000e-02 of 2.000e-02 s  1.3 s``, drawn only once
    the run has taken ``delay`` s of wall time (default :data:`PROGRESS_DELAY_S`), at most
    every 0.1 s, and only when ``stream`` is a terminal (or ``enabled=True``); :meth:`close`
    ends the line. ``clock`` (s) is for tests."""

    WIDTH = 30

    def __init__(self, t_end: float, *, stream: IO[str] | None = None,
                 enabled: bool | None = None, delay: float | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.t_end = t_end
        self.stream = sys.stderr if stream is None else stream
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self.delay = PROGRESS_DELAY_S if delay is None else delay
        self.clock = clock
        self.started = clock()
        self.shown = False
        self.last = -math.inf

    def update(self, t: float, *, final: bool = False) -> None:
        """Show the simulated time ``t`` (s) reached (``final``: the run has ended; drawn
        however soon after the previous update)."""
        now = self.clock()
        elapsed = now - self.started
        if not self.enabled or elapsed < self.delay or (now - self.last < 0.1 and not final):
            return
        self.last = now
        fraction = min(max(t / self.t_end, 0.0), 1.0) if self.t_end > 0 else 1.0
        filled = round(self.WIDTH * fraction)
        bar = "#" * filled + "." * (self.WIDTH - filled)
        self.stream.write(f"\r[{bar}] {100 * fraction:5.1f} %  t = {t:.3e} of "
                          f"{self.t_end:.3e} s  {elapsed:.1f} s")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        """End the bar's line (if it was drawn)."""
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
            self.shown = False


def _log_events(events: list[dict[str, Any]], dropped: int) -> None:
    """Log the core's solver events (``_core.Running.take_events``) at INFO."""
    for e in events:
        kind = e["kind"]
        if kind == "step-cut":
            log.info("solver: t = %.9e s: step cut: Newton did not converge in %d iterations "
                     "(gap %d, penetration %.3e m) on a step of %.3e s; retrying with shorter "
                     "steps", e["t"], e["iterations"], e["gap"], e["penetration"], e["dt"])
        elif kind == "impact":
            log.info("solver: t = %.9e s: gap %d impact (%s wall), approach speed %.4g m/s, "
                     "separation speed %.4g m/s", e["t"], e["gap"], e["side"], e["v_in"],
                     e["v_out"])
        elif kind == "contact-start":
            log.info("solver: t = %.9e s: gap %d closed (%s wall), approach speed %.4g m/s",
                     e["t"], e["gap"], e["side"], e["speed"])
        elif kind == "linear-solver":
            band = "" if e["bandwidth"] is None else f", bandwidth {e['bandwidth']}"
            log.info("solver: effective stiffness (%d DOFs) for steps of %.3e s: %s factor, "
                     "%d stored values%s", e["dofs"], e["dt"], e["solver"], e["stored_values"],
                     band)
        else:
            log.info("solver: t = %.9e s: gap %d opened (%s wall), separation speed %.4g m/s, "
                     "after %d steps in contact and %d Newton iterations (%.2f per step)",
                     e["t"], e["gap"], e["side"], e["speed"], e["steps"], e["iterations"],
                     e["iterations"] / max(e["steps"], 1))
    if dropped:
        log.info("solver: %d events not logged (more than 10000 between two polls)", dropped)


def _run_core(
    spec: dict[str, Any],
    *,
    on_rows: Callable[[dict[str, Any]], None] | None = None,
    chunk_rows: int | None = None,
    progress: ProgressBar | None = None,
) -> tuple[dict[str, Any], int | None]:
    """Run ``spec`` in the core and return its raw output and the signal received, if any.

    The core runs on a Rust worker thread (``_core.start``); this thread polls it every
    :data:`POLL_S` s with the GIL released in between: it hands each block of ``chunk_rows``
    recorded rows to ``on_rows`` (in order; the output then holds only the rows after the last
    block), logs the solver events (when ``vibroimpact.solver`` logs INFO) and updates
    ``progress`` from the simulated time the core publishes. No Python runs inside the time
    loop. On the main thread, ``Ctrl-C`` and SIGTERM are caught while the run lasts: they ask
    the core to stop (``_core.request_interrupt``), which it does within 64 steps, returning
    the results up to then. If ``on_rows`` raises, the run is stopped the same way and the
    exception re-raised. A short run (``run.inline``, ≲ 10 ms) goes at the first ``wait`` on
    this thread with the GIL released, so that no Python handler could run before it ends: no
    handler is installed for it (~5 µs a run) and a signal during it is handled after it, as
    one outside a run."""
    received: list[int] = []
    _core.clear_interrupt()
    events = log.isEnabledFor(logging.INFO)
    run = _core.start(spec, chunk_rows, events)
    previous: dict[int, Any] = {}
    if not run.inline and threading.current_thread() is threading.main_thread():

        def on_signal(signum: int, frame: Any) -> None:
            received.append(signum)
            _core.request_interrupt()

        try:
            for sig in _RUN_SIGNALS:
                previous[sig] = _signal.signal(sig, on_signal)
        except (ValueError, OSError):  # pragma: no cover - no signals here
            pass
    failure: BaseException | None = None
    try:
        while True:
            finished = run.wait(POLL_S)
            rows = run.take_rows()
            if rows is not None and on_rows is not None and failure is None:
                try:
                    on_rows(rows)
                except BaseException as e:  # re-raised once the run has stopped
                    failure = e
                    _core.request_interrupt()
            if events:
                _log_events(*run.take_events())
            if progress is not None:
                progress.update(run.time(), final=finished)
            if finished:
                break
        raw = run.finish()
    finally:
        for sig, old in previous.items():
            _signal.signal(sig, old)
        _core.clear_interrupt()
        if progress is not None:
            progress.close()
    if failure is not None:
        raise failure
    if _SIGNAL_AFTER_RUN:
        os.kill(os.getpid(), signal.Signals[_SIGNAL_AFTER_RUN])
    return raw, (received[0] if received else None)


def simulate(
    model: Model,
    t_end: float,
    dt: float,
    method: Integrator | None = None,
    *,
    every: int = 1,
    dofs: Sequence[int] | None = None,
    throw: bool = True,
    progress: bool = False,
    on_rows: Callable[[dict[str, Any]], None] | None = None,
    chunk_rows: int | None = None,
) -> Result:
    """Integrate ``model`` from ``t = 0`` to ``t_end`` (s) with steps of ``dt`` (s).

    **Arguments:**

    - ``method``: an integrator (default :class:`~vibroimpact.Newmark`, average acceleration).
    - ``every``: keep every k-th step in the time histories (impacts, peaks and the energy
      account still see every step).
    - ``dofs``: the DOFs whose displacement, velocity and acceleration are kept (default all).
    - ``throw``: if the solver fails (Newton after all step cuts, divergence, energy blow-up,
      singular effective stiffness), raise :class:`~vibroimpact.SolverError` carrying the
      partial result; with ``throw=False`` return the partial result with ``complete = False``
      and ``message`` set instead.
    - ``progress``: draw a :class:`ProgressBar` on stderr once the run has taken a second
      (only when stderr is a terminal).
    - ``on_rows``, ``chunk_rows``: stream the time histories: every ``chunk_rows`` recorded
      rows, ``on_rows`` gets them as a dict of arrays (``time``, ``displacement``,
      ``velocity``, ``acceleration``, ``gap_penetration``, ``gap_force``, ``energy``: a dict
      of the energy terms), in order, while the run goes on, and the returned result holds
      only the rows recorded after the last block (its impact table, peaks, statistics and
      energy balance error are those of the whole run). Memory then holds at most three
      blocks. :func:`vibroimpact.io.results_file.simulate_to_file` uses this to write long
      runs to disk.

    With ``logging.getLogger("vibroimpact.solver")`` at INFO (``vibroimpact run --verbose``)
    the solver's events are logged as they happen: each step cut (time, gap, penetration,
    Newton iterations; fixed steps), each contact's start and end (time, gap, wall, approach
    and separation speeds, its steps and Newton iterations).

    ``Ctrl-C`` or SIGTERM during the run (on the main thread) stops it within 64 steps and
    raises :class:`~vibroimpact.Interrupted` (a ``SolverError``, whatever ``throw`` says) with
    the results up to then in ``partial`` (a run short enough, ≲ 10 ms, to go on the calling
    thread is not stopped: a signal during it is handled after it, as one outside a run).
    A step longer than a tenth of a gap's estimated contact period (:func:`contact_periods`)
    draws a :class:`~vibroimpact.ContactResolutionWarning` before the run, and a step beyond
    the critical step of a conditionally stable Newmark (``2β < γ``) for the structure's
    highest natural frequency a :class:`~vibroimpact.StepStabilityWarning` (fixed steps only:
    :func:`pre_run_warnings`).

    ``dt`` is reduced slightly, if needed, so that ``t_end`` is a whole number of steps. With
    adaptive stepping (``method.adaptive``), ``dt`` is the first step and ``every`` counts
    accepted steps.

    **Example:** ``vi.simulate(model, t_end=0.02, dt=1e-6).impacts``
    """
    require(isinstance(model, Model), "model", type(model).__name__, "a vibroimpact.Model")
    for name, value in (("solver.t_end", t_end), ("solver.dt", dt)):
        require(
            isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value) and value > 0,
            name,
            value,
            "a number > 0 in s",
        )
    if dt > t_end:  # (the message formatted only then: a float's repr costs ~1 µs a run)
        require(False, "solver.dt", dt, f"dt <= t_end = {t_end}")
    require(
        isinstance(every, int) and every >= 1, "output.every", every, "an integer >= 1"
    )
    method = _DEFAULT_METHOD if method is None else method
    require(isinstance(method, Integrator), "solver.method", method, "a vibroimpact integrator")
    check_run(model, float(t_end), float(dt), method)
    n = model.n_dof
    if dofs is None:
        record = list(range(n))
    else:
        record = [int(d) for d in dofs]
        bad = [d for d in record if not 0 <= d < n]
        if bad:
            raise ModelError(f"output.dofs: {bad[0]} is out of range; expected 0 <= dof < {n}")
    spec = model._run_spec()
    spec.update(
        method._run_spec(),
        t_end=float(t_end),
        dt=float(dt),
        every=int(every),
        record_dofs=record,
    )
    for warning in pre_run_warnings(model, method, float(dt)):
        warnings.warn(warning, stacklevel=2)
    if chunk_rows is not None or on_rows is not None:
        require(isinstance(chunk_rows, int) and not isinstance(chunk_rows, bool)
                and chunk_rows >= 1 and callable(on_rows), "chunk_rows", chunk_rows,
                "an integer >= 1 together with a callable on_rows")
    bar = ProgressBar(float(t_end)) if progress else None
    raw, signum = _run_core(spec, on_rows=on_rows, chunk_rows=chunk_rows, progress=bar)
    result = Result.from_core(raw, model=model, method=method, t_end=float(t_end))
    if signum is not None or raw.get("error_kind") == "interrupted":
        signum = int(signal.SIGINT) if signum is None else signum
        name = signal.Signals(signum).name
        message = (f"{result.message} ({name})" if not result.complete
                   else f"{name} received as the run finished at t = {result.time[-1]:.9e} s")
        raise Interrupted(message, partial=result, signum=signum)
    if not result.complete and throw:
        raise SolverError(result.message, partial=result)
    return result
