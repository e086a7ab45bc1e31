"""Large sparse models stay sparse end to end (issue 6, item 2): a scipy.sparse structure is
validated, handed to the core as CSR and integrated by Newmark's banded path without any
n×n array, checked against an independent SciPy Newmark (``splu`` of the effective
stiffness, scalar Newton on the Hertz gap) and against the same chain cut short."""

from __future__ import annotations

import dataclasses
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import vibroimpact as vi
from vibroimpact.errors import ModelError
from vibroimpact.io import results_file as rf
from vibroimpact.model import spd_solver
from vibroimpact.sweeps.grid import apply, numeric_paths

MASS, SPRING = 0.1, 1e6  # kg per node, N/m per link
CONTACT, CLEARANCE, SPEED = 1e10, 1e-4, 1.0  # Hertz N/m^1.5, m, m/s
DT, STEPS = 1e-5, 200


def chain(n: int) -> vi.Structure:
    """``n`` equal masses in a line, the first tied to the ground, the last free."""
    diag = np.full(n, 2 * SPRING)
    diag[-1] = SPRING
    off = np.full(n - 1, -SPRING)
    k = sp.diags([off, diag, off], [-1, 0, 1], format="csr")
    return vi.Structure(sp.identity(n, format="csr") * MASS, k)


def chain_model(structure: vi.Structure) -> vi.Model:
    """The free end moves at ``SPEED`` towards a Hertz wall ``CLEARANCE`` away."""
    n = structure.n_dof
    v0 = np.zeros(n)
    v0[-1] = SPEED
    gap = vi.Gap(dof=n - 1, clearance=CLEARANCE, law=vi.contact.Hertz(stiffness=CONTACT))
    return vi.Model(structure=structure, gaps=[gap], initial_velocity=v0)


def scipy_newmark(structure: vi.Structure, steps: int) -> np.ndarray:
    """Average-acceleration Newmark from rest at ``SPEED`` (x₀ = 0, a₀ = 0): ``K̃ x₁ = M(4/h² x₀
    + 4/h v₀ + a₀) − f₁ e`` with ``K̃ = K + 4M/h²`` factorised by SuperLU and the Hertz force
    ``f₁ = k⟨u − d⟩^1.5`` of the end coordinate ``u = x_lin − f₁ G`` (``G = K̃⁻¹ e``) found by
    bracketing; returns the end displacement after each step."""
    n, h = structure.n_dof, DT
    m, k = structure.mass, structure.stiffness
    lu = spla.splu(sp.csc_array(k + m * (4 / h**2)))
    e = np.zeros(n)
    e[-1] = 1.0
    g = lu.solve(e)
    x, v, a = np.zeros(n), e * SPEED, np.zeros(n)
    out = []
    for _ in range(steps):
        x_lin = lu.solve(m @ (4 / h**2 * x + 4 / h * v + a))
        u_lin = x_lin[-1]
        force = 0.0
        if u_lin > CLEARANCE:
            def residual(u: float, u_lin: float = u_lin) -> float:
                return u - u_lin + g[-1] * CONTACT * max(u - CLEARANCE, 0.0) ** 1.5

            u = scipy.optimize.brentq(residual, CLEARANCE, u_lin, xtol=1e-18, rtol=1e-15)
            force = CONTACT * (u - CLEARANCE) ** 1.5
        x1 = x_lin - force * g
        a1 = 4 / h**2 * (x1 - x) - 4 / h * v - a
        v = v + h / 2 * (a + a1)
        x, a = x1, a1
        out.append(x[-1])
    return np.array(out)


def test_sparse_structure_is_kept_sparse_and_validated() -> None:
    s = chain(6)
    assert s.is_sparse and isinstance(s.mass, sp.csr_array)
    assert isinstance(s.damping, sp.csr_array) and s.damping.nnz == 0
    dense = vi.Structure(s.mass.toarray(), s.stiffness.toarray())
    assert not dense.is_sparse
    # duplicates (as in an FE assembly) are summed
    coo = sp.coo_array(([1.0, 1.0, 2.0], ([0, 0, 1], [0, 0, 1])), shape=(2, 2))
    assert vi.Structure(coo).mass.toarray().tolist() == [[2.0, 0.0], [0.0, 2.0]]
    asym = s.stiffness.tolil()
    asym[0, 1] = -0.5 * SPRING
    with pytest.raises(ModelError, match=r"structure.stiffness: not symmetric"):
        vi.Structure(s.mass, asym)
    with pytest.raises(ModelError, match=r"structure.mass: contains NaN"):
        vi.Structure(s.mass * np.nan)
    with pytest.raises(ModelError, match=r"structure.mass: not positive definite"):
        vi.Structure(s.stiffness - 0.1 * SPRING * sp.identity(6))  # K − cI: one pivot < 0


