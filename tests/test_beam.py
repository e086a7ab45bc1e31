"""Beam finite elements (vibroimpact.fe.beam) against closed forms: Euler–Bernoulli βL values,
the Timoshenko frequency equation (solved here with brentq), bars in tension and torsion, the
total mass, rigid-body modes, damping, and placing gaps and loads by node or position."""

from __future__ import annotations

import math

import numpy as np
import pytest
import vibroimpact as vi
from scipy.optimize import brentq
from vibroimpact.errors import ModelError
from vibroimpact.fe import (
    Beam,
    Material,
    ModalDamping,
    PointMass,
    Rayleigh,
    Section,
    Spring,
    Support,
    cowper_shear_coefficient,
    modes,
)
from vibroimpact.fe.beam import bending_matrices, element_matrices

STEEL = Material(youngs_modulus=207e9, poisson=0.3, density=7850.0)
SHAFT = Material(youngs_modulus=207e9, poisson=0.3, density=34410.0)
TUBE = Section.tube(outer_diameter=0.190, wall_thickness=0.005)

#: βL of the first modes (Blevins, Formulas for Natural Frequency and Mode Shape, Table 8-1).
FREE_FREE = (4.730040745, 7.853204624, 10.995607838)
CANTILEVER = 1.875104069


def beta_l(beam: Beam, frequencies: np.ndarray) -> np.ndarray:
    """βL from f = (βL)² / (2π L²) · sqrt(EI / ρA)."""
    ei = beam.material.youngs_modulus * beam.section.second_moment_x
    rho_a = beam.material.density * beam.section.area
    w = 2 * math.pi * np.asarray(frequencies)
    return np.sqrt(w * beam.length**2 / math.sqrt(ei / rho_a))


# ------------------------------------------------------------------------------------------
# Euler–Bernoulli: convergence to the analytical βL
# ------------------------------------------------------------------------------------------


def test_euler_bernoulli_free_free_converges_to_analytical_beta_l() -> None:
    errors = []
    for n in (4, 8, 16, 32):
        beam = Beam(1.0, n, Section.circle(0.02), STEEL, theory="euler-bernoulli")
        m = modes(beam, 3)
        assert m.rigid_body_modes == 2
        errors.append(np.abs(beta_l(beam, m.elastic_frequencies_hz) / FREE_FREE - 1))
    errors_arr = np.array(errors)
    assert np.all(np.diff(errors_arr, axis=0) < 0)  # every mode improves with refinement
    assert errors_arr[-1].max() < 1e-4
    assert errors_arr[-2].max() / errors_arr[-1].max() > 10  # cubic Hermite: O(h^4)


def test_euler_bernoulli_cantilever_converges_to_1_8751() -> None:
    errors = []
    for n in (2, 4, 8):
        beam = Beam(2.0, n, Section.rectangle(0.05, 0.02), STEEL, theory="euler-bernoulli",
                    supports=[Support(node="start", kind="fixed")])
        m = modes(beam, 1)
        assert m.rigid_body_modes == 0
        errors.append(abs(beta_l(beam, m.elastic_frequencies_hz[:1])[0] / CANTILEVER - 1))
    assert errors[0] > errors[1] > errors[2]
    assert errors[-1] < 1e-4


def test_pinned_pinned_euler_bernoulli_is_n_pi() -> None:
    beam = Beam(1.5, 24, Section.circle(0.03), STEEL, theory="euler-bernoulli",
                supports=[Support(node="start", kind="pinned"), Support(node="end", kind="pinned")])
    bl = beta_l(beam, modes(beam, 3).elastic_frequencies_hz)
    np.testing.assert_allclose(bl, [math.pi, 2 * math.pi, 3 * math.pi], rtol=1e-5)


# ------------------------------------------------------------------------------------------
# Timoshenko: the frequency equation of a thick beam
# ------------------------------------------------------------------------------------------


