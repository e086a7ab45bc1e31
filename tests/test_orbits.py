"""Periodic orbits by shooting (``vibroimpact.periodic_orbit``, ``vibroimpact orbit``): the
rigid stop's period-1 orbit and multipliers against the closed form, the multipliers from the
core's state-transition matrix against finite differences of the simulated map, a stable
orbit attracting a perturbed state in simulation, and the one-line errors."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
import vibroimpact as vi
import xarray as xr
from vibroimpact.benchmarks.continuation import SHAFT_DT, shaft_on_sliders
from vibroimpact.cli import main
from vibroimpact.fe.reduction import reduce_model
from vibroimpact.orbits import Shooting, forcing_period

ZETA, W, D, R = 0.05, 1.1, 0.5, 0.8


def oscillator(law: vi.contact.ContactLaw, w: float = W) -> vi.Model:
    """``x'' + 2ζx' + x = cos(wt)`` with a stop at ``x = d`` (m = k = F0 = 1)."""
    return vi.Model(
        vi.Structure.sdof(mass=1.0, stiffness=1.0, damping=2 * ZETA),
        gaps=[vi.Gap(dof=0, clearance=D, side="positive", law=law)],
        loads=[vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=w / (2 * np.pi),
                               phase=np.pi / 2)],
    )


A = np.array([[0.0, 1.0], [-1.0, -2 * ZETA]])
T = 2 * np.pi / W
H = 1 / (1 - W**2 + 2j * ZETA * W)  # the linear response's complex amplitude


def particular(t: float) -> np.ndarray:
    """The steady free response ``Re(H e^{iwt})`` and its rate."""
    e = H * np.exp(1j * W * t)
    return np.array([e.real, (1j * W * e).real])


def closed_form_orbit(t0: float, v: float) -> tuple[float, float]:
    """Impact instant ``t0`` (in a period) and approach speed ``v`` of the period-1 orbit with
    one impact: from ``(d, −r v)`` at ``t0`` the free flow over ``T`` returns to ``(d, v)``."""

    def equations(p: np.ndarray) -> np.ndarray:
        t, speed = p
        start = np.array([D, -R * speed])
        end = scipy.linalg.expm(A * T) @ (start - particular(t)) + particular(t)
        return end - np.array([D, speed])

    solution, _info, ok, message = scipy.optimize.fsolve(equations, [t0, v], xtol=1e-14,
                                                       full_output=True)
    assert ok == 1, message
    assert np.max(np.abs(equations(solution))) < 1e-13
    return float(solution[0]), float(solution[1])


def test_rigid_stop_period_one_orbit_matches_the_closed_form() -> None:
    model = oscillator(vi.contact.Rigid(restitution=R))
    orbit = vi.periodic_orbit(model, period=1, transient=5, dt=T / 4000)
    assert len(orbit.impacts) == 1 and orbit.iterations >= 1
    guess_t0 = float(orbit.impacts.t_start[0])
    t0, v = closed_form_orbit(guess_t0, float(orbit.impacts.v_in[0]))
    # a genuine one-impact orbit: the free flight stays off the wall
    flight = [scipy.linalg.expm(A * s) @ (np.array([D, -R * v]) - particular(t0))
              + particular(t0 + s) for s in np.linspace(1e-3, T - 1e-3, 400)]
    assert max(z[0] for z in flight) < D
    # the section state (t = 0 of the forcing period) from the impact at t0
    section = (scipy.linalg.expm(A * (T - t0)) @ (np.array([D, -R * v]) - particular(t0))
               + particular(T))
    assert abs(orbit.displacement[0] - section[0]) < 1e-8
    assert abs(orbit.velocity[0] - section[1]) < 1e-8
    assert abs(orbit.impacts.v_in[0] - v) < 1e-8 and abs(guess_t0 - t0) < 1e-8
    assert abs(orbit.impact_phase[0] - W * t0) < 1e-8
    # multipliers: the closed-form monodromy S e^{AT}, S from the impact map (the docs' page)
    s = np.array([[-R, 0.0], [(1 + R) * (np.cos(W * t0) - D) / v, -R]])
    expected = np.linalg.eigvals(s @ scipy.linalg.expm(A * T))
    expected = expected[np.argsort(-np.abs(expected))]
    assert np.max(np.abs(orbit.multipliers - expected)) < 1e-7, (orbit.multipliers, expected)
    assert orbit.stable == bool(np.max(np.abs(expected)) < 1)
    assert orbit.residual <= 1e-9 * np.linalg.norm(section)


