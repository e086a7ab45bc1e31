"""Independent SciPy reference solutions for vibro-impact contact problems.

This module is deliberately independent of ``vibroimpact``: it uses only numpy and scipy and
implements every contact law from its formula. Tests compare the Rust engine against it.

Conventions (SI units throughout):

* ``delta`` is the penetration (> 0 in contact), ``delta_dot`` its rate, ``v_imp`` the approach
  speed ``delta_dot`` at the instant the gap closed (located by an event, never a step value).
* The contact force pushes the body out of the wall and is never tensile: a damped law whose
  formula turns negative near separation is clamped to zero; the body then moves free of that
  wall (still with ``delta > 0``) until ``delta`` returns to zero or the formula turns positive
  again, which re-engages the same contact (same ``v_imp``).

Integration is piecewise (event-driven) with ``scipy.integrate.solve_ivp`` (DOP853, dense
output): every point where the right-hand side is non-smooth (gap closing, gap opening,
force clamp/unclamp) ends a segment, so the high-order method only ever integrates smooth
pieces, and every crossing is located by root finding on the dense output.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar
from scipy.special import beta

__all__ = [
    "LAWS",
    "ContactLaw",
    "bilateral_sdof",
    "contact_force",
    "hertz_closed_form",
    "make_law",
    "paper_stiffness",
    "single_impact",
]

LAWS: tuple[str, ...] = (
    "hertz",
    "hunt-crossley",
    "lankarani-nikravesh",
    "gonthier",
    "flores",
    "kelvin-voigt",
    "herbert-mcwhannell",
    "lee-wang",
    "zhiying-qishao",
    "hu-guo",
    "gharib-hurmuzlu",
    "ye",
    "carvalho-martins",
    "exact-restitution",
    "tabulated",
)

#: Laws ``K delta^n (1 + chi(ce) delta_dot / v_imp)`` that take only a restitution ce.
_CE_LAWS: tuple[str, ...] = (
    "lankarani-nikravesh",
    "gonthier",
    "flores",
    "herbert-mcwhannell",
    "lee-wang",
    "zhiying-qishao",
    "hu-guo",
    "gharib-hurmuzlu",
    "ye",
    "carvalho-martins",
    "exact-restitution",
)

_TABLE_KEYS: tuple[str, ...] = (
    "loading_penetration",
    "loading_force",
    "unloading_penetration",
    "unloading_force",
)


def exact_hunt_crossley_factor(ce: float) -> float:
    """The factor ``chi`` for which ``K d^n (1 + chi d_dot/v_imp)`` restitutes exactly ``ce``
    in one impact of a free mass on a rigid wall.

    Energy integral of ``m v dv/dd = -K d^n (1 + chi v/v_imp)`` from ``v_imp`` to 0 and from 0
    to ``-ce v_imp`` (``u = chi v / v_imp``): ``int u/(1+u) du`` over both phases gives
    ``chi - ln(1 + chi) = -chi ce - ln(1 - chi ce)``, whose root in ``(0, 1/ce)`` is returned.
    """
    if ce >= 1.0:
        return 0.0

    def g(chi: float) -> float:
        return chi - math.log1p(chi) + chi * ce + math.log1p(-chi * ce)

    hi = 1.0 / ce
    lo = hi * 1e-12
    while g(lo) <= 0.0:  # pragma: no cover - g > 0 near 0 for every ce < 1
        lo *= 0.5
    # g -> -inf as chi -> 1/ce; bracket from below that pole.
    top = hi * (1.0 - 1e-15)
    return float(brentq(g, lo, top, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500))


def _table_eval(x: tuple[float, ...], y: tuple[float, ...], d: Any) -> Any:
    """Piecewise-linear interpolation through ``(x, y)``, continued linearly past the end."""
    d = np.asarray(d, dtype=float)
    xa, ya = np.asarray(x), np.asarray(y)
    inside = np.interp(d, xa, ya)
    slope = (ya[-1] - ya[-2]) / (xa[-1] - xa[-2])
    return np.where(d > xa[-1], ya[-1] + slope * (d - xa[-1]), inside)

# Short names accepted as keyword aliases (paper symbols).
_ALIASES: dict[str, str] = {
    "K": "stiffness",
    "k": "stiffness",
    "n": "exponent",
    "ce": "restitution",
    "c": "damping",
    "b": "damping",
}

_SIDES: dict[str, int] = {"positive": +1, "negative": -1}


# --------------------------------------------------------------------------------------------
# Contact laws
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ContactLaw:
    """A contact-force law ``F(delta, delta_dot, v_imp)`` with its parameters.

    Power laws are written ``F = K delta^n * h`` with a bracket ``h`` that is smooth in
    ``delta_dot``; the sign of ``h`` is the sign of the unclamped force while ``delta > 0``:

    * hertz: ``h = 1``
    * hunt-crossley (restitution ce): ``h = 1 + 3(1-ce)/2 * delta_dot/v_imp``
    * hunt-crossley (coefficient b): ``h = 1 + (b/K) delta_dot`` (i.e. ``K d^n + b d^n d_dot``)
    * lankarani-nikravesh: ``h = 1 + 3(1-ce^2)/4 * delta_dot/v_imp``
    * gonthier: ``h = 1 + (1-ce^2)/ce * delta_dot/v_imp``
    * flores: ``h = 1 + 8(1-ce)/(5 ce) * delta_dot/v_imp``

    Kelvin-Voigt is linear: ``F = k delta + c delta_dot`` and its "bracket" is that same value.

    Further restitution laws (factor ``chi`` of ``delta_dot/v_imp``, from the papers):

    * herbert-mcwhannell (1977): ``6(1-ce)/((2ce-1)^2+3)``
    * lee-wang (1983): ``3(1-ce)/4``
    * zhiying-qishao (2006): ``3(1-ce^2) exp(2(1-ce))/4``
    * hu-guo (2015): ``3(1-ce)/(2ce)``
    * gharib-hurmuzlu (2012): ``1/ce - 1``
    * ye (Ye, Li & Zhu 2009): ``8(1-ce)/(5ce)``
    * carvalho-martins (2019): ``3(1-ce)(11-ce)/(2(1+9ce))``
    * exact-restitution: the exact factor (:func:`exact_hunt_crossley_factor`)

    tabulated: loading curve ``F_L`` while ``delta_dot >= 0``; while ``delta_dot <= -w`` the
    unloading curve stretched to start on ``F_L`` at the contact's largest penetration ``dm``,
    ``F_U* = min(F_L(dm) F_U(delta de/dm)/F_U(de), F_L)`` (``de``: last unloading point);
    ``F_U* + (F_L - F_U*)(3x^2 - 2x^3)`` with ``x = 1 + delta_dot/w`` in between,
    ``w = reversal_band * v_imp``; both piecewise linear, continued linearly.
    """

    name: str
    stiffness: float
    exponent: float = 1.5
    restitution: float | None = None
    damping: float | None = None
    loading: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    unloading: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    reversal_band: float = 0.01

    @cached_property
    def alpha(self) -> float:
        """Coefficient of ``delta_dot / v_imp`` in the bracket (0 if not v_imp-scaled)."""
        ce = self.restitution
        if self.name == "hunt-crossley" and ce is not None:
            return 1.5 * (1.0 - ce)
        if self.name == "lankarani-nikravesh":
            assert ce is not None
            return 0.75 * (1.0 - ce * ce)
        if self.name == "gonthier":
            assert ce is not None
            return (1.0 - ce * ce) / ce
        if self.name == "flores":
            assert ce is not None
            return 8.0 * (1.0 - ce) / (5.0 * ce)
        if ce is None:
            return 0.0
        if self.name == "herbert-mcwhannell":
            return 6.0 * (1.0 - ce) / ((2.0 * ce - 1.0) ** 2 + 3.0)
        if self.name == "lee-wang":
            return 3.0 * (1.0 - ce) / 4.0
        if self.name == "zhiying-qishao":
            return 3.0 * (1.0 - ce**2) * math.exp(2.0 * (1.0 - ce)) / 4.0
        if self.name == "hu-guo":
            return 3.0 * (1.0 - ce) / (2.0 * ce)
        if self.name == "gharib-hurmuzlu":
            return 1.0 / ce - 1.0
        if self.name == "ye":
            return 8.0 * (1.0 - ce) / (5.0 * ce)
        if self.name == "carvalho-martins":
            return 3.0 * (1.0 - ce) * (11.0 - ce) / (2.0 * (1.0 + 9.0 * ce))
        if self.name == "exact-restitution":
            return exact_hunt_crossley_factor(ce)
        return 0.0

    @property
    def can_clamp(self) -> bool:
        """True when the unclamped formula can turn negative while in contact."""
        if self.name == "tabulated":
            return False
        if self.name == "kelvin-voigt":
            return bool(self.damping)
        if self.name == "hunt-crossley" and self.restitution is None:
            return bool(self.damping)
        return self.alpha != 0.0

    def bracket(self, delta: Any, delta_dot: Any, v_imp: float) -> Any:
        """Smooth function whose sign is the sign of the unclamped force while ``delta > 0``."""
        if self.name == "kelvin-voigt":
            return self.stiffness * delta + (self.damping or 0.0) * delta_dot
        if self.name == "hunt-crossley" and self.restitution is None:
            return 1.0 + (self.damping or 0.0) / self.stiffness * delta_dot
        a = self.alpha
        if a == 0.0:
            return 1.0 + 0.0 * delta_dot
        if not v_imp > 0.0:
            raise ValueError(f"{self.name}: v_imp must be > 0 (got {v_imp!r})")
        return 1.0 + a * delta_dot / v_imp

    def force(self, delta: Any, delta_dot: Any, v_imp: float, delta_max: Any = None) -> Any:
        """Contact force (>= 0); zero for ``delta <= 0``. Accepts scalars or arrays.
        ``delta_max``: largest penetration of the contact so far (tabulated only; default
        the last unloading point)."""
        d = np.asarray(delta, dtype=float)
        dd = np.asarray(delta_dot, dtype=float)
        pen = np.maximum(d, 0.0)
        if self.name == "tabulated":
            assert self.loading is not None and self.unloading is not None
            (ux, uy), de = self.unloading, self.unloading[0][-1]
            dm = np.maximum(pen, de if delta_max is None else delta_max)
            dm = np.maximum(dm, 1e-300)
            f_load = _table_eval(*self.loading, pen)
            f_turn = _table_eval(*self.loading, dm)
            f_unload = np.minimum(f_turn * _table_eval(ux, uy, pen * de / dm) / uy[-1], f_load)
            w = self.reversal_band * v_imp
            x = np.clip(1.0 + dd / w, 0.0, 1.0)
            s = x * x * (3.0 - 2.0 * x)
            raw = np.where(dd >= 0.0, f_load, f_unload + (f_load - f_unload) * s)
            out = np.where(d > 0.0, raw, 0.0)
            return float(out) if out.ndim == 0 else out
        if self.name == "kelvin-voigt":
            raw = self.bracket(pen, dd, v_imp)
        else:
            raw = self.stiffness * pen**self.exponent * self.bracket(pen, dd, v_imp)
        out = np.where(d > 0.0, np.maximum(raw, 0.0), 0.0)
        return float(out) if out.ndim == 0 else out


def make_law(law: str, **params: Any) -> ContactLaw:
    """Build and validate a :class:`ContactLaw`.

    Keywords: ``stiffness`` (alias ``K``/``k``), ``exponent`` (``n``, default 1.5),
    ``restitution`` (``ce``), ``damping`` (``c`` for kelvin-voigt, ``b`` for hunt-crossley);
    tabulated: ``loading_penetration``, ``loading_force``, ``unloading_penetration``,
    ``unloading_force`` (sequences) and ``reversal_band`` (default 0.01).
    """
    name = law.lower().replace("_", "-")
    if name not in LAWS:
        raise ValueError(f"unknown law {law!r}; expected one of {LAWS}")
    if name == "tabulated":
        return _make_tabulated(params)
    norm: dict[str, float] = {}
    for key, value in params.items():
        full = _ALIASES.get(key, key)
        if full not in ("stiffness", "exponent", "restitution", "damping"):
            raise TypeError(f"unknown contact-law parameter {key!r}")
        if full in norm:
            raise TypeError(f"parameter {full!r} given twice")
        norm[full] = float(value)
    if "stiffness" not in norm or not norm["stiffness"] > 0.0:
        raise ValueError(f"{name}: stiffness must be given and > 0")
    ce = norm.get("restitution")
    damping = norm.get("damping")
    exponent = norm.get("exponent", 1.5)
    if name == "kelvin-voigt":
        if "exponent" in norm and exponent != 1.0:
            raise ValueError("kelvin-voigt is linear (F = k delta + c delta_dot); no exponent")
        if ce is not None:
            raise ValueError("kelvin-voigt takes damping c, not restitution")
        if damping is None or damping < 0.0:
            raise ValueError("kelvin-voigt: damping c must be given and >= 0")
        return ContactLaw(name, norm["stiffness"], 1.0, None, damping)
    if not exponent > 0.0:
        raise ValueError(f"{name}: exponent must be > 0")
    if name == "hertz":
        if ce is not None or damping is not None:
            raise ValueError("hertz takes only stiffness and exponent")
        return ContactLaw(name, norm["stiffness"], exponent)
    if name == "hunt-crossley":
        if (ce is None) == (damping is None):
            raise ValueError("hunt-crossley: give exactly one of restitution ce or damping b")
        if damping is not None and damping < 0.0:
            raise ValueError("hunt-crossley: damping b must be >= 0")
    elif damping is not None:
        raise ValueError(f"{name} takes restitution ce, not damping")
    elif ce is None:
        raise ValueError(f"{name}: restitution ce must be given")
    if ce is not None:
        lo_ok = ce >= 0.0 if name in ("hunt-crossley", "lankarani-nikravesh") else ce > 0.0
        if not (lo_ok and ce <= 1.0):
            raise ValueError(f"{name}: restitution must be in (0, 1] (got {ce})")
    return ContactLaw(name, norm["stiffness"], exponent, ce, damping)


def _make_tabulated(params: dict[str, Any]) -> ContactLaw:
    unknown = set(params) - {*_TABLE_KEYS, "reversal_band"}
    if unknown:
        raise TypeError(f"tabulated: unknown parameters {sorted(unknown)}")
    curves = []
    for which in ("loading", "unloading"):
        x = tuple(float(v) for v in params[f"{which}_penetration"])
        y = tuple(float(v) for v in params[f"{which}_force"])
        if len(x) != len(y) or len(x) < 2 or x[0] != 0.0 or y[0] != 0.0:
            raise ValueError(f"tabulated: {which} curve must start at (0, 0), >= 2 points")
        if any(b <= a for a, b in itertools.pairwise(x)):
            raise ValueError(f"tabulated: {which} penetrations must increase")
        curves.append((x, y))
    band = float(params.get("reversal_band", 0.01))
    if not 0.0 < band <= 1.0:
        raise ValueError("tabulated: reversal_band must be in (0, 1]")
    (lx, ly), _ = curves
    secant = ly[-1] / lx[-1]
    return ContactLaw("tabulated", secant, 1.0, loading=curves[0], unloading=curves[1],
                      reversal_band=band)


def contact_force(law: str, delta: float, delta_dot: float, v_imp: float, **params: float) -> float:
    """Contact force of ``law`` at penetration ``delta``, rate ``delta_dot``, approach ``v_imp``.

    Zero when ``delta <= 0``, clamped at zero (never tensile). See :func:`make_law` for params.
    """
    return float(make_law(law, **params).force(delta, delta_dot, v_imp))


def paper_stiffness(
    e_modulus: float = 207e9, poisson: float = 0.3, r1: float = 10e-3, r2: float = 9.9e-3
) -> float:
    """Hertz stiffness ``K = 4/3 E* sqrt(R*)`` of the paper's ball-in-socket case (eq. 4).

    ``E* = E / (2 (1 - nu^2))`` (same material both sides), ``R* = R1 R2 / (R1 - R2)``.
    """
    e_star = e_modulus / (2.0 * (1.0 - poisson**2))
    r_star = r1 * r2 / (r1 - r2)
    return 4.0 / 3.0 * e_star * math.sqrt(r_star)


def hertz_closed_form(
    mass: float, velocity: float, stiffness: float, exponent: float = 1.5
) -> dict[str, float]:
    """Closed-form single Hertz impact on a rigid wall: ``delta_max``, ``force_max``, ``duration``.

    Energy: ``m v0^2/2 = K delta_max^(n+1)/(n+1)``; duration
    ``2 delta_max/v0 * int_0^1 dx/sqrt(1-x^(n+1)) = 2 delta_max/v0 * B(1/(n+1), 1/2)/(n+1)``.
    """
    p = exponent + 1.0
    delta_max = (p * mass * velocity**2 / (2.0 * stiffness)) ** (1.0 / p)
    duration = 2.0 * delta_max / velocity * beta(1.0 / p, 0.5) / p
    return {
        "delta_max": delta_max,
        "force_max": stiffness * delta_max**exponent,
        "duration": float(duration),
    }


def _penetration_scale(law: ContactLaw, mass: float, speed: float) -> float:
    """Rough size of the penetration of ``mass`` arriving at ``speed`` (for tolerances)."""
    speed = max(abs(speed), 1e-300)
    if law.name == "tabulated":  # where the loading curve has stored the kinetic energy
        assert law.loading is not None
        x, y = np.asarray(law.loading[0]), np.asarray(law.loading[1])
        work = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(x) * (y[1:] + y[:-1]))])
        energy = 0.5 * mass * speed**2
        if energy <= work[-1]:
            return float(np.interp(energy, work, x))
        slope = (y[-1] - y[-2]) / (x[-1] - x[-2])
        rest = energy - work[-1]  # y[-1] u + slope u^2 / 2 = rest
        return float(x[-1] + 2.0 * rest / (y[-1] + math.sqrt(y[-1] ** 2 + 2.0 * slope * rest)))
    if law.name == "kelvin-voigt":
        return speed * math.sqrt(mass / law.stiffness)
    p = law.exponent + 1.0
    return (p * mass * speed**2 / (2.0 * law.stiffness)) ** (1.0 / p)


# --------------------------------------------------------------------------------------------
# Piecewise event-driven single-DOF integrator
# --------------------------------------------------------------------------------------------


@dataclass
class _Segment:
    """One smooth piece of the trajectory: ``[t0, t1]`` with its dense output and RHS."""

    t0: float
    t1: float
    sol: Callable[[Any], np.ndarray]
    rhs: Callable[[float, np.ndarray], np.ndarray]
    side: int = 0  # 0 free, +1/-1 in contact with that wall
    v_imp: float = 0.0
    impact: int | None = None  # index into the impact list
    delta_max: float | None = None  # largest penetration of the contact so far (tabulated)


@dataclass
class _Run:
    """Raw result of :func:`_simulate`."""

    segments: list[_Segment] = field(default_factory=list)
    impacts: list[dict[str, Any]] = field(default_factory=list)
    extrema: list[tuple[float, float]] = field(default_factory=list)  # (t, x) where v = 0
    t_final: float = 0.0
    y_final: np.ndarray | None = None


def _event(fun: Callable[[float, np.ndarray], float], direction: float, terminal: bool) -> Callable:
    fun.direction = direction  # type: ignore[attr-defined]
    fun.terminal = terminal  # type: ignore[attr-defined]
    return fun


def _simulate(
    law: ContactLaw,
    mass: float,
    clearance: float,
    stiffness: float,
    damping: float,
    x0: float,
    v0: float,
    t_end: float,
    rtol: float,
    atol: Sequence[float],
    stop_after_separation: bool = False,
    max_segments: int = 100_000,
) -> _Run:
    """Integrate ``m x'' + c x' + k x = -F_pos + F_neg`` piecewise from ``t = 0`` to ``t_end``."""
    m, k, c, d = float(mass), float(stiffness), float(damping), float(clearance)
    if abs(x0) > d:
        raise ValueError("x0 starts inside a wall (|x0| > clearance): v_imp is undefined")
    max_step = 2.0 * math.pi * math.sqrt(m / k) / 64.0 if k > 0.0 else math.inf
    run = _Run()

    def rhs_free(t: float, y: np.ndarray) -> np.ndarray:
        return np.array([y[1], (-c * y[1] - k * y[0]) / m])

    def make_rhs_contact(
        s: int, v_imp: float, dmax: float | None
    ) -> Callable[[float, np.ndarray], np.ndarray]:
        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            f = law.force(s * y[0] - d, s * y[1], v_imp, dmax)
            return np.array([y[1], (-c * y[1] - k * y[0] - s * f) / m])

        return rhs

    ev_velocity = _event(lambda t, y: y[1], 0.0, False)

    t = 0.0
    y = np.array([float(x0), float(v0)])
    # phase: 0 free, +1/-1 contact with that wall
    side, v_imp, engaged, impact_idx = 0, 0.0, True, None
    # The tabulated law unloads from the largest penetration: its contact segments end where
    # the penetration turns (rising: at a maximum, then falling: at a minimum).
    turns = law.name == "tabulated"
    rising = True
    for s in (+1, -1):
        if s * x0 - d == 0.0 and s * v0 > 0.0:
            side, v_imp = s, s * v0
            run.impacts.append(_new_impact(s, 0.0, v_imp))
            impact_idx = 0
            break

    for _ in range(max_segments):
        if t >= t_end:
            break
        if side == 0:
            rhs = rhs_free
            events = [
                _event(lambda t, y: y[0] - d, +1.0, True),
                _event(lambda t, y: -y[0] - d, +1.0, True),
                ev_velocity,
            ]
        else:
            dmax = run.impacts[impact_idx]["delta_max"] if turns else None  # type: ignore[index]
            rhs = make_rhs_contact(side, v_imp, dmax)
            s_, vi_ = side, v_imp
            events = [
                _event(lambda t, y, s_=s_: s_ * y[0] - d, -1.0, True),
                _event(lambda t, y, s_=s_: s_ * y[1], -1.0 if rising else 1.0, True)
                if turns else ev_velocity,
            ]
            if law.can_clamp:
                events.append(
                    _event(
                        lambda t, y, s_=s_, vi_=vi_: law.bracket(s_ * y[0] - d, s_ * y[1], vi_),
                        -1.0 if engaged else +1.0,
                        True,
                    )
                )
        sol = solve_ivp(
            rhs,
            (t, t_end),
            y,
            method="DOP853",
            rtol=rtol,
            atol=np.asarray(atol, dtype=float),
            dense_output=True,
            events=events,
            max_step=max_step,
        )
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed at t={t}: {sol.message}")
        t_new = float(sol.t[-1])
        y_new = np.array(sol.y[:, -1], dtype=float)
        run.segments.append(_Segment(t, t_new, sol.sol, rhs, side, v_imp, impact_idx,
                                     dmax if side else None))
        iv = 1 if side else 2  # index of the velocity (extremum) event
        for te, ye in zip(sol.t_events[iv], sol.y_events[iv], strict=True):
            run.extrema.append((float(te), float(ye[0])))
            if side:
                imp = run.impacts[impact_idx]  # type: ignore[index]
                imp["delta_max"] = max(imp["delta_max"], side * float(ye[0]) - d)
        fired = None
        if sol.status == 1:
            for i, ev in enumerate(events):
                if ev.terminal and len(sol.t_events[i]) and sol.t_events[i][-1] == t_new:
                    fired = i
                    break
        t, y = t_new, y_new
        if fired is None:
            continue  # reached t_end
        if side == 0:
            side = +1 if fired == 0 else -1
            y[0] = side * d  # snap exactly onto the wall
            v_imp = side * y[1]
            engaged = True
            run.impacts.append(_new_impact(side, t, v_imp))
            impact_idx = len(run.impacts) - 1
            rising = True
        elif fired == 0:  # separation
            y[0] = side * d
            imp = run.impacts[impact_idx]  # type: ignore[index]
            imp["t_end"] = t
            imp["v_out"] = float(-side * y[1])
            side, v_imp, impact_idx = 0, 0.0, None
            if stop_after_separation:
                break
        elif turns:  # the penetration turned (delta_max recorded above)
            rising = not rising
        else:  # the force formula crossed zero: clamp / re-engage, same contact
            engaged = not engaged
    else:
        raise RuntimeError(f"more than {max_segments} segments before t_end")
    run.t_final, run.y_final = t, y
    for imp in run.impacts:
        if imp["t_end"] is None:  # still in contact at the end: penetration at t_end counts
            imp["delta_max"] = max(imp["delta_max"], imp["_side"] * float(y[0]) - d)
    _locate_force_maxima(run, law, d)
    return run


