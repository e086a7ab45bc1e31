"""The continuation benchmark (issue 21; ``vibroimpact bench``): a 200-point branch of the
non-dimensional impact oscillator ``x'' + 0.1 x' + x = cos(w t)`` with a rigid stop at
``d = 0.2`` (restitution 0.8, examples/models/impact_oscillator_rigid.toml) from ``w = 2``,
multipliers at every point, through its period-doubling; beside it the brute-force sweep over
the same range of ``w`` (as many frequencies, 100 transient + 10 sampled periods each, the
event-driven method at the same 200 steps a period, one thread), which finds the period-1
orbit only where it is stable. Both are timed in the same run, in wall time and in this
process's CPU time (both run on one thread: on an idle machine the two agree; on a loaded one
the CPU time is what the work costs).

Beside it, a large structure's periodic orbit with its monodromy in a reduced basis: the hollow
shaft on its sliders (docs/periodic-orbits.md, "A beam through a fold") meshed with 500
Euler–Bernoulli elements (1,002 DOFs, more than the Newmark family's dense state-transition
matrix takes): the full model's orbit (its map's residual), Newton with the Jacobian of the
slider coordinates plus 20 fixed-interface modes and the complement's own maps
(:mod:`vibroimpact.orbit_basis`)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from vibroimpact.contact import Hertz, Rigid
from vibroimpact.continuation import continue_orbit
from vibroimpact.fe import Rayleigh
from vibroimpact.integrators import EventDriven
from vibroimpact.model import Gap, HarmonicLoad, Model, Structure
from vibroimpact.orbits import Shooting, solve_orbit
from vibroimpact.paper import cases
from vibroimpact.sweeps.grid import Param
from vibroimpact.sweeps.runner import Sweep, run_sweep

__all__ = ["TARGET_MS_PER_POINT", "continuation_benchmark", "reduced_orbit_benchmark",
           "rigid_impact_oscillator", "shaft_on_sliders"]

#: The issue's target: 200 points with multipliers in under 1 s.
TARGET_MS_PER_POINT = 5.0
FREQUENCY = "loads.0.frequency"


def rigid_impact_oscillator(w: float = 2.0) -> Model:
    """``x'' + 2ζx' + x = cos(wt)``, ζ = 0.05, a rigid stop at ``x = 0.2`` with r = 0.8."""
    return Model(Structure.sdof(mass=1.0, stiffness=1.0, damping=0.1),
                 gaps=[Gap(dof=0, clearance=0.2, side="positive", law=Rigid(restitution=0.8))],
                 loads=[HarmonicLoad(dof=0, amplitude=1.0, frequency=w / (2 * np.pi),
                                     phase=np.pi / 2)])


def continuation_benchmark(points: int = 200, transient: int = 100,
                           sampled: int = 10) -> dict[str, Any]:
    """The branch's and the sweep's wall times, points and what each found: the branch's
    stable and unstable points and special points; the sweep's points on a period-1 orbit
    (its Poincaré samples within 1e-6 of each other)."""
    start, end = 2.0 / (2 * np.pi), 3.0 / (2 * np.pi)
    model = rigid_impact_oscillator()
    t0, c0 = time.perf_counter(), time.process_time()
    branch = continue_orbit(model, FREQUENCY, start, end, transient=transient, step=0.01,
                            max_step=0.01, max_points=points)
    branch_s, branch_cpu_s = time.perf_counter() - t0, time.process_time() - c0
    values = np.array([p.value for p in branch.points])
    frequencies = np.linspace(start, float(values.max()), len(values))
    sweep = Sweep(model, [Param(FREQUENCY, frequencies)], dt=2 * np.pi / 2.0 / 200,
                  method=EventDriven(), transient=transient, periods=sampled)
    t0, c0 = time.perf_counter(), time.process_time()
    ds = run_sweep(sweep, threads=1, progress=False)
    sweep_s, sweep_cpu_s = time.perf_counter() - t0, time.process_time() - c0
    samples = ds["poincare_displacement"].sel(dof=0).values
    period_one = int(np.count_nonzero(np.ptp(samples, axis=1) < 1e-6))
    stable = sum(p.stable for p in branch.points)
    return {
        "branch_points": len(branch.points), "branch_s": branch_s,
        "branch_cpu_s": branch_cpu_s, "ms_per_point": 1e3 * branch_s / len(branch.points),
        "cpu_ms_per_point": 1e3 * branch_cpu_s / len(branch.points),
        "stable_points": stable, "unstable_points": len(branch.points) - stable,
        "special_points": [(s.type, 2 * np.pi * s.point.value) for s in branch.special_points],
        "w_range": (2 * np.pi * start, 2 * np.pi * float(values.max())),
        "sweep_points": len(frequencies), "sweep_s": sweep_s, "sweep_cpu_s": sweep_cpu_s,
        "sweep_period_one_points": period_one,
        "target_ms_per_point": TARGET_MS_PER_POINT,
    }


#: Newmark's step for the shaft's orbits (1,000 steps a period at 30 Hz).
SHAFT_DT = 1 / 30e3


def shaft_on_sliders(elements: int) -> Model:
    """The hollow shaft between its three sliders with ``elements`` Euler–Bernoulli elements
    (an even number), made periodic as in docs/periodic-orbits.md: soft mounts, Rayleigh
    damping, Hertz sliders of 1.6e7 N/m^1.5, 2100 N at 30 Hz spread over the nodes, started
    near the resonant orbit."""
    beam = cases.hollow_shaft_beam("euler-bernoulli", elements)
    return cases.hollow_shaft_model(
        "euler-bernoulli", elements, law=Hertz(stiffness=1.6e7, exponent=1.5),
        load_amplitude=2100.0 / (elements + 1), load_frequency=30.0, mount_stiffness=1.97e5,
        damping=Rayleigh(mass_coefficient=6.3, stiffness_coefficient=1e-5),
        initial_displacement=-0.012 * beam.translation_vector("x"))


def reduced_orbit_benchmark(elements: int = 500) -> dict[str, Any]:
    """The shaft's periodic orbit at ``elements`` elements with the monodromy in its default
    reduced basis (HHT at T/1000): the sizes, the basis's and the orbit's wall and CPU times
    (the transient of 60 periods included), Newton's iterations and relative residual, the
    leading multiplier, the complement's largest, the impacts per period."""
    model = shaft_on_sliders(elements)
    t0, c0 = time.perf_counter(), time.process_time()
    shooting = Shooting(model, dt=SHAFT_DT)
    basis_s, basis_cpu_s = time.perf_counter() - t0, time.process_time() - c0
    assert shooting.basis is not None
    start = np.concatenate([model.initial_displacement, model.initial_velocity])
    t0, c0 = time.perf_counter(), time.process_time()
    orbit = solve_orbit(shooting, shooting.settle(start, 60), tol=1e-6)
    orbit_s, orbit_cpu_s = time.perf_counter() - t0, time.process_time() - c0
    extra = orbit.complement_multipliers
    return {
        "dofs": model.n_dof, "retained": shooting.basis.n_retained,
        "modes": shooting.basis.cb.n_modes, "basis_s": basis_s, "basis_cpu_s": basis_cpu_s,
        "orbit_s": orbit_s, "orbit_cpu_s": orbit_cpu_s, "iterations": orbit.iterations,
        "residual": orbit.residual / float(np.linalg.norm(orbit.state)),
        "largest_multiplier": float(np.max(np.abs(orbit.multipliers))),
        "complement_max": float(np.max(np.abs(extra))) if extra is not None else 0.0,
        "stable": orbit.stable, "impacts_per_period": len(orbit.impacts),
    }