def timoshenko_frequencies(
    beam: Beam, ends: tuple[str, str], count: int, f_max: float
) -> np.ndarray:
    """Roots of the Timoshenko frequency equation (Timoshenko 1921; Huang, J. Appl. Mech.
    28:579, 1961) below ``f_max`` Hz, for ends ``"free"`` or ``"clamped"``.

    With a = κGA, b = EI, the motion e^{sx} satisfies a·b·s⁴ + (a ρI + b ρA) ω² s² +
    ρA ω² (ρI ω² − a) = 0, roots s = ±α, ±iβ below the cut-off ω² = a/ρI. The general
    solution w = C1 cosh αx + C2 sinh αx + C3 cos βx + C4 sin βx has the section rotation
    ψ = C1 p sinh + C2 p cosh + C3 q sin − C4 q cos with p = (aα² + ρAω²)/(aα),
    q = (ρAω² − aβ²)/(aβ). Free: EIψ' = 0 and a(w' − ψ) = 0; clamped: w = ψ = 0.
    The frequencies are the zeros of the 4×4 determinant, bracketed on a grid, refined with
    brentq."""
    mat, sec = beam.material, beam.section
    a = sec.shear_coefficient_for(mat.poisson) * mat.shear_modulus * sec.area
    b = mat.youngs_modulus * sec.second_moment_x
    rho_a, rho_i, length = mat.density * sec.area, mat.density * sec.second_moment_x, beam.length

    def det(w: float) -> float:
        c2, c1 = a * b, (a * rho_i + b * rho_a) * w**2
        c0 = rho_a * w**2 * (rho_i * w**2 - a)
        disc = math.sqrt(c1 * c1 - 4 * c2 * c0)
        al = math.sqrt((-c1 + disc) / (2 * c2))
        be = math.sqrt((c1 + disc) / (2 * c2))
        p = (a * al**2 + rho_a * w**2) / (a * al)
        q = (rho_a * w**2 - a * be**2) / (a * be)

        def rows(x: float, end: str) -> list[list[float]]:
            ch, sh = math.cosh(al * x), math.sinh(al * x)
            c, s = math.cos(be * x), math.sin(be * x)
            if end == "clamped":
                return [[ch, sh, c, s], [p * sh, p * ch, q * s, -q * c]]
            return [
                [p * al * ch, p * al * sh, q * be * c, q * be * s],
                [(al - p) * sh, (al - p) * ch, -(be + q) * s, (be + q) * c],
            ]

        return float(np.linalg.det(np.array(rows(0.0, ends[0]) + rows(length, ends[1]))))

    grid = np.linspace(2 * math.pi, 2 * math.pi * f_max, 6000)
    values = [det(w) for w in grid]
    roots = [
        brentq(det, grid[i], grid[i + 1], xtol=1e-10, rtol=1e-14)
        for i in range(len(grid) - 1)
        if np.sign(values[i]) != np.sign(values[i + 1])
    ]
    assert len(roots) >= count
    return np.array(roots[:count]) / (2 * math.pi)


@pytest.mark.parametrize(
    ("section", "material", "supports", "ends", "f_max"),
    [
        (TUBE, SHAFT, [], ("free", "free"), 2500.0),  # the paper's shaft: L/r = 15
        (Section.circle(0.2), STEEL, [Support(node="start")], ("clamped", "free"), 2500.0),
    ],
    ids=["hollow-shaft-free-free", "thick-cantilever"],
)
def test_timoshenko_converges_to_the_frequency_equation(
    section: Section, material: Material, supports: list[Support], ends: tuple[str, str],
    f_max: float,
) -> None:
    exact = timoshenko_frequencies(Beam(1.0, 1, section, material), ends, 3, f_max)
    f = {n: modes(Beam(1.0, n, section, material, supports=supports), 3).elastic_frequencies_hz
         for n in (40, 80, 160)}
    err = {n: np.abs(f[n] / exact - 1) for n in f}
    assert np.all(err[80] < err[40]) and np.all(err[160] < err[80])
    assert err[160].max() < 2e-4
    # the error falls as h² (shear-dominated elements); Richardson's extrapolation of the two
    # finest meshes lands on the frequency equation's roots
    assert np.all(err[80] / err[160] > 3.5)
    np.testing.assert_allclose((4 * f[160] - f[80]) / 3, exact, rtol=2e-6)


def test_timoshenko_tends_to_euler_bernoulli_for_a_slender_beam() -> None:
    slender = Section.circle(0.005)  # L/d = 200
    tim = modes(Beam(1.0, 40, slender, STEEL), 3).elastic_frequencies_hz
    eb = modes(Beam(1.0, 40, slender, STEEL, theory="euler-bernoulli"), 3).elastic_frequencies_hz
    np.testing.assert_allclose(tim, eb, rtol=5e-4)  # shift ≈ (βr)²(1 + E/κG)/2
    assert np.all(tim < eb)