def _new_impact(side: int, t_start: float, v_in: float) -> dict[str, Any]:
    return {
        "side": "positive" if side > 0 else "negative",
        "t_start": float(t_start),
        "t_end": None,
        "v_in": float(v_in),
        "v_out": None,
        "delta_max": 0.0,
        "force_max": 0.0,
        "_side": side,
    }


def _locate_force_maxima(run: _Run, law: ContactLaw, d: float, samples: int = 257) -> None:
    """Fill ``force_max`` of each impact: dense sampling, then bounded Brent refinement."""
    for seg in run.segments:
        if not seg.side or seg.t1 <= seg.t0:
            continue
        s, vi = seg.side, seg.v_imp

        def force_at(tt: Any, seg: _Segment = seg, s: int = s, vi: float = vi) -> Any:
            yy = seg.sol(tt)
            return law.force(s * yy[0] - d, s * yy[1], vi, seg.delta_max)

        ts = np.linspace(seg.t0, seg.t1, samples)
        fs = np.asarray(force_at(ts))
        i = int(np.argmax(fs))
        best = float(fs[i])
        lo, hi = ts[max(i - 1, 0)], ts[min(i + 1, samples - 1)]
        if hi > lo:
            res = minimize_scalar(
                lambda tt, f=force_at: -float(f(tt)),
                bounds=(lo, hi),
                method="bounded",
                options={"xatol": (hi - lo) * 1e-10},
            )
            best = max(best, -float(res.fun))
        imp = run.impacts[seg.impact]  # type: ignore[index]
        imp["force_max"] = max(imp["force_max"], best)


