"""The impulsive methods through the one time-loop driver (issue 19, item 1): the rigid-stop
impact oscillator swept in frequency with ``event-driven`` against its period-1 orbit solved
here from the linear flow and the restitution map, and compliant stops of growing stiffness
(DOP853) converging to it; streamed runs equal in-memory ones bit for bit; solver events as
for the other methods. (Progress: ``tests/test_run_progress.py``; interrupts:
``tests/test_interrupt.py``; the core's own: ``rust/vibroimpact-core/tests/interrupt.rs``.)"""

from __future__ import annotations

import logging

import numpy as np
import pytest
import vibroimpact as vi
from scipy.linalg import expm
from scipy.optimize import brentq, fsolve
from vibroimpact.sweeps import Param, Sweep, run_sweep

# m x'' + c x' + k x = F sin(2π f t): 1 Hz natural frequency, 5 % damping; a rigid stop at
# x = D (positive side) with Newton's restitution E.
M, K = 1.0, (2 * np.pi) ** 2
C = 2 * 0.05 * np.sqrt(K * M)
F, D, E = 1.0, 0.005, 0.8
FREQS = np.array([1.2, 1.5, 1.8, 2.1])


def oscillator(frequency: float, law: vi.contact.ContactLaw, x0: float = 0.0,
               v0: float = 0.0) -> vi.Model:
    return vi.Model(
        vi.Structure.sdof(M, K, C),
        gaps=[vi.Gap(dof=0, clearance=D, side="positive", law=law)],
        loads=[vi.HarmonicLoad(dof=0, amplitude=F, frequency=frequency)],
        initial_displacement=[x0],
        initial_velocity=[v0],
    )


def flow(f: float, t0: float, z0: np.ndarray, t: float) -> np.ndarray:
    """The state ``(x, v)`` at ``t`` of the free flight from ``z0`` at ``t0``: the forced
    response ``Im(H e^{iωt})``, ``H = F/(k − mω² + icω)``, plus the homogeneous part
    ``exp(A (t − t0))`` applied to the difference at ``t0``."""
    w = 2 * np.pi * f
    h = F / (K - M * w * w + 1j * C * w)

    def forced(s: float) -> np.ndarray:
        e = h * np.exp(1j * w * s)
        return np.array([e.imag, (1j * w * e).imag])

    a = np.array([[0.0, 1.0], [-K / M, -C / M]])
    return forced(t) + expm(a * (t - t0)) @ (z0 - forced(t0))


def period_one(f: float, guess: tuple[float, float]) -> tuple[float, float]:
    """Impact instant ``t0`` (in the period) and approach speed ``V`` of the period-1 orbit
    with one impact per period: leaving the stop at ``t0`` with ``−E V``, the free flight is
    back at the stop one period later with the approach speed ``V``: ``x(t0 + T) = D``,
    ``v(t0 + T) = V``. Checked to stay clear of the stop in between."""
    period = 1 / f

    def residual(u: np.ndarray) -> np.ndarray:
        t0, v = u
        z = flow(f, t0, np.array([D, -E * v]), t0 + period)
        return np.array([(z[0] - D) / D, (z[1] - v) / v])

    (t0, v), *_ = fsolve(residual, guess, xtol=1e-13, full_output=True)
    assert np.abs(residual(np.array([t0, v]))).max() < 1e-12
    inside = [flow(f, t0, np.array([D, -E * v]), t0 + s * period)[0]
              for s in np.linspace(0.01, 0.99, 99)]
    assert max(inside) < D and v > 0
    return t0 % period, v


def test_event_driven_sweep_matches_the_period_one_orbit() -> None:
    """Each frequency's impact speeds (all of the sampled periods) and phases equal the closed
    form to 1e-8: the sweep's reducer sees every rigid impact of the event-driven method."""
    model = oscillator(FREQS[0], vi.contact.Rigid(restitution=E))
    ds = run_sweep(Sweep(model, [Param("loads.0.frequency", FREQS)], dt=2e-3,
                         method=vi.EventDriven(), transient=150, periods=8), threads=1)
    count = ds["impact_count"].isel(gap=0).values
    assert np.all(count == 8), count  # one impact per period
    for f in FREQS:
        point = ds.sel({"loads.0.frequency": f}).isel(gap=0)
        speeds = point["impact_velocity"].values
        phases = point["impact_phase"].values
        t0, v = period_one(f, (phases[0] / f, speeds[0]))
        assert np.abs(speeds - v).max() < 1e-8 * v, (f, speeds - v)
        assert np.abs(phases - t0 * f).max() < 1e-8, (f, phases - t0 * f)
        # the stroboscopic samples are those of the orbit: the flight from the impact
        x = point["poincare_displacement"].isel(dof=0).values
        z = flow(f, t0, np.array([D, -E * v]), 1 / f)
        assert np.abs(x - z[0]).max() < 1e-8 * D


def restitution_for(e: float) -> float:
    """The ``ce`` of Lankarani–Nikravesh whose factor ``χ = 3(1 − ce²)/4`` makes one impact of
    a free mass restitute exactly ``e``: ``χ`` is the root in ``(0, 1/e)`` of
    ``χ − ln(1 + χ) = −χ e − ln(1 − χ e)`` (Hunt & Crossley's energy integral, derived in
    ``vi.contact.ExactRestitution``'s docstring). LN's own ``ce = e`` restitutes more than e
    (0.847 for 0.8)."""
    chi = brentq(lambda c: c - np.log1p(c) + c * e + np.log1p(-c * e), 1e-9, 1 / e - 1e-9,
                 xtol=1e-15)
    return float(np.sqrt(1 - 4 * chi / 3))


