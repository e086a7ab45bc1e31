"""The one entry point that runs a model: :func:`simulate`."""

from __future__ import annotations

import math
import signal
import threading
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from vibroimpact import _core
from vibroimpact.errors import (
    ContactResolutionWarning,
    Interrupted,
    ModelError,
    SolverError,
    require,
)
from vibroimpact.integrators import Integrator, Newmark
from vibroimpact.model import Model
from vibroimpact.result import Result

__all__ = ["contact_periods", "simulate"]

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
    energy enters the model, or when the structure is stiff enough (positive definite ``K``)
    that this energy cannot close the gap: ``E < d² / (2 b K⁻¹ bᵀ)``."""
    if not model.gaps:
        return []
    st = model.structure
    x0 = np.asarray(model.initial_displacement, dtype=float)
    v0 = np.asarray(model.initial_velocity, dtype=float)
    energy = 0.5 * float(v0 @ st.mass @ v0) + 0.5 * float(x0 @ st.stiffness @ x0)
    reach = max((float(g.clearance) for g in model.gaps), default=0.0)
    for load in model.loads:
        amplitude = getattr(load, "amplitude", None)
        if amplitude is None:  # a table: its largest force
            amplitude = float(np.max(np.abs(getattr(load, "force", (0.0,))))) * float(
                getattr(load, "scale", 1.0))
        energy += abs(float(amplitude)) * len(load.dofs) * max(reach, 1e-3)
    n_gaps = len(model.gaps)
    b = np.zeros((model.n_dof, n_gaps))
    for g, gap in enumerate(model.gaps):
        for d, c in zip(gap.dofs, gap.coefficients or (1.0,) * len(gap.dofs), strict=True):
            b[d, g] += c
    mass = st.mass
    diagonal = np.diagonal(mass)
    if np.array_equal(mass, np.diag(diagonal)):  # lumped masses: no solve
        flexibility = np.einsum("ig,ig->g", b, b / diagonal[:, None])
    else:
        flexibility = np.einsum("ig,ig->g", b, np.linalg.solve(mass, b))
    # compliance b K⁻¹ bᵀ of each gap when K is positive definite (else: unbounded)
    compliance = np.full(n_gaps, math.inf)
    if np.any(st.stiffness):
        try:
            np.linalg.cholesky(st.stiffness)
            compliance = np.einsum("ig,ig->g", b, np.linalg.solve(st.stiffness, b))
        except np.linalg.LinAlgError:  # only positive semi-definite
            pass
    periods: list[float | None] = []
    for g, gap in enumerate(model.gaps):
        try:
            stiffness, exponent = float(gap.law.contact_stiffness), float(gap.law.exponent)
        except (AttributeError, NotImplementedError):
            periods.append(None)
            continue
        if not (energy > 0 and stiffness > 0 and flexibility[g] > 0):
            periods.append(None)
            continue
        if 0 < compliance[g] < math.inf and (
                energy < float(gap.clearance) ** 2 / (2.0 * compliance[g])):
            periods.append(None)  # the gap cannot close
            continue
        m_eff = 1.0 / flexibility[g]
        delta = ((exponent + 1.0) * energy / stiffness) ** (1.0 / (exponent + 1.0))
        k = stiffness * delta ** (exponent - 1.0)
        periods.append(2.0 * math.pi * math.sqrt(m_eff / k))
    return periods


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


def _run_core(spec: dict[str, Any]) -> tuple[dict[str, Any], int | None]:
    """``_core.simulate(spec)``, interruptible. The core runs on a Rust worker thread while
    the calling thread waits with the GIL released and lets Python handle signals every 50 ms:
    ``Ctrl-C`` (KeyboardInterrupt) and, on the main thread, SIGTERM (a temporary handler) ask
    the core to stop (``_core.request_interrupt``); it stops within 64 steps and returns the
    results up to then. Returns the raw output and the signal received, if any."""
    received: list[int] = []

    def on_sigterm(signum: int, frame: Any) -> None:
        received.append(signum)
        _core.request_interrupt()

    previous = None
    if threading.current_thread() is threading.main_thread():
        try:
            previous = signal.signal(signal.SIGTERM, on_sigterm)
        except (ValueError, OSError):  # pragma: no cover - no signals here
            previous = None
    _core.clear_interrupt()
    try:
        raw = _core.simulate(spec)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        _core.clear_interrupt()
    if raw.get("keyboard_interrupt"):
        return raw, int(signal.SIGINT)
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

    ``Ctrl-C`` or SIGTERM during the run (on the main thread) stops it within ~1000 steps and
    raises :class:`~vibroimpact.Interrupted` (a ``SolverError``, whatever ``throw`` says) with
    the results up to then in ``partial``. A step longer than a tenth of a gap's estimated
    contact period (:func:`contact_periods`) draws a :class:`~vibroimpact.ContactResolutionWarning`
    before the run (fixed steps only).

    ``dt`` is reduced slightly, if needed, so that ``t_end`` is a whole number of steps. With
    adaptive stepping (``method.adaptive``), ``dt`` is the first step and ``every`` counts
    accepted steps.

    **Example:** ``vi.simulate(model, t_end=0.02, dt=1e-6).impacts``
    """
    require(isinstance(model, Model), "model", type(model).__name__, "a vibroimpact.Model")
    for name, value, unit in (("solver.t_end", t_end, "s"), ("solver.dt", dt, "s")):
        require(
            isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value) and value > 0,
            name,
            value,
            f"a number > 0 in {unit}",
        )
    require(dt <= t_end, "solver.dt", dt, f"dt <= t_end = {t_end}")
    require(
        isinstance(every, int) and every >= 1, "output.every", every, "an integer >= 1"
    )
    method = Newmark() if method is None else method
    require(isinstance(method, Integrator), "solver.method", method, "a vibroimpact integrator")
    n = model.n_dof
    record = list(range(n)) if dofs is None else [int(d) for d in dofs]
    bad = [d for d in record if not 0 <= d < n]
    if bad:
        raise ModelError(f"output.dofs: {bad[0]} is out of range; expected 0 <= dof < {n}")
    spec = model.to_spec()
    spec.update(
        t_end=float(t_end),
        dt=float(dt),
        every=int(every),
        record_dofs=record,
        method=method.to_spec(),
        newton=method.newton.to_spec(),
        adaptive=None if method.adaptive is None else method.adaptive.to_spec(t_end, dt),
    )
    if method.adaptive is None:
        for line in contact_resolution_messages(model, float(dt)):
            warnings.warn(line, ContactResolutionWarning, stacklevel=2)
    raw, signum = _run_core(spec)
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