def test_rigid_orbit_extremes_are_located_on_the_exact_flight() -> None:
    """On the event-driven method's default coarse grid (200 steps a period) the orbit's
    smallest displacement is the closed-form flight's turning point, not a sample's."""
    model = oscillator(vi.contact.Rigid(restitution=R))
    orbit = vi.periodic_orbit(model, transient=5)
    assert orbit.shooting.dt == pytest.approx(T / 200, rel=1e-14)

    def equations(p: np.ndarray) -> np.ndarray:  # as closed_form_orbit, solved by root
        start = np.array([D, -R * p[1]])
        end = scipy.linalg.expm(A * T) @ (start - particular(p[0])) + particular(p[0])
        return end - np.array([D, p[1]])

    t0, v = scipy.optimize.root(equations, [float(orbit.impacts.t_start[0]) + 1e-3,
                                            1.001 * float(orbit.impacts.v_in[0])],
                                tol=1e-14).x
    assert np.max(np.abs(equations(np.array([t0, v])))) < 1e-13

    def flight(s: float) -> np.ndarray:
        return (scipy.linalg.expm(A * s) @ (np.array([D, -R * v]) - particular(t0))
                + particular(t0 + s))

    grid = np.linspace(0.0, T, 2001)
    rates = np.array([flight(s)[1] for s in grid])
    k = int(np.flatnonzero((rates[:-1] < 0) & (rates[1:] >= 0))[0])
    turn = scipy.optimize.brentq(lambda s: flight(s)[1], grid[k], grid[k + 1], xtol=1e-15)
    assert abs(orbit.displacement_min[0] - flight(turn)[0]) < 1e-12
    assert orbit.displacement_max[0] == pytest.approx(D, abs=1e-12)  # on the wall
    # the samples alone are off by far more: what the located turning point replaces
    sampled = orbit.result.displacement[:, 0].min()
    assert sampled - flight(turn)[0] > 1e-7


def test_contact_spanning_the_section_is_one_onset() -> None:
    """A contact under way at the section is in the impact table twice (from t = 0 and from
    its onset before the period's end); the orbit, its JSON and the continuation count it
    once."""
    law = vi.contact.Hertz(stiffness=1e4, exponent=1.5)
    orbit = vi.periodic_orbit(oscillator(law), transient=30)
    assert len(orbit.impacts) == 1
    start, end = float(orbit.impacts.t_start[0]), float(orbit.impacts.t_end[0])
    middle = 0.5 * (start + end)
    state = orbit.shooting.state_at(orbit.state, middle)
    shifted = vi.Model(  # the same orbit, its section moved into the contact
        orbit.shooting.model.structure, gaps=orbit.shooting.model.gaps,
        loads=[vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=W / (2 * np.pi),
                               phase=np.pi / 2 + W * middle)],
        initial_displacement=state[:1], initial_velocity=state[1:])
    inside = vi.periodic_orbit(shifted, transient=0)
    assert len(inside.impacts) == 2 and float(inside.impacts.t_start[0]) == 0.0
    assert inside.impacts_per_period == 1 and inside.summary()["impacts_per_period"] == 1
    assert orbit.impacts_per_period == 1
    branch = vi.continue_orbit(shifted, "loads.0.frequency", W / (2 * np.pi),
                               1.001 * W / (2 * np.pi), transient=0, max_points=3)
    assert [p.impacts_per_period for p in branch.points] == [1] * len(branch.points)


def test_an_orbit_at_a_parameter_value_carries_the_model_there() -> None:
    model = oscillator(vi.contact.Rigid(restitution=R))
    base = vi.periodic_orbit(model, transient=20)
    shooting = base.shooting.at("gaps.0.clearance", 0.45)
    orbit = vi.orbits.solve_orbit(shooting, base.state)
    assert orbit.result.model.gaps[0].clearance == 0.45
    assert orbit.shooting.model.gaps[0].clearance == 0.45
    assert orbit.displacement_max[0] == pytest.approx(0.45, abs=1e-12)
    # the carried model is the orbit's: simulated from the section state for one period, it
    # returns there (the base model, its stop at 0.5, would not)
    run = vi.simulate(orbit.result.model, orbit.period, orbit.shooting.dt, vi.EventDriven())
    end = np.array([run.displacement[-1, 0], run.velocity[-1, 0]])
    assert np.linalg.norm(end - orbit.state) < 1e-9 * np.linalg.norm(orbit.state)
    assert orbit.result.model.loads == model.loads


