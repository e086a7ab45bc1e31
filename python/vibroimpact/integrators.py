"""Time integrators (paper §2.3; DESIGN.md §4). Each is a small settings object passed to
:func:`vibroimpact.simulate`; the stepping itself runs in the Rust core."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

from vibroimpact.errors import require

__all__ = ["METHODS", "Integrator", "Newmark", "NewtonOptions", "method_from_options"]


@dataclass(frozen=True)
class NewtonOptions:
    """Newton–Raphson on the gap forces (paper eqs. 22–27).

    ``rtol``: relative tolerance on the increment and the residual of the gap coordinates
    (eq. 27's ``e``, as a fraction); ``atol``: absolute tolerance in m; ``max_iterations`` per
    step; ``max_step_cuts``: how often a failing step may be halved before the run fails.
    """

    rtol: float = 1e-10
    atol: float = 1e-15
    max_iterations: int = 30
    max_step_cuts: int = 12

    def __post_init__(self) -> None:
        require(0 < self.rtol < 1, "solver.rtol", self.rtol, "0 < rtol < 1")
        require(self.atol >= 0, "solver.atol", self.atol, "atol >= 0 in m")
        require(
            isinstance(self.max_iterations, int) and self.max_iterations >= 1,
            "solver.max_iterations",
            self.max_iterations,
            "an integer >= 1",
        )
        require(
            isinstance(self.max_step_cuts, int) and 0 <= self.max_step_cuts <= 40,
            "solver.max_step_cuts",
            self.max_step_cuts,
            "an integer from 0 to 40",
        )

    def to_spec(self) -> dict[str, Any]:
        return {
            "rtol": float(self.rtol),
            "atol": float(self.atol),
            "max_iterations": int(self.max_iterations),
            "max_step_cuts": int(self.max_step_cuts),
        }


@dataclass(frozen=True)
class Integrator:
    """Base of the integrators."""

    name: str = field(default="", init=False)
    newton: NewtonOptions = field(default_factory=NewtonOptions)

    def to_spec(self) -> dict[str, Any]:
        raise NotImplementedError


@dataclass(frozen=True)
class Newmark(Integrator):
    """Newmark-β with Newton–Raphson (paper eqs. 14–27). ``gamma = 1/2, beta = 1/4`` (the
    default) is the average-acceleration rule: unconditionally stable, second order, no
    numerical damping. Stability needs ``gamma >= 1/2`` and ``beta >= (1/2 + gamma)²/4``
    (paper eq. 16)."""

    name: str = field(default="newmark", init=False)
    gamma: float = 0.5
    beta: float = 0.25

    def __post_init__(self) -> None:
        require(
            isinstance(self.gamma, (int, float)) and math.isfinite(self.gamma)
            and self.gamma >= 0.5,
            "solver.gamma",
            self.gamma,
            "gamma >= 0.5 (paper eq. 16)",
        )
        require(
            isinstance(self.beta, (int, float)) and math.isfinite(self.beta) and self.beta > 0,
            "solver.beta",
            self.beta,
            "beta > 0",
        )

    def to_spec(self) -> dict[str, Any]:
        return {"kind": "newmark", "beta": float(self.beta), "gamma": float(self.gamma)}


#: Integrators by their model-file / CLI name (``[solver] method``).
METHODS: dict[str, type[Integrator]] = {"newmark": Newmark}

#: ``[solver]`` options that belong to Newton rather than to the scheme.
NEWTON_OPTIONS = ("rtol", "atol", "max_iterations", "max_step_cuts")


def method_from_options(name: str, options: dict[str, Any] | None = None) -> Integrator:
    """Build an integrator from its name and the ``[solver]`` options that belong to it
    (scheme parameters such as ``gamma``/``beta`` and the Newton options)."""
    from vibroimpact.errors import ModelError

    if name not in METHODS:
        raise ModelError(
            f"solver.method: {name!r} is not valid; expected one of {', '.join(METHODS)}"
        )
    options = dict(options or {})
    newton = NewtonOptions(**{k: options.pop(k) for k in NEWTON_OPTIONS if k in options})
    cls = METHODS[name]
    allowed = {f.name for f in fields(cls) if f.init and f.name != "newton"}
    unknown = sorted(set(options) - allowed)
    if unknown:
        raise ModelError(
            f"solver.{unknown[0]}: not an option of method {name!r}; expected one of "
            f"{', '.join(sorted(allowed | set(NEWTON_OPTIONS)))}"
        )
    return cls(newton=newton, **options)
