"""Time integrators (paper §2.3; docs/integrators.md). Each is a small settings object passed to
:func:`vibroimpact.simulate`; the stepping itself runs in the Rust core.

Which methods there are, their parameters, defaults and checks come from the core's catalog
(``_core.method_catalog()``, :data:`CATALOG`): an integrator's name is the method's name there
(and the model file's ``solver.method``), its fields' defaults are the catalog's, and building
one checks it in the core (``_core.method_spec``), which keeps the checked, typed method that
every run of the integrator hands to the core."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

from vibroimpact import _core
from vibroimpact.errors import require

__all__ = [
    "CATALOG",
    "HHT",
    "METHODS",
    "Adaptive",
    "Bathe",
    "Dop853",
    "EventDriven",
    "GeneralizedAlpha",
    "Integrator",
    "MoreauJean",
    "Newmark",
    "NewtonOptions",
    "PreciseIntegration",
    "catalog_default",
    "method_from_options",
]

#: The core's catalog of methods: ``methods`` (each with its ``name``, ``class_name``,
#: ``parameters``, ``newton``, ``impulsive``, ``adaptive`` and ``adaptive_defaults``), and the
#: settings of ``newton`` and ``adaptive``; each setting with its ``kind``, ``default``,
#: ``unit``, ``doc`` and ``expected`` (what a valid value is).
CATALOG: dict[str, Any] = _core.method_catalog()
_ENTRIES: dict[str, dict[str, Any]] = {m["name"]: m for m in CATALOG["methods"]}


def _settings(group: str) -> list[dict[str, Any]]:
    return CATALOG[group] if group in ("newton", "adaptive") else _ENTRIES[group]["parameters"]


def catalog_default(group: str, name: str) -> Any:
    """The core's default of setting ``name`` of ``group``: a method's name, ``"newton"`` or
    ``"adaptive"`` (``None``: computed from the run)."""
    return next(s["default"] for s in _settings(group) if s["name"] == name)


#: Python type of a setting's kind.
_PLAIN = {"number": float, "integer": int, "flag": bool}


@dataclass(frozen=True)
class NewtonOptions:
    """Newton–Raphson on the gap forces (paper eqs. 22–27).

    ``rtol``: relative tolerance on the increment and the residual of the gap coordinates
    (eq. 27's ``e``, as a fraction); ``atol``: absolute tolerance in m; ``max_iterations`` per
    step; ``max_step_cuts``: how often a failing step may be halved before the run fails.
    """

    rtol: float = catalog_default("newton", "rtol")
    atol: float = catalog_default("newton", "atol")
    max_iterations: int = catalog_default("newton", "max_iterations")
    max_step_cuts: int = catalog_default("newton", "max_step_cuts")

    def __post_init__(self) -> None:
        _core.check_settings("newton", self)

    def to_spec(self) -> dict[str, Any]:
        """The options as plain data (sweep definitions)."""
        return {s["name"]: _PLAIN[s["kind"]](getattr(self, s["name"])) for s in CATALOG["newton"]}


#: The default Newton options, checked once and shared by every integrator given none (they
#: are immutable).
_DEFAULT_NEWTON = NewtonOptions()


@dataclass(frozen=True)
class Adaptive:
    """Adaptive stepping (Newmark family). Free flight: one Newmark step at a time, its local
    error estimated by Zienkiewicz–Xie ``(β − 1/6) h² |a₁ − a₀|`` (displacement) and
    ``h³ |a''| / 12`` (velocity, ``a''`` from the last two steps), kept below
    ``atol + rtol·|x|`` (m) per DOF. While a wall is closed, average acceleration (γ = 1/2,
    β = 1/4) doubles the step: each step is taken once and as two halves, ``(fine − coarse)/3``
    is the error (displacement against ``atol + rtol·|x|``, velocity against
    ``atol/dt_max + rtol·v_max``, ``v_max`` the DOF's largest speed so far) and the Richardson
    extrapolation ``fine + (fine − coarse)/3`` is kept — fourth order, as the rule is symmetric
    (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.4) — provided the step resolves the
    structure's stiffest mode (``ω_max h ≤ 0.2``: extrapolation amplifies an unresolved mode by
    up to 5/3 per step); otherwise, and for HHT / generalized-α, the single-step estimate.
    Every gap's closing (from the start state's Taylor polynomial, just short of the wall) and
    opening, a grazing touch, and the first peak of each contact are located inside the step
    and landed on, so that no contact is stepped over and ``v_imp``, ``t_start``, ``t_end``,
    ``v_out`` and the peak come from step ends. Step sizes are ``dt_max / 2^(k/4)`` (operators
    cached per size) between ``dt_min`` and ``dt_max`` (s; defaults ``t_end / 50`` and
    ``dt / 1e4``, with ``dt`` the first step). ``stats.steps`` counts every Newmark step solved
    (three per doubled step), ``rejected_steps`` every attempt discarded (error, an event inside
    it, Newton). On the paper's SDOF case ``rtol = 1e-5`` is as accurate as fixed ``dt = 1 µs``
    on the peak, every impact time and ``v_out`` with about 15× fewer steps, and ``rtol = 2e-7``
    reaches 2e-11 m / 6e-10 s (``tests/test_adaptive.py``, ``vibroimpact bench``)."""

    rtol: float = catalog_default("adaptive", "rtol")
    atol: float = catalog_default("adaptive", "atol")
    dt_min: float | None = None
    dt_max: float | None = None

    def __post_init__(self) -> None:
        _core.check_settings("adaptive", self)


@dataclass(frozen=True)
class Integrator:
    """Base of the integrators: the Newton options, and adaptive stepping where the method
    supports it (``supports_adaptive``)."""

    name: str = field(default="", init=False)
    # what the catalog says of the method (set below, from :data:`CATALOG`):
    #: Whether it steps adaptively (with ``adaptive``).
    supports_adaptive: ClassVar[bool] = False
    #: Adaptive stepping unless the model file says ``adaptive = false``, with these
    #: tolerances where it gives none (the explicit method).
    adaptive_defaults: ClassVar[dict[str, float] | None] = None
    #: True for the methods of rigid gaps (``contact.Rigid``), which take no force law.
    impulsive: ClassVar[bool] = False
    #: False for the methods without Newton iterations (no ``newton_*`` options).
    uses_newton: ClassVar[bool] = True
    newton: NewtonOptions = _DEFAULT_NEWTON
    adaptive: Adaptive | None = None

    def __post_init__(self) -> None:
        require(isinstance(self.newton, NewtonOptions), "solver.newton", self.newton,
                "a vibroimpact.NewtonOptions")
        require(
            self.adaptive is None or isinstance(self.adaptive, Adaptive),
            "solver.adaptive", self.adaptive, "a vibroimpact.Adaptive or None",
        )
        object.__setattr__(self, "_spec", {"method": _core.method_spec(self)})

    def to_spec(self) -> dict[str, Any]:
        """The method as plain data: its name (``kind``) and parameters (results files and
        sweep definitions)."""
        return {"kind": self.name, **{p["name"]: _PLAIN[p["kind"]](getattr(self, p["name"]))
                                      for p in _settings(self.name)}}

    def _run_spec(self) -> dict[str, Any]:
        """``method`` of a run's spec: the core's checked, typed method (``_core.MethodSpec``),
        built with the integrator (it is immutable) and rebuilt after unpickling."""
        spec = self.__dict__.get("_spec")
        if spec is None:
            spec = {"method": _core.method_spec(self)}
            object.__setattr__(self, "_spec", spec)
        return spec

    def __getstate__(self) -> dict[str, Any]:
        """Pickled and copied without the core's method spec (:meth:`_run_spec`)."""
        return {k: v for k, v in self.__dict__.items() if k != "_spec"}


