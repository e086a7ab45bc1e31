"""Special points of continued branches beyond the one-DOF oscillator: the hollow shaft on its
sliders (a planar beam, Newmark at fixed steps) through a fold with impacts at every slider on
both sides of it, its multipliers against finite differences of the simulated map, and the
symmetry-breaking pitchfork of the same symmetric shaft located as a branch point; a
Neimark–Sacker point of a two-mass chain with a stop, against simulation on either side of it."""

from __future__ import annotations

import dataclasses

import numpy as np
import vibroimpact as vi
from vibroimpact.fe import Rayleigh
from vibroimpact.paper import cases

FREQUENCY = "loads.0.frequency"
#: Steps per forcing period (Newmark's multipliers are those of its discrete map).
STEPS = 1000


def mounted_shaft(frequency: float, start: float = 0.0) -> vi.Model:
    """The hollow shaft as 2 Euler–Bernoulli elements (6 DOFs) on soft mounts (1.97e5 N/m at
    each end: its translation resonates at 10 Hz), Rayleigh damping (α = 6.3 /s: 5 % there),
    between its three sliders (3 mm each side, Hertz 1.6e7 N/m^1.5) and 700 N at each node
    (2100 N in all, as the paper's 21 nodes × 100 N); ``start``: a uniform displacement (m)."""
    beam = cases.hollow_shaft_beam("euler-bernoulli", 2)
    return cases.hollow_shaft_model(
        "euler-bernoulli", 2, law=vi.contact.Hertz(stiffness=1.6e7, exponent=1.5),
        load_amplitude=700.0, load_frequency=frequency,
        damping=Rayleigh(mass_coefficient=6.3, stiffness_coefficient=1e-5),
        mount_stiffness=1.97e5, initial_displacement=start * beam.translation_vector("x"))


def continued(model: vi.Model, start: float, end: float, **options) -> vi.continuation.Branch:
    return vi.continue_orbit(model, FREQUENCY, start, end, method=vi.Newmark(),
                             dt=1 / (start * STEPS), transient=60, step=0.05, max_step=0.5,
                             **options)


def finite_difference_monodromy(shooting: vi.orbits.Shooting, z: np.ndarray) -> np.ndarray:
    """Central differences of the simulated map, each component moved by 1e-5 of the largest
    component of its half of the state (displacements, velocities)."""
    n = z.size // 2
    columns = []
    for j in range(z.size):
        dz = np.zeros_like(z)
        dz[j] = 1e-5 * np.max(np.abs(z[n:] if j >= n else z[:n]))
        columns.append((shooting.flow(z + dz)[0] - shooting.flow(z - dz)[0]) / (2 * dz[j]))
    return np.column_stack(columns)


def test_hollow_shaft_on_its_sliders_continues_through_a_fold() -> None:
    # from a large uniform displacement the shaft settles on the resonant, impacting orbit
    model = mounted_shaft(30.0, start=-0.012)
    branch = continued(model, 30.0, 33.0, max_points=60)
    folds = [s for s in branch.special_points if s.type == "fold"]
    assert len(folds) == 1
    fold = folds[0].point
    assert np.min(np.abs(fold.multipliers - 1)) < 1e-6
    values = np.array([p.value for p in branch.points])
    arclength = np.array([p.arclength for p in branch.points])
    before = [p for p in branch.points if p.arclength < fold.arclength]
    after = [p for p in branch.points if p.arclength > fold.arclength]
    assert before and after and values.max() <= fold.value  # the branch turns there
    assert before[-1].stable and not after[0].stable
    assert np.all(np.diff(arclength) > 0)
    # impacts at every slider on both sides of it, every point of the branch: each wall
    # penetrated (grazing test < 0), each slider struck once a period on each side
    for p in branch.points:
        assert np.all(p.wall_margins < 0) and np.all(p.impact_speed_max > 0)
        assert p.impacts_per_period == 2 * len(model.gaps)
    # one point's multipliers against finite differences of the simulated map
    point = after[0]
    shooting = vi.orbits.Shooting(model, method=vi.Newmark(), dt=1 / (30.0 * STEPS)).at(
        FREQUENCY, point.value)
    fd = finite_difference_monodromy(shooting, point.state)
    assert np.max(np.abs(fd - point.monodromy)) < 1e-6 * np.max(np.abs(fd))
    # each multiplier next to one of the differences' (pairs of equal modulus sort either way)
    expected = np.linalg.eigvals(fd)
    assert max(np.min(np.abs(expected - m)) for m in point.multipliers) < 1e-6


