"""One central impact of a body on a rigid wall: the quantities users compare contact laws by
(``vibroimpact impact``; the paper's Figs. 3–4)."""

from __future__ import annotations

import math
from typing import Any

from vibroimpact.contact import ContactLaw
from vibroimpact.errors import ModelError, SolverError, require
from vibroimpact.integrators import Adaptive, Dop853
from vibroimpact.model import Gap, Model, Structure
from vibroimpact.result import Result
from vibroimpact.simulate import simulate

__all__ = ["hertz_estimate", "single_impact"]

#: Relative tolerance of the impact's DOP853 integration. The closed-form Hertz checks need
#: 1e-5; at 1e-12 every law's numbers are within about 1e-11 of the SciPy reference (the
#: tabulated law's within about 1e-8: its force has a kink at every table point, where the
#: error control falls back to short steps; 1e-10 would leave 3e-8 in its restitution).
RTOL = 1e-12

#: Its absolute tolerance on the displacement, as a fraction of the estimated peak indentation.
ATOL_OF_PEAK = 1e-12

#: Steps per estimated contact duration at least (``dt_max``), so that the run's rows draw
#: the force–indentation loop smoothly (:mod:`vibroimpact.plotting.laws`): about 300 steps
#: per impact, where the smooth laws would need some 60.
STEPS_PER_CONTACT = 200


def hertz_estimate(stiffness: float, exponent: float, mass: float, velocity: float) -> dict:
    """Undamped estimate: ``delta_max = ((n+1) m v²/(2K))^(1/(n+1))`` and a contact duration
    of about ``3.2 delta_max / v`` (2.943 for n = 1.5, π for n = 1). Raises a
    :class:`~vibroimpact.ModelError` naming ``velocity`` if either is not a finite number
    > 0 (speed, mass and stiffness whose impact has no time scale in doubles)."""
    # m v v, not m v²: a product of finite doubles overflows to inf, a power raises
    energy = (exponent + 1) * mass * velocity * velocity / (2 * stiffness)
    delta_max = energy ** (1 / (exponent + 1))
    duration = 3.2 * delta_max / velocity
    # the acceleration scale the integrator meets (v/duration: an overflow fails the run)
    deceleration = velocity / duration if duration > 0 else math.inf
    if not (0 < delta_max < math.inf and 0 < duration < math.inf
            and deceleration < math.inf):
        raise ModelError(
            f"velocity = {velocity:g}: the impact's peak penetration {delta_max:g} m, "
            f"duration {duration:g} s and deceleration {deceleration:g} m/s^2 (mass {mass:g} "
            f"kg, law stiffness {stiffness:g}) are not finite numbers > 0; expected a speed, "
            "mass and stiffness whose impact has finite length, time and acceleration scales")
    return {"delta_max": delta_max, "duration": duration}


def _impact_model(law: ContactLaw, mass: float, velocity: float) -> Model:
    return Model(
        structure=Structure.sdof(mass=mass),
        gaps=[Gap(dof=0, clearance=0.0, side="positive", law=law)],
        initial_velocity=velocity,
    )


def single_impact_result(law: ContactLaw, mass: float, velocity: float) -> Result:
    """The full run of one impact: the body touches the wall at ``t = 0`` moving at
    ``velocity`` (m/s, > 0) and is followed until it separates. Integrated by DOP853 at
    :data:`RTOL` (it takes every force law, the tabulated one included, so no law falls back
    to another method): eighth order, with the closing, the opening, a force clamped to zero
    and the peaks located, so that a law whose force jumps at the touch (Kelvin–Voigt) is as
    accurate as the smooth ones, where fixed Newmark steps left 2e-5 in its restitution."""
    require(
        isinstance(mass, (int, float)) and math.isfinite(mass) and mass > 0,
        "mass", mass, "a mass > 0 in kg",
    )
    require(
        isinstance(velocity, (int, float)) and math.isfinite(velocity) and velocity > 0,
        "velocity", velocity, "an approach speed > 0 in m/s",
    )
    model = _impact_model(law, float(mass), float(velocity))
    est = hertz_estimate(law.contact_stiffness, law.exponent, mass, velocity)
    dt = est["duration"] / STEPS_PER_CONTACT
    method = Dop853(adaptive=Adaptive(rtol=RTOL, atol=ATOL_OF_PEAK * est["delta_max"],
                                      dt_max=dt))
    t_end = 1.5 * est["duration"]
    for _ in range(8):
        result = simulate(model, t_end=t_end, dt=dt, method=method)
        if len(result.impacts) and not math.isnan(result.impacts.t_end[0]):
            return result
        t_end *= 3.0  # strongly damped laws separate slowly
    raise SolverError(
        f"the body had not left the wall after {t_end:.3e} s; check the law's parameters"
    )


def single_impact(law: ContactLaw, mass: float, velocity: float) -> dict[str, Any]:
    """``delta_max`` (m), ``force_max`` (N), ``duration`` (s, first touch to separation),
    ``v_out`` (m/s, separation speed) and ``restitution_effective`` (``v_out / velocity``)."""
    imp = single_impact_result(law, mass, velocity).impacts
    return {
        "law": law.kind,
        "delta_max": float(imp.delta_max[0]),
        "force_max": float(imp.force_max[0]),
        "duration": float(imp.t_end[0] - imp.t_start[0]),
        "v_out": float(imp.v_out[0]),
        "restitution_effective": float(imp.restitution_effective[0]),
    }
