"""Newmark's stability bound (issue 18): the critical ``ω·dt = 1/√(γ/2 − β)`` of the
conditionally stable Newmark rules (``2β < γ``) against the spectral radius of the step's
amplification matrix and against runs of an undamped oscillator on either side of it; the
structure's highest natural frequency against closed forms; the warning given before a run
exactly when the step exceeds the critical one."""

from __future__ import annotations

import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
import vibroimpact as vi
from vibroimpact.fe import FEStructure
from vibroimpact.fe.modal import DENSE_MODAL_LIMIT, highest_angular_frequency
from vibroimpact.simulate import step_stability_messages


def spectral_radius(omega_dt: float, gamma: float, beta: float) -> float:
    """Of one Newmark step of ``x'' + ω² x = 0`` on the state ``(x, dt·v, dt²·a)``: the
    update equations written out, solved for the new state."""
    implicit = np.array([[1.0, 0.0, -beta], [0.0, 1.0, -gamma], [omega_dt**2, 0.0, 1.0]])
    explicit = np.array([[1.0, 1.0, 0.5 - beta], [0.0, 1.0, 1.0 - gamma], [0.0, 0.0, 0.0]])
    return float(max(abs(np.linalg.eigvals(np.linalg.solve(implicit, explicit)))))


def first_unstable_omega_dt(gamma: float, beta: float) -> float:
    """The smallest ``ω·dt`` up to 1e4 whose spectral radius exceeds 1 (bisection after a
    scan), inf if none."""
    grid = np.geomspace(1e-3, 1e4, 3001)
    unstable = [i for i, x in enumerate(grid) if spectral_radius(x, gamma, beta) > 1 + 1e-12]
    if not unstable:
        return math.inf
    lo, hi = grid[unstable[0] - 1], grid[unstable[0]]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if spectral_radius(mid, gamma, beta) > 1 + 1e-12 else (mid, hi)
    return hi


@pytest.mark.parametrize(("gamma", "beta"), [(0.5, 1e-4), (0.5, 0.1), (0.6, 0.25),
                                             (0.7, 0.2), (0.5, 0.25), (0.6, 0.3),
                                             (0.6, 0.3025)])
def test_critical_omega_dt_is_where_the_amplification_matrix_turns_unstable(
        gamma: float, beta: float) -> None:
    limit = vi.Newmark(gamma=gamma, beta=beta).critical_omega_dt
    found = first_unstable_omega_dt(gamma, beta)
    if beta >= gamma / 2:  # unconditionally stable, also below (1/2 + gamma)²/4
        assert limit == math.inf and found == math.inf
    else:
        assert limit == pytest.approx(found, rel=1e-6)


def test_gamma_below_one_half_amplifies_at_every_step_and_is_refused() -> None:
    assert all(spectral_radius(x, 0.45, 0.3) > 1 for x in np.geomspace(1e-2, 1e3, 50))
    with pytest.raises(vi.ModelError, match=r"solver.gamma: 0.45 is not valid; expected "
                                            r"gamma >= 0.5"):
        vi.Newmark(gamma=0.45, beta=0.3)


FREQUENCY = 10.0  # Hz
OMEGA = 2 * math.pi * FREQUENCY


def _free_oscillator() -> vi.Model:
    return vi.Model(vi.Structure.sdof(mass=1.0, stiffness=OMEGA**2), initial_displacement=[1e-3])


def test_an_oscillator_stays_bounded_below_the_critical_step_and_grows_above() -> None:
    """Near the central-difference rule (gamma = 1/2, beta = 1e-4: beta = 0 is not allowed,
    the method being implicit here) the critical step is 2.0004/ω; 2 % either side of it."""
    method = vi.Newmark(gamma=0.5, beta=1e-4)
    dt_crit = method.critical_omega_dt / OMEGA
    model = _free_oscillator()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # below the critical step: no warning
        below = vi.simulate(model, t_end=400 * dt_crit, dt=0.98 * dt_crit, method=method)
    assert below.complete and np.max(np.abs(below.displacement)) < 2e-3
    with pytest.warns(vi.StepStabilityWarning) as caught:
        above = vi.simulate(model, t_end=400 * dt_crit, dt=1.02 * dt_crit, method=method,
                            throw=False)
    assert not above.complete and "energy blow-up" in above.message
    assert np.max(np.abs(above.displacement)) > 1e3 * 1e-3
    (w,) = caught
    text = str(w.message)
    assert f"critical step {dt_crit:.3e} s" in text and "highest natural frequency 10 Hz" in text
    assert "gaps open" in text and "\n" not in text