def _evaluator(run: _Run) -> Callable[[Any], tuple[np.ndarray, np.ndarray]]:
    """Build ``evaluate(t) -> (x, v)`` from the piecewise dense output."""
    starts = np.array([seg.t0 for seg in run.segments])

    def evaluate(t_array: Any) -> tuple[np.ndarray, np.ndarray]:
        tt = np.atleast_1d(np.asarray(t_array, dtype=float))
        if tt.size and (tt.min() < 0.0 or tt.max() > run.t_final * (1 + 1e-15)):
            raise ValueError(f"t outside [0, {run.t_final}]")
        idx = np.clip(np.searchsorted(starts, tt, side="right") - 1, 0, len(starts) - 1)
        x = np.empty_like(tt)
        v = np.empty_like(tt)
        for j in np.unique(idx):
            mask = idx == j
            seg = run.segments[int(j)]
            yy = seg.sol(np.clip(tt[mask], seg.t0, seg.t1))
            x[mask], v[mask] = yy[0], yy[1]
        return x, v

    return evaluate


def _default_atol(
    law: ContactLaw, mass: float, length: float, speed: float, rtol: float
) -> list[float]:
    """Absolute tolerances ``rtol/10`` times the length and speed scales of the problem."""
    pen = _penetration_scale(law, mass, speed)
    return [
        rtol * 0.1 * max(min(pen, length) if length > 0 else pen, 1e-300),
        rtol * 0.1 * max(abs(speed), 1e-300),
    ]


