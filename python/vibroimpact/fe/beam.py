"""Beam finite elements: 2-node Euler–Bernoulli and Timoshenko beams (paper §3.2, Fig. 15).

The beam lies on the z axis from ``z = 0`` (node 0, ``"start"``) to ``z = length``
(``"end"``), divided into ``elements`` equal elements. Node DOFs:

* planar (``dofs_per_node = 2``, the default): ``x`` (deflection, m) and ``ry`` (rotation
  about y, rad, ``ry = dx/dz`` for Euler–Bernoulli); bending in the x–z plane.
* 3-D (``dofs_per_node = 6``): ``x, y, z, rx, ry, rz``; bending in the x–z and y–z planes
  (``rx = −dy/dz``), axial ``z`` and torsion ``rz``.
* rotor (``dofs_per_node = 4``): ``x, y, rx, ry``, the two bending planes of a shaft
  spinning about z (docs/rotors.md), with discs (:class:`Disc`), bearings
  (:class:`Bearing`) and the gyroscopic matrix ``G`` at ``spin_speed``.

Gyroscopic matrix of a spinning shaft element (Nelson & McVaugh, *J. Eng. Ind.* 98:593,
1976; Friswell et al., *Dynamics of Rotating Machines*, 2010, §5.4): with the rotation
shape functions ``N`` of the bending element (``ry = N [x1, ry1, x2, ry2]``, and
``rx = −N T [y1, rx1, y2, rx2]``, ``T = diag(1, −1, 1, −1)``), the gyroscopic moments
``ρ I_p Ω (ṙy, −ṙx)`` on ``(rx, ry)`` per length give ``G[x, y] = ρ I_p ∫NᵀN dz · T`` and
``G[y, x] = −T · ρ I_p ∫NᵀN dz`` (``I_p = I_x + I_y``; the shaft's rotary-inertia matrix
with ``I_p`` for ``I``, so ``G`` exists with ``rotary_inertia`` only). A disc adds
``G[rx, ry] = I_p = −G[ry, rx]`` at its node, the gyroscopic couple of a spinning disc.

Element matrices (Przemieniecki, *Theory of Matrix Structural Analysis*, 1968, §5.6 and
§11.7; the interdependent-interpolation element), with ``Φ = 12 E I / (κ G A L²)``
(``Φ = 0``: Euler–Bernoulli; ``G = E / 2(1 + ν)``)::

    K = E I / ((1 + Φ) L³) · [[12, 6L, −12, 6L], [6L, (4+Φ)L², −6L, (2−Φ)L²], ...]

consistent translational mass ``ρAL/(1+Φ)² · [13/35 + 7Φ/10 + Φ²/3, ...]`` plus the rotary
inertia ``ρI/((1+Φ)² L) · [6/5, (1/10 − Φ/2)L, ...]``; axial bar ``EA/L``, ``ρAL/6·[2 1; 1 2]``
and torsion ``GJ/L``, ``ρI_pL/6·[2 1; 1 2]``. The lumped mass puts ``ρAL/2`` on each node's
translations and scales the consistent rotational diagonal by the same factor (HRZ lumping:
Hinton, Rock & Zienkiewicz, 1976; ``ρAL³/78`` per node for Euler–Bernoulli), plus ``ρIL/2``
of rotary inertia when that is included.

Shear coefficient κ (Cowper, *J. Appl. Mech.* 33:335, 1966, Table 1): solid circle
``6(1+ν)/(7+6ν)``; tube with ``m = d_inner/d_outer``:
``6(1+ν)(1+m²)² / [(7+6ν)(1+m²)² + (20+12ν)m²]`` (→ ``2(1+ν)/(4+3ν)`` for a thin wall);
rectangle ``10(1+ν)/(12+11ν)``; a user section gives κ itself.

Example — the paper's hollow shaft, free–free (no supports)::

    >>> from vibroimpact.fe import Beam, Material, Section, modes
    >>> shaft = Beam(length=1.0, elements=20,
    ...              section=Section.tube(outer_diameter=0.190, wall_thickness=0.005),
    ...              material=Material(youngs_modulus=207e9, poisson=0.3, density=34410.0))
    >>> round(shaft.total_mass, 2)
    100.0
    >>> gap = shaft.dof(node="end", direction="x")
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibroimpact.contact import ContactLaw
from vibroimpact.errors import ModelError
from vibroimpact.fe.damping import Damping, damping_from_table
from vibroimpact.fe.dofs import DIRECTIONS, DofMap, FEStructure, direction_name
from vibroimpact.model import Gap, Load, Model, Structure, model_default

__all__ = [
    "Beam",
    "Bearing",
    "Disc",
    "Material",
    "PointMass",
    "Section",
    "Spring",
    "Support",
    "beam_from_table",
    "cowper_shear_coefficient",
    "element_matrices",
]

Theory = Literal["euler-bernoulli", "timoshenko"]
THEORIES: tuple[str, ...] = ("euler-bernoulli", "timoshenko")
SECTION_KINDS: tuple[str, ...] = ("circle", "tube", "rectangle", "user")
SUPPORT_KINDS: tuple[str, ...] = ("fixed", "pinned", "free")
NODE_NAMES: tuple[str, ...] = ("start", "middle", "end")
PLANAR_DIRECTIONS: tuple[str, ...] = ("x", "ry")
ROTOR_DIRECTIONS: tuple[str, ...] = ("x", "y", "rx", "ry")
#: Per ``dofs_per_node``: the node's directions, and the element's local DOFs of the x–z
#: bending plane ``(x, ry)`` and of the y–z plane ``(y, rx)`` (``None``: planar).
_LAYOUTS: dict[int, tuple[tuple[str, ...], list[int] | None, list[int] | None]] = {
    2: (PLANAR_DIRECTIONS, None, None),
    4: (ROTOR_DIRECTIONS, [0, 3, 4, 7], [1, 2, 5, 6]),
    6: (DIRECTIONS, [0, 4, 6, 10], [1, 3, 7, 9]),
}
NodeRef = int | str


def _number(value: Any, name: str, expected: str) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not ok or not math.isfinite(float(value)):
        raise ModelError(f"{name}: {value!r} is not valid; expected {expected}")
    return float(value)


def _positive(value: Any, name: str, unit: str) -> float:
    x = _number(value, name, f"a number > 0 in {unit}")
    if x <= 0:
        raise ModelError(f"{name}: {value!r} is not valid; expected a number > 0 in {unit}")
    return x


#: The largest section size (m) taken: its fourth power (second moments) stays a finite float.
_LARGEST_SIZE = 1e60


def _size(value: Any, name: str) -> float:
    """A section's size (m): > 0 and small enough that its section properties are finite."""
    x = _positive(value, name, "m")
    if x > _LARGEST_SIZE:
        raise ModelError(f"{name}: {value!r} is not valid; expected a size in m <= "
                         f"{_LARGEST_SIZE:g} (its fourth power must be a finite number)")
    return x


