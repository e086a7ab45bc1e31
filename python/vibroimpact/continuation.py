"""Pseudo-arclength continuation of periodic orbits in a model parameter, with their stability
and special points (docs/periodic-orbits.md, Continuation).

The unknowns are ``y = (z, p)``: the state on the section and the parameter (any number a
sweep can set: :func:`vibroimpact.sweeps.apply`). Each point solves ``P^N(z; p) − z = 0`` plus
the arclength condition ``t·(y − y_pred) = 0`` by Newton with the Jacobian
``[Φ − I, ∂P^N/∂p]``: ``Φ`` from the core's state-transition matrix, the parameter column from
the core too where it carries it (DOP853, the Newmark family and the event-driven method, for
a load's amplitude, frequency or phase and a gap's clearance), else
by a central difference of the simulated map
(:func:`parameter_column`; :attr:`Branch.parameter_column` says which). The
unknowns are scaled (the state by its largest component at the start, the parameter by the
range) so that the arclength weighs both. The tangent comes from the bordered system with the
previous tangent as its last row, which keeps its orientation through a fold.

Special points are sign changes between two points of a test function, located by the
Illinois (regula falsi) iteration on the arclength from the first point:

* ``fold``: ``det(Φ − I)`` (a multiplier through +1) while the bordered determinant keeps its
  sign; ``branch-point``: the bordered determinant ``det [[Φ − I, ∂P/∂p], tᵀ]`` changes sign;
* ``period-doubling``: ``det(Φ + I)`` (a multiplier through −1);
* ``neimark-sacker``: ``Π_{i<j} (μ_i μ_j − 1)`` with a complex pair on the unit circle there;
* ``grazing``, per wall: the smallest distance to the wall over the orbit while nothing
  touches it, minus the largest penetration (compliant laws) or the smallest impact speed
  (rigid stops) while something does. A rigid stop's impact speed falling to zero is
  continued through onto the orbit clear of the stop (:func:`_through_grazing`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from vibroimpact.errors import ModelError, SolverError
from vibroimpact.integrators import Integrator
from vibroimpact.model import Model
from vibroimpact.orbit_basis import BlockJacobian
from vibroimpact.orbits import DenseJacobian, Shooting, contact_onsets, solve_orbit
from vibroimpact.sweeps.grid import canonical_path, units_of

__all__ = ["BRANCH_KIND", "SPECIAL_POINT_TYPES", "Branch", "BranchPoint", "SpecialPoint",
           "continue_orbit", "parameter_column"]

#: The ``kind`` attribute of a branch's Dataset (its ``.nc`` file).
BRANCH_KIND = "vibroimpact-branch"
#: The ``type`` of a special point (public names: JSON, the ``.nc`` file).
SPECIAL_POINT_TYPES = ("fold", "period-doubling", "neimark-sacker", "grazing", "branch-point")

#: The relative step of the parameter column's central difference: ``ε^(1/3)``, which balances
#: its truncation error ``O(h²)`` against rounding ``O(ε/h)``.
PARAMETER_STEP = 6e-6
#: Newton iterations of a corrector before the step is called failed (and shortened).
MAX_CORRECTOR_ITERATIONS = 10
#: A residual above this fraction of the last one takes the parameter column again.
SLOW_CONTRACTION = 0.01
#: Step control: grow by this factor after a point that took at most ``FAST`` iterations,
#: shrink by ``SHRINK`` after one that took ``SLOW`` or more, or after a failure.
GROW, SHRINK, FAST, SLOW = 1.5, 0.5, 3, 6
#: Steps tried (each half the last) onto the period-2 branch at a period-doubling.
SWITCH_ATTEMPTS = 12
#: Iterations locating a special point, and the arclength (scaled) it is located to.
MAX_LOCATE_ITERATIONS = 40
LOCATE_TOLERANCE = 1e-13
#: A trial point of a special point's location is corrected to this fraction of the
#: continuation's residual, or to the residual itself where the map is not that smooth (the
#: Newmark family's converged steps: their own Newton's tolerance).
LOCATE_RESIDUAL = 0.01
#: A located zero's test function must be below this fraction of its values at the ends.
LOCATED_FRACTION = 1e-3
#: At a located fold, period-doubling or Neimark–Sacker point a multiplier must be this close to
#: the critical one (else the test function jumped: a grazing, not that bifurcation).
CRITICAL_MULTIPLIER_TOLERANCE = 1e-3


class _StepFailed(Exception):
    """A corrector that did not converge (or left the model's valid values)."""


def _check_count(value: Any, name: str, low: int) -> int:
    if not (isinstance(value, int) and not isinstance(value, bool) and value >= low):
        raise ModelError(f"{name}: {value!r} is not valid; expected an integer >= {low}")
    return value


@dataclass(frozen=True)
class BranchPoint:
    """A periodic orbit on a branch: the parameter ``value``, the orbit's ``periods`` (forcing
    periods), the ``state`` on the section, the ``monodromy`` and its ``multipliers`` (largest
    modulus first), each DOF's ``displacement_max``/``displacement_min`` over the orbit, its
    ``impacts_per_period`` (contact onsets over the orbit's period), ``wall_margins`` (per wall: the
    grazing test function, see the module doc), its ``arclength`` (scaled units) and
    ``impact_speed_max`` (per gap)."""

    value: float
    periods: int
    state: NDArray[np.float64]
    monodromy: NDArray[np.float64]
    multipliers: NDArray[np.complex128]
    displacement_max: NDArray[np.float64]
    displacement_min: NDArray[np.float64]
    impacts_per_period: int
    wall_margins: NDArray[np.float64]
    arclength: float
    #: Per gap: the largest approach speed of its impacts over the orbit, m/s (0 without).
    impact_speed_max: NDArray[np.float64]
    #: In a reduced basis: the complement's multipliers (``monodromy`` and ``multipliers``
    #: are then ``Φ_r``'s, as :class:`vibroimpact.PeriodicOrbit`'s); None for the full ``Φ``.
    complement_multipliers: NDArray[np.complex128] | None = None

    @property
    def stable(self) -> bool:
        """Every multiplier inside the unit circle (the complement's too)."""
        largest = float(np.max(np.abs(self.multipliers)))
        extra = self.complement_multipliers
        if extra is not None and extra.size:
            largest = max(largest, float(np.max(np.abs(extra))))
        return largest < 1.0

    def summary(self) -> dict[str, Any]:
        """The point as ``vibroimpact continue --json`` prints it."""
        return {"value": self.value, "stable": self.stable,
                "multipliers": _pairs(self.multipliers),
                "displacement_max": self.displacement_max.tolist(),
                "displacement_min": self.displacement_min.tolist(),
                "impacts_per_period": self.impacts_per_period,
                "forcing_periods": self.periods}


@dataclass(frozen=True)
class SpecialPoint:
    """A located special point: its ``type`` (one of :data:`SPECIAL_POINT_TYPES`) and the
    orbit there."""

    type: str
    point: BranchPoint

    def summary(self) -> dict[str, Any]:
        return {"type": self.type, "value": self.point.value,
                "multipliers": _pairs(self.point.multipliers),
                "arclength": self.point.arclength}


@dataclass(frozen=True)
class Branch:
    """The points of a branch in order of arclength and its located special points. With
    ``switch``, the points after the first period-doubling are on its period-2 branch."""

    parameter: str
    points: tuple[BranchPoint, ...]
    special_points: tuple[SpecialPoint, ...]
    #: The displacement unit of each DOF (``m`` or ``rad``; the model's).
    dof_units: tuple[str, ...] = ()
    #: Why the branch ended before the range's end or ``max_points`` (empty otherwise): at a
    #: rigid stop's grazing with no orbit clear of the stop past it.
    stopped: str = ""
    #: How ``∂P^N/∂p`` was taken: ``"exact"`` (the core's column, beside ``Φ``) or
    #: ``"central difference: <why the core has no column>"``.
    parameter_column: str = "exact"
    #: The reduced basis of the monodromy in words ("" for the full ``Φ``).
    basis: str = ""

    def summary(self) -> dict[str, Any]:
        """The JSON of ``vibroimpact continue --json``: ``parameter`` (the path), ``points``
        and ``special_points`` (in a reduced basis also ``basis``)."""
        return {"parameter": self.parameter,
                "points": [p.summary() for p in self.points],
                "special_points": [s.summary() for s in self.special_points],
                **({"basis": self.basis} if self.basis else {})}

    def to_dataset(self) -> xr.Dataset:
        """The branch along its arclength (dimension ``point``, coordinate ``arclength``): the
        parameter (variable ``parameter``, its path in the attribute ``path``), ``stable``,
        ``forcing_periods``, ``impacts_per_period``, ``displacement_max``/``_min`` (point, dof),
        ``state`` (point, component: the section's displacements then velocities),
        ``multiplier_real``/``_imag`` (point, multiplier), ``impact_speed_max`` (point, gap),
        the coordinate ``dof_unit`` (dof) and the attribute ``kind = "vibroimpact-branch"``; the
        special points along dimension ``special`` (and the attributes ``stopped``: why the
        branch ended early, if it did, ``parameter_column``: how ``∂P/∂p`` was taken, and in
        a reduced basis ``basis``, the basis in words):
        ``special_type``, ``special_value``, ``special_arclength``,
        ``special_multiplier_real``/``_imag``."""
        pts, sps = self.points, self.special_points
        n_mult = pts[0].multipliers.size
        multipliers = np.array([p.multipliers for p in pts])
        special = (np.array([s.point.multipliers for s in sps]) if sps
                   else np.zeros((0, n_mult), dtype=complex))
        ds = xr.Dataset(
            {
                "parameter": ("point", [p.value for p in pts],
                              {"path": self.parameter, "units": units_of(self.parameter)}),
                "stable": ("point", np.array([p.stable for p in pts], dtype=np.int8)),
                "forcing_periods": ("point", [p.periods for p in pts]),
                "impacts_per_period": ("point", [p.impacts_per_period for p in pts]),
                "displacement_max": (("point", "dof"), [p.displacement_max for p in pts]),
                "displacement_min": (("point", "dof"), [p.displacement_min for p in pts]),
                "state": (("point", "component"), [p.state for p in pts]),
                "impact_speed_max": (("point", "gap"), [p.impact_speed_max for p in pts],
                                     {"units": "m/s"}),
                "multiplier_real": (("point", "multiplier"), multipliers.real),
                "multiplier_imag": (("point", "multiplier"), multipliers.imag),
                "special_type": ("special", np.array([s.type for s in sps], dtype=str)),
                "special_value": ("special", [s.point.value for s in sps]),
                "special_arclength": ("special", [s.point.arclength for s in sps]),
                "special_multiplier_real": (("special", "multiplier"), special.real),
                "special_multiplier_imag": (("special", "multiplier"), special.imag),
            },
            coords={"arclength": ("point", [p.arclength for p in pts]),
                    **({"dof_unit": ("dof", list(self.dof_units))} if self.dof_units else {})},
            attrs={"parameter": self.parameter, "kind": BRANCH_KIND, "stopped": self.stopped,
                   "parameter_column": self.parameter_column,
                   **({"basis": self.basis} if self.basis else {})},
        )
        return ds


def _pairs(multipliers: NDArray[np.complex128]) -> list[list[float]]:
    return [[float(m.real), float(m.imag)] for m in multipliers]


def parameter_column(shooting: Shooting, z: NDArray[np.float64], path: str, value: float,
                     scale: float, relative_step: float = PARAMETER_STEP
                     ) -> NDArray[np.float64]:
    """``∂P^N/∂p`` at ``(z, value)`` by the central difference
    ``(P^N(z; p + h) − P^N(z; p − h)) / 2h`` of the simulated map, ``h = relative_step ·
    max(|p|, scale)``: an approximation (error ``O(h²)`` plus rounding ``O(ε/h)``, about 1e-10
    relative where the map is smooth), for a parameter or method whose column the core does not
    carry. When ``p`` is a load's frequency each side runs its own forcing period."""
    h = relative_step * max(abs(value), scale)
    up, down = (shooting.at(path, value + sign * h) for sign in (1, -1))
    return (up.state_at(z, up.duration) - down.state_at(z, down.duration)) / (2 * h)


@dataclass
class _Solution:
    """A corrected point with what the next step needs: the scaled unknowns ``u``, the
    parameter column and the tangent (scaled)."""

    point: BranchPoint
    u: NDArray[np.float64]
    column: NDArray[np.float64]
    jacobian: Jacobian
    tangent: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    tests: dict[str, NDArray[np.float64]] = field(default_factory=dict)


#: ``∂P^N/∂z`` at a point: the full ``Φ`` or, in a reduced basis, its blocks.
Jacobian = DenseJacobian | BlockJacobian


#: A wall's measure at a state's displacements and velocities: its distance towards the wall
#: and that distance's rate.
_Measure = Callable[[NDArray[np.float64], NDArray[np.float64]], tuple[float, float]]


def _wall_measure(gap: Any, sign: int, dofs: list[int],
                  coefficients: NDArray[np.float64]) -> _Measure:
    """Wall ``sign`` of ``gap``'s measure: the gap coordinate times ``sign``, or for a radial
    gap's wall (``sign = 0``) the distance ``ρ`` from the stator's centre and ``δ̇``."""
    if sign == 0:
        def radius(x: NDArray[np.float64], v: NDArray[np.float64]) -> tuple[float, float]:
            delta, rate = gap.penetration(x, v)
            return delta + float(gap.clearance), rate
        return radius

    def coordinate(x: NDArray[np.float64], v: NDArray[np.float64]) -> tuple[float, float]:
        return sign * float(x[dofs] @ coefficients), sign * float(v[dofs] @ coefficients)
    return coordinate


class _Continuation:
    """The continuation of one branch of ``shooting``'s orbits in ``path``."""

    def __init__(self, shooting: Shooting, path: str, start: float, end: float,
                 z_scale: float, tol: float) -> None:
        self.shooting = shooting
        self.path = path
        self.start, self.end = start, end
        self.scale = abs(end - start)
        n = shooting.n_state
        self.weights = np.append(np.full(n, 1.0 / z_scale), 1.0 / self.scale)
        self.tol = tol
        # per wall its gap and sign (a radial gap's one wall: 0)
        self.walls = [(g, sign) for g, gap in enumerate(shooting.model.gaps)
                      for sign in {"positive": (1,), "negative": (-1,), "both": (1, -1),
                                   "radial": (0,)}[gap.side]]

    # --- the map at a parameter value ----------------------------------------------------

    def at(self, value: float) -> Shooting:
        return self.shooting.at(self.path, value)

    def column(self, y: NDArray[np.float64], raw: dict[str, Any]) -> NDArray[np.float64]:
        """``∂P^N/∂p`` at ``y``: the core's column in its output ``raw`` of the flow from
        there, else the central difference."""
        exact = raw["parameter_column"]
        if exact is not None:
            return np.asarray(exact, dtype=float)
        return parameter_column(self.shooting, y[:-1], self.path, float(y[-1]), self.scale)

    def correct(self, u0: NDArray[np.float64], row: NDArray[np.float64], target: float,
                column: NDArray[np.float64], tol: float | None = None
                ) -> tuple[NDArray[np.float64], Jacobian, dict[str, Any],
                           NDArray[np.float64], int]:
        """Newton on ``P^N(z; p) − z = 0`` and ``row · u = target`` (scaled ``u``) from
        ``u0``, with the core's parameter column at each iterate, or without one the central
        difference ``column`` kept while the residual falls fast (a chord in that column),
        taken again at the iterate where it does not. Returns ``u``, the Jacobian
        (:meth:`Shooting.linearised`: in a reduced basis a quasi-Newton iteration), the
        core's output there, the last column (the core's: at ``u``) and the iterations."""
        tol = self.tol if tol is None else tol
        w = self.weights
        u = u0.copy()
        previous = math.inf
        for iteration in range(MAX_CORRECTOR_ITERATIONS + 1):
            y = u / w
            try:
                end, phi, raw = self.at(float(y[-1])).linearised(y[:-1])
                if raw["parameter_column"] is not None:
                    column = np.asarray(raw["parameter_column"], dtype=float)
                residual = end - y[:-1]
                norm = float(np.linalg.norm(residual))
                if norm <= tol * max(float(np.linalg.norm(y[:-1])), 1e-300) and iteration > 0:
                    return u, phi, raw, column, iteration
                if iteration == MAX_CORRECTOR_ITERATIONS:
                    break
                if norm > SLOW_CONTRACTION * previous:  # the kept column is too far off
                    column = self.column(y, raw)
            except (ModelError, SolverError) as e:
                raise _StepFailed(str(e)) from None
            previous = norm
            try:
                du = phi.solve_bordered(column, w, row, -np.append(residual, row @ u - target))
            except np.linalg.LinAlgError:
                break
            if not np.all(np.isfinite(du)):
                break
            u = u + du
        raise _StepFailed(f"Newton did not converge in {MAX_CORRECTOR_ITERATIONS} iterations")

    def tangent(self, phi: Jacobian, column: NDArray[np.float64],
                previous: NDArray[np.float64]) -> NDArray[np.float64]:
        """The unit tangent (scaled) oriented as ``previous``: the bordered system's
        solution for ``[0, …, 0, 1]``."""
        rhs = np.append(np.zeros(self.shooting.n_state), 1.0)
        t = phi.solve_bordered(column, self.weights, previous, rhs)
        return t / np.linalg.norm(t)

    # --- a point and its test functions ---------------------------------------------------

    def point(self, u: NDArray[np.float64], phi: Jacobian, raw: dict[str, Any],
              arclength: float, refine: bool = False) -> BranchPoint:
        y = u / self.weights
        shooting = self.at(float(y[-1]))
        return BranchPoint(
            value=float(y[-1]), periods=shooting.periods, state=y[:-1].copy(),
            monodromy=phi.monodromy, multipliers=phi.multipliers,
            displacement_max=np.asarray(raw["displacement_max"], dtype=float),
            displacement_min=np.asarray(raw["displacement_min"], dtype=float),
            impacts_per_period=contact_onsets(raw["impacts"]["t_start"]),
            wall_margins=self.wall_margins(shooting, y[:-1], raw, refine),
            arclength=arclength,
            impact_speed_max=self.impact_speeds(raw),
            complement_multipliers=phi.complement_multipliers)

    def impact_speeds(self, raw: dict[str, Any]) -> NDArray[np.float64]:
        """Per gap: the largest approach speed of its impacts in the core's output ``raw``."""
        impacts = raw["impacts"]
        speeds = np.abs(np.asarray(impacts["v_in"], dtype=float))
        speeds[~np.isfinite(speeds)] = 0.0
        return np.array([float(np.max(speeds[impacts["gap"] == g], initial=0.0))
                         for g in range(len(self.shooting.model.gaps))])

    def wall_margins(self, shooting: Shooting, z: NDArray[np.float64], raw: dict[str, Any],
                     refine: bool) -> NDArray[np.float64]:
        """Per wall, the grazing test function (module doc). The distance: for a gap on one
        DOF, from that DOF's extremes over the orbit (located inside the steps: exact for the
        event-driven flights, DOP853's interpolant); for a gap coordinate of several DOFs (a
        radial gap: the distance ``ρ`` from the stator's centre), from its largest recorded
        value, and with ``refine`` at the instant its rate vanishes, found by the Illinois
        iteration on runs that end there."""
        impacts = raw["impacts"]
        x = np.asarray(raw["displacement"], dtype=float)
        v = np.asarray(raw["velocity"], dtype=float)
        t = np.asarray(raw["time"], dtype=float)
        margins = []
        for g, sign in self.walls:
            gap, numbers = self.shooting.model.gaps[g], shooting.spec["gaps"][g]
            side = {1: 1, -1: 0, 0: 2}[sign]
            here = (impacts["gap"] == g) & (impacts["side"] == side)
            if here.any():
                if gap.law.impulsive:
                    margins.append(-float(np.min(np.abs(impacts["v_in"][here]))))
                else:
                    margins.append(-float(np.nanmax(impacts["delta_max"][here])))
                continue
            dofs = tuple(numbers["dofs"])
            coefficients = np.asarray(numbers["coefficients"], dtype=float)
            clearance = float(numbers["clearance"])
            measure = _wall_measure(gap, sign, list(dofs), coefficients)
            if len(dofs) == 1 and sign != 0:
                c = sign * float(coefficients[0])
                extreme = raw["displacement_max" if c > 0 else "displacement_min"]
                margins.append(clearance - c * float(extreme[dofs[0]]))
                continue
            u = [measure(xi, vi)[0] for xi, vi in zip(x, v, strict=True)]
            k = int(np.argmax(u))
            peak = float(u[k])
            if refine:
                peak = self._refined_peak(shooting, z, t, k, measure)
            margins.append(clearance - peak)
        return np.array(margins)

    @staticmethod
    def _refined_peak(shooting: Shooting, z: NDArray[np.float64], t: NDArray[np.float64],
                      k: int, measure: _Measure) -> float:
        """The largest value of a gap's ``measure`` (its value and rate at a state's
        displacements and velocities) near the recorded step ``k``."""
        n, period = shooting.model.n_dof, shooting.duration

        def coordinate(s: float) -> tuple[float, float]:
            state = shooting.state_at(z, s - period if s > period else
                                      (s + period if s <= 0 else s))
            return measure(state[:n], state[n:])

        last = t.size - 1
        left = t[k - 1] if k > 0 else t[last - 1] - period
        right = t[k + 1] if k < last else period + t[1]
        a, (_, fa) = left, coordinate(left)
        b, (_, fb) = right, coordinate(right)
        if not fa > 0 > fb:
            return coordinate(float(t[k]))[0]
        root = _illinois(lambda s: coordinate(s)[1], a, fa, b, fb,
                         1e-15 * period, MAX_LOCATE_ITERATIONS)
        return coordinate(root)[0]

    def tests(self, sol: _Solution) -> dict[str, NDArray[np.float64]]:
        """The test functions at a solution whose tangent is set (in a reduced basis the
        complement's blocks are factors of each determinant: see
        :class:`~vibroimpact.orbit_basis.BlockJacobian`)."""
        phi = sol.jacobian
        return {
            "fold": np.array([phi.determinant(-1.0)]),
            "period-doubling": np.array([phi.determinant(1.0)]),
            "neimark-sacker": np.array([phi.pair_test()]),
            "branch-point": np.array([phi.bordered_determinant(sol.column, self.weights,
                                                               sol.tangent)]),
            "grazing": sol.point.wall_margins,
        }

    # --- a step and a special point --------------------------------------------------------

    def step(self, sol: _Solution, ds: float, refine: bool = False,
             tol: float | None = None, value: float | None = None,
             guard: bool = True) -> tuple[_Solution, int]:
        """The corrected point at arclength ``ds`` along ``sol``'s tangent (or, given
        ``value``, the one at that parameter value predicted from there), with its
        parameter column, tangent and test functions. ``guard``: fail if the corrector moved
        farther than ``ds`` from the prediction (onto another branch)."""
        predicted = sol.u + ds * sol.tangent
        row = sol.tangent
        if value is not None:
            row = np.zeros(sol.u.size)
            row[-1] = 1.0
            predicted[-1] = value * self.weights[-1]
            guard = False
        u, phi, raw, column, iterations = self.correct(predicted, row, row @ predicted,
                                                       sol.column, tol)
        if guard and np.linalg.norm(u - predicted) > max(ds, 1e-12):
            # onto another branch (an impact lost or gained by a large Newton step)
            raise _StepFailed(f"the corrector moved {np.linalg.norm(u - predicted):.3g} from "
                              f"the prediction, more than the step {ds:.3g}")
        moved = ds if value is None else float(np.linalg.norm(u - sol.u))
        try:
            point = self.point(u, phi, raw, sol.point.arclength + moved, refine)
            if column is sol.column:
                column = self.column(u / self.weights, raw)
        except (ModelError, SolverError) as e:
            raise _StepFailed(str(e)) from None
        new = _Solution(point=point, u=u, column=column, jacobian=phi)
        new.tangent = self.tangent(phi, column, sol.tangent)
        new.tests = self.tests(new)
        return new, iterations

    def locate(self, sol: _Solution, new: _Solution, kind: str, index: int,
               ds: float) -> _Solution | None:
        """The point between ``sol`` and ``new`` (``ds`` apart) where test ``kind``'s
        component ``index`` vanishes, or None where the iteration fails there."""
        refine = kind == "grazing"
        cache: dict[float, _Solution] = {}

        def test(s: float) -> float:
            for tol in (LOCATE_RESIDUAL * self.tol, self.tol):
                try:
                    cache[s] = self.step(sol, s, refine=refine, tol=tol, guard=False)[0]
                    return float(cache[s].tests[kind][index])
                except _StepFailed:
                    pass  # the map's own noise may be above the tighter residual
            raise _LocateFailed

        try:
            fa = test(1e-300) if refine else float(sol.tests[kind][index])
            fb = test(ds) if refine else float(new.tests[kind][index])
            if fa * fb > 0:
                return None
            s = _illinois(test, 0.0, fa, ds, fb, LOCATE_TOLERANCE, MAX_LOCATE_ITERATIONS)
            if s not in cache:
                test(s)
        except _LocateFailed:
            return None
        if np.linalg.norm(cache[s].u - sol.u) > 2 * ds:  # the corrector left the segment
            return None
        if abs(cache[s].tests[kind][index]) > LOCATED_FRACTION * max(abs(fa), abs(fb)):
            return None  # the test function jumps there (the branch changed orbits), no zero
        return cache[s]


class _LocateFailed(Exception):
    pass


def _illinois(f: Callable[[float], float], a: float, fa: float, b: float, fb: float,
              tol: float, max_iterations: int) -> float:
    """A root of ``f`` in ``[a, b]`` with ``fa``, ``fb`` of opposite signs: the Illinois
    variant of regula falsi (bracketing, superlinear for a smooth ``f``)."""
    side = 0
    s = b
    for _ in range(max_iterations):
        s = (a * fb - b * fa) / (fb - fa)
        fs = f(s)
        if fs == 0 or abs(b - a) <= tol:
            return s
        if (fs > 0) == (fa > 0):
            a, fa = s, fs
            if side == -1:
                fb /= 2
            side = -1
        else:
            b, fb = s, fs
            if side == 1:
                fa /= 2
            side = 1
    return s


def _critical(kind: str, point: BranchPoint) -> bool:
    """Whether the located ``kind`` point has its critical multiplier (module doc)."""
    mu = point.multipliers
    if kind in ("fold", "branch-point"):
        return bool(np.min(np.abs(mu - 1)) < CRITICAL_MULTIPLIER_TOLERANCE)
    if kind == "period-doubling":
        return bool(np.min(np.abs(mu + 1)) < CRITICAL_MULTIPLIER_TOLERANCE)
    if kind == "neimark-sacker":
        pair = mu[np.abs(mu.imag) > 1e-9]
        return bool(pair.size and np.min(np.abs(np.abs(pair) - 1))
                    < CRITICAL_MULTIPLIER_TOLERANCE)
    return True


def continue_orbit(model: Model, parameter: str, start: float, end: float, *,
                   period: int = 1, transient: int = 50, method: Integrator | None = None,
                   dt: float | None = None, max_points: int = 200, step: float = 0.02,
                   max_step: float = 0.1, min_step: float = 1e-7, tol: float = 1e-10,
                   switch: bool = False, modes: int | None = None) -> Branch:
    """The branch of periodic orbits of ``period`` forcing periods through the one found at
    ``parameter = start`` (as :func:`vibroimpact.periodic_orbit` finds it after ``transient``
    forcing periods), continued by pseudo-arclength until the parameter reaches ``end``
    (or ``start`` again, after a fold) or ``max_points`` points. ``parameter``: a path of
    ``sweep --param`` (``loads.0.frequency``, ``gaps.0.clearance``, ...). ``step``,
    ``max_step``, ``min_step``: arclength steps in scaled units (the parameter by
    ``|end − start|``, the state by its largest component at the start); ``tol``: Newton's
    relative residual. ``switch``: at the first period-doubling, go on along its period-2
    branch. ``method``, ``dt``, ``modes``: as :class:`vibroimpact.orbits.Shooting` (above
    its dense limit, or with ``modes``, the monodromy in a reduced basis: each point is the
    full model's orbit, corrected by a quasi-Newton iteration with the block Jacobian
    :class:`~vibroimpact.orbit_basis.BlockJacobian` and the full map's central-difference
    parameter column; docs/periodic-orbits.md, "Large structures").

    Raises :class:`ModelError` for a bad parameter path or value and :class:`SolverError` if
    the first orbit is not found or a step fails at ``min_step``.

    **Example:** ``vi.continue_orbit(model, "loads.0.frequency", 0.15, 0.2).special_points``
    """
    path = canonical_path(parameter)
    for name, value in (("start", start), ("end", end)):
        if not (isinstance(value, (int, float)) and not isinstance(value, bool)
                and math.isfinite(value)):
            raise ModelError(f"--param {path}: {name} = {value!r} is not valid; expected a "
                             "finite number")
    if start == end:
        raise ModelError(f"--param {path}: start = end = {start!r}; expected two different "
                         "values")
    _check_count(max_points, "--max-points", 2)
    _check_count(transient, "--transient", 0)
    base = Shooting(model, period, method, dt, modes)
    first = base.at(path, start)
    base.at(path, end).linearised(np.zeros(base.n_state))  # a bad END is refused first
    z = np.concatenate([np.asarray(model.initial_displacement, dtype=float),
                        np.asarray(model.initial_velocity, dtype=float)])
    try:
        z = solve_orbit(first, first.settle(z, transient), tol).state
    except SolverError as e:
        raise SolverError(f"continuation: no periodic orbit found at {path} = {start:g}: "
                          f"{e}") from None
    scale = max(float(np.max(np.abs(z))), 1e-300)
    run = _Continuation(base, path, float(start), float(end), scale, tol)
    u = np.append(z, start) * run.weights
    row = np.zeros(u.size)
    row[-1] = 1.0
    _, phi, raw = first.linearised(z)
    note = raw["parameter_column_note"]
    sol = _Solution(point=run.point(u, phi, raw, 0.0), u=u,
                    column=run.column(u / run.weights, raw), jacobian=phi)
    sol.tangent = run.tangent(phi, sol.column, np.sign(end - start) * row)
    sol.tests = run.tests(sol)
    points, specials = [sol.point], []
    ds, switched, stop = float(step), False, ""
    low, high = min(start, end), max(start, end)
    while len(points) < max_points:
        try:
            new, iterations = run.step(sol, ds)
        except _StepFailed as e:
            ds *= SHRINK
            if ds < min_step:
                through = (_through_grazing(run, points, sol, low, high, into_contact=True)
                           if len(points) > 1 else None)
                if through is not None:
                    specials.append(through[0])
                    points.append(through[1].point)
                    sol, ds = through[1], float(step)
                    continue
                grazing = _rigid_grazing(run, points, sol)
                if grazing is None:
                    raise SolverError(f"continuation: the step fell below {min_step:g} at "
                                      f"{path} = {sol.point.value:.9g} after {len(points)} "
                                      f"points ({e})") from None
                specials.append(grazing)
                stop = (f"stopped at the grazing of a rigid stop at {path} = "
                        f"{grazing.point.value:.9g}: no orbit clear of the stop was found "
                        "past it")
                break
            continue
        value = new.point.value
        last = not low < value < high
        if not low <= value <= high:  # the last point on the range's end
            bound = high if value > high else low
            fraction = (bound - sol.point.value) / (value - sol.point.value)
            try:
                new, _ = run.step(sol, ds * min(max(fraction, 0.0), 1.0), value=bound)
            except _StepFailed:
                pass
        for kind in SPECIAL_POINT_TYPES:
            if kind == "fold" and np.any(sol.tests["branch-point"] * new.tests["branch-point"]
                                         < 0):
                continue
            for i in np.flatnonzero(sol.tests[kind] * new.tests[kind] < 0):
                located = run.locate(sol, new, kind, int(i), new.point.arclength
                                     - sol.point.arclength)
                if located is not None and _critical(kind, located.point):
                    specials.append(SpecialPoint(kind, located.point))
        if (switch and not switched and specials
                and specials[-1].type == "period-doubling"):
            switched = True
            points.append(specials[-1].point)
            # at the initial step, not a grown one: the period-2 branch leaves at a right
            # angle, and a long first step can land on another orbit (the rigid stop's
            # period-doubling at step 0.1: an unstable period-2 orbit 0.009 further in w)
            run, new = _switch(run, specials[-1], min(ds, float(step)))
        points.append(new.point)
        through = None if last else _through_grazing(run, points, new, low, high)
        if through is not None:  # a rigid stop's grazing ahead: past it, clear of the stop
            specials.append(through[0])
            points.append(through[1].point)
            new = through[1]
        sol = new
        if last:
            break
        if iterations <= FAST:
            ds = min(ds * GROW, max_step)
        elif iterations >= SLOW:
            ds *= SHRINK
    specials.sort(key=lambda s: s.point.arclength)
    return Branch(parameter=path, points=tuple(points), special_points=tuple(specials),
                  dof_units=tuple(model.structure.dof_units), stopped=stop,
                  parameter_column=f"central difference: {note}" if note else "exact",
                  basis=base.basis.describe() if base.basis is not None else "")


#: A rigid wall's grazing test function (its distance, or minus the impact speed) this small
#: against the wall's clearance (at least 1) at a branch's last point is a grazing at hand.
GRAZING_END = 1e-3
#: A rigid wall's impact speed falling below this fraction of its largest along the branch is
#: a grazing at hand too: near it the multipliers grow as the inverse of the speed, Newton
#: slows and the steps shrink, so that the branch would crawl there.
GRAZING_FRACTION = 1e-3
#: Tries, each twice as far past the estimated grazing, of an orbit clear of the stop.
THROUGH_ATTEMPTS = 20
#: The clearance of the gap taken away to find the orbit clear of its stop.
FAR = 1e12
#: Periods run from the orbit clear of a compliant wall, past its grazing, before the orbit in
#: contact there is solved for.
THROUGH_SETTLE = 60


def _rigid_wall_grazing(run: _Continuation,
                        points: list[BranchPoint]) -> tuple[int, float] | None:
    """The rigid wall (index in ``run.walls``) whose impact speed falls to zero ahead of the
    last of ``points`` (below ``GRAZING_END`` or ``GRAZING_FRACTION`` of its largest on them),
    and the parameter value where the secant of its speed through the last two vanishes; None
    if there is none."""
    previous, last = points[-2], points[-1]
    for i, (g, _) in enumerate(run.walls):
        gap = run.shooting.model.gaps[g]
        fa, fb = float(previous.wall_margins[i]), float(last.wall_margins[i])
        if not (gap.law.impulsive and fa < fb < 0):
            continue
        largest = max(-float(p.wall_margins[i]) for p in points)
        near = GRAZING_END * max(abs(float(gap.clearance)), 1.0)
        if -fb < near or -fb < GRAZING_FRACTION * largest:
            return i, last.value - fb * (last.value - previous.value) / (fb - fa)
    return None


def _compliant_wall_grazing(run: _Continuation,
                            points: list[BranchPoint]) -> tuple[int, float] | None:
    """The compliant wall (index in ``run.walls``) that the orbit clear of it approaches
    ahead of the last of ``points``: its distance falls at the last two points and is below
    ``GRAZING_END`` of its clearance, or ``GRAZING_FRACTION`` of its largest on them; and the
    parameter value where the secant of the distance through them vanishes; None if none."""
    previous, last = points[-2], points[-1]
    for i, (g, _) in enumerate(run.walls):
        gap = run.shooting.model.gaps[g]
        fa, fb = float(previous.wall_margins[i]), float(last.wall_margins[i])
        if gap.law.impulsive or not fa > fb > 0:
            continue
        largest = max(float(p.wall_margins[i]) for p in points)
        if fb < GRAZING_END * abs(float(gap.clearance)) or fb < GRAZING_FRACTION * largest:
            return i, last.value - fb * (last.value - previous.value) / (fb - fa)
    return None


def _through_grazing(run: _Continuation, points: list[BranchPoint], sol: _Solution,
                     low: float, high: float, into_contact: bool = False
                     ) -> tuple[SpecialPoint, _Solution] | None:
    """The grazing of a rigid stop that the branch ``points`` reaches after its last, ``sol``
    (at least two points), and the first point past it, on the branch clear of the stop; None
    if there is no grazing at hand (:func:`_rigid_wall_grazing`) or no such orbit in
    ``[low, high]``. ``into_contact``: the other way, the grazing of a compliant wall
    (:func:`_compliant_wall_grazing`) that the branch clear of it reaches where the corrector
    fails (a whole orbit touching at once, an isotropic rotor's rub onset: every iterate near it
    touches the wall at a few points, a different piece of the map each time), and the first
    point past it in contact: the orbit clear of the wall corrected on the model itself.

    Clear of the stop, the orbit is that of the model whose gap is moved away (clearance
    ``FAR``: nothing impacts there, so nothing at zero speed either), and its distance to the
    wall is smooth in the parameter: its zero, bracketed between the last point and the first
    value past the secant's estimate where the distance is positive and located by the
    Illinois iteration, is the grazing, and the orbit there is the grazing orbit (its
    multipliers those of the flow clear of the stop). The first point past it is that orbit,
    corrected on the model itself, at the bracket's far end."""
    found = (_compliant_wall_grazing if into_contact else _rigid_wall_grazing)(run, points)
    if found is None:
        return None
    wall, estimate = found
    side = -1.0 if into_contact else 1.0  # the sign of the clear orbit's distance past it
    # into contact, the first point past it penetrates by GRAZING_END of the clearance (its
    # corrector clear of the few-touch pieces of the map next to the grazing)
    beyond = (GRAZING_END * abs(float(run.shooting.model.gaps[run.walls[wall][0]].clearance))
              if into_contact else 0.0)
    g = run.walls[wall][0]
    row = np.zeros(sol.u.size)
    row[-1] = 1.0

    def clear(value: float) -> tuple[float, NDArray[np.float64], BranchPoint]:
        away = run.at(value).at(f"gaps.{g}.clearance", FAR)
        z = solve_orbit(away, sol.point.state, run.tol).state
        _, phi, raw = away.linearised(z)
        u = np.append(z, value) * run.weights
        point = run.point(u, phi, raw, sol.point.arclength, refine=True)
        return float(point.wall_margins[wall]), u, point

    a, b = sol.point.value, estimate
    try:
        fa = clear(a)[0]
        step = b - a
        for _ in range(THROUGH_ATTEMPTS):
            fb, u_far, _ = clear(b)
            if side * fb > beyond:
                break
            b += step
            step *= 2
        else:
            return None
        if not (side * fa < 0 < side * fb and low <= b <= high):
            return None
        cache: dict[float, tuple[NDArray[np.float64], BranchPoint]] = {}

        def margin(value: float) -> float:
            f, u, point = clear(value)
            cache[value] = (u, point)
            return f

        at = _illinois(margin, a, fa, b, fb, LOCATE_TOLERANCE * run.scale,
                       MAX_LOCATE_ITERATIONS)
        if at not in cache:
            margin(at)
        u_grazing, grazing = cache[at]
        grazing = replace(grazing, arclength=sol.point.arclength
                          + float(np.linalg.norm(u_grazing - sol.u)))
    except (_StepFailed, _LocateFailed, ModelError, SolverError):
        return None
    # the first point past it: the clear orbit at b corrected on the model (into contact:
    # after THROUGH_SETTLE periods on it, the clear orbit being far from the one in contact
    # for a stiff wall); a b where the corrector fails is moved farther
    for _ in range(THROUGH_ATTEMPTS):
        try:
            if into_contact:
                here = run.at(b)
                settled = here.settle(u_far[:-1] / run.weights[:-1], THROUGH_SETTLE)
                u_far = np.append(solve_orbit(here, settled, run.tol).state, b) * run.weights
            u, phi, raw, column, _ = run.correct(u_far, row, u_far[-1], sol.column)
            moved = float(np.linalg.norm(u - u_grazing))
            point = run.point(u, phi, raw, grazing.arclength + moved)
            # (not back across the wall)
            if side * point.wall_margins[wall] > 0:
                if column is sol.column:
                    column = run.column(u / run.weights, raw)
                break
        except (_StepFailed, ModelError, SolverError):
            pass
        b += step
        step *= 2
        if not low <= b <= high:
            return None
        try:
            u_far = clear(b)[1]
        except (_StepFailed, ModelError, SolverError):
            return None
    else:
        return None
    new = _Solution(point=point, u=u, column=column, jacobian=phi)
    new.tangent = run.tangent(phi, column, (u - u_grazing) / moved)
    new.tests = run.tests(new)
    return SpecialPoint("grazing", grazing), new


def _rigid_grazing(run: _Continuation, points: list[BranchPoint],
                   sol: _Solution) -> SpecialPoint | None:
    """The grazing of a rigid stop where the branch that cannot go on from ``sol`` ends, or
    None if it does not end at one: the grazing test function of a rigid wall (its distance,
    or minus the impact speed) at the last two points is small (``GRAZING_END``) and goes to
    zero, and its zero is found by the secant through them (both points end at the grazing
    orbit; the event-driven method has no derivative at an impact at zero speed, so the
    corrector fails there). The orbit reported is the one corrected at that value, or the
    last point's if the corrector fails there."""
    if len(points) < 2:
        return None
    previous, last = points[-2], sol.point
    for i, (g, _) in enumerate(run.walls):
        gap = run.shooting.model.gaps[g]
        fa, fb = float(previous.wall_margins[i]), float(last.wall_margins[i])
        near = GRAZING_END * max(abs(float(gap.clearance)), 1.0)
        if not (gap.law.impulsive and abs(fb) < near and abs(fb) < abs(fa) and fa != fb):
            continue
        value = last.value - fb * (last.value - previous.value) / (fb - fa)
        row = np.zeros(sol.u.size)
        row[-1] = 1.0
        u0 = sol.u.copy()
        u0[-1] = value * run.weights[-1]
        try:
            u, phi, raw, _, _ = run.correct(u0, row, u0[-1], sol.column)
            point = run.point(u, phi, raw, last.arclength + float(np.linalg.norm(u - sol.u)))
        except (_StepFailed, ModelError, SolverError):
            point = replace(last, value=value)
        return SpecialPoint("grazing", point)
    return None


def _switch(run: _Continuation, pd: SpecialPoint, ds: float) -> tuple[_Continuation, _Solution]:
    """The first point of the period-2 branch born at the period-doubling ``pd``: from its
    orbit displaced by ``ds`` (scaled) along the eigenvector of the multiplier −1, with that
    direction as the first tangent (the new branch leaves the old one at a right angle in the
    parameter)."""
    point = pd.point
    values, vectors = np.linalg.eig(point.monodromy)
    v = np.real(vectors[:, int(np.argmin(np.abs(values + 1)))])
    basis = run.shooting.basis
    if basis is not None:  # an eigenvector of Φ_r: the retained coordinates
        v = basis.state(v, np.zeros((basis.complement.shape[1], 2)))
    doubled = _Continuation(run.shooting.with_periods(2 * run.shooting.periods), run.path,
                            run.start, run.end, 1.0 / run.weights[0], run.tol)
    u = np.append(point.state, point.value) * doubled.weights
    direction = np.append(v * doubled.weights[:-1], 0.0)
    direction /= np.linalg.norm(direction)
    y = u / doubled.weights
    at = doubled.at(float(y[-1]))
    _, phi, raw = at.linearised(y[:-1])
    sol = _Solution(point=doubled.point(u, phi, raw, point.arclength), u=u,
                    column=doubled.column(y, raw), jacobian=phi, tangent=direction)
    for _ in range(SWITCH_ATTEMPTS):
        try:
            # the period-2 branch leaves at a right angle: its first correction is large
            return doubled, doubled.step(sol, ds, guard=False)[0]
        except _StepFailed as e:
            failure = e
            ds *= SHRINK
    raise SolverError(f"continuation: no period-2 orbit found next to the period-doubling at "
                      f"{run.path} = {point.value:.9g} ({failure})")