@dataclass(frozen=True)
class Newmark(Integrator):
    """Newmark-β with Newton–Raphson (paper eqs. 14–27). ``gamma = 1/2, beta = 1/4`` (the
    default) is the average-acceleration rule: unconditionally stable, second order, no
    numerical damping. ``gamma >= 1/2`` is required (paper eq. 16; below it every mode is
    amplified at any step) and ``beta > 0`` (the method is implicit here).

    **Stability on the linear structure** (Hughes, *The Finite Element Method*, 2000, §9.1,
    the undamped case): unconditional for ``beta >= gamma/2``; for ``beta < gamma/2`` only
    while ``ω·dt <= Ω_crit = 1/√(gamma/2 − beta)`` for every natural frequency ω
    (:attr:`critical_omega_dt`; 2 for the central-difference rule ``gamma = 1/2, beta → 0``,
    2.58 at ``beta = 0.1``); damping never lowers it (it raises it for ``gamma > 1/2``).
    A fixed-step run beyond it for the structure's highest frequency is warned about before
    it starts (:class:`~vibroimpact.StepStabilityWarning`, one line from ``vibroimpact run``);
    the bound is the linear structure's (gaps open): a closed contact adds stiffness and
    lowers it. Checked against the spectral radius of the step's amplification matrix and
    runs on either side of it (``tests/test_newmark_stability.py``).
    ``beta >= (1/2 + gamma)²/4`` in addition (paper eq. 16) keeps the eigenvalues of the step
    complex at every ω·dt, so that ``gamma > 1/2`` damps the high frequencies most."""

    name: str = field(default="newmark", init=False)
    gamma: float = catalog_default("newmark", "gamma")
    beta: float = catalog_default("newmark", "beta")

    @property
    def critical_omega_dt(self) -> float:
        """The largest ``ω·dt`` at which the undamped linear oscillator stays bounded:
        ``1/√(gamma/2 − beta)``, ``inf`` when ``beta >= gamma/2`` (unconditionally stable)."""
        margin = self.gamma / 2 - self.beta
        return math.inf if margin <= 0 else 1.0 / math.sqrt(margin)


@dataclass(frozen=True)
class GeneralizedAlpha(Integrator):
    """Generalized-α (Chung & Hulbert 1993, J. Appl. Mech. 60:371; paper eqs. 28–31) with
    Newton on the gap forces, parameterised by the spectral radius at infinity
    ``rho_inf`` ∈ [0, 1]: ``α_m = (2ρ∞ − 1)/(ρ∞ + 1)``, ``α_f = ρ∞/(ρ∞ + 1)``,
    ``γ = 1/2 − α_m + α_f``, ``β = (1 − α_m + α_f)²/4``. Second order; ``rho_inf = 1`` is the
    average-acceleration rule, smaller values damp the high frequencies (the contact's). On a
    DOF without a spring the free-flight acceleration decays geometrically
    (``a₁ = −α_m/(1−α_m) a₀``); below 1e-280 it is set to 0 rather than carried through the
    slow subnormal numbers (``benchmarks/per-step.md``)."""

    name: str = field(default="generalized-alpha", init=False)
    rho_inf: float = catalog_default("generalized-alpha", "rho_inf")

    def parameters(self) -> dict[str, float]:
        """``alpha_m``, ``alpha_f``, ``gamma``, ``beta`` of the α-form (the core's)."""
        return self._run_spec()["method"].newmark_parameters()


@dataclass(frozen=True)
class HHT(Integrator):
    """HHT-α (Hilber, Hughes & Taylor 1977, Earthq. Eng. Struct. Dyn. 5:283): generalized-α with
    ``α_m = 0``, ``α_f = alpha`` ∈ [0, 1/3], ``γ = 1/2 + alpha``, ``β = (1 + alpha)²/4``.
    (HHT's own α is ``−alpha``.) Spectral radius at infinity ``(1 − alpha)/(1 + alpha)``."""

    name: str = field(default="hht", init=False)
    alpha: float = catalog_default("hht", "alpha")

    def parameters(self) -> dict[str, float]:
        """``alpha_m``, ``alpha_f``, ``gamma``, ``beta`` of the α-form (the core's)."""
        return self._run_spec()["method"].newmark_parameters()


