"""Periodic orbits and continuation of a rotor rubbing in a radial gap (docs/rotors.md §Orbits
and continuation of a rub): the synchronous full annular rub found by shooting against its
closed form, its Floquet multipliers against the rotating frame's eigenvalues (``μ = e^{λT}``)
and against central differences of the map, the rub onset of a continuation in the spin speed
against ``rotor.rub_onset_speeds``, and the onset of instability on the full-annular-rub branch
against the rotating frame's eigenvalues."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize
import vibroimpact as vi
from test_orbits import finite_difference_monodromy
from test_radial_gap import CLEARANCE, KS, ME, OMEGA, K, M, full_annular_rub, rotor
from vibroimpact import rotor as rotors
from vibroimpact.cli import main
from vibroimpact.continuation import parameter_column
from vibroimpact.orbits import Shooting

ROOT = Path(__file__).resolve().parents[1]
TIGHT = vi.Dop853(adaptive=vi.Adaptive(rtol=1e-11, atol=1e-16))


def rotating_jacobian(damping: float, mu: float, w: complex, spin: float) -> np.ndarray:
    """The Jacobian of the rubbing rotor's rotating-frame equation (docs/rotors.md §Full annular
    rub) in ``(Re w, Im w, Re w', Im w')`` at ``w`` in contact, in closed form: the stator's
    force ``k_s (1 + iμ)(w − c w/|w|)`` has the real Jacobian ``k_s [[1, −μ], [μ, 1]]
    (I − c (I − n nᵀ)/|w|)`` and ``i`` is the rotation ``[[0, −1], [1, 0]]``."""
    rho = abs(w)
    n = np.array([w.real, w.imag]) / rho
    eye, turn = np.eye(2), np.array([[0.0, -1.0], [1.0, 0.0]])
    stator = KS * np.array([[1.0, -mu], [mu, 1.0]]) @ (eye - CLEARANCE * (eye - np.outer(n, n))
                                                       / rho)
    stiffness = (-stator - K * eye - damping * spin * turn + M * spin**2 * eye) / M
    velocity = (-damping * eye - 2 * M * spin * turn) / M
    return np.block([[np.zeros((2, 2)), eye], [stiffness, velocity]])


def whirl(damping: float, mu: float, spin: float) -> complex:
    """The full annular rub's whirl ``w`` at ``spin`` (its one branch here)."""
    (w,) = full_annular_rub(damping, mu, spin)
    return w


def inertial_state(w: complex, spin: float) -> np.ndarray:
    """``(x, y, ẋ, ẏ)`` at ``t = 0`` of the whirl ``z = w e^{iΩt}``."""
    return np.array([w.real, w.imag, (1j * spin * w).real, (1j * spin * w).imag])


@pytest.mark.parametrize("mu, stable", [(0.1, True), (0.3, False)])
def test_full_annular_rub_orbit_and_its_multipliers(mu: float, stable: bool) -> None:
    """Shooting from 0.1 % off the closed-form whirl finds it (to 1e-9 of ρ in the state, the
    velocities scaled by Ω); its monodromy equals central differences of the map to 1e-6 and
    its multipliers are ``e^{λT}`` of the rotating frame's eigenvalues λ to 1e-6 (the orbit is
    a fixed point there, and the frame turns by 2π over the spin period T: the same
    linearisation), stable at μ = 0.1 (largest |μ| 0.65) and unstable at μ = 0.3 (2.15)."""
    w = whirl(50.0, mu, OMEGA)
    start = inertial_state(w * 1.001, OMEGA)
    model = rotor(50.0, friction=mu, radius=0.01, x0=tuple(start[:2]), v0=tuple(start[2:]))
    orbit = vi.periodic_orbit(model, transient=0, method=TIGHT)
    z = np.concatenate([orbit.displacement, orbit.velocity])
    scale = np.array([1.0, 1.0, OMEGA, OMEGA])
    assert np.abs((z - inertial_state(w, OMEGA)) / scale).max() < 1e-9 * abs(w)
    assert len(orbit.impacts) == 1  # one contact, all along the period
    fd = finite_difference_monodromy(orbit.shooting, z, 1e-6 * abs(w))
    assert np.abs(fd - orbit.monodromy).max() < 1e-6 * np.abs(fd).max()
    lam = np.linalg.eigvals(rotating_jacobian(50.0, mu, w, OMEGA))
    expected = np.exp(lam * 2 * math.pi / OMEGA)
    for m in expected:
        assert np.abs(orbit.multipliers - m).min() < 1e-6
    assert orbit.stable == stable == (lam.real.max() < 0)