#: Stiffness levels of the compliant stop, N/m^1.5: ×10 each.
STIFFNESSES = 10.0 ** np.arange(8, 13)


def test_compliant_stops_of_growing_stiffness_converge_to_the_rigid_orbit() -> None:
    """The same sweep with a Lankarani–Nikravesh stop (exponent 1.5, restituting E for a free
    impact) of stiffness 1e8 … 1e12, run by DOP853 at rtol 1e-10 (~0.1 s a sweep): the impact
    speeds tend to those of the closed-form period-1 orbit of the rigid stop. The error comes
    from the contact's depth and duration, both ∝ K^(−2/5), so each ×10 in stiffness divides
    it by 10^(2/5) ≈ 2.51: measured 2.42–2.58 on every level and frequency, down to 2.4e-5
    (1.2 Hz) … 1.9e-3 (2.1 Hz) of the speed at 1e12. A stop that restitutes anything but E
    stalls at its own orbit (with LN's ``ce = E``, which restitutes 0.847, the ratios wander
    between 0.2 and 9 and the error stays at 1e-2 … 3e-2)."""
    ce = restitution_for(E)
    method = vi.Dop853(adaptive=vi.Adaptive(rtol=1e-10, atol=1e-14))
    levels = []
    for k in STIFFNESSES:
        law = vi.contact.LankaraniNikravesh(stiffness=k, exponent=1.5, restitution=ce)
        ds = run_sweep(Sweep(oscillator(FREQS[0], law), [Param("loads.0.frequency", FREQS)],
                             dt=1e-3, method=method, transient=150, periods=8), threads=1)
        assert np.all(ds["impact_count"].values == 8)  # one impact per period
        levels.append(ds.isel(gap=0))
    for f in FREQS:
        # the closed form, from the stiffest stop's first impact as the guess
        stiffest = levels[-1].sel({"loads.0.frequency": f})
        _, v = period_one(f, (float(stiffest["impact_phase"][0]) / f,
                              float(stiffest["impact_velocity"][0])))
        speeds = np.array([ds.sel({"loads.0.frequency": f})["impact_velocity"].values
                           for ds in levels])
        errors = np.abs(speeds - v).max(axis=1) / v
        ratios = errors[:-1] / errors[1:]
        assert np.all((2.3 < ratios) & (ratios < 2.7)), (f, errors, ratios)
        assert errors[-1] < 2.5e-3, (f, errors)


@pytest.mark.parametrize("method", [vi.EventDriven(), vi.MoreauJean()],
                         ids=["event-driven", "moreau-jean"])
def test_streamed_impulsive_runs_equal_in_memory_ones(method: vi.Integrator,
                                                      caplog: pytest.LogCaptureFixture) -> None:
    """Blocks of rows handed over during the run (``on_rows``) and the rest, concatenated,
    are the rows of the in-memory run bit for bit; the impact table is the same; the progress
    bar follows the run; the solver log names each impact."""
    model = oscillator(1.8, vi.contact.Rigid(restitution=E))
    kw = dict(t_end=5.0, dt=1e-3, method=method)
    whole = vi.simulate(model, **kw)
    blocks: list[dict] = []
    with caplog.at_level(logging.INFO, logger="vibroimpact.solver"):
        rest = vi.simulate(model, on_rows=blocks.append, chunk_rows=400, **kw)
    # (blocks that arrive between two polls come as one)
    assert blocks and 1 <= len(rest.time) <= 400 < len(whole.time)
    for key in ("time", "displacement", "velocity", "acceleration", "gap_penetration",
                "gap_force"):
        cat = np.concatenate([b[key] for b in blocks] + [getattr(rest, key)])
        assert np.array_equal(cat, getattr(whole, key)), key
    assert np.array_equal(rest.impacts.t_start, whole.impacts.t_start)
    assert np.array_equal(rest.impacts.v_in, whole.impacts.v_in)
    impacts = [r for r in caplog.records if " impact (" in r.getMessage()]
    # Moreau–Jean reports an impact once per contact (consecutive steps with impulses)
    assert len(impacts) == len(whole.impacts.t_start) > 5
    first = impacts[0].getMessage()
    assert f"{whole.impacts.t_start[0]:.9e}" in first and "gap 0" in first


def test_event_driven_flight_is_exact_at_a_coarse_step() -> None:
    """The harmonic load is propagated exactly (as its own oscillator inside the exponential),
    so the orbit does not depend on ``dt``: at 10 ms (50-80 steps a period) the impact speeds
    and instants of the settled orbit equal the closed form to 1e-10 and 1e-12 s (measured
    6e-12 and 1.4e-13 s; the quadratic interpolation of the load that this replaced was off
    by 8e-7 and 2e-8 s)."""
    for f in FREQS[[0, -1]]:
        res = vi.simulate(oscillator(f, vi.contact.Rigid(restitution=E)), t_end=200 / f,
                          dt=1e-2, method=vi.EventDriven())
        t, v = res.impacts.t_start[-8:], res.impacts.v_in[-8:]
        t0, speed = period_one(f, (t[0] % (1 / f), v[0]))
        periods = np.round((t - t0) * f)
        assert np.abs(v - speed).max() < 1e-10 * speed, (f, v - speed)
        assert np.abs(t - t0 - periods / f).max() < 1e-12, (f, t - t0 - periods / f)
