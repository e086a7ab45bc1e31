"""Continuation of periodic orbits (``vibroimpact.continue_orbit``, ``vibroimpact continue``):
the rigid stop's period-1 branch and multipliers against the closed form, a fold of a Hertz
stop's branch (its multiplier at 1, the branch turning there), a supercritical
period-doubling whose period-2 orbit (``switch``) is stable in simulation, a grazing against
the linear response's closed form, the core's parameter column against central differences of
the map (and the fallback difference against a difference of another step),
and the command line's JSON, file and one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
import vibroimpact as vi
import xarray as xr
from vibroimpact.cli import main
from vibroimpact.continuation import SPECIAL_POINT_TYPES, parameter_column
from vibroimpact.orbits import Shooting

ZETA, R = 0.05, 0.8
FREQUENCY = "loads.0.frequency"
A = np.array([[0.0, 1.0], [-1.0, -2 * ZETA]])


def oscillator(law: vi.contact.ContactLaw, w: float, d: float) -> vi.Model:
    """``x'' + 2ζx' + x = cos(wt)`` with a stop at ``x = d`` (m = k = F0 = 1)."""
    return vi.Model(
        vi.Structure.sdof(mass=1.0, stiffness=1.0, damping=2 * ZETA),
        gaps=[vi.Gap(dof=0, clearance=d, side="positive", law=law)],
        loads=[vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=w / (2 * np.pi),
                               phase=np.pi / 2)])


def particular(w: float, t: float) -> np.ndarray:
    e = np.exp(1j * w * t) / (1 - w**2 + 2j * ZETA * w)
    return np.array([e.real, (1j * w * e).real])


def closed_form(w: float, d: float, guess: tuple[float, float]) -> tuple[float, float]:
    """Impact instant and approach speed of the period-1 one-impact orbit: from
    ``(d, −r v)`` at ``t0`` the free flow over ``T = 2π/w`` returns to ``(d, v)``."""
    period = 2 * np.pi / w

    def equations(p: np.ndarray) -> np.ndarray:
        t, v = p
        end = (scipy.linalg.expm(A * period) @ (np.array([d, -R * v]) - particular(w, t))
               + particular(w, t))
        return end - np.array([d, v])

    solution = scipy.optimize.root(equations, guess, tol=1e-14).x
    assert np.max(np.abs(equations(solution))) < 1e-13
    return float(solution[0]), float(solution[1])


def test_rigid_branch_matches_the_closed_form_and_its_monodromy() -> None:
    d = 0.5
    model = oscillator(vi.contact.Rigid(restitution=R), 1.1, d)
    branch = vi.continue_orbit(model, FREQUENCY, 1.1 / (2 * np.pi), 1.4 / (2 * np.pi),
                               transient=20)
    assert branch.points[-1].value == pytest.approx(1.4 / (2 * np.pi), rel=1e-12)
    assert len(branch.points) >= 8
    shooting = Shooting(model)
    for point in branch.points:
        w = 2 * np.pi * point.value
        raw = shooting.at(FREQUENCY, point.value).flow(point.state)[2]
        assert point.impacts_per_period == 1
        t_start, v_in = float(raw["impacts"]["t_start"][0]), float(raw["impacts"]["v_in"][0])
        t0, v = closed_form(w, d, (t_start, v_in))
        assert abs(t_start - t0) < 1e-8 and abs(v_in - v) < 1e-8
        s = np.array([[-R, 0.0], [(1 + R) * (np.cos(w * t0) - d) / v, -R]])
        expected = np.linalg.eigvals(s @ scipy.linalg.expm(A * 2 * np.pi / w))
        expected = expected[np.argsort(-np.abs(expected))]
        assert np.max(np.abs(point.multipliers - expected)) < 1e-7
        assert point.stable == bool(np.max(np.abs(expected)) < 1)


def test_parameter_column_matches_a_difference_of_another_step() -> None:
    model = oscillator(vi.contact.Hertz(stiffness=1e4, exponent=1.5), 1.1, 0.5)
    orbit = vi.periodic_orbit(model, transient=30)
    value = 1.1 / (2 * np.pi)
    column = parameter_column(orbit.shooting, orbit.state, FREQUENCY, value, 0.01)
    other = parameter_column(orbit.shooting, orbit.state, FREQUENCY, value, 0.01,
                             relative_step=1e-4)
    assert np.max(np.abs(column - other)) < 1e-6 * np.max(np.abs(column))
    # a column of the wrong parameter or a one-sided difference would be far off
    assert np.max(np.abs(column)) > 1.0


@pytest.mark.parametrize("path, value", [(FREQUENCY, 1.1 / (2 * np.pi)),
                                         ("loads.0.amplitude", 1.0), ("loads.0.phase", 1.5),
                                         ("gaps.0.clearance", 0.5)])