@pytest.mark.parametrize("case", ["friction", "gyroscopic", "free"])
def test_spin_speed_column_equals_the_difference_of_the_map(case: str) -> None:
    """DOP853's column ``∂P/∂Ω`` of ``structure.spin_speed`` (the unbalance ``m e Ω²`` at
    ``Ωt``, the gyroscopic ``Ω G ẋ``, the friction's sliding speed ``R Ω``, and the run's
    length, the spin period) equals the central difference of the simulated map over a spin
    period to 1e-6 (it measures 1e-8 to 2e-10) from a state with contacts that cross the wall
    (away from grazing corners), on a rubbing Jeffcott rotor with regularised friction, on a
    rotor with a gyroscopic matrix rubbing with friction, and on that rotor free of the seal
    (where Newmark, which has no such column, says why and falls back to the difference)."""
    gyroscopic = [[0.0, 0.3], [-0.3, 0.0]] if case != "friction" else None
    st = vi.Structure(np.eye(2) * M, np.eye(2) * K, np.eye(2) * 10.0, gyroscopic=gyroscopic,
                      spin_speed=OMEGA)
    gap = vi.RadialGap(dof=[0, 1], clearance=CLEARANCE, friction=0.1, radius=0.01,
                       friction_law="regularised", regularisation_speed=0.05,
                       law=vi.contact.Hertz(stiffness=KS, exponent=1.0))
    model = vi.Model(st, gaps=[] if case == "free" else [gap],
                     loads=[vi.UnbalanceLoad(dof=[0, 1], magnitude=ME, phase=0.4)])
    period = 2 * math.pi / OMEGA
    r = vi.simulate(model, t_end=20 * period, dt=period / 100, method=TIGHT)
    z = np.concatenate([r.displacement[-1], r.velocity[-1]])
    shooting = Shooting(model, method=TIGHT)
    raw = shooting.at("structure.spin_speed", OMEGA).flow(z)[2]
    assert raw["parameter_column_note"] == ""
    assert (len(raw["impacts"]["t_start"]) > 0) == (case != "free")
    fd = parameter_column(shooting, z, "structure.spin_speed", OMEGA, OMEGA)
    assert np.max(np.abs(raw["parameter_column"] - fd)) < 1e-6 * np.max(np.abs(fd))
    if case == "free":  # (the Newmark family's state-transition matrix refuses a radial gap)
        newmark = Shooting(model, method=vi.Newmark(), dt=period / 2000)
        other = newmark.at("structure.spin_speed", OMEGA).flow(z)[2]
        assert other["parameter_column"] is None
        assert ("does not carry the column of 'structure.spin_speed'"
                in other["parameter_column_note"])


