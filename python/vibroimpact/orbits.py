"""Periodic orbits by shooting on the stroboscopic map, and their Floquet multipliers
(docs/periodic-orbits.md).

The section is the start of a forcing period: ``P^N`` maps the state ``z = (x, v)`` at
``t = 0`` to the state ``N`` forcing periods later. :class:`Shooting` evaluates the residual
``P^N(z) − z`` and its Jacobian ``Φ − I`` from one run of the core that carries the
state-transition matrix ``Φ = ∂P^N/∂z`` (the variational equations of DOP853's stages with
the saltation matrices of its switches; the exact ``exp(A h)`` of the event-driven method's
flights with the saltation matrices of its impacts; the exact derivative of each converged
step of the Newmark family at fixed steps, whose multipliers are the discrete map's).
:func:`periodic_orbit` solves ``P^N(z) = z`` by Newton from a state reached after a
transient. :meth:`Shooting.at` is the same problem at another value of a model parameter
(what :mod:`vibroimpact.continuation` follows). A model above the Newmark family's dense limit
(or with ``modes`` given) is shot on with its monodromy in a reduced basis
(:mod:`vibroimpact.orbit_basis`): the full map's residual, a quasi-Newton Jacobian.
"""

from __future__ import annotations

import copy
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from vibroimpact import _core
from vibroimpact.errors import ModelError, SolverError
from vibroimpact.integrators import (
    HHT,
    Adaptive,
    Dop853,
    EventDriven,
    GeneralizedAlpha,
    Integrator,
    Newmark,
)
from vibroimpact.model import ConstantLoad, HarmonicLoad, Model, TableLoad
from vibroimpact.orbit_basis import BlockJacobian, OrbitBasis, _sorted
from vibroimpact.result import ImpactTable, Result
from vibroimpact.simulate import _run_core, check_run
from vibroimpact.sweeps.grid import canonical_path

__all__ = ["DenseJacobian", "PeriodicOrbit", "Shooting", "contact_onsets", "forcing_period",
           "periodic_orbit", "solve_orbit"]

#: DOP853's first step per forcing period by default.
STEPS_PER_PERIOD = 1000
#: The event-driven method's steps per forcing period by default: its flights are exact and
#: the displacements' extremes are located inside them, so the grid only bounds where an
#: impact is looked for (a quintic interpolant sampled at 1/32 of a step).
EVENT_DRIVEN_STEPS_PER_PERIOD = 200
#: Largest denominator of a ratio of two load frequencies taken as commensurate.
MAX_FREQUENCY_DENOMINATOR = 64
#: The core's largest model for the Newmark family's dense state-transition matrix
#: (``MAX_TRANSITION_DOFS``); above it the monodromy is formed in a reduced basis.
MAX_TRANSITION_DOFS = 200


def forcing_period(model: Model) -> float:
    """The common period of the model's harmonic loads, s: the smallest ``T`` with
    ``f T`` whole for every frequency ``f > 0`` (constant loads are periodic with any period).

    Raises :class:`ModelError` if there is no harmonic load, if a load is a table (not
    periodic) or if two frequencies are not commensurate (their ratio is not a fraction with a
    denominator up to 64, to 1e-12)."""
    st = model.structure
    if st.spin_profile != "constant":
        raise ModelError(f"structure.spin_profile: {st.spin_profile!r} (a run-up) is not "
                         "periodic; expected spin_profile = 'constant' for a periodic orbit")
    frequencies = []
    for i, load in enumerate(model.applied_loads):
        if isinstance(load, TableLoad):
            raise ModelError(f"loads[{i}]: a table load is not periodic; expected harmonic or "
                             "constant loads for a periodic orbit")
        if isinstance(load, HarmonicLoad) and load.frequency > 0:
            frequencies.append(float(load.frequency))
        elif not isinstance(load, (HarmonicLoad, ConstantLoad)):
            raise ModelError(f"loads[{i}]: {type(load).__name__} is not periodic; expected "
                             "harmonic or constant loads for a periodic orbit")
    return _common_period(tuple(frequencies))


