"""Contact-force laws ``F(δ, δ̇, v_imp)`` (paper §2.2, Table 2; docs/contact-laws.md) and
contact stiffness from geometry and material.

Each law is plain data; the force, its derivatives and the time loop live in the Rust core.
Which laws there are, their parameters and defaults come from the core's catalog
(``_core.law_catalog()``): the classes of the hysteretic laws below are generated from it, the
others are written here and checked against it.
``stiffness`` is either a number (N/mⁿ) or a :class:`Geometry` from which the stiffness is
computed (paper eq. 4 for the Hertzian point contacts).

The Hertzian laws with hysteresis damping all read ``F = K δⁿ (1 + χ δ̇ / v_imp)``, i.e. a
damping coefficient ``D = χ K / v_imp`` in ``F = K δⁿ + D δⁿ δ̇``: the damping grows as the
restitution ``ce`` falls (through ``χ(ce)``) and is inversely proportional to the approach
speed ``v_imp`` of the current impact. They differ only in ``χ(ce)``; the sources and the
effective restitution each one gives are in ``docs/contact-laws.md``.

Example::

    >>> from vibroimpact import contact
    >>> steel = dict(youngs_modulus=207e9, poisson=0.3)
    >>> g = contact.Geometry("ball-in-socket", radius1=0.010, radius2=0.0099, **steel)
    >>> law = contact.LankaraniNikravesh(stiffness=g, exponent=1.5, restitution=0.9)
    >>> round(law.contact_stiffness / 1e11, 3)
    1.509
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibroimpact import _core
from vibroimpact.errors import ModelError, require

__all__ = [
    "CATALOG",
    "FORCE_LAWS",
    "GEOMETRY_KINDS",
    "LAWS",
    "PAPER_LAWS",
    "REMOVED_LAWS",
    "RESTITUTION_LAWS",
    "ContactLaw",
    "Geometry",
    "Hertz",
    "HuntCrossley",
    "KelvinVoigt",
    "PowerLaw",
    "Rigid",
    "Tabulated",
    "catalog_default",
    "check_parameter",
    "kelvin_voigt_damping",
    "law_from_name",
    "refuse_removed_law",
]  # and the classes of the hysteretic laws, generated below (HYSTERETIC_CLASSES)

GeometryKind = Literal[
    "sphere-sphere", "ball-in-socket", "sphere-plane", "cylinder-in-hole", "flat-punch"
]

#: The shapes :class:`Geometry` knows.
GEOMETRY_KINDS: tuple[str, ...] = (
    "sphere-sphere",
    "ball-in-socket",
    "sphere-plane",
    "cylinder-in-hole",
    "flat-punch",
)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _positive(value: Any, field: str, unit: str) -> None:
    require(
        _is_number(value) and math.isfinite(value) and value > 0,
        field,
        value,
        f"a number > 0 in {unit}",
    )


#: The core's catalog of laws, by kind: family, class name, source, parameters (name, unit,
#: ``required``, ``default``, ``list``, ``doc``) and, for a generated class, its documentation.
CATALOG: dict[str, dict[str, Any]] = {entry["name"]: entry for entry in _core.law_catalog()}


def _parameter(kind: str, parameter: str) -> dict[str, Any]:
    return next(p for p in CATALOG[kind]["parameters"] if p["name"] == parameter)


def catalog_default(kind: str, parameter: str) -> Any:
    """The core's default of ``parameter`` of law ``kind`` (``None``: none, it must be given or
    is one of alternatives)."""
    return _parameter(kind, parameter)["default"]


def check_parameter(kind: str, parameter: str, value: Any, field: str | None = None) -> None:
    """Refuse ``value`` for number ``parameter`` of law ``kind`` unless the core accepts it: the
    check is the core's (``_core.law_parameter_accepts``), the message names ``field`` (default
    ``law.<parameter>``), the value and the catalog's ``expected`` text."""
    require(
        _is_number(value) and _core.law_parameter_accepts(kind, parameter, value),
        field or f"law.{parameter}",
        value,
        _parameter(kind, parameter)["expected"],
    )