def test_thick_beam_shear_and_rotary_inertia_lower_the_frequencies() -> None:
    full = modes(Beam(1.0, 20, TUBE, SHAFT), 3).elastic_frequencies_hz
    no_rotary = modes(Beam(1.0, 20, TUBE, SHAFT, rotary_inertia=False), 3).elastic_frequencies_hz
    eb = modes(Beam(1.0, 20, TUBE, SHAFT, theory="euler-bernoulli"), 3).elastic_frequencies_hz
    assert np.all(full < no_rotary) and np.all(no_rotary < eb)


# ------------------------------------------------------------------------------------------
# Element matrices, mass and rigid-body modes
# ------------------------------------------------------------------------------------------


def test_cowper_shear_coefficients() -> None:
    nu = 0.3
    assert cowper_shear_coefficient("circle", nu) == pytest.approx(6 * 1.3 / 8.8)
    assert cowper_shear_coefficient("rectangle", nu) == pytest.approx(13 / 15.3)
    # a tube tends to the thin-walled limit 2(1+ν)/(4+3ν) and to the circle for m -> 0
    assert cowper_shear_coefficient("tube", nu, 0.9999) == pytest.approx(2.6 / 4.9, rel=1e-6)
    assert cowper_shear_coefficient("tube", nu, 0.0) == pytest.approx(6 * 1.3 / 8.8)
    assert TUBE.shear_coefficient_for(nu) == pytest.approx(0.53123, abs=1e-5)
    assert Section.user(1.0, 1.0, shear_coefficient=0.7).shear_coefficient_for(nu) == 0.7
    with pytest.raises(ModelError, match="shear_coefficient: missing"):
        Section.user(1.0, 1.0).shear_coefficient_for(nu)


@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
@pytest.mark.parametrize("lumped", [False, True])
@pytest.mark.parametrize("dofs_per_node", [2, 6])
def test_mass_matrix_integrates_to_the_total_mass(
    theory: str, lumped: bool, dofs_per_node: int
) -> None:
    beam = Beam(1.0, 7, TUBE, SHAFT, theory=theory, lumped_mass=lumped,
                dofs_per_node=dofs_per_node, masses=[PointMass(2.5, node="end")])
    assert beam.total_mass == pytest.approx(SHAFT.density * TUBE.area + 2.5)
    assert SHAFT.density * TUBE.area == pytest.approx(100.0, abs=0.01)  # the paper's 100 kg
    m = beam.structure.mass
    for d in ("x", "y", "z")[: 1 if dofs_per_node == 2 else 3]:
        r = beam.translation_vector(d)
        assert r @ m @ r == pytest.approx(beam.total_mass, rel=1e-12)


def test_element_matrices_are_symmetric_and_rigid_motions_are_free() -> None:
    for theory in ("euler-bernoulli", "timoshenko"):
        k, m = element_matrices(TUBE, SHAFT, 0.1, theory=theory, dofs_per_node=6)
        np.testing.assert_allclose(k, k.T, atol=1e-9 * np.abs(k).max())
        np.testing.assert_allclose(m, m.T, atol=1e-15)
        assert np.all(np.linalg.eigvalsh(m) > 0)
        # rigid translation in x and rotation about y (x = z·θ, ry = θ) cost no strain energy
        L = 0.1
        for u in (np.array([1.0, 0, 1.0, 0]), np.array([0.0, 1.0, L, 1.0])):
            kb, _ = bending_matrices(1e6, None if theory == "euler-bernoulli" else 1e7, 1, 1, L)
            np.testing.assert_allclose(kb @ u, 0.0, atol=1e-6)


@pytest.mark.parametrize(("dofs_per_node", "rigid"), [(2, 2), (6, 6)])
def test_free_free_beam_has_zero_frequency_rigid_body_modes(dofs_per_node: int, rigid: int) -> None:
    beam = Beam(1.0, 10, TUBE, SHAFT, dofs_per_node=dofs_per_node)
    m = modes(beam, 4)
    assert m.rigid_body_modes == rigid
    assert np.all(m.frequencies_hz[:rigid] == 0.0)
    # numerically zero: far below the first elastic mode
    assert np.abs(m.eigenvalues[:rigid]).max() < 1e-8 * m.eigenvalues[rigid]
    k = beam.structure.stiffness
    for j in range(rigid):
        phi = m.shapes[:, j]
        assert phi @ k @ phi < 1e-8 * m.eigenvalues[rigid]


