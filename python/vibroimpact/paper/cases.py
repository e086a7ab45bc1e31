"""The paper's cases (docs/paper-cases.md), built from the public API so that users can start
from them: the two-sphere single impact (§2.2, Figs. 3–4) and the SDOF block between two walls
(§3.1, Figs. 5–13, Table 3), and the hollow shaft on sliders (§3.2, Figs. 14–17, Table 4)."""

from __future__ import annotations

from typing import Any

from vibroimpact.contact import LAWS, PAPER_LAWS, ContactLaw, Geometry
from vibroimpact.impact import single_impact
from vibroimpact.model import Gap, HarmonicLoad, Model, Structure

__all__ = [
    "HOLLOW_SHAFT_DT",
    "HOLLOW_SHAFT_PAPER_FREQUENCIES_HZ",
    "HOLLOW_SHAFT_T_END",
    "PAPER_LAWS",
    "SDOF_DT",
    "SDOF_T_END",
    "TWO_SPHERES_PAPER_V_OUT",
    "hollow_shaft_beam",
    "hollow_shaft_model",
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
    and no damper (k0 = c0 = 0), with the case-1 contact stiffness (docs/paper-cases.md)."""
    return Model(
        structure=Structure.sdof(mass=100.0),
        gaps=[Gap(dof=0, clearance=0.005, side="both", law=paper_law(law, restitution))],
        initial_velocity=8.0,
    )


def two_spheres(law: str, restitution: float = 0.5) -> dict[str, Any]:
    """Case 1: the 0.04 kg sphere hitting the socket at 0.3 m/s (docs/paper-cases.md §Case 1)."""
    return single_impact(paper_law(law, restitution), mass=0.04, velocity=0.3)


#: The hollow shaft's first three free–free bending frequencies in the paper (Hz; §3.2,
#: Table 4, ABAQUS shell reference model; the paper's beam model gives 477, 1035, 1637).
HOLLOW_SHAFT_PAPER_FREQUENCIES_HZ = (477.0, 1035.0, 1614.0)

#: The hollow shaft's forced run: duration and step (s). 0.5 s is five periods of the 10 Hz
#: load; 2 µs resolves every contact (≈ 0.1–0.5 ms long) with over 50 steps.
HOLLOW_SHAFT_T_END = 0.5
HOLLOW_SHAFT_DT = 2e-6

#: Where the sliders sit (nodes of the beam): both ends and the middle.
HOLLOW_SHAFT_SLIDERS = ("start", "middle", "end")


def hollow_shaft_beam(theory: str = "timoshenko", elements: int = 20, *,
                      damping: Any = None, mount_stiffness: float = 0.0) -> Any:
    """Case 3's tube as a planar beam (``vibroimpact.fe.Beam``): Ø190 mm × 5 mm wall ×
    1000 mm, E = 207 GPa, ν = 0.3, ρ = 34.41 g/cm³ (≈ 100 kg), free–free, ``elements`` equal
    elements of ``theory`` ``"timoshenko"`` (Cowper's thin-tube shear coefficient, rotary
    inertia) or ``"euler-bernoulli"``; consistent mass (docs/paper-cases.md §Case 3).

    Not in the paper (the continuation's variant, docs/periodic-orbits.md): ``damping``
    (``vibroimpact.fe.Rayleigh``, default undamped) and, with ``mount_stiffness`` > 0 (N/m),
    a spring in x to ground at each end (the shaft on soft mounts: its rigid-body modes
    become a resonance)."""
    from vibroimpact.fe import Beam, Material, Section, Spring

    springs = ([Spring(mount_stiffness, "x", node=end) for end in ("start", "end")]
               if mount_stiffness > 0 else [])
    return Beam(
        length=1.0,
        elements=elements,
        section=Section.tube(outer_diameter=0.190, wall_thickness=0.005),
        material=Material(youngs_modulus=207e9, poisson=0.3, density=34410.0),
        theory=theory,
        damping=damping,
        springs=springs,
    )


def hollow_shaft_model(
    theory: str = "timoshenko",
    elements: int = 20,
    *,
    law: ContactLaw | None = None,
    clearance: float = 0.003,
    load: bool = True,
    initial_velocity: Any = None,
    initial_displacement: Any = None,
    load_amplitude: float = 100.0,
    load_frequency: float = 10.0,
    damping: Any = None,
    mount_stiffness: float = 0.0,
) -> Model:
    """Case 3 (paper §3.2, Figs. 14–17): the hollow shaft of :func:`hollow_shaft_beam` between
    sliders at both ends and the middle, ``clearance`` (m) on both sides in x (gaps named
    ``start``, ``middle``, ``end``), and with ``load`` the force F = 100 sin(20πt) N in x at
    every node (``load_amplitude`` N, ``load_frequency`` Hz). ``damping``,
    ``mount_stiffness``: as :func:`hollow_shaft_beam` (the paper's case has neither).

    Contact law (``law``, default Hertz): the paper does not give this case's contact
    stiffness, so we use the one Hertz stiffness it derives, eq. 4 with the case-1 steel
    ball-in-socket geometry, K = 1.509e11 N/m^1.5, exponent 1.5."""
    beam = hollow_shaft_beam(theory, elements, damping=damping,
                             mount_stiffness=mount_stiffness)
    law = paper_law("hertz", 1.0) if law is None else law
    gaps = [
        beam.gap(law, node=name, direction="x", clearance=clearance, side="both", name=name)
        for name in HOLLOW_SHAFT_SLIDERS
    ]
    loads = []
    if load:
        loads.append(
            beam.load(HarmonicLoad, nodes="all", direction="x", amplitude=load_amplitude,
                      frequency=load_frequency)
        )
    return beam.model(gaps, loads, initial_displacement=initial_displacement,
                      initial_velocity=initial_velocity)
