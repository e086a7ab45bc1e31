"""Parameter sweeps (issue 8): the batch core against the same runs done one by one, the classic
impact oscillator's grazing and period-doubling bifurcations against closed forms, resumable
parts, the Dataset file, plots and the command line. (Dask: ``test_sweep_dask.py``.)"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import vibroimpact as vi
import xarray as xr
from scipy.linalg import expm
from scipy.optimize import brentq
from vibroimpact.impact import single_impact
from vibroimpact.sweeps import (
    ChunkEvent,
    Param,
    Sweep,
    apply,
    load_sweep,
    parse_param,
    plot_bifurcation,
    plot_response,
    run_sweep,
)

# The oscillator of the bifurcation tests: m x'' + c x' + k x = F sin(2π f t), 1 Hz natural
# frequency, 5 % damping, a stiff Kelvin–Voigt stop (contact ≈ 1 ms, < 0.3 % of a period).
M, K = 1.0, (2 * np.pi) ** 2
C = 2 * 0.05 * np.sqrt(K * M)
F = 1.0
STOP = vi.contact.KelvinVoigt(stiffness=1e7, damping=300.0)
ADAPTIVE = vi.Newmark(adaptive=vi.Adaptive(rtol=1e-6, atol=1e-9))
#: A soft stop (contact ≈ 70 ms) for the fixed-step comparisons at dt = 2 ms.
SOFT = vi.contact.KelvinVoigt(stiffness=2e3, damping=2.0)


def oscillator(clearance: float, law: vi.contact.ContactLaw = STOP, frequency: float = 1.0,
               x0: float = 0.0, v0: float = 0.0) -> vi.Model:
    return vi.Model(
        vi.Structure.sdof(M, K, C),
        gaps=[vi.Gap(dof=0, clearance=clearance, side="positive", law=law)],
        loads=[vi.HarmonicLoad(dof=0, amplitude=F, frequency=frequency)],
        initial_displacement=[x0],
        initial_velocity=[v0],
    )


def receptance(f: float) -> complex:
    """Linear steady state ``x = Im(H e^{iωt})`` of ``F sin ωt``: ``H = F/(k − mω² + icω)``."""
    w = 2 * np.pi * f
    return F / (K - M * w * w + 1j * C * w)


# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------


def test_parse_param_spacings_and_lists() -> None:
    p = parse_param("loads.0.frequency=5:50:400")
    assert p.path == "loads.0.frequency" and len(p) == 400
    assert p.values[0] == 5 and p.values[-1] == 50
    assert np.allclose(np.diff(p.values), 45 / 399)
    g = parse_param("gaps[0].clearance=1e-4:1e-2:3:log")
    assert g.path == "gaps.0.clearance" and np.allclose(g.values, [1e-4, 1e-3, 1e-2])
    assert list(parse_param("gaps.0.law.restitution=0.5, 0.7,0.9").values) == [0.5, 0.7, 0.9]
    assert g.units == "m" and p.units == "Hz"
    for bad in ("loads.0.frequency", "x=1:2", "x=1:2:0", "x=a,b", "x=0:1:5:log", "x=1:2:3:cos"):
        with pytest.raises(vi.ModelError, match="--param"):
            parse_param(bad)


def test_apply_sets_one_number_and_names_the_paths_that_exist() -> None:
    spec = oscillator(0.01, vi.contact.LankaraniNikravesh(stiffness=1e9, restitution=0.8)
                      ).to_spec()
    out = apply(spec, "gaps[0].law.restitution", 0.6)
    assert out["gaps"][0]["law"]["restitution"] == 0.6
    assert spec["gaps"][0]["law"]["restitution"] == 0.8  # the base is not touched
    assert apply(spec, "structure.mass", 2.0)["mass"][0, 0] == 2.0
    assert spec["mass"][0, 0] == 1.0
    assert apply(spec, "initial.velocity", 3.0)["v0"][0] == 3.0
    assert apply(spec, "loads.0.frequency", 7.0)["loads"][0]["frequency"] == 7.0
    with pytest.raises(vi.ModelError, match=r"--param gaps\.0\.side.*gaps\.0\.clearance"):
        apply(spec, "gaps.0.side", 1.0)
    with pytest.raises(vi.ModelError, match=r"--param loads\.3\.amplitude"):
        apply(spec, "loads.3.amplitude", 1.0)
    with pytest.raises(vi.ModelError, match="no number 'damping'"):
        apply(spec, "gaps.0.law.damping", 1.0)


def test_bad_values_are_refused_before_anything_runs() -> None:
    sweep = Sweep(oscillator(0.01), [Param("gaps.0.clearance", [0.01, -0.01])], dt=1e-3,
                  transient=1, periods=1)
    with pytest.raises(vi.ModelError, match=r"sweep point gaps\.0\.clearance=-0\.01.*clearance"):
        run_sweep(sweep)
    with pytest.raises(vi.ModelError, match="no harmonic load"):
        run_sweep(Sweep(oscillator(0.01), [Param("loads.0.frequency", [0.0])], dt=1e-3))


# --------------------------------------------------------------------------------------------
# The batch core equals the runs done one by one
# --------------------------------------------------------------------------------------------


def _hermite(x0, v0, x1, v1, h, s):  # numpy arrays or floats
    s2, s3 = s * s, s * s * s
    return ((2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * h * v0
            + (-2 * s3 + 3 * s2) * x1 + (s3 - s2) * h * v1)


def _peaks_and_rms(t: np.ndarray, x: np.ndarray, v: np.ndarray) -> tuple[float, float, float]:
    """Largest and smallest displacement of the cubic Hermite interpolant of the steps, and
    its RMS by Simpson's rule: the reductions of the core, recomputed here from a full
    history."""
    h = np.diff(t)
    x0, x1, v0, v1 = x[:-1], x[1:], v[:-1], v[1:]
    hi, lo = [x.max()], [x.min()]
    for i in np.flatnonzero(np.sign(v0) != np.sign(v1)):
        # interior stationary point: root in (0, 1) of the derivative of the cubic
        y0, y1, m0, m1 = x0[i], x1[i], h[i] * v0[i], h[i] * v1[i]
        a = 6 * y0 - 6 * y1 + 3 * m0 + 3 * m1
        b = -6 * y0 + 6 * y1 - 4 * m0 - 2 * m1
        for s in np.roots([a, b, m0]):
            if abs(s.imag) < 1e-12 and 0 <= s.real <= 1:
                val = _hermite(y0, v0[i], y1, v1[i], h[i], s.real)
                (hi if v0[i] > 0 else lo).append(val)
    xm = _hermite(x0, v0, x1, v1, h, 0.5)
    integral = np.sum(h / 6 * (x0**2 + 4 * xm**2 + x1**2))
    return max(hi), min(lo), math.sqrt(integral / (t[-1] - t[0]))


def _one_by_one(model: vi.Model, f: float, dt: float, transient: int, periods: int
                ) -> tuple[vi.Result, float, int]:
    """The run the sweep makes of one point, every step kept."""
    period = 1 / f
    m = max(math.ceil(period / dt - 1e-9), 1)
    result = vi.simulate(model, t_end=(transient + periods) * period, dt=period / m)
    return result, period, m


def test_sweep_equals_the_runs_one_by_one() -> None:
    """Fixed steps: every number the sweep keeps is the one-by-one run's (bitwise for samples,
    final state and impact speeds; peaks and RMS to round-off), whatever the thread count."""
    freqs, clearances = [0.7, 1.0, 1.6], [0.02, 0.05]
    tr, n, dt = 6, 5, 2e-3
    sweep = Sweep(oscillator(0.0, SOFT), [Param("loads.0.frequency", freqs),
                                    Param("gaps.0.clearance", clearances)],
                  dt=dt, transient=tr, periods=n, max_impacts=4, chunk_size=2)
    ds = run_sweep(sweep)
    assert ds["poincare_displacement"].dims == ("loads.0.frequency", "gaps.0.clearance",
                                                "sample", "dof")
    impacting = 0
    for f in freqs:
        for d in clearances:
            p = ds.sel({"loads.0.frequency": f, "gaps.0.clearance": d}).isel(dof=0, gap=0)
            model = oscillator(d, SOFT, frequency=f)
            r, period, m = _one_by_one(model, f, dt, tr, n)
            x, v = r.displacement[:, 0], r.velocity[:, 0]
            k = (tr + np.arange(1, n + 1)) * m
            assert np.array_equal(p["poincare_displacement"].values, x[k])
            assert np.array_equal(p["poincare_velocity"].values, v[k])
            assert p["final_displacement"].item() == x[-1]
            assert p["final_velocity"].item() == v[-1]
            start = tr * period
            after = r.impacts.t_start > start
            assert p["impact_count"].item() == after.sum()
            impacting += int(after.sum() > 0)
            kept = r.impacts.v_in[after][:4]
            assert np.array_equal(p["impact_velocity"].values[: kept.size], kept)
            assert np.all(np.isnan(p["impact_velocity"].values[kept.size:]))
            phases = ((r.impacts.t_start[after][:4] - start) / period) % 1
            assert np.allclose(p["impact_phase"].values[: kept.size], phases, atol=1e-9)
            w = slice(tr * m, None)
            hi, lo, rms = _peaks_and_rms(r.time[w], x[w], v[w])
            assert p["displacement_max"].item() == pytest.approx(hi, rel=1e-12, abs=1e-15)
            assert p["displacement_min"].item() == pytest.approx(lo, rel=1e-12, abs=1e-15)
            assert p["displacement_rms"].item() == pytest.approx(rms, rel=1e-10)
            assert p["steps"].item() == r.stats.steps
    assert 0 < impacting < len(freqs) * len(clearances)  # both kinds of point are covered
    for threads in (1, 2):
        xr.testing.assert_equal(run_sweep(sweep, threads=threads), ds)


def test_adaptive_samples_are_the_interpolated_accepted_steps() -> None:
    """Adaptive steps: the samples are the cubic Hermite interpolants (x from x, v; v from v,
    a) of the accepted step containing each instant, and the rest as with fixed steps."""
    f, tr, n = 1.3, 5, 6
    period = 1 / f
    sweep = Sweep(oscillator(0.02, STOP), [Param("loads.0.frequency", [f])], dt=1e-3,
                  method=ADAPTIVE, transient=tr, periods=n)
    p = run_sweep(sweep).isel({"loads.0.frequency": 0, "dof": 0, "gap": 0})
    method = vi.Newmark(adaptive=vi.Adaptive(rtol=1e-6, atol=1e-9, dt_max=period / 16))
    r = vi.simulate(oscillator(0.02, STOP, frequency=f), t_end=(tr + n) * period, dt=1e-3,
                    method=method)
    t, x, v, a = r.time, r.displacement[:, 0], r.velocity[:, 0], r.acceleration[:, 0]
    assert p["steps"].item() == r.stats.steps
    for k in range(1, n + 1):
        ts = (tr + k) * period
        i = min(np.searchsorted(t, ts) - 1, t.size - 2)
        h = t[i + 1] - t[i]
        s = (ts - t[i]) / h
        xs = _hermite(x[i], v[i], x[i + 1], v[i + 1], h, s)
        vs = _hermite(v[i], a[i], v[i + 1], a[i + 1], h, s)
        assert p["poincare_displacement"].values[k - 1] == pytest.approx(xs, rel=1e-9, abs=1e-14)
        assert p["poincare_velocity"].values[k - 1] == pytest.approx(vs, rel=1e-9, abs=1e-12)
    assert p["final_displacement"].item() == x[-1]
    after = r.impacts.t_start > tr * period
    assert p["impact_count"].item() == after.sum() > 0
    assert np.array_equal(p["impact_velocity"].values[: min(after.sum(), n)],
                          r.impacts.v_in[after][:n])


def test_continuation_starts_each_point_from_the_previous_final_state() -> None:
    freqs = [0.8, 0.9, 1.0, 1.1, 1.2]
    tr, n, dt = 3, 2, 2e-3
    sweep = Sweep(oscillator(0.03, SOFT), [Param("loads.0.frequency", freqs)], dt=dt,
                  transient=tr, periods=n, continuation="both", chunk_size=2)  # chains span chunks
    ds = run_sweep(sweep)
    assert list(ds["direction"].values) == ["up", "down"]
    for direction, order in (("up", freqs), ("down", freqs[::-1])):
        x0, v0 = 0.0, 0.0
        for f in order:
            model = oscillator(0.03, SOFT, frequency=f, x0=x0, v0=v0)
            r, _, m = _one_by_one(model, f, dt, tr, n)
            p = ds.sel({"direction": direction, "loads.0.frequency": f}).isel(dof=0)
            k = (tr + np.arange(1, n + 1)) * m
            assert np.array_equal(p["poincare_displacement"].values, r.displacement[k, 0])
            x0, v0 = float(r.displacement[-1, 0]), float(r.velocity[-1, 0])
            assert p["final_displacement"].item() == x0
    up, down = ds.sel(direction="up"), ds.sel(direction="down")
    assert not np.array_equal(up["final_displacement"].values,
                              down["final_displacement"].values)


# --------------------------------------------------------------------------------------------
# The impact oscillator against closed forms
# --------------------------------------------------------------------------------------------


def test_grazing_where_the_linear_amplitude_reaches_the_clearance() -> None:
    """No impacts while the linear steady amplitude ``A(ω) = F/|k − mω² + icω|`` stays below
    the clearance ``d``; impacts as soon as it exceeds it (grazing bifurcation). Up-sweep by
    continuation from the linear steady state, in steps small against the distance to
    grazing (so that no transient reaches the wall before the orbit does)."""
    d = 0.05
    f_graze = brentq(lambda f: abs(receptance(f)) - d, 0.1, 1.0)  # 0.7059 Hz
    deltas = np.array([-0.03, -0.02, -0.012, -0.008, -0.005, -0.003, -0.002, -0.0015, -0.001,
                       0.001, 0.002, 0.005])
    freqs = f_graze * (1 + deltas)
    h0 = receptance(freqs[0])
    model = oscillator(d, x0=h0.imag, v0=2 * np.pi * freqs[0] * h0.real)
    ds = run_sweep(Sweep(model, [Param("loads.0.frequency", freqs)], dt=1e-3, method=ADAPTIVE,
                         transient=30, periods=20, continuation="up"))
    count = ds["impact_count"].isel(gap=0).values
    assert np.all(count[deltas < 0] == 0)
    assert np.all(count[deltas > 0] > 0)
    first = freqs[np.argmax(count > 0)]
    assert first / f_graze - 1 == pytest.approx(0.001, abs=1e-9)  # next grid point above
    # below grazing the response is the linear one
    amp = np.abs([receptance(f) for f in freqs])
    below = deltas < 0
    assert np.allclose(ds["displacement_max"].isel(dof=0).values[below], amp[below], rtol=1e-4)
    assert np.allclose(-ds["displacement_min"].isel(dof=0).values[below], amp[below],
                       rtol=1e-4)


def period_one_orbit(r: float, f: float, d: float = 0.0) -> dict[str, float]:
    """The period-1, one-impact-per-period orbit of ``m x'' + c x' + k x = F sin(ωt)`` with a
    rigid stop at ``x = d`` and restitution ``v⁺ = −r v⁻``, and its Floquet multipliers.

    Closed form (the standard construction of the impact-oscillator literature, e.g. Shaw &
    Holmes 1983, J. Sound Vib. 90:129; Bishop 1994, Phil. Trans. R. Soc. A 347:347): with the
    forced response ``x_p = a sin ψ + b cos ψ`` and the free flow ``Φ(T) = exp(A T)`` over a
    period, the orbit leaving the stop at ``(d, −rV)`` at phase ``θ`` returns to ``(d, V)``
    one period later: ``P(θ) = (d, 0) + V (I − Φ)⁻¹ (e₂ + r Φ e₂)`` with ``P(θ)`` the forced
    state at the impact, linear in ``(sin θ, cos θ)``; ``sin² + cos² = 1`` is a quadratic in
    ``V``. Stability: the eigenvalues of ``S Φ(T)``, with the impact's saltation matrix
    ``S = [[−r, 0], [(a⁺ + r a⁻)/V, −r]]`` (``a∓`` the accelerations just before and after);
    period doubling where one of them crosses −1.
    """
    w, period = 2 * np.pi * f, 1 / f
    a_mat = np.array([[0.0, 1.0], [-K / M, -C / M]])
    phi = expm(a_mat * period)
    kp, cp = K - M * w * w, C * w
    den = kp * kp + cp * cp
    a, b = F * kp / den, -F * cp / den
    forced = np.array([[a, b], [-w * b, w * a]])  # (x_p, v_p) = forced @ (sin θ, cos θ)
    g = np.linalg.solve(np.eye(2) - phi, np.array([0.0, 1.0]) + r * phi[:, 1])
    inv = np.linalg.inv(forced)
    alpha, beta = inv @ np.array([d, 0.0]), inv @ g
    qa, qb, qc = beta @ beta, 2 * alpha @ beta, alpha @ alpha - 1
    roots = [(-qb + sgn * math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa) for sgn in (1, -1)]
    v_imp = max(roots)
    s, c = alpha + v_imp * beta
    theta = math.atan2(s, c)
    acc_in = (F * math.sin(theta) - K * d - C * v_imp) / M
    acc_out = (F * math.sin(theta) - K * d + C * r * v_imp) / M
    saltation = np.array([[-r, 0.0], [(acc_out + r * acc_in) / v_imp, -r]])
    mult = np.linalg.eigvals(saltation @ phi)
    # state at forcing phase 0 (t = 0 mod T): the free flow from the impact
    dt0 = ((2 * np.pi - theta) % (2 * np.pi)) / w
    h = expm(a_mat * dt0) @ (np.array([d, -r * v_imp]) - forced @ [math.sin(theta), c])
    x0 = h + forced @ [math.sin(theta + w * dt0), math.cos(theta + w * dt0)]
    return {"v_imp": v_imp, "phase": (theta / (2 * np.pi)) % 1,
            "pd_margin": float(np.real(1 + mult.sum() + np.prod(mult))),
            "x0": float(x0[0]), "v0": float(x0[1])}


def test_period_doubling_of_the_impact_oscillator_at_the_closed_form_point() -> None:
    """Stop at the static equilibrium (d = 0): the period-1 orbit loses stability by period
    doubling where its Floquet multiplier reaches −1 (f ≈ 2.66 Hz = 2.66 f_n). The sweep
    (stiff compliant stop; its effective restitution in the closed form) is period-1 up to
    0.99 f_pd and period-2 from 1.005 f_pd, with the closed form's impact speed and phase."""
    r = single_impact(STOP, 1.0, 0.1)["restitution_effective"]  # 0.865, speed-independent
    f_pd = brentq(lambda f: period_one_orbit(r, f)["pd_margin"], 2.5, 2.75)
    assert 2.6 < f_pd < 2.7
    ratios = np.array([0.95, 0.97, 0.98, 0.99, 1.005, 1.01, 1.015])
    freqs = f_pd * ratios
    start = period_one_orbit(r, freqs[0])
    model = oscillator(0.0, x0=start["x0"], v0=start["v0"])
    ds = run_sweep(Sweep(model, [Param("loads.0.frequency", freqs)], dt=1e-3, method=ADAPTIVE,
                         transient=150, periods=16, continuation="up"))
    samples = ds["poincare_displacement"].isel(dof=0).values
    tol = 1e-3 * np.abs(samples).max()  # the step control's noise is ~1e-4 of it
    for ratio, f, x, p in zip(ratios, freqs, samples, ds.isel(gap=0, dof=0).impact_velocity,
                              strict=True):
        even, odd = x[0::2], x[1::2]
        if ratio < 1:
            assert np.ptp(x) < tol, f"period-1 expected at {ratio} f_pd"
            orbit = period_one_orbit(r, f)
            assert np.nanmax(p.values) == pytest.approx(orbit["v_imp"], rel=0.01)
            phase = ds.sel({"loads.0.frequency": f}).impact_phase.isel(gap=0, impact=0).item()
            assert phase == pytest.approx(orbit["phase"], abs=0.005)
        else:
            assert np.ptp(even) < tol and np.ptp(odd) < tol, f"period-2 expected at {ratio}"
            assert abs(even.mean() - odd.mean()) > 50 * tol