# --------------------------------------------------------------------------------------------
# Material and section
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Material:
    """Linear elastic, isotropic: ``youngs_modulus`` E (Pa), ``poisson`` ν, ``density`` ρ
    (kg/m³)."""

    youngs_modulus: float
    poisson: float
    density: float

    def __post_init__(self) -> None:
        _positive(self.youngs_modulus, "structure.material.youngs_modulus", "Pa")
        nu = _number(self.poisson, "structure.material.poisson", "a number with -1 < poisson < 0.5")
        if not -1 < nu < 0.5:
            raise ModelError(
                f"structure.material.poisson: {self.poisson!r} is not valid; expected a number "
                "with -1 < poisson < 0.5"
            )
        _positive(self.density, "structure.material.density", "kg/m^3")

    @property
    def shear_modulus(self) -> float:
        """``G = E / (2(1 + ν))``, Pa."""
        return self.youngs_modulus / (2 * (1 + self.poisson))


def cowper_shear_coefficient(kind: str, poisson: float, diameter_ratio: float = 0.0) -> float:
    """Timoshenko shear coefficient κ of Cowper (1966, Table 1) for ``kind`` ``"circle"``,
    ``"tube"`` (``diameter_ratio`` m = inner/outer diameter) or ``"rectangle"``."""
    nu = poisson
    if kind == "circle":
        return 6 * (1 + nu) / (7 + 6 * nu)
    if kind == "tube":
        m2 = diameter_ratio**2
        a = (1 + m2) ** 2
        return 6 * (1 + nu) * a / ((7 + 6 * nu) * a + (20 + 12 * nu) * m2)
    if kind == "rectangle":
        return 10 * (1 + nu) / (12 + 11 * nu)
    raise ModelError(
        f"section.kind: {kind!r} has no Cowper formula; expected circle, tube, rectangle"
    )


@dataclass(frozen=True)
class Section:
    """Cross-section: ``area`` A (m²), second moments ``second_moment_x`` = ∫x² dA (bending
    with deflection along x, the planar case) and ``second_moment_y`` = ∫y² dA (m⁴),
    ``torsion_constant`` J (m⁴, 3-D only) and ``shear_coefficient`` κ (None: Cowper's formula
    for the shape). Build one with :meth:`circle`, :meth:`tube`, :meth:`rectangle` or
    :meth:`user`."""

    kind: str
    area: float
    second_moment_x: float
    second_moment_y: float
    torsion_constant: float | None = None
    shear_coefficient: float | None = None
    diameter_ratio: float = 0.0

    def __post_init__(self) -> None:
        p = "structure.section"
        if self.kind not in SECTION_KINDS:
            raise ModelError(
                f"{p}.kind: {self.kind!r} is not valid; expected one of {', '.join(SECTION_KINDS)}"
            )
        area_name = f"{p}.area"
        _positive(self.area, area_name, "m^2")
        _positive(self.second_moment_x, f"{p}.second_moment", "m^4")
        _positive(self.second_moment_y, f"{p}.second_moment_y", "m^4")
        if self.torsion_constant is not None:
            _positive(self.torsion_constant, f"{p}.torsion_constant", "m^4")
        if self.shear_coefficient is not None:
            k = _positive(self.shear_coefficient, f"{p}.shear_coefficient", "(dimensionless)")
            if k > 2:
                raise ModelError(
                    f"{p}.shear_coefficient: {self.shear_coefficient!r} is not valid; expected a "
                    "number with 0 < shear_coefficient <= 2"
                )

    @classmethod
    def circle(cls, diameter: float, *, shear_coefficient: float | None = None) -> Section:
        """Solid circle of ``diameter`` (m): ``A = πd²/4``, ``I = πd⁴/64``, ``J = πd⁴/32``."""
        d = _positive(diameter, "structure.section.diameter", "m")
        i = math.pi * d**4 / 64
        return cls("circle", math.pi * d**2 / 4, i, i, 2 * i, shear_coefficient)

    @classmethod
    def tube(
        cls,
        outer_diameter: float,
        wall_thickness: float | None = None,
        *,
        inner_diameter: float | None = None,
        shear_coefficient: float | None = None,
    ) -> Section:
        """Circular tube: ``outer_diameter`` and either ``wall_thickness`` or ``inner_diameter``
        (m): ``A = π(D⁴ − d⁴)/4``, ``I = π(D⁴ − d⁴)/64``, ``J = 2I``."""
        p = "structure.section"
        do = _size(outer_diameter, f"{p}.outer_diameter")
        if (wall_thickness is None) == (inner_diameter is None):
            raise ModelError(
                f"{p}.wall_thickness: {wall_thickness!r} is not valid; expected exactly one of "
                "wall_thickness or inner_diameter"
            )
        if wall_thickness is not None:
            t = _positive(wall_thickness, f"{p}.wall_thickness", "m")
            if 2 * t > do:
                raise ModelError(
                    f"{p}.wall_thickness: {wall_thickness!r} is not valid; expected a thickness "
                    f"<= outer_diameter / 2 = {do / 2!r} m"
                )
            di = do - 2 * t
        else:
            di = _number(inner_diameter, f"{p}.inner_diameter", "a diameter >= 0 in m")
            if not 0 <= di < do:
                raise ModelError(
                    f"{p}.inner_diameter: {inner_diameter!r} is not valid; expected 0 <= "
                    f"inner_diameter < outer_diameter = {do!r} m"
                )
        i = math.pi * (do**4 - di**4) / 64
        return cls("tube", math.pi * (do**2 - di**2) / 4, i, i, 2 * i, shear_coefficient, di / do)

    @classmethod
    def rectangle(
        cls, size_x: float, size_y: float, *, shear_coefficient: float | None = None
    ) -> Section:
        """Solid rectangle ``size_x`` × ``size_y`` (m; ``size_x`` along the planar deflection
        x): ``I_x = size_y·size_x³/12``, ``I_y = size_x·size_y³/12``, ``J = a b³ [1/3 −
        0.21 (b/a)(1 − b⁴/12a⁴)]`` with a ≥ b (Roark's Formulas, Table 10.7)."""
        bx = _size(size_x, "structure.section.size_x")
        by = _size(size_y, "structure.section.size_y")
        a, b = max(bx, by), min(bx, by)
        j = a * b**3 * (1 / 3 - 0.21 * (b / a) * (1 - b**4 / (12 * a**4)))
        return cls("rectangle", bx * by, by * bx**3 / 12, bx * by**3 / 12, j, shear_coefficient)

    @classmethod
    def user(
        cls,
        area: float,
        second_moment: float,
        *,
        second_moment_y: float | None = None,
        torsion_constant: float | None = None,
        shear_coefficient: float | None = None,
    ) -> Section:
        """Any section from its ``area`` (m²), ``second_moment`` (m⁴; ∫x² dA, and ∫y² dA too
        unless ``second_moment_y`` is given), ``torsion_constant`` J (m⁴, 3-D beams) and
        ``shear_coefficient`` κ (Timoshenko beams)."""
        iy = second_moment if second_moment_y is None else second_moment_y
        return cls("user", area, second_moment, iy, torsion_constant, shear_coefficient)

    @property
    def polar_moment(self) -> float:
        """``I_p = I_x + I_y`` (m⁴), for the torsional inertia ``ρ I_p``."""
        return self.second_moment_x + self.second_moment_y

    def shear_coefficient_for(self, poisson: float) -> float:
        """κ: the given one, else Cowper's for the shape (see the module docstring)."""
        if self.shear_coefficient is not None:
            return float(self.shear_coefficient)
        if self.kind == "user":
            raise ModelError(
                "structure.section.shear_coefficient: missing; expected a number > 0 for a user "
                'section with theory = "timoshenko"'
            )
        return cowper_shear_coefficient(self.kind, poisson, self.diameter_ratio)


