"""One impact per law, against closed forms (Hertz) and an independent SciPy reference."""

from __future__ import annotations

import math

import pytest
import reference
import vibroimpact as vi
from vibroimpact import contact
from vibroimpact.impact import single_impact

K = reference.paper_stiffness()  # ≈ 1.509e11 N/m^1.5, paper eq. 4
MASS, V0 = 0.04, 0.3  # the paper's two-sphere case


def test_hertz_impact_matches_closed_form() -> None:
    """delta_max = (5 m v0²/(4K))^(2/5); duration = 2·(2/5)·B(2/5, 1/2)·delta_max/v0."""
    out = single_impact(contact.Hertz(stiffness=K), MASS, V0)
    delta_max = (5 * MASS * V0**2 / (4 * K)) ** 0.4
    duration = 2 * 0.4 * math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9) * delta_max / V0
    assert out["delta_max"] == pytest.approx(delta_max, rel=1e-10)
    assert out["duration"] == pytest.approx(duration, rel=1e-10)
    assert out["force_max"] == pytest.approx(K * delta_max**1.5, rel=1e-10)
    assert out["restitution_effective"] == pytest.approx(1.0, abs=1e-10)


LAW_CASES = [
    ("hunt-crossley", {"restitution": 0.5}),
    ("hunt-crossley", {"damping": 2.0e11}),
    ("lankarani-nikravesh", {"restitution": 0.5}),
    ("lankarani-nikravesh", {"restitution": 0.9}),
    ("gonthier", {"restitution": 0.5}),
    ("gonthier", {"restitution": 0.2}),
    ("flores", {"restitution": 0.5}),
    ("flores", {"restitution": 0.1}),
]


@pytest.mark.parametrize(("law", "params"), LAW_CASES)
def test_dissipative_law_matches_scipy_reference(law: str, params: dict) -> None:
    """Every number of the impact within 1e-9 of the reference (the issue asks 1e-3 of the
    restitution), also at low ce, where the damped force clamps to zero before the opening
    (DOP853 locates the clamp)."""
    ours = single_impact(contact.law_from_name(law, stiffness=K, **params), MASS, V0)
    ref = reference.single_impact(law, MASS, V0, stiffness=K, exponent=1.5, **params)
    for key in ("restitution_effective", "v_out", "delta_max", "force_max", "duration"):
        assert ours[key] == pytest.approx(ref[key], rel=1e-9), key


def test_kelvin_voigt_clamps_and_matches_reference() -> None:
    """A linear spring-dashpot whose force would turn tensile before separation."""
    law = contact.KelvinVoigt(stiffness=4.0e6, damping=150.0)
    ours = single_impact(law, MASS, V0)
    ref = reference.single_impact("kelvin-voigt", MASS, V0, stiffness=4.0e6, damping=150.0)
    for key in ("restitution_effective", "v_out", "delta_max", "force_max", "duration"):
        assert ours[key] == pytest.approx(ref[key], rel=1e-9), key
    assert ours["restitution_effective"] < 0.9


def kelvin_voigt_free_peak_force(k: float, c: float, mass: float, v0: float) -> float:
    """The largest force ``k δ + c δ̇`` of the free response from ``δ = 0``, ``δ̇ = v0``
    (underdamped: ``δ = (v0/ω_d) e^{−at} sin ω_d t`` with ``a = c/(2m)``). Where
    ``dF/dt = k δ̇ + c δ̈ = v0 e^{−at} [(k − 2ac) cos ω_d t + (c(a² − ω_d²) − k a)/ω_d sin ω_d t]``
    starts negative (``k < c²/m``, i.e. ζ > 1/2) the force only falls and its peak is the
    onset ``c v0`` (overdamped too: ``F`` obeys ``m F'' + c F' + k F = 0`` as δ does, so its
    rate has at most one zero, past the clamp); else the peak is at its first zero,
    ``tan ω_d t = (k − 2ac) ω_d / (k a − c(a² − ω_d²))``."""
    a = c / (2 * mass)
    if k - 2 * a * c <= 0:
        return c * v0
    wd = math.sqrt(k / mass - a * a)
    t = math.atan2((k - 2 * a * c) * wd, k * a - c * (a * a - wd * wd)) / wd
    delta = v0 / wd * math.exp(-a * t) * math.sin(wd * t)
    rate = v0 * math.exp(-a * t) * (math.cos(wd * t) - a / wd * math.sin(wd * t))
    return k * delta + c * rate


@pytest.mark.parametrize("zeta", [1.24, 0.8, 0.55, 0.3, 0.1875])
def test_kelvin_voigt_force_peak_is_the_closed_form(zeta: float) -> None:
    """force_max of a Kelvin–Voigt impact: for ζ > 1/2 the force jumps to ``c v0`` at the touch
    and only falls, so the peak is that onset value (ζ = 1.24 is the paper's spheres' at
    ce = 0.1, where the fixed-step Newmark of old had 12 % too much and DOP853 missed it); for
    ζ < 1/2 the closed-form peak where dF/dt = 0. To 1e-8."""
    k = 4.0e6
    c = 2 * zeta * math.sqrt(k * MASS)
    out = single_impact(contact.KelvinVoigt(stiffness=k, damping=c), MASS, V0)
    expected = kelvin_voigt_free_peak_force(k, c, MASS, V0)
    assert (expected == c * V0) == (zeta > 0.5)
    assert out["force_max"] == pytest.approx(expected, rel=1e-8)