# --------------------------------------------------------------------------------------------
# Files, resuming, plots
# --------------------------------------------------------------------------------------------


def _small_sweep(chunk_size: int = 3) -> Sweep:
    return Sweep(oscillator(0.03, SOFT),
                 [Param("loads.0.frequency", np.linspace(0.6, 1.6, 12))],
                 dt=2e-3, transient=4, periods=4, chunk_size=chunk_size)


def test_file_round_trip_and_plots(tmp_path: Path) -> None:
    sweep = _small_sweep()
    ds = run_sweep(sweep, output=tmp_path / "s.nc")
    assert not (tmp_path / "s.nc.parts").exists()
    back = load_sweep(tmp_path / "s.nc")
    xr.testing.assert_equal(back, ds)
    assert back["poincare_displacement"].attrs["units"] == "m"
    assert back["loads.0.frequency"].attrs["units"] == "Hz"
    assert back["failed"].dtype == bool
    for kind, fn in (("bifurcation", plot_bifurcation), ("response", plot_response)):
        fn(back, path=tmp_path / f"{kind}.png")
        assert (tmp_path / f"{kind}.png").stat().st_size > 1000
    plot_bifurcation(back, quantity="impact-velocity", path=tmp_path / "v.svg")
    with pytest.raises(vi.ModelError, match="--dof"):
        plot_bifurcation(back, dof=3)