@functools.lru_cache(maxsize=64)
def _common_period(frequencies: tuple[float, ...]) -> float:
    """The smallest ``T`` with ``f T`` whole for every frequency (Hz) of ``frequencies``."""
    if not frequencies:
        raise ModelError("loads: no harmonic load with a frequency > 0; expected one (its "
                         "period is the section of the periodic orbit)")
    base = min(frequencies)
    ratios = []
    for f in frequencies:
        ratio = Fraction(f / base).limit_denominator(MAX_FREQUENCY_DENOMINATOR)
        if abs(float(ratio) - f / base) > 1e-12 * f / base:
            raise ModelError(f"loads: frequencies {base} and {f} Hz are not commensurate; "
                             "expected frequencies in a ratio of small whole numbers (a common "
                             "period)")
        ratios.append(ratio)
    denominator = math.lcm(*(r.denominator for r in ratios))
    numerator = math.gcd(*(r.numerator * denominator // r.denominator for r in ratios))
    return denominator / (numerator * base)


def default_steps_per_period(method: Integrator) -> int:
    """Steps per forcing period of ``method`` by default (DOP853: its first step)."""
    return EVENT_DRIVEN_STEPS_PER_PERIOD if isinstance(method, EventDriven) else STEPS_PER_PERIOD


def file_step(method: Integrator, dt: float, model: Model) -> float | None:
    """The step of a model file's shooting (``vibroimpact orbit`` and ``continue``): where its
    ``method`` steps at a fixed ``dt`` (the Newmark family), that ``dt`` shortened to a whole
    number of steps a forcing period, so a stiff contact keeps the step the file resolves it
    with; None (the method's default, :func:`default_steps_per_period`) for the others."""
    if not isinstance(method, (Newmark, HHT, GeneralizedAlpha)) or method.adaptive:
        return None
    period = forcing_period(model)
    return period / math.ceil(period / dt * (1 - 1e-12))


def contact_onsets(t_start: ArrayLike) -> int:
    """The contacts that begin over an orbit's period, from its impact table's start times:
    a contact under way at the section is in the table from ``t = 0`` and again from its onset
    before the period's end, and is one contact."""
    return int(np.count_nonzero(np.asarray(t_start, dtype=float) > 0))


def default_method(model: Model) -> Integrator:
    """The event-driven method for rigid stops, else DOP853 at ``rtol = 1e-12`` (its
    state-transition matrix is that of the integrated flow to about the tolerance's square
    root near a Hertzian contact's ends)."""
    if any(getattr(g.law, "impulsive", False) for g in model.gaps):
        return EventDriven()
    return Dop853(adaptive=Adaptive(rtol=1e-12, atol=1e-15))



def _core_load_path(spec: dict[str, Any], path: str) -> tuple[str | None, str]:
    """The core's spelling of the model path ``path`` (the core holds an unbalance as two
    loads, x and y, so a later load's index moves by one per unbalance before it), or None
    and why the core carries no column for it (an unbalance's own numbers)."""
    parts = path.split(".")
    if parts[0] != "loads" or len(parts) < 3 or not parts[1].isdigit():
        return path, ""
    k, loads = int(parts[1]), spec["loads"]
    if k < len(loads) and loads[k]["kind"] == "unbalance":
        return None, f"'{path}': an unbalance's column is not carried"
    core = sum(2 if load["kind"] == "unbalance" else 1 for load in loads[:k])
    return ".".join(["loads", str(core), *parts[2:]]), ""

class Shooting:
    """The stroboscopic map ``P^N`` of ``model`` over ``period`` forcing periods and its
    state-transition matrix, integrated by ``method`` (default :func:`default_method`; one that
    carries the matrix: DOP853 with adaptive steps, the event-driven method, or Newmark-β,
    HHT-α and generalized-α with fixed steps) with steps of ``dt`` (s; default the forcing
    period / :func:`default_steps_per_period`; DOP853: its first step).

    ``modes``: the monodromy is formed in a reduced basis (:class:`OrbitBasis`: the gap
    coordinates plus ``modes`` fixed-interface modes; the Newmark family only, default
    :class:`~vibroimpact.HHT`, whose numerical damping takes the highest modes' multipliers
    away from the unit circle); always so above :data:`MAX_TRANSITION_DOFS` DOFs, with
    ``modes`` by default :func:`~vibroimpact.orbit_basis.default_modes`. :attr:`basis` is then
    set and :attr:`reduced` is the shooting of the reduced model that carries ``Φ_r``."""

    def __init__(self, model: Model, period: int = 1, method: Integrator | None = None,
                 dt: float | None = None, modes: int | None = None) -> None:
        if not (isinstance(period, int) and not isinstance(period, bool) and period >= 1):
            raise ModelError(f"period: {period!r} is not valid; expected an integer >= 1 "
                             "(forcing periods per orbit)")
        self._model: Model | None = model
        #: The model's numbers (:meth:`Model.to_spec`), with the parameter of :meth:`at` set:
        #: the model is built from them only when asked for (the continuation's many runs need
        #: only these).
        self.spec = model.to_spec()
        #: The model that :attr:`spec` came from (its gaps' names and DOF units).
        self._source = model
        self.n_dof = model.n_dof
        self.periods = period
        self.forcing_period = forcing_period(model)
        self.duration = period * self.forcing_period
        large = modes is not None or model.n_dof > MAX_TRANSITION_DOFS
        if method is None:
            method = HHT() if large else default_method(model)
        self.method = method
        self.dt = (self.forcing_period / default_steps_per_period(self.method) if dt is None
                   else float(dt))
        check_run(model, self.duration, self.dt, self.method)
        #: The parameter set by :meth:`at` (path, value); None: the model's own numbers.
        self.parameter: tuple[str, float] | None = None
        self._spec = model._run_spec()
        self._spec.update(
            self.method._run_spec(),
            t_end=self.duration,
            dt=self.dt,
            every=1,
            record_dofs=list(range(model.n_dof)),
        )
        #: The reduced basis of the monodromy (None: the full ``Φ`` from the core).
        self.basis: OrbitBasis | None = None
        self._reduced: Shooting | None = None
        if large:
            self._reduce(modes)

    def _reduce(self, modes: int | None) -> None:
        """Sets :attr:`basis` and :attr:`reduced` (``modes``: as the constructor)."""
        method = self.method
        if not isinstance(method, (Newmark, HHT, GeneralizedAlpha)) or method.adaptive:
            raise ModelError(f"solver.method: '{method.name}' has no monodromy in a reduced "
                             f"basis ({self.n_dof} DOFs, modes = {modes!r}); expected the "
                             "Newmark family with fixed steps")
        self.basis = OrbitBasis.of(self.model, modes, 1.0 / self.forcing_period)
        if self.basis.n_retained > MAX_TRANSITION_DOFS:
            raise ModelError(f"modes: {self.basis.cb.n_modes} is not valid; expected at most "
                             f"{MAX_TRANSITION_DOFS - len(self.basis.boundary)} (the gap "
                             f"coordinates plus the modes within {MAX_TRANSITION_DOFS})")

    @property
    def reduced(self) -> Shooting | None:
        """The reduced model's shooting, which carries ``Φ_r`` (with :attr:`basis`; made when
        first asked for, at this problem's parameter value, period and step)."""
        if self.basis is not None and self._reduced is None:
            self._reduced = Shooting(self.basis.cb.reduce_model(self.model), self.periods,
                                     self.method, self.dt)
        return self._reduced

    def at(self, path: str, value: float) -> Shooting:
        """This problem for the model with the number at ``path`` (the paths of ``sweep
        --param``, set by the core: ``ModelSpec.with_value``) equal to ``value``. A load's
        frequency moves the forcing period, hence the section's period and the steps, which
        stay the same fraction of it; so does a rotor's spin speed (``structure.spin_speed``:
        the unbalance's period ``2π/Ω``, its ``Ω²`` force and the gyroscopic ``Ω G``). The
        core checks the value at the first :meth:`flow`
        (:class:`ModelError` naming the field). In a reduced basis, the basis (the
        structure's) stays and the reduced model is made again from the moved model (a load's
        reduced loads, a gap's reduced gap), so a structure's number is refused."""
        if self.basis is not None and canonical_path(path).startswith("structure."):
            raise ModelError(f"--param {canonical_path(path)}: a structure's number is not "
                             "valid in a reduced basis (the basis is the structure's, formed "
                             "once); expected a load's or a gap's number, or a model within "
                             f"{MAX_TRANSITION_DOFS} DOFs without modes")
        core = self._spec["model"].with_value(canonical_path(path), float(value))
        period = _common_period(tuple(f for f in core.load_frequencies() if f > 0))
        shooting = copy.copy(self)
        shooting._model, shooting.spec = None, core.to_dict()
        shooting.parameter = (canonical_path(path), float(value))
        shooting.forcing_period = period
        shooting.duration = self.periods * period
        shooting.dt = self.dt * period / self.forcing_period
        shooting._spec = dict(self._spec, model=core, t_end=shooting.duration, dt=shooting.dt)
        shooting._reduced = None
        return shooting

    @property
    def model(self) -> Model:
        """The model, with the parameter of :meth:`at` set (its gaps' names and DOF units kept)."""
        if self._model is None:
            source = self._source
            self._model = Model.from_spec(
                dict(self.spec, gaps=[dict(g, name=gap.name) for g, gap in
                                      zip(self.spec["gaps"], source.gaps, strict=True)]),
                dof_units=source.structure.dof_units)
        return self._model

    def with_periods(self, period: int) -> Shooting:
        """This problem (at the same parameter value) over ``period`` forcing periods."""
        shooting = copy.copy(self)
        shooting.periods = period
        shooting.duration = period * self.forcing_period
        shooting._spec = dict(self._spec, t_end=shooting.duration)
        shooting._reduced = None
        return shooting

    def settle(self, z: NDArray[np.float64], periods: int) -> NDArray[np.float64]:
        """The state ``periods`` forcing periods after ``z`` (a plain run, no derivatives)."""
        if periods == 0:
            return np.asarray(z, dtype=float)
        n = self.n_dof
        t_end = periods * self.forcing_period
        raw, _ = _run_core(dict(self._spec, x0=np.ascontiguousarray(z[:n]),
                                v0=np.ascontiguousarray(z[n:]), t_end=t_end,
                                every=max(1, round(t_end / self.dt))))
        if raw["error"] is not None:
            raise SolverError(f"periodic orbit: the transient of {periods} forcing periods "
                              f"failed: {raw['error']}")
        return np.concatenate([raw["displacement"][-1], raw["velocity"][-1]])

    def state_at(self, z: NDArray[np.float64], t: float) -> NDArray[np.float64]:
        """The state at ``0 < t <= `` :attr:`duration` from ``z`` at the section (the last step
        ends at ``t``)."""
        n = self.n_dof
        raw, _ = _run_core(dict(self._spec, x0=np.ascontiguousarray(z[:n]),
                                v0=np.ascontiguousarray(z[n:]), t_end=float(t),
                                dt=min(self.dt, float(t)), every=10**9))
        if raw["error"] is not None:
            raise SolverError(f"periodic orbit: the run to t = {t:.9g} s failed: "
                              f"{raw['error']}")
        return np.concatenate([raw["displacement"][-1], raw["velocity"][-1]])

    @property
    def n_state(self) -> int:
        """``2n``: displacements then velocities."""
        return 2 * self.n_dof

    def flow(self, z: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                    dict[str, Any]]:
        """``P^N(z)``, ``∂P^N/∂z`` and the core's output of the run (its time histories; with
        the parameter of :meth:`at`, its ``parameter_column`` ``∂P^N/∂p`` where the core
        carries it, else None and ``parameter_column_note`` says why)."""
        n = self.n_dof
        spec = dict(self._spec, x0=np.ascontiguousarray(z[:n]),
                    v0=np.ascontiguousarray(z[n:]))
        core_path, refused = (None, "") if self.parameter is None else _core_load_path(
            self.spec, self.parameter[0])
        if core_path is not None:
            spec["sensitivity_parameter"] = core_path
        raw = _core.flow_map(spec)
        if refused:
            raw["parameter_column"], raw["parameter_column_note"] = None, refused
        if raw["error"] is not None:
            raise SolverError(f"periodic orbit: the run from the section state failed: "
                              f"{raw['error']}")
        end = np.concatenate([raw["displacement"][-1], raw["velocity"][-1]])
        return end, raw["state_transition"], raw

    def linearised(self, z: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                          DenseJacobian | BlockJacobian,
                                                          dict[str, Any]]:
        """``P^N(z)``, its Jacobian and the core's output of the run: the full ``Φ``
        (:meth:`flow`), or in a reduced basis the full map's plain run (:meth:`plain_flow`)
        with the :class:`BlockJacobian` of ``Φ_r`` (the reduced model's flow from ``z``'s
        retained coordinates) and the complement's maps; its ``parameter_column`` is then
        None (``parameter_column_note`` says why)."""
        if self.basis is None:
            end, phi, raw = self.flow(z)
            return end, DenseJacobian(phi), raw
        reduced = self.reduced
        assert reduced is not None
        end, raw = self.plain_flow(z)
        raw["parameter_column"] = None
        raw["parameter_column_note"] = (
            "the full map's, in a reduced basis (the reduced model's column lacks the "
            "complement's part and the truncation of the full residual)")
        phi_r = reduced.flow(self.basis.coordinates(z)[0])[1]
        maps = self.basis.complement_maps(self.method, self.dt, self.duration)
        return end, BlockJacobian(self.basis, phi_r, maps), raw

    def plain_flow(self, z: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                          dict[str, Any]]:
        """``P^N(z)`` and the core's output of the run without the state-transition matrix
        (every step recorded; ``displacement_max``/``_min`` over the steps' ends, which is what
        the Newmark family's runs with the matrix report too)."""
        n = self.n_dof
        raw, _ = _run_core(dict(self._spec, x0=np.ascontiguousarray(z[:n]),
                                v0=np.ascontiguousarray(z[n:])))
        if raw["error"] is not None:
            raise SolverError(f"periodic orbit: the run from the section state failed: "
                              f"{raw['error']}")
        raw["displacement_max"] = np.max(raw["displacement"], axis=0)
        raw["displacement_min"] = np.min(raw["displacement"], axis=0)
        return np.concatenate([raw["displacement"][-1], raw["velocity"][-1]]), raw

    def residual(self, z: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                        NDArray[np.float64]]:
        """``P^N(z) − z`` and its Jacobian ``∂P^N/∂z − I``."""
        end, phi, _ = self.flow(z)
        return end - z, phi - np.eye(self.n_state)


@dataclass(frozen=True)
class PeriodicOrbit:
    """A periodic orbit of ``period`` forcing periods (:func:`periodic_orbit`).

    ``displacement``, ``velocity``: the state on the section (``t = 0`` of a forcing period);
    ``result``: the time histories over the orbit's period from there; ``monodromy``:
    ``∂P^N/∂z`` at the orbit (``2n × 2n``); ``multipliers``: its eigenvalues, largest modulus
    first; ``residual``: ``|P^N(z) − z|`` at the returned state; ``iterations``: Newton's."""

    shooting: Shooting
    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]
    result: Result
    monodromy: NDArray[np.float64]
    multipliers: NDArray[np.complex128]
    residual: float
    iterations: int
    #: Each DOF's largest and smallest displacement over the orbit: at every step's end (the
    #: impact instants included) and DOP853's turning points inside its steps.
    displacement_max: NDArray[np.float64]
    displacement_min: NDArray[np.float64]
    #: With a reduced basis (:attr:`Shooting.basis`): the basis in words, and the multipliers
    #: of the complement's own maps (largest modulus first); ``monodromy`` and
    #: ``multipliers`` are then the reduced model's ``Φ_r`` at the orbit's retained
    #: coordinates. "" and None for the full ``Φ``.
    basis: str = ""
    complement_multipliers: NDArray[np.complex128] | None = None

    @property
    def state(self) -> NDArray[np.float64]:
        """``z = (x, v)`` on the section."""
        return np.concatenate([self.displacement, self.velocity])

    @property
    def period(self) -> float:
        """The orbit's period, s (``period`` forcing periods)."""
        return self.shooting.duration

    @property
    def stable(self) -> bool:
        """Every multiplier inside the unit circle (the complement's too)."""
        extra = self.complement_multipliers
        largest = float(np.max(np.abs(self.multipliers)))
        if extra is not None and extra.size:
            largest = max(largest, float(np.max(np.abs(extra))))
        return largest < 1.0

    @property
    def impacts(self) -> ImpactTable:
        """The contacts over the orbit's period (compliant laws: one row per contact; rigid:
        one per impact)."""
        return self.result.impacts

    @property
    def impacts_per_period(self) -> int:
        """The contacts that begin over the orbit's period (:func:`contact_onsets`)."""
        return contact_onsets(self.impacts.t_start)

    @property
    def impact_phase(self) -> NDArray[np.float64]:
        """Each impact's instant as a phase of the forcing period, rad in ``[0, 2π)``."""
        t = np.asarray(self.impacts.t_start, dtype=float)
        return 2 * np.pi * np.mod(t / self.shooting.forcing_period, 1.0)

    def _per_gap(self, column: NDArray[np.float64]) -> list[float | None]:
        """The largest value of an impact-table column per gap (0 without contact; None where
        it is NaN: a rigid impact has no finite force)."""
        gaps = np.asarray(self.impacts.gap)
        out: list[float | None] = []
        for g in range(len(self.shooting.model.gaps)):
            values = np.asarray(column, dtype=float)[gaps == g]
            if values.size == 0:
                out.append(0.0)
            elif np.isnan(values).any():
                out.append(None)
            else:
                out.append(float(values.max()))
        return out

    @property
    def force_max(self) -> list[float | None]:
        """Per gap: the largest contact force over the orbit, N (None for a rigid stop)."""
        return self._per_gap(self.impacts.force_max)

    @property
    def penetration_max(self) -> list[float | None]:
        """Per gap: the largest penetration over the orbit, m (0 for a rigid stop)."""
        return self._per_gap(self.impacts.delta_max)

    def to_dataset(self) -> xr.Dataset:
        """The orbit's time histories as :func:`vibroimpact.io.results_file.to_dataset` has
        them, with the multipliers (``multiplier_real``, ``multiplier_imag``), the monodromy
        matrix and the attributes ``orbit_period`` (s), ``orbit_forcing_periods``,
        ``orbit_residual`` and ``orbit_stable`` (0/1); in a reduced basis also the attribute
        ``orbit_basis`` and ``complement_multiplier_real``/``_imag``."""
        from vibroimpact.io import results_file

        ds = results_file.to_dataset(self.result)
        ds["multiplier_real"] = ("multiplier", self.multipliers.real)
        ds["multiplier_imag"] = ("multiplier", self.multipliers.imag)
        ds["monodromy"] = (("state", "state_from"), self.monodromy)
        ds.attrs.update(orbit_period=self.period, orbit_forcing_periods=self.shooting.periods,
                        orbit_residual=self.residual, orbit_stable=int(self.stable))
        if self.basis:
            extra = self.complement_multipliers
            assert extra is not None
            ds["complement_multiplier_real"] = ("complement_multiplier", extra.real)
            ds["complement_multiplier_imag"] = ("complement_multiplier", extra.imag)
            ds.attrs["orbit_basis"] = self.basis
        return ds

    def summary(self) -> dict[str, Any]:
        """The JSON summary of ``vibroimpact orbit --json`` (with a reduced basis also
        ``basis`` and ``complement_multiplier_max``, the complement's largest modulus)."""
        reduced: dict[str, Any] = {}
        if self.basis:
            extra = self.complement_multipliers
            reduced = {"basis": self.basis, "complement_multiplier_max": (
                float(np.max(np.abs(extra))) if extra is not None and extra.size else 0.0)}
        return {
            "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
            "stable": self.stable,
            "period": self.period,
            "residual": self.residual,
            "initial_state": {"displacement": self.displacement.tolist(),
                              "velocity": self.velocity.tolist()},
            "displacement_max": self.displacement_max.tolist(),
            "displacement_min": self.displacement_min.tolist(),
            "impacts_per_period": self.impacts_per_period,
            "force_max": self.force_max,
            "penetration_max": self.penetration_max,
            **reduced,
        }


@dataclass
class DenseJacobian:
    """The full ``Φ = ∂P^N/∂z`` with the operations of a reduced basis's
    :class:`~vibroimpact.orbit_basis.BlockJacobian` (dense solves and determinants)."""

    monodromy: NDArray[np.float64]
    complement_multipliers = None

    @property
    def multipliers(self) -> NDArray[np.complex128]:
        return multipliers_of(self.monodromy)

    def _bordered(self, column: NDArray[np.float64], weights: NDArray[np.float64],
                  row: NDArray[np.float64]) -> NDArray[np.float64]:
        n = len(self.monodromy)
        return np.vstack([np.column_stack([self.monodromy - np.eye(n), column]) / weights, row])

    def solve_bordered(self, column: NDArray[np.float64], weights: NDArray[np.float64],
                       row: NDArray[np.float64], rhs: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
        """``du`` with ``[[Φ − I, c] / w, row] du = rhs``."""
        return np.linalg.solve(self._bordered(column, weights, row), rhs)

    def bordered_determinant(self, column: NDArray[np.float64], weights: NDArray[np.float64],
                             row: NDArray[np.float64]) -> float:
        """``det [[Φ − I, c] / w, row]``."""
        return float(np.linalg.det(self._bordered(column, weights, row)))

    def determinant(self, shift: float) -> float:
        """``det(Φ + shift · I)``."""
        return float(np.linalg.det(self.monodromy + shift * np.eye(len(self.monodromy))))

    def pair_test(self) -> float:
        """The Neimark–Sacker test ``Π_{i<j} (μ_i μ_j − 1)``."""
        mu = self.multipliers
        pairs = [mu[i] * mu[j] - 1 for i in range(mu.size) for j in range(i + 1, mu.size)]
        return float(np.prod(pairs).real) if pairs else 1.0


def multipliers_of(monodromy: NDArray[np.float64]) -> NDArray[np.complex128]:
    """The eigenvalues of ``monodromy`` (the Floquet multipliers), largest modulus first."""
    return _sorted(np.linalg.eigvals(monodromy))


#: Halvings of a Newton step that does not lower the residual (or leaves a rigid wall's side).
MAX_HALVINGS = 12


Flow = Callable[[NDArray[np.float64]], tuple[NDArray[np.float64], Any, dict[str, Any]]]


def _line_search(flow: Flow, z: NDArray[np.float64], step: NDArray[np.float64],
                 residual: float) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                           Any, dict[str, Any], float]:
    """The first of ``z + step``, ``z + step/2``, ... whose residual under ``flow``
    (:meth:`Shooting.flow`, or a map without its matrix) is below ``residual`` (the map is
    only piecewise smooth: a full step may cross a grazing or start inside a rigid wall, which
    the core refuses); the last halving if none is."""
    for halving in range(MAX_HALVINGS):
        trial = z + step * 0.5**halving
        try:
            end, phi, raw = flow(trial)
        except ModelError:
            continue
        trial_residual = float(np.linalg.norm(end - trial))
        if trial_residual < residual:
            return trial, end, phi, raw, trial_residual
    trial = z + step * 0.5**MAX_HALVINGS
    end, phi, raw = flow(trial)
    return trial, end, phi, raw, float(np.linalg.norm(end - trial))


def periodic_orbit(model: Model, period: int = 1, transient: int = 50, *,
                   method: Integrator | None = None, dt: float | None = None,
                   tol: float = 1e-9, max_iterations: int = 30,
                   modes: int | None = None) -> PeriodicOrbit:
    """The periodic orbit of ``period`` forcing periods near the state that ``model`` reaches
    after ``transient`` forcing periods from its initial state (0: the initial state itself is
    the guess), by Newton on ``P^N(z) − z`` with the exact Jacobian of the map; converged when
    ``|P^N(z) − z| <= tol · max(|z|, 1e-300)``. ``method``, ``dt``, ``modes``: as
    :class:`Shooting` (a model above :data:`MAX_TRANSITION_DOFS` DOFs, or ``modes`` given: the
    monodromy in a reduced basis, :func:`solve_orbit`).

    Raises :class:`ModelError` for a model without a periodic load (or a method that does not
    carry the state-transition matrix) and :class:`SolverError` if Newton does not converge in
    ``max_iterations`` (naming the residual).

    **Example:** ``vi.periodic_orbit(model, period=1, transient=50).multipliers``
    """
    if not (isinstance(transient, int) and not isinstance(transient, bool) and transient >= 0):
        raise ModelError(f"transient: {transient!r} is not valid; expected an integer >= 0 "
                         "(forcing periods)")
    shooting = Shooting(model, period, method, dt, modes)
    z = np.concatenate([np.asarray(model.initial_displacement, dtype=float),
                        np.asarray(model.initial_velocity, dtype=float)])
    return solve_orbit(shooting, shooting.settle(z, transient), tol, max_iterations)


def solve_orbit(shooting: Shooting, z: NDArray[np.float64], tol: float = 1e-9,
                max_iterations: int = 30) -> PeriodicOrbit:
    """The periodic orbit of ``shooting`` by Newton on ``P^N(z) − z`` from the guess ``z``
    (:func:`periodic_orbit` says when it converges and what it raises)."""
    if shooting.basis is not None:
        return _solve_reduced(shooting, z, tol, max_iterations)
    model = shooting.model
    n = model.n_dof
    end, phi, raw = shooting.flow(z)
    residual = float(np.linalg.norm(end - z))
    iteration = 0
    while residual > tol * max(float(np.linalg.norm(z)), 1e-300):
        if iteration == max_iterations:
            raise _not_converged(max_iterations, residual, tol)
        iteration += 1
        try:
            step = np.linalg.solve(phi - np.eye(2 * n), z - end)
        except np.linalg.LinAlgError:
            raise SolverError(f"periodic orbit: the Jacobian P^N' - I is singular at iteration "
                              f"{iteration} (a multiplier at 1: a fold or a family of orbits); "
                              f"residual {residual:.3e}") from None
        z, end, phi, raw, residual = _line_search(shooting.flow, z, step, residual)
    return _orbit(shooting, model, z, raw, phi, residual, iteration)


def _not_converged(max_iterations: int, residual: float, tol: float) -> SolverError:
    return SolverError(f"periodic orbit: Newton did not converge in {max_iterations} "
                       f"iterations; residual |P^N(z) - z| = {residual:.3e}, expected "
                       f"<= {tol:g} |z|")


def _solve_reduced(shooting: Shooting, z: NDArray[np.float64], tol: float,
                   max_iterations: int) -> PeriodicOrbit:
    """:func:`solve_orbit` with the monodromy in :attr:`Shooting.basis`: the residual is the
    full map's (plain runs of the full model), the Newton step solves the block-diagonal
    Jacobian of :mod:`vibroimpact.orbit_basis` — ``(Φ_r − I) δ_r = −r_r`` with the reduced
    model's monodromy at the retained coordinates, ``(E_j − I) δ_j = −r_j`` per complement
    mode — and lifts ``(δ_r, δ_h)`` back to the full state."""
    basis, reduced = shooting.basis, shooting.reduced
    assert basis is not None and reduced is not None
    model = shooting.model
    maps = basis.complement_maps(shooting.method, shooting.dt, shooting.duration)

    def plain(state: NDArray[np.float64]) -> tuple[NDArray[np.float64], None,
                                                   dict[str, Any]]:
        end, raw = shooting.plain_flow(state)
        return end, None, raw

    def monodromy(state: NDArray[np.float64]) -> NDArray[np.float64]:
        return reduced.flow(basis.coordinates(state)[0])[1]

    end, _, raw = plain(z)
    residual = float(np.linalg.norm(end - z))
    iteration = 0
    phi_r = None
    while residual > tol * max(float(np.linalg.norm(z)), 1e-300):
        if iteration == max_iterations:
            raise _not_converged(max_iterations, residual, tol)
        iteration += 1
        phi_r = monodromy(z)
        try:
            step = BlockJacobian(basis, phi_r, maps).solve(z - end)
        except np.linalg.LinAlgError:
            raise SolverError(f"periodic orbit: the reduced Jacobian Phi_r - I is singular at "
                              f"iteration {iteration}; residual {residual:.3e}") from None
        z, end, _, raw, residual = _line_search(plain, z, step, residual)
        phi_r = None
    if phi_r is None:
        phi_r = monodromy(z)
    return _orbit(shooting, model, z, raw, phi_r, residual, iteration,
                  basis=basis.describe(),
                  complement_multipliers=_sorted(np.linalg.eigvals(maps).ravel()))


def _orbit(shooting: Shooting, model: Model, z: NDArray[np.float64], raw: dict[str, Any],
           monodromy: NDArray[np.float64], residual: float, iterations: int,
           **reduced: Any) -> PeriodicOrbit:
    """The converged orbit ``z`` with its run ``raw`` over the period and its monodromy
    (``reduced``: the basis it was formed in and the complement's multipliers)."""
    n = model.n_dof
    result = Result.from_core(raw, model=replace(model, initial_displacement=z[:n],
                                                 initial_velocity=z[n:]),
                              method=shooting.method, t_end=shooting.duration)
    return PeriodicOrbit(shooting=shooting, displacement=z[:n].copy(), velocity=z[n:].copy(),
                         result=result, monodromy=monodromy,
                         multipliers=multipliers_of(monodromy), residual=residual,
                         iterations=iterations,
                         displacement_max=np.asarray(raw["displacement_max"]),
                         displacement_min=np.asarray(raw["displacement_min"]), **reduced)