# --------------------------------------------------------------------------------------------
# Element matrices
# --------------------------------------------------------------------------------------------


def bending_matrices(
    flexural_rigidity: float,
    shear_rigidity: float | None,
    mass_per_length: float,
    rotary_inertia_per_length: float,
    length: float,
    *,
    lumped: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Stiffness and mass (4×4, DOFs ``w1, θ1, w2, θ2``) of one bending element:
    ``flexural_rigidity`` EI (N·m²), ``shear_rigidity`` κGA (N; None: Euler–Bernoulli),
    ``mass_per_length`` ρA (kg/m), ``rotary_inertia_per_length`` ρI (kg·m; 0: none),
    ``length`` L (m). Przemieniecki (1968) eqs. 5.116 and 11.42–11.43."""
    ei, L = flexural_rigidity, length
    phi = 0.0 if shear_rigidity is None else 12 * ei / (shear_rigidity * L**2)
    c = ei / ((1 + phi) * L**3)
    k = c * np.array(
        [
            [12, 6 * L, -12, 6 * L],
            [6 * L, (4 + phi) * L**2, -6 * L, (2 - phi) * L**2],
            [-12, -6 * L, 12, -6 * L],
            [6 * L, (2 - phi) * L**2, -6 * L, (4 + phi) * L**2],
        ]
    )
    ra = mass_per_length * L / (1 + phi) ** 2
    m11 = 13 / 35 + 7 * phi / 10 + phi**2 / 3
    m12 = (11 / 210 + 11 * phi / 120 + phi**2 / 24) * L
    m13 = 9 / 70 + 3 * phi / 10 + phi**2 / 6
    m14 = -(13 / 420 + 3 * phi / 40 + phi**2 / 24) * L
    m22 = (1 / 105 + phi / 60 + phi**2 / 120) * L**2
    m24 = -(1 / 140 + phi / 60 + phi**2 / 120) * L**2
    mt = ra * np.array(
        [
            [m11, m12, m13, m14],
            [m12, m22, -m14, m24],
            [m13, -m14, m11, -m12],
            [m14, m24, -m12, m22],
        ]
    )
    mr = rotary_inertia_per_length * rotation_gram(phi, L)
    if not lumped:
        return k, mt + mr
    half = mass_per_length * L / 2
    rot = half * mt[1, 1] / mt[0, 0] + rotary_inertia_per_length * L / 2
    return k, np.diag([half, rot, half, rot])


def rotation_gram(phi: float, length: float) -> NDArray[np.float64]:
    """``∫ Nᵀ N dz`` (m, 4×4 on ``w1, θ1, w2, θ2``) of the rotation shape functions ``N`` of
    a bending element with shear parameter ``phi`` (Przemieniecki 1968 eq. 11.43: the rotary
    inertia is ``ρI`` times it)."""
    L = length
    r12 = (1 / 10 - phi / 2) * L
    r22 = (2 / 15 + phi / 6 + phi**2 / 3) * L**2
    r24 = (-1 / 30 - phi / 6 + phi**2 / 6) * L**2
    return np.array(
        [
            [6 / 5, r12, -6 / 5, r12],
            [r12, r22, -r12, r24],
            [-6 / 5, -r12, 6 / 5, -r12],
            [r12, r24, -r12, r22],
        ]
    ) / ((1 + phi) ** 2 * L)


def shaft_gyroscopic(
    section: Section, material: Material, length: float, *, theory: str = "timoshenko",
    dofs_per_node: int = 4,
) -> NDArray[np.float64]:
    """The gyroscopic matrix ``G`` (kg·m², skew-symmetric, node-major like
    :func:`element_matrices`) of one shaft element spinning about z (module docstring)."""
    _, x_plane, y_plane = _LAYOUTS[dofs_per_node]
    if x_plane is None or y_plane is None:
        raise ModelError(f"structure.dofs_per_node: {dofs_per_node} is not valid for a rotor; "
                         "expected 4 (x, y, rx, ry) or 6")
    i = section.second_moment_x
    phi = 0.0
    if theory == "timoshenko":
        kappa = section.shear_coefficient_for(material.poisson)
        phi = 12 * material.youngs_modulus * i / (kappa * material.shear_modulus * section.area
                                                  * length**2)
    s = material.density * section.polar_moment * rotation_gram(phi, length)
    t = np.diag([1.0, -1.0, 1.0, -1.0])
    g = np.zeros((2 * dofs_per_node, 2 * dofs_per_node))
    g[np.ix_(x_plane, y_plane)] = s @ t
    g[np.ix_(y_plane, x_plane)] = -t @ s
    return g


def bar_matrices(
    rigidity: float, inertia_per_length: float, length: float, *, lumped: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two-node bar (axial: EA, ρA; torsion: GJ, ρI_p): ``rigidity/L·[1 −1; −1 1]`` and
    ``inertia·L/6·[2 1; 1 2]`` (lumped: ``inertia·L/2`` per node)."""
    k = rigidity / length * np.array([[1.0, -1.0], [-1.0, 1.0]])
    if lumped:
        return k, inertia_per_length * length / 2 * np.eye(2)
    return k, inertia_per_length * length / 6 * np.array([[2.0, 1.0], [1.0, 2.0]])


def element_matrices(
    section: Section,
    material: Material,
    length: float,
    *,
    theory: str = "timoshenko",
    rotary_inertia: bool = True,
    lumped: bool = False,
    dofs_per_node: int = 2,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Stiffness and mass of one element in node-major DOF order (planar: ``x1, ry1, x2,
    ry2``; rotor: ``x, y, rx, ry``; 3-D: ``x, y, z, rx, ry, rz`` of node 1 then node 2)."""
    e, g, rho = material.youngs_modulus, material.shear_modulus, material.density
    a = section.area
    kappa = section.shear_coefficient_for(material.poisson) if theory == "timoshenko" else None
    shear = None if kappa is None else kappa * g * a

    def plane(i: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return bending_matrices(
            e * i, shear, rho * a, rho * i if rotary_inertia else 0.0, length, lumped=lumped
        )

    _, x_plane, y_plane = _LAYOUTS[dofs_per_node]
    if x_plane is None or y_plane is None:
        return plane(section.second_moment_x)
    n = 2 * dofs_per_node
    k, m = np.zeros((n, n)), np.zeros((n, n))

    def put(local: Sequence[int], kk: NDArray[np.float64], mm: NDArray[np.float64]) -> None:
        idx = np.array(local)
        k[np.ix_(idx, idx)] += kk
        m[np.ix_(idx, idx)] += mm

    kx, mx = plane(section.second_moment_x)  # deflection x, rotation ry = +dx/dz
    put(x_plane, kx, mx)
    ky, my = plane(section.second_moment_y)  # deflection y, rotation rx = -dy/dz
    t = np.diag([1.0, -1.0, 1.0, -1.0])
    put(y_plane, t @ ky @ t, t @ my @ t)
    if dofs_per_node == 4:
        return k, m
    ka, ma = bar_matrices(e * a, rho * a, length, lumped=lumped)
    put([2, 8], ka, ma)
    if section.torsion_constant is None:
        raise ModelError(
            "structure.section.torsion_constant: missing; expected a number > 0 in m^4 for a "
            "user section with dofs_per_node = 6"
        )
    kt, mt = bar_matrices(
        g * section.torsion_constant, rho * section.polar_moment, length, lumped=lumped
    )
    put([5, 11], kt, mt)
    return k, m


# --------------------------------------------------------------------------------------------
# Supports, springs, point masses
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Support:
    """A support at ``node`` (index, ``"start"``, ``"middle"``, ``"end"``) or at the fraction
    ``at`` of the length: ``kind`` ``"fixed"`` (every DOF of the node), ``"pinned"`` (the
    translations) or ``"free"``; or ``directions``, the DOFs to fix (``["x"]``)."""

    node: NodeRef | None = None
    at: float | None = None
    kind: str = "fixed"
    directions: Sequence[str] | None = None


@dataclass(frozen=True)
class Spring:
    """A spring to ground on DOF ``direction`` at ``node``/``at``: ``stiffness`` in N/m
    (translations) or N·m/rad (rotations)."""

    stiffness: float
    direction: str = "x"
    node: NodeRef | None = None
    at: float | None = None


@dataclass(frozen=True)
class PointMass:
    """A rigid mass at ``node``/``at``: ``mass`` (kg) on each translation and
    ``rotary_inertia`` (kg·m²) on each rotation of the node."""

    mass: float
    node: NodeRef | None = None
    at: float | None = None
    rotary_inertia: float = 0.0


@dataclass(frozen=True)
class Disc:
    """A rigid disc of a rotor at ``node``/``at``: ``mass`` (kg) on x and y,
    ``diametral_inertia`` I_d (kg·m²) on rx and ry, ``polar_inertia`` I_p (kg·m², its
    gyroscopic couple ``Ω I_p``)."""

    mass: float
    node: NodeRef | None = None
    at: float | None = None
    polar_inertia: float = 0.0
    diametral_inertia: float = 0.0


@dataclass(frozen=True)
class Bearing:
    """A bearing of a rotor at ``node``/``at``: springs ``kxx``, ``kyy`` (N/m) and dampers
    ``cxx``, ``cyy`` (N·s/m) to ground on x and y."""

    node: NodeRef | None = None
    at: float | None = None
    kxx: float = 0.0
    kyy: float = 0.0
    cxx: float = 0.0
    cyy: float = 0.0


# --------------------------------------------------------------------------------------------
# The beam
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Beam:
    """A straight uniform beam of ``length`` (m) divided into ``elements`` equal elements
    (see the module docstring for the axes, DOFs and element formulas).

    ``theory``: ``"timoshenko"`` (shear deformation, default) or ``"euler-bernoulli"``;
    ``lumped_mass``: HRZ-lumped instead of consistent mass; ``rotary_inertia``: include ρI
    (default: True for Timoshenko, False for Euler–Bernoulli); ``dofs_per_node``: 2 (planar)
    4 (rotor: x, y, rx, ry) or 6 (3-D); ``supports``, ``springs``, ``masses``:
    :class:`Support`, :class:`Spring`, :class:`PointMass`; ``damping``:
    :class:`~vibroimpact.fe.Rayleigh` or :class:`~vibroimpact.fe.ModalDamping` (None:
    undamped). A rotor (4 or 6 DOFs per node): ``discs`` (:class:`Disc`), ``bearings``
    (:class:`Bearing`, their dampers added to ``damping``'s ``C``) and ``spin_speed`` Ω
    (rad/s); its structure has the gyroscopic matrix ``G`` (module docstring).

    Constrained DOFs are removed; :attr:`dof_map` gives ``(node, direction)`` per remaining
    DOF, :attr:`structure` the dense :class:`~vibroimpact.Structure`, :attr:`fe` the sparse
    :class:`~vibroimpact.fe.FEStructure`.
    """

    length: float
    elements: int
    section: Section
    material: Material
    theory: str = "timoshenko"
    lumped_mass: bool = False
    rotary_inertia: bool | None = None
    dofs_per_node: int = 2
    supports: Sequence[Support] = ()
    springs: Sequence[Spring] = ()
    masses: Sequence[PointMass] = ()
    damping: Damping | None = None
    discs: Sequence[Disc] = ()
    bearings: Sequence[Bearing] = ()
    spin_speed: float = model_default("structure", "spin_speed")
    fe: FEStructure = field(init=False, repr=False, compare=False)
    free_dofs: NDArray[np.int64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        p = "structure"
        _positive(self.length, f"{p}.length", "m")
        ok = isinstance(self.elements, (int, np.integer)) and not isinstance(self.elements, bool)
        if not ok or self.elements < 1:
            raise ModelError(
                f"{p}.elements: {self.elements!r} is not valid; expected an integer >= 1"
            )
        if self.theory not in THEORIES:
            raise ModelError(
                f"{p}.theory: {self.theory!r} is not valid; expected one of "
                + ", ".join(f'"{t}"' for t in THEORIES)
            )
        if self.dofs_per_node not in _LAYOUTS:
            raise ModelError(
                f"{p}.dofs_per_node: {self.dofs_per_node!r} is not valid; expected 2 (planar), "
                "4 (rotor: x, y, rx, ry) or 6 (3-D)"
            )
        if (self.discs or self.bearings) and self.dofs_per_node == 2:
            raise ModelError(
                f"{p}.dofs_per_node: 2 is not valid with discs or bearings; expected 4 (rotor: "
                "x, y, rx, ry) or 6"
            )
        if self.dofs_per_node == 4 and self.section.second_moment_x != self.section.second_moment_y:
            raise ModelError(
                f"{p}.section: second moments {self.section.second_moment_x!r} and "
                f"{self.section.second_moment_y!r} m^4 differ; expected an axisymmetric shaft "
                "section for dofs_per_node = 4"
            )
        if not isinstance(self.section, Section):
            raise ModelError(f"{p}.section: {self.section!r} is not valid; expected a Section")
        if not isinstance(self.material, Material):
            raise ModelError(f"{p}.material: {self.material!r} is not valid; expected a Material")
        if self.damping is not None and not isinstance(self.damping, Damping):
            raise ModelError(
                f"{p}.damping: {self.damping!r} is not valid; expected Rayleigh or ModalDamping"
            )
        for name in ("supports", "springs", "masses", "discs", "bearings"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        if self.rotary_inertia is None:
            object.__setattr__(self, "rotary_inertia", self.theory == "timoshenko")
        object.__setattr__(self, "elements", int(self.elements))
        self._assemble()

    # ---- geometry and addressing ----

    @property
    def node_directions(self) -> tuple[str, ...]:
        """The DOF directions of every node (before supports)."""
        return _LAYOUTS[self.dofs_per_node][0]

    @property
    def n_nodes(self) -> int:
        return self.elements + 1

    @property
    def node_positions(self) -> NDArray[np.float64]:
        """z of each node, m."""
        return np.linspace(0.0, float(self.length), self.n_nodes)

    @property
    def element_length(self) -> float:
        return float(self.length) / self.elements

    @property
    def total_mass(self) -> float:
        """ρAL plus the point masses and discs, kg."""
        m = self.material.density * self.section.area * self.length
        return float(m + sum(pm.mass for pm in self.masses) + sum(d.mass for d in self.discs))

    @property
    def dof_map(self) -> DofMap:
        """``(node index, direction)`` of each DOF of :attr:`structure`."""
        assert self.fe.dof_map is not None
        return self.fe.dof_map

    @property
    def n_dof(self) -> int:
        return self.fe.n_dof

    @cached_property
    def structure(self) -> Structure:
        """The dense :class:`~vibroimpact.Structure` (constrained DOFs removed)."""
        return self.fe.to_structure()

    def node_index(
        self,
        node: NodeRef | None = None,
        *,
        at: float | None = None,
        position: float | None = None,
        field_name: str = "node",
    ) -> int:
        """The index of a node given as ``node`` (0 … elements, ``"start"``, ``"middle"``,
        ``"end"``), ``at`` (fraction of the length, 0 … 1) or ``position`` (z in m). A
        position must fall on a node (within 1e-9 of the length)."""
        given = [
            k for k, v in (("node", node), ("at", at), ("position", position)) if v is not None
        ]
        base = field_name.rsplit(".", 1)[0] if "." in field_name else ""
        pre = f"{base}." if base else ""
        if len(given) != 1:
            raise ModelError(
                f"{pre}node: {len(given)} of node, at, position given; expected exactly one"
            )
        n = self.elements
        if node is not None:
            if isinstance(node, str):
                if node == "start":
                    return 0
                if node == "end":
                    return n
                if node == "middle" and n % 2 == 0:
                    return n // 2
                if node == "middle":
                    raise ModelError(
                        f"{pre}node: 'middle' is not valid; expected an even number of elements "
                        f"(there are {n}, so no node lies at the middle)"
                    )
            ok = isinstance(node, (int, np.integer)) and not isinstance(node, bool)
            if not ok or not 0 <= int(node) <= n:
                raise ModelError(
                    f"{pre}node: {node!r} is not valid; expected a node index 0 .. {n} or one of "
                    + ", ".join(f'"{s}"' for s in NODE_NAMES)
                )
            return int(node)
        if at is not None:
            frac = _number(at, f"{pre}at", "a fraction of the length with 0 <= at <= 1")
            key, shown = "at", at
        else:
            frac = _number(position, f"{pre}position", "a position in m") / self.length
            key, shown = "position", position
        if not -1e-12 <= frac <= 1 + 1e-12:
            raise ModelError(
                f"{pre}{key}: {shown!r} is not valid; expected a point on the beam "
                f"({'0 <= at <= 1' if key == 'at' else f'0 <= position <= {self.length!r} m'})"
            )
        x = frac * n
        i = round(x)
        if abs(x - i) > 1e-9 * n:
            lo, hi = math.floor(x), math.ceil(x)
            raise ModelError(
                f"{pre}{key}: {shown!r} is not valid; expected a point at a node (the nearest "
                f"nodes are {lo} at {lo / n:.6g} and {hi} at {hi / n:.6g} of the length; "
                "change elements or the position)"
            )
        return i

    def node_indices(self, nodes: NodeRef | Iterable[NodeRef] | str = "all") -> list[int]:
        """Node indices of ``"all"``, one node reference or a list of them."""
        if isinstance(nodes, str) and nodes == "all":
            return list(range(self.n_nodes))
        if isinstance(nodes, (str, int, np.integer)):
            return [self.node_index(nodes)]  # type: ignore[arg-type]
        return [self.node_index(n) for n in nodes]

    def _direction(self, direction: str | int, field_name: str = "direction") -> str:
        try:
            d = direction_name(direction)
        except ModelError:
            d = ""
        if d not in self.node_directions:
            extra = (
                " (a planar beam; use dofs_per_node = 4 for a rotor, 6 for 3-D)"
                if self.dofs_per_node == 2 else ""
            )
            raise ModelError(
                f"{field_name}: {direction!r} is not valid; expected one of "
                + ", ".join(self.node_directions)
                + extra
            )
        return d

    def full_dof(self, node: int, direction: str) -> int:
        """Index of ``(node, direction)`` before the supports remove DOFs."""
        return node * self.dofs_per_node + self.node_directions.index(direction)

    def dof(
        self,
        node: NodeRef | None = None,
        *,
        at: float | None = None,
        position: float | None = None,
        direction: str | int = "x",
    ) -> int:
        """The DOF index (in :attr:`structure`) of ``direction`` at a node given by ``node``,
        ``at`` or ``position`` (see :meth:`node_index`)."""
        i = self.node_index(node, at=at, position=position)
        d = self._direction(direction)
        try:
            return self.dof_map.index(i, d)
        except ModelError:
            raise ModelError(
                f"direction: {direction!r} is not valid at node {i}; expected a DOF that no "
                "support fixes"
            ) from None

    def dofs(
        self, nodes: NodeRef | Iterable[NodeRef] | str = "all", direction: str = "x"
    ) -> list[int]:
        """DOF indices of ``direction`` at ``nodes`` (``"all"``: every node where that DOF is
        free; an explicit list must not name a fixed DOF)."""
        d = self._direction(direction)
        if isinstance(nodes, str) and nodes == "all":
            return [
                i
                for i, (_, dd) in enumerate(
                    zip(self.dof_map.nodes, self.dof_map.directions, strict=True)
                )
                if dd == d
            ]
        return [self.dof(n, direction=d) for n in self.node_indices(nodes)]

    def gap(
        self,
        law: ContactLaw,
        *,
        node: NodeRef | None = None,
        at: float | None = None,
        position: float | None = None,
        direction: str = "x",
        clearance: float = 0.0,
        side: str = "both",
        name: str | None = None,
    ) -> Gap:
        """A :class:`~vibroimpact.Gap` on ``direction`` at a node (``node``/``at``/
        ``position``); ``clearance`` in m; walls on ``side`` (default both)."""
        i = self.node_index(node, at=at, position=position)
        return Gap(
            dof=self.dof(i, direction=direction),
            law=law,
            clearance=clearance,
            side=side,  # type: ignore[arg-type]
            name=name if name is not None else f"node {i} {direction}",
        )

    def load(
        self,
        load_type: type[Load],
        *,
        nodes: NodeRef | Iterable[NodeRef] | str = "all",
        direction: str = "x",
        **params: Any,
    ) -> Load:
        """A load of ``load_type`` (e.g. :class:`~vibroimpact.HarmonicLoad`) with ``params``,
        the same force on ``direction`` at each of ``nodes``."""
        dofs = self.dofs(nodes, direction)
        return load_type(dof=dofs if len(dofs) > 1 else dofs[0], **params)

    def model(
        self,
        gaps: Sequence[Gap] = (),
        loads: Sequence[Load] = (),
        initial_displacement: ArrayLike | None = None,
        initial_velocity: ArrayLike | None = None,
    ) -> Model:
        """A :class:`~vibroimpact.Model` of this beam."""
        return Model(
            self.structure,
            gaps=gaps,
            loads=loads,
            initial_displacement=initial_displacement,
            initial_velocity=initial_velocity,
        )

    def node_values(self, vector: ArrayLike, direction: str = "x") -> NDArray[np.float64]:
        """The ``direction`` component at every node of a DOF vector (or of each row of a
        time history, rows × DOFs); constrained DOFs give 0."""
        d = self._direction(direction)
        v = np.asarray(vector, dtype=float)
        out = np.zeros((*v.shape[:-1], self.n_nodes))
        m = self.dof_map
        for i, (node, dd) in enumerate(zip(m.nodes, m.directions, strict=True)):
            if dd == d:
                out[..., node] = v[..., i]
        return out

    def translation_vector(self, direction: str = "x") -> NDArray[np.float64]:
        """A unit rigid translation along ``direction`` as a DOF vector (1 on those DOFs)."""
        d = self._direction(direction)
        return np.array([1.0 if dd == d else 0.0 for dd in self.dof_map.directions])

    # ---- assembly ----

    def _assemble(self) -> None:
        ndpn = self.dofs_per_node
        n_full = self.n_nodes * ndpn
        try:
            ke, me = element_matrices(
                self.section,
                self.material,
                self.element_length,
                theory=self.theory,
                rotary_inertia=bool(self.rotary_inertia),
                lumped=self.lumped_mass,
                dofs_per_node=ndpn,
            )
        except (OverflowError, ZeroDivisionError):
            ke = me = np.array([np.inf])
        if not (np.all(np.isfinite(ke)) and np.all(np.isfinite(me))):
            raise ModelError(
                f"structure.length: {self.length!r} m over {self.elements} elements gives "
                "non-finite element matrices; expected a length, section and material whose "
                "E·I/L³ and ρ·A·L are finite in floating point"
            )
        nel = self.elements
        local = np.arange(2 * ndpn)
        rows, cols, kv, mv = [], [], [], []
        for e in range(nel):
            idx = e * ndpn + local
            r, c = np.meshgrid(idx, idx, indexing="ij")
            rows.append(r.ravel())
            cols.append(c.ravel())
            kv.append(ke.ravel())
            mv.append(me.ravel())
        r_all, c_all = np.concatenate(rows), np.concatenate(cols)
        k = sp.coo_array((np.concatenate(kv), (r_all, c_all)), shape=(n_full, n_full)).tocsr()
        m = sp.coo_array((np.concatenate(mv), (r_all, c_all)), shape=(n_full, n_full)).tocsr()
        g = self._gyroscopic(r_all, c_all) if self.dofs_per_node > 2 else None
        k_add = np.zeros(n_full)
        m_add = np.zeros(n_full)
        c_add = np.zeros(n_full)
        fixed: set[int] = set()
        translations = [d for d in self.node_directions if not d.startswith("r")]
        rotations = [d for d in self.node_directions if d.startswith("r")]
        for i, s in enumerate(self.supports):
            p = f"structure.supports[{i}]"
            if not isinstance(s, Support):
                raise ModelError(f"{p}: {s!r} is not valid; expected a Support")
            node = self.node_index(s.node, at=s.at, field_name=f"{p}.node")
            if s.directions is not None:
                dirs = [self._direction(d, f"{p}.directions") for d in s.directions]
            elif s.kind == "fixed":
                dirs = list(self.node_directions)
            elif s.kind == "pinned":
                dirs = translations
            elif s.kind == "free":
                dirs = []
            else:
                raise ModelError(
                    f"{p}.kind: {s.kind!r} is not valid; expected one of "
                    + ", ".join(f'"{k}"' for k in SUPPORT_KINDS)
                )
            fixed.update(self.full_dof(node, d) for d in dirs)
        for i, s in enumerate(self.springs):
            p = f"structure.springs[{i}]"
            if not isinstance(s, Spring):
                raise ModelError(f"{p}: {s!r} is not valid; expected a Spring")
            node = self.node_index(s.node, at=s.at, field_name=f"{p}.node")
            d = self._direction(s.direction, f"{p}.direction")
            unit = "N·m/rad" if d.startswith("r") else "N/m"
            k_add[self.full_dof(node, d)] += _nonnegative(s.stiffness, f"{p}.stiffness", unit)
        for i, pm in enumerate(self.masses):
            p = f"structure.masses[{i}]"
            if not isinstance(pm, PointMass):
                raise ModelError(f"{p}: {pm!r} is not valid; expected a PointMass")
            node = self.node_index(pm.node, at=pm.at, field_name=f"{p}.node")
            mass = _nonnegative(pm.mass, f"{p}.mass", "kg")
            inertia = _nonnegative(pm.rotary_inertia, f"{p}.rotary_inertia", "kg·m^2")
            for d in translations:
                m_add[self.full_dof(node, d)] += mass
            for d in rotations:
                m_add[self.full_dof(node, d)] += inertia
        for i, disc in enumerate(self.discs):
            p = f"structure.discs[{i}]"
            if not isinstance(disc, Disc):
                raise ModelError(f"{p}: {disc!r} is not valid; expected a Disc")
            node = self.node_index(disc.node, at=disc.at, field_name=f"{p}.node")
            mass = _nonnegative(disc.mass, f"{p}.mass", "kg")
            diametral = _nonnegative(disc.diametral_inertia, f"{p}.diametral_inertia", "kg·m^2")
            polar = _nonnegative(disc.polar_inertia, f"{p}.polar_inertia", "kg·m^2")
            for d, value in (("x", mass), ("y", mass), ("rx", diametral), ("ry", diametral)):
                m_add[self.full_dof(node, d)] += value
            assert g is not None  # a rotor's layout
            rx, ry = self.full_dof(node, "rx"), self.full_dof(node, "ry")
            g[rx, ry] += polar
            g[ry, rx] -= polar
        for i, b in enumerate(self.bearings):
            p = f"structure.bearings[{i}]"
            if not isinstance(b, Bearing):
                raise ModelError(f"{p}: {b!r} is not valid; expected a Bearing")
            node = self.node_index(b.node, at=b.at, field_name=f"{p}.node")
            for d, key, target, unit in (("x", "kxx", k_add, "N/m"), ("y", "kyy", k_add, "N/m"),
                                         ("x", "cxx", c_add, "N·s/m"),
                                         ("y", "cyy", c_add, "N·s/m")):
                target[self.full_dof(node, d)] += _nonnegative(getattr(b, key), f"{p}.{key}",
                                                               unit)
        k = k + sp.diags_array(k_add, format="csr")
        m = m + sp.diags_array(m_add, format="csr")
        free = np.array([i for i in range(n_full) if i not in fixed], dtype=np.int64)
        if free.size == 0:
            raise ModelError("structure.supports: every DOF is fixed; expected a free DOF")
        k = sp.csr_array(k[free][:, free])
        m = sp.csr_array(m[free][:, free])
        k = 0.5 * (k + k.T)
        m = 0.5 * (m + m.T)
        dof_map = DofMap(
            [int(i) // ndpn for i in free], [self.node_directions[int(i) % ndpn] for i in free]
        )
        c = None if self.damping is None else self.damping.matrix(m, k)
        if c_add.any():
            dampers = sp.diags_array(c_add[free], format="csr")
            c = dampers if c is None else sp.csr_array(c + dampers)
        if g is not None:
            g = sp.csr_array(g[free][:, free])
            g = 0.5 * (g - g.T)
        spin = _number(self.spin_speed, "structure.spin_speed", "a spin speed in rad/s")
        object.__setattr__(self, "free_dofs", free)
        object.__setattr__(self, "fe", FEStructure(m, k, c, dof_map, gyroscopic=g,
                                                   spin_speed=spin))

    def _gyroscopic(self, rows: NDArray[np.int64], cols: NDArray[np.int64]) -> sp.lil_array:
        """The shaft's assembled gyroscopic matrix (zero without rotary inertia), before
        supports; the discs add theirs."""
        n_full = self.n_nodes * self.dofs_per_node
        if not self.rotary_inertia:
            return sp.lil_array((n_full, n_full))
        ge = shaft_gyroscopic(self.section, self.material, self.element_length,
                              theory=self.theory, dofs_per_node=self.dofs_per_node)
        values = np.tile(ge.ravel(), self.elements)
        return sp.coo_array((values, (rows, cols)), shape=(n_full, n_full)).tolil()


def _nonnegative(value: Any, name: str, unit: str) -> float:
    x = _number(value, name, f"a number >= 0 in {unit}")
    if x < 0:
        raise ModelError(f"{name}: {value!r} is not valid; expected a number >= 0 in {unit}")
    return x


# --------------------------------------------------------------------------------------------
# From a model file's [structure] table
# --------------------------------------------------------------------------------------------


def _section_from_table(s: Mapping[str, Any]) -> Section:
    kind = s.get("kind")
    kappa = s.get("shear_coefficient")
    if kind == "circle":
        return Section.circle(s["diameter"], shear_coefficient=kappa)
    if kind == "tube":
        return Section.tube(
            s["outer_diameter"],
            s.get("wall_thickness"),
            inner_diameter=s.get("inner_diameter"),
            shear_coefficient=kappa,
        )
    if kind == "rectangle":
        return Section.rectangle(s["size_x"], s["size_y"], shear_coefficient=kappa)
    return Section.user(
        s["area"],
        s["second_moment"],
        second_moment_y=s.get("second_moment_y"),
        torsion_constant=s.get("torsion_constant"),
        shear_coefficient=kappa,
    )


def beam_from_table(s: Mapping[str, Any]) -> Beam:
    """A :class:`Beam` from the checked values of a model file's ``[structure]`` table with
    ``kind = "beam"`` (docs/model-file.md); errors name the TOML path."""
    material = Material(**{k: s["material"][k] for k in ("youngs_modulus", "poisson", "density")})
    section = _section_from_table(s["section"])
    supports = [
        Support(
            node=t.get("node"),
            at=t.get("at"),
            kind=t.get("kind", "fixed"),
            directions=t.get("directions"),
        )
        for t in s.get("supports", [])
    ]
    springs = [
        Spring(
            stiffness=t["stiffness"],
            direction=t.get("direction", "x"),
            node=t.get("node"),
            at=t.get("at"),
        )
        for t in s.get("springs", [])
    ]
    masses = [
        PointMass(
            mass=t["mass"],
            node=t.get("node"),
            at=t.get("at"),
            rotary_inertia=t.get("rotary_inertia", 0.0),
        )
        for t in s.get("masses", [])
    ]
    damping = damping_from_table(s["damping"]) if s.get("damping") else None
    discs = [
        Disc(mass=t["mass"], node=t.get("node"), at=t.get("at"),
             polar_inertia=t.get("polar_inertia", 0.0),
             diametral_inertia=t.get("diametral_inertia", 0.0))
        for t in s.get("discs", [])
    ]
    bearings = [
        Bearing(node=t.get("node"), at=t.get("at"),
                **{k: t.get(k, 0.0) for k in ("kxx", "kyy", "cxx", "cyy")})
        for t in s.get("bearings", [])
    ]
    return Beam(
        length=s["length"],
        elements=s["elements"],
        section=section,
        material=material,
        theory=s.get("theory", "timoshenko"),
        lumped_mass=bool(s.get("lumped_mass", False)),
        rotary_inertia=s.get("rotary_inertia"),
        dofs_per_node=s.get("dofs_per_node", 2),
        supports=supports,
        springs=springs,
        masses=masses,
        damping=damping,
        discs=discs,
        bearings=bearings,
        spin_speed=s.get("spin_speed", model_default("structure", "spin_speed")),
    )
