"""Rotors (docs/rotors.md): Jeffcott unbalance response and rub onset against their closed
forms, beam-rotor gyroscopics and Campbell diagrams against independent eigen-solutions and
ROSS, the solver paths with the unsymmetric C + ΩG, and one-line errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact import fe, rotor

M, K, C, ME = 10.0, 1e6, 200.0, 1e-3  # kg, N/m, N·s/m, kg·m


def _jeffcott_closed_form(omega: float, phase: float = 0.0) -> complex:
    """x + i y = z e^{iΩt}: M z'' + c z' + k z = m e Ω² e^{i(Ωt + φ)}."""
    return ME * omega**2 * np.exp(1j * phase) / (K - M * omega**2 + 1j * C * omega)


@pytest.mark.parametrize("omega", [150.0, 316.0, 700.0])
def test_jeffcott_unbalance_response_matches_closed_form(omega: float) -> None:
    phase = 0.4
    z = _jeffcott_closed_form(omega, phase)
    st = vi.Structure.jeffcott(mass=M, stiffness=K, damping=C, spin_speed=omega)
    load = vi.UnbalanceLoad(dof=[0, 1], magnitude=ME, phase=phase)
    # the API's steady state: x = Re(Z_x e^{iΩt}) = Re(z e^{iΩt}), y = Re(−i z e^{iΩt})
    zz = rotor.unbalance_response(vi.Model(st, loads=[load]), [omega])[0]
    assert abs(zz[0] - z) < 1e-12 * abs(z) and abs(zz[1] + 1j * z) < 1e-12 * abs(z)
    # the simulation, started on the closed-form orbit, stays on it (amplitude and phase)
    model = vi.Model(st, loads=[load], initial_displacement=[z.real, z.imag],
                     initial_velocity=[-omega * z.imag, omega * z.real])
    revolutions = 5
    r = vi.simulate(model, t_end=revolutions * 2 * math.pi / omega, dt=1e-4,
                    method=vi.Dop853(adaptive=vi.Adaptive(rtol=1e-13, atol=1e-18)))
    w = (r.displacement[:, 0] + 1j * r.displacement[:, 1]) * np.exp(-1j * omega * r.time)
    assert np.abs(np.abs(w) - abs(z)).max() < 1e-9 * abs(z)
    assert np.abs(np.angle(w / z)).max() < 1e-9


def test_rub_onset_speeds_match_closed_form() -> None:
    clearance = 1e-3
    model = vi.Model(vi.Structure.jeffcott(mass=M, stiffness=K, damping=C),
                     loads=[vi.UnbalanceLoad(dof=[0, 1], magnitude=ME)])
    got = rotor.rub_onset_speeds(model, [0, 1], clearance, (1.0, 2000.0))
    # |z| = c: (M² c² − (me)²) s² + (c_d² c² − 2 k M c²) s + k² c² = 0 for s = Ω²
    s = np.roots([M**2 * clearance**2 - ME**2, C**2 * clearance**2 - 2 * K * M * clearance**2,
                  K**2 * clearance**2])
    expected = sorted(math.sqrt(v) for v in s.real if v > 0)
    assert len(got) == 2
    assert got == pytest.approx(expected, rel=1e-9)


def _shaft(**kw: object) -> fe.Beam:
    args: dict = dict(length=1.2, elements=8, dofs_per_node=4,
                      section=fe.Section.circle(0.06),
                      material=fe.Material(youngs_modulus=2.1e11, poisson=0.3, density=7810.0),
                      discs=[fe.Disc(node=3, mass=30.0, polar_inertia=0.6,
                                     diametral_inertia=0.3)])
    args.update(kw)
    return fe.Beam(**args)  # type: ignore[arg-type]


def test_beam_gyroscopic_matrix_is_the_rigid_rotor_polar_inertia() -> None:
    """A rigid tilt of the free shaft about x and about y couples by the whole polar inertia
    ρ I_p L + Σ I_p(disc): the textbook rigid rotor's gyroscopic couple."""
    beam = _shaft()
    g = beam.structure.gyroscopic.toarray()
    z = beam.node_positions
    tilt_x = np.zeros(beam.n_dof)  # rx = θ, y = −z θ
    tilt_y = np.zeros(beam.n_dof)  # ry = ψ, x = z ψ
    for i, (node, d) in enumerate(zip(beam.dof_map.nodes, beam.dof_map.directions, strict=True)):
        tilt_x[i] = {"rx": 1.0, "y": -z[node]}.get(d, 0.0)
        tilt_y[i] = {"ry": 1.0, "x": z[node]}.get(d, 0.0)
    sec, mat = beam.section, beam.material
    polar = mat.density * sec.polar_moment * beam.length + 0.6
    assert tilt_x @ g @ tilt_y == pytest.approx(polar, rel=1e-12)
    assert np.abs(g + g.T).max() == 0