def test_resumed_sweep_recomputes_no_finished_chunk(tmp_path: Path) -> None:
    sweep = _small_sweep()
    out = tmp_path / "s.nc"
    computed: list[int] = []

    def stop_after_two(ev: ChunkEvent) -> None:
        computed.append(ev.index)
        if len(computed) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(sweep, output=out, on_chunk=stop_after_two)
    parts = sorted((tmp_path / "s.nc.parts").glob("*/chunk-*.npz"))
    assert len(parts) >= 2 and not out.exists()
    mtimes = {p.name: p.stat().st_mtime_ns for p in parts}
    events = []

    def record(ev: ChunkEvent) -> None:
        events.append(ev)
        if ev.reused:  # a reused part is read, never rewritten
            p = next(q for q in parts if q.name == f"chunk-{ev.index:05d}.npz")
            assert p.stat().st_mtime_ns == mtimes[p.name]

    ds = run_sweep(sweep, output=out, on_chunk=record)
    reused = {e.index for e in events if e.reused}
    assert reused == {int(p.stem.split("-")[1]) for p in parts}
    assert all(not e.reused for e in events if e.index not in reused)
    assert len(events) == 4 and events[-1].done == 12
    assert ds.attrs["chunks_reused"] == len(parts)
    assert ds.attrs["chunks_computed"] == 4 - len(parts)
    xr.testing.assert_equal(ds, run_sweep(sweep))
    assert not (tmp_path / "s.nc.parts").exists()