# --------------------------------------------------------------------------------------------
# Public solvers
# --------------------------------------------------------------------------------------------


def single_impact(
    law: str,
    mass: float,
    velocity: float,
    rtol: float = 1e-12,
    atol: float | Sequence[float] | None = None,
    **law_params: Any,
) -> dict[str, float]:
    """One impact of a free mass on a rigid wall, touched at ``t = 0`` with speed ``velocity``.

    Solves ``m delta'' = -F(delta, delta', v_imp)`` from ``delta = 0``, ``delta' = v0 = v_imp``
    until separation (``delta`` back to 0, after free motion if the force clamped to zero).
    ``atol`` applies to ``(delta, delta')``; by default ``rtol/10`` times their scales.

    Returns ``delta_max`` (m), ``force_max`` (N), ``duration`` (s), ``v_out`` (m/s, > 0) and
    ``restitution_effective = v_out / v0``.
    """
    cl = make_law(law, **law_params)
    if not velocity > 0.0:
        raise ValueError("velocity must be > 0 (towards the wall)")
    if not mass > 0.0:
        raise ValueError("mass must be > 0")
    if atol is None:
        atol = _default_atol(cl, mass, 0.0, velocity, rtol)
    elif np.ndim(atol) == 0:
        atol = [float(atol), float(atol)]  # type: ignore[arg-type]
    pen = _penetration_scale(cl, mass, velocity)
    t_scale = pen / velocity
    t_end = 1e4 * t_scale
    for _ in range(6):
        run = _simulate(
            cl, mass, 0.0, 0.0, 0.0, 0.0, velocity, t_end, rtol, atol, stop_after_separation=True
        )
        if run.impacts[0]["t_end"] is not None:
            break
        t_end *= 100.0
    else:
        raise RuntimeError("no separation found")
    imp = run.impacts[0]
    return {
        "delta_max": float(imp["delta_max"]),
        "force_max": float(imp["force_max"]),
        "duration": float(imp["t_end"] - imp["t_start"]),
        "v_out": float(imp["v_out"]),
        "restitution_effective": float(imp["v_out"] / velocity),
    }