def test_beam_rotor_campbell_against_an_independent_eigen_solution() -> None:
    beam = _shaft(bearings=[fe.Bearing(node="start", kxx=2e7, kyy=3e7, cxx=300.0, cyy=300.0),
                            fe.Bearing(node="end", kxx=2e7, kyy=3e7)])
    st = beam.structure
    speeds = [0.0, 800.0, 2000.0]
    diagram = rotor.campbell(st, speeds, 6, rotor.translation_pairs(beam.dof_map, st.n_dof))
    m, k, c = st.dense_matrices()
    g = st.gyroscopic.toarray()
    n = st.n_dof
    minv = np.linalg.inv(m)
    for i, w in enumerate(speeds):
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ (c + w * g)]])
        lam = np.linalg.eigvals(a)
        wd = np.sort(lam.imag[lam.imag > 1e-6])[:6]
        # two formulations' round-off (M⁻¹ explicit here, the pencil A − λB there)
        assert diagram.frequencies[i] == pytest.approx(wd, rel=1e-7)
    # gyroscopic stiffening: the forward mode of each pair rises, the backward one falls
    f = diagram.frequencies
    assert f[-1, 1] > f[0, 1] and f[-1, 0] < f[0, 0]
    assert diagram.whirl[-1][:2] == ("backward", "forward")


def test_ross_rotor_example_campbell_matches_run_campbell(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # ccp looks for REFPROP in the working directory
    rs = pytest.importorskip("ross", reason="ROSS (the optional extra `ross`) not installed")
    example = rs.rotor_example()
    speeds = np.array([0.0, 500.0])
    ref = example.run_campbell(speeds, frequencies=6)
    structure = rotor.from_ross(example)
    st = structure.to_structure()
    pairs = rotor.translation_pairs(structure.dof_map, st.n_dof)
    ours = rotor.campbell(st, speeds, 10, pairs)
    for i in range(len(speeds)):
        lateral = [j for j, w in enumerate(ours.whirl[i]) if w != "none"][:6]
        assert ours.frequencies[i, lateral] == pytest.approx(ref.wd[i], rel=1e-6)
        # ROSS's whirl values: 0 forward, 1 backward, 0.5 mixed
        for j, value in zip(lateral, ref.whirl_values[i], strict=True):
            if value in (0.0, 1.0) and speeds[i] > 0:
                assert ours.whirl[i][j] == ("forward" if value == 0.0 else "backward")


def test_gyroscopic_runs_agree_across_methods_and_conserve_energy() -> None:
    """Undamped spinning beam rotor, free whirl: Newmark (dense LU: K̃ is unsymmetric),
    precise integration and DOP853 agree, and no energy is lost to the gyroscopic forces."""
    beam = _shaft(spin_speed=1500.0, supports=[fe.Support(node="start", kind="pinned"),
                                               fe.Support(node="end", kind="pinned")])
    force = np.zeros(beam.n_dof)
    force[beam.dof(3, direction="x")] = 1e3
    x0 = np.linalg.solve(beam.structure.dense_matrices()[1], force)  # a static deflection
    model = beam.model(initial_displacement=x0)
    i = beam.dof(3, direction="y")
    ref = vi.simulate(model, t_end=0.02, dt=2e-6, method=vi.Dop853(adaptive=None))
    for method, tol in ((vi.Newmark(), 2e-3), (vi.PreciseIntegration(), 1e-6)):
        r = vi.simulate(model, t_end=0.02, dt=2e-6, method=method)
        scale = np.abs(ref.displacement[:, i]).max()
        assert scale > 1e-6  # the gyroscopic coupling moved y
        assert np.abs(r.displacement[:, i] - ref.displacement[:, i]).max() < tol * scale
        if isinstance(method, vi.Newmark):
            e = r.energy
            assert np.abs(e.damping_dissipated).max() < 1e-12 * e.total[0]
            assert np.abs(e.total - e.total[0]).max() < 1e-9 * e.total[0]


def test_newmark_refuses_a_spinning_rotor_too_large_for_the_dense_lu() -> None:
    beam = _shaft(elements=1300, discs=[fe.Disc(node=650, mass=30.0, polar_inertia=0.6)],
                  spin_speed=100.0, supports=[fe.Support(node="start", kind="pinned")])
    with pytest.raises(vi.ModelError, match=r"^structure\.gyroscopic: .*unsymmetric") as e:
        vi.simulate(beam.model(), t_end=1e-5, dt=1e-5)
    assert "\n" not in str(e.value)


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "vibroimpact", *args],
                          capture_output=True, text=True, timeout=300)