@dataclass(frozen=True)
class Geometry:
    """Two elastic bodies whose contact stiffness follows from shape and material.

    ``kind`` (radii in m, Young's moduli in Pa):

    * ``"sphere-sphere"``: spheres outside each other, ``R* = R1R2/(R1+R2)``;
    * ``"ball-in-socket"``: ``R* = R1R2/|R1−R2|`` (the paper's case);
    * ``"sphere-plane"``: ``R* = R1``;

      these three are Hertzian point contacts, ``K = (4/3) E* √R*`` (paper eq. 4), for a law
      with exponent 1.5;
    * ``"cylinder-in-hole"``: a pin of radius ``radius1`` in a hole of radius ``radius2``
      over a contact ``length`` (the journal-bearing clearance joint). Johnson's relation
      ``δ = F/(π L E*) [ln(4π L E* ΔR/F) − 1]`` (``ΔR = radius2 − radius1``) is nonlinear and
      implicit in ``F``; it is linearised here by its secant at the reference force ``load``
      (N): ``K = load / δ(load)``, for a linear law (exponent 1). Valid for elastic long
      cylinders with a contact half-width small against the radii, near ``load``;
    * ``"flat-punch"``: a rigid flat circular punch of radius ``radius1`` on an elastic body,
      ``K = 2 a E*`` (linear, exponent 1).

    ``1/E* = (1−ν1²)/E1 + (1−ν2²)/E2``; body 2 has body 1's material unless
    ``youngs_modulus2``/``poisson2`` are given.
    """

    kind: GeometryKind
    radius1: float
    youngs_modulus: float
    poisson: float
    radius2: float | None = None
    youngs_modulus2: float | None = None
    poisson2: float | None = None
    length: float | None = None
    load: float | None = None

    def __post_init__(self) -> None:
        require(
            self.kind in GEOMETRY_KINDS, "geometry.kind", self.kind,
            "one of " + ", ".join(GEOMETRY_KINDS),
        )
        if self.kind in ("sphere-sphere", "ball-in-socket", "cylinder-in-hole"):
            require(self.radius2 is not None, "geometry.radius2", None, "a radius in m")
        if self.kind == "cylinder-in-hole":
            require(self.length is not None, "geometry.length", None, "a contact length in m")
            require(self.load is not None, "geometry.load", None,
                    "a reference force in N (the linearisation point)")
        # computed (and the radii and materials validated) by the core once: fields are frozen
        object.__setattr__(self, "_stiffness", self._core_stiffness())

    @property
    def exponent(self) -> float:
        """Exponent ``n`` of the law ``K δⁿ`` the stiffness is for (1.5 or 1)."""
        return 1.0 if self.kind in ("cylinder-in-hole", "flat-punch") else 1.5

    def stiffness(self) -> float:
        """Contact stiffness ``K``: N/m^1.5 for the point contacts, N/m for the others."""
        return float(self.__dict__["_stiffness"])

    def _core_stiffness(self) -> float:
        e2 = self.youngs_modulus if self.youngs_modulus2 is None else self.youngs_modulus2
        nu2 = self.poisson if self.poisson2 is None else self.poisson2
        opt = lambda v: None if v is None else float(v)  # noqa: E731
        k, _ = _core.geometry_stiffness(
            self.kind,
            float(self.radius1),
            opt(self.radius2),
            opt(self.length),
            opt(self.load),
            float(self.youngs_modulus),
            float(self.poisson),
            float(e2),
            float(nu2),
        )
        return float(k)