@pytest.mark.parametrize("during", ["a chunk's callback", "a part's writing"])
def test_a_signal_stops_the_sweep_with_interrupted_naming_the_points_kept(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, during: str) -> None:
    """SIGTERM on the main thread, between chunks or while a part is written (held until the
    part is complete), raises Interrupted with the signal and the points on disk."""
    sweep = _small_sweep()
    out = tmp_path / "s.nc"
    term_handler = signal.getsignal(signal.SIGTERM)
    if during == "a part's writing":
        savez = np.savez

        def savez_then_signal(*args: object, **kwargs: object) -> None:
            os.kill(os.getpid(), signal.SIGTERM)
            savez(*args, **kwargs)

        monkeypatch.setattr(np, "savez", savez_then_signal)
        on_chunk = None
    else:
        def on_chunk(ev: ChunkEvent) -> None:
            os.kill(os.getpid(), signal.SIGTERM)

    with pytest.raises(vi.Interrupted) as err:
        run_sweep(sweep, output=out, on_chunk=on_chunk, threads=1)
    monkeypatch.undo()
    parts = sorted((tmp_path / "s.nc.parts").glob("*/chunk-*.npz"))
    assert err.value.signum == signal.SIGTERM and 1 <= len(parts) < 4
    assert str(err.value) == (
        f"sweep stopped by SIGTERM: {3 * len(parts)} of 12 points ({len(parts)} of 4 chunks) "
        f"are kept in {out}.parts/; the same command (the same sweep and output) resumes "
        "from them")
    assert signal.getsignal(signal.SIGTERM) == term_handler
    xr.testing.assert_equal(run_sweep(sweep, output=out), run_sweep(sweep))