def test_the_warning_appears_exactly_beyond_the_critical_step() -> None:
    method = vi.Newmark(gamma=0.6, beta=0.2)
    dt_crit = method.critical_omega_dt / OMEGA
    model = _free_oscillator()
    for factor, expected in ((0.999, 0), (1.001, 1)):
        assert len(step_stability_messages(model, method, factor * dt_crit)) == expected
    for unconditional in (vi.Newmark(), vi.Newmark(gamma=0.6, beta=0.3), vi.HHT(alpha=0.3),
                          vi.GeneralizedAlpha(rho_inf=0.0)):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            vi.simulate(model, t_end=50 * dt_crit, dt=10 * dt_crit, method=unconditional)
    with warnings.catch_warnings():  # adaptive steps: the error control decides
        warnings.simplefilter("error")
        vi.simulate(model, t_end=50 * dt_crit, dt=10 * dt_crit,
                    method=vi.Newmark(gamma=0.6, beta=0.2, adaptive=vi.Adaptive()))


def _chain(n: int, sparse: bool) -> vi.Structure:
    """n equal masses on springs, fixed at one end, free at the other."""
    k, m = 1e4, 2.0
    diag = np.full(n, 2 * k)
    diag[-1] = k
    stiffness = sp.diags([diag, -k * np.ones(n - 1), -k * np.ones(n - 1)], [0, 1, -1])
    mass = sp.identity(n) * m
    if sparse:
        return vi.Structure(sp.csr_array(mass), sp.csr_array(stiffness))
    return vi.Structure(mass.toarray(), stiffness.toarray())


@pytest.mark.parametrize(("n", "sparse"), [(1, False), (40, False), (DENSE_MODAL_LIMIT + 50,
                                                                       True)])
def test_highest_frequency_of_a_spring_mass_chain_is_the_closed_form(n: int,
                                                                      sparse: bool) -> None:
    # fixed-free chain: ω_j = 2 √(k/m) sin((2j − 1)π / (2(2n + 1))), j = 1..n
    exact = 2 * math.sqrt(1e4 / 2.0) * math.sin((2 * n - 1) * math.pi / (2 * (2 * n + 1)))
    assert highest_angular_frequency(_chain(n, sparse)) == pytest.approx(exact, rel=1e-8)


def test_highest_frequency_of_a_structure_with_massless_dofs() -> None:
    """Its massless rotations condensed: that of (K_condensed, M) by LAPACK."""
    le = 0.2
    ke = (2e4 / le**3) * np.array([[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le,
                                   2 * le**2], [-12, -6 * le, 12, -6 * le],
                                   [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
    k = np.zeros((12, 12))
    for e in range(5):
        k[2 * e:2 * e + 4, 2 * e:2 * e + 4] += ke
    m = np.diag([0.0, 0.0] + [1.6, 0.0] * 4 + [0.8, 0.0])
    fe = FEStructure(sp.csr_array(m[2:, 2:]), sp.csr_array(k[2:, 2:]))
    kt, kr = k[2::2, 2::2], k[2::2, 3::2]
    condensed = kt - kr @ np.linalg.solve(k[3::2, 3::2], kr.T)
    lam = scipy.linalg.eigh(condensed, np.diag(m[2::2, 2::2].diagonal()), eigvals_only=True)
    assert highest_angular_frequency(fe) == pytest.approx(math.sqrt(lam[-1]), rel=1e-9)


def test_the_cli_prints_the_warning_on_one_line(tmp_path: Path) -> None:
    model = tmp_path / "m.toml"
    dt_crit = vi.Newmark(gamma=0.5, beta=0.1).critical_omega_dt / OMEGA
    model.write_text(f"""schema_version = 1
[structure]
kind = "sdof"
mass = 1.0
stiffness = {OMEGA**2!r}
[initial]
displacement = 1e-3
[solver]
method = "newmark"
gamma = 0.5
beta = 0.1
dt = {1.5 * dt_crit!r}
t_end = {60 * dt_crit!r}
""")
    proc = subprocess.run([sys.executable, "-m", "vibroimpact", "run", str(model)],
                          capture_output=True, text=True, timeout=120)
    warned = [ln for ln in proc.stderr.splitlines() if ln.startswith("vibroimpact: warning: ")]
    assert len(warned) == 1, proc.stderr
    assert f"exceeds the critical step {dt_crit:.3e} s" in warned[0]
    assert "Warning" not in proc.stderr.replace("vibroimpact: warning:", "")