@dataclass(frozen=True)
class PreciseIntegration(Integrator):
    """Precise integration (Zhong & Williams 1994) with the Adams multi-step treatment of the
    contact forces and loads (paper eqs. 32–43): the linear structure is integrated exactly
    through ``Φ = exp(H dt)`` (2^N algorithm) and the Duhamel matrices, computed once per step
    size; the nonlinear term is a quadratic through the last three steps (explicit, third
    order; stable for ``ω_c dt ≲ 0.97`` with ``ω_c`` the contact frequency).

    ``predictor_corrector = True`` corrects each Adams step by treating the contact force
    implicitly (its average over the step, Newton on the gap coordinates): unconditionally
    stable on a stiff contact, second order in the contact force, still exact for the
    linear structure. See docs/integrators.md."""

    name: str = field(default="precise", init=False)
    predictor_corrector: bool = catalog_default("precise", "predictor_corrector")


@dataclass(frozen=True)
class Bathe(Integrator):
    """Bathe's composite scheme (Bathe & Baig 2005, Comput. Struct. 83:2513; Bathe 2007):
    a trapezoidal-rule sub-step to ``t + gamma·dt``, then the three-point Euler backward
    formula to ``t + dt``, each with Newton on the gap forces. Second order, unconditionally
    stable, and it damps the unresolved high frequencies (spectral radius → 0 for
    ``gamma = 1/2``) while keeping the resolved ones. ``gamma`` ∈ (0, 1); ``2 − √2`` gives
    both sub-steps the same effective stiffness. About twice the work of Newmark per step."""

    name: str = field(default="bathe", init=False)
    gamma: float = catalog_default("bathe", "gamma")


@dataclass(frozen=True)
class Dop853(Integrator):
    """Explicit Runge–Kutta DOP853 (Dormand & Prince; Hairer, Nørsett & Wanner, *Solving
    ODEs I*, 1993, §II.10: order 8, error estimators of orders 5 and 3) with located contact
    events, for small models. The contact set is fixed inside each step; every wall's closing
    and opening is located on the step's quintic Hermite interpolant and the step retaken to
    end on it, and peaks are found inside the steps on the dense output of order 7, so
    ``v_imp``, impact times, ``v_out`` and peaks are those of the integrated motion. The
    energy account's work integrals and each wall's impulse are integrated with the same
    stages (the work integrals error-controlled too). Adaptive by
    default (``adaptive = Adaptive(rtol=1e-8, atol=1e-12)``: each DOF's displacement error
    against ``atol + rtol·|x|``, its velocity error against ``atol/dt_max + rtol·v_max``);
    ``adaptive = None`` takes fixed steps ``dt`` (still landing on events). Explicit: the
    step is bounded by the stiffest mode (``ω_max·h ≲ 5``), so stiff FE models are better
    served by the implicit methods. On the paper's SDOF case it is within 1e-11 m / 1e-9 s of
    the reference in about 135 steps solved (``vibroimpact bench``). No Newton iterations."""

    name: str = field(default="dop853", init=False)
    adaptive: Adaptive | None = field(
        default_factory=lambda: Adaptive(**_ENTRIES["dop853"]["adaptive_defaults"]))


@dataclass(frozen=True)
class EventDriven(Integrator):
    """Event-driven integration of rigid impacts (gaps with ``contact.Rigid`` only): every
    impact instant is located by root finding on the exact solution, Newton's restitution
    law is applied as a velocity jump through the generalized impulse, and between events
    the linear structure is integrated exactly (matrix exponential; constant, harmonic and
    table loads exactly, a table split at its breakpoints). ``dt`` is the step on
    which events are searched and output is recorded.

    Rules (docs/rigid-impacts.md): simultaneous impacts are resolved together by the
    generalized Newton law (one LCP on the Delassus matrix ``G M⁻¹ Gᵀ``); chattering ends
    when the flight after an impact would be shorter than ``chatter_fraction · dt``: that
    impact is made plastic and the gap is held closed (sticking) until its contact force
    would become tensile (the sticking instant is then within
    ``chatter_fraction · dt / (1 − e)`` of the accumulation point). More than
    ``max_events_per_step`` events in one step make every further impact of the step
    plastic."""

    name: str = field(default="event-driven", init=False)
    chatter_fraction: float = catalog_default("event-driven", "chatter_fraction")
    max_events_per_step: int = catalog_default("event-driven", "max_events_per_step")


@dataclass(frozen=True)
class MoreauJean(Integrator):
    """Moreau–Jean time stepping for rigid gaps (``contact.Rigid`` only; Moreau 1988,
    Jean 1999): a θ-method on the velocities, ``Â (v₊ − v) = h [F_θ − C v − K x − hθ K v] −
    Gᵀ P`` with ``Â = M + hθ C + h²θ² K``, and on the walls predicted closed at
    ``x + h v/2`` the velocity-level Newton law ``0 ≤ P ⊥ −(δ̇₊ + e δ̇) ≥ 0``: one LCP per
    step for any number of simultaneous contacts (enumeration up to 10 active walls,
    projected Gauss–Seidel beyond). ``theta`` ∈ [1/2, 1]. First order at impacts (an impact
    is known to one step; a wall may be passed by about one step's travel), no event
    location, no special rule needed for chattering or sticking; with ``theta = 1/2`` the
    energy account balances exactly."""

    name: str = field(default="moreau-jean", init=False)
    theta: float = catalog_default("moreau-jean", "theta")