def bilateral_sdof(
    law: str,
    mass: float,
    clearance: float,
    velocity: float,
    t_end: float,
    x0: float = 0.0,
    stiffness: float = 0.0,
    damping: float = 0.0,
    *,
    rtol: float = 1e-12,
    atol: Sequence[float] | None = None,
    n_points: int = 2001,
    **law_params: float,
) -> dict[str, Any]:
    """Single DOF between two walls at ``x = +d`` and ``x = -d`` (paper Fig. 5 case).

    ``m x'' + c x' + k x = -F_pos + F_neg`` with ``delta_pos = x - d``, ``delta_neg = -x - d``,
    each wall with its own ``v_imp``. ``stiffness``/``damping`` are the structure's ``k``, ``c``
    (default 0); the contact-law parameters go in ``law_params`` (see :func:`make_law`).

    Returns a dict:

    * ``impacts``: list of dicts ``side`` ("positive"/"negative"), ``t_start``, ``t_end``
      (None if still in contact at ``t_end``), ``v_in`` (approach speed, > 0), ``v_out``
      (separation speed, > 0, None if still in contact), ``delta_max`` (m), ``force_max`` (N);
    * ``max_abs_displacement``: max of ``|x|`` over the run (located at ``x' = 0`` events);
    * ``t``, ``x``, ``v``, ``a``: ``n_points`` uniform samples of the dense output;
    * ``evaluate``: callable ``t_array -> (x, v)`` on the piecewise dense output.
    """
    cl = make_law(law, **law_params)
    if not mass > 0.0 or not clearance >= 0.0 or not t_end > 0.0:
        raise ValueError("need mass > 0, clearance >= 0 and t_end > 0")
    if atol is None:
        speed = max(abs(velocity), math.sqrt(stiffness / mass) * max(abs(x0), clearance), 1e-300)
        atol = _default_atol(cl, mass, max(clearance, abs(x0)), speed, rtol)
    run = _simulate(cl, mass, clearance, stiffness, damping, x0, velocity, t_end, rtol, atol)
    evaluate = _evaluator(run)
    t = np.linspace(0.0, t_end, n_points)
    x, v = evaluate(t)
    a = np.empty_like(t)
    starts = np.array([seg.t0 for seg in run.segments])
    idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
    for i, j in enumerate(idx):
        a[i] = run.segments[int(j)].rhs(float(t[i]), np.array([x[i], v[i]]))[1]
    candidates = [abs(x0), abs(float(run.y_final[0]))]  # type: ignore[index]
    candidates += [abs(xe) for _, xe in run.extrema]
    impacts = [{k: v_ for k, v_ in imp.items() if not k.startswith("_")} for imp in run.impacts]
    return {
        "impacts": impacts,
        "max_abs_displacement": float(max(candidates)),
        "t": t,
        "x": x,
        "v": v,
        "a": a,
        "evaluate": evaluate,
    }
