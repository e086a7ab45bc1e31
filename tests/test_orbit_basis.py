"""Periodic orbits of large structures with the monodromy in a reduced basis
(vibroimpact.orbit_basis; docs/periodic-orbits.md, "Large structures"): the gap coordinates
plus retained fixed-interface modes, the complement by its own linear maps, Newton on the full
map's residual."""

from __future__ import annotations

import json

import numpy as np
import pytest
import vibroimpact as vi
import xarray as xr
from vibroimpact.benchmarks.continuation import SHAFT_DT, shaft_on_sliders
from vibroimpact.orbit_basis import _newmark_mode_maps
from vibroimpact.orbits import MAX_TRANSITION_DOFS, DenseJacobian, Shooting, solve_orbit


@pytest.mark.parametrize("method", [vi.Newmark(), vi.HHT(), vi.GeneralizedAlpha()])
def test_complement_maps_are_the_core_discrete_map(method: vi.Integrator) -> None:
    """Each complement mode's 2 x 2 map (closed form of the α-form step, raised to the steps)
    equals the core's state-transition matrix of the same oscillator, from a slow mode to one
    far beyond the step (ω h = 100, heavily damped)."""
    for w, c in [(3.0, 0.1), (1e3, 50.0), (1e5, 1e5)]:
        model = vi.Model(vi.Structure.sdof(mass=1.0, stiffness=w * w, damping=c),
                         loads=[vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=1.0)])
        _, phi, _ = Shooting(model, method=method, dt=1e-3).flow(np.array([0.1, 0.2]))
        parameters = method._run_spec()["method"].newmark_parameters()
        maps = _newmark_mode_maps(np.array([w]), np.array([c]), 1e-3, 1000, parameters)
        assert np.max(np.abs(maps[0] - phi)) <= 1e-12 * max(np.max(np.abs(phi)), 1e-300) + 1e-13


def test_reduced_multipliers_converge_to_the_exact_ones() -> None:
    """The shaft on its sliders at 150 DOFs, where the exact (dense) monodromy of HHT's map
    still exists: the orbit found with the reduced Jacobian is the exact-Jacobian orbit (an
    exact Newton step from it moves it by less than 1e-8 of the state), and the four dominant
    multipliers of the reduced monodromy tend to the exact ones as modes are added (measured:
    1.1e-2, 2.1e-4, 2.2e-5, 1.5e-5 off with 0, 2, 4, 8 modes; 1.5e-5 is where the reduced
    model's trajectory, on which Φ_r is formed, stops converging to the full one)."""
    model = shaft_on_sliders(74)
    assert model.n_dof == 150
    start = np.concatenate([model.initial_displacement, np.zeros(model.n_dof)])
    shootings = {modes: Shooting(model, method=vi.HHT(), dt=SHAFT_DT, modes=modes)
                 for modes in (0, 2, 4, 8)}
    guess = shootings[8].settle(start, 60)
    orbits = {modes: solve_orbit(s, guess) for modes, s in shootings.items()}
    orbit = orbits[8]
    assert len(orbit.impacts) >= 6
    assert orbit.basis.startswith("3 gap coordinates (DOFs [0, 74, 148]) + 8 fixed-interface")
    exact = Shooting(model, method=vi.HHT(), dt=SHAFT_DT)
    assert exact.basis is None
    end, phi, _ = exact.flow(orbit.state)
    newton = np.linalg.solve(phi - np.eye(len(phi)), orbit.state - end)
    norm = np.linalg.norm(orbit.state)
    assert np.linalg.norm(end - orbit.state) <= 1e-9 * norm
    # the exact-Jacobian orbit is one exact Newton step away: within the residual's 1e-9
    # times |(Φ − I)⁻¹| (about 10: multipliers of modulus 0.9)
    assert np.linalg.norm(newton) <= 1e-8 * norm
    reference = vi.orbits.multipliers_of(phi)[:4]
    errors = [float(np.max(np.abs(orbits[m].multipliers[:4] - reference))) for m in (0, 2, 4, 8)]
    assert errors[0] > 10 * errors[2], errors  # the modes matter
    assert errors[1] < 1e-3 and errors[2] < 1e-4 and errors[3] < 5e-5, errors
    # the complement (HHT damps its modes) is far inside the unit circle
    assert orbit.complement_multipliers is not None
    assert np.max(np.abs(orbit.complement_multipliers)) < 1e-3