def finite_difference_monodromy(shooting: Shooting, z: np.ndarray, eps: float) -> np.ndarray:
    columns = []
    for j in range(z.size):
        dz = np.zeros_like(z)
        dz[j] = eps
        columns.append((shooting.flow(z + dz)[0] - shooting.flow(z - dz)[0]) / (2 * eps))
    return np.column_stack(columns)


@pytest.mark.parametrize("law", [
    vi.contact.Rigid(restitution=R),
    vi.contact.Hertz(stiffness=1e4, exponent=1.5),
    vi.contact.LankaraniNikravesh(stiffness=1e4, exponent=1.5, restitution=0.3),
    # stiff at first touch (the force's slope jumps at the wall): DOP853's steps land on the
    # onset and end to round-off and the landing condition is differentiated
    vi.contact.Hertz(stiffness=1e4, exponent=1.0),
    vi.contact.HuntCrossley(stiffness=1e4, exponent=1.0, restitution=0.5),
    vi.contact.LankaraniNikravesh(stiffness=1e4, exponent=1.0, restitution=0.5),
    # its force jumps by c·v at the onset (saltation S ≠ I) and is clamped to zero before the
    # wall opens, where the force is the switching function
    vi.contact.KelvinVoigt(stiffness=1e4, damping=20.0),
], ids=["rigid", "hertz", "lankarani-nikravesh", "linear", "hunt-crossley-1",
        "lankarani-nikravesh-1", "kelvin-voigt"])
def test_multipliers_match_finite_differences_of_the_map(law: vi.contact.ContactLaw) -> None:
    orbit = vi.periodic_orbit(oscillator(law), transient=30)
    assert len(orbit.impacts) >= 1
    z = np.concatenate([orbit.displacement, orbit.velocity])
    fd = finite_difference_monodromy(orbit.shooting, z, 1e-5)
    assert np.max(np.abs(fd - orbit.monodromy)) < 1e-6 * max(1.0, np.abs(fd).max())
    expected = np.linalg.eigvals(fd)
    expected = expected[np.argsort(-np.abs(expected))]
    assert np.max(np.abs(orbit.multipliers - expected)) < 1e-6


BETA = 10.0  # the linear spring stop's stiffness ratio


