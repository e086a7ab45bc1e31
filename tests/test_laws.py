"""The contact-law library (issue 5): every law against the independent SciPy reference for
ce in {0.1, 0.3, 0.5, 0.7, 0.9, 0.99}; the laws built to reproduce ce within the accuracy
asserted for them; the documented e_eff table; energy conservation (Hertz) and the energy
account of every dissipative law."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import reference
from vibroimpact import contact
from vibroimpact.docs import documented_restitution_table
from vibroimpact.impact import single_impact, single_impact_result
from vibroimpact.laws_compare import (
    COMPARE_FIELDS,
    DESIGN_ACCURACY,
    DOC_MASS,
    DOC_RESTITUTIONS,
    DOC_VELOCITY,
    comparison_laws,
    render_restitution_table,
    restitution_table,
)

K = reference.paper_stiffness()  # ≈ 1.509e11 N/m^1.5, paper eq. 4
MASS, V0 = DOC_MASS, DOC_VELOCITY  # the paper's two spheres: 0.04 kg at 0.3 m/s


@pytest.fixture(scope="module")
def core_table() -> dict[str, dict[float, float]]:
    """e_eff of every law and ce, computed once by the core (also the documented table)."""
    return restitution_table(DOC_RESTITUTIONS, stiffness=K, exponent=1.5)


def _reference_params(law: contact.ContactLaw) -> dict:
    """The law's parameters for the reference, which has no series spring: the Hertz law's
    ``compliance`` is left out where it is 0 (the plain law)."""
    params = {k: v for k, v in law.to_spec().items() if k != "kind" and v is not None}
    if params.get("compliance") == 0.0:
        del params["compliance"]
    return params


@pytest.mark.parametrize("name", list(contact.FORCE_LAWS))
def test_core_impact_matches_scipy_reference(
    name: str, core_table: dict[str, dict[float, float]]
) -> None:
    """One impact by the core (DOP853) equals an independent SciPy solve_ivp integration of the
    law's formula (tests/reference.py) for every ce: every number to 1e-8 (the issue asks 1e-3
    of the restitution); the tabulated law to 3e-5, the reference's own error at rtol 1e-8
    (its value moves by 1e-5 from rtol 1e-8 to 1e-11, where it is within 2e-9 of ours; its
    kinks make rtol 1e-10 slow). The documented table holds the same restitutions."""
    rtol, tol = (1e-8, 3e-5) if name == "tabulated" else (1e-10, 1e-8)
    for ce in DOC_RESTITUTIONS:
        law = comparison_laws(ce, MASS, V0, K, 1.5, [name])[name]
        ref = reference.single_impact(name, MASS, V0, rtol=rtol, **_reference_params(law))
        ours = single_impact(law, MASS, V0)
        for key in COMPARE_FIELDS:
            assert ours[key] == pytest.approx(ref[key], rel=tol), (name, ce, key)
        assert core_table[name][ce] == ours["restitution_effective"], (name, ce)


@pytest.mark.parametrize("name", list(DESIGN_ACCURACY))
def test_laws_designed_for_ce_reproduce_it(
    name: str, core_table: dict[str, dict[float, float]]
) -> None:
    acc = DESIGN_ACCURACY[name]
    inside = [ce for ce in DOC_RESTITUTIONS if acc.ce_min <= ce <= acc.ce_max]
    assert inside, name
    for ce in inside:
        assert abs(core_table[name][ce] - ce) <= acc.tolerance, (name, ce, core_table[name][ce])


def test_documented_table_is_current(core_table: dict[str, dict[float, float]]) -> None:
    """docs/contact-laws.md holds the table the core computes (regenerate it with
    ``python -m vibroimpact.docs``)."""
    docs = Path(__file__).resolve().parents[1] / "docs" / "contact-laws.md"
    text = docs.read_text(encoding="utf-8")
    assert documented_restitution_table(text) == render_restitution_table(core_table), (
        "docs/contact-laws.md is stale; run: python -m vibroimpact.docs"
    )


def test_restitution_independent_of_stiffness_mass_and_speed() -> None:
    """For K δⁿ (1 + χ δ̇/v_imp) the restitution depends on χ alone."""
    a = restitution_table((0.5,), ["flores", "carvalho-martins"], 0.04, 0.3, stiffness=K,
                          exponent=1.5)
    b = restitution_table((0.5,), ["flores", "carvalho-martins"], 2.0, 1.7, stiffness=3.0e7,
                          exponent=1.0)
    for name in a:
        assert a[name][0.5] == pytest.approx(b[name][0.5], abs=1e-9)


@pytest.mark.parametrize("ce", [0.05, 0.3, 0.5, 0.8, 0.95, 0.999])
def test_exact_restitution_restitutes_ce(ce: float) -> None:
    """One impact of ``exact-restitution`` restitutes ce: in the independent SciPy integration
    of its force (with the reference's own root of χ − ln(1+χ) = −χ ce − ln(1 − χ ce)) to 1e-8
    and in the core to 1e-9, on the paper's spheres and on a soft linear contact (K, n, m and
    v_imp drop out of the relation)."""
    chi = reference.exact_hunt_crossley_factor(ce)
    assert chi - math.log1p(chi) == pytest.approx(-chi * ce - math.log1p(-chi * ce), rel=1e-8)
    for k, n, mass, v0 in ((K, 1.5, MASS, V0), (3.0e7, 1.0, 2.0, 1.7)):
        law = contact.ExactRestitution(stiffness=k, exponent=n, restitution=ce)
        ours = single_impact(law, mass, v0)
        ref = reference.single_impact("exact-restitution", mass, v0, rtol=1e-10, stiffness=k,
                                      exponent=n, restitution=ce)
        assert ref["restitution_effective"] == pytest.approx(ce, abs=1e-8), (k, n)
        assert ours["restitution_effective"] == pytest.approx(ce, abs=1e-9), (k, n)
        assert ours["v_out"] == pytest.approx(ref["v_out"], abs=1e-9 * v0), (k, n)


def test_hertz_conserves_energy() -> None:
    result = single_impact_result(contact.Hertz(stiffness=K), MASS, V0)
    kinetic = 0.5 * MASS * V0**2
    assert result.impacts.restitution_effective[0] == pytest.approx(1.0, abs=1e-10)
    assert abs(result.energy.contact_dissipated[-1]) <= 1e-10 * kinetic
    assert result.energy.kinetic[-1] == pytest.approx(kinetic, rel=1e-10)
    assert abs(result.energy.balance_error) <= 1e-10


@pytest.mark.parametrize("name", [n for n in contact.FORCE_LAWS if n != "hertz"])
def test_dissipated_energy_is_the_work_of_the_force(name: str) -> None:
    """The energy account's contact dissipation equals the kinetic energy the impact took,
    ½ m (v_in² − v_out²), and the account balances: to 1e-9 of the impact's energy (3e-8 for
    the tabulated law, whose force has a kink at every table point)."""
    law = comparison_laws(0.5, MASS, V0, K, 1.5, [name])[name]
    result = single_impact_result(law, MASS, V0)
    v_in, v_out = result.impacts.v_in[0], result.impacts.v_out[0]
    lost = 0.5 * MASS * (v_in**2 - v_out**2)
    kinetic = 0.5 * MASS * V0**2
    assert lost > 0.1 * kinetic, name
    tol = 3e-8 if name == "tabulated" else 1e-9
    assert result.energy.contact_dissipated[-1] == pytest.approx(lost, abs=tol * kinetic)
    assert abs(result.energy.balance_error) <= tol, name