def test_thousand_dof_beam_orbit_matches_finite_differences_of_the_full_map() -> None:
    """The shaft meshed with 500 elements (1,002 DOFs, beyond the dense limit: the reduced
    basis is the default, 20 modes): the full map's residual falls below the tolerance and the
    two dominant multiplier pairs are those of central differences of the full map along
    their eigenvectors lifted to the full state (1e-3 of the state: the map is noisy at about
    1e-6 of it at fixed steps, so the difference is good to about 1e-3)."""
    model = shaft_on_sliders(500)
    assert model.n_dof > MAX_TRANSITION_DOFS
    orbit = vi.periodic_orbit(model, transient=60, dt=SHAFT_DT, tol=1e-6)
    shooting, basis = orbit.shooting, orbit.shooting.basis
    assert basis is not None and basis.cb.n_modes == 20
    z = orbit.state
    assert orbit.residual <= 1e-6 * np.linalg.norm(z)
    assert len(orbit.impacts) >= 6
    values, vectors = np.linalg.eig(orbit.monodromy)
    order = np.argsort(-np.abs(values))
    none = np.zeros((basis.complement.shape[1], 2))
    for k in order[[0, 2]]:
        mu, w = values[k], vectors[:, k]
        image = []
        for part in (w.real, w.imag):
            v = basis.state(part, none)
            step = 1e-3 * np.linalg.norm(z) / np.linalg.norm(v)
            up, _ = shooting.plain_flow(z + step * v)
            down, _ = shooting.plain_flow(z - step * v)
            image.append(basis.coordinates((up - down) / (2 * step))[0])
        fd = np.vdot(w, image[0] + 1j * image[1]) / np.vdot(w, w)
        assert abs(fd - mu) < 2e-3, (mu, fd)
    assert abs(orbit.multipliers[0]) > 0.5  # a lightly damped pair, not a trivial check


def test_reduced_basis_mistakes_are_one_line() -> None:
    model = shaft_on_sliders(74)
    with pytest.raises(vi.ModelError, match=r"^solver.method: 'dop853' has no monodromy in a "
                       "reduced basis"):
        Shooting(model, method=vi.Dop853(), modes=4)
    with pytest.raises(vi.ModelError, match=r"^modes: 500 is not valid; expected an integer"):
        Shooting(model, method=vi.HHT(), dt=SHAFT_DT, modes=500)
    with pytest.raises(vi.ModelError, match=r"^--param structure.mass: a structure's "
                       "number is not valid in a reduced basis"):
        Shooting(model, method=vi.HHT(), dt=SHAFT_DT, modes=4).at("structure.mass", 2.0)


CHAIN = """
schema_version = 1
[structure]
kind = "matrices"
mass = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
stiffness = [[2000.0, -1000.0, 0.0], [-1000.0, 2000.0, -1000.0], [0.0, -1000.0, 1000.0]]
damping = [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]
[[gaps]]
dof = 0
clearance = 0.002
side = "positive"
[gaps.law]
kind = "hertz"
stiffness = 1.0e7
exponent = 1.5
[[loads]]
kind = "harmonic"
dof = 2
amplitude = 20.0
frequency = 4.0
phase = 0.0
[solver]
method = "newmark"
dt = 1e-4
t_end = 1.0
"""