def test_three_d_beam_bending_axial_and_torsion() -> None:
    beam = Beam(1.0, 40, Section.rectangle(0.04, 0.02), STEEL, dofs_per_node=6,
                theory="euler-bernoulli")
    m = modes(beam, 30)
    f = m.elastic_frequencies_hz
    # bending in both planes: βL = 4.73 with I_x = size_y size_x³/12 and I_y = size_x size_y³/12
    rho_a = STEEL.density * beam.section.area
    for i in (beam.section.second_moment_x, beam.section.second_moment_y):
        f1 = FREE_FREE[0] ** 2 / (2 * math.pi) * math.sqrt(STEEL.youngs_modulus * i / rho_a)
        assert np.min(np.abs(f / f1 - 1)) < 1e-4
    # axial free-free bar: f = c / 2L
    f_axial = math.sqrt(STEEL.youngs_modulus / STEEL.density) / 2
    assert np.min(np.abs(f / f_axial - 1)) < 2e-3
    # torsion: f = sqrt(GJ / ρ I_p) / 2L
    sec = beam.section
    f_torsion = math.sqrt(STEEL.shear_modulus * sec.torsion_constant
                          / (STEEL.density * sec.polar_moment)) / 2
    assert np.min(np.abs(f / f_torsion - 1)) < 2e-3


def test_tube_bends_alike_in_both_planes() -> None:
    m = modes(Beam(1.0, 10, TUBE, SHAFT, dofs_per_node=6), 4)
    planar = modes(Beam(1.0, 10, TUBE, SHAFT), 2).elastic_frequencies_hz
    f = m.elastic_frequencies_hz
    np.testing.assert_allclose(f[:2], [planar[0]] * 2, rtol=1e-9)


def test_springs_and_point_masses() -> None:
    # a stiff, light rod on a soft spring with a heavy end mass: f ≈ sqrt(k/m)/2π
    rod = Beam(0.1, 4, Section.circle(0.05), STEEL, theory="euler-bernoulli",
               supports=[Support(node="start", directions=["ry"])],
               springs=[Spring(1e4, direction="x", node="start")],
               masses=[PointMass(100.0, node="end")])
    total = rod.total_mass
    f = modes(rod, 1).elastic_frequencies_hz[0]
    assert f == pytest.approx(math.sqrt(1e4 / total) / (2 * math.pi), rel=1e-4)


# ------------------------------------------------------------------------------------------
# Damping
# ------------------------------------------------------------------------------------------


def modal_ratios(beam: Beam, n: int) -> np.ndarray:
    m = modes(beam, n)
    phi, w = m.elastic_shapes, 2 * math.pi * m.elastic_frequencies_hz
    return np.diag(phi.T @ beam.structure.damping @ phi) / (2 * w)


def test_rayleigh_damping_from_two_frequencies_and_ratios() -> None:
    undamped = modes(Beam(1.0, 20, TUBE, SHAFT), 3).elastic_frequencies_hz
    r = Rayleigh.from_frequencies(undamped[0], undamped[2], 0.02, 0.05)
    beam = Beam(1.0, 20, TUBE, SHAFT, damping=r)
    z = modal_ratios(beam, 3)
    assert z[0] == pytest.approx(0.02, rel=1e-9)
    assert z[2] == pytest.approx(0.05, rel=1e-9)
    assert z[1] == pytest.approx(r.damping_ratio(undamped[1]), rel=1e-9)
    s = beam.structure
    c = s.damping.toarray()
    np.testing.assert_allclose(
        c, (r.mass_coefficient * s.mass + r.stiffness_coefficient * s.stiffness).toarray(),
        rtol=1e-12, atol=1e-12 * np.abs(c).max())
    with pytest.raises(ModelError, match=r"^damping\.frequencies"):
        Rayleigh.from_frequencies(100.0, 100.0, 0.01, 0.01)


def test_modal_damping_gives_each_mode_its_ratio_and_leaves_rigid_modes_undamped() -> None:
    beam = Beam(1.0, 12, TUBE, SHAFT, damping=ModalDamping([0.01, 0.02, 0.03]))
    np.testing.assert_allclose(modal_ratios(beam, 5), [0.01, 0.02, 0.03, 0.03, 0.03], rtol=1e-7)
    rigid = modes(beam, 1).shapes[:, :2]
    c = beam.structure.damping
    assert np.abs(c @ rigid).max() < 1e-6 * np.abs(c).max()


# ------------------------------------------------------------------------------------------
# Addressing DOFs: nodes, positions, directions; gaps and loads
# ------------------------------------------------------------------------------------------


