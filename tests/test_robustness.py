"""Solver failures (issue 10, item 2), each triggered deliberately: the message names the
time, the gap and a remedy on one line; ``vibroimpact run -o OUT`` keeps the results up to the
failure in OUT marked incomplete (``complete = 0``) and exits with code 3. Also the warning for
a step too long to resolve a contact, and a run with cut steps equal to one at the cut size."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact.io import results_file
from vibroimpact.paper import cases
from vibroimpact.simulate import contact_periods

PAPER = Path(__file__).parents[1] / "examples" / "models" / "sdof_paper_ln.toml"

SDOF_GAP = """
[[gaps]]
dof = 0
clearance = {clearance}
side = "both"
[gaps.law]
kind = "hertz"
stiffness = 1e9
exponent = 1.5
"""

# A stiff oscillator integrated by Newmark with a small beta beyond its stability limit
# (beta = 0.1: omega dt = 5 > 1/sqrt(1/4 - beta) = 2.58): the energy grows without bound.
UNSTABLE = """schema_version = 1
[structure]
kind = "sdof"
mass = 1.0
stiffness = {stiffness}
[initial]
displacement = 1e-3
[solver]
method = "newmark"
beta = {beta}
gamma = 0.5
dt = {dt}
t_end = {t_end}
"""

# K = -M/(beta dt^2) exactly (dt = 2^-10 s): K + M/(beta dt^2) is singular.
SINGULAR = """schema_version = 1
[structure]
kind = "matrices"
mass = [[1.0]]
stiffness = [[-4194304.0]]
[initial]
velocity = 1.0
[solver]
method = "newmark"
dt = 0.0009765625
t_end = 0.03125
"""


def _paper_with(solver_extra: str, dt: str = "5e-5") -> str:
    text = PAPER.read_text()
    text = text.replace("dt = 1e-6 ", f"dt = {dt} ")
    return text.replace('method = "newmark"', f'method = "newmark"\n{solver_extra}')


def _run_cli(tmp_path: Path, text: str, out: str = "out.nc", *extra: str,
             ) -> subprocess.CompletedProcess[str]:
    model = tmp_path / "model.toml"
    model.write_text(text)
    return subprocess.run(
        [sys.executable, "-m", "vibroimpact", "run", str(model), "-o", str(tmp_path / out),
         *extra],
        capture_output=True, text=True, timeout=120,
    )


def _check_incomplete_file(tmp_path: Path, out: str, message: str) -> object:
    ds = results_file.load(tmp_path / out)
    assert int(ds.attrs["complete"]) == 0
    assert message in ds.attrs["message"]
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    return ds


def _check_failure_line(proc: subprocess.CompletedProcess[str], *words: str) -> str:
    assert proc.returncode == 3, proc.stderr
    lines = proc.stderr.splitlines()
    failed = [ln for ln in lines if ln.startswith("vibroimpact: solver failed: ")]
    assert len(failed) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    for w in words:
        assert w in failed[0], failed[0]
    assert any("marked incomplete" in ln for ln in lines), proc.stderr
    return failed[0]


# --------------------------------------------------------------------------------------------
# Newton does not converge after the step cuts
# --------------------------------------------------------------------------------------------


def test_newton_failure_names_time_gap_and_remedy_and_keeps_partial_results(
        tmp_path: Path) -> None:
    text = _paper_with("max_iterations = 3\nmax_step_cuts = 0")
    proc = _run_cli(tmp_path, text, "out.nc")
    line = _check_failure_line(proc, "Newton-Raphson did not converge", "t = 6.000000000e-4 s",
                               "gap 0", "reduce dt")
    assert "penetration" in line
    ds = _check_incomplete_file(tmp_path, "out.nc", "Newton-Raphson did not converge")
    assert float(ds.time[-1]) == pytest.approx(6.0e-4)
    assert ds.sizes["time"] == 13  # t = 0 and the 12 accepted steps of 50 µs


def test_partial_results_in_csv_are_marked_incomplete_in_meta(tmp_path: Path) -> None:
    text = _paper_with("max_iterations = 3\nmax_step_cuts = 0")
    proc = _run_cli(tmp_path, text, "out.csv", "--json")
    _check_failure_line(proc, "t = 6.000000000e-4 s", "gap 0")
    meta = json.loads((tmp_path / "out_meta.json").read_text())
    assert meta["complete"] == 0 and "Newton-Raphson" in meta["message"]
    summary = json.loads(proc.stdout)
    assert summary["complete"] is False
    assert results_file.load(tmp_path / "out.csv").attrs["complete"] == 0


# --------------------------------------------------------------------------------------------
# Divergence: energy blow-up and a non-finite state
# --------------------------------------------------------------------------------------------


def test_energy_blow_up_is_reported_before_the_state_overflows(tmp_path: Path) -> None:
    proc = _run_cli(tmp_path, UNSTABLE.format(stiffness=1e4, dt=0.05, t_end=100.0, beta=0.1))
    _check_failure_line(proc, "energy blow-up", "t = 3.200000000e0 s", "no gap in contact",
                        "reduce dt")
    ds = _check_incomplete_file(tmp_path, "out.nc", "energy blow-up")
    assert float(ds.time[-1]) == pytest.approx(3.2)  # the first check, after 64 steps
    assert np.all(np.isfinite(ds.displacement.values))


def test_energy_blow_up_names_the_gap_in_contact() -> None:
    law = vi.contact.Hertz(stiffness=1e9, exponent=1.5)
    model = vi.Model(vi.Structure.sdof(mass=1.0, stiffness=1e4),
                     gaps=[vi.Gap(dof=0, clearance=1.0, side="both", law=law)],
                     initial_displacement=[1e-3])
    with pytest.raises(vi.SolverError) as err, pytest.warns(vi.StepStabilityWarning):
        vi.simulate(model, t_end=100.0, dt=0.05, method=vi.Newmark(beta=0.1))
    msg = str(err.value)
    assert "energy blow-up" in msg and "with gap 0 in contact" in msg and "\n" not in msg
    partial = err.value.partial
    assert partial is not None and not partial.complete
    total = partial.energy.total
    assert total[-1] > 1e3 * total[0]


def test_a_non_finite_state_is_reported_as_divergence(tmp_path: Path) -> None:
    # beta = 1e-6, omega dt = 1e8: the amplitude grows ~1e6 per step and overflows before the
    # first energy check (64 steps)
    proc = _run_cli(tmp_path, UNSTABLE.format(stiffness=1e16, dt=1.0, t_end=1000.0, beta=1e-6))
    _check_failure_line(proc, "diverged (non-finite state)", "t = 5.000000000e1 s",
                        "no gap in contact", "reduce dt")
    ds = _check_incomplete_file(tmp_path, "out.nc", "non-finite")
    assert np.all(np.isfinite(ds.displacement.values))  # the last finite state is kept
    assert 1 < ds.sizes["time"] < 64


def test_no_false_alarm_on_energy_for_a_forced_run() -> None:
    """External work counts as energy that entered: a resonant forced oscillator whose energy
    grows a thousandfold from rest is not a blow-up."""
    model = vi.Model(vi.Structure.sdof(mass=1.0, stiffness=(2 * np.pi * 10) ** 2),
                     loads=[vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=10.0)])
    r = vi.simulate(model, t_end=5.0, dt=1e-3)
    assert r.complete
    assert r.energy.total[-1] > 1e3 * r.energy.total[1]


# --------------------------------------------------------------------------------------------
# Singular effective stiffness
# --------------------------------------------------------------------------------------------


def test_singular_effective_stiffness_is_one_line_with_partial_file(tmp_path: Path) -> None:
    proc = _run_cli(tmp_path, SINGULAR)
    _check_failure_line(proc, "singular", "dt = 9.766e-4 s", "t = 0 s", "no gap",
                        "check the mass and stiffness matrices")
    ds = _check_incomplete_file(tmp_path, "out.nc", "singular")
    assert ds.sizes["time"] == 1 and float(ds.time[0]) == 0.0


# --------------------------------------------------------------------------------------------
# A step longer than the contact can be resolved with
# --------------------------------------------------------------------------------------------


def test_contact_period_estimate_is_close_to_the_hertz_contact_duration() -> None:
    model = cases.sdof_model("hertz")
    (period,) = contact_periods(model)
    fine = vi.simulate(model, t_end=0.002, dt=1e-6)
    duration = fine.impacts.t_end[0] - fine.impacts.t_start[0]
    assert period == pytest.approx(2 * duration, rel=0.1)


def test_contact_periods_kept_on_a_model_follow_its_initial_state() -> None:
    """A dense model keeps its contact periods for its initial state: an initial velocity
    changed in place (the model's arrays are writable) gives the periods of a model built with
    it, and a second fixed-step run of the model is warned about as the first was."""
    model = cases.sdof_model("hertz")
    first = contact_periods(model)
    assert contact_periods(model) == first and model._contact_periods[1] == tuple(first)
    model.initial_velocity[0] *= 4.0  # four times the speed: 16 times the energy
    faster = contact_periods(model)
    rebuilt = vi.Model(model.structure, gaps=model.gaps, loads=model.loads,
                       initial_displacement=model.initial_displacement.copy(),
                       initial_velocity=model.initial_velocity.copy())
    assert faster == contact_periods(rebuilt)
    # Hertz (n = 1.5): the period goes as E^(-1/10)
    assert faster[0] == pytest.approx(first[0] * 16.0 ** -0.1, rel=1e-12)
    for _ in range(2):
        with pytest.warns(vi.ContactResolutionWarning):
            vi.simulate(model, t_end=0.02, dt=2e-4, throw=False)


def test_a_step_too_long_for_the_contact_is_warned_about(tmp_path: Path) -> None:
    model = cases.sdof_model("lankarani-nikravesh")
    with pytest.warns(vi.ContactResolutionWarning) as caught:
        vi.simulate(model, t_end=0.02, dt=2e-4, throw=False)
    (w,) = caught
    msg = str(w.message)
    assert "gap 0" in msg and "dt = 2.000e-04 s" in msg and "contact period 8.6" in msg
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vi.simulate(model, t_end=0.002, dt=1e-6)  # resolved: no warning
        vi.simulate(model, t_end=0.02, dt=2e-4,  # adaptive stepping resolves it itself
                    method=vi.Newmark(adaptive=vi.Adaptive()))
    # the CLI prints it before the run, on one line
    proc = _run_cli(tmp_path, _paper_with("", dt="2e-4"))
    warn = [ln for ln in proc.stderr.splitlines() if ln.startswith("vibroimpact: warning: ")]
    assert len(warn) == 1 and "gap 0" in warn[0] and "period" in warn[0], proc.stderr


def test_an_unreachable_gap_is_not_warned_about() -> None:
    law = vi.contact.Hertz(stiffness=1e9, exponent=1.5)
    model = vi.Model(vi.Structure.sdof(mass=1.0, stiffness=1e4),
                     gaps=[vi.Gap(dof=0, clearance=1.0, side="both", law=law)],
                     initial_displacement=[1e-3])
    assert contact_periods(model) == [None]


def test_gap_flexibility_against_inverse_matrices_dense_and_sparse() -> None:
    """``b M⁻¹ bᵀ`` and ``b K⁻¹ bᵀ`` of each gap against ``numpy.linalg.inv``, for a
    consistent (non-lumped) mass; a dense structure's values are computed once, a sparse
    one's at every call (its arrays stay writable)."""
    import scipy.sparse as sp

    mass = np.array([[2.0, 0.5], [0.5, 1.0]])
    stiffness = np.array([[3e4, -1e4], [-1e4, 1e4]])
    law = vi.contact.Hertz(stiffness=1e9)
    gaps = [vi.Gap(dof=0, clearance=1e-3, law=law),
            vi.Gap(dof=[0, 1], coefficients=[1.0, -2.0], clearance=1e-3, law=law)]
    b = np.array([[1.0, 0.0], [1.0, -2.0]])
    expected = [np.einsum("gi,ij,gj->g", b, np.linalg.inv(a), b) for a in (mass, stiffness)]
    dense = vi.Model(vi.Structure(mass, stiffness), gaps=gaps)
    first = dense.gap_flexibility()
    for got, want in zip(first, expected, strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-12)
        assert not got.flags.writeable
    assert dense.gap_flexibility() is first
    sparse = vi.Model(vi.Structure(sp.csr_array(mass), sp.csr_array(stiffness)), gaps=gaps)
    for got, want in zip(sparse.gap_flexibility(), expected, strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-12)
    sparse.structure.mass.data[:] *= 2.0  # in place: seen by the next call
    np.testing.assert_allclose(sparse.gap_flexibility()[0], expected[0] / 2, rtol=1e-12)
    # no stiffness: unbounded compliance
    free = vi.Model(vi.Structure(mass), gaps=gaps)
    assert np.all(np.isinf(free.gap_flexibility()[1]))


# --------------------------------------------------------------------------------------------
# Cut steps leave no trace
# --------------------------------------------------------------------------------------------


def test_cut_steps_give_the_impact_table_of_a_fine_run() -> None:
    """Newton limited to 3 iterations forces step cuts at every contact; the impact table
    still matches a fine run's (a rejected attempt that left a half-updated contact behind
    would add or shift impacts). The Rust test ``step_cut_tests`` shows bit-identity with a
    run at the cut step size when every step is rejected after wrecking the trial state."""
    model = cases.sdof_model("lankarani-nikravesh")
    cut = vi.simulate(model, t_end=0.02, dt=5e-5,
                      method=vi.Newmark(newton=vi.NewtonOptions(max_iterations=3)))
    assert cut.complete and cut.stats.step_cuts > 0 and cut.stats.rejected_steps > 0
    plain = vi.simulate(model, t_end=0.02, dt=5e-5)
    assert plain.stats.step_cuts == 0
    fine = vi.simulate(model, t_end=0.02, dt=1e-6)
    assert len(cut.impacts) == len(plain.impacts) == len(fine.impacts) >= 8
    assert cut.impacts.v_in[0] == pytest.approx(8.0, rel=1e-9)  # free flight at 8 m/s
    assert np.all(cut.gap_force >= 0.0)
    # within the discretisation error of a 50 µs step (a leaked contact state would add or
    # drop impacts or put them far off)
    np.testing.assert_allclose(cut.impacts.t_start, fine.impacts.t_start, rtol=3e-2)
    np.testing.assert_allclose(cut.impacts.v_in, fine.impacts.v_in, rtol=6e-2)
    assert cut.energy.balance_error <= plain.energy.balance_error


def test_a_streamed_run_keeps_the_windows_before_a_failure(tmp_path: Path) -> None:
    text = _paper_with("max_iterations = 3\nmax_step_cuts = 0")
    proc = _run_cli(tmp_path, text, "out.nc", "--window", "5")
    assert proc.returncode == 3, proc.stderr
    line = proc.stderr.splitlines()[0]
    assert line.startswith("vibroimpact: solver failed: Newton-Raphson did not converge")
    assert "at t = 6.000000000e-4 s" in line and "gap 0" in line  # as when held in memory
    ds = _check_incomplete_file(tmp_path, "out.nc", "Newton-Raphson did not converge")
    assert float(ds.time[-1]) == pytest.approx(6.0e-4)
    assert np.all(np.diff(ds.time.values) > 0)