def linear_spring_orbit(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The period-1 orbit with one contact of the oscillator with a linear spring stop
    ``β (x − d)`` at ``x = d``, by matching the two linear flows (each exact: ``expm`` and the
    particular solution) at the contact's onset and end; and its monodromy, the product of
    the flows' ``e^{A τ}`` and the saltation matrices at the two switches (continuous state,
    the vector field's jump zero there: the identity)."""
    a_in = np.array([[0.0, 1.0], [-(1.0 + BETA), -2 * ZETA]])
    h_in = 1 / (1 + BETA - W**2 + 2j * ZETA * W)

    def flow(a: np.ndarray, h: complex, offset: float, t0: float, t1: float,
             start: np.ndarray) -> np.ndarray:
        # x'' + 2ζx' + (1 + β_)x = cos(wt) + β_ d: the particular solution plus the constant
        def particular(t: float) -> np.ndarray:
            e = h * np.exp(1j * W * t)
            return np.array([e.real + offset, (1j * W * e).real])
        return scipy.linalg.expm(a * (t1 - t0)) @ (start - particular(t0)) + particular(t1)

    offset_in = BETA * D / (1 + BETA)

    def equations(p: np.ndarray) -> np.ndarray:
        t_on, t_off, v_on = p  # onset and end in [0, T), the speed at the onset
        inside = flow(a_in, h_in, offset_in, t_on, t_off, np.array([D, v_on]))
        back = flow(A, H, 0.0, t_off, t_on + T, inside)
        return np.array([inside[0] - D, back[0] - D, back[1] - v_on])

    t_on, t_off, v_on = scipy.optimize.fsolve(equations, z, xtol=1e-13)
    assert np.max(np.abs(equations(np.array([t_on, t_off, v_on])))) < 1e-12
    shift = np.floor(t_on / T) * T  # both flows are T-periodic in time
    t_on, t_off = t_on - shift, t_off - shift
    onset = np.array([D, v_on])
    contact = scipy.linalg.expm(a_in * (t_off - t_on))
    if t_off <= T:  # the section t = T in free flight: free, contact, free again
        section = flow(A, H, 0.0, t_off, T, flow(a_in, h_in, offset_in, t_on, t_off, onset))
        return section, (scipy.linalg.expm(A * (T - t_off)) @ contact
                         @ scipy.linalg.expm(A * t_on))
    # the section inside the contact: to its end, free flight, the contact again up to T
    section = flow(a_in, h_in, offset_in, t_on, T, onset)
    free = scipy.linalg.expm(A * (T - (t_off - t_on)))
    return section, (scipy.linalg.expm(a_in * (T - t_on)) @ free
                     @ scipy.linalg.expm(a_in * (t_off - T)))


def test_linear_spring_stop_orbit_and_multipliers_match_matched_linear_flows() -> None:
    """The piecewise-linear oscillator's period-1 orbit (one contact per period) and its
    multipliers from DOP853's state-transition matrix equal the closed form of matched linear
    solutions to 1e-8 and 1e-7."""
    orbit = vi.periodic_orbit(oscillator(vi.contact.Hertz(stiffness=BETA, exponent=1.0)),
                              transient=50)
    assert orbit.impacts_per_period == 1
    impacts = orbit.impacts
    onset = float(impacts.t_start[0]) % T
    end = onset + float(impacts.t_end[0] - impacts.t_start[0])
    speed = float(impacts.v_in[0])
    section, monodromy = linear_spring_orbit(np.array([onset, end, speed]))
    state = np.concatenate([orbit.displacement, orbit.velocity])
    assert np.max(np.abs(state - section)) < 1e-8
    expected = np.linalg.eigvals(monodromy)
    expected = expected[np.argsort(-np.abs(expected))]
    assert np.max(np.abs(orbit.multipliers - expected)) < 1e-7


NEWMARK_LAWS = [vi.contact.Hertz(stiffness=1e4, exponent=1.0),
                vi.contact.Hertz(stiffness=1e4, exponent=1.5)]


@pytest.mark.parametrize("method", [vi.Newmark(), vi.HHT(alpha=0.1),
                                    vi.GeneralizedAlpha(rho_inf=0.8)],
                         ids=["newmark", "hht", "generalized-alpha"])
@pytest.mark.parametrize("law", NEWMARK_LAWS, ids=["linear", "hertz"])
def test_newmark_multipliers_match_finite_differences_of_its_map(
        law: vi.contact.ContactLaw, method: vi.integrators.Integrator) -> None:
    """The Newmark family's monodromy is the derivative of its own discrete map (fixed
    steps): against central differences of that map, to 1e-6."""
    orbit = vi.periodic_orbit(oscillator(law), transient=30, method=method, dt=T / 2000)
    assert len(orbit.impacts) >= 1 and orbit.residual < 1e-8
    z = np.concatenate([orbit.displacement, orbit.velocity])
    # a step small enough not to straddle a step that ends just past the wall (where the
    # discrete map of a linear spring kinks), large enough for Newton's round-off
    fd = finite_difference_monodromy(orbit.shooting, z, 1e-7)
    assert np.max(np.abs(fd - orbit.monodromy)) < 1e-6 * max(1.0, np.abs(fd).max())


def test_newmark_multipliers_converge_to_dop853s() -> None:
    """The discrete map's multipliers tend to the flow's (DOP853 at rtol 1e-12) as dt → 0, at
    an order of about 1.25 rather than the scheme's 2: where the contact's onset falls inside
    its step changes with dt, so the error is not monotone (measured: 0.28 at T/2000, 0.11
    at T/11314, 1.4e-3 at T/64000). The fitted order over 11 step sizes is at least 1."""
    law = vi.contact.Hertz(stiffness=1e4, exponent=1.5)
    reference = vi.periodic_orbit(oscillator(law), transient=30).multipliers
    steps = [int(2000 * 2 ** (k / 2)) for k in range(11)]
    errors = []
    for n in steps:
        orbit = vi.periodic_orbit(oscillator(law), transient=30, method=vi.Newmark(),
                                  dt=T / n)
        errors.append(float(np.max(np.abs(orbit.multipliers - reference))))
    order = -np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert order > 1.0 and errors[-1] < 2e-3 and errors[-1] < errors[0] / 100, (order, errors)


@pytest.mark.parametrize(("law", "method"), [
    (vi.contact.Rigid(restitution=R), vi.EventDriven()),
    (vi.contact.KelvinVoigt(stiffness=1e4, damping=20.0),
     vi.Dop853(adaptive=vi.Adaptive(rtol=1e-12, atol=1e-15))),
], ids=["rigid", "kelvin-voigt"])
def test_a_stable_orbit_attracts_a_perturbed_state(law: vi.contact.ContactLaw,
                                                    method: vi.Integrator) -> None:
    model = oscillator(law)
    orbit = vi.periodic_orbit(model, transient=30)
    assert orbit.stable
    z = np.concatenate([orbit.displacement, orbit.velocity])
    periods, steps = 40, 1000
    perturbed = vi.Model(model.structure, gaps=model.gaps, loads=model.loads,
                         initial_displacement=orbit.displacement + 1e-6,
                         initial_velocity=orbit.velocity - 1e-6)
    run = vi.simulate(perturbed, periods * T, T / steps, method, every=steps)
    assert run.time[-1] == pytest.approx(periods * T, rel=1e-14)
    # the first and the last state (DOP853's rows between them are not at whole periods)
    samples = np.column_stack([run.displacement[:, 0], run.velocity[:, 0]])[[0, -1]]
    distance = np.linalg.norm(samples - z, axis=1)
    assert distance[0] == pytest.approx(math.sqrt(2) * 1e-6)
    rho = float(np.max(np.abs(orbit.multipliers)))
    assert distance[-1] < 1e-8 and distance[-1] < 100 * rho**periods * distance[0]


def test_forcing_period_of_commensurate_loads_and_the_errors() -> None:
    base = oscillator(vi.contact.Rigid(restitution=R))
    two = vi.Model(base.structure, gaps=base.gaps, loads=[
        vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=4.0),
        vi.HarmonicLoad(dof=0, amplitude=0.5, frequency=6.0),
        vi.ConstantLoad(dof=0, amplitude=0.1)])
    assert forcing_period(two) == pytest.approx(0.5, rel=1e-15)
    free = vi.Model(base.structure, gaps=base.gaps)
    with pytest.raises(vi.ModelError, match=r"^loads: no harmonic load") as e:
        vi.periodic_orbit(free)
    assert "\n" not in str(e.value)
    odd = vi.Model(base.structure, gaps=base.gaps, loads=[
        vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=1.0),
        vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=math.sqrt(2))])
    with pytest.raises(vi.ModelError, match="not commensurate"):
        forcing_period(odd)
    with pytest.raises(vi.ModelError, match=r"^solver.method: 'bathe' does not compute"):
        vi.periodic_orbit(base, transient=0, method=vi.Bathe())
    hertz = oscillator(vi.contact.Hertz(stiffness=1e4, exponent=1.5))
    with pytest.raises(vi.ModelError, match=r"^solver.adaptive: true is not valid for the "
                                            "Newmark family's state-transition matrix"):
        vi.periodic_orbit(hertz, transient=0, method=vi.Newmark(adaptive=vi.Adaptive()))
    with pytest.raises(vi.ModelError, match=r"^solver.adaptive: false is not valid for "
                                            "DOP853's state-transition matrix"):
        vi.periodic_orbit(hertz, transient=0, method=vi.Dop853(adaptive=None))
    with pytest.raises(vi.SolverError, match=r"did not converge in 1 iterations; residual"):
        vi.periodic_orbit(base, transient=0, max_iterations=1)