def test_continuation_in_spin_speed_locates_a_radial_rub_onset() -> None:
    """An anisotropic Jeffcott rotor (k_x = 1e4, k_y = 1.2e4 N/m) whirls on an ellipse that
    touches the seal at two points per revolution: continued in the spin speed from 50 to
    76 rad/s, the located grazing equals ``rotor.rub_onset_speeds`` (75.07 rad/s) to 1e-9,
    without and with friction, and the branch past it rubs once per revolution."""
    st = vi.Structure.jeffcott(mass=M, stiffness=[K, 1.2 * K], damping=50.0, spin_speed=50.0)
    loads = [vi.UnbalanceLoad(dof=[0, 1], magnitude=ME)]
    (onset,) = rotors.rub_onset_speeds(vi.Model(st, loads=loads), [0, 1], CLEARANCE,
                                       (1.0, 1000.0))
    for mu in (0.0, 0.1):
        gap = vi.RadialGap(dof=[0, 1], clearance=CLEARANCE, friction=mu, radius=0.01,
                           law=vi.contact.Hertz(stiffness=KS, exponent=1.0))
        branch = vi.continue_orbit(vi.Model(st, gaps=[gap], loads=loads),
                                   "structure.spin_speed", 50.0, 76.0, transient=60,
                                   method=TIGHT)
        grazing = [s.point.value for s in branch.special_points if s.type == "grazing"]
        assert grazing == pytest.approx([onset], rel=1e-9)
        assert branch.points[-1].value == 76.0 and branch.points[-1].impacts_per_period == 1
        assert branch.points[0].impacts_per_period == 0


@pytest.mark.parametrize("mu", [0.0, 0.1])
def test_continuation_in_spin_speed_through_an_isotropic_rub_onset(mu: float) -> None:
    """An isotropic Jeffcott rotor's synchronous whirl touches the seal all around at once at
    the rub onset: continued in the spin speed from 50 to 90 rad/s with the exact column, the
    branch goes from the contact-free whirl through the grazing, located at
    ``rotor.rub_onset_speeds`` (75.59 rad/s) to 1e-9, onto the full annular rub, every point
    past it the closed-form whirl at its speed (to 1e-9 of ρ), in contact all along."""
    st = vi.Structure.jeffcott(mass=M, stiffness=K, damping=50.0, spin_speed=50.0)
    loads = [vi.UnbalanceLoad(dof=[0, 1], magnitude=ME)]
    (onset,) = rotors.rub_onset_speeds(vi.Model(st, loads=loads), [0, 1], CLEARANCE,
                                       (1.0, 1000.0))
    gap = vi.RadialGap(dof=[0, 1], clearance=CLEARANCE, friction=mu, radius=0.01,
                       law=vi.contact.Hertz(stiffness=KS, exponent=1.0))
    branch = vi.continue_orbit(vi.Model(st, gaps=[gap], loads=loads), "structure.spin_speed",
                               50.0, 90.0, transient=60, method=TIGHT)
    assert branch.parameter_column == "exact"
    assert [s.type for s in branch.special_points] == ["grazing"]
    assert branch.special_points[0].point.value == pytest.approx(onset, rel=1e-9)
    assert branch.points[-1].value == 90.0
    before = [p for p in branch.points if p.value < onset]
    past = [p for p in branch.points if p.value > onset * (1 + 1e-6)]
    assert len(before) > 5 and len(past) > 5
    assert all(p.wall_margins[0] > 0 for p in before)
    for p in past:
        assert p.wall_margins[0] < 0 and p.stable
        w = whirl(50.0, mu, p.value)
        scale = np.array([1.0, 1.0, p.value, p.value])
        assert np.abs((p.state - inertial_state(w, p.value)) / scale).max() < 1e-9 * abs(w)