def test_symmetry_breaking_pitchfork_of_the_shaft_is_a_branch_point() -> None:
    """The shaft and its sliders are symmetric about the middle, and so is its orbit (the ends
    move alike); near 13.66 Hz a multiplier goes through +1 without a fold (the frequency keeps
    rising): a pitchfork onto a pair of rocking orbits. Located, its multiplier is 1; past it
    the symmetric orbit is unstable and a rocking start settles in simulation on a stable
    orbit whose ends move differently (the other branch); before it the symmetric one is
    stable."""
    model = mounted_shaft(13.3)
    branch = continued(model, 13.3, 14.0, max_points=20)
    assert [s.type for s in branch.special_points] == ["branch-point"]
    point = branch.special_points[0].point
    assert np.min(np.abs(point.multipliers - 1)) < 1e-6
    values = np.array([p.value for p in branch.points])
    assert np.all(np.diff(values) > 0)  # not a fold
    n = model.n_dof
    for p in branch.points:  # the continued branch is the symmetric one
        assert abs(p.state[0] - p.state[4]) < 1e-9 * abs(p.state[0])
        assert p.stable == (p.value < point.value)
    past = next(p for p in branch.points if p.value > point.value + 0.05)
    rocking = past.state.copy()
    rocking[[0, 4]] += 1e-4 * np.array([1.0, -1.0])
    other = vi.periodic_orbit(
        dataclasses.replace(mounted_shaft(past.value), initial_displacement=rocking[:n],
                            initial_velocity=rocking[n:]),
        transient=100, method=vi.Newmark(), dt=1 / (past.value * STEPS))
    assert other.stable and other.impacts_per_period > 0
    assert abs(other.displacement[0] - other.displacement[4]) > 1e-2 * abs(other.displacement[0])


def two_masses(frequency: float) -> vi.Model:
    """Two unit masses in a chain (springs 1, 1), Rayleigh-like damping ``0.01 (M + K)``, a
    Hertz stop (10 δ^1.5) 0.3 beyond the second mass, 0.2 cos(2πft) on the first."""
    mass, stiffness = np.eye(2), np.array([[2.0, -1.0], [-1.0, 1.0]])
    return vi.Model(
        vi.Structure(mass=mass, stiffness=stiffness, damping=0.01 * (mass + stiffness)),
        gaps=[vi.Gap(dof=1, clearance=0.3, side="positive",
                     law=vi.contact.Hertz(stiffness=10.0, exponent=1.5))],
        loads=[vi.HarmonicLoad(dof=0, amplitude=0.2, frequency=frequency, phase=np.pi / 2)])


def test_neimark_sacker_point_of_a_two_mass_chain_with_a_stop() -> None:
    """A complex pair of multipliers leaves the unit circle: located, it is on the circle;
    in simulation a perturbation of the orbit dies out before the point and grows after it."""
    branch = vi.continue_orbit(two_masses(0.124), FREQUENCY, 0.124, 0.13, transient=200,
                               step=0.05, max_step=0.3, max_points=80)
    ns = [s.point for s in branch.special_points if s.type == "neimark-sacker"]
    assert len(ns) == 1
    pair = ns[0].multipliers[:2]  # the largest pair: complex, on the circle
    assert pair[0] == np.conj(pair[1]) and abs(pair[0].imag) > 0.1
    assert np.max(np.abs(np.abs(pair) - 1)) < 1e-6
    points = [p for p in branch.points if p.impacts_per_period > 0]
    before = [p for p in points if p.arclength < ns[0].arclength][-1]
    after = next(p for p in points if p.arclength > ns[0].arclength)
    assert before.stable and not after.stable
    assert after.multipliers[0].imag != 0 and np.all(np.abs(after.multipliers[:2]) > 1)
    for point, decays in ((before, True), (after, False)):
        shooting = vi.orbits.Shooting(two_masses(point.value))
        start = point.state + 1e-6 * np.array([1.0, 0.0, 0.0, 0.0])
        end = shooting.settle(start, 200)
        distance = np.linalg.norm(end - point.state)
        assert (distance < 1e-8) if decays else (distance > 1e-4)
