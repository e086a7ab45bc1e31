"""The paper's cases (DESIGN.md §7), built from the public API so that users can start from
them: the two-sphere single impact (§2.2, Figs. 3–4) and the SDOF block between two walls
(§3.1, Figs. 5–13, Table 3)."""

from __future__ import annotations

from typing import Any

from vibroimpact.contact import LAWS, PAPER_LAWS, ContactLaw, Geometry
from vibroimpact.impact import single_impact
from vibroimpact.model import Gap, Model, Structure

__all__ = [
    "PAPER_LAWS",
    "SDOF_DT",
    "SDOF_T_END",
    "TWO_SPHERES_PAPER_V_OUT",
    "paper_geometry",
    "paper_law",
    "sdof_model",
    "two_spheres",
]

#: Steel of the paper's spheres and block: E = 207 GPa, ν = 0.3.
STEEL = {"youngs_modulus": 207e9, "poisson": 0.3}

#: Separation speeds the paper reports for case 1 (m/s; §2.2, Fig. 4).
TWO_SPHERES_PAPER_V_OUT = {
    "hertz": 0.3,
    "hunt-crossley": 0.2,
    "lankarani-nikravesh": 0.2,
    "gonthier": 0.15,
    "flores": 0.15,
}

#: The SDOF case's duration and step (paper §3.1, Table 3).
SDOF_T_END = 0.02
SDOF_DT = 1e-6


def paper_geometry() -> Geometry:
    """Ball (R2 = 9.9 mm) in a socket (R1 = 10 mm), both steel: K ≈ 1.509e11 N/m^1.5 (eq. 4)."""
    return Geometry("ball-in-socket", radius1=0.010, radius2=0.0099, **STEEL)


def paper_law(name: str, restitution: float) -> ContactLaw:
    """One of the paper's five laws with the case-1 stiffness and exponent 1.5."""
    if name == "hertz":
        return LAWS[name](stiffness=paper_geometry(), exponent=1.5)
    return LAWS[name](stiffness=paper_geometry(), exponent=1.5, restitution=restitution)


def sdof_model(law: str = "lankarani-nikravesh", restitution: float = 0.9) -> Model:
    """Case 2: a 100 kg block leaving the middle of a 2 × 5 mm clearance at 8 m/s, no spring
    and no damper (k0 = c0 = 0), with the case-1 contact stiffness (DESIGN.md §7.2)."""
    return Model(
        structure=Structure.sdof(mass=100.0),
        gaps=[Gap(dof=0, clearance=0.005, side="both", law=paper_law(law, restitution))],
        initial_velocity=8.0,
    )


def two_spheres(law: str, restitution: float = 0.5) -> dict[str, Any]:
    """Case 1: the 0.04 kg sphere hitting the socket at 0.3 m/s (DESIGN.md §7.1)."""
    return single_impact(paper_law(law, restitution), mass=0.04, velocity=0.3)