def test_full_annular_rub_branch_and_its_loss_of_stability() -> None:
    """Continued in the spin speed from 150 to 300 rad/s (μ = 0.1), every point is the closed-
    form whirl at its speed (to 1e-9 of ρ) and the branch loses its stability at the one
    Neimark–Sacker point, where the rotating frame's largest real part crosses zero
    (266.9 rad/s, to 1e-6), with its largest multipliers on the unit circle there (1e-5) at
    ``e^{±iωT}`` of the critical mode, a backward whirl."""
    mu = 0.1
    w = whirl(50.0, mu, OMEGA)
    start = inertial_state(w, OMEGA)
    model = rotor(50.0, friction=mu, radius=0.01, x0=tuple(start[:2]), v0=tuple(start[2:]))
    branch = vi.continue_orbit(model, "structure.spin_speed", OMEGA, 300.0, transient=0,
                               method=TIGHT)
    assert branch.points[-1].value == 300.0
    for p in branch.points:
        w = whirl(50.0, mu, p.value)
        scale = np.array([1.0, 1.0, p.value, p.value])
        assert np.abs((p.state - inertial_state(w, p.value)) / scale).max() < 1e-9 * abs(w)

    def growth(spin: float) -> float:
        return float(np.linalg.eigvals(rotating_jacobian(50.0, mu, whirl(50.0, mu, spin),
                                                         spin)).real.max())

    critical = scipy.optimize.brentq(growth, 200.0, 300.0, xtol=1e-12)
    (ns,) = [s for s in branch.special_points if s.type == "neimark-sacker"]
    assert [s.type for s in branch.special_points] == ["neimark-sacker"]
    assert ns.point.value == pytest.approx(critical, rel=1e-6)
    assert np.abs(np.abs(ns.point.multipliers).max() - 1.0) < 1e-5
    assert branch.points[0].stable and not branch.points[-1].stable
    # the critical mode, λ = iω in the rotating frame, whirls in the fixed frame at Ω ± ω:
    # mostly backward (Ω − ω = −846 rad/s carries 3x the amplitude of Ω + ω), and its
    # multipliers are e^{±iωT}
    lam, vectors = np.linalg.eig(rotating_jacobian(50.0, mu, whirl(50.0, mu, critical),
                                                   critical))
    k = int(np.argmax(lam.imag * (np.abs(lam.real) < 1e-6)))
    omega, v = lam[k].imag, vectors[:, k]
    forward, backward = abs(v[0] + 1j * v[1]), abs(np.conj(v[0]) + 1j * np.conj(v[1]))
    assert critical - omega < 0 and backward > 2 * forward
    angle = omega * 2 * math.pi / critical
    assert np.abs(ns.point.multipliers - np.exp(1j * angle)).min() < 1e-4


