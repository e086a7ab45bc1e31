"""Rotor run-ups (docs/rotors.md, Run-up): the unbalance force with its angular-acceleration
term and the gyroscopic forces Ω(t) G, against SciPy's ``solve_ivp`` (the angle integrated as a
state of its own), the implicit methods' one-line refusal, the model file's fields and a result
file's round trip."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate
import scipy.sparse as sp
import vibroimpact as vi
from vibroimpact import fe
from vibroimpact.io import results_file

M, K, C, ME = 10.0, 1e6, 200.0, 1e-3  # kg, N/m, N·s/m, kg·m
W0, W1, T_UP = 60.0, 420.0, 0.25  # rad/s, rad/s, s


def _reference(model: vi.Model, w0: float, w1: float, t_up: float, t_end: float,
               times: np.ndarray, gyroscopic: bool = True,
               angular_acceleration: bool = True) -> np.ndarray:
    """``solve_ivp`` (DOP853, rtol 1e-10) of ``M x'' + (C + Ω(t) G) x' + K x = F`` with each
    unbalance's force ``m e (Ω² cos φ + Ω̇ sin φ, Ω² sin φ − Ω̇ cos φ)`` and ``φ' = Ω`` a
    state, in two legs split at the end of the run-up (Ω̇ jumps there). ``gyroscopic=False``:
    ``G`` held at ``Ω(0)`` (what a solver that ignored the run-up would do)."""
    st = model.structure
    m, k, c = st.dense_matrices()
    g = np.zeros_like(m) if st.gyroscopic is None else np.asarray(st.gyroscopic)
    n = st.n_dof
    minv = np.linalg.inv(m)

    def omega(t: float) -> tuple[float, float]:
        return (w0 + (w1 - w0) * t / t_up, (w1 - w0) / t_up) if t < t_up else (w1, 0.0)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        x, v, phi = y[:n], y[n:2 * n], y[2 * n]
        w, dw = omega(t)
        dw = dw if angular_acceleration else 0.0
        f = np.zeros(n)
        for ld in model.loads:
            ix, iy = ld.dofs
            angle = phi + ld.phase
            f[ix] += ld.magnitude * (w * w * math.cos(angle) + dw * math.sin(angle))
            f[iy] += ld.magnitude * (w * w * math.sin(angle) - dw * math.cos(angle))
        spin = w if gyroscopic else w0
        a = minv @ (f - (c + spin * g) @ v - k @ x)
        return np.concatenate([v, a, [w]])

    y = np.zeros(2 * n + 1)
    out = []
    for a, b in ((0.0, t_up), (t_up, t_end)):
        sol = scipy.integrate.solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-10,
                                        atol=1e-16, dense_output=True)
        assert sol.success
        inside = times[(times >= a) & ((times < b) | (b == t_end))]
        out.append(sol.sol(inside)[:n].T)
        y = sol.y[:, -1]
    return np.concatenate(out)


def _jeffcott() -> vi.Model:
    st = vi.Structure.jeffcott(mass=M, stiffness=K, damping=C, spin_speed=W0).run_up(W1, T_UP)
    return vi.Model(st, loads=[vi.UnbalanceLoad(dof=[0, 1], magnitude=ME, phase=0.3)])


def test_jeffcott_run_up_matches_solve_ivp() -> None:
    model, t_end = _jeffcott(), 0.35
    r = vi.simulate(model, t_end=t_end, dt=1e-4,
                    method=vi.Dop853(adaptive=vi.Adaptive(rtol=1e-12, atol=1e-16)))
    ref = _reference(model, W0, W1, T_UP, t_end, r.time)
    scale = np.abs(ref).max()
    assert scale > 1e-4  # through the critical speed (316 rad/s)
    error = np.abs(r.displacement - ref).max()
    assert error < 1e-8 * scale
    # the test sees the Ω̇ term: without it the reference is far off
    plain = _reference(model, W0, W1, T_UP, t_end, r.time, angular_acceleration=False)
    assert np.abs(plain - ref).max() > 1e3 * error


@pytest.mark.parametrize("method", [vi.Newmark(), vi.GeneralizedAlpha()])
def test_jeffcott_run_up_with_an_implicit_method(method: vi.Integrator) -> None:
    """No gyroscopic forces: the implicit methods take a run-up (only the load changes);
    second order in dt against the reference."""
    model, t_end = _jeffcott(), 0.3
    errors = []
    for dt in (2e-5, 1e-5):
        r = vi.simulate(model, t_end=t_end, dt=dt, method=method)
        ref = _reference(model, W0, W1, T_UP, t_end, r.time)
        errors.append(np.abs(r.displacement - ref).max())
    assert 3.5 < errors[0] / errors[1] < 4.5


def _beam_rotor(**kw: object) -> fe.Beam:
    return fe.Beam(length=0.8, elements=3, dofs_per_node=4, section=fe.Section.circle(0.05),
                   material=fe.Material(youngs_modulus=2.1e11, poisson=0.3, density=7810.0),
                   discs=[fe.Disc(node=2, mass=20.0, polar_inertia=0.8, diametral_inertia=0.4)],
                   bearings=[fe.Bearing(node="start", kxx=2e7, kyy=3e7, cxx=500.0, cyy=500.0),
                             fe.Bearing(node="end", kxx=2e7, kyy=3e7, cxx=500.0, cyy=500.0)],
                   **kw)  # type: ignore[arg-type]


def _beam_model(w0: float, w1: float, t_up: float) -> vi.Model:
    beam = _beam_rotor(spin_speed=w0)
    load = vi.UnbalanceLoad(dof=[beam.dof(2, direction="x"), beam.dof(2, direction="y")],
                            magnitude=2e-4, phase=-0.5)
    model = beam.model(loads=[load])
    return vi.Model(model.structure.run_up(w1, t_up), loads=model.loads)


def test_gyroscopic_beam_run_up_matches_solve_ivp() -> None:
    w0, w1, t_up, t_end = 500.0, 4000.0, 0.006, 0.01
    model = _beam_model(w0, w1, t_up)
    assert model.structure.gyroscopic is not None
    r = vi.simulate(model, t_end=t_end, dt=1e-6,
                    method=vi.Dop853(adaptive=vi.Adaptive(rtol=1e-12, atol=1e-16)))
    ref = _reference(model, w0, w1, t_up, t_end, r.time)
    scale = np.abs(ref).max()
    error = np.abs(r.displacement - ref).max()
    assert error < 1e-7 * scale
    # the test sees Ω(t) G: holding G at Ω(0) is far off
    frozen = _reference(model, w0, w1, t_up, t_end, r.time, gyroscopic=False)
    assert np.abs(frozen - ref).max() > 1e3 * error
    # G does no work: the energy account closes with the gyroscopic forces left out
    e = r.energy
    assert abs(e.balance[-1]) < 1e-8 * np.abs(e.total).max()


def test_implicit_methods_refuse_a_gyroscopic_run_up_in_one_line() -> None:
    model = _beam_model(200.0, 3000.0, 0.02)
    for method in (vi.Newmark(), vi.PreciseIntegration()):
        with pytest.raises(vi.ModelError, match=r"^structure\.spin_profile: .*'dop853'") as e:
            vi.simulate(model, t_end=1e-3, dt=1e-5, method=method)
        assert "\n" not in str(e.value)


def test_bad_run_up_values_are_refused_in_one_line() -> None:
    st = vi.Structure.jeffcott(mass=M, stiffness=K)
    for kw, field in (({"spin_speed_end": 1.0, "run_up_time": 0.0}, "run_up_time"),
                      ({"spin_speed_end": math.nan, "run_up_time": 1.0}, "spin_speed_end"),
                      ({"run_up_time": 1.0}, "spin_speed_end")):
        with pytest.raises(vi.ModelError, match=rf"^structure\.{field}"):
            vi.Structure(st.mass, st.stiffness, spin_profile="linear", **kw)
    with pytest.raises(vi.ModelError, match=r"^structure\.spin_speed_end.*'linear'"):
        vi.Structure(st.mass, st.stiffness, spin_speed_end=3.0)
    with pytest.raises(vi.ModelError, match=r"^structure\.spin_profile"):
        vi.Structure(st.mass, st.stiffness, spin_profile="cubic")


RUN_UP_FILE = """
[structure]
kind = "jeffcott"
mass = 10.0
stiffness = 1e6
damping = 200.0
spin_speed = 60.0
spin_profile = "linear"
spin_speed_end = 420.0
run_up_time = 0.25

