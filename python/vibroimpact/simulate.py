"""The one entry point that runs a model: :func:`simulate`."""

from __future__ import annotations

import math
from collections.abc import Sequence

from vibroimpact import _core
from vibroimpact.errors import ModelError, SolverError, require
from vibroimpact.integrators import Integrator, Newmark
from vibroimpact.model import Model
from vibroimpact.result import Result

__all__ = ["simulate"]


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
    - ``throw``: if the solver fails (Newton after all step cuts, divergence), raise
      :class:`~vibroimpact.SolverError` carrying the partial result; with ``throw=False`` return
      the partial result with ``complete = False`` and ``message`` set instead.

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
    raw = _core.simulate(spec)
    result = Result.from_core(raw, model=model, method=method, t_end=float(t_end))
    if not result.complete and throw:
        raise SolverError(result.message, partial=result)
    return result