def test_cli_orbit_of_a_seal_rub_gives_force_and_penetration(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture
                                                              ) -> None:
    """``vibroimpact orbit --json`` on the seal example with more damping (50 N·s/m) and
    Coulomb friction μ = 0.1: the full annular rub, its ``penetration_max`` ρ − c and
    ``force_max`` k_s (ρ − c) per gap equal the closed form to 1e-7."""
    text = (ROOT / "examples/models/jeffcott_seal_rub.toml").read_text()
    for old, new in (("damping = 10.0", "damping = 50.0"), ("friction = 0.05", "friction = 0.1"),
                     ('friction_law = "regularised"', 'friction_law = "coulomb"'),
                     ("regularisation_speed = 0.05 # m/s", "")):
        assert old in text
        text = text.replace(old, new, 1)
    path = tmp_path / "rub.toml"
    path.write_text(text)
    assert main(["orbit", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    penetration = abs(whirl(50.0, 0.1, OMEGA)) - CLEARANCE
    assert out["stable"] is True
    assert out["penetration_max"][0] == pytest.approx(penetration, rel=1e-7)
    assert out["force_max"][0] == pytest.approx(KS * penetration, rel=1e-7)


def test_python_built_rotors_keep_their_dof_map(tmp_path: Path) -> None:
    """A rotor built in Python (a beam's structure, a Jeffcott rotor) gives ``vi.simulate``'s
    result its DOF map, as a model file's run does: its result file draws ``--node 3`` from
    the DOFs ``Beam.dof(3, "x")``, ``dof(3, "y")`` name; the Jeffcott's node 0 is x and y."""
    from test_rotor import ROTOR_FILE
    from vibroimpact.io import results_file

    model_path = tmp_path / "shaft.toml"
    model_path.write_text(ROTOR_FILE)
    mf = vi.load_model(model_path)
    beam = mf.beam
    model = vi.Model(beam.structure, loads=list(mf.model.loads))
    result = vi.simulate(model, t_end=mf.t_end, dt=mf.dt, method=mf.method)
    assert result.dof_map == beam.dof_map
    out = tmp_path / "python.nc"
    results_file.save(result, out)
    ix, iy = beam.dof(3, direction="x"), beam.dof(3, direction="y")
    assert (ix, iy) != (0, 1)
    assert np.array_equal(_orbit_line(out, node=3), result.displacement[:, [ix, iy]])
    jeffcott = vi.simulate(rotor(10.0), t_end=0.01, dt=1e-4)
    assert jeffcott.dof_map is not None
    assert (jeffcott.dof_map.index(0, "x"), jeffcott.dof_map.index(0, "y")) == (0, 1)


def _orbit_line(path: Path, **options: object) -> np.ndarray:
    """The (x, y) points of the orbit plot of the result file at ``path``."""
    from vibroimpact.io.results_file import load
    from vibroimpact.plotting import plot

    fig = plot(load(path), "orbit", **options)
    return np.asarray(fig.axes[0].lines[0].get_xydata())


@pytest.mark.parametrize("stream", [False, True], ids=["in-memory", "streamed"])
def test_orbit_plot_by_node_from_the_result_files_dof_map(tmp_path: Path, stream: bool) -> None:
    """A result file of a beam rotor keeps its DOF map: ``--node 3`` draws the displacements
    of the DOFs that ``Beam.dof(3, "x")`` and ``dof(3, "y")`` name (not the first two); a
    Jeffcott rotor's node 0 is its x and y; a file without a map, a node without x and y, and
    ``--node`` with ``--dof`` are refused in one line."""
    from test_rotor import ROTOR_FILE
    from vibroimpact.errors import ModelError

    model_path = tmp_path / "shaft.toml"
    model_path.write_text(ROTOR_FILE)
    mf = vi.load_model(model_path)
    ix, iy = mf.beam.dof(3, direction="x"), mf.beam.dof(3, direction="y")
    out = tmp_path / "shaft.nc"
    assert main(["run", str(model_path), "-o", str(out), "--quiet",
                 *(["--stream"] if stream else [])]) == 0
    result = mf.simulate()
    expected = result.displacement[:, [ix, iy]]
    assert np.abs(expected).max() > 0 and (ix, iy) != (0, 1)
    assert np.array_equal(_orbit_line(out, node=3), expected)
    png = tmp_path / "orbit.png"
    assert main(["plot", str(out), "--kind", "orbit", "--node", "3", "-o", str(png)]) == 0
    assert png.stat().st_size > 0

    jeffcott = tmp_path / "rub.nc"
    assert main(["run", str(ROOT / "examples/models/jeffcott_seal_rub.toml"), "-o",
                 str(jeffcott), "--quiet"]) == 0
    assert np.array_equal(_orbit_line(jeffcott, node=0), _orbit_line(jeffcott, dofs=[0, 1]))

    sdof = tmp_path / "sdof.nc"
    assert main(["run", str(ROOT / "examples/models/sdof_paper_ln.toml"), "-o", str(sdof),
                 "--quiet"]) == 0
    for path, options, start in (
        (sdof, {"node": 0}, "--node: 0 cannot be found: the result file has no DOF map"),
        (out, {"node": 99}, "--node: 99 has no x and y DOFs in the result's DOF map; expected "
                            "a node with both (0, 1, 2, 3, 4, 5, 6, 7, 8)"),
        (out, {"node": 3, "dofs": [0, 1]}, "--node: 3 is not valid; expected either --node N"),
    ):
        with pytest.raises(ModelError) as e:
            _orbit_line(path, **options)
        assert str(e.value).startswith(start) and "\n" not in str(e.value), str(e.value)