def test_core_parameter_column_equals_the_difference_of_the_map(path: str,
                                                                value: float) -> None:
    """DOP853's column ``∂P/∂p`` (carried beside ``Φ``) is the central difference of the
    simulated map, the forcing period moving with a frequency; a law's stiffness has none."""
    model = oscillator(vi.contact.Hertz(stiffness=1e4, exponent=1.5), 1.1, 0.5)
    orbit = vi.periodic_orbit(model, transient=30)
    raw = orbit.shooting.at(path, value).flow(orbit.state)[2]
    assert raw["parameter_column_note"] == ""
    fd = parameter_column(orbit.shooting, orbit.state, path, value, abs(value))
    assert np.max(np.abs(raw["parameter_column"] - fd)) < 1e-6 * np.max(np.abs(fd))
    assert np.max(np.abs(fd)) > 0.1
    other = orbit.shooting.at("gaps.0.law.stiffness", 1e4).flow(orbit.state)[2]
    assert other["parameter_column"] is None
    assert "'gaps.0.law.stiffness' has no exact column" in other["parameter_column_note"]



@pytest.mark.parametrize(("path", "value"), [
    ("gaps.0.clearance", 0.5),
    ("loads.0.amplitude", 1.0),
    ("loads.0.phase", np.pi / 2),
    ("loads.0.frequency", 1.1 / (2 * np.pi)),
])
def test_event_driven_columns_equal_the_difference_of_the_map(path: str, value: float) -> None:
    """The event-driven method carries a clearance's column (the impacts' saltation with
    ``∂δ/∂d = −1``) and a load's (the flights' exponential differentiated, then the
    saltation): the central difference of its map, at the rigid stop's orbit."""
    model = oscillator(vi.contact.Rigid(restitution=R), 1.1, 0.5)
    orbit = vi.periodic_orbit(model, transient=30)
    raw = orbit.shooting.at(path, value).flow(orbit.state)[2]
    assert raw["parameter_column_note"] == ""
    fd = parameter_column(orbit.shooting, orbit.state, path, value, abs(value))
    assert np.max(np.abs(raw["parameter_column"] - fd)) < 1e-6 * np.max(np.abs(fd))
    assert np.max(np.abs(fd)) > 0.1
    other = orbit.shooting.at("gaps.0.law.restitution", R).flow(orbit.state)[2]
    assert other["parameter_column"] is None


def test_fold_of_a_hertz_stop_branch() -> None:
    model = oscillator(vi.contact.Hertz(stiffness=10.0, exponent=1.5), 0.8, 0.5)
    branch = vi.continue_orbit(model, FREQUENCY, 0.8 / (2 * np.pi), 2.5 / (2 * np.pi),
                               transient=100, step=0.05, max_step=0.5, max_points=300)
    folds = [s for s in branch.special_points if s.type == "fold"]
    assert len(folds) == 2
    assert branch.parameter_column == "exact"
    values = np.array([p.value for p in branch.points])
    arclength = np.array([p.arclength for p in branch.points])
    for fold, turn in zip(folds, (np.max, np.min), strict=True):
        assert np.min(np.abs(fold.point.multipliers - 1)) < 1e-6
        # the branch turns there: its neighbours on both sides lie on the same side of it
        before = values[arclength < fold.point.arclength][-1]
        after = values[arclength > fold.point.arclength][0]
        assert turn([before, after, fold.point.value]) == fold.point.value
    # between the folds the branch is unstable (a multiplier beyond 1), outside stable
    inside = (arclength > folds[0].point.arclength) & (arclength < folds[1].point.arclength)
    assert inside.any() and not any(branch.points[i].stable for i in np.flatnonzero(inside))
    assert branch.points[0].stable and branch.points[-1].stable


def test_period_doubling_switches_onto_a_stable_period_two_orbit() -> None:
    d = 0.2
    model = oscillator(vi.contact.Rigid(restitution=R), 2.0, d)
    branch = vi.continue_orbit(model, FREQUENCY, 2.0 / (2 * np.pi), 2.3 / (2 * np.pi),
                               transient=100, switch=True, max_points=80)
    pd = next(s for s in branch.special_points if s.type == "period-doubling")
    assert pd.point.periods == 1 and np.min(np.abs(pd.point.multipliers + 1)) < 1e-6
    doubled = [p for p in branch.points if p.periods == 2]
    first = doubled[0]
    assert first.value > pd.point.value and first.stable  # supercritical: past it, stable
    # in simulation: a perturbed start returns to the period-2 orbit, which is not period 1
    w = 2 * np.pi * first.value
    period = 2 * np.pi / w
    start = vi.Model(model.structure, gaps=model.gaps, loads=[
        vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=first.value, phase=np.pi / 2)],
        initial_displacement=first.state[:1] + 1e-6, initial_velocity=first.state[1:])
    steps = 1000
    run = vi.simulate(start, 200 * period, period / steps, vi.EventDriven(), every=steps)
    samples = np.column_stack([run.displacement[:, 0], run.velocity[:, 0]])
    assert np.linalg.norm(samples[-1] - first.state) < 1e-8
    assert np.linalg.norm(samples[-2] - first.state) > 1e-3 * np.linalg.norm(first.state)