# --------------------------------------------------------------------------------------------
# The command line
# --------------------------------------------------------------------------------------------

MODEL_FILE = Path(__file__).parents[1] / "examples" / "models" / "impact_oscillator.toml"


def _cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "vibroimpact", *args],
                          capture_output=True, text=True, timeout=timeout)


def test_benchmark_model_is_the_example_file() -> None:
    from vibroimpact.benchmarks.sweep import impact_oscillator

    mf = vi.load_model(MODEL_FILE)
    model, method, dt = impact_oscillator(frequency=mf.model.loads[0].frequency)
    a, b = mf.model.to_spec(), model.to_spec()
    assert a.keys() == b.keys()
    for key in a:
        if isinstance(a[key], np.ndarray):
            assert np.array_equal(a[key], b[key]), key
        else:
            assert a[key] == b[key], key
    assert (mf.method, mf.dt) == (method, dt)


def test_cli_sweep_and_plot(tmp_path: Path) -> None:
    out = tmp_path / "sweep.nc"
    p = _cli("sweep", str(MODEL_FILE), "--param", "loads.0.frequency=8:30:8",
             "--transient", "20", "--periods", "8", "--continuation", "both", "-o", str(out),
             "--json")
    assert p.returncode == 0, p.stderr
    summary = json.loads(p.stdout)
    assert summary["points"] == 16 and summary["failed_points"] == 0
    assert 0 < summary["impacting_points"] < 16  # grazing at 12.2 and 25.5 Hz
    ds = load_sweep(out)
    assert ds.sizes["loads.0.frequency"] == 8 and ds.sizes["sample"] == 8
    for kind in ("bifurcation", "response"):
        fig = tmp_path / f"{kind}.png"
        q = _cli("plot", str(out), "--kind", kind, "-o", str(fig))
        assert q.returncode == 0, q.stderr
        assert fig.stat().st_size > 1000


