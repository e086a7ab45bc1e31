"""Newmark-β on linear oscillators: exact solutions, measured order, step cutting."""

from __future__ import annotations

import math

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact.paper import cases


def _forced_oscillator_exact(m, c, k, amp, freq, x0, v0):
    """Closed-form response of m x'' + c x' + k x = amp sin(2π freq t)."""
    w = 2 * math.pi * freq
    wn = math.sqrt(k / m)
    zeta = c / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta**2)
    big_x = amp / math.hypot(k - m * w**2, c * w)
    theta = math.atan2(c * w, k - m * w**2)
    c1 = x0 - big_x * math.sin(-theta)
    c2 = (v0 - big_x * w * math.cos(-theta) + zeta * wn * c1) / wd

    def x(t):
        decay = np.exp(-zeta * wn * t)
        return decay * (c1 * np.cos(wd * t) + c2 * np.sin(wd * t)) + big_x * np.sin(w * t - theta)

    return x


def test_newmark_converges_at_second_order_to_the_exact_forced_response() -> None:
    m, c, k = 3.0, 12.0, 4.8e4
    amp, freq, x0, v0 = 50.0, 7.0, 2e-3, -0.1
    exact = _forced_oscillator_exact(m, c, k, amp, freq, x0, v0)
    model = vi.Model(
        vi.Structure.sdof(mass=m, stiffness=k, damping=c),
        loads=[vi.HarmonicLoad(dof=0, amplitude=amp, frequency=freq)],
        initial_displacement=x0,
        initial_velocity=v0,
    )
    dts = [4e-4, 2e-4, 1e-4, 5e-5]
    errors = []
    for dt in dts:
        r = vi.simulate(model, t_end=0.5, dt=dt)
        errors.append(np.max(np.abs(r.displacement[:, 0] - exact(r.time))))
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert slope == pytest.approx(2.0, abs=0.05)
    amplitude = np.max(np.abs(exact(np.linspace(0, 0.5, 2001))))
    assert errors[-1] < 2e-4 * amplitude


def test_two_dof_relative_gap_free_vibration_is_exact_modes() -> None:
    """Two masses on springs, a relative gap that never closes: the response is the sum of
    the two modes (eigh of K, M), and energy is conserved by average acceleration."""
    mass = np.diag([1.0, 2.0])
    stiffness = np.array([[3e4, -1e4], [-1e4, 1e4]])
    law = vi.contact.Hertz(stiffness=1e9)
    model = vi.Model(
        vi.Structure(mass, stiffness),
        gaps=[vi.Gap(dof=[0, 1], coefficients=[1, -1], clearance=1.0, law=law)],
        initial_displacement=[1e-3, 0.0],
    )
    r = vi.simulate(model, t_end=0.2, dt=1e-5)
    from scipy.linalg import eigh

    w2, phi = eigh(stiffness, mass)
    q0 = phi.T @ mass @ np.array([1e-3, 0.0])
    exact = (phi * q0) @ np.cos(np.sqrt(w2)[:, None] * r.time[None, :])
    assert np.max(np.abs(r.displacement.T - exact)) < 1e-3 * 1e-3
    assert len(r.impacts) == 0
    assert r.energy.balance_error < 1e-12


def test_step_cutting_rescues_a_step_that_newton_cannot_take() -> None:
    """With only 3 Newton iterations per step, dt = 50 µs fails at the first contact unless the
    step may be cut; with cuts the run completes and agrees with the fine-step solution."""
    model = cases.sdof_model("lankarani-nikravesh")
    tight = vi.Newmark(newton=vi.NewtonOptions(max_iterations=3, max_step_cuts=0))
    with pytest.raises(vi.SolverError) as err:
        vi.simulate(model, t_end=0.02, dt=5e-5, method=tight)
    msg = str(err.value)
    assert "t = 6.000000000e-4 s" in msg and "gap 0" in msg and "\n" not in msg
    partial = err.value.partial
    assert partial is not None and not partial.complete
    assert partial.time[-1] == pytest.approx(6.0e-4)
    cut = vi.Newmark(newton=vi.NewtonOptions(max_iterations=3, max_step_cuts=8))
    r = vi.simulate(model, t_end=0.02, dt=5e-5, method=cut)
    assert r.complete and r.stats.step_cuts > 0
    fine = vi.simulate(model, t_end=0.02, dt=1e-6)
    assert r.max_abs_displacement[0] == pytest.approx(fine.max_abs_displacement[0], rel=2e-3)


def test_results_do_not_depend_on_output_decimation() -> None:
    model = cases.sdof_model("flores", 0.5)
    full = vi.simulate(model, t_end=0.01, dt=1e-6)
    dec = vi.simulate(model, t_end=0.01, dt=1e-6, every=7)
    kept = list(range(0, len(full.time), 7))
    if kept[-1] != len(full.time) - 1:
        kept.append(len(full.time) - 1)  # the last step is always recorded
    assert np.array_equal(dec.time, full.time[kept])
    assert np.array_equal(dec.displacement, full.displacement[kept])
    assert np.array_equal(dec.gap_force, full.gap_force[kept])
    assert np.array_equal(dec.energy.contact_dissipated, full.energy.contact_dissipated[kept])
    assert np.array_equal(dec.max_abs_displacement, full.max_abs_displacement)
    for name in ("t_start", "t_end", "v_in", "v_out", "delta_max", "force_max", "impulse"):
        assert np.array_equal(getattr(dec.impacts, name), getattr(full.impacts, name),
                              equal_nan=True)