ROTOR_FILE = """
[structure]
kind = "beam"
length = 1.2
elements = 8
dofs_per_node = 4
spin_speed = 300.0
section = { kind = "circle", diameter = 0.06 }
material = { youngs_modulus = 2.1e11, poisson = 0.3, density = 7810.0 }

[[structure.discs]]
node = 3
mass = 30.0
polar_inertia = 0.6
diametral_inertia = 0.3

[[structure.bearings]]
node = "start"
kxx = 2e7
kyy = 3e7
cxx = 300.0
cyy = 300.0

[[structure.bearings]]
node = "end"
kxx = 2e7
kyy = 3e7

[[loads]]
kind = "unbalance"
node = 3
magnitude = 1e-4
phase = 0.2

[solver]
dt = 1e-5
t_end = 1e-3
"""


def test_model_file_rotor_and_modal_speed_json(tmp_path: Path) -> None:
    path = tmp_path / "rotor.toml"
    path.write_text(ROTOR_FILE)
    mf = vi.load_model(path)
    api = _shaft(bearings=[fe.Bearing(node="start", kxx=2e7, kyy=3e7, cxx=300.0, cyy=300.0),
                           fe.Bearing(node="end", kxx=2e7, kyy=3e7)], spin_speed=300.0)
    st = mf.model.structure
    assert st.spin_speed == 300.0
    assert abs(st.gyroscopic - api.structure.gyroscopic).max() == 0
    (x_load, y_load) = mf.model.applied_loads
    assert (x_load.dof, y_load.dof) == (api.dof(3, direction="x"), api.dof(3, direction="y"))
    assert x_load.amplitude == pytest.approx(1e-4 * 300.0**2, rel=1e-15)
    p = _cli("modal", str(path), "--speed", "0:900:4", "--modes", "4", "--json",
             "--plot", str(tmp_path / "campbell.png"))
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    expected = rotor.campbell(st, np.linspace(0, 900, 4), 4,
                              rotor.translation_pairs(api.dof_map, st.n_dof))
    assert out["speeds_rad_s"] == pytest.approx([0, 300, 600, 900])
    np.testing.assert_allclose(out["frequencies_hz"], expected.frequencies_hz, rtol=1e-12)
    assert out["whirl"] == [list(w) for w in expected.whirl]
    assert (tmp_path / "campbell.png").stat().st_size > 0


@pytest.mark.parametrize(("text", "field"), [
    ('[structure]\nkind = "jeffcott"\nstiffness = 1e6\n', "structure.mass"),
    ('[structure]\nkind = "jeffcott"\nmass = 1.0\nstiffness = [1e6, 2e6, 3e6]\n',
     "structure.stiffness"),
    ('[structure]\nkind = "jeffcott"\nmass = 1.0\n[[loads]]\nkind = "unbalance"\ndof = [0]\n'
     'magnitude = 1e-3\n', "loads[0].dof"),
    ('[structure]\nkind = "jeffcott"\nmass = 1.0\n[[loads]]\nkind = "unbalance"\n'
     'dof = [0, 1]\nmagnitude = -1.0\n', "loads[0].magnitude"),
    ('[structure]\nkind = "matrices"\nmass = [[1.0, 0.0], [0.0, 1.0]]\n'
     'gyroscopic = [[0.0, 1.0], [1.0, 0.0]]\nspin_speed = 10.0\n', "structure.gyroscopic"),
])
def test_bad_rotor_input_is_one_line_naming_the_field(tmp_path: Path, text: str,
                                                      field: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text + '[solver]\ndt = 1e-4\nt_end = 1e-3\n')
    p = _cli("run", str(path), "-o", str(tmp_path / "out.nc"))
    assert p.returncode == 2
    lines = [ln for ln in p.stderr.strip().splitlines() if field in ln]
    assert lines, p.stderr
    assert "Traceback" not in p.stderr
    assert not (tmp_path / "out.nc").exists()


def test_bad_speed_option_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "rotor.toml"
    path.write_text(ROTOR_FILE)
    p = _cli("modal", str(path), "--speed", "0:900")
    assert p.returncode == 2
    assert p.stderr.strip().count("\n") == 0 and "--speed" in p.stderr