#: Integrators by their name (``[solver] method``, the CLI), in the catalog's order: the
#: methods of force laws, then the impulsive ones (``impulsive = True``) of rigid gaps.
METHODS: dict[str, type[Integrator]] = {
    m["name"]: globals()[m["class_name"]] for m in CATALOG["methods"]
}
for _name, _cls in METHODS.items():
    _entry = _ENTRIES[_name]
    _cls.supports_adaptive = _entry["adaptive"] != "fixed"
    _cls.adaptive_defaults = _entry["adaptive_defaults"]
    _cls.impulsive = _entry["impulsive"]
    _cls.uses_newton = _entry["newton"]

#: The integrators of force laws (every method of :data:`METHODS` but the impulsive ones).
FORCE_METHODS: dict[str, type[Integrator]] = {
    k: c for k, c in METHODS.items() if not c.impulsive
}

#: ``[solver]`` keys of the Newton options (TOML name -> :class:`NewtonOptions` field).
NEWTON_KEYS = {
    "newton_rtol": "rtol",
    "newton_atol": "atol",
    "max_iterations": "max_iterations",
    "max_step_cuts": "max_step_cuts",
}

#: ``[solver]`` keys of adaptive stepping (with ``adaptive = true``).
ADAPTIVE_KEYS = tuple(s["name"] for s in CATALOG["adaptive"])


def method_options(name: str) -> dict[str, tuple[str, Any]]:
    """Every ``[solver]`` option of method ``name`` (besides ``method``, ``dt``, ``t_end``):
    TOML key -> (type name, default), from the core's catalog. The model-file loader and its
    reference use this."""
    entry = _ENTRIES[name]
    kind = {"number": "float", "integer": "int", "flag": "bool"}
    out = {p["name"]: (kind[p["kind"]], p["default"]) for p in entry["parameters"]}
    if entry["newton"]:
        newton = {s["name"]: s for s in CATALOG["newton"]}
        for key, attr in NEWTON_KEYS.items():
            out[key] = (kind[newton[attr]["kind"]], newton[attr]["default"])
    if entry["adaptive"] != "fixed":
        defaults = entry["adaptive_defaults"] or {}
        out["adaptive"] = ("bool", entry["adaptive"] == "by-default")
        for s in CATALOG["adaptive"]:
            out[s["name"]] = (kind[s["kind"]], defaults.get(s["name"], s["default"]))
    return out


def method_from_options(name: str, options: dict[str, Any] | None = None) -> Integrator:
    """Build an integrator from its name and its ``[solver]`` options (:func:`method_options`):
    scheme parameters, Newton options and adaptive stepping."""
    from vibroimpact.errors import ModelError

    if name not in METHODS:
        raise ModelError(
            f"solver.method: {name!r} is not valid; expected one of {', '.join(METHODS)}"
        )
    options = dict(options or {})
    known = method_options(name)
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise ModelError(
            f"solver.{unknown[0]}: not an option of method {name!r}; expected one of "
            f"{', '.join(sorted(known))}"
        )
    newton = NewtonOptions(**{a: options.pop(k) for k, a in NEWTON_KEYS.items() if k in options})
    defaults = METHODS[name].adaptive_defaults
    adaptive_on = options.pop("adaptive", defaults is not None)
    require(isinstance(adaptive_on, bool), "solver.adaptive", adaptive_on, "true or false")
    tolerances = {k: options.pop(k) for k in ADAPTIVE_KEYS if k in options}
    if tolerances and not adaptive_on:
        key = next(iter(tolerances))
        raise ModelError(
            f"solver.{key}: {tolerances[key]!r} is given but adaptive is false; expected "
            "adaptive = true with it"
        )
    adaptive = Adaptive(**{**(defaults or {}), **tolerances}) if adaptive_on else None
    return METHODS[name](newton=newton, adaptive=adaptive, **options)


