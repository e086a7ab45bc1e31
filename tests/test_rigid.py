"""Rigid impacts (issue 5 item 3, the massless bar): ``contact.Rigid`` with the impulsive
methods ``EventDriven`` and ``MoreauJean`` against the closed-form bouncing mass, a compliant
law with growing stiffness converging to the rigid solution, the model file, and the
refusals. (The core's own tests: rust/vibroimpact-core/tests/rigid.rs.)"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact import contact
from vibroimpact.cli import main as cli_main
from vibroimpact.impact import single_impact

G, H = 9.81, 1.0


def _model(law: contact.ContactLaw, mass: float = 1.0, table: bool = False) -> vi.Model:
    """A mass dropped from rest at height H onto a floor at u = 0, under gravity (``table``:
    given as a two-row table, held at its end values)."""
    gravity = (vi.TableLoad(dof=0, time=[0.0, 1.0], force=[-G * mass, -G * mass]) if table
               else vi.ConstantLoad(dof=0, amplitude=-G * mass))
    return vi.Model(
        vi.Structure.sdof(mass=mass),
        gaps=[vi.Gap(dof=0, clearance=0.0, side="negative", law=law)],
        loads=[gravity],
        initial_displacement=H,
    )


def closed_form(e: float, k: int) -> tuple[float, float]:
    """Impact k (k >= 1): ``t_k = t1 + 2 v1 (e − e^k) / (g (1 − e))`` and approach speed
    ``e^(k−1) v1``, with ``t1 = √(2H/g)``, ``v1 = g t1`` (each flight after impact j lasts
    ``2 e^j v1 / g``)."""
    t1 = math.sqrt(2 * H / G)
    v1 = G * t1
    if e == 1.0:
        return t1 + 2 * v1 * (k - 1) / G, v1
    return t1 + 2 * v1 * (e - e**k) / (G * (1 - e)), e ** (k - 1) * v1


def accumulation_time(e: float) -> float:
    """``t∞ = t1 + 2 e v1 / (g (1 − e))``: the impacts accumulate there (Zeno)."""
    t1 = math.sqrt(2 * H / G)
    return t1 + 2 * e * G * t1 / (G * (1 - e))


@pytest.mark.parametrize("table", [False, True], ids=["constant-load", "table-load"])
def test_event_driven_matches_the_closed_form_and_sticks_at_t_inf(table: bool) -> None:
    """Constant loads ride in the exact propagator as their own state; a table load takes the
    quadratic-interpolation path (exact for a load constant over each step)."""
    e, dt = 0.7, 1e-3
    method = vi.EventDriven()
    r = vi.simulate(_model(contact.Rigid(restitution=e), table=table),
                    t_end=accumulation_time(e) + 0.2,
                    dt=dt, method=method)
    imp = r.impacts
    n = len(imp.t_start)
    assert n > 20
    for k in range(n - 1):
        t, v = closed_form(e, k + 1)
        assert imp.t_start[k] == pytest.approx(t, abs=1e-10)
        assert imp.t_end[k] == imp.t_start[k]
        assert imp.v_in[k] == pytest.approx(v, rel=1e-9)
        assert imp.restitution_effective[k] == pytest.approx(e, rel=1e-9)
        assert imp.impulse[k] == pytest.approx((1 + e) * v, rel=1e-9)  # m = 1
        assert math.isnan(imp.force_max[k]) and imp.delta_max[k] == 0.0
    # The chattering rule: the last row is the sticking contact, from within
    # chatter_fraction·dt/(1 − e) before t∞, still closed at the end, carrying the weight.
    t_inf = accumulation_time(e)
    assert 0 <= t_inf - imp.t_start[-1] < method.chatter_fraction * dt / (1 - e)
    assert math.isnan(imp.t_end[-1])
    assert imp.force_max[-1] == pytest.approx(G, rel=1e-9)
    assert abs(r.displacement[-1, 0]) < 1e-12 and abs(r.velocity[-1, 0]) < 1e-12


@pytest.mark.parametrize("theta", [0.5, 1.0])
def test_moreau_jean_converges_to_the_event_driven_solution(theta: float) -> None:
    e = 0.7
    t_end = closed_form(e, 4)[0]
    ref = vi.simulate(_model(contact.Rigid(restitution=e)), t_end=t_end, dt=1e-4,
                      method=vi.EventDriven())
    errors = []
    dts = [2e-3, 1e-3, 5e-4, 2.5e-4]
    for dt in dts:
        r = vi.simulate(_model(contact.Rigid(restitution=e)), t_end=t_end, dt=dt,
                        method=vi.MoreauJean(theta=theta))
        x_ref = np.interp(r.time, ref.time, ref.displacement[:, 0])
        errors.append(float(np.max(np.abs(r.displacement[:, 0] - x_ref))))
        # the first three impacts: each known to a step, the errors adding up
        for k in range(3):
            assert abs(r.impacts.t_start[k] - closed_form(e, k + 1)[0]) < 3 * (k + 1) * dt
    order = math.log(errors[0] / errors[-1]) / math.log(dts[0] / dts[-1])
    assert order > 0.8, (order, errors)


@pytest.mark.parametrize("kind", ["hertz", "flores"])
def test_compliant_law_with_growing_stiffness_converges_to_rigid(kind: str) -> None:
    """A Hertz-based law ``K δ^1.5 (…)`` with K → ∞: contact durations shrink like
    K^(−2/5), and the impact times and rebound speeds of the first three impacts approach the
    rigid solution whose restitution is the law's effective restitution (1 for Hertz; for
    Flores, which does not reproduce its ce exactly, measured by one impact)."""
    def law(k: float) -> contact.ContactLaw:
        if kind == "hertz":
            return contact.Hertz(stiffness=k)
        return contact.Flores(stiffness=k, restitution=0.8)

    e = 1.0 if kind == "hertz" else single_impact(law(1e9), 1.0, 1.0)["restitution_effective"]
    n_imp = 3
    t_end = closed_form(e, n_imp)[0] + 0.2 * (closed_form(e, n_imp)[0] - closed_form(e, 2)[0])
    errors = []
    for k in (1e7, 1e9, 1e11):
        duration = 3.2 * (1.25 * (G * math.sqrt(2 * H / G)) ** 2 / k) ** 0.4 / 4.43
        r = vi.simulate(_model(law(k)), t_end=t_end, dt=duration / 100, every=10_000,
                        method=vi.Newmark())
        imp = r.impacts
        assert len(imp.t_start) >= n_imp
        err = 0.0
        for j in range(n_imp):
            t, v = closed_form(e, j + 1)
            err = max(err, abs(imp.t_start[j] - t) / t, abs(imp.v_in[j] - v) / v,
                      abs(imp.v_out[j] - e * v) / v)
        errors.append(err)
    assert errors[0] > errors[1] > errors[2], errors
    # ~K^(−2/5) per factor 100 in K: 100^0.4 = 6.3
    assert errors[1] / errors[2] > 3.0, errors
    assert errors[2] < 2e-2, errors


def test_two_gaps_simultaneous_impacts() -> None:
    """Two masses on a spring, each against its own wall, moving antisymmetrically: the two
    impacts are simultaneous (one event, one LCP) and each wall gets its own Newton impact."""
    k = 100.0
    structure = vi.Structure(mass=np.eye(2), stiffness=np.array([[k, -k], [-k, k]]))
    law = contact.Rigid(restitution=0.7)
    model = vi.Model(structure, gaps=[
        vi.Gap(dof=0, clearance=0.01, side="positive", law=law),
        vi.Gap(dof=1, clearance=0.01, side="negative", law=law),
    ], initial_velocity=[1.0, -1.0])
    r = vi.simulate(model, t_end=0.3, dt=1e-4, method=vi.EventDriven())
    imp = r.impacts
    w = math.sqrt(2 * k)
    t = math.asin(0.01 * w) / w
    assert imp.gap[0] == 0 and imp.gap[1] == 1
    assert imp.t_start[0] == imp.t_start[1] == pytest.approx(t, abs=1e-12)
    assert np.allclose(imp.restitution_effective[:2], 0.7)
    assert np.allclose(r.displacement[:, 0], -r.displacement[:, 1], atol=1e-12)


@pytest.mark.filterwarnings("ignore::vibroimpact.ContactResolutionWarning")
def test_refusals_are_one_line() -> None:
    with pytest.raises(vi.ModelError, match=r"^gaps\[0\]\.law\.kind: 'rigid' needs") as err:
        vi.simulate(_model(contact.Rigid(restitution=0.5)), t_end=0.1, dt=1e-3,
                    method=vi.Newmark())
    assert "\n" not in str(err.value)
    with pytest.raises(vi.ModelError, match=r"^gaps\[0\]\.law\.kind: 'hertz' is a force law"):
        vi.simulate(_model(contact.Hertz(stiffness=1e9)), t_end=0.1, dt=1e-3,
                    method=vi.MoreauJean())
    with pytest.raises(vi.ModelError, match=r"^law\.restitution: "):
        contact.Rigid(restitution=1.5)
    with pytest.raises(vi.ModelError, match=r"^solver\.theta: "):
        vi.MoreauJean(theta=0.2)


def test_model_file_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bounce.toml"
    path.write_text("""schema_version = 1
[structure]
kind = "sdof"
mass = 1.0
[[gaps]]
dof = 0
clearance = 0.0
side = "negative"
[gaps.law]
kind = "rigid"
restitution = 0.5
[[loads]]
kind = "constant"
dof = 0
amplitude = -9.81
[initial]
displacement = 1.0
[solver]
method = "event-driven"
dt = 1e-3
t_end = 1.0
chatter_fraction = 1e-3
""", encoding="utf-8")
    assert cli_main(["run", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    first = out["impacts"][0]
    assert first["t_start"] == pytest.approx(closed_form(0.5, 1)[0], abs=1e-10)
    assert first["force_max"] is None  # NaN: an impact has no finite force
    assert first["restitution_effective"] == pytest.approx(0.5)
