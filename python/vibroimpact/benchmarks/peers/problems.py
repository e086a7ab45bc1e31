"""The benchmark problems of ``vibroimpact bench --peers`` (issue 9), stated once as plain
numbers so that every tool (ours, SciPy, OpenSeesPy, Exudyn) builds the same physics.

An SDOF problem is ``m x'' + c x' + k x = F sin(2π f t) − F_pos + F_neg`` with walls at
``x = +d`` (``F_pos``) and, if two-sided, ``x = −d`` (``F_neg``), and a Hertz or
Lankarani–Nikravesh contact ``F = K δⁿ (1 + χ δ̇/v_imp)``, ``χ = 3(1 − ce²)/4``."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = [
    "BeamProblem", "SdofProblem", "all_problems", "forced_sdof", "hollow_shaft", "paper_sdof",
]


@dataclass(frozen=True)
class SdofProblem:
    """One SDOF impact problem, SI units; ``sides``: (+1,) one wall at +d, (+1, −1) both."""

    key: str
    title: str
    mass: float
    contact_stiffness: float
    exponent: float
    restitution: float | None  # None: Hertz (elastic)
    clearance: float
    sides: tuple[int, ...]
    t_end: float
    dt: float
    stiffness: float = 0.0
    damping: float = 0.0
    force_amplitude: float = 0.0
    force_frequency: float = 0.0
    x0: float = 0.0
    v0: float = 0.0
    #: Rough penetration and speed scales (for the absolute tolerances of the ODE peers).
    length_scale: float = 1e-3
    speed_scale: float = 1.0

    @property
    def law_name(self) -> str:
        return "hertz" if self.restitution is None else "lankarani-nikravesh"

    @property
    def chi(self) -> float:
        """Coefficient of ``δ̇/v_imp`` in the law's bracket."""
        ce = self.restitution
        return 0.0 if ce is None else 0.75 * (1.0 - ce * ce)

    def force(self, t: float) -> float:
        if self.force_amplitude == 0.0:
            return 0.0
        return self.force_amplitude * math.sin(2.0 * math.pi * self.force_frequency * t)

    def contact_force(self, delta: float, delta_dot: float, v_imp: float) -> float:
        """The law, from its formula (never tensile)."""
        if delta <= 0.0:
            return 0.0
        f = self.contact_stiffness * delta**self.exponent
        if self.chi:
            f *= 1.0 + self.chi * delta_dot / v_imp
        return max(f, 0.0)

    def describe(self) -> str:
        law = ("Hertz" if self.restitution is None
               else f"Lankarani-Nikravesh ce {self.restitution:g}")
        walls = "both sides" if len(self.sides) == 2 else "one side"
        load = (f"F {self.force_amplitude:g} sin(2 pi {self.force_frequency:g} t) N"
                if self.force_amplitude else "no load")
        return (f"{self.title}: m {self.mass:g} kg, k {self.stiffness:g} N/m, c {self.damping:g}"
                f" N s/m, {load}, "
                f"clearance {self.clearance * 1e3:g} mm {walls}, {law}, "
                f"K {self.contact_stiffness:.4g} N/m^{self.exponent:g}, x0 {self.x0:g} m, "
                f"v0 {self.v0:g} m/s, "
                f"{self.t_end:g} s")

    def model(self) -> Any:
        """The problem as a :class:`vibroimpact.Model`."""
        from vibroimpact.contact import Hertz, LankaraniNikravesh
        from vibroimpact.model import Gap, HarmonicLoad, Model, Structure

        if self.restitution is None:
            law: Any = Hertz(stiffness=self.contact_stiffness, exponent=self.exponent)
        else:
            law = LankaraniNikravesh(stiffness=self.contact_stiffness, exponent=self.exponent,
                                     restitution=self.restitution)
        side = "both" if len(self.sides) == 2 else ("positive" if self.sides[0] > 0
                                                    else "negative")
        loads = []
        if self.force_amplitude:
            loads.append(HarmonicLoad(dof=0, amplitude=self.force_amplitude,
                                      frequency=self.force_frequency))
        return Model(
            structure=Structure.sdof(mass=self.mass, stiffness=self.stiffness,
                                     damping=self.damping),
            gaps=[Gap(dof=0, clearance=self.clearance, side=side, law=law)],
            loads=loads,
            initial_displacement=self.x0,
            initial_velocity=self.v0,
        )


def paper_sdof() -> SdofProblem:
    """The paper's SDOF case (docs/paper-cases.md): 100 kg at 8 m/s between two walls 5 mm
    away, k0 = c0 = 0, Lankarani–Nikravesh ce 0.9 with the case-1 stiffness (K ≈ 1.509e11), 0.02 s
    at dt = 1 µs."""
    from vibroimpact.paper import cases

    return SdofProblem(
        key="paper-sdof", title="paper SDOF case (0.02 s)", mass=100.0,
        contact_stiffness=cases.paper_geometry().stiffness(), exponent=1.5, restitution=0.9,
        clearance=0.005, sides=(1, -1), t_end=cases.SDOF_T_END, dt=cases.SDOF_DT,
        v0=8.0, length_scale=1e-3, speed_scale=8.0,
    )


def forced_sdof() -> SdofProblem:
    """A forced impact oscillator: m = 1 kg, k = 1e4 N/m (15.9 Hz), c = 2 N s/m,
    F = 10 sin(2π·12 t) N, one wall 1 mm away on the positive side, Lankarani–Nikravesh
    ce 0.9, K = 1e9 N/m^1.5, from rest, 1 s at dt = 10 µs (contacts last ≈ 1 ms)."""
    return SdofProblem(
        key="forced-sdof", title="forced SDOF impact oscillator (1 s)", mass=1.0,
        contact_stiffness=1e9, exponent=1.5, restitution=0.9, clearance=0.001, sides=(1,),
        t_end=1.0, dt=1e-5, stiffness=1e4, damping=2.0, force_amplitude=10.0,
        force_frequency=12.0, length_scale=1e-4, speed_scale=0.2,
    )


@dataclass(frozen=True)
class BeamProblem:
    """The paper's hollow shaft on three sliders
    (:func:`vibroimpact.paper.cases.hollow_shaft_model`), run for ``t_end`` at ``dt``; the
    response is the x displacement at the middle slider."""

    key: str
    title: str
    t_end: float
    dt: float
    elements: int = 20

    def model(self) -> Any:
        from vibroimpact.paper import cases

        return cases.hollow_shaft_model("timoshenko", self.elements)

    def describe(self) -> str:
        return (f"{self.title}: vibroimpact.paper.cases.hollow_shaft_model('timoshenko', "
                f"{self.elements}), Hertz K 1.509e11 N/m^1.5, 3 mm clearance both sides at 3 "
                f"sliders, F = 100 sin(20 pi t) N at every node, {self.t_end:g} s at dt "
                f"{self.dt:g} s")


def hollow_shaft() -> BeamProblem:
    """The hollow shaft (0.2 s at :data:`vibroimpact.paper.cases.HOLLOW_SHAFT_DT`)."""
    from vibroimpact.paper import cases

    return BeamProblem(key="hollow-shaft", title="hollow shaft beam (0.2 s)", t_end=0.2,
                       dt=cases.HOLLOW_SHAFT_DT)


def all_problems() -> list[Any]:
    """Every problem, in table order."""
    return [paper_sdof(), forced_sdof(), hollow_shaft()]