def test_cli_method_overrides_the_model_files_method(tmp_path: Path) -> None:
    """``--method dop853`` sweeps with DOP853 at its defaults: the same Dataset as the API's
    sweep with ``method=Dop853()``, and other steps than the file's adaptive Newmark."""
    mf = vi.load_model(MODEL_FILE)
    grid = [Param("loads.0.frequency", [9.0, 14.0, 20.0])]
    options = {"transient": 10, "periods": 5}
    out = tmp_path / "dop853.nc"
    p = _cli("sweep", str(MODEL_FILE), "--param", "loads.0.frequency=9,14,20", "--transient",
             "10", "--periods", "5", "--method", "dop853", "-o", str(out), "--quiet")
    assert p.returncode == 0, p.stderr
    cli = load_sweep(out)
    api = run_sweep(Sweep.from_model_file(mf, grid, method=vi.Dop853(), **options))
    file_method = run_sweep(Sweep.from_model_file(mf, grid, **options))
    assert not isinstance(mf.method, vi.Dop853)
    for name in ("steps", "displacement_max", "impact_count"):
        xr.testing.assert_equal(cli[name], api[name])
    assert not np.array_equal(cli["steps"].values, file_method["steps"].values)


@pytest.mark.parametrize(("args", "message"), [
    (["--param", "loads.0.freq=5:50:4"], "--param loads.0.freq"),
    (["--param", "loads.0.frequency=5:50"], "expected PATH=A:B:N"),
    (["--param", "gaps.0.clearance=-1,1"], "sweep point gaps.0.clearance=-1"),
    (["--param", "loads.0.frequency=5:50:4", "--workers", "2"], "--workers"),
    (["--param", "loads.0.frequency=5:50:4", "--method", "rk4"], "--method: 'rk4'"),
    (["--param", "loads.0.frequency=5:50:4", "--method", "event-driven"],
     "--method: 'event-driven' cannot take gaps[0].law.kind = 'lankarani-nikravesh'"),
])
def test_cli_mistakes_are_one_line_with_exit_code_2(tmp_path: Path, args: list[str],
                                                     message: str) -> None:
    p = _cli("sweep", str(MODEL_FILE), *args, "-o", str(tmp_path / "s.nc"))
    assert p.returncode == 2
    assert message in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "s.nc").exists()


