"""The paper's SDOF case (docs/paper-cases.md §Case 2) against an independent SciPy reference."""

from __future__ import annotations

import functools

import numpy as np
import pytest
import reference
import vibroimpact as vi
from vibroimpact.paper import cases

K = reference.paper_stiffness()


@functools.cache
def _reference(law: str, ce: float) -> dict:
    params = {} if law == "hertz" else {"restitution": ce}
    return reference.bilateral_sdof(
        law, 100.0, 0.005, 8.0, cases.SDOF_T_END, stiffness=0.0, exponent=1.5, **params,
        **{"K": K},
    )


@pytest.mark.parametrize(("law", "ce"), [("hertz", 0.9), ("lankarani-nikravesh", 0.9),
                                         ("flores", 0.5)])
def test_sdof_case_matches_reference(law: str, ce: float) -> None:
    ours = vi.simulate(cases.sdof_model(law, ce), t_end=cases.SDOF_T_END, dt=cases.SDOF_DT)
    ref = _reference(law, ce)
    assert ours.complete
    assert ours.max_abs_displacement[0] == pytest.approx(ref["max_abs_displacement"], rel=1e-4)
    ref_impacts = ref["impacts"]
    assert len(ours.impacts) == len(ref_impacts)
    for i, r in enumerate(ref_impacts[:4]):
        assert ours.impacts.side[i] == r["side"]
        assert ours.impacts.t_start[i] == pytest.approx(r["t_start"], rel=1e-4)
        assert ours.impacts.t_end[i] == pytest.approx(r["t_end"], rel=1e-4)
        assert ours.impacts.v_in[i] == pytest.approx(r["v_in"], rel=1e-4)
        assert ours.impacts.v_out[i] == pytest.approx(r["v_out"], rel=1e-4)
        assert ours.impacts.delta_max[i] == pytest.approx(r["delta_max"], rel=1e-4)
        assert ours.impacts.force_max[i] == pytest.approx(r["force_max"], rel=1e-4)
    # The time histories agree too (displacement on the reference's uniform grid).
    x_ref, _ = ref["evaluate"](ours.time)
    assert np.max(np.abs(ours.displacement[:, 0] - x_ref)) < 2e-4 * 0.005
    assert ours.energy.balance_error < 1e-4


def test_hertz_peak_displacement_is_paper_value() -> None:
    """Paper §3.1: 'the displacement reaches a maximum of about 6 mm'; with the case-1
    stiffness the Hertz peak is 5 mm + (5 m v0²/(4K))^(2/5) = 6.23 mm."""
    ours = vi.simulate(cases.sdof_model("hertz"), t_end=cases.SDOF_T_END, dt=cases.SDOF_DT)
    expected = 0.005 + (5 * 100.0 * 8.0**2 / (4 * K)) ** 0.4
    assert ours.max_abs_displacement[0] == pytest.approx(expected, rel=1e-5)
    assert 6.1e-3 < expected < 6.3e-3
    assert ours.impacts.restitution_effective[0] == pytest.approx(1.0, abs=1e-5)


def test_energy_account_with_damping_spring_and_load() -> None:
    """A damped, sprung, forced block hitting one wall: the independently accumulated energy
    terms balance, and the imbalance (the quadrature error of the contact's elastic work)
    falls at second order with dt."""
    law = vi.contact.LankaraniNikravesh(stiffness=1e9, restitution=0.7)
    model = vi.Model(
        vi.Structure.sdof(mass=2.0, stiffness=2.0e4, damping=15.0),
        gaps=[vi.Gap(dof=0, clearance=1e-3, side="positive", law=law)],
        loads=[vi.HarmonicLoad(dof=0, amplitude=80.0, frequency=12.0)],
    )
    errors = []
    for dt in (4e-6, 2e-6):
        r = vi.simulate(model, t_end=0.5, dt=dt, every=10)
        assert len(r.impacts) > 3
        e = r.energy
        assert e.damping_dissipated[-1] > 0.01 * e.external_work[-1] > 0
        assert e.contact_dissipated[-1] > 0.01 * e.external_work[-1]
        scale = max(np.max(e.total), e.total[0] + np.max(np.abs(e.external_work)))
        assert np.max(np.abs(e.balance)) / scale == pytest.approx(e.balance_error, rel=1e-9)
        errors.append(e.balance_error)
    assert errors[1] < 1e-5
    assert errors[0] / errors[1] > 3.0