[[loads]]
kind = "unbalance"
dof = [0, 1]
magnitude = 1e-3
phase = 0.3

[solver]
method = "dop853"
dt = 1e-4
t_end = 0.3
"""


def test_model_file_run_up_and_result_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "runup.toml"
    path.write_text(RUN_UP_FILE)
    mf = vi.load_model(path)
    assert mf.model.to_spec()["loads"] == _jeffcott().to_spec()["loads"]
    st = mf.model.structure
    assert (st.spin_profile, st.spin_speed_end, st.run_up_time) == ("linear", 420.0, 0.25)
    bad = tmp_path / "bad.toml"
    bad.write_text(RUN_UP_FILE.replace("run_up_time = 0.25\n", ""))
    p = subprocess.run([sys.executable, "-m", "vibroimpact", "run", str(bad)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "structure.run_up_time" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    # a gyroscopic beam with a run-up and an unbalance, saved and read back
    model = _beam_model(200.0, 3000.0, 0.02)
    r = vi.simulate(model, t_end=2e-3, dt=1e-5, method=vi.Dop853())
    out = tmp_path / "beam.nc"
    r.save(out)
    again, method = results_file.model_from_dataset(results_file.load(out))
    a, b = model.to_spec(), again.to_spec()
    for key in ("mass", "stiffness", "damping", "gyroscopic"):
        dense = [x.toarray() if sp.issparse(x) else np.asarray(x) for x in (a[key], b[key])]
        assert np.array_equal(*dense), key
    for key in ("spin_speed", "spin_profile", "spin_speed_end", "run_up_time", "loads"):
        assert a[key] == b[key], key
    rerun = vi.simulate(again, t_end=2e-3, dt=1e-5, method=method)
    assert np.array_equal(rerun.displacement, r.displacement)
