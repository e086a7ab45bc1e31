"""The tabulated law unloads from the largest penetration of each contact (issue 5): its
unloading curve is stretched to start on the loading curve there. Checked against closed
forms for piecewise-linear curves, where one impact's stored and returned energies are
areas of triangles and trapezoids."""

from __future__ import annotations

import math

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact import contact
from vibroimpact.impact import single_impact_result

# Softening piecewise-linear loading (k1 up to d1, then k2 < k1, continued) and an unloading
# shape with residual indentation R * DE: every stretched unloading line stays below it.
K1, K2, D1, DE, R = 4.0e7, 1.5e7, 1.0e-5, 2.0e-5, 0.45
MASS = 0.05


def _law() -> contact.Tabulated:
    f_e = K1 * D1 + K2 * (DE - D1)
    return contact.Tabulated([0.0, D1, DE], [0.0, K1 * D1, f_e], [0.0, R * DE, DE],
                             [0.0, 0.0, f_e])


def _loading(d: float) -> float:
    return K1 * d if d <= D1 else K1 * D1 + K2 * (d - D1)


def _stored(d: float) -> float:
    """∫₀^d F_L."""
    if d <= D1:
        return 0.5 * K1 * d * d
    return 0.5 * K1 * D1 * D1 + (d - D1) * (K1 * D1 + 0.5 * K2 * (d - D1))


def _turning_point(speed: float) -> float:
    """δ_m where the loading curve has stored ½ m v² (a quadratic on each segment)."""
    energy = 0.5 * MASS * speed**2
    if energy <= _stored(D1):
        return math.sqrt(2.0 * energy / K1)
    rest = energy - _stored(D1)  # K1 D1 u + K2 u²/2 = rest
    f1 = K1 * D1
    return D1 + 2.0 * rest / (f1 + math.sqrt(f1 * f1 + 2.0 * K2 * rest))


def _closed_form(speed: float) -> tuple[float, float]:
    """(δ_m, restitution): the stretched unloading line from (R δ_m, 0) to (δ_m, F_L(δ_m))
    returns F_L(δ_m) δ_m (1 − R)/2 of the stored ½ m v²."""
    dm = _turning_point(speed)
    returned = 0.5 * _loading(dm) * dm * (1.0 - R)
    return dm, math.sqrt(returned / (0.5 * MASS * speed**2))


def test_lone_evaluation_and_max_penetration() -> None:
    """Alone the unloading curve starts at its last point; inside a contact, at δ_m."""
    t = _law()
    f_e = _loading(DE)
    # δ_m = δ_e: the given line from (R δ_e, 0) to (δ_e, F_L(δ_e)).
    d = 0.8 * DE
    assert t.force(d, -1.0, 0.3)[0] == pytest.approx(f_e * (0.8 - R) / (1 - R), rel=1e-12)
    # δ_m = 0.6 δ_e: the line from (0.6 R δ_e, 0) to (0.6 δ_e, F_L(0.6 δ_e)).
    dm = 0.6 * DE
    d = 0.5 * DE
    expected = _loading(dm) * (d / dm - R) / (1 - R)
    assert t.force(d, -1.0, 0.3, max_penetration=dm)[0] == pytest.approx(expected, rel=1e-12)
    f, dp, dr = t.evaluate([d, d], [-1.0, 0.5], [0.3, 0.3], max_penetration=[dm, dm])
    assert f[0] == pytest.approx(expected, rel=1e-12)
    assert dp[0] == pytest.approx(_loading(dm) / (dm * (1 - R)), rel=1e-12)
    assert dr[0] == 0.0  # below the reversal band
    assert f[1] == pytest.approx(_loading(d), rel=1e-12)  # loading: the loading curve
    # Residual indentation: no force below R δ_m while unloading.
    assert t.force(0.9 * R * dm, -1.0, 0.3, max_penetration=dm)[0] == 0.0


@pytest.mark.parametrize("speed", [0.2, 0.4, 0.6])
def test_one_impact_restitutes_the_closed_form(speed: float) -> None:
    """δ_m inside the first segment, the second, and beyond the data (loading continued):
    the core's e_eff, peak and dissipated energy equal the closed form."""
    dm, e = _closed_form(speed)
    result = single_impact_result(_law(), MASS, speed)
    imp = result.impacts
    assert imp.delta_max[0] == pytest.approx(dm, rel=1e-6)
    assert imp.restitution_effective[0] == pytest.approx(e, abs=1e-6)
    lost = 0.5 * MASS * speed**2 * (1.0 - e * e)
    assert result.energy.contact_dissipated[-1] == pytest.approx(lost, rel=1e-6)
    assert abs(result.energy.balance_error) <= 1e-6


@pytest.mark.parametrize(
    "method",
    [vi.Newmark(), vi.Bathe(), vi.PreciseIntegration(),
     vi.Newmark(adaptive=vi.Adaptive(rtol=1e-7, atol=1e-13, dt_max=2e-5))],
    ids=["newmark", "bathe", "precise", "adaptive"],
)
def test_every_impact_unloads_from_its_own_maximum(method: vi.Integrator) -> None:
    """A free mass between two walls: each impact arrives slower, turns at a smaller δ_m
    and restitutes the closed form of that δ_m (the state is reset at every contact and
    survives rejected steps)."""
    law = _law()
    model = vi.Model(
        structure=vi.Structure.sdof(mass=MASS),
        gaps=[vi.Gap(dof=0, clearance=1e-4, side="both", law=law)],
        initial_velocity=0.6,
    )
    result = vi.simulate(model, t_end=4e-3, dt=2e-7, method=method)
    imp = result.impacts
    done = [i for i in range(len(imp)) if not math.isnan(imp.t_end[i])]
    assert len(done) >= 4
    speeds = [0.6]
    for i in done:
        v_in = imp.v_in[i]
        assert v_in == pytest.approx(speeds[-1], rel=1e-3)
        dm, e = _closed_form(v_in)
        assert imp.delta_max[i] == pytest.approx(dm, rel=1e-5)
        assert imp.restitution_effective[i] == pytest.approx(e, abs=5e-5), i
        speeds.append(e * v_in)
    # The sequence crosses from beyond the data into the first segment: e changes with δ_m.
    es = np.array([imp.restitution_effective[i] for i in done])
    assert es.max() - es.min() > 0.01
    if getattr(method, "adaptive", None) is not None:
        assert result.stats.rejected_steps > 0  # the wall state survived rejected steps
