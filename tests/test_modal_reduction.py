"""Craig–Bampton reduction (vibroimpact.fe.reduction): exact with all modes, exact for static
boundary loads and generalized forces, Rayleigh–Ritz bounds on the frequencies, and — the
issue's check — the reduced model's impact response matches the full model's.

Stated tolerance: a cantilever (80 DOFs) whose tip and middle hit walls, reduced to the 2 gap
DOFs + 20 fixed-interface modes (22 DOFs), matches the full run's gap
displacements within 1e-3 of their peak, the peak contact forces within 1e-3, and has the
same impacts."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import vibroimpact as vi
from vibroimpact.errors import ModelError
from vibroimpact.fe import Beam, FEStructure, Material, Rayleigh, Section, Support, modes
from vibroimpact.fe.reduction import check_reduction, craig_bampton, reduce_model

STEEL = Material(youngs_modulus=207e9, poisson=0.3, density=7850.0)
LAW = vi.contact.Hertz(stiffness=1e9)


def cantilever(elements: int = 40, **kw: object) -> Beam:
    return Beam(1.0, elements, Section.circle(0.03), STEEL,
                supports=[Support(node="start")], **kw)  # type: ignore[arg-type]


def impact_model(beam: Beam) -> vi.Model:
    """The tip moving at 1 m/s in the first mode's shape towards a wall 1 mm away; the middle
    between two walls 1 mm away."""
    gaps = [beam.gap(LAW, node="end", clearance=1e-3, side="positive"),
            beam.gap(LAW, at=0.5, clearance=1e-3, side="both")]
    phi = modes(beam, 1).elastic_shapes[:, 0]
    v0 = phi / phi[beam.dof(node="end")]
    return beam.model(gaps, initial_velocity=v0)


def test_reduced_impact_response_matches_the_full_model() -> None:
    beam = cantilever()
    model = impact_model(beam)
    reduced, cb = reduce_model(model, n_modes=20)
    assert reduced.n_dof == 22
    assert cb.boundary == (beam.dof(node="end"), beam.dof(node="middle"))
    check = check_reduction(model, cb, t_end=0.02, dt=2e-6)
    assert check.impacts_full >= 4
    assert check.displacement_error < 1e-3
    assert check.peak_force_error < 1e-3
    assert check.impacts_full == check.impacts_reduced
    assert check.passed(1e-3)
    # fewer modes: a larger, measurable error (the check is not vacuous)
    coarse = check_reduction(model, craig_bampton(model, cb.boundary, 3), t_end=0.02, dt=2e-6)
    assert coarse.displacement_error > 10 * check.displacement_error


def test_all_interior_modes_reproduce_the_full_model_exactly() -> None:
    beam = cantilever(10, damping=Rayleigh(5.0, 1e-6))
    model = impact_model(beam)
    reduced, cb = reduce_model(model, n_modes=beam.n_dof - 2)
    full = vi.simulate(model, t_end=5e-3, dt=1e-5)
    red = vi.simulate(reduced, t_end=5e-3, dt=1e-5)
    x = cb.expand(red.displacement)
    np.testing.assert_allclose(x, full.displacement, atol=1e-9 * np.abs(full.displacement).max())
    assert cb.damping is not None


def test_static_boundary_load_is_exact_and_interior_loads_are_generalized_forces() -> None:
    beam = cantilever(12)
    k = beam.structure.stiffness.toarray()
    tip, mid = beam.dof(node="end"), beam.dof(node=4)
    cb = craig_bampton(beam, [tip], n_modes=2)
    f = np.zeros(beam.n_dof)
    f[tip] = 1.0
    x_full = np.linalg.solve(k, f)
    q = np.linalg.solve(cb.stiffness, cb.transform.T @ f)
    np.testing.assert_allclose(cb.expand(q), x_full, rtol=1e-10, atol=1e-18)
    # a load on an interior DOF becomes loads whose sum is Tᵀ f
    load = vi.HarmonicLoad(dof=[mid, tip], amplitude=3.0, frequency=5.0)
    reduced = cb.reduce_load(load)
    g = np.zeros(cb.n_dof)
    for ld in reduced:
        assert isinstance(ld, vi.HarmonicLoad) and ld.frequency == 5.0
        g[list(ld.dofs)] += ld.amplitude
    np.testing.assert_allclose(g, 3.0 * cb.transform[[mid, tip]].sum(axis=0), rtol=1e-12)


def test_frequencies_converge_from_above() -> None:
    beam = cantilever(30)
    errors = [craig_bampton(beam, [beam.dof(node="end")], n).frequency_errors(beam, 4)
              for n in (4, 8, 16)]
    for e in errors:
        assert np.all(e > -1e-9)  # Rayleigh–Ritz: never below the full model
    assert errors[1].max() < errors[0].max() / 10 and errors[2].max() < 2e-5


def test_sparse_path_matches_dense() -> None:
    beam = Beam(1.0, 320, Section.circle(0.03), STEEL, supports=[Support(node="start")])
    assert beam.n_dof > 600  # the interior is handled with splu and eigsh
    boundary = [beam.dof(node="end"), beam.dof(node="middle")]
    a = craig_bampton(beam, boundary, 6)
    b = craig_bampton(beam.structure, boundary, 6)  # dense input
    np.testing.assert_allclose(a.interior_frequencies_hz, b.interior_frequencies_hz, rtol=1e-8)
    fa = modes((a.mass, a.stiffness), 4).elastic_frequencies_hz
    fb = modes((b.mass, b.stiffness), 4).elastic_frequencies_hz
    np.testing.assert_allclose(fa, fb, rtol=1e-9)


def test_free_free_interior_needs_enough_boundary_dofs() -> None:
    free = Beam(1.0, 6, Section.circle(0.03), STEEL)
    with pytest.raises(ModelError, match=r"^boundary: 1 boundary DOF\(s\) leave the interior"):
        craig_bampton(free, [free.dof(node="end")], 2)
    ok = craig_bampton(free, [free.dof(node="start"), free.dof(node="end")], 2)
    assert modes((ok.mass, ok.stiffness), 1).rigid_body_modes == 2
    with pytest.raises(ModelError, match=r"^n_modes: 99 is not valid"):
        craig_bampton(free, [0, 12], 99)


def test_reduce_a_sparse_imported_structure() -> None:
    beam = cantilever(20)
    fe = FEStructure(sp.csr_array(beam.fe.mass), sp.csr_array(beam.fe.stiffness),
                     dof_map=beam.dof_map)
    gap = fe.gap(LAW, node=20, direction="x", clearance=1e-3, side="positive")
    cb = craig_bampton(fe, [gap.dof], 10)
    reduced = cb.model([gap], initial_velocity=np.where(
        np.array(beam.dof_map.directions) == "x", 1.0, 0.0))
    assert reduced.gaps[0].dof == 0
    r = vi.simulate(reduced, t_end=0.01, dt=2e-6, dofs=[0])
    assert len(r.impacts) >= 1


def test_solid_response_converges_as_modes_are_added() -> None:
    """A 960-DOF block of hexahedra (the sparse path: the core's Cholesky factor of K_ii and
    eigsh), its tip driven from rest at the first frequency into a resolved Hertz wall: the
    gap's displacement and contact force approach the full model's as modes are added (5 ->
    40), each step of the ladder by a clear factor (measured 8.7e-3, 5.4e-4, 1.6e-5, 3.1e-6
    for the displacement)."""
    from vibroimpact.benchmarks.large_models import hexahedral_block

    ne = (20, 3, 3)
    fe = hexahedral_block(ne)
    tip = ne[0] * (ne[1] + 1) * (ne[2] + 1) + (ne[1] // 2) * (ne[2] + 1) + ne[2] // 2 + 1
    gap = fe.gap(LAW, node=tip, direction="y", clearance=1e-5, side="positive")
    f1 = modes(fe.to_structure(), 1).elastic_frequencies_hz[0]
    model = vi.Model(fe.to_structure(), gaps=[gap],
                     loads=[vi.HarmonicLoad(dof=gap.dof, amplitude=200.0, frequency=f1)])
    full = vi.simulate(model, t_end=6e-3, dt=2e-6, dofs=[gap.dof])
    assert len(full.impacts) == 2
    errors = []
    for n_modes in (5, 10, 20, 40):
        cb = craig_bampton(model, [gap.dof], n_modes)
        red = vi.simulate(cb.reduce_model(model), t_end=6e-3, dt=2e-6, dofs=[0])
        assert len(red.impacts) == len(full.impacts)
        errors.append((
            np.abs(red.displacement - full.displacement).max() / np.abs(full.displacement).max(),
            np.abs(red.gap_force - full.gap_force).max() / full.gap_force.max(),
        ))
    e = np.array(errors)
    assert np.all(e[1:] < e[:-1] / 3), e  # every doubling of the modes: 3x closer at least
    assert e[0, 0] > 3e-3 and e[-1].max() < 3e-5, e


def test_core_cholesky_factor_solves_like_scipy() -> None:
    """The core's sparse factor as the reduction uses it (_core.CholeskyFactor) against
    SciPy's spsolve, for a vector and for columns; an indefinite or unsymmetric matrix is
    refused in one line."""
    from vibroimpact import _core

    beam = cantilever(200)
    k = sp.csr_array(beam.fe.stiffness)
    k.sort_indices()
    f = _core.CholeskyFactor(k)
    b = np.sin(np.arange(k.shape[0]) * 0.37)
    exact = spla.spsolve(sp.csc_array(k), b)
    x = f.solve(b)
    # backward error at round-off; the two solutions agree to the beam's conditioning
    assert np.abs(k @ x - b).max() < 1e-14 * abs(k).max() * np.abs(x).max()
    np.testing.assert_allclose(x, exact, rtol=0, atol=1e-7 * np.abs(exact).max())
    two = f.solve(np.column_stack([b, 2 * b]))
    assert two.shape == (k.shape[0], 2)
    np.testing.assert_array_equal(two[:, 0], x)
    np.testing.assert_allclose(two[:, 1], 2 * x, rtol=1e-15)
    with pytest.raises(_core.ModelError, match=r"^matrix: the Cholesky factorisation failed"):
        _core.CholeskyFactor(sp.csr_array(-k.toarray()))
    skew = k.toarray()
    skew[0, 1] += 1.0
    with pytest.raises(_core.ModelError, match=r"^matrix: max \|A - A\^T\|"):
        _core.CholeskyFactor(sp.csr_array(skew))
    with pytest.raises(_core.ModelError, match=r"^b: shape \(3,\) is not valid"):
        f.solve(np.ones(3))


def test_contact_patch_response_converges_as_modes_are_added() -> None:
    """The Craig–Bampton benchmark's model on a 960-DOF block: the gap is the mean ``y``
    displacement of a 12-node contact patch (its 12 DOFs kept physical, a constraint mode
    each), the block starting in the patch's constraint-mode shape at 1 m/s into a Hertz stop
    (200 µs, one long contact). The reduced patch gap approaches the full one as modes are
    added (measured 8.3e-2, 2.4e-2, 1.4e-3, 3.6e-4 with 5, 20, 40, 160 modes; with all 948
    interior modes 2e-13): a wrong constraint mode, a gap weight lost in the reduction or an
    initial state not in the basis would stop the ladder short."""
    from vibroimpact.benchmarks.large_models import solid_reduction_benchmark

    rows = list(solid_reduction_benchmark(steps=400, n_modes=(5, 20, 40, 160),
                                          n_elements=(20, 3, 3)))
    assert rows[0]["patch_nodes"] == 12 and rows[-1]["reduced_n_dof"] == 12 + 160
    assert all(r["impacts"] == 1 and r["contact_steps"] > 300 for r in rows), rows
    e = np.array([(r["displacement_error"], r["contact_displacement_error"], r["force_error"])
                  for r in rows])
    assert np.all(e[1:] < e[:-1]), e
    assert e[0, 0] > 3e-2 and e[-1].max() < 1e-3, e


def test_interface_mass_selection_keeps_the_modes_with_the_most_boundary_mass() -> None:
    """select = "interface-mass" keeps, of the lowest ``candidates`` fixed-interface modes,
    those whose coupling to the boundary carries the largest share of the boundary DOFs'
    mass. Checked by a second route: the Craig–Bampton model with every interior mode, whose
    reduced mass holds the couplings ``L_iᵀ`` as its boundary–mode block and the boundary
    mass ``M̂`` as its boundary block (dense path, a 4 × 2 × 2 block of hexahedra)."""
    from vibroimpact.benchmarks.large_models import hexahedral_block

    fe = hexahedral_block((4, 2, 2))
    structure = fe.to_structure()
    boundary = [fe.dof(n, "y") for n in (37, 38, 40, 41)]  # four nodes of the free end
    full = craig_bampton(structure, boundary, structure.n_dof - 4)
    nb = len(boundary)
    share = (full.mass[:nb, nb:] ** 2 / np.diag(full.mass)[:nb, None]).sum(axis=0)
    assert np.ptp(share) > 10 * np.median(share)  # the ranking is not the frequency order
    for candidates in (40, structure.n_dof - 4):
        chosen = craig_bampton(structure, boundary, 8, select="interface-mass",
                               candidates=candidates)
        expected = np.sort(np.argsort(-share[:candidates])[:8])
        np.testing.assert_allclose(chosen.interior_frequencies_hz,
                                   full.interior_frequencies_hz[expected], rtol=1e-9)
        assert (chosen.select, chosen.candidates, chosen.n_dof) == ("interface-mass",
                                                                    candidates, nb + 8)
    lowest = craig_bampton(structure, boundary, 8)
    assert (lowest.select, lowest.candidates) == ("frequency", 8)
    assert craig_bampton(structure, boundary, 8, select="interface-mass").candidates == 32
    same = craig_bampton(structure, boundary, 8, select="interface-mass", candidates=8)
    np.testing.assert_allclose(same.stiffness, lowest.stiffness, rtol=1e-12, atol=1e-6)
    for kw, message in (
        ({"select": "mass"}, r"^select: 'mass' is not valid; expected one of"),
        ({"candidates": 20}, r"^candidates: 20 is not valid with select = 'frequency'"),
        ({"select": "interface-mass", "candidates": 5},
         r"^candidates: 5 is not valid; expected an integer 8 \.\. "),
    ):
        with pytest.raises(ModelError, match=message):
            craig_bampton(structure, boundary, 8, **kw)  # type: ignore[arg-type]


def test_interface_mass_selection_converges_faster_than_the_lowest_modes() -> None:
    """The contact-patch model of the test above (960-DOF block, 400 steps): at the same
    number of modes, those of the most effective interface mass among 4× as many lowest ones
    bring the patch gap closer to the full model's than the lowest ones (measured
    displacement error 2.8e-2, 1.9e-3, 1.0e-3 against 4.5e-2, 2.4e-2, 1.4e-3 with 10, 20,
    40 modes; the contact force's 2.6e-2, 2.4e-3, 1.2e-3 against 5.1e-2, 3.2e-2, 1.9e-3).
    With 5 modes the lowest do better (8.3e-2 against 1.3e-1): so few must carry the
    block's bending, which ranks below the local modes by interface mass."""
    from vibroimpact.benchmarks.large_models import solid_reduction_benchmark

    rows = list(solid_reduction_benchmark(steps=400, n_modes=(10, 20, 40),
                                          n_elements=(20, 3, 3),
                                          select=("frequency", "interface-mass")))
    assert [(r["select"], r["n_modes"], r["candidates"]) for r in rows] == [
        ("frequency", 10, 10), ("frequency", 20, 20), ("frequency", 40, 40),
        ("interface-mass", 10, 40), ("interface-mass", 20, 80), ("interface-mass", 40, 160)]
    assert all(r["impacts"] == r["impacts_reduced"] == 1 for r in rows), rows
    e = np.array([(r["displacement_error"], r["force_error"]) for r in rows]).reshape(2, 3, 2)
    lowest, chosen = e
    assert np.all(chosen < lowest), e
    assert np.all(chosen[1:] < chosen[:-1]), e
    assert lowest[1, 0] > 1.5e-2 and chosen[1, 0] < 3e-3, e  # 20 modes: 12x closer
    assert chosen[2].max() < 1.5e-3, e
