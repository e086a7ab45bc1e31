"""Adaptive stepping with located contact events (issue 4, item 3)."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
import reference
import vibroimpact as vi
from vibroimpact.paper import cases


@functools.cache
def _sdof_reference() -> dict:
    return reference.bilateral_sdof("lankarani-nikravesh", 100.0, 0.005, 8.0, cases.SDOF_T_END,
                                    K=reference.paper_stiffness(), restitution=0.9)


def _errors(r: vi.Result) -> dict[str, float]:
    """Largest errors against the SciPy reference: peak |x|, each impact's start and end
    time, and separation speed."""
    ref = _sdof_reference()
    imp = ref["impacts"]
    assert len(r.impacts) == len(imp)

    def column(key: str) -> np.ndarray:
        return np.array([np.nan if i[key] is None else i[key] for i in imp])

    return {"peak": abs(r.max_abs_displacement[0] - ref["max_abs_displacement"]),
            "t_start": float(np.max(np.abs(r.impacts.t_start - column("t_start")))),
            "t_end": float(np.nanmax(np.abs(r.impacts.t_end - column("t_end")))),
            "v_out": float(np.nanmax(np.abs(r.impacts.v_out - column("v_out"))))}


def test_adaptive_matches_fixed_1us_accuracy_with_5x_fewer_steps() -> None:
    """Peak displacement, every impact's start and end time and separation speed at least as
    accurate as fixed dt = 1 µs (issue 4), with at least 5× fewer Newmark steps — counting
    every step solved: the three of each extrapolated step in contact and every discarded
    attempt (error, event inside, Newton)."""
    model = cases.sdof_model("lankarani-nikravesh")
    fixed = vi.simulate(model, t_end=cases.SDOF_T_END, dt=1e-6)
    method = vi.Newmark(adaptive=vi.Adaptive(rtol=1e-5, atol=1e-12, dt_max=1e-3))
    adaptive = vi.simulate(model, t_end=cases.SDOF_T_END, dt=1e-5, method=method)
    err_fixed, err_adaptive = _errors(fixed), _errors(adaptive)
    for key, e in err_adaptive.items():
        assert e <= err_fixed[key], (key, e, err_fixed[key])
    solved = adaptive.stats.steps + adaptive.stats.rejected_steps
    assert 5 * solved <= fixed.stats.steps
    assert adaptive.time[-1] == pytest.approx(cases.SDOF_T_END, rel=1e-14)


def test_adaptive_converges_to_the_reference() -> None:
    """Tightening rtol drives every error down: 1e-7 reaches 1e-10 m on the peak and 1e-9 s
    on every impact time (the benchmark's 1e-8 m / 1e-9 s target)."""
    model = cases.sdof_model("lankarani-nikravesh")
    errors = []
    for rtol in (1e-5, 1e-7):
        method = vi.Newmark(adaptive=vi.Adaptive(rtol=rtol, atol=1e-12, dt_max=1e-3))
        errors.append(_errors(vi.simulate(model, t_end=cases.SDOF_T_END, dt=1e-5,
                                          method=method)))
    loose, tight = errors
    for key in loose:
        assert tight[key] < loose[key] / 20, key
    assert tight["peak"] < 1e-10
    assert max(tight["t_start"], tight["t_end"]) < 1e-9


def test_adaptive_lands_on_contact_events() -> None:
    """Each closing and opening is the end of a step: v_in is the flight speed exactly; and so
    is each contact's deepest point (the speed there is 1e-6 of v_in, against about 1e-2 at the
    nearest step end of steps that do not land on it)."""
    model = cases.sdof_model("hertz")
    method = vi.Newmark(adaptive=vi.Adaptive(rtol=1e-6, atol=1e-12, dt_max=2e-4))
    r = vi.simulate(model, t_end=cases.SDOF_T_END, dt=1e-5, method=method)
    assert r.impacts.t_start[0] == pytest.approx(0.005 / 8.0, rel=1e-12)
    assert r.impacts.v_in[0] == pytest.approx(8.0, rel=1e-12)
    # free flight between walls at constant speed: v_in(k+1) = v_out(k)
    assert np.allclose(r.impacts.v_in[1:], r.impacts.v_out[:-1], rtol=1e-12, equal_nan=True)
    for t_start, t_end, v_in in zip(r.impacts.t_start, r.impacts.t_end, r.impacts.v_in,
                                    strict=True):
        inside = (r.time > t_start) & (r.time < (t_end if t_end == t_end else np.inf))
        assert np.abs(r.velocity[inside, 0]).min() < 1e-4 * v_in
    # steps are long in free flight and short in contact
    dt = np.diff(r.time)
    in_contact = np.abs(r.displacement[1:, 0]) > 0.005
    assert dt[~in_contact].max() > 20 * np.median(dt[in_contact])


def test_grazing_contact_is_recorded() -> None:
    """A spring-mass whose free amplitude exceeds the clearance by 0.01 %: the contact lasts
    a few µs in a 63 ms period, yet large adaptive steps must not step over it."""
    m, k, d = 1.0, 1e4, 1e-3
    w = math.sqrt(k / m)
    amplitude = d * (1 + 1e-4)
    law = vi.contact.Hertz(stiffness=1e9)
    model = vi.Model(vi.Structure.sdof(mass=m, stiffness=k),
                     gaps=[vi.Gap(dof=0, clearance=d, side="positive", law=law)],
                     initial_velocity=w * amplitude)
    method = vi.Newmark(adaptive=vi.Adaptive(rtol=1e-4, atol=1e-9, dt_max=5e-3))
    r = vi.simulate(model, t_end=0.1, dt=1e-3, method=method)
    assert len(r.impacts) == 2  # touches at t = T/4 and 5T/4
    t_touch = math.asin(d / amplitude) / w
    assert r.impacts.t_start[0] == pytest.approx(t_touch, abs=2e-5)
    assert r.impacts.delta_max[0] == pytest.approx(amplitude - d, rel=0.05)
    assert r.stats.steps < 2000


def test_adaptive_from_a_model_file(tmp_path) -> None:
    text = """
[structure]
kind = "sdof"
mass = 100.0
[[gaps]]
dof = 0
clearance = 0.005
side = "both"
[gaps.law]
kind = "hertz"
stiffness = 1.5088e11
[initial]
velocity = 8.0
[solver]
method = "newmark"
dt = 1e-5
t_end = 0.02
adaptive = true
rtol = 1e-6
atol = 1e-12
dt_max = 2e-4
"""
    path = tmp_path / "adaptive.toml"
    path.write_text(text)
    mf = vi.load_model(path)
    assert mf.method.adaptive == vi.Adaptive(rtol=1e-6, atol=1e-12, dt_max=2e-4)
    r = vi.simulate(mf.model, t_end=mf.t_end, dt=mf.dt, method=mf.method)
    assert r.complete and r.stats.steps + r.stats.rejected_steps < 6000
    assert np.diff(r.time).max() > 100 * np.diff(r.time).min()  # the step size adapts
    assert r.max_abs_displacement[0] == pytest.approx(6.2296e-3, rel=1e-5)


@pytest.mark.parametrize("method", [vi.GeneralizedAlpha(rho_inf=0.9), vi.HHT(alpha=0.05)])
def test_adaptive_alpha_methods_reach_the_reference(method: vi.Integrator) -> None:
    import dataclasses

    method = dataclasses.replace(method, adaptive=vi.Adaptive(rtol=1e-7, atol=1e-12,
                                                              dt_max=2e-4))
    r = vi.simulate(cases.sdof_model("lankarani-nikravesh"), t_end=cases.SDOF_T_END, dt=1e-5,
                    method=method)
    e = _errors(r)
    assert e["peak"] < 5e-8 and e["t_start"] < 2e-6
    assert r.stats.steps < 20000


@pytest.mark.parametrize(
    ("options", "field"),
    [
        ({"rtol": 1e-6}, "solver.rtol"),
        ({"adaptive": True, "dt_min": -1.0}, "solver.dt_min"),
        ({"adaptive": "yes"}, "solver.adaptive"),
        ({"adaptive": True, "rtol": -1.0}, "solver.rtol"),
    ],
)
def test_bad_adaptive_options(options: dict, field: str) -> None:
    with pytest.raises(vi.ModelError, match=field.replace(".", r"\.")):
        vi.integrators.method_from_options("newmark", options)