def test_cli_dask_without_dask_says_how_to_install_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from vibroimpact.cli import main

    monkeypatch.setitem(sys.modules, "distributed", None)  # as if not installed
    code = main(["sweep", str(MODEL_FILE), "--param", "loads.0.frequency=8,9", "--dask",
                 "-o", str(tmp_path / "s.nc")])
    assert code == 2
    assert "pip install 'vibroimpact[distributed]'" in capsys.readouterr().err


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT, signal.SIGTERM])
def test_cli_killed_sweep_restarts_where_it_stopped(tmp_path: Path, sig: int) -> None:
    """SIGKILL (or Ctrl-C or SIGTERM: the running chunks stop at once and are not kept; one
    line says how many points are kept and that the same command resumes) the sweep once
    some chunks are on disk; the same command then reuses every finished chunk and writes the
    same Dataset as an uninterrupted run."""
    out = tmp_path / "s.nc"
    args = ("sweep", str(MODEL_FILE), "--param", "loads.0.frequency=8:30:40", "--transient",
            "40", "--periods", "10", "--chunk-size", "2", "--threads", "1", "-o", str(out),
            "--json")
    proc = subprocess.Popen([sys.executable, "-m", "vibroimpact", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    parts: list[Path] = []
    deadline = time.monotonic() + 60
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            parts = list((tmp_path / "s.nc.parts").glob("*/chunk-*.npz"))
            if len(parts) >= 3:
                break
            time.sleep(0.02)
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, sig)
        _, stderr = proc.communicate(timeout=30)
    expected = -signal.SIGKILL if sig == signal.SIGKILL else 128 + sig  # 130, 143
    assert proc.returncode == expected, "the sweep finished before it could be killed"
    done = {p.name for p in (tmp_path / "s.nc.parts").glob("*/chunk-*.npz")}
    assert 3 <= len(done) < 20 and not out.exists()
    if sig != signal.SIGKILL:
        assert stderr.decode().splitlines() == [
            f"vibroimpact: interrupted: sweep stopped by {signal.Signals(sig).name}: "
            f"{2 * len(done)} of 40 points ({len(done)} of 20 chunks) are kept in "
            f"{out}.parts/; the same command (the same sweep and output) resumes from them"]
    p = _cli(*args)
    assert p.returncode == 0, p.stderr
    summary = json.loads(p.stdout)
    assert summary["failed_points"] == 0
    assert summary["chunks_reused"] == len(done)
    assert summary["chunks_computed"] == 20 - len(done)
    fresh = run_sweep(Sweep.from_model_file(
        vi.load_model(MODEL_FILE), [parse_param("loads.0.frequency=8:30:40")], transient=40,
        periods=10, chunk_size=2))
    xr.testing.assert_equal(load_sweep(out), fresh)


# A stiff SDOF (ω = 100 rad/s, or 1 and 3.2 rad/s when swept) integrated by Newmark with
# beta = 0.1 at dt = 0.05 s: stable only for ω dt <= 1/sqrt(gamma/2 - beta) = 2.58, so a
# point of ω = 100 (ω dt = 5) fails (energy blow-up) and the soft ones run through.
UNSTABLE_SWEEP = """schema_version = 1
[structure]
kind = "sdof"
mass = 1.0
stiffness = 1e4
[initial]
displacement = 1e-3
[[loads]]
kind = "harmonic"
dof = 0
amplitude = 1.0
frequency = 1.0
[solver]
method = "newmark"
beta = 0.1
gamma = 0.5
dt = 0.05
t_end = 1.0
"""


def _unstable_sweep(tmp_path: Path, param: str, *extra: str) -> subprocess.CompletedProcess:
    model = tmp_path / "unstable.toml"
    model.write_text(UNSTABLE_SWEEP)
    return _cli("sweep", str(model), "--param", param, "--transient", "5", "--periods", "5",
                "-o", str(tmp_path / "u.nc"), *extra)


def test_cli_sweep_whose_every_point_fails_exits_3_on_one_line(tmp_path: Path) -> None:
    p = _unstable_sweep(tmp_path, "loads.0.frequency=1:2:4", "--json")
    assert p.returncode == 3, p.stderr
    lines = p.stderr.splitlines()
    assert len(lines) == 1, p.stderr
    assert lines[0].startswith("vibroimpact: solver failed: every one of the 4 points failed "
                               "(first: loads.0.frequency=1: the solution diverged (energy "
                               "blow-up) at t = ")
    assert lines[0].endswith(f"the Dataset (every point marked failed) was written to "
                             f"{tmp_path / 'u.nc'}")
    assert json.loads(p.stdout)["failed_points"] == 4
    assert bool(load_sweep(tmp_path / "u.nc").failed.all())


def test_cli_sweep_with_some_failed_points_counts_them_and_the_file_lists_them(
        tmp_path: Path) -> None:
    stiffness = [1.0, 10.0, 1e4, 2e4]
    p = _unstable_sweep(tmp_path, "structure.stiffness=" + ",".join(map(str, stiffness)))
    assert p.returncode == 0, p.stderr
    # the points beyond Newmark's critical step fail, the others run through
    omega_dt = np.sqrt(stiffness) * 0.05
    beyond = omega_dt > 1 / np.sqrt(0.5 / 2 - 0.1)
    assert beyond.tolist() == [False, False, True, True]
    assert p.stdout.splitlines()[-1].endswith(
        "0 impacting, 2 of 4 failed (listed above; all are marked in the Dataset's variable "
        f"failed, docs/sweeps.md: Failed points); written to {tmp_path / 'u.nc'}")
    listed = [ln for ln in p.stderr.splitlines() if ln.startswith("  failed: ")]
    assert [ln.split(":")[1].strip() for ln in listed] == ["structure.stiffness=10000",
                                                          "structure.stiffness=20000"]
    # docs/sweeps.md, "Failed points": listing them from the file
    ds = load_sweep(tmp_path / "u.nc")
    failed = ds.failed.to_series()
    assert failed[failed].index.tolist() == np.array(stiffness)[beyond].tolist()
    messages = json.loads(ds.attrs["errors"])
    assert [e["point"] for e in messages] == ["structure.stiffness=10000",
                                              "structure.stiffness=20000"]
    assert all("energy blow-up" in e["message"] for e in messages)