def test_spd_solver_agrees_with_eigenvalues() -> None:
    """Positive definiteness from the sparse LDLᵀ pivots against the smallest eigenvalue."""
    rng = np.random.default_rng(3)
    for _ in range(40):
        q = sp.random(30, 30, density=0.1, random_state=rng)
        a = (q + q.T).toarray() + rng.uniform(0.0, 3.0) * np.eye(30)
        positive = np.linalg.eigvalsh(a)[0] > 0
        for form in (a, sp.csr_array(a)):
            solve = spd_solver(form)
            assert (solve is not None) == positive
            if solve is not None:
                b = rng.normal(size=30)
                np.testing.assert_allclose(a @ solve(b), b, atol=1e-10 * np.abs(b).max())


def test_large_sparse_chain_matches_scipy_newmark_and_the_short_chain() -> None:
    """20,000 DOFs, 200 Newmark steps through a Hertz impact: the end displacement equals an
    independent SciPy Newmark on the full sparse model and the same chain with 300 DOFs (the
    disturbance travels ~6 links in 2 ms), and Python never holds an n×n array."""
    n = 20_000
    structure = chain(n)
    tracemalloc.start()
    result = vi.simulate(chain_model(structure), STEPS * DT, DT, dofs=[n - 1])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 8 * n**2 / 1000, peak  # a dense M alone: 3.2 GB
    end = result.displacement[1:, 0]
    assert len(result.impacts) == 1 and end.max() > CLEARANCE
    reference = scipy_newmark(structure, STEPS)
    scale = np.abs(reference).max()
    np.testing.assert_allclose(end, reference, rtol=0, atol=1e-10 * scale)
    short = vi.simulate(chain_model(chain(300)), STEPS * DT, DT, dofs=[299])
    np.testing.assert_allclose(end, short.displacement[1:, 0], rtol=0, atol=1e-12 * scale)


def test_fifty_thousand_dofs_run_without_dense_matrices() -> None:
    """Dense M, C, K at this size would take 60 GB; the sparse run is a few MB. The dense-only
    methods refuse it with a one-line error."""
    n = 50_000
    model = chain_model(chain(n))
    tracemalloc.start()
    result = vi.simulate(model, 50 * DT, DT, dofs=[n - 1])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert result.complete and peak < 8 * n**2 / 1000, peak
    np.testing.assert_allclose(result.displacement[1:, 0], scipy_newmark(model.structure, 50),
                               rtol=0, atol=1e-9 * CLEARANCE)
    rigid = dataclasses.replace(model, gaps=[dataclasses.replace(
        model.gaps[0], law=vi.contact.Rigid(restitution=0.8))])
    for method, case in ((vi.integrators.Bathe(), model),
                         (vi.integrators.PreciseIntegration(), model),
                         (vi.integrators.EventDriven(), rigid),
                         (vi.integrators.MoreauJean(), rigid)):
        with pytest.raises(ModelError, match=rf"^solver.method: {method.name} needs dense n x n "
                           r"matrices and the structure has 50000 DOFs .*newmark"):
            vi.simulate(case, 2 * DT, DT, method)


def test_fe_structure_passes_sparse_matrices_through() -> None:
    s = chain(8)
    fe = vi.fe.FEStructure(s.mass, s.stiffness)
    structure = fe.to_structure()
    assert structure.is_sparse
    assert (structure.stiffness != s.stiffness).nnz == 0


@pytest.mark.parametrize("suffix", [".nc", ".csv"])
def test_result_files_keep_a_sparse_structure(tmp_path: Path, suffix: str) -> None:
    """The matrices are stored as entries and read back as the same CSR arrays; the model
    rebuilt from the file reruns to the same result."""
    model = chain_model(chain(40))
    result = vi.simulate(model, 20 * DT, DT)
    rf.save(result, tmp_path / f"run{suffix}")
    ds = rf.load(tmp_path / f"run{suffix}")
    assert ds["structure_stiffness"].dims == ("structure_stiffness_entry",)
    assert ds.sizes["structure_stiffness_entry"] == model.structure.stiffness.nnz
    back, method = rf.model_from_dataset(ds)
    assert back.structure.is_sparse
    for key in ("mass", "stiffness", "damping"):
        assert (getattr(back.structure, key) != getattr(model.structure, key)).nnz == 0, key
    again = vi.simulate(back, 20 * DT, DT, method)
    np.testing.assert_array_equal(again.displacement, result.displacement)


def test_a_sweep_sets_an_entry_of_a_sparse_matrix() -> None:
    spec = chain_model(chain(5)).to_spec()
    assert "structure.stiffness.I.J" in numeric_paths(spec)
    out = apply(spec, "structure.stiffness.3.4", -7.0)
    assert sp.issparse(out["stiffness"]) and sp.issparse(spec["stiffness"])
    assert out["stiffness"][3, 4] == out["stiffness"][4, 3] == -7.0
    assert spec["stiffness"][3, 4] == -SPRING  # the original is not changed