def test_paper_two_spheres_separation_speeds() -> None:
    """Paper §2.2: 0.3 m/s for Hertz, about 0.2 for HC and LN, about 0.15 for Gonthier and
    Flores (ce = 0.5)."""
    from vibroimpact.paper import cases

    v = {law: cases.two_spheres(law)["v_out"] for law in cases.PAPER_LAWS}
    assert v["hertz"] == pytest.approx(0.3, rel=1e-6)
    assert v["hunt-crossley"] == pytest.approx(0.2, abs=0.02)
    assert v["lankarani-nikravesh"] == pytest.approx(0.2, abs=0.02)
    assert v["gonthier"] == pytest.approx(0.15, abs=0.01)
    assert v["flores"] == pytest.approx(0.15, abs=0.01)


def test_gonthier_factor_over_ce_is_the_one_that_meets_the_papers_fig_4() -> None:
    """The paper prints Gonthier's factor as (1 − ce²)/ce² (eq. 9, Table 2); its Fig. 4 has the
    two spheres leave at 0.15 m/s (ce = 0.5), which (1 − ce²)/ce, ours, meets and the printed
    factor misses (the numbers docs/contact-laws.md states)."""
    from vibroimpact.paper import cases

    ce = 0.5
    printed = (1 - ce**2) / ce**2
    # Gonthier's law with the restitution c whose (1 − c²)/c equals the printed factor at ce
    c = (math.sqrt(printed**2 + 4) - printed) / 2
    assert (1 - c**2) / c == pytest.approx(printed, rel=1e-12)
    ours = cases.two_spheres("gonthier", ce)["v_out"]
    as_printed = cases.two_spheres("gonthier", c)["v_out"]
    assert ours == pytest.approx(0.146, abs=5e-4)
    assert as_printed == pytest.approx(0.092, abs=5e-4)


def test_geometry_stiffness_matches_paper_equation_4() -> None:
    g = contact.Geometry("ball-in-socket", radius1=0.010, radius2=0.0099,
                         youngs_modulus=207e9, poisson=0.3)
    sigma = (1 - 0.3**2) / (math.pi * 207e9)
    r = 0.010 * 0.0099 / (0.010 - 0.0099)
    assert g.stiffness() == pytest.approx(4 / (3 * math.pi * 2 * sigma) * math.sqrt(r), rel=1e-12)
    plane = contact.Geometry("sphere-plane", radius1=0.01, youngs_modulus=207e9, poisson=0.3)
    e_star = 207e9 / (2 * (1 - 0.09))
    assert plane.stiffness() == pytest.approx(4 / 3 * e_star * math.sqrt(0.01), rel=1e-12)


def test_force_is_clamped_and_matches_formula() -> None:
    law = contact.LankaraniNikravesh(stiffness=K, restitution=0.5)
    f, dpen, drate = law.force(1e-6, 0.1, 0.3)
    chi = 0.75 * (1 - 0.25)
    assert f == pytest.approx(K * 1e-6**1.5 * (1 + chi * 0.1 / 0.3), rel=1e-12)
    assert dpen == pytest.approx(1.5 * K * 1e-6**0.5 * (1 + chi * 0.1 / 0.3), rel=1e-12)
    assert drate == pytest.approx(K * 1e-6**1.5 * chi / 0.3, rel=1e-12)
    assert law.force(1e-6, -10.0, 0.3) == (0.0, 0.0, 0.0)
    assert law.force(-1e-6, 0.1, 0.3) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize(
    ("cls", "kwargs", "field"),
    [
        (contact.Hertz, {"stiffness": -1.0}, "law.stiffness"),
        (contact.Hertz, {"stiffness": 1e9, "exponent": 0.5}, "law.exponent"),
        (contact.LankaraniNikravesh, {"stiffness": 1e9, "restitution": 0.0}, "law.restitution"),
        (contact.Flores, {"stiffness": 1e9, "restitution": 1.5}, "law.restitution"),
        (contact.Gonthier, {"stiffness": 1e9}, "law.restitution"),
        (contact.HuntCrossley, {"stiffness": 1e9}, "law"),
        (contact.KelvinVoigt, {"stiffness": 1e9, "damping": -1.0}, "law.damping"),
    ],
)
def test_bad_law_parameters_are_refused(cls: type, kwargs: dict, field: str) -> None:
    with pytest.raises(vi.ModelError, match=field.replace(".", r"\.")) as err:
        cls(**kwargs)
    assert "\n" not in str(err.value)