@dataclass(frozen=True)
class ContactLaw:
    """Base of the laws. Every law has a kebab-case ``kind``, a spec dict for the core
    (:meth:`to_spec`), and the stiffness ``contact_stiffness`` and ``exponent`` of the
    Hertz-like law that estimates its impact (used to choose step sizes)."""

    kind: ClassVar[str] = ""
    #: True for the massless bar (:class:`Rigid`): no force law; impulsive methods only.
    impulsive: ClassVar[bool] = False

    @property
    def contact_stiffness(self) -> float:  # pragma: no cover - every law overrides it
        raise NotImplementedError

    def to_spec(self) -> dict[str, Any]:  # pragma: no cover - every law overrides it
        raise NotImplementedError

    def force(
        self,
        penetration: float,
        rate: float,
        impact_speed: float,
        max_penetration: float | None = None,
    ) -> tuple[float, float, float]:
        """``(F, ∂F/∂δ, ∂F/∂δ̇)`` at penetration δ (m), rate δ̇ (m/s) and approach speed
        ``v_imp`` (m/s), evaluated by the core (zero when δ <= 0; never tensile), inside a
        contact whose largest penetration so far is ``max_penetration`` (m) if given (only
        :class:`Tabulated` depends on it)."""
        return _core.contact_force(
            self.to_spec(), float(penetration), float(rate), float(impact_speed),
            None if max_penetration is None else float(max_penetration),
        )

    def evaluate(
        self,
        penetration: ArrayLike,
        rate: ArrayLike,
        impact_speed: ArrayLike,
        clamp: bool = False,
        max_penetration: ArrayLike | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Vectorised ``(F, ∂F/∂δ, ∂F/∂δ̇)`` over broadcast arrays of δ (m, > 0), δ̇ (m/s),
        ``v_imp`` (m/s) and, if given, the contact's largest penetration (m): the law's formula
        as is (``clamp=False``, may be tensile), or clamped to be compressive as in a run."""
        arrays = [penetration, rate, impact_speed]
        if max_penetration is not None:
            arrays.append(max_penetration)
        pen, r, v, *m = np.broadcast_arrays(*(np.asarray(a, float) for a in arrays))
        flat = lambda a: np.ascontiguousarray(a.ravel())  # noqa: E731
        f, dp, dr = _core.contact_law_evaluate(
            self.to_spec(), flat(pen), flat(r), flat(v), clamp, flat(m[0]) if m else None,
        )
        return f.reshape(pen.shape), dp.reshape(pen.shape), dr.reshape(pen.shape)


def _require_given(law: ContactLaw) -> None:
    """Refuse a law whose parameters the core's catalog requires are left ``None`` (a dataclass
    field after one with a default needs a default too)."""
    for p in CATALOG[law.kind]["parameters"]:
        if p["required"] and getattr(law, p["name"]) is None:
            needed = [q["name"] for q in CATALOG[law.kind]["parameters"] if q["required"]]
            raise ModelError(f"law.{p['name']}: missing; {law.kind} needs {', '.join(needed)}")


@dataclass(frozen=True)
class PowerLaw(ContactLaw):
    """Base of the laws built on ``K δⁿ``: a stiffness (number or :class:`Geometry`) and an
    exponent."""

    stiffness: float | Geometry
    exponent: float = catalog_default("hertz", "exponent")

    def __post_init__(self) -> None:
        _require_given(self)
        if not isinstance(self.stiffness, Geometry):
            check_parameter(self.kind, "stiffness", self.stiffness)
        check_parameter(self.kind, "exponent", self.exponent)
        if isinstance(self.stiffness, Geometry) and self.exponent != self.stiffness.exponent:
            raise ModelError(
                f"law.exponent: {self.exponent!r} is not valid with geometry "
                f"{self.stiffness.kind!r}; expected {self.stiffness.exponent:g} (the exponent "
                "its stiffness is computed for)"
            )

    @property
    def contact_stiffness(self) -> float:
        """The stiffness ``K`` in N/mⁿ (computed from the geometry if one was given)."""
        if isinstance(self.stiffness, Geometry):
            return self.stiffness.stiffness()
        return float(self.stiffness)

    def to_spec(self) -> dict[str, Any]:
        """Plain dict for the core."""
        return {"kind": self.kind, "stiffness": self.contact_stiffness, "exponent": self.exponent}


@dataclass(frozen=True)
class Hertz(PowerLaw):
    """``F = K δⁿ`` (Hertz 1882; paper eq. 3). Elastic: no energy lost, no damping.

    ``compliance`` ``c`` (m/N, default 0): a linear spring in series with the law, so the gap
    penetrates ``δ = δ_l + c F`` with ``F = K δ_lⁿ`` (a flexible stop; and what a contact on
    a node with a massless part of an FE model sees, :mod:`vibroimpact.fe.condensation`)."""

    kind: ClassVar[str] = "hertz"
    compliance: float = catalog_default("hertz", "compliance")

    def __post_init__(self) -> None:
        super().__post_init__()
        check_parameter(self.kind, "compliance", self.compliance)

    def to_spec(self) -> dict[str, Any]:
        return {**super().to_spec(), "compliance": float(self.compliance)}


@dataclass(frozen=True)
class KelvinVoigt(PowerLaw):
    """Linear spring–dashpot ``F = k δ + c δ̇`` (Kelvin–Voigt; the spring–damping description,
    paper Fig. 1b), clamped to zero when it would pull. ``stiffness`` in N/m, ``damping`` in
    N·s/m. Its damping is a constant ``c``, independent of ``ce`` and ``v_imp``; the force
    jumps to ``c v_imp`` at first touch.

    Restitution of one impact of a mass ``m`` on a rigid wall, with ``ζ = c/(2√(k m))``,
    ``ω = √(k/m)``: the free response from ``δ = 0``, ``δ̇ = v_imp`` gives
    ``F/m = ω² δ + 2ζω δ̇ ∝ sin(ω_d t)(1 − 2ζ²)/√(1 − ζ²) + 2ζ cos(ω_d t)``, which turns
    tensile at ``ω_d t = 2 arccos ζ`` (before ``δ`` is back to 0, at ``π``). There the clamp
    ends the contact force and ``δ̇ = −v_imp exp(−ζω t)``; the body then leaves at that speed:
    ``e = exp(−2ζ arccos ζ/√(1 − ζ²))`` (``exp(−2)`` at ``ζ = 1``;
    ``exp(−2ζ arccosh ζ/√(ζ² − 1))`` overdamped). The textbook ``e = exp(−ζπ/√(1 − ζ²))``
    assumes the contact ends at ``δ = 0`` and would pull the body back meanwhile: with its
    ``ζ`` the clamped contact restitutes more (0.253 for ce = 0.1). :func:`kelvin_voigt_damping`
    inverts the clamped relation."""

    kind: ClassVar[str] = "kelvin-voigt"
    exponent: float = catalog_default("kelvin-voigt", "exponent")
    damping: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        check_parameter(self.kind, "damping", self.damping)

    def to_spec(self) -> dict[str, Any]:
        return {**super().to_spec(), "damping": float(self.damping)}


def _kelvin_voigt_log_restitution(zeta: float) -> float:
    """``−ln e`` of one clamped Kelvin–Voigt impact at damping ratio ``ζ`` (:class:`KelvinVoigt`):
    ``2ζ arccos ζ/√(1 − ζ²)``, continued through ``ζ = 1`` (2) to ``2ζ arccosh ζ/√(ζ² − 1)``."""
    if zeta < 1.0:
        return 2.0 * zeta * math.acos(zeta) / math.sqrt((1.0 - zeta) * (1.0 + zeta))
    if zeta > 1.0:
        return 2.0 * zeta * math.acosh(zeta) / math.sqrt((zeta - 1.0) * (zeta + 1.0))
    return 2.0


def kelvin_voigt_damping(restitution: float, stiffness: float, mass: float) -> float:
    """The dashpot ``c`` (N·s/m) with which one impact of a body of ``mass`` (kg) on a rigid
    wall through a Kelvin–Voigt contact of ``stiffness`` ``k`` (N/m) restitutes exactly
    ``restitution`` ``ce``, the force clamped non-tensile as in a run (:class:`KelvinVoigt`):
    ``c = 2ζ√(k m)`` with ``ζ`` the root of ``2ζ arccos ζ/√(1 − ζ²) = −ln ce`` (continued
    past ``ζ = 1`` for ce < e⁻² ≈ 0.135), found by Brent's method; 0 for ce = 1."""
    from scipy.optimize import brentq

    check_parameter("hunt-crossley", "restitution", restitution)
    check_parameter("kelvin-voigt", "stiffness", stiffness)
    _positive(mass, "mass", "kg")
    target = -math.log(restitution)
    if target == 0.0:
        return 0.0
    # 2ζ arccosh ζ/√(ζ² − 1) >= 2 ln ζ, so ζ = e^(target/2) is past the root.
    upper = max(1.0, math.exp(0.5 * target))
    zeta = brentq(lambda z: _kelvin_voigt_log_restitution(z) - target, 0.0, upper,
                  xtol=1e-300, rtol=4.0 * np.finfo(float).eps, maxiter=500)
    return 2.0 * float(zeta) * math.sqrt(stiffness * mass)


