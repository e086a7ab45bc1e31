"""The 2-D radial gap (docs/rotors.md §Radial gaps) against independent solutions: SciPy's
event-located DOP853 on a rubbing Jeffcott rotor, the invariants of a free rotor bouncing in
its stator (energy, angular momentum about the centre), the closed-form synchronous full
annular rub and its rotating-frame stability, and one-line refusals of bad input."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact.benchmarks.rotor_rub import RubRotor, scipy_rub
from vibroimpact.errors import ModelError, SolverError
from vibroimpact.model import UnbalanceLoad

ROOT = Path(__file__).resolve().parents[1]

# The rubbing rotor of the benchmark (examples/models/jeffcott_seal_rub.toml): 1 kg on 1e4 N/m
# (critical speed 100 rad/s), 150 rad/s, unbalance 1e-4 kg·m (free whirl radius 0.179 mm) in
# a 0.1 mm seal, a linear stator of 1e6 N/m.
_P = RubRotor()
M, K, OMEGA, ME, CLEARANCE, KS = (_P.mass, _P.stiffness, _P.spin_speed, _P.unbalance,
                                  _P.clearance, _P.stator_stiffness)


def rotor(damping: float, friction: float = 0.0, radius: float | None = None,
          friction_law: str = "coulomb", regularisation_speed: float | None = None,
          law: vi.contact.ContactLaw | None = None, stiffness: float = K,
          unbalance: float = ME, spin: float = OMEGA,
          x0: tuple[float, ...] = (0, 0), v0: tuple[float, ...] = (0, 0)) -> vi.Model:
    gap = vi.RadialGap(dof=[0, 1], clearance=CLEARANCE,
                       law=law or vi.contact.Hertz(stiffness=KS, exponent=1.0),
                       friction=friction, radius=radius, friction_law=friction_law,  # type: ignore[arg-type]
                       regularisation_speed=regularisation_speed)
    loads = [UnbalanceLoad(dof=[0, 1], magnitude=unbalance, phase=0.0)] if unbalance else []
    st = vi.Structure.jeffcott(mass=M, stiffness=stiffness, damping=damping, spin_speed=spin)
    return vi.Model(st, gaps=[gap], loads=loads, initial_displacement=list(x0),
                    initial_velocity=list(v0))


@pytest.mark.parametrize("friction", [None, (0.1, 0.01, 0.05)], ids=["frictionless", "friction"])
@pytest.mark.parametrize("method, dt, tol", [
    (vi.Dop853(adaptive=vi.Adaptive(rtol=1e-10, atol=1e-14)), 1e-4, 1e-6),
    (vi.Newmark(), 1e-6, 2e-5),
    (vi.integrators.HHT(), 1e-6, 2e-5),
    (vi.Newmark(adaptive=vi.Adaptive(rtol=1e-8, atol=1e-13)), 1e-5, 2e-4),
], ids=["dop853", "newmark", "hht", "newmark-adaptive"])
def test_rub_equals_scipy_event_located(friction: tuple[float, float, float] | None,
                                        method: vi.integrators.Integrator, dt: float,
                                        tol: float) -> None:
    """Thirteen to twenty-one rubs in 0.2 s: the final state (to `tol` of the clearance: DOP853
    at rtol 1e-10 measures 4e-8, Newmark average acceleration and HHT at dt = 1 µs 2e-6,
    adaptive Newmark at rtol 1e-8 5e-5) and every onset (to 1e-8 s with DOP853, 1e-6 s else)
    equal SciPy's; a friction force of the wrong sign or size, or a normal force off the
    normal, moves the orbit by the clearance itself."""
    mu, radius, v_reg = friction or (0.0, 0.0, 1.0)
    model = rotor(10.0, *((mu, radius, "regularised", v_reg) if friction else ()))
    t_end = 0.2
    # SciPy's event-located DOP853 (the benchmark's reference, written from the physics)
    y_ref, onsets = scipy_rub(RubRotor(friction=mu, radius=radius, regularisation_speed=v_reg),
                              t_end)
    r = vi.simulate(model, t_end=t_end, dt=dt, method=method)
    assert len(onsets) >= 13
    assert np.abs(r.displacement[-1] - y_ref[:2]).max() < tol * CLEARANCE
    assert np.abs(r.velocity[-1] - y_ref[2:]).max() < tol * CLEARANCE * OMEGA * 10
    assert len(r.impacts) == len(onsets)
    assert np.abs(r.impacts.t_start - onsets).max() < (1e-8 if tol < 2e-5 else 1e-6)
    assert set(r.impacts.side) == {"radial"}
    if friction:  # |F_T| = μ F_N tanh(...) <= μ F_N, and close to it (v_rel ≈ R Ω ≫ v_reg)
        assert np.all(r.impacts.friction_max <= mu * r.impacts.force_max * (1 + 1e-9))
        assert np.all(r.impacts.friction_max > 0.9 * mu * r.impacts.force_max)
    else:
        assert np.all(r.impacts.friction_max == 0)


def test_coulomb_sticking_stops_with_one_line() -> None:
    """A rotor at rest (Ω = 0) thrown obliquely into the stator under Coulomb friction: the
    friction brings the sliding speed to zero inside the contact, which stops the run with
    one line offering the regularised law; regularised, the same run goes through."""
    kw = dict(damping=0.0, friction=0.5, radius=0.01, stiffness=0.0, unbalance=0.0, spin=0.0,
              x0=(0.0, 0.0), v0=(1.0, 0.05))
    with pytest.raises(SolverError) as e:
        vi.simulate(rotor(**kw), t_end=2e-3, dt=1e-6, method=vi.Dop853())  # type: ignore[arg-type]
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("gaps[0]: the sliding speed")
    assert "sticking is not modelled" in msg and "friction_law = 'regularised'" in msg
    t_stick = float(msg.split("at t = ")[1].split(" s")[0])
    assert 1e-4 < t_stick < 2e-3
    r = vi.simulate(rotor(**{**kw, "friction_law": "regularised",  # type: ignore[arg-type]
                             "regularisation_speed": 1e-3}), t_end=2e-3, dt=1e-6,
                    method=vi.Dop853())
    assert r.complete and len(r.impacts) >= 1


@pytest.mark.parametrize("law", [vi.contact.Hertz(stiffness=1e13, exponent=1.5),
                                 vi.contact.Hertz(stiffness=1e10, exponent=1.0)],
                         ids=["hertz", "linear"])
def test_free_rotor_conserves_energy_and_angular_momentum(law: vi.contact.ContactLaw) -> None:
    """No spring, damping, friction or load: a rotor thrown across its stator bounces off it
    hundreds of times; between contacts its kinetic energy stays the one it was thrown with
    (to 1e-9 with DOP853, measured 4e-10; 5e-4 with Newmark average acceleration at ~100 steps
    a contact, measured 1.2e-4) and its angular momentum m (x y' − y x') about the centre too
    (to 1e-10 of m |v| c, measured 1e-13), where a normal off the radius by 1e-6 rad would
    change it by 2e-6 m |v| c at each contact."""
    v0 = (0.3, 1.0)
    model = rotor(0.0, law=law, stiffness=0.0, unbalance=0.0, spin=0.0, x0=(2e-5, -1e-5),
                  v0=v0)
    e0 = 0.5 * M * (v0[0] ** 2 + v0[1] ** 2)
    l0 = M * (2e-5 * v0[1] + 1e-5 * v0[0])
    for method, dt, tol in ((vi.Dop853(adaptive=vi.Adaptive(rtol=1e-12, atol=1e-16)), 1e-5, 1e-9),
                            (vi.Newmark(), 2e-7, 5e-4)):
        r = vi.simulate(model, t_end=0.06, dt=dt, method=method)
        assert len(r.impacts) > 200
        free = r.gap_penetration[:, 0] < 0
        x, v = r.displacement[free], r.velocity[free]
        energy = 0.5 * M * (v**2).sum(axis=1)
        momentum = M * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0])
        assert np.abs(energy / e0 - 1).max() < tol
        # relative to the momentum a contact could change: m |v| c
        assert np.abs(momentum - l0).max() < 1e-10 * M * math.hypot(*v0) * CLEARANCE
        assert abs(l0) > 0.1 * M * math.hypot(*v0) * CLEARANCE  # not a trivially radial throw


def test_bad_input_gives_one_line() -> None:
    law = vi.contact.Hertz(stiffness=1e6, exponent=1.0)
    cases = [
        (dict(dof=[0]), "gap.dof: [0] is not valid; expected two DOFs [ix, iy]"),
        (dict(dof=[0, 1, 2]), "gap.dof: [0, 1, 2] is not valid; expected two DOFs"),
        (dict(dof=[1, 1]), "gap.dof: [1, 1] is not valid; expected two different DOFs"),
        (dict(clearance=-1e-3), "gap.clearance: -0.001 is not valid; expected a clearance >= 0"),
        (dict(friction=0.2), "gap.radius: None is not valid; expected the rotor's radius"),
        (dict(friction=-0.1), "gap.friction: -0.1 is not valid"),
        (dict(center=[0.0]), "gap.center: [0.0] is not valid; expected two numbers"),
        (dict(friction=0.1, radius=0.01, friction_law="regularised"),
         "gap.regularisation_speed: None is not valid; expected a speed > 0"),
        (dict(friction_law="viscous"), "gap.friction_law: 'viscous' is not valid"),
        (dict(law=vi.contact.Rigid(restitution=0.5)), "gap.law: "),
    ]
    for kw, start in cases:
        with pytest.raises(ModelError) as e:
            vi.RadialGap(**{"dof": [0, 1], "clearance": 1e-3, "law": law, **kw})  # type: ignore[arg-type]
        assert str(e.value).startswith(start) and "\n" not in str(e.value), str(e.value)
    model = rotor(1.0)
    with pytest.raises(ModelError, match=r"^gaps\[0\]\.kind: 'radial' is not available with "
                                         r"solver\.method 'precise'"):
        vi.simulate(model, t_end=1e-3, dt=1e-5, method=vi.integrators.PreciseIntegration())
    with pytest.raises(ModelError, match=r"^gaps\[0\]\.law\.kind: 'hertz' is a force law"):
        vi.simulate(model, t_end=1e-3, dt=1e-5, method=vi.integrators.MoreauJean())
    with pytest.raises(ModelError, match=r"^gaps\[0\]\.kind: 'radial' has no state-transition "
                                         r"matrix with method 'newmark' yet"):
        vi.periodic_orbit(model, transient=2, method=vi.Newmark(), dt=1e-5)
    # the sliding speed R Ω of a run-up is not followed yet: refused, not run at Ω(0)
    rubbing = rotor(1.0, friction=0.1, radius=0.01, friction_law="regularised",
                    regularisation_speed=0.05)
    running_up = dataclasses.replace(rubbing, structure=rubbing.structure.run_up(300.0, 0.1))
    with pytest.raises(ModelError, match=r"^gaps\[0\]\.friction: 0.1 on a radial gap during a "
                                         r"run-up is not available yet"):
        vi.simulate(running_up, t_end=1e-3, dt=1e-5, method=vi.Dop853())
    vi.simulate(dataclasses.replace(model, structure=model.structure.run_up(300.0, 0.1)),
                t_end=1e-3, dt=1e-5, method=vi.Dop853())  # frictionless: runs


def test_model_file_radial_gap(tmp_path: Path) -> None:
    """examples/models/jeffcott_seal_rub.toml runs as the same model built in Python; a bad field
    is one line naming it."""
    mf = vi.load_model(ROOT / "examples" / "models" / "jeffcott_seal_rub.toml")
    gap = mf.model.gaps[0]
    assert isinstance(gap, vi.RadialGap) and gap.dofs == (0, 1) and gap.friction == 0.05
    assert gap.friction_law == "regularised" and gap.regularisation_speed == 0.05
    text = (ROOT / "examples" / "models" / "jeffcott_seal_rub.toml").read_text()
    for old, new, line in (
        ("friction = 0.05\n", "friction = 0.05\nside = \"both\"\n", "gaps[0].side"),
        ("dof = [0, 1]\nclearance", "dof = [0, 1]\ndirections = [\"x\", \"y\"]\nclearance",
         "gaps[0].directions"),
        ("radius = 0.01 ", "radius = -0.01 ", "gaps[0].radius: -0.01 is not valid"),
        ("dof = [0, 1]\nclearance", "dof = [0]\nclearance", "gaps[0].dof: [0] is not valid"),
        ("regularisation_speed = 0.05 ", "", "gaps[0].regularisation_speed"),
    ):
        bad = tmp_path / "bad.toml"
        bad.write_text(text.replace(old, new, 1))
        with pytest.raises(ModelError) as e:
            vi.load_model(bad)
        assert line in str(e.value), str(e.value)


def full_annular_rub(damping: float, mu: float, spin: float = OMEGA) -> list[complex]:
    """The synchronous full annular rub's steady whirl w = ρ e^{−iφ} (z = x + iy = w e^{iΩt}):
    with s = k_s (1 − c/ρ), (k − mΩ² + icΩ + s (1 + iμ)) w = m e Ω², whose modulus is the
    quadratic (a ρ − k_s c)² + (b ρ − μ k_s c)² = (m e Ω²)² in ρ (a = k − mΩ² + k_s,
    b = cΩ + μ k_s; docs/rotors.md §Full annular rub) at the spin speed Ω = ``spin``. The
    roots with ρ > c."""
    f = ME * spin**2
    a, b = K - M * spin**2 + KS, damping * spin + mu * KS
    qa, qb = a * a + b * b, KS * CLEARANCE * (a + mu * b)
    qc = KS**2 * CLEARANCE**2 * (1 + mu**2) - f**2
    disc = qb * qb - qa * qc
    roots = [(qb + sign * math.sqrt(disc)) / qa for sign in (1, -1)] if disc >= 0 else []
    out = []
    for rho in (r for r in roots if r > CLEARANCE):
        s = KS * (1 - CLEARANCE / rho)
        out.append(f / (K - M * spin**2 + s + 1j * (damping * spin + mu * s)))
    return out


def rotating_frame(damping: float, mu: float):
    """The rubbing rotor's equation in the frame turning at Ω, w = z e^{−iΩt}: m (w'' + 2iΩw'
    − Ω²w) + c (w' + iΩw) + k w + k_s (|w| − c)(1 + iμ) w/|w| = m e Ω² (Coulomb friction with
    v_rel > 0), as a first-order system in (Re w, Im w, Re w', Im w')."""
    def f(y: np.ndarray) -> np.ndarray:
        w, wd = y[0] + 1j * y[1], y[2] + 1j * y[3]
        r = abs(w)
        contact = KS * (r - CLEARANCE) * (1 + 1j * mu) * w / r if r > CLEARANCE else 0
        wdd = (ME * OMEGA**2 - contact - K * w - damping * (wd + 1j * OMEGA * w)
               - M * (2j * OMEGA * wd - OMEGA**2 * w)) / M
        return np.array([wd.real, wd.imag, wdd.real, wdd.imag])
    return f


def rotating_eigenvalues(damping: float, mu: float, w: complex) -> np.ndarray:
    """Eigenvalues of the rotating-frame linearisation at the steady whirl w (its Jacobian by
    central differences)."""
    f, y0 = rotating_frame(damping, mu), np.array([w.real, w.imag, 0.0, 0.0])
    jac = np.zeros((4, 4))
    for j, h in enumerate((1e-9 * abs(w),) * 2 + (1e-6,) * 2):
        e = np.zeros(4)
        e[j] = h
        jac[:, j] = (f(y0 + e) - f(y0 - e)) / (2 * h)
    return np.linalg.eigvals(jac)


@pytest.mark.parametrize("damping, mu, stable", [(50.0, 0.1, True), (50.0, 0.3, False)])
def test_full_annular_rub_closed_form_and_stability(damping: float, mu: float,
                                                    stable: bool) -> None:
    """Started 0.1 % off the closed-form whirl: where the rotating-frame eigenvalues all have
    Re < 0 (μ = 0.1: −10.4 1/s) the run converges onto it (to 1e-7 of ρ after 1.5 s), where
    one has Re > 0 (μ = 0.3: +18.3 1/s) it leaves it (by more than 10 % of its penetration
    ρ − c within 0.6 s)."""
    (w,) = full_annular_rub(damping, mu)
    assert np.abs(rotating_frame(damping, mu)(np.array([w.real, w.imag, 0, 0]))).max() < 1e-9
    growth = rotating_eigenvalues(damping, mu, w).real.max()
    assert (growth < -5.0) if stable else (growth > 5.0)
    rho = abs(w)
    w0 = w * (1 + 1e-3)  # perturbed in the radius: into the stator
    model = rotor(damping, friction=mu, radius=0.01,
                  x0=(w0.real, w0.imag), v0=((1j * OMEGA * w0).real, (1j * OMEGA * w0).imag))
    t_end = 1.5 if stable else 0.6
    r = vi.simulate(model, t_end=t_end, dt=1e-4,
                    method=vi.Dop853(adaptive=vi.Adaptive(rtol=1e-11, atol=1e-16)))
    z = r.displacement[:, 0] + 1j * r.displacement[:, 1]
    off = np.abs(z * np.exp(-1j * OMEGA * r.time) - w)
    if stable:
        assert len(r.impacts) == 1 and math.isnan(r.impacts.t_end[0])  # one contact, all along
        assert off[r.time > 1.4].max() < 1e-7 * rho
        assert off[0] > 1e-4 * rho
    else:
        assert off.max() > 0.1 * (rho - CLEARANCE)


def test_full_annular_rub_orbit_is_one_contact_without_onset() -> None:
    """The stable full rub (μ = 0.1) as a periodic orbit: one contact under way all period
    (one row from t = 0, no end), so ``impacts_per_period`` — contact onsets — is 0, and the
    contact shows in ``penetration_max`` and ``force_max``: the closed form's ``ρ − c`` and
    ``k_s (ρ − c)`` to 1e-9."""
    from vibroimpact.orbits import periodic_orbit

    (w,) = full_annular_rub(50.0, 0.1)
    z = 1j * OMEGA * w
    model = rotor(50.0, friction=0.1, radius=0.01, x0=(w.real, w.imag), v0=(z.real, z.imag))
    orbit = periodic_orbit(model, transient=5)
    assert orbit.impacts_per_period == 0
    assert len(orbit.impacts) == 1 and orbit.impacts.t_start[0] == 0.0
    assert math.isnan(orbit.impacts.t_end[0])
    depth = abs(w) - CLEARANCE
    assert orbit.penetration_max[0] == pytest.approx(depth, rel=1e-9)
    assert orbit.force_max[0] == pytest.approx(KS * depth, rel=1e-9)


def test_rub_benchmark_errors_equal_those_against_scipy() -> None:
    """The accuracy `vibroimpact bench` states for the rub's long runs (against our DOP853
    at rtol 1e-13) is their distance from SciPy's event-located DOP853 at rtol 1e-13 (here
    over 20 revolutions), to within the two references' own difference; the reference is
    converged (1e-12 against 1e-13) well below the errors it measures."""
    from vibroimpact.benchmarks.rotor_rub import rub_benchmark, rub_model

    p = RubRotor()
    revolutions = 20
    period = 2 * math.pi / p.spin_speed
    b = rub_benchmark(repeats=1, revolutions=2, long_revolutions=revolutions)
    y, _ = scipy_rub(p, revolutions * period, rtol=1e-13)
    for key, method, dt in (
            ("dop853_loose", vi.Dop853(adaptive=vi.Adaptive(rtol=1e-8, atol=1e-14)), period / 100),
            ("dop853_coarse", vi.Dop853(adaptive=vi.Adaptive(rtol=1e-6, atol=1e-14)),
             period / 100),
            ("newmark", vi.Newmark(), period / 200)):
        r = vi.simulate(rub_model(p), t_end=revolutions * period, dt=dt, method=method,
                        every=1_000_000)
        against_scipy = float(np.abs(r.displacement[-1] - y[:2]).max())
        assert b[f"{key}_1000_error_m"] == pytest.approx(against_scipy, abs=1e-13), key
        assert b[f"{key}_1000_error_m"] > 1e3 * b["reference_convergence_m"], key
    assert b["reference_convergence_m"] < 1e-13 * revolutions
    assert (b["reference_contacts_1000"] == b["newmark_contacts_1000"] == b["contacts_1000"]
            == b["dop853_coarse_contacts_1000"])