def test_all_modes_retained_is_the_exact_monodromy_and_the_cli_states_the_basis(
        tmp_path, capsys) -> None:
    """With every interior mode retained the basis is an exact change of coordinates: the
    reduced Jacobian is the exact one, so the orbit and its multipliers are those of the full
    monodromy (to Newton's tolerance). ``vibroimpact orbit --modes N --json`` states the basis
    and the complement's largest multiplier (none here). On this 3-DOF chain one mode is not
    enough: the complement (the other interior mode) is as slow as the response, and the
    quasi-Newton iteration diverges (docs: what the basis neglects)."""
    from vibroimpact.cli import main
    from vibroimpact.io.model_file import load_model

    path = tmp_path / "chain.toml"
    path.write_text(CHAIN)
    model = load_model(path).model
    # the file's dt, 2,500 steps a forcing period, as `vibroimpact orbit` takes it
    exact = vi.periodic_orbit(model, transient=30, method=vi.Newmark(), dt=1e-4)
    assert exact.impacts_per_period >= 1
    full_basis = vi.periodic_orbit(model, transient=30, method=vi.Newmark(), dt=1e-4, modes=2)
    assert full_basis.complement_multipliers is not None
    assert full_basis.complement_multipliers.size == 0
    assert np.max(np.abs(full_basis.multipliers - exact.multipliers)) < 1e-7
    assert np.linalg.norm(full_basis.state - exact.state) < 1e-8 * np.linalg.norm(exact.state)
    out = tmp_path / "orbit.nc"
    assert main(["orbit", str(path), "--transient", "30", "--modes", "2", "--json",
                 "-o", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    with xr.open_dataset(out) as ds:
        assert ds.attrs["orbit_basis"] == summary["basis"]
        assert ds["complement_multiplier_real"].size == 0
    assert summary["basis"].startswith("1 gap coordinates (DOFs [0]) + 2 fixed-interface modes")
    assert summary["complement_multiplier_max"] == 0.0
    assert summary["impacts_per_period"] == exact.impacts_per_period
    assert summary["initial_state"]["displacement"] == pytest.approx(
        exact.displacement.tolist(), rel=1e-6, abs=1e-9)


def test_block_jacobian_is_the_dense_algebra_of_its_blocks() -> None:
    """The block Jacobian's bordered solve (the complement eliminated in closed form), its
    determinants and multipliers equal the dense ones of the same ``Φ = L B L⁻¹`` (``B`` the
    blocks, ``L`` the basis's lift written out column by column) on the 18-DOF shaft with 4
    modes (7 complement modes), to rounding."""
    model = shaft_on_sliders(8)
    shooting = Shooting(model, method=vi.HHT(), dt=SHAFT_DT, modes=4)
    basis = shooting.basis
    assert basis is not None
    z = shooting.settle(np.concatenate([model.initial_displacement, np.zeros(model.n_dof)]), 5)
    jac = shooting.linearised(z)[1]
    n, r, h = shooting.n_state, 2 * basis.n_retained, basis.complement.shape[1]
    assert h > 0
    lift = np.column_stack([basis.state(e[:r], e[r:].reshape(h, 2)) for e in np.eye(n)])
    blocks = np.zeros((n, n))
    blocks[:r, :r] = jac.phi_r
    for j in range(h):
        blocks[r + 2 * j:r + 2 * j + 2, r + 2 * j:r + 2 * j + 2] = jac.maps[j]
    dense = DenseJacobian(lift @ blocks @ np.linalg.inv(lift))
    rng = np.random.default_rng(1)
    column, row, rhs = (rng.standard_normal(n), rng.standard_normal(n + 1),
                        rng.standard_normal(n + 1))
    weights = np.append(np.full(n, 30.0), 0.5)
    expected = dense.solve_bordered(column, weights, row, rhs)
    got = jac.solve_bordered(column, weights, row, rhs)
    assert np.linalg.norm(got - expected) <= 1e-11 * np.linalg.norm(expected)
    # the block determinant drops the positive factor Π w of the scaled columns
    assert jac.bordered_determinant(column, weights, row) == pytest.approx(
        dense.bordered_determinant(column, weights, row) * np.prod(weights), rel=1e-10)
    for shift in (-1.0, 1.0):
        assert jac.determinant(shift) == pytest.approx(dense.determinant(shift), rel=1e-10)
    every = np.concatenate([jac.multipliers, jac.complement_multipliers])
    assert np.max(np.abs(np.sort(np.abs(every)) - np.sort(np.abs(dense.multipliers)))) < 1e-12
    solved = jac.solve(rhs[:-1])
    assert np.linalg.norm((dense.monodromy - np.eye(n)) @ solved - rhs[:-1]) < 1e-10


def test_reduced_continuation_follows_the_exact_branch_through_the_fold() -> None:
    """The 150-DOF shaft continued in the frequency with the monodromy in a reduced basis (8
    modes; quasi-Newton correctors, the full map's central-difference parameter column) up to
    the fold and back: checked against the exact (dense) Jacobian of the same map at the start,
    an unstable point past the fold and the located fold. The exact minimum-norm Newton
    correction in ``(z, p)`` from each point moves it by less than 1e-7 of the state and the
    range (measured: 1.5e-9, 9.4e-9, 1.1e-8; the points are corrected to tol = 1e-7, the
    150-DOF map's noise floor near the fold is 2e-8), their largest displacements then equal to
    1e-8 relative (measured <= 1.6e-9); the dominant multipliers are the exact ones to 1e-4
    (1.6e-5 measured, the basis's floor). The fold: the exact correction moves its value by less
    than 1e-7 Hz (1.1e-8 measured) and the exact ``Φ`` there has a multiplier 1 to 2e-5
    (3.7e-6 measured: with the branch's curvature the exact ``μ = 1`` is a further ~1e-11 Hz
    away). Stability is the exact one at the two others."""
    from vibroimpact.orbits import multipliers_of

    model = shaft_on_sliders(74)
    path, low, high = "loads.0.frequency", 30.0, 33.0
    branch = vi.continue_orbit(model, path, low, high, method=vi.HHT(), dt=SHAFT_DT,
                               transient=60, step=0.2, max_step=0.5, max_points=30, modes=8,
                               tol=1e-7)
    assert branch.basis.startswith("3 gap coordinates (DOFs [0, 74, 148]) + 8 fixed-interface")
    assert branch.parameter_column.startswith("central difference: the full map's")
    assert [s.type for s in branch.special_points] == ["fold"]
    fold = branch.special_points[0].point
    assert 32.6 < fold.value < 32.63  # 32.6148 (32.5873 at 6 DOFs, docs)
    values = [p.value for p in branch.points]
    assert max(values) < fold.value and branch.points[-1].value < values[-2]  # turned back
    assert branch.points[0].stable and not branch.points[-1].stable
    assert min(p.impacts_per_period for p in branch.points) == 6
    exact = Shooting(model, method=vi.HHT(), dt=SHAFT_DT)
    for point in (branch.points[0], branch.points[-1], fold):  # start, unstable, fold
        at = exact.at(path, point.value)
        end, phi, raw = at.flow(point.state)
        norm = float(np.linalg.norm(point.state))
        # the minimum-norm correction of [Φ − I, ∂P/∂p] in units of |z| and of the range
        jacobian = np.column_stack([(phi - np.eye(len(phi))) * norm,
                                    np.asarray(raw["parameter_column"]) * (high - low)])
        step = np.linalg.lstsq(jacobian, point.state - end, rcond=None)[0]
        assert np.linalg.norm(step) < 1e-7, (point.value, np.linalg.norm(step))
        corrected = exact.at(path, point.value + step[-1] * (high - low)).plain_flow(
            point.state + step[:-1] * norm)[1]
        top = np.max(np.abs(point.displacement_max))
        assert np.max(np.abs(corrected["displacement_max"] - point.displacement_max)) \
            < 1e-8 * top
        mu = multipliers_of(phi)
        assert np.max(np.abs(mu[:4] - point.multipliers[:4])) < 1e-4
        if point is not fold:  # at the fold a multiplier is 1 to the tolerance
            assert point.stable == bool(np.max(np.abs(mu)) < 1.0)
    # the fold's, the last one checked
    assert abs(step[-1] * (high - low)) < 1e-7 and np.min(np.abs(mu - 1)) < 2e-5


def test_thousand_dof_beam_continues_with_the_full_map_converged() -> None:
    """A few points of the 1,002-DOF shaft's branch (the default basis, 20 modes): each point
    is a fixed point of the full map to the tolerance (a plain run of the full model from it),
    the branch goes up in frequency on the resonant orbit struck 6 times a period, stable, and
    its first point's largest slider displacement is the 150-DOF mesh's to 1e-4 (mesh
    convergence: 1.5e-5 measured)."""
    model = shaft_on_sliders(500)
    path = "loads.0.frequency"
    branch = vi.continue_orbit(model, path, 30.0, 33.0, dt=SHAFT_DT, transient=60, step=0.5,
                               max_step=2.0, max_points=5, tol=1e-5)
    assert len(branch.points) == 5
    assert branch.basis.endswith("complement: 979 modes, each by its own linear map")
    values = [p.value for p in branch.points]
    assert values[0] == 30.0 and np.all(np.diff(values) > 0)
    full = Shooting(model, dt=SHAFT_DT)
    for point in branch.points:
        end, _ = full.at(path, point.value).plain_flow(point.state)
        assert np.linalg.norm(end - point.state) <= 1e-5 * np.linalg.norm(point.state)
        assert point.impacts_per_period == 6 and point.stable
        assert point.complement_multipliers is not None
        assert np.max(np.abs(point.complement_multipliers)) < 1e-3
    coarse = vi.periodic_orbit(shaft_on_sliders(74), transient=60, dt=SHAFT_DT, modes=8)
    first = branch.points[0].displacement_max[0]
    assert abs(first - coarse.displacement_max[0]) < 1e-4 * abs(first)


def test_continue_cli_modes_states_the_basis(tmp_path, capsys) -> None:
    """``vibroimpact continue --modes N --json`` continues in the reduced basis: the JSON has
    the issue's keys plus ``basis``, the points are the API's, the .nc file states the basis
    and how the parameter column was taken."""
    from vibroimpact.cli import main

    path = tmp_path / "chain.toml"
    path.write_text(CHAIN)
    out = tmp_path / "branch.nc"
    assert main(["continue", str(path), "--param", "loads.0.amplitude=20:22", "--transient",
                 "30", "--max-points", "4", "--modes", "2", "--json", "-o", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary) == {"parameter", "points", "special_points", "basis"}
    assert summary["basis"].startswith("1 gap coordinates (DOFs [0]) + 2 fixed-interface")
    from vibroimpact.io.model_file import load_model

    branch = vi.continue_orbit(load_model(path).model, "loads.0.amplitude", 20.0, 22.0,
                               transient=30, max_points=4, modes=2,
                               method=vi.Newmark(), dt=1e-4)  # the file's, as the CLI
    assert [p["value"] for p in summary["points"]] == pytest.approx(
        [p.value for p in branch.points], rel=1e-12)
    with xr.open_dataset(out) as ds:
        assert ds.attrs["basis"] == summary["basis"]
        assert ds.attrs["parameter_column"].startswith("central difference: the full map's")