@dataclass(frozen=True)
class HuntCrossley(PowerLaw):
    """``F = K δⁿ + b δⁿ δ̇`` (Hunt & Crossley 1975, J. Appl. Mech. 42:440; paper eq. 5).
    Give either the damping ``b`` (N·s/m^(n+1)) or the restitution ``ce``, from which
    ``b = 3K(1 − ce)/(2 v_imp)``, i.e. ``χ = 3(1 − ce)/2`` (paper eq. 6; derived for ce near 1)."""

    kind: ClassVar[str] = "hunt-crossley"
    restitution: float | None = None
    damping: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        fault = _core.law_alternatives_fault(self.restitution is not None,
                                             self.damping is not None)
        if fault is not None:
            field, expected = fault
            require(False, f"law.{field}", getattr(self, field), expected)
        if self.restitution is not None:
            check_parameter(self.kind, "restitution", self.restitution)
        else:
            check_parameter(self.kind, "damping", self.damping)

    def to_spec(self) -> dict[str, Any]:
        return {**super().to_spec(), "restitution": self.restitution, "damping": self.damping}


@dataclass(frozen=True)
class _RestitutionLaw(PowerLaw):
    """``F = K δⁿ [1 + χ(ce) δ̇/v_imp]``: a Hertzian law whose hysteresis damping
    ``D = χ(ce) K/v_imp`` follows from the restitution ``ce`` (0 < ce <= 1) by the law's relation
    ``χ(ce)``, which the core holds. The classes are generated from the core's catalog
    (:func:`_hysteretic_class`)."""

    restitution: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        check_parameter(self.kind, "restitution", self.restitution)

    def to_spec(self) -> dict[str, Any]:
        assert self.restitution is not None
        return {**super().to_spec(), "restitution": float(self.restitution)}