MODEL_FILE = f"""
schema_version = 1
[structure]
kind = "sdof"
mass = 1.0
stiffness = 1.0
damping = {2 * ZETA}
[[gaps]]
dof = 0
clearance = {D}
side = "positive"
[gaps.law]
kind = "rigid"
restitution = {R}
[[loads]]
kind = "harmonic"
dof = 0
amplitude = 1.0
frequency = {W / (2 * np.pi)!r}
phase = {np.pi / 2!r}
[solver]
method = "event-driven"
dt = 0.01
t_end = 10.0
"""


def test_cli_orbit_json_and_netcdf(tmp_path, capsys) -> None:
    path = tmp_path / "oscillator.toml"
    path.write_text(MODEL_FILE)
    out = tmp_path / "orbit.nc"
    assert main(["orbit", str(path), "--transient", "30", "--json", "-o", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary) == {"multipliers", "stable", "period", "residual", "initial_state",
                            "displacement_max", "displacement_min", "impacts_per_period",
                            "force_max", "penetration_max"}
    orbit = vi.periodic_orbit(oscillator(vi.contact.Rigid(restitution=R)), transient=30)
    assert summary["period"] == pytest.approx(T, rel=1e-14)
    assert summary["impacts_per_period"] == 1 and summary["stable"] is True
    assert np.allclose([complex(*m) for m in summary["multipliers"]], orbit.multipliers,
                       atol=1e-9)
    assert summary["initial_state"]["displacement"] == pytest.approx(orbit.displacement,
                                                                     abs=1e-9)
    assert summary["displacement_max"] == pytest.approx([D], abs=1e-9)
    assert summary["force_max"] == [None] and summary["penetration_max"] == [0.0]
    with xr.open_dataset(out) as ds:
        assert ds.attrs["orbit_period"] == pytest.approx(T)
        assert ds["time"].values[-1] == pytest.approx(T)
        assert np.allclose(ds["multiplier_real"].values, orbit.multipliers.real, atol=1e-9)


def test_cli_orbit_refuses_a_model_without_a_periodic_load(tmp_path, capsys) -> None:
    path = tmp_path / "free.toml"
    path.write_text(MODEL_FILE.split("[[loads]]")[0] + MODEL_FILE.split("phase = ")[1]
                    .split("\n", 1)[1])
    out = tmp_path / "orbit.nc"
    assert main(["orbit", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["vibroimpact: error: loads: no harmonic load with a frequency > 0; expected "
                   "one (its period is the section of the periodic orbit)"]
    assert not out.exists()


def test_reduced_basis_multipliers_converge_to_the_full_ones() -> None:
    """A large structure's monodromy in a reduced basis: the shaft on its sliders (18 DOFs,
    where the full state-transition matrix is allowed) reduced by Craig–Bampton to its slider
    DOFs plus 0, 2, 4, 8 fixed-interface modes; the reduced orbit's leading multipliers (the
    two least damped pairs) tend to the full model's as modes are added."""
    model = shaft_on_sliders(8)
    assert model.n_dof == 18
    full = vi.periodic_orbit(model, transient=60, method=vi.Newmark(), dt=SHAFT_DT)
    errors = []
    for modes in (0, 2, 4, 8):
        reduced, _cb = reduce_model(model, modes)
        assert reduced.n_dof == 3 + modes
        orbit = vi.periodic_orbit(reduced, transient=60, method=vi.Newmark(), dt=SHAFT_DT)
        assert len(orbit.impacts) == len(full.impacts)
        errors.append(float(np.max(np.abs(orbit.multipliers[:4] - full.multipliers[:4]))))
    assert all(b < 0.5 * a for a, b in itertools.pairwise(errors)), errors
    assert errors[0] > 1e-4 and errors[-1] < 2e-6, errors


def test_a_model_files_fixed_step_is_the_orbits_step_in_whole_steps_a_period() -> None:
    """vibroimpact orbit / continue shoot a fixed-step Newmark file at its dt, shortened to a
    whole number of steps a forcing period; DOP853 and the event-driven method keep their own."""
    from vibroimpact.orbits import file_step, forcing_period

    mf = vi.load_model(Path(__file__).parents[1] / "examples" / "models" / "impact_oscillator.toml")
    period = forcing_period(mf.model)
    for dt in (period / 1000, period / 999.5, 1e-5):
        step = file_step(vi.Newmark(), dt, mf.model)
        assert step is not None and step <= dt * (1 + 1e-12)
        steps = period / step
        assert abs(steps - round(steps)) < 1e-9 and round(steps) == math.ceil(period / dt - 1e-9)
    assert file_step(vi.Dop853(), 1e-5, mf.model) is None
    assert file_step(vi.EventDriven(), 1e-5, mf.model) is None
    assert file_step(vi.Newmark(adaptive=vi.Adaptive(rtol=1e-6)), 1e-5, mf.model) is None