#: Longer documentation of some methods, rendered after their parameters in
#: docs/integrators.md (``python -m vibroimpact.docs``).
DOC_NOTES: dict[str, str] = {
    "event-driven": """\
Rigid gaps only (`contact.Rigid`, the massless bar). The method, the rules for simultaneous
impacts and chattering, the impact table of impulsive methods and the verification against the
closed-form bouncing mass: [rigid-impacts.md](rigid-impacts.md).
""",
    "moreau-jean": """\
Rigid gaps only (`contact.Rigid`). The scheme, the LCP solver and its convergence to the
event-driven solution: [rigid-impacts.md](rigid-impacts.md).
""",
    "precise": """\
### The method (paper eqs. 32–43)

With the dual variable `p = M q' + C q/2` (eq. 33) and `y = [q; p]`, the equation of motion is
`y' = H y + f(y, t)` (eq. 34) with (eqs. 36–37)

    H = [[A1, A4], [A2, A3]],  A1 = −M⁻¹C/2,  A4 = M⁻¹,  A2 = C M⁻¹ C/4 − K,  A3 = −C M⁻¹/2
    f = [0; F(t) − Σ_g φ_g b_gᵀ]        (external loads and contact forces)

and over a step `η` (eq. 38) `y_{k+1} = Φ y_k + ∫₀^η e^{H(η−τ)} f(t_k + τ) dτ`, `Φ = exp(Hη)`:
exact for the linear structure. With `f` a polynomial `Σ_m f_m τ^m` on the step (eq. 39),
`y_{k+1} = Φ y_k + Σ_m η^{m+1} Φ_m(η) f_m` with the Duhamel matrices
`Φ_m(η) = η^{−(m+1)} ∫₀^η e^{H(η−τ)} τ^m dτ` (eqs. 40–41).

* **`Φ` by the 2^N algorithm** (Zhong & Williams 1994): `τ = η/2^N`, the increment
  `T = Hτ + (Hτ)²/2 + (Hτ)³/6 + (Hτ)⁴/24`, then N doublings `T ← 2T + T²` on the increment
  alone, and `Φ = I + T` at the end (adding `I` early would round `T` away). `N` makes
  `‖Hτ‖₁ ≤ 2⁻¹³` after an exact power-of-two balancing of `H` (a structure's `q` and `p`
  blocks differ by many orders of magnitude). Against `scipy.linalg.expm` on structural
  matrices (a damped SDOF, a 3-DOF Rayleigh-damped chain, a stiff-light part on a soft-heavy
  one, a free mass) with ω·η from 1e-3 to 10: relative difference 1e-16 to 6e-13, asserted
  below 1e-12 (`tests/test_precise.py`; in the worst case, the stiff–soft pair at ω·η = 10,
  SciPy and we are both 2–4e-13 from a 50-digit mpmath exponential).
* **Duhamel matrices**: `η^{m+1} Φ_m` for m = 0, 1, 2 from one exponential, by the same
  algorithm, of Van Loan's augmented matrix `[[Hη, B, 0, 0], [0, 0, I, 0], [0, 0, 0, I],
  [0, 0, 0, 0]]`, with `B` only the columns that forces act on (`[0; b]` of each load and
  gap): size `2n + 3k`. Checked against SciPy to 1e-12 as well.
* **Once per step size**: `Φ` and the Duhamel columns are built for `dt` before the run and
  for `dt/2^k` when a step is cut, never per step (the paper's 19× slowdown is a per-step
  exponential). They are mapped once through the exact change of variables
  `q' = M⁻¹(p − C q/2)`, so a step is one `2n × 2n` mat-vec on `[x; v]` plus three columns
  per load and per gap; the acceleration comes from the equation of motion.
* **Adams (eqs. 42–43)**, `predictor_corrector = false`: `f` on `[t_k, t_{k+1}]` is the
  quadratic through `f_{k−2}, f_{k−1}, f_k`,
  `f̃(τ) = f_k + (f_{k−2} − 4f_{k−1} + 3f_k) τ/(2η) + (f_{k−2} − 2f_{k−1} + f_k) τ²/(2η²)`:
  explicit, third order. *Self-starting*: the first step predicts with `f_0` (constant),
  evaluates the contact forces at the prediction and corrects with the line through
  `f_0, f_1`; the second predicts with the line through `f_0, f_1` and corrects with the
  quadratic through `f_0, f_1, f_2` (local errors `O(η³)`, `O(η⁴)`: the global order stays
  three). After a step cut the history points are unevenly spaced; the Lagrange weights
  follow the actual spacing, and a point spaced less than `η/2` (the step just grew 4× or
  more) is dropped rather than extrapolated from.
* **Predictor–corrector**, `predictor_corrector = true`: the Adams step predicts; the
  corrector takes the contact force as its average over the step, `(φ_k + φ_{k+1})/2`, and the
  loads (known functions of time) as the quadratic through `t_{k−1}, t_k, t_{k+1}`. The gap
  coordinates and rates at `t_{k+1}` are then affine in `φ_{k+1}`
  (`u = u_lin − W φ`, `u̇ = u̇_lin − V φ`, `W`, `V` from the Duhamel columns, per step size), and
  `φ_{k+1}` is found by Newton on the gap coordinates with `u̇ = u̇_lin − V W⁻¹ (Δu_lin − Δu)`
  — the same loop (`GapNewton`), stopping rule and step cutting as the Newmark family, the
  crossing and `v_imp` located the same way.

### Stability gain of the predictor–corrector

On a free mass against a linear contact spring of frequency `ω_c` (a contact's linearisation;
Rust test `predictor_corrector_is_stable_on_stiff_contact`):

| variant | stable for | at ω_c·η = 0.5 | at ω_c·η = 2 | order (contact force) |
|---|---|---|---|---|
| Adams (explicit) | ω_c·η ≤ 0.97 | spectral radius 0.990 | unstable (2.2) | 3 |
| predictor–corrector | every ω_c·η | 1 (no numerical damping) | 1 | 2 |

With a structure (stiffness, damping) under the contact, the corrector's spectral radius stays
≤ 1 for every ω_c·η (checked numerically on an SDOF for ω_c·η from 1e-3 to 1e5, structural
ω·η up to 100, with and without damping). On the free mass the corrector is exactly the
average-acceleration rule, so on the paper's SDOF case (k0 = c0 = 0) it reproduces Newmark
to the Newton tolerance (peaks within 2e-12). In the paper's case the contact frequency at the peak
penetration is `√(1.5 K δ^0.5 / m) ≈ 8.8e3 rad/s`: the linearised stability limit of Adams
is dt ≈ 110 µs; the predictor–corrector has none (accuracy decides). The linear structure
stays exact in both; the loads are third order in both.

### When to use

* A linear structure with many modes (FE models) whose response must not suffer the period
  error of Newmark at the chosen step, with contacts that are resolved by the step: Adams;
  it is the most accurate method here on the paper's SDOF case (table below).
* Stiff contacts relative to the step, or steps chosen for the structure rather than for the
  contact: the predictor–corrector.
* Not with adaptive stepping. `Φ` costs `O((2n + 3k)³)` once per step size: fine for
  hundreds of DOFs, not for a raw FE model of thousands (reduce it first).
""",
    "dop853": """\
### The method

Dormand & Prince's explicit Runge–Kutta pair DOP853 (Hairer, Nørsett & Wanner, *Solving
ODEs I*, 2nd ed. 1993, §II.10; coefficients as in Hairer's `dop853.f` and SciPy) on
`x' = v`, `M v' = F(t) − C v − K x − Σ φ_g b_gᵀ`: 12 stages per step, the 13th (the
acceleration at the step's end) reused as the next step's first. Error: Hairer's norm of the
fifth-order estimate damped by the third-order one, each DOF's displacement against
`atol + rtol·|x|` and its velocity against `atol/dt_max + rtol·v_max`; step factor
`0.9·err^(−1/8)` within [0.2, 6], with Gustafsson's predictive correction, no growth after a
rejection.

**Contacts.** The set of closed walls is fixed inside a step, so each step integrates a
smooth equation. After each step every wall's penetration is interpolated by the quintic
Hermite polynomial through its value, rate and acceleration at both ends; a closing or an
opening inside the step (or the first peak of a `tabulated` contact, whose law turns onto
its unloading curve there) makes the step be retaken to end there (the event is then within
1e-5 of a step of its end, and the wall switches at the next step's start — the force law
is zero on the open side, so the early switch changes nothing measurable). A step rejected
for its error that contains a closing or opening lands on it instead of shrinking blindly;
a closing that the wall's present rate and acceleration put inside the next step is landed
on at once (exact in free flight under constant forces; otherwise corrected as any landing).
A contact force that its law's formula turns tensile before the wall opens (Kelvin–Voigt,
strongly damped laws: clamped to zero there, a kink) is landed on the same way, located on
the formula along the interpolated penetration. A closed wall's force is evaluated from the
switch on (at the smallest positive penetration while the wall is still just short of it),
so that a force that does not start from zero — Kelvin–Voigt's `c·δ̇` — does not jump
inside the contact's first step; for such a force the early switch is not negligible (it
acts up to 1e-5 of a step before the wall is reached: 5.6e-7 off in the velocity of a
period at `rtol = 1e-11`), so the steps of a model with a damped Kelvin–Voigt stop land on
every closing, opening and release to round-off (Newton on the penetration or the force
formula, as when the state-transition matrix is carried). `v_imp` is the rate at the closing; the
impact table interpolates `t_start`, `t_end`, `v_out` inside the step that ends at the
event.

**A linear law through its wall.** A law linear in the penetration (`hertz` with
`exponent = 1` and no series compliance: a linear stator, a linear spring stop) keeps its
formula on both sides of the wall while the wall is closed — tensile past it — instead of the
clamp to compressive, as event-located Runge–Kutta codes integrate each mode's own vector
field (Hairer, Nørsett & Wanner §II.6; SciPy's `solve_ivp` with events): the step that crosses
the opening then integrates an analytic field, keeps its eighth-order error estimate, is
accepted at its length, and the opening is located on its interpolant as precisely as the
motion and landed on by one retake (with the clamp, the kink inside that step reads as an error
of 1e4–1e6 tolerances and the opening was only approached by rejections: 12 a contact for the
rotor rub of [rotors.md](rotors.md)); a contact switched on just short of its wall starts
smoothly (its tensile force acts that long, an error `k δ̇ τ²/2`, where a clamp's kink inside
the first step costs `h² k δ̇` through its first stages); and its first step and the steps
landed on its switches take the usual error estimate, not the third-order one. No accepted
step pulls on the motion beyond the switching window: such a wall opens at a step's start
where its penetration's quadratic prediction leaves the wall within the next step's window
(1e-5 of the step), and a graze that would be over inside the window (penetration below
`|δ̈| τ²/8`, 1e-18 m for the rotor rub) is not closed at all.

**Peaks inside the steps.** Where a wall's penetration or a DOF's displacement turns
inside a step (its rate changes sign), the turning point is located on the quintic
interpolant and valued on DOP853's dense output of order 7 (Hairer's continuous extension:
three more evaluations, spent only in such a step), whose error is the step's: the impact
table's `delta_max`, the largest force (golden-section search along the interpolant), the
run's `max_abs_displacement` and a sweep's peaks come from inside the steps, so no step
needs to end on a peak, and a free vibration's amplitude is exact to the tolerance although
a period takes about ten steps. The force at a contact's first instant (the law at
`δ = 0⁺`, as the dynamics evaluate it) is a candidate too: Kelvin–Voigt's `c·v_imp`, its
largest for `ζ > 1/2`, where its force only falls (every method's impact table has it).

**Contact ends in ζ = √δ.** A Hertzian force starts and ends like `t^1.5`, so in time the
motion has a `t^3.5` term there and no expansion in `h` holds: the steps would have to shrink
towards every closing and opening. With adaptive steps and a power-law force (every law but
`tabulated` and `kelvin-voigt`), the first step of a contact and the last ones are taken in
`ζ = √δ` of its wall instead (Hénon's change of independent variable, *Physica D* 5, 1982,
made regular at `δ = 0` by the square root): `dt/dζ = 2ζ/δ'`, the force sees `δ = ζ²`, the
motion is analytic in `ζ`, and `t` is integrated and error-controlled with the rest. One
step covers a contact's start; its end is integrated down to `ζ = 0`, which lands on the
opening exactly, each step spanning at most half the way back to the peak's `ζ` (where
`dt/dζ` is singular; nearer, the damped error estimate fell ten times short of the true
error). The end begins in `ζ` as soon as the penetration, extrapolated with its rate and
acceleration, would leave the wall within the next step. A contact whose step in `ζ` is
rejected six times (a grazing wall that turns at once) is integrated in time to its end: its
first step and every step landed on its events take the larger (third-order) error
estimate, where the damped one can fall several times below the true error. On the
paper's SDOF case this halves the steps solved (174 against 318 at rtol 1e-8). After a
contact the free motion resumes at the step proposed before the contact began (a contact is
short; the error control cuts a step that is too long). A closing predicted within the next
step at constant acceleration is refined by Newton's method on the free motion's Taylor
series (to its eighth derivative, where every wall is open, the model is small and its loads
are constant or harmonic), so that the step landed on it ends there. The next step is sized
on the last step's error measured in the next step's scales (each displacement's
`atol + rtol |x|` at the step's end and at its end extrapolated), so that an orbit passing
near a zero of a displacement does not reject a step there. With the predicted closings and
openings and the peaks found inside the steps, 135 steps are solved (118 accepted, 17
rejected) at the benchmark's `dt_max = 1 ms`; the default `dt_max = t_end/50` takes 156
(141 accepted):

```python
import vibroimpact as vi
from vibroimpact.paper import cases

model = cases.sdof_model("lankarani-nikravesh", 0.9)       # the paper's SDOF case
bench = vi.Dop853(adaptive=vi.Adaptive(rtol=1e-8, atol=1e-12, dt_max=1e-3))
for method in (bench, vi.Dop853()):
    r = vi.simulate(model, t_end=0.02, dt=1e-5, method=method)
    print(r.stats.steps, r.stats.rejected_steps)
```

```output
118 17
141 15
```

**Energy account.** The external work and the damping and contact dissipation are
integrated with the same stages (`W' = F·v`, `D' = vᵀCv`, `(F − F_el)·δ̇`) and are part of
the step's error norm (against `rtol` times the initial energy or the external work), so the
balance closes to the method's accuracy (1e-8 of the energy in at the default rtol 1e-8) even
where their integrands have kinks the motion hardly feels (a tabulated law's loading curve
while it unloads) — the trapezoidal account of the implicit methods is exact only for
average acceleration. Each wall's impulse is integrated with the stages too.

### Verification

* Order 8 on the damped oscillator, fixed steps ω_n·dt from 1 to 0.25
  (`tests/test_integrator_order.py`: measured 7.98).
* The paper's SDOF case at the default rtol 1e-8: peak within 1e-11 m, every impact's start
  and end within 1e-9 s of the SciPy reference, in under 150 steps solved
  (`tests/test_dop853.py`); an undamped oscillator's amplitude within 2e-8 (rtol 1e-8) and
  3e-10 (rtol 1e-10) at about ten steps a period, where the largest step end is 2e-3
  short; every force law but the tabulated one against the SciPy reference (peak 1e-10 m,
  impact times 2e-9 s; Kelvin–Voigt, whose force jumps at the closing and is clamped before
  the opening, within 1e-11 s and 5e-8 m/s); Hertz's closed form (peak indentation,
  contact duration, restitution 1, force peak, impulse, energy: within 3e-8 at rtol 1e-8
  and 2e-9 at rtol 1e-10, about 20 steps for the impact); a grazing contact found inside
  10 ms steps; a forced 2-DOF relative gap against an independent SciPy integration
  (33 impacts); the Rust tests `hertz_impact_of_a_free_mass_matches_energy_closed_form`
  and `dense_output_is_of_order_seven` (the dense output's error falls by 2⁸ per halved step).

### When to use

Small models (a few DOFs) where impact times, peaks and rebound speeds must be accurate to
many digits, and parameter sweeps of such models: an eighth-order method needs tens of
steps per impact where a second-order one needs thousands. On the sweep benchmark's impact
oscillator (6 frequencies, 70 periods each) DOP853 at its default tolerance takes 0.05 s
against 1.0 s for adaptive Newmark at rtol 1e-6, and its peaks are 1000× closer to the
converged values (1e-8 against 5e-5 relative). Not for FE models with stiff
high modes: as an explicit method its step is bounded by the stiffest mode (`ω_max·h ≲ 5`);
use `newmark`, `generalized-alpha` or `bathe` there. No Newton iterations
(`newton_iterations` is 0); `adaptive = false` takes fixed steps `dt` (still landing on
events).
""",
    "bathe": """\
### The method (Bathe & Baig 2005; Bathe 2007)

Each step `Δt` is two sub-steps:

1. the trapezoidal rule (average acceleration) from `t` to `t + γΔt` (Newmark with `β = 1/4`,
   `γ_N = 1/2`, on `γΔt`);
2. the three-point Euler backward formula on `t, t + γΔt, t + Δt`:
   `v₁ = c₁ x₀ + c₂ x_γ + c₃ x₁`, `a₁ = c₁ v₀ + c₂ v_γ + c₃ v₁`, with
   `c₁ = (1 − γ)/(γΔt)`, `c₂ = −1/((1 − γ)γΔt)`, `c₃ = (2 − γ)/((1 − γ)Δt)`
   (`1/Δt, −4/Δt, 3/Δt` for `γ = 1/2`), and the equation of motion at `t + Δt`.

Each sub-step factorises its effective stiffness once per step size
(`K + 4M/(γΔt)² + 2C/(γΔt)` and `K + c₃ C + c₃² M`) and solves Newton on the gap coordinates
only, with the shared loop of the Newmark family (in the backward sub-step
`u̇₁ = c₂ (u_γ − u₀) + c₃ Δu`). A gap closing in a sub-step gets its crossing and `v_imp` located
inside that sub-step. `γ = 2 − √2` makes both effective stiffnesses equal.

Properties: second order (measured 2.00 on the damped oscillator), unconditionally stable,
spectral radius → 0 as ωΔt → ∞ for `γ = 1/2` (a free vibration at ωΔt = 100 is gone after 20
steps) while the resolved frequencies keep their amplitude (1e-6 over 1000 steps at
ωΔt = 0.01). About 1.6× Newmark's work per step.

### When to use

When stiff contacts excite high-frequency modes that the step does not resolve (beam models
against hard stops, fine FE meshes) and they should be damped out strongly without the
overshoot or the first-order damping of other dissipative schemes; when generalized-α with a
small ρ∞ still leaves too much high-frequency noise in accelerations and contact forces.
""",
}