def test_grazing_frequency_equals_the_linear_response_closed_form() -> None:
    d = 3.0
    model = oscillator(vi.contact.Hertz(stiffness=1e3, exponent=1.5), 0.5, d)
    branch = vi.continue_orbit(model, FREQUENCY, 0.5 / (2 * np.pi), 0.95 / (2 * np.pi),
                               transient=0)
    # |H(w)| = 1 / sqrt((1 - w²)² + (2ζw)²) = d, for w² below the resonance
    b = 2 - 4 * ZETA**2
    w2 = (b - np.sqrt(b**2 - 4 * (1 - 1 / d**2))) / 2
    expected = np.sqrt(w2) / (2 * np.pi)
    grazing = [s for s in branch.special_points if s.type == "grazing"]
    assert len(grazing) == 1
    assert abs(grazing[0].point.value - expected) < 1e-10 * expected
    # continued through: impacting orbits beyond it, none before
    for p in branch.points:
        assert (p.impacts_per_period > 0) == (p.value > expected)
    assert branch.points[-1].value == pytest.approx(0.95 / (2 * np.pi), rel=1e-12)


def test_rigid_branch_stops_at_its_grazing_against_the_closed_form() -> None:
    """Past its fold the rigid stop's unstable branch loses its impact speed: the branch ends
    at the grazing, where the free response's amplitude |H(w)| equals the clearance (the
    event-driven method has no derivative at an impact at zero speed)."""
    d = 0.5
    model = oscillator(vi.contact.Rigid(restitution=R), 1.5, d)
    branch = vi.continue_orbit(model, FREQUENCY, 1.5 / (2 * np.pi), 2.0 / (2 * np.pi),
                               transient=50, max_points=100)
    b = 2 - 4 * ZETA**2  # |H(w)| = d above the resonance
    expected = np.sqrt((b + np.sqrt(b**2 - 4 * (1 - 1 / d**2))) / 2) / (2 * np.pi)
    assert [s.type for s in branch.special_points] == ["fold", "grazing"]
    grazing = branch.special_points[-1].point
    assert abs(grazing.value - expected) < 1e-9 * expected
    assert abs(grazing.wall_margins[0]) < 1e-8
    assert branch.stopped.startswith(f"stopped at the grazing of a rigid stop at {FREQUENCY} = ")
    assert branch.parameter_column == "exact"
    assert branch.points[-1].value == pytest.approx(expected, rel=1e-5)
    assert len(branch.points) < 100  # it ended there, not at max_points or the range's end


def test_rigid_branch_continues_through_its_grazing_onto_the_linear_response() -> None:
    """The example's rigid stop (d = 0.2): past its period-doubling the unstable period-1
    branch loses its impact speed; the grazing is located where the free response's amplitude
    |H(w)| equals the clearance, and the branch goes on clear of the stop, where each orbit is
    the linear response (its state on the section and its multipliers ``eig e^{AT}``)."""
    model = vi.load_model(RIGID_MODEL).model
    d = float(model.gaps[0].clearance)
    end = 2.7 / (2 * np.pi)
    branch = vi.continue_orbit(model, FREQUENCY, 2.0 / (2 * np.pi), end, transient=100)
    assert [s.type for s in branch.special_points] == ["period-doubling", "grazing"]
    b = 2 - 4 * ZETA**2  # |H(w)| = d above the resonance
    expected = np.sqrt((b + np.sqrt(b**2 - 4 * (1 - 1 / d**2))) / 2) / (2 * np.pi)
    grazing = branch.special_points[-1].point
    assert abs(grazing.value - expected) < 1e-10 * expected
    assert abs(grazing.wall_margins[0]) < 1e-10
    assert branch.stopped == "" and branch.points[-1].value == pytest.approx(end, rel=1e-12)
    beyond = [p for p in branch.points if p.value > expected]
    assert len(beyond) >= 5
    for p in branch.points:
        assert p.impacts_per_period == (0 if p.value > expected else 1)
    for p in beyond:
        w = 2 * np.pi * p.value
        assert np.max(np.abs(p.state - particular(w, 0.0))) < 1e-10
        free = np.linalg.eigvals(scipy.linalg.expm(A * 2 * np.pi / w))
        assert np.max(np.abs(np.sort_complex(p.multipliers) - np.sort_complex(free))) < 1e-10
        assert p.stable and p.wall_margins[0] > 0


