"""Every integrator in ``METHODS`` on a damped linear oscillator: the measured order of
convergence (slope of log error against log dt, diffrax's ``test_ode_order``) equals the
theory, and the precise method is exact to round-off for free vibration at any dt."""

from __future__ import annotations

import math

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact.integrators import FORCE_METHODS as METHODS  # rigid-gap methods: test_rigid.py

#: Instances to test per ``METHODS`` name, with (order on the forced response, exact for free
#: vibration). Precise integration: the linear structure is integrated exactly and the load by
#: the Adams quadratic (third order).
INTEGRATORS: dict[str, list[tuple[str, vi.Integrator, int, bool]]] = {
    "newmark": [("newmark", vi.Newmark(), 2, False)],
    "generalized-alpha": [
        ("generalized-alpha-0.8", vi.GeneralizedAlpha(rho_inf=0.8), 2, False),
        ("generalized-alpha-0", vi.GeneralizedAlpha(rho_inf=0.0), 2, False),
    ],
    "hht": [("hht-0.1", vi.HHT(alpha=0.1), 2, False)],
    "precise": [
        ("precise", vi.PreciseIntegration(), 3, True),
        ("precise-pc", vi.PreciseIntegration(predictor_corrector=True), 3, True),
    ],
    "bathe": [("bathe", vi.Bathe(), 2, False)],
    "dop853": [("dop853", vi.Dop853(adaptive=None), 8, False)],
}

CASES = [case for name in METHODS for case in INTEGRATORS.get(name, [])]

M, C, K = 3.0, 12.0, 4.8e4  # ω_n = 126.5 rad/s, ζ = 1.6 %
X0, V0 = 2e-3, -0.1
AMP, FREQ = 50.0, 7.0
DTS = [4e-4, 2e-4, 1e-4, 5e-5]  # ω_n dt from 0.05 to 0.006
#: Steps of the eighth-order method (fixed steps): ω_n dt from 1 to 0.25, where its error is
#: still above round-off.
DTS_BY_LABEL = {"dop853": [8e-3, 6e-3, 4e-3, 3e-3, 2e-3]}


def test_every_method_has_a_theory() -> None:
    assert set(METHODS) <= set(INTEGRATORS), "add the new method's theory order here"


def _free(t: np.ndarray) -> np.ndarray:
    wn = math.sqrt(K / M)
    zeta = C / (2 * math.sqrt(K * M))
    wd = wn * math.sqrt(1 - zeta**2)
    b = (V0 + zeta * wn * X0) / wd
    return np.exp(-zeta * wn * t) * (X0 * np.cos(wd * t) + b * np.sin(wd * t))


def _forced(t: np.ndarray) -> np.ndarray:
    """``M x'' + C x' + K x = AMP sin(2π FREQ t)`` from ``X0, V0``, in closed form."""
    w = 2 * math.pi * FREQ
    wn = math.sqrt(K / M)
    zeta = C / (2 * math.sqrt(K * M))
    wd = wn * math.sqrt(1 - zeta**2)
    amp = AMP / math.hypot(K - M * w**2, C * w)
    theta = math.atan2(C * w, K - M * w**2)
    c1 = X0 - amp * math.sin(-theta)
    c2 = (V0 - amp * w * math.cos(-theta) + zeta * wn * c1) / wd
    decay = np.exp(-zeta * wn * t)
    return decay * (c1 * np.cos(wd * t) + c2 * np.sin(wd * t)) + amp * np.sin(w * t - theta)


def _model(loads: list) -> vi.Model:
    return vi.Model(
        vi.Structure.sdof(mass=M, stiffness=K, damping=C),
        loads=loads,
        initial_displacement=X0,
        initial_velocity=V0,
    )


@pytest.mark.parametrize(("label", "method", "order", "exact"), CASES,
                         ids=[c[0] for c in CASES])
def test_free_vibration(label: str, method: vi.Integrator, order: int, exact: bool) -> None:
    model = _model([])
    errors = []
    dts = DTS_BY_LABEL.get(label, DTS)
    for dt in dts:
        r = vi.simulate(model, t_end=0.5, dt=dt, method=method)
        errors.append(np.max(np.abs(r.displacement[:, 0] - _free(r.time))))
    if exact:
        # Exact for the linear part: round-off only, at every step size, even ω dt = 0.5.
        assert max(errors) < 1e-12 * X0
        r = vi.simulate(model, t_end=0.5, dt=4e-3, method=method)
        assert np.max(np.abs(r.displacement[:, 0] - _free(r.time))) < 1e-12 * X0
    else:
        slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
        assert slope == pytest.approx(order, abs=0.1), f"{label}: errors {errors}"


@pytest.mark.parametrize(("label", "method", "order", "exact"), CASES,
                         ids=[c[0] for c in CASES])
def test_forced_response_order(label: str, method: vi.Integrator, order: int,
                               exact: bool) -> None:
    model = _model([vi.HarmonicLoad(dof=0, amplitude=AMP, frequency=FREQ)])
    errors = []
    dts = DTS_BY_LABEL.get(label, DTS)
    for dt in dts:
        r = vi.simulate(model, t_end=0.5, dt=dt, method=method)
        errors.append(np.max(np.abs(r.displacement[:, 0] - _forced(r.time))))
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert slope == pytest.approx(order, abs=0.1), f"{label}: errors {errors}"