#: Verification and speed of all methods, rendered at the end of docs/integrators.md.
VERIFICATION_NOTES = """\
## Verification

**Order on a damped linear oscillator** (`tests/test_integrator_order.py`, every entry of
`METHODS`; slope of log max error against log dt, dt from 4e-4 to 5e-5 s, ωₙ = 126 rad/s,
ζ = 1.6 %):

| method | free vibration | forced (50 N at 7 Hz) |
|---|---|---|
| `newmark` | 2.000 | 2.000 |
| `generalized-alpha` ρ∞ = 0.8 / 0 | 2.000 / 1.998 | 2.000 / 1.998 |
| `hht` α = 0.1 | 2.000 | 2.000 |
| `precise` (Adams / predictor–corrector) | exact (see below) | 3.00 / 3.00 |
| `bathe` | 2.000 | 2.000 |

The precise method's free-vibration error is round-off at every step: at most 6e-16 m on a
2e-3 m amplitude for every dt above and at ωₙdt = 0.5 (asserted below 1e-12 relative; the
Rust test `precise_free_vibration_is_exact_at_any_step` up to ωₙdt = 5).

**Generalized-α's spectral radius at infinity equals ρ∞** (Rust test
`generalized_alpha_spectral_radius_at_infinity_is_rho_inf`: the amplification matrix of one
`NewmarkStepper::attempt` on an undamped SDOF from the three basis states of (x, v, a), its
eigenvalues by nalgebra). With Chung & Hulbert's parameters the three eigenvalues tend to −ρ∞
together, so the spectral radius approaches ρ∞ like (ωΔt)^(−2/3): 0.7–1e-2 above it at
ωΔt = 1e3, about 1e-4 at 1e6 and 5e-6 at 1e8, for ρ∞ = 0, 0.3, 0.5, 0.8 (1 to round-off for
ρ∞ = 1); resolved frequencies (ωΔt = 0.01) keep a spectral radius of 1 within 1e-5.

**The paper's SDOF impact case** (0.02 s, Lankarani–Nikravesh, ce = 0.9, nine impacts) against
the SciPy reference `tests/reference.py: bilateral_sdof` (event-located contact phases,
rtol 1e-12): relative error of the peak displacement / largest error of an impact's start or
end time, reached (asserted, `tests/test_integrators_sdof.py`):

| method | dt = 1 µs | dt = 0.5 µs |
|---|---|---|
| `newmark` | 1.5e-6 / 85 ns (2e-6 / 150 ns) | 2.4e-7 / 20 ns (4e-7 / 40 ns) |
| `generalized-alpha` ρ∞ = 0.8 | 1.5e-6 / 90 ns (2e-6 / 150 ns) | 2.5e-7 / 22 ns (4e-7 / 40 ns) |
| `generalized-alpha` ρ∞ = 0 | 4.7e-6 / 450 ns (6e-6 / 600 ns) | 1.1e-6 / 120 ns (1.5e-6 / 200 ns) |
| `hht` α = 0.1 | 1.6e-6 / 110 ns (2.5e-6 / 150 ns) | 2.9e-7 / 27 ns (4e-7 / 40 ns) |
| `precise` (Adams) | 7.4e-7 / 11 ns (1e-6 / 20 ns) | 6.6e-8 / 1.8 ns (1e-7 / 3 ns) |
| `precise` (predictor–corrector) | 1.5e-6 / 85 ns (2e-6 / 150 ns) | 2.4e-7 / 20 ns (4e-7 / 40 ns) |
| `bathe` | 1.1e-6 / 42 ns (1.5e-6 / 60 ns) | 1.6e-7 / 10 ns (2.5e-7 / 15 ns) |

The contact force starts like δ^1.5 at each impact, which no polynomial follows across the
closing instant: on impacts every method converges at about second order in the peak (Adams
a little faster in the impact times).

## Speed (paper Table 3)

`vibroimpact bench` times the same case (0.02 s at dt = 1 µs, 20,000 steps, every step
recorded) per method through the Python API, round-robin over the methods (median of the
repeats), with the paper's MATLAB times beside
(`vibroimpact.benchmarks.sdof.integrator_table`). On this project's 2-core CI machine
(median of 40), and as instructions executed by the core (valgrind, insensitive to the
machine's load):

| method | wall time | vs Newmark | instructions vs Newmark | paper (MATLAB) | paper ratio |
|---|---|---|---|---|---|
| Newmark-β + Newton | 3.54 ms | 1.00 | 1.00 | 1.3 s | 1.0 |
| generalized-α (ρ∞ = 0.8) | 3.58 ms | 1.01 | 1.01 | 2.1 s | 1.6 |
| HHT-α (α = 0.1) | 3.72 ms | 1.05 | | | |
| precise (Adams) | 3.25 ms | 0.92 | 0.97 | 25 s | 19 |
| precise (predictor–corrector) | 4.68 ms | 1.32 | 1.43 | | |
| Bathe (γ = 1/2) | 5.84 ms | 1.65 | 1.64 | | |

Targets: generalized-α ≤ 1.3× Newmark, precise ≤ 3× Newmark: both met. The table predates
issue 20's per-step work, which made every step cheaper (issue 20 asks precise ≤ 1.5×
Newmark). Instructions a step on the current core (callgrind, `examples/sdof_bench.rs`;
`METHOD=precise`, `METHOD=precise-pc`, `SCHEME=generalized-alpha`): Newmark 515,
generalized-α 535 (1.04×), precise Adams 512 (0.99×), predictor–corrector 1,716 (3.33×).
Where nothing watches a step, free flight runs in *free runs* (docs/architecture.md) for
the Newmark family (Newmark, generalized-α, HHT-α) and precise integration's Adams steps:
about 200 instructions a free step for Newmark and for the Adams step; a contact step is
Newmark's Newton on the gaps, or the Adams step's wall evaluation. The predictor–corrector
evaluates the walls and solves for the contact force every step. The latest wall-time
ratios are `vibroimpact bench`'s, in the README.
"""
