"""Contact-force laws ``F(δ, δ̇, v_imp)`` (paper §2.2, Table 2; DESIGN.md §3).

Each law is plain data; the force, its derivatives and the time loop live in the Rust core.
``stiffness`` is either a number (N/mⁿ) or a :class:`Geometry` from which the Hertz stiffness
``K = (4/3) E* √R*`` is computed (paper eq. 4).

Example::

    >>> from vibroimpact import contact
    >>> steel = dict(youngs_modulus=207e9, poisson=0.3)
    >>> g = contact.Geometry("ball-in-socket", radius1=0.010, radius2=0.0099, **steel)
    >>> law = contact.LankaraniNikravesh(stiffness=g, exponent=1.5, restitution=0.9)
    >>> round(law.contact_stiffness / 1e11, 3)
    1.509
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from vibroimpact import _core
from vibroimpact.errors import ModelError, require

__all__ = [
    "LAWS",
    "ContactLaw",
    "Flores",
    "Geometry",
    "Gonthier",
    "Hertz",
    "HuntCrossley",
    "KelvinVoigt",
    "LankaraniNikravesh",
    "law_from_name",
]

GeometryKind = Literal["sphere-sphere", "ball-in-socket", "sphere-plane"]


def _positive(value: float, field: str, unit: str) -> None:
    require(
        isinstance(value, (int, float)) and math.isfinite(value) and value > 0,
        field,
        value,
        f"a number > 0 in {unit}",
    )


@dataclass(frozen=True)
class Geometry:
    """Two elastic bodies whose Hertz stiffness follows from shape and material (paper eq. 4).

    ``kind``: ``"sphere-sphere"`` (outside each other, ``R* = R1R2/(R1+R2)``),
    ``"ball-in-socket"`` (``R* = R1R2/|R1−R2|``, the paper's case) or ``"sphere-plane"``
    (``R* = R1``). Radii in m, Young's moduli in Pa; body 2 has body 1's material unless
    ``youngs_modulus2``/``poisson2`` are given.
    """

    kind: GeometryKind
    radius1: float
    youngs_modulus: float
    poisson: float
    radius2: float | None = None
    youngs_modulus2: float | None = None
    poisson2: float | None = None

    def __post_init__(self) -> None:
        kinds = ("sphere-sphere", "ball-in-socket", "sphere-plane")
        require(self.kind in kinds, "geometry.kind", self.kind, "one of " + ", ".join(kinds))
        if self.kind != "sphere-plane":
            require(self.radius2 is not None, "geometry.radius2", None, "a radius in m")
        self.stiffness()  # validates radii and materials in the core

    def stiffness(self) -> float:
        """Hertz contact stiffness ``K``, N/m^1.5."""
        e2 = self.youngs_modulus if self.youngs_modulus2 is None else self.youngs_modulus2
        nu2 = self.poisson if self.poisson2 is None else self.poisson2
        return _core.hertz_stiffness(
            self.kind,
            float(self.radius1),
            None if self.radius2 is None else float(self.radius2),
            float(self.youngs_modulus),
            float(self.poisson),
            float(e2),
            float(nu2),
        )


@dataclass(frozen=True)
class ContactLaw:
    """Base of the laws: a stiffness (number or :class:`Geometry`) and an exponent."""

    kind: ClassVar[str] = ""
    stiffness: float | Geometry
    exponent: float = 1.5

    def __post_init__(self) -> None:
        if not isinstance(self.stiffness, Geometry):
            _positive(self.stiffness, "law.stiffness", "N/m^n")
        require(
            isinstance(self.exponent, (int, float))
            and math.isfinite(self.exponent)
            and self.exponent >= 1,
            "law.exponent",
            self.exponent,
            "a number >= 1 (1.5 for Hertzian point contact)",
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

    def force(
        self, penetration: float, rate: float, impact_speed: float
    ) -> tuple[float, float, float]:
        """``(F, ∂F/∂δ, ∂F/∂δ̇)`` at penetration δ (m), rate δ̇ (m/s) and approach speed
        ``v_imp`` (m/s), evaluated by the core (zero when δ <= 0; never tensile)."""
        return _core.contact_force(
            self.to_spec(), float(penetration), float(rate), float(impact_speed)
        )


def _check_restitution(value: float | None) -> None:
    require(
        isinstance(value, (int, float)) and 0 < value <= 1,
        "law.restitution",
        value,
        "0 < restitution <= 1",
    )


@dataclass(frozen=True)
class Hertz(ContactLaw):
    """``F = K δⁿ`` (Hertz 1882; paper eq. 3). Elastic: no energy lost."""

    kind: ClassVar[str] = "hertz"


@dataclass(frozen=True)
class KelvinVoigt(ContactLaw):
    """Linear spring–dashpot ``F = k δ + c δ̇`` (the spring–damping description, paper Fig. 1b),
    clamped to zero when it would pull. ``stiffness`` in N/m, ``damping`` in N·s/m."""

    kind: ClassVar[str] = "kelvin-voigt"
    exponent: float = 1.0
    damping: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        require(self.exponent == 1, "law.exponent", self.exponent, "1 for kelvin-voigt")
        require(
            isinstance(self.damping, (int, float)) and math.isfinite(self.damping)
            and self.damping >= 0,
            "law.damping",
            self.damping,
            "a number >= 0 in N·s/m",
        )

    def to_spec(self) -> dict[str, Any]:
        return {**super().to_spec(), "damping": float(self.damping)}


@dataclass(frozen=True)
class HuntCrossley(ContactLaw):
    """``F = K δⁿ + b δⁿ δ̇`` (Hunt & Crossley 1975; paper eq. 5). Give either the damping
    ``b`` (N·s/m^(n+1)) or the restitution ``ce``, from which ``b = 3K(1 − ce)/(2 v_imp)``
    (paper eq. 6)."""

    kind: ClassVar[str] = "hunt-crossley"
    restitution: float | None = None
    damping: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if (self.restitution is None) == (self.damping is None):
            raise ModelError(
                "law: hunt-crossley needs exactly one of restitution or damping; "
                f"got restitution={self.restitution!r}, damping={self.damping!r}"
            )
        if self.restitution is not None:
            _check_restitution(self.restitution)
        else:
            require(
                isinstance(self.damping, (int, float)) and self.damping >= 0,
                "law.damping",
                self.damping,
                "a number >= 0",
            )

    def to_spec(self) -> dict[str, Any]:
        return {**super().to_spec(), "restitution": self.restitution, "damping": self.damping}


@dataclass(frozen=True)
class _RestitutionLaw(ContactLaw):
    restitution: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_restitution(self.restitution)

    def to_spec(self) -> dict[str, Any]:
        assert self.restitution is not None
        return {**super().to_spec(), "restitution": float(self.restitution)}


@dataclass(frozen=True)
class LankaraniNikravesh(_RestitutionLaw):
    """``F = K δⁿ [1 + 3(1 − ce²)/4 · δ̇/v_imp]`` (Lankarani & Nikravesh 1990; paper eq. 8)."""

    kind: ClassVar[str] = "lankarani-nikravesh"


@dataclass(frozen=True)
class Gonthier(_RestitutionLaw):
    """``F = K δⁿ [1 + (1 − ce²)/ce · δ̇/v_imp]`` (Gonthier et al. 2004; paper eq. 9, whose
    ``ce²`` denominator is a misprint of Table 2's ``ce``)."""

    kind: ClassVar[str] = "gonthier"


@dataclass(frozen=True)
class Flores(_RestitutionLaw):
    """``F = K δⁿ [1 + 8(1 − ce)/(5 ce) · δ̇/v_imp]`` (Flores et al. 2011; paper eq. 13)."""

    kind: ClassVar[str] = "flores"


LAWS: dict[str, type[ContactLaw]] = {
    cls.kind: cls
    for cls in (Hertz, KelvinVoigt, HuntCrossley, LankaraniNikravesh, Gonthier, Flores)
}

#: The paper's five laws, in its order (Table 2).
PAPER_LAWS = ("hertz", "hunt-crossley", "lankarani-nikravesh", "gonthier", "flores")


def law_from_name(name: str, **params: Any) -> ContactLaw:
    """Build a law from its kebab-case name (``"lankarani-nikravesh"``) and parameters."""
    if name not in LAWS:
        raise ModelError(
            f"law.kind: {name!r} is not a known contact law; expected one of {', '.join(LAWS)}"
        )
    return LAWS[name](**params)
