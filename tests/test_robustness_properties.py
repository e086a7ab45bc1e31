"""Property-based tests of physics invariants (issue 10, item 4), with a bounded number of
examples: for random small models with dissipative contact laws and no external load the
mechanical energy never increases; a contact force is never tensile (any law, any load); the
results do not depend on the output decimation."""

from __future__ import annotations

import math

import numpy as np
import vibroimpact as vi
from hypothesis import given, settings
from hypothesis import strategies as st
from vibroimpact.simulate import contact_periods

PROPERTY = settings(max_examples=50, deadline=None, derandomize=True)

DISSIPATIVE = ("lankarani-nikravesh", "flores", "gonthier", "hunt-crossley", "kelvin-voigt",
               "zhiying-qishao", "hu-guo")


@st.composite
def laws(draw: st.DrawFn, kinds: tuple[str, ...] = DISSIPATIVE) -> vi.contact.ContactLaw:
    kind = draw(st.sampled_from(kinds))
    stiffness = draw(st.floats(1e6, 1e11))
    restitution = draw(st.floats(0.3, 0.95))
    c = vi.contact
    if kind == "kelvin-voigt":
        # damping ratio 0.05 to 0.5 for a 1 kg, `stiffness` N/m contact
        ratio = draw(st.floats(0.05, 0.5))
        k = draw(st.floats(1e5, 1e8))
        return c.KelvinVoigt(stiffness=k, damping=2 * ratio * math.sqrt(k))
    if kind == "hunt-crossley":
        return c.HuntCrossley(stiffness=stiffness, exponent=1.5, restitution=restitution)
    cls = {"lankarani-nikravesh": c.LankaraniNikravesh, "flores": c.Flores,
           "gonthier": c.Gonthier, "zhiying-qishao": c.ZhiyingQishao, "hu-guo": c.HuGuo,
           "hertz": None}[kind]
    if cls is None:
        return c.Hertz(stiffness=stiffness, exponent=1.5)
    return cls(stiffness=stiffness, exponent=1.5, restitution=restitution)


@st.composite
def models(draw: st.DrawFn, kinds: tuple[str, ...] = DISSIPATIVE,
           loads: bool = False) -> vi.Model:
    """One or two masses (spring and dashpot between them and to ground), one or two
    gaps, thrown at a wall."""
    n = draw(st.integers(1, 2))
    masses = [draw(st.floats(0.1, 100.0)) for _ in range(n)]
    k_ground = draw(st.sampled_from([0.0, 1e3, 1e5]))
    c_ground = draw(st.sampled_from([0.0, 10.0]))
    mass = np.diag(masses)
    stiffness = np.zeros((n, n))
    damping = np.zeros((n, n))
    stiffness[0, 0] += k_ground
    damping[0, 0] += c_ground
    if n == 2:
        k, c = draw(st.floats(1e3, 1e6)), draw(st.sampled_from([0.0, 5.0]))
        stiffness += k * np.array([[1, -1], [-1, 1]])
        damping += c * np.array([[1, -1], [-1, 1]])
    gaps = [vi.Gap(dof=0, clearance=draw(st.floats(0.0, 2e-3)), side="both", law=draw(laws(kinds)))]
    if n == 2 and draw(st.booleans()):
        gaps.append(vi.Gap(dof=[0, 1], coefficients=[1.0, -1.0],
                           clearance=draw(st.floats(0.0, 1e-3)), side="both",
                           law=draw(laws(kinds))))
    v0 = [draw(st.floats(0.1, 5.0))] + [draw(st.floats(-2.0, 2.0)) for _ in range(n - 1)]
    load = []
    if loads:
        load = [vi.HarmonicLoad(dof=n - 1, amplitude=draw(st.floats(-1e3, 1e3)),
                                frequency=draw(st.floats(1.0, 200.0)))]
    return vi.Model(vi.Structure(mass, stiffness, damping), gaps=gaps, loads=load,
                    initial_velocity=v0)


def _resolving_step(model: vi.Model, t_end: float) -> float:
    """A step resolving every contact (1/100 of the shortest estimated contact period), and
    at least t_end / 20000."""
    periods = [p for p in contact_periods(model) if p is not None]
    return max(min(periods, default=t_end / 1000) / 100, t_end / 20000)


@PROPERTY
@given(model=models())
def test_energy_never_increases_without_external_load(model: vi.Model) -> None:
    t_end = 0.02
    r = vi.simulate(model, t_end=t_end, dt=_resolving_step(model, t_end), throw=False)
    assert r.complete, r.message
    total = r.energy.total
    e0 = total[0]
    tol = 2e-3 * e0
    assert np.all(total <= e0 + tol), (total.max() - e0) / e0
    assert np.all(np.diff(total) <= tol), np.diff(total).max() / e0
    dissipated = r.energy.contact_dissipated + r.energy.damping_dissipated
    assert np.all(np.diff(dissipated) >= -tol)


@PROPERTY
@given(model=models(kinds=(*DISSIPATIVE, "hertz"), loads=True))
def test_contact_force_is_never_tensile(model: vi.Model) -> None:
    t_end = 0.01
    r = vi.simulate(model, t_end=t_end, dt=_resolving_step(model, t_end), throw=False)
    assert np.all(r.gap_force >= 0.0)
    assert np.all(r.impacts.force_max >= 0.0)
    assert np.all(r.impacts.impulse >= 0.0)


@settings(max_examples=30, deadline=None, derandomize=True)
@given(model=models(loads=True), every=st.integers(2, 40))
def test_results_do_not_depend_on_output_decimation(model: vi.Model, every: int) -> None:
    t_end = 0.005
    dt = _resolving_step(model, t_end)
    full = vi.simulate(model, t_end=t_end, dt=dt, throw=False)
    dec = vi.simulate(model, t_end=t_end, dt=dt, every=every, throw=False)
    assert full.complete == dec.complete
    kept = list(range(0, len(full.time), every))
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
