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


def test_full_annular_rub_branch_and_its_loss_of_stability() -> None:
    """Continued in the spin speed from 150 to 300 rad/s (μ = 0.1), every point is the closed-
    form whirl at its speed (to 1e-9 of ρ) and the branch loses its stability at the one
    Neimark–Sacker point, where the rotating frame's largest real part crosses zero
    (266.9 rad/s, to 1e-6), with its largest multipliers on the unit circle there (1e-5)."""
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