#: The rigid impact oscillator at w = 2 (``d = 0.2``, ``r = 0.8``, ``ζ = 0.05``).
RIGID_MODEL = Path(__file__).resolve().parents[1] / "examples/models/impact_oscillator_rigid.toml"


def test_cli_continue_json_and_netcdf(tmp_path, capsys) -> None:
    path = RIGID_MODEL
    out = tmp_path / "branch.nc"
    end = 2.3 / (2 * np.pi)
    args = ["continue", str(path), "--param", f"{FREQUENCY}={2.0 / (2 * np.pi)!r}:{end!r}",
            "--transient", "100", "--max-points", "60", "--switch", "--json", "-o", str(out)]
    assert main(args) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary) == {"parameter", "points", "special_points"}
    assert summary["parameter"] == FREQUENCY
    for p in summary["points"]:
        assert {"value", "stable", "multipliers", "displacement_max", "displacement_min",
                "impacts_per_period"} <= set(p)
        moduli = [abs(complex(*m)) for m in p["multipliers"]]
        assert moduli == sorted(moduli, reverse=True)
        assert p["stable"] == (moduli[0] < 1)
    types = [s["type"] for s in summary["special_points"]]
    assert "period-doubling" in types and set(types) <= set(SPECIAL_POINT_TYPES)
    for s in summary["special_points"]:
        assert {"type", "value", "multipliers"} <= set(s)
    with xr.open_dataset(out) as ds:
        assert ds.sizes["point"] == len(summary["points"])
        assert "arclength" in ds.coords and np.all(np.diff(ds["arclength"].values) > 0)
        assert np.allclose(ds["parameter"].values, [p["value"] for p in summary["points"]])
        assert ds["parameter"].attrs["path"] == FREQUENCY
        assert list(ds["special_type"].values) == types


@pytest.mark.parametrize(("param", "message"), [
    ("loads.0.frequency=0.3", "--param: 'loads.0.frequency=0.3' is not valid; expected "
                              "PATH=START:END"),
    ("loads.0.frequency=0.3:0.3", "--param: 'loads.0.frequency=0.3:0.3' is not valid"),
    ("gaps.0.clearance=0.2:-1", "gaps[0].clearance: -1 is not valid; expected a clearance >= 0"),
    ("gaps.0.law.stiffness=1:2", "--param gaps.0.law.stiffness: gap 0's rigid law has no "
                                 "number 'stiffness'"),
])
def test_cli_continue_bad_input_is_one_line(tmp_path, capsys, param, message) -> None:
    path = RIGID_MODEL
    out = tmp_path / "branch.nc"
    assert main(["continue", str(path), "--param", param, "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"vibroimpact: error: {message}"), err
    assert not out.exists()


def test_bad_arguments_of_the_api() -> None:
    model = oscillator(vi.contact.Rigid(restitution=R), 1.1, 0.5)
    with pytest.raises(vi.ModelError, match=r"^--max-points: 1 is not valid"):
        vi.continue_orbit(model, FREQUENCY, 0.17, 0.2, max_points=1)
    with pytest.raises(vi.ModelError, match=r"^--param loads.0.frequency: start = end"):
        vi.continue_orbit(model, FREQUENCY, 0.17, 0.17)
    hertz = oscillator(vi.contact.Hertz(stiffness=1e4, exponent=1.5), 1.1, 0.5)
    with pytest.raises(vi.ModelError, match=r"^solver.method: 'bathe' does not compute"):
        vi.continue_orbit(hertz, FREQUENCY, 0.17, 0.2, method=vi.Bathe())


def test_parameter_column_counts_a_load_after_an_unbalance_as_the_model_does() -> None:
    """The core holds an unbalance as two loads (x and y): the path ``loads.1`` of the
    model must reach the core's third load, not the unbalance's y half."""
    st = vi.Structure.jeffcott(mass=10.0, stiffness=1e6, damping=200.0, spin_speed=250.0)
    model = vi.Model(st, loads=[vi.UnbalanceLoad(dof=[0, 1], magnitude=1e-3, phase=0.4),
                                vi.ConstantLoad(dof=1, amplitude=50.0)])
    orbit = vi.periodic_orbit(model, transient=0)
    raw = orbit.shooting.at("loads.1.amplitude", 50.0).flow(orbit.state)[2]
    assert raw["parameter_column_note"] == ""
    fd = parameter_column(orbit.shooting, orbit.state, "loads.1.amplitude", 50.0, 50.0)
    assert np.max(np.abs(fd)) > 0
    assert np.max(np.abs(raw["parameter_column"] - fd)) < 1e-6 * np.max(np.abs(fd))
    own = orbit.shooting.at("loads.0.magnitude", 1e-3).flow(orbit.state)[2]
    assert own["parameter_column"] is None
    assert "an unbalance's column is not carried" in own["parameter_column_note"]