def test_large_banded_model_matches_modal_solution() -> None:
    """A 60-DOF spring chain (above the banded-solver threshold, in scrambled DOF order so the
    reordering matters) against its exact modal solution; with a gap that closes, the energy
    account still balances."""
    from scipy.linalg import eigh

    n = 60
    k = np.zeros((n, n))
    for i in range(n):
        k[i, i] += 2e4
        if i + 1 < n:
            k[i, i] += 1e4
            k[i + 1, i + 1] += 1e4
            k[i, i + 1] -= 1e4
            k[i + 1, i] -= 1e4
    order = np.random.default_rng(3).permutation(n)
    k = k[np.ix_(order, order)]
    m = np.diag(np.linspace(0.5, 1.5, n))
    x0 = np.sin(np.arange(n) * 0.3) * 1e-3
    free = vi.simulate(vi.Model(vi.Structure(m, k), initial_displacement=x0), t_end=0.05,
                       dt=2e-6, every=50)
    w2, phi = eigh(k, m)
    q0 = phi.T @ m @ x0
    exact = (phi * q0) @ np.cos(np.sqrt(w2)[:, None] * free.time[None, :])
    assert np.max(np.abs(free.displacement.T - exact)) < 2e-4 * np.max(np.abs(x0))
    law = vi.contact.Hertz(stiffness=1e9)
    gapped = vi.simulate(
        vi.Model(vi.Structure(m, k), gaps=[vi.Gap(dof=int(order[10]), clearance=2e-4,
                                                  side="both", law=law)],
                 initial_displacement=x0),
        t_end=0.05, dt=2e-6, every=50)
    assert len(gapped.impacts) > 2
    assert gapped.energy.balance_error < 1e-4


@pytest.mark.parametrize(
    "method", [vi.Newmark(), vi.GeneralizedAlpha(rho_inf=0.8), vi.HHT(alpha=0.1)],
    ids=["newmark", "generalized-alpha", "hht"])
def test_large_damped_banded_model_matches_modal_solution(method: vi.Integrator) -> None:
    """A 40-DOF spring chain with Rayleigh damping (banded predictor: Newmark-β with K and C,
    the α-form with K, C and M) against its exact damped modal solution; and with a gap, the
    energy account of the damped impacts balances."""
    from scipy.linalg import eigh

    n = 40
    k = np.zeros((n, n))
    for i in range(n):
        k[i, i] += 2e4
        if i + 1 < n:
            k[np.ix_([i, i + 1], [i, i + 1])] += 1e4 * np.array([[1, -1], [-1, 1]])
    order = np.random.default_rng(5).permutation(n)
    k = k[np.ix_(order, order)]
    m = np.diag(np.linspace(0.5, 1.5, n))
    c = 2.0 * m + 2e-5 * k
    x0 = np.cos(np.arange(n) * 0.7) * 1e-3
    v0 = np.sin(np.arange(n) * 0.4) * 1e-2
    structure = vi.Structure(m, k, damping=c)
    free = vi.simulate(vi.Model(structure, initial_displacement=x0, initial_velocity=v0),
                       t_end=0.05, dt=2e-6, every=50, method=method)
    w2, phi = eigh(k, m)
    w = np.sqrt(w2)
    zeta = 2.0 / (2 * w) + 2e-5 * w / 2
    wd = w * np.sqrt(1 - zeta**2)
    q0, dq0 = phi.T @ m @ x0, phi.T @ m @ v0
    t = free.time[None, :]
    decay = np.exp(-(zeta * w)[:, None] * t)
    q = decay * (q0[:, None] * np.cos(wd[:, None] * t)
                 + ((dq0 + zeta * w * q0) / wd)[:, None] * np.sin(wd[:, None] * t))
    exact = phi @ q
    assert np.max(np.abs(free.displacement.T - exact)) < 2e-4 * np.max(np.abs(x0))
    if isinstance(method, vi.Newmark):
        law = vi.contact.Hertz(stiffness=1e9)
        gapped = vi.simulate(
            vi.Model(structure, gaps=[vi.Gap(dof=int(order[10]), clearance=2e-4, side="both",
                                             law=law)],
                     initial_displacement=x0, initial_velocity=v0),
            t_end=0.05, dt=2e-6, every=50, method=method)
        assert len(gapped.impacts) > 2
        assert gapped.energy.balance_error < 1e-4


def test_generalized_alpha_free_flight_acceleration_decays_to_zero_not_through_subnormals(
) -> None:
    """On a free mass generalized-α's acceleration obeys ``(1−α_m) a₁ + α_m a₀ = 0``: it halves
    and changes sign each step for ρ∞ = 0.8 (α_m = 1/3). It must follow that closed form and
    then be exactly 0, never a subnormal number (each of which costs up to a hundred cycles;
    the step sets accelerations below 1e-280 to 0)."""
    rho_inf = 0.8
    alpha_m = (2 * rho_inf - 1) / (rho_inf + 1)
    result = vi.simulate(cases.sdof_model("lankarani-nikravesh", 0.9), t_end=0.02, dt=1e-6,
                         method=vi.GeneralizedAlpha(rho_inf=rho_inf))
    a = result.acceleration[:, 0]
    force = result.gap_force[:, 0]
    free = (force[2:] == 0) & (force[1:-1] == 0) & (force[:-2] == 0)
    decaying = free & (a[1:-1] != 0) & (a[2:] != 0)
    assert decaying.sum() > 5000
    np.testing.assert_allclose(a[2:][decaying] / a[1:-1][decaying], -alpha_m / (1 - alpha_m),
                               rtol=1e-12)
    nonzero = np.abs(a[a != 0])
    assert nonzero.min() >= 1e-280
    assert np.count_nonzero(free & (a[2:] == 0)) > 5000
