"""Rotor results and spin-speed paths (docs/rotors.md): the full spectrum on a synthetic
orbit, the revolution times against a quadrature of Ω(t), the per-revolution section on the
closed-form orbit, and continuation and sweeps over ``structure.spin_speed`` against the
closed-form unbalance response and rub-onset speed."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate
import vibroimpact as vi
from vibroimpact import rotor
from vibroimpact.cli import main as cli_main
from vibroimpact.io import results_file
from vibroimpact.sweeps import Param, Sweep, run_sweep

M, K, C, ME = 10.0, 1e6, 200.0, 1e-3  # kg, N/m, N·s/m, kg·m


def _model(speed: float = 250.0, **kw: object) -> vi.Model:
    st = vi.Structure.jeffcott(mass=M, stiffness=K, damping=C, spin_speed=speed)
    return vi.Model(st, loads=[vi.UnbalanceLoad(dof=[0, 1], magnitude=ME, phase=0.4)], **kw)


def test_full_spectrum_separates_forward_and_backward_whirl() -> None:
    n, dt = 1024, 1e-3
    f1 = 37 / (n * dt)  # whole numbers of cycles in the record: exact lines
    t = np.arange(n) * dt
    centre = 3e-5 - 1e-5j
    z = (centre + 2e-4 * np.exp(1j * (2 * np.pi * f1 * t + 0.3))
         + 7e-5 * np.exp(-1j * (2 * np.pi * 3 * f1 * t + 1.1)))
    s = rotor.full_spectrum(z.real, z.imag, dt)
    assert np.all(np.diff(s.frequency) > 0)
    for f, amplitude, phase in ((f1, 2e-4, 0.3), (-3 * f1, 7e-5, -1.1), (0.0, abs(centre),
                                                                          np.angle(centre))):
        k = int(np.argmin(np.abs(s.frequency - f)))
        assert abs(s.frequency[k] - f) < 1e-9 * f1
        assert abs(s.amplitude[k] - amplitude) < 1e-12 * amplitude
        assert abs(s.phase[k] - phase) < 1e-10
    others = np.ones(n, dtype=bool)
    others[[int(np.argmin(np.abs(s.frequency - f))) for f in (f1, -3 * f1, 0.0)]] = False
    assert s.amplitude[others].max() < 1e-12 * 2e-4
    with pytest.raises(vi.ModelError, match="dt"):
        rotor.full_spectrum(z.real, z.imag, 0.0)


@pytest.mark.parametrize("profile", [(120.0, None, None), (30.0, 400.0, 0.35),
                                     (0.0, 250.0, 0.2), (300.0, 100.0, 0.3)])
def test_revolution_times_against_a_quadrature_of_the_speed(profile: tuple) -> None:
    w0, w1, duration = profile
    st = vi.Structure.jeffcott(mass=M, stiffness=K, spin_speed=w0)
    if w1 is not None:
        st = st.run_up(w1, duration)

    def omega(t: float) -> float:  # written here, independently of Structure.spin
        return w0 if w1 is None else (w0 + (w1 - w0) * t / duration if t < duration else w1)

    phase, t_end = 0.7, 0.6
    times = rotor.revolution_times(st, t_end, phase=phase)
    k = np.arange(times.size) + (0 if phase >= 0 else 1)
    breaks = [duration] if w1 is not None else None
    for t, turns in zip(times, k, strict=True):
        angle = scipy.integrate.quad(omega, 0.0, t, points=breaks if breaks and t > duration
                                     else None, epsabs=0, epsrel=1e-13)[0]
        assert abs(angle - (2 * math.pi * turns + phase)) < 1e-11 * max(angle, 1.0)
    # every revolution of [0, t_end] is there
    total = scipy.integrate.quad(omega, 0.0, t_end, points=breaks, epsrel=1e-13)[0]
    assert times.size == math.floor((total - phase) / (2 * math.pi)) + 1


def test_per_revolution_section_of_the_steady_orbit_is_a_fixed_point() -> None:
    omega = 250.0
    z = rotor.unbalance_response(_model(omega), [omega])[0]
    model = _model(omega, initial_displacement=z.real, initial_velocity=(1j * omega * z).real)
    # fixed steps, 256 a revolution: rows land on the revolutions (DOP853: error ~(Ωh)^8)
    result = vi.simulate(model, t_end=20 * 2 * math.pi / omega, dt=2 * math.pi / omega / 256,
                         method=vi.Dop853(adaptive=None))
    section = rotor.per_revolution(result, transient=2 * 2 * math.pi / omega)
    assert section.revolution.tolist() == list(range(2, 21))
    assert np.allclose(section.speed, omega, rtol=0, atol=0)
    assert np.abs(section.displacement - z.real).max() < 1e-9 * abs(z).max()
    assert np.abs(section.velocity - (1j * omega * z).real).max() < 1e-9 * omega * abs(z).max()


def _expected_state(value: float) -> np.ndarray:
    z = rotor.unbalance_response(_model(value), [value])[0]
    return np.concatenate([z.real, (1j * value * z).real]), z


def test_continuation_in_spin_speed_is_the_unbalance_response() -> None:
    branch = vi.continue_orbit(_model(150.0), "structure.spin_speed", 150.0, 500.0,
                               transient=0, max_points=400, step=0.2, max_step=4.0, tol=1e-12)
    assert branch.points[-1].value == pytest.approx(500.0, abs=1e-9)
    for p in branch.points:
        expected, z = _expected_state(p.value)
        # the section's state at t = 0 is (Re Z, Re iΩZ): amplitude and phase
        assert np.abs(p.state - expected).max() < 1e-9 * p.value * np.abs(z).max()
        assert p.displacement_max[0] == pytest.approx(abs(z[0]), rel=1e-9)
        assert p.stable


def test_continuation_in_spin_speed_locates_the_rub_onset() -> None:
    clearance = 1e-3
    gap = vi.Gap(dof=0, clearance=clearance, side="positive",
                 law=vi.contact.Hertz(stiffness=1e9))
    model = _model(290.0, gaps=[gap])
    branch = vi.continue_orbit(model, "structure.spin_speed", 290.0, 312.0, transient=0,
                               max_points=80, step=0.1, max_step=0.3)
    grazing = [s.point.value for s in branch.special_points if s.type == "grazing"]
    free = vi.Model(model.structure, loads=model.loads)
    onset = rotor.rub_onset_speeds(free, [0, 1], clearance, (100.0, 1000.0))[0]
    assert len(grazing) == 1
    assert grazing[0] == pytest.approx(onset, rel=1e-9)
    assert branch.points[-1].impacts_per_period == 1


def test_sweep_over_spin_speed_gives_the_unbalance_amplitudes() -> None:
    speeds = np.linspace(150.0, 500.0, 8)
    z0 = rotor.unbalance_response(_model(150.0), [150.0])[0]
    model = _model(150.0, initial_displacement=z0.real,
                   initial_velocity=(1j * 150.0 * z0).real)
    sweep = Sweep(model, [Param("structure.spin_speed", speeds)], dt=1e-4,
                  method=vi.Dop853(adaptive=vi.Adaptive(rtol=1e-12, atol=1e-16)),
                  transient=250, periods=4, continuation="up")
    ds = run_sweep(sweep, progress=False)
    z = rotor.unbalance_response(model, speeds)
    assert ds["forcing_period"].values == pytest.approx(2 * np.pi / speeds, rel=1e-15)
    for name in ("displacement_max", "displacement_min"):
        got = np.abs(ds[name].values)
        assert np.abs(got - np.abs(z)).max() < 1e-9 * np.abs(z).max(), name
    # the section at whole revolutions: Re Z (the transient of 60 revolutions decayed)
    assert np.abs(ds.poincare_displacement.values[:, -1, :] - z.real).max() < 1e-9 * np.abs(
        z).max()


def test_waterfall_of_a_speed_sweep_is_the_forward_synchronous_whirl(tmp_path: Path) -> None:
    speeds = np.linspace(200.0, 450.0, 4)
    z0 = rotor.unbalance_response(_model(200.0), [200.0])[0]
    model = _model(200.0, initial_displacement=z0.real,
                   initial_velocity=(1j * 200.0 * z0).real)
    # fixed steps: a whole number between samples, which land on step ends
    sweep = Sweep(model, [Param("structure.spin_speed", speeds)], dt=5e-5,
                  method=vi.Dop853(adaptive=None), transient=250, periods=4,
                  continuation="up", samples_per_period=16)
    out = tmp_path / "speeds.nc"
    ds = run_sweep(sweep, output=out, progress=False)
    assert ds.sizes["sample"] == 64 and ds.attrs["samples_per_period"] == 16
    w = rotor.waterfall(ds)
    z = rotor.unbalance_response(model, speeds)
    for k, speed in enumerate(speeds):
        s = rotor.FullSpectrum(w.frequency[k], w.amplitude[k], np.zeros_like(w.amplitude[k]))
        # a circular forward orbit x + iy = Z e^{iΩt}: one line at +Ω/2π of radius |Z|
        assert s.at(speed / (2 * np.pi)) == pytest.approx(abs(z[k, 0]), rel=1e-9)
        assert s.at(-speed / (2 * np.pi)) < 1e-9 * abs(z[k, 0])
    assert cli_main(["plot", str(out), "--kind", "waterfall", "-o",
                        str(tmp_path / "w.png")]) == 0
    with pytest.raises(vi.ModelError, match="--samples-per-period"):
        rotor.waterfall(run_sweep(Sweep(model, [Param("structure.spin_speed", speeds)],
                                        dt=1e-4, transient=1, periods=2), progress=False))


def test_orbit_plot_and_cli_paths_over_spin_speed(tmp_path: Path) -> None:
    model_file = tmp_path / "jeffcott.toml"
    model_file.write_text(JEFFCOTT_FILE)
    result = tmp_path / "run.nc"
    assert cli_main(["run", str(model_file), "-o", str(result), "--quiet"]) == 0
    assert cli_main(["plot", str(result), "--kind", "orbit", "--dof", "0", "--dof", "1",
                        "--clearance", "1e-3", "--center", "0", "1e-5",
                        "-o", str(tmp_path / "o.svg")]) == 0
    ax = vi.plotting.plot(results_file.load(result), "orbit", clearance=1e-3).axes[0]
    assert "[m]" in ax.get_xlabel() and "[m]" in ax.get_ylabel()
    x, y = ax.get_lines()[1].get_data()  # the clearance circle
    assert np.hypot(x, y) == pytest.approx(1e-3, rel=1e-12)
    for bad, field in ((["--dof", "0"], "--dof"), (["--clearance", "-1"], "--clearance")):
        p = subprocess.run([sys.executable, "-m", "vibroimpact", "plot", str(result), "--kind",
                            "orbit", *bad, "-o", str(tmp_path / "x.png")],
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 2 and field in p.stderr and len(p.stderr.splitlines()) == 1
    # continue and sweep on the command line, over the spin speed
    branch = tmp_path / "branch.nc"
    p = subprocess.run([sys.executable, "-m", "vibroimpact", "continue", str(model_file),
                        "--param", "structure.spin_speed=290:312", "--json", "-o", str(branch)],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    grazing = [s["value"] for s in json.loads(p.stdout)["special_points"]
               if s["type"] == "grazing"]
    free = vi.Model(vi.Structure.jeffcott(mass=M, stiffness=K, damping=C),
                    loads=[vi.UnbalanceLoad(dof=[0, 1], magnitude=ME)])
    assert grazing == pytest.approx(rotor.rub_onset_speeds(free, [0, 1], 1e-3, (100.0, 310.0)),
                                    rel=1e-9)
    p = subprocess.run([sys.executable, "-m", "vibroimpact", "sweep", str(model_file),
                        "--param", "structure.spin_speed=200:400:3", "--transient", "5",
                        "--periods", "2", "--samples-per-period", "8", "--quiet",
                        "-o", str(tmp_path / "s.nc")], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    assert results_file_sizes(tmp_path / "s.nc") == 16


def results_file_sizes(path: Path) -> int:
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return int(ds.sizes["sample"])


JEFFCOTT_FILE = """
[structure]
kind = "jeffcott"
mass = 10.0
stiffness = 1e6
damping = 200.0
spin_speed = 250.0

[[gaps]]
dof = 0
clearance = 1e-3
side = "positive"
[gaps.law]
kind = "hertz"
stiffness = 1e9

[[loads]]
kind = "unbalance"
dof = [0, 1]
magnitude = 1e-3

[solver]
method = "dop853"
dt = 1e-4
t_end = 0.1
"""


def test_spin_speed_paths_are_refused_in_one_line() -> None:
    plain = vi.Model(vi.Structure.sdof(mass=1.0, stiffness=1.0),
                     loads=[vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=1.0)])
    with pytest.raises(vi.ModelError, match=r"structure\.spin_speed_end"):
        vi.sweeps.apply(_model().to_spec(), "structure.spin_speed_end", 1.0)
    assert "structure.spin_speed" in vi.sweeps.numeric_paths(_model().to_spec())
    assert "structure.spin_speed" not in vi.sweeps.numeric_paths(plain.to_spec())
    spun = _model().structure.run_up(400.0, 0.5)
    with pytest.raises(vi.ModelError, match=r"structure\.spin_profile.*not periodic"):
        vi.periodic_orbit(vi.Model(spun, loads=_model().loads))