def test_dof_addressing_by_node_and_position() -> None:
    beam = Beam(2.0, 8, TUBE, SHAFT)
    assert beam.node_index("start") == 0 and beam.node_index("end") == 8
    assert beam.node_index("middle") == 4
    assert beam.node_index(at=0.25) == 2 and beam.node_index(position=1.5) == 6
    assert beam.dof(node="end", direction="x") == 16
    assert beam.dof(at=0.5, direction="ry") == 9
    assert beam.dofs("all", "x") == list(range(0, 18, 2))
    assert beam.dofs(["start", 3], "x") == [0, 6]
    np.testing.assert_allclose(beam.node_positions, np.linspace(0, 2, 9))
    assert beam.dof_map.labels()[:3] == ["0.x", "0.ry", "1.x"]


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda b: b.dof(at=0.3), r"^at: 0.3 is not valid; expected a point at a node"),
        (lambda b: b.dof(node=9), r"^node: 9 is not valid; expected a node index 0 .. 8"),
        (lambda b: b.dof(node="top"), r"^node: 'top' is not valid"),
        (lambda b: b.dof(at=1.5), r"^at: 1.5 is not valid; expected a point on the beam"),
        (lambda b: b.dof(node=1, direction="y"), r"^direction: 'y' is not valid; expected one "
         r"of x, ry \(a planar beam"),
        (lambda b: b.dof(node=1, at=0.5), r"^node: 2 of node, at, position given"),
        (lambda b: Beam(1.0, 7, TUBE, SHAFT).node_index("middle"), r"^node: 'middle' is not valid"),
    ],
)
def test_addressing_mistakes_are_one_line_errors(call, message: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ModelError, match=message) as info:
        call(Beam(1.0, 8, TUBE, SHAFT))
    assert "\n" not in str(info.value)


def test_constrained_dofs_are_removed_and_cannot_hold_a_gap() -> None:
    beam = Beam(1.0, 4, TUBE, SHAFT, supports=[Support(node="start", kind="pinned")])
    assert beam.n_dof == 9  # 10 minus the fixed x at node 0
    assert beam.dof_map.labels()[0] == "0.ry"
    with pytest.raises(ModelError, match="no support fixes"):
        beam.dof(node="start", direction="x")
    assert 0 not in beam.node_values(np.ones(beam.n_dof))[1:]  # every other node has x
    assert beam.node_values(np.ones(beam.n_dof))[0] == 0.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"length": -1.0}, r"^structure.length: -1.0 is not valid; expected a number > 0 in m$"),
        ({"elements": 0}, r"^structure.elements: 0 is not valid; expected an integer >= 1$"),
        ({"theory": "bernoulli"}, r"^structure.theory: 'bernoulli' is not valid"),
        ({"dofs_per_node": 3}, r"^structure.dofs_per_node: 3 is not valid"),
        ({"supports": [Support(node=99)]}, r"^structure.supports\[0\].node: 99 is not valid"),
        ({"supports": [Support(node=0, kind="clamped")]}, r"^structure.supports\[0\].kind"),
        ({"springs": [Spring(-1.0, node=0)]}, r"^structure.springs\[0\].stiffness: -1.0"),
        ({"masses": [PointMass(1.0, at=0.33)]}, r"^structure.masses\[0\].at: 0.33 is not valid"),
    ],
)
def test_beam_mistakes_name_the_field(kwargs: dict, message: str) -> None:
    args = {"length": 1.0, "elements": 4, "section": TUBE, "material": SHAFT, **kwargs}
    with pytest.raises(ModelError, match=message):
        Beam(**args)


def test_section_and_material_mistakes() -> None:
    with pytest.raises(ModelError, match=r"^structure.section.wall_thickness: 0.1 is not valid"):
        Section.tube(0.19, 0.1)
    with pytest.raises(ModelError, match=r"^structure.section.diameter: 0 is not valid"):
        Section.circle(0)
    with pytest.raises(ModelError, match=r"^structure.material.poisson: 0.5 is not valid"):
        Material(1e9, 0.5, 1000.0)


def test_gaps_and_loads_placed_by_node_run() -> None:
    beam = Beam(1.0, 10, TUBE, SHAFT, supports=[Support(node="start")])
    law = vi.contact.Hertz(stiffness=1e10)
    gap = beam.gap(law, node="end", direction="x", clearance=2e-6, side="both")
    load = beam.load(vi.HarmonicLoad, nodes="all", direction="x", amplitude=500.0, frequency=40.0)
    assert gap.dof == beam.dof(node="end") and gap.side == "both"
    assert load.dofs == tuple(beam.dofs("all", "x"))  # node 0's x is fixed
    r = vi.simulate(beam.model([gap], [load]), t_end=0.05, dt=1e-5, dofs=[gap.dof])
    assert r.complete and len(r.impacts) > 0