#: Python types of the parameters of the generated classes (the others are numbers), written as
#: the annotations of the classes above are.
_PARAMETER_TYPES: dict[str, str] = {"stiffness": "float | Geometry"}


def _hysteretic_class(entry: dict[str, Any]) -> type[_RestitutionLaw]:
    """The class of hysteretic law ``entry`` of the core's catalog: its name, kind, docstring,
    parameters and defaults are the catalog's, its behaviour that of :class:`_RestitutionLaw`."""
    fields = []
    for p in entry["parameters"]:
        kind = _PARAMETER_TYPES.get(p["name"], "float")
        if p["default"] is not None:
            fields.append((p["name"], kind, dataclasses.field(default=p["default"])))
        elif p["name"] == "stiffness":  # first, and without a default
            fields.append((p["name"], kind))
        else:  # required or optional, after parameters with defaults
            fields.append((p["name"], f"{kind} | None", dataclasses.field(default=None)))
    cls = dataclasses.make_dataclass(
        entry["class_name"], fields, bases=(_RestitutionLaw,), frozen=True,
        namespace={"__doc__": entry["doc"], "kind": entry["name"]},
    )
    cls.__module__ = __name__
    return cls


def _curve(
    name: str, penetration: Sequence[float], force: Sequence[float]
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Curve ``name`` (``loading`` or ``unloading``) as tuples of floats; its shape is the
    core's rule (``_core.tabulated_curve_fault``)."""
    given = {f"{name}_penetration": penetration, f"{name}_force": force}
    for field, values in given.items():
        require(
            isinstance(values, (list, tuple, np.ndarray))
            and all(_is_number(v) or isinstance(v, np.floating) for v in values),
            f"law.{field}", values, "a list of numbers",
        )
    x, f = tuple(float(v) for v in penetration), tuple(float(v) for v in force)
    fault = _core.tabulated_curve_fault(name, x, f)
    if fault is not None:
        field, expected = fault
        require(False, f"law.{field}", given[field], expected)
    return x, f


@dataclass(frozen=True)
class Tabulated(ContactLaw):
    """A user law from tabulated force–indentation data: a loading curve (``δ`` in m, ``F`` in
    N, piecewise linear, from ``(0, 0)``) and an unloading curve on or below it, measured
    from its last point ``δ_e`` and ending at a force > 0.

    Rule, in a contact whose largest penetration so far is ``δ_m``: while ``δ̇ >= 0`` the
    force is the loading curve ``F_L(δ)``; while ``δ̇ <= −w`` it is the unloading curve
    stretched to start on the loading curve at ``δ_m``,
    ``F_U*(δ) = F_L(δ_m) F_U(δ δ_e/δ_m) / F_U(δ_e)`` (penetrations scaled by ``δ_m/δ_e``,
    forces by ``F_L(δ_m)/F_U(δ_e)``; the given curve itself when ``δ_m = δ_e`` and it ends on
    the loading curve), capped by ``F_L``; in between it passes smoothly,
    ``F = F_U* + (F_L − F_U*) s(1 + δ̇/w)`` with ``s(x) = 3x² − 2x³``, ``w = reversal_band ·
    v_imp``. The loading curve is continued linearly beyond its last point. The damping is
    rate-independent: the loop between the curves is what one impact dissipates; with a
    linear loading curve and an unloading shape with residual indentation ``r δ_e``, every
    impact restitutes ``√(1 − r)``. A run tracks ``δ_m`` per wall (the largest penetration at
    step ends); :meth:`force` without ``max_penetration`` takes ``δ_m = δ_e``.
    """

    kind: ClassVar[str] = "tabulated"
    loading_penetration: Sequence[float]
    loading_force: Sequence[float]
    unloading_penetration: Sequence[float]
    unloading_force: Sequence[float]
    reversal_band: float = catalog_default("tabulated", "reversal_band")

    def __post_init__(self) -> None:
        lx, lf = _curve("loading", self.loading_penetration, self.loading_force)
        ux, uf = _curve("unloading", self.unloading_penetration, self.unloading_force)
        object.__setattr__(self, "loading_penetration", lx)
        object.__setattr__(self, "loading_force", lf)
        object.__setattr__(self, "unloading_penetration", ux)
        object.__setattr__(self, "unloading_force", uf)
        check_parameter(self.kind, "reversal_band", self.reversal_band)
        # The core checks that the unloading points are not above the loading curve and that
        # the unloading curve ends at a force > 0.
        _core.contact_force(self.to_spec(), 1e-300, 0.0, 1.0)

    @classmethod
    def from_curves(
        cls,
        loading: Sequence[tuple[float, float]],
        unloading: Sequence[tuple[float, float]],
        reversal_band: float = catalog_default("tabulated", "reversal_band"),
    ) -> Tabulated:
        """From sequences of ``(δ, F)`` points."""
        lx, lf = zip(*loading, strict=True)
        ux, uf = zip(*unloading, strict=True)
        return cls(lx, lf, ux, uf, reversal_band)

    @property
    def contact_stiffness(self) -> float:
        """Secant stiffness of the loading curve at its last point, N/m."""
        return self.loading_force[-1] / self.loading_penetration[-1]

    @property
    def exponent(self) -> float:
        """1: :attr:`contact_stiffness` is that of a linear estimate."""
        return 1.0

    def to_spec(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "loading_penetration": list(self.loading_penetration),
            "loading_force": list(self.loading_force),
            "unloading_penetration": list(self.unloading_penetration),
            "unloading_force": list(self.unloading_force),
            "reversal_band": float(self.reversal_band),
        }


@dataclass(frozen=True)
class Rigid(ContactLaw):
    """The massless bar (paper Fig. 1a): a rigid wall with Newton's restitution
    law ``δ̇⁺ = −e δ̇⁻``, applied as an instantaneous velocity jump through the generalized
    impulse, ``Δv = −(1+e)(b·v) M⁻¹bᵀ/(b M⁻¹ bᵀ)`` for one wall. ``restitution`` ``e`` in
    [0, 1] (0: plastic impact). It has no force–indentation relation: only the impulsive
    methods (``vi.EventDriven``, ``vi.MoreauJean``) take it, and they take no other law.
    Rules for simultaneous impacts and chattering: docs/rigid-impacts.md."""

    kind: ClassVar[str] = "rigid"
    impulsive: ClassVar[bool] = True
    restitution: float

    def __post_init__(self) -> None:
        check_parameter(self.kind, "restitution", self.restitution)

    @property
    def contact_stiffness(self) -> float:
        """Not defined (a rigid wall): raises ``NotImplementedError``, so that step-size
        estimates from the contact period (``simulate.contact_periods``) skip the gap."""
        raise NotImplementedError("a rigid wall has no contact stiffness")

    @property
    def exponent(self) -> float:
        """1 (no force law; kept for the interface)."""
        return 1.0

    def to_spec(self) -> dict[str, Any]:
        return {"kind": self.kind, "restitution": float(self.restitution)}

    def force(
        self,
        penetration: float,
        rate: float,
        impact_speed: float,
        max_penetration: float | None = None,
    ) -> tuple[float, float, float]:
        """Not defined: a rigid wall has no force–indentation law."""
        raise ModelError("law.kind: 'rigid' has no contact force; it acts by impulses "
                         "(methods event-driven, moreau-jean)")

    def evaluate(
        self,
        penetration: ArrayLike,
        rate: ArrayLike,
        impact_speed: ArrayLike,
        clamp: bool = False,
        max_penetration: ArrayLike | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Not defined: see :meth:`force`."""
        return self.force(0.0, 0.0, 0.0)  # type: ignore[return-value]


#: The classes written here (each checked against its catalog entry by the tests); every other
#: law of the catalog is hysteretic and has a generated class.
_WRITTEN: dict[str, type[ContactLaw]] = {
    c.__name__: c for c in (Hertz, KelvinVoigt, HuntCrossley, Tabulated, Rigid)
}


def _generated_classes() -> tuple[type[_RestitutionLaw], ...]:
    unwritten = [e for e in CATALOG.values() if e["class_name"] not in _WRITTEN]
    other = [e["class_name"] for e in unwritten if e["family"] != "hysteretic"]
    if other:  # only a hysteretic law is data alone; another family needs its class here
        raise ImportError(f"vibroimpact.contact: no class for {', '.join(other)}")
    return tuple(_hysteretic_class(e) for e in unwritten)


#: The classes generated from the core's catalog, one per hysteretic law with a restitution
#: (``vi.contact.LankaraniNikravesh``, ...).
HYSTERETIC_CLASSES: tuple[type[_RestitutionLaw], ...] = _generated_classes()
globals().update({cls.__name__: cls for cls in HYSTERETIC_CLASSES})
__all__ += ["HYSTERETIC_CLASSES", *(cls.__name__ for cls in HYSTERETIC_CLASSES)]

#: Every law by its kebab-case name (model files, CLI, JSON), in the order of the core's
#: catalog; the last, ``rigid``, is the massless bar (impulsive methods only).
LAWS: dict[str, type[ContactLaw]] = {
    kind: {**_WRITTEN, **{c.__name__: c for c in HYSTERETIC_CLASSES}}[e["class_name"]]
    for kind, e in CATALOG.items()
}

#: The force laws ``F(δ, δ̇, v_imp)`` (every law but ``rigid``): what the compliant integrators,
#: ``vibroimpact impact`` and ``vibroimpact laws`` take.
FORCE_LAWS: dict[str, type[ContactLaw]] = {k: c for k, c in LAWS.items() if not c.impulsive}

#: The laws whose damping follows from a restitution ``ce`` they require.
RESTITUTION_LAWS: tuple[str, ...] = tuple(
    kind for kind, cls in LAWS.items() if issubclass(cls, _RestitutionLaw)
)

#: The paper's five laws, in its order (Table 2).
PAPER_LAWS = ("hertz", "hunt-crossley", "lankarani-nikravesh", "gonthier", "flores")

#: Law names no longer accepted, each with the one line that says why and what to use.
REMOVED_LAWS: dict[str, str] = {
    "safaeifar-karimi": "law 'safaeifar-karimi' was removed: it was a stand-in, not the "
                        "published law; use 'exact-restitution' (the same relation under its "
                        "own name)",
}


def refuse_removed_law(name: str) -> None:
    """Raise the one-line :class:`ModelError` of :data:`REMOVED_LAWS` if ``name`` is removed."""
    if name in REMOVED_LAWS:
        raise ModelError(REMOVED_LAWS[name])


def law_from_name(name: str, **params: Any) -> ContactLaw:
    """Build a law from its kebab-case name (``"lankarani-nikravesh"``) and parameters."""
    refuse_removed_law(name)
    if name not in LAWS:
        raise ModelError(
            f"law.kind: {name!r} is not a known contact law; expected one of {', '.join(LAWS)}"
        )
    cls = LAWS[name]
    accepted = [f.name for f in dataclasses.fields(cls) if f.init]
    unknown = [k for k in params if k not in accepted]
    if unknown:
        raise ModelError(
            f"law.{unknown[0]}: not a parameter of {name}; expected some of "
            f"{', '.join(accepted)}"
        )
    missing = [
        f.name for f in dataclasses.fields(cls)
        if f.init and f.default is dataclasses.MISSING and f.name not in params
    ]
    if missing:
        raise ModelError(f"law.{missing[0]}: missing; {name} needs {', '.join(missing)}")
    return cls(**params)
