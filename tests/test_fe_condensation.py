"""Massless DOFs condensed statically (vibroimpact.fe.condensation) and model files that read
CalculiX, ABAQUS, Matrix Market and numpy matrices with DOF maps (issue 6 item 2).

The structure: a cantilever Euler–Bernoulli beam of 5 equal elements with lumped translational
mass and massless rotations (the usual lumped-mass FE export). Independent references:

* the condensed stiffness is the inverse of the beam's flexibility matrix from beam theory
  (cantilever: ``δ_ij = x_i² (3 x_j - x_i) / 6EI`` for ``x_i <= x_j``; cubic elements are
  exact at the nodes for nodal loads);
* the impact response is integrated by SciPy (DOP853, tight tolerances) on that flexibility
  model with the Hertz force written out here.

Fixture recipe: the CalculiX (``write_calculix``, ccx's ``%d %d %20.13e`` layout with the
``job.dof`` map), ABAQUS (``write_abaqus_mtx``, ``FORMAT=MATRIX INPUT`` lines; the mass file has
no rotation entries at all), Matrix Market and ``.npz`` files are written by the test from the
same matrices; each model file must give the response of the ``.npz`` one.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
from scipy.integrate import solve_ivp
from vibroimpact.cli import main as cli_main
from vibroimpact.contact import Hertz
from vibroimpact.errors import ModelError
from vibroimpact.fe import DofMap, FEStructure, craig_bampton, modes
from vibroimpact.fe.condensation import CondensationWarning
from vibroimpact.fe.matrices import (
    read_structure,
    save_npz,
    write_abaqus_mtx,
    write_calculix,
    write_matrix_market,
)
from vibroimpact.io import ModelFileError, load_model, results_file

E_I = 2.0e4  # N·m², bending stiffness
MASS_PER_LENGTH = 8.0  # kg/m
LENGTH = 1.0  # m
ELEMENTS = 5
HERTZ = 1.0e9  # N/m^1.5
CLEARANCE = 2e-4  # m
V0 = 0.05  # m/s, initial velocity of every translation


def lumped_cantilever() -> FEStructure:
    """Cantilever (node 0 clamped), nodes 1..5 with DOFs (x, ry); mass only on x."""
    le = LENGTH / ELEMENTS
    ke = (E_I / le**3) * np.array(
        [
            [12, 6 * le, -12, 6 * le],
            [6 * le, 4 * le**2, -6 * le, 2 * le**2],
            [-12, -6 * le, 12, -6 * le],
            [6 * le, 2 * le**2, -6 * le, 4 * le**2],
        ]
    )
    n = 2 * (ELEMENTS + 1)
    k = np.zeros((n, n))
    for e in range(ELEMENTS):
        k[2 * e : 2 * e + 4, 2 * e : 2 * e + 4] += ke
    m = np.zeros((n, n))
    for j in range(1, ELEMENTS + 1):
        m[2 * j, 2 * j] = MASS_PER_LENGTH * le * (0.5 if j == ELEMENTS else 1.0)
    dm = DofMap([j for j in range(1, ELEMENTS + 1) for _ in range(2)], ["x", "ry"] * ELEMENTS)
    return FEStructure(sp.csr_array(m[2:, 2:]), sp.csr_array(k[2:, 2:]), dof_map=dm)


def flexibility() -> np.ndarray:
    x = np.arange(1, ELEMENTS + 1) * LENGTH / ELEMENTS
    a, b = np.minimum.outer(x, x), np.maximum.outer(x, x)
    return a**2 * (3 * b - a) / (6 * E_I)


def test_condensed_stiffness_is_the_inverse_beam_flexibility() -> None:
    fe = lumped_cantilever()
    assert fe.massless_dofs == [1, 3, 5, 7, 9]
    with pytest.raises(ModelError, match="massless DOFs"):
        fe.to_structure()
    c = fe.condense_massless()
    k_ref = np.linalg.inv(flexibility())
    k_r = c.structure.stiffness.toarray()
    assert np.abs(k_r - k_ref).max() <= 1e-10 * np.abs(k_ref).max()
    np.testing.assert_array_equal(c.retained, [0, 2, 4, 6, 8])
    assert c.structure.dof_map == DofMap([1, 2, 3, 4, 5], ["x"] * 5)
    # recovered rotations: the slope of the deflection under a tip load, from beam theory
    x = np.arange(1, ELEMENTS + 1) * LENGTH / ELEMENTS
    tip = flexibility()[:, -1]  # deflection under a unit tip load
    full = c.recover(tip)
    np.testing.assert_allclose(full[0::2], tip, rtol=1e-12)
    slope = x * (2 * LENGTH - x) / (2 * E_I)  # dw/dx of P x² (3L - x) / 6EI, P = 1
    np.testing.assert_allclose(full[1::2], slope, rtol=1e-10)


def test_modes_of_a_structure_with_massless_dofs() -> None:
    """Against scipy.linalg.eigh of (flexibility⁻¹, lumped M): the beam-theory model."""
    fe = lumped_cantilever()
    got = modes(fe, 3)
    le = LENGTH / ELEMENTS
    m = MASS_PER_LENGTH * le * np.diag([1.0, 1.0, 1.0, 1.0, 0.5])
    lam, phi = scipy.linalg.eigh(np.linalg.inv(flexibility()), m)
    np.testing.assert_allclose(got.eigenvalues, lam[:3], rtol=1e-10)
    assert got.shapes.shape == (2 * ELEMENTS, 3) and got.dof_map == fe.dof_map
    for j in range(3):  # translations: the reference shape (up to sign); mass-normalised
        sign = np.sign(got.shapes[8, j] * phi[4, j])
        np.testing.assert_allclose(got.shapes[0::2, j], sign * phi[:, j], rtol=1e-8, atol=1e-10)
        assert got.shapes[:, j] @ fe.mass @ got.shapes[:, j] == pytest.approx(1.0, rel=1e-12)
    # rotations: K φ = ω² M φ holds on every row, the massless ones included
    residual = fe.stiffness @ got.shapes - fe.mass @ got.shapes * got.eigenvalues
    assert np.abs(residual).max() <= 1e-8 * np.abs(fe.stiffness @ got.shapes).max()


def test_craig_bampton_of_the_condensed_structure() -> None:
    """Condense, then reduce keeping every mode: the beam-theory model's frequencies."""
    c = lumped_cantilever().condense_massless()
    cb = craig_bampton(c.structure, boundary=[4], n_modes=4)
    lam = scipy.linalg.eigh(cb.stiffness, cb.mass, eigvals_only=True)
    m_ref = c.structure.mass.toarray()
    ref = scipy.linalg.eigh(np.linalg.inv(flexibility()), m_ref, eigvals_only=True)
    np.testing.assert_allclose(lam, ref, rtol=1e-9)


def test_damping_on_massless_dofs() -> None:
    fe = lumped_cantilever()
    beta = 1e-4
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # Rayleigh damping is condensed exactly: no warning
        c = FEStructure(fe.mass, fe.stiffness, 0.5 * fe.mass + beta * fe.stiffness,
                        fe.dof_map).condense_massless()
    assert c.damping_residual < 1e-12
    expected = 0.5 * c.structure.mass.toarray() + beta * c.structure.stiffness.toarray()
    np.testing.assert_allclose(c.structure.damping.toarray(), expected, atol=1e-9 * beta * 1e6)
    dashpot = sp.csr_array(([3.0], ([1], [1])), shape=(10, 10))  # on a rotation only
    with pytest.warns(CondensationWarning, match="massless DOFs"):
        c = FEStructure(fe.mass, fe.stiffness, dashpot, fe.dof_map).condense_massless()
    assert c.damping_residual > 1e-3


def test_refusals() -> None:
    fe = lumped_cantilever()
    with pytest.raises(ModelError, match=r"dof: 3 \(node 2 direction 'ry'\) .*carries mass"):
        fe.condense_massless(keep=[0, 3])
    k = fe.stiffness.toarray()
    k[:, 9] = k[9, :] = 0.0  # the tip rotation held by nothing
    with pytest.raises(ModelError, match="does not hold the 5 massless DOFs"):
        FEStructure(fe.mass, k, dof_map=fe.dof_map).condense_massless()
    with pytest.raises(ModelError, match=r"5 massless DOFs .*condense them first"):
        craig_bampton(fe, boundary=[8], n_modes=2)
    m = fe.mass.toarray()
    m[1, 0] = m[0, 1] = 0.1  # a zero diagonal with a non-zero row
    with pytest.raises(ModelError, match=r"diagonal entry 1 is 0\.0"):
        FEStructure(m, fe.stiffness)


# ------------------------------------------------------------------------------------------
# Model files in every format, against an independent SciPy integration
# ------------------------------------------------------------------------------------------

MODEL = """
[structure]
kind = "matrices"
{structure}

[[gaps]]
{where}
clearance = {clearance}
side = "both"
[gaps.law]
kind = "hertz"
stiffness = {hertz}

[initial]
velocity = {velocity}

[solver]
dt = 2e-6
t_end = 0.04
"""


def write_model(folder: Path, structure: str, where: str = 'node = 5\ndirection = "x"') -> Path:
    path = folder / f"model{len(list(folder.glob('model*.toml')))}.toml"
    velocity = [V0 if i % 2 == 0 else 0.0 for i in range(2 * ELEMENTS)]
    path.write_text(
        MODEL.format(structure=structure, where=where, clearance=CLEARANCE, hertz=HERTZ,
                     velocity=velocity),
        encoding="utf-8",
    )
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("fe_files")
    fe = lumped_cantilever()
    save_npz(folder / "beam.npz", fe)
    write_calculix(folder / "ccx", fe)
    write_abaqus_mtx(folder / "job_STIF1.mtx", fe.stiffness, fe.dof_map)  # type: ignore[arg-type]
    # the mass file has no entries for the massless rotations (as ABAQUS writes it)
    write_abaqus_mtx(folder / "job_MASS1.mtx", fe.mass, fe.dof_map)  # type: ignore[arg-type]
    write_matrix_market(folder / "K.mtx", fe.stiffness)
    write_matrix_market(folder / "M.mtx", fe.mass)
    fe.dof_map.write_csv(folder / "dofs.csv")  # type: ignore[union-attr]
    return folder


def reference_tip(t: np.ndarray) -> np.ndarray:
    """Tip displacement from SciPy: lumped masses, K = flexibility⁻¹, Hertz walls at the tip."""
    k = np.linalg.inv(flexibility())
    le = LENGTH / ELEMENTS
    m = MASS_PER_LENGTH * le * np.array([1.0, 1.0, 1.0, 1.0, 0.5])

    def rhs(_: float, y: np.ndarray) -> np.ndarray:
        x, v = y[:ELEMENTS], y[ELEMENTS:]
        f = -k @ x
        pen = abs(x[-1]) - CLEARANCE
        if pen > 0:
            f[-1] -= np.sign(x[-1]) * HERTZ * pen**1.5
        return np.concatenate([v, f / m])

    y0 = np.concatenate([np.zeros(ELEMENTS), np.full(ELEMENTS, V0)])
    sol = solve_ivp(rhs, (0, t[-1]), y0, method="DOP853", rtol=1e-11, atol=1e-14, t_eval=t,
                    max_step=2e-5)
    return sol.y[ELEMENTS - 1]


def test_calculix_model_file_matches_scipy_on_the_flexibility_model(files: Path) -> None:
    mf = load_model(write_model(files, 'mass = "ccx.mas"\nstiffness = "ccx.sti"'))
    assert mf.model.n_dof == ELEMENTS and mf.condensation is not None
    assert mf.model.gaps[0].dofs == (ELEMENTS - 1,)  # node 5 x, among the DOFs with mass
    np.testing.assert_array_equal(mf.model.initial_velocity, np.full(ELEMENTS, V0))
    r = mf.simulate()
    assert len(r.impacts) >= 2
    tip = r.displacement[:, list(r.dofs).index(2 * ELEMENTS - 2)]  # the file's DOF 8: node 5 x
    ref = reference_tip(r.time)
    err = np.abs(tip - ref).max() / np.abs(ref).max()
    assert err < 5e-4, err  # measured 1.6e-4 (Newmark at dt = 2 µs, 5 impacts)


@pytest.mark.parametrize(
    "structure",
    [
        'mass = "ccx.mas"\nstiffness = "ccx.sti"',
        'mass = "job_MASS1.mtx"\nstiffness = "job_STIF1.mtx"',
        'mass = "job_MASS1.mtx"\nstiffness = "job_STIF1.mtx"\nformat = "abaqus"',
        'mass = "M.mtx"\nstiffness = "K.mtx"\ndof_map = "dofs.csv"',
        'mass = "M.mtx"\nstiffness = "K.mtx"\nformat = "mtx"\ndof_map = '
        + str([f"{n}.{d}" for n in range(1, 6) for d in ("1", "ry")]).replace("'", '"'),
        'mass = "beam.npz"\nstiffness = "beam.npz"\ndof_map = "ccx.dof"',
    ],
    ids=["calculix", "abaqus", "abaqus-explicit", "mtx-csv", "mtx-labels", "npz-dof"],
)
def test_every_format_gives_the_npz_response(files: Path, structure: str) -> None:
    ref = load_model(write_model(files, 'mass = "beam.npz"\nstiffness = "beam.npz"')).simulate()
    mf = load_model(write_model(files, structure))
    r = mf.simulate()
    scale = np.abs(ref.displacement).max()
    # CalculiX stores 14 significant digits; the others are exact
    tol = 1e-9 if "ccx.mas" in structure else 0.0
    assert np.abs(r.displacement - ref.displacement).max() <= tol * scale
    assert len(r.impacts) == len(ref.impacts)


def test_read_structure_api(files: Path) -> None:
    fe = lumped_cantilever()
    for got in (
        read_structure(files / "ccx.mas", files / "ccx.sti"),
        read_structure(files / "job_MASS1.mtx", files / "job_STIF1.mtx"),
        read_structure(files / "M.mtx", files / "K.mtx", dof_map=files / "dofs.csv"),
    ):
        assert got.dof_map == fe.dof_map
        np.testing.assert_allclose(got.stiffness.toarray(), fe.stiffness.toarray(), rtol=1e-12)
        np.testing.assert_allclose(got.mass.toarray(), fe.mass.toarray(), rtol=1e-12)


def test_addressing_mistakes(files: Path) -> None:
    mtx = 'mass = "M.mtx"\nstiffness = "K.mtx"'
    cases = {
        (mtx, 'node = 5\ndirection = "x"'): "gaps[0].node: 5 is not valid; expected dof, or a "
        "DOF map",
        ('mass = "ccx.mas"\nstiffness = "ccx.sti"', 'node = 9\ndirection = "x"'):
        "gaps[0].node: 9 is not valid; expected a node of the model (labels 1 .. 5",
    }
    for (structure, where), message in cases.items():
        with pytest.raises(ModelFileError) as info:
            load_model(write_model(files, structure, where))
        assert len(info.value.errors) == 1 and info.value.errors[0].startswith(message), (
            info.value.errors
        )
    # a gap on a massless DOF runs: its law in series with that DOF's static compliance
    for where in ('node = 5\ndirection = "ry"', "dof = 3"):
        law = load_model(write_model(files, 'mass = "ccx.mas"\nstiffness = "ccx.sti"',
                                     where)).model.gaps[0].law
        assert isinstance(law, Hertz) and law.compliance > 0, law


# ------------------------------------------------------------------------------------------
# Results in the file's DOF numbering, massless DOFs recovered
# ------------------------------------------------------------------------------------------

NPZ = 'mass = "beam.npz"\nstiffness = "beam.npz"'


def with_output(path: Path, dofs: list[int], every: int = 1) -> Path:
    path.write_text(path.read_text(encoding="utf-8") + f"\n[output]\ndofs = {dofs}\n"
                    f"every = {every}\n", encoding="utf-8")
    return path


def test_results_label_the_files_dofs_and_recover_rotations(files: Path) -> None:
    """Every DOF of the file is reported (rotations too); the rotations equal an independent
    dense solve of K_ss x_s = -K_sm x_m on the recorded translations, for x, v and a."""
    r = load_model(write_model(files, NPZ)).simulate()
    np.testing.assert_array_equal(r.dofs, np.arange(2 * ELEMENTS))
    k = lumped_cantilever().stiffness.toarray()
    s, m = np.arange(1, 2 * ELEMENTS, 2), np.arange(0, 2 * ELEMENTS, 2)
    for name in ("displacement", "velocity", "acceleration"):
        h = getattr(r, name)
        expected = -np.linalg.solve(k[np.ix_(s, s)], k[np.ix_(s, m)] @ h[:, m].T).T
        scale = np.abs(expected).max()
        assert scale > 0 and np.abs(h[:, s] - expected).max() <= 1e-10 * scale, name
    # beam theory: the nodal forces are F = flexibility⁻¹ x_m, and the cantilever's slope at
    # x_j under a unit force at x_i is x_i²/2EI (x_i <= x_j) or x_j (2 x_i - x_j)/2EI
    x = np.arange(1, ELEMENTS + 1) * LENGTH / ELEMENTS
    a, b = np.meshgrid(x, x, indexing="ij")  # a: slope node x_j, b: load node x_i
    theta = np.where(b <= a, b**2 / (2 * E_I), (2 * b * a - a**2) / (2 * E_I))
    forces = np.linalg.solve(flexibility(), r.displacement[:, m].T)
    slopes = (theta @ forces).T
    scale = np.abs(slopes).max()
    assert np.abs(r.displacement[:, s] - slopes).max() <= 1e-10 * scale
    # the peaks: the core's for translations (every step), the recorded rows' for rotations
    np.testing.assert_allclose(r.max_abs_displacement[s], np.abs(r.displacement[:, s]).max(0),
                               rtol=0, atol=0)
    assert np.all(r.max_abs_displacement[m] >= np.abs(r.displacement[:, m]).max(0))

    # output.dofs in file numbering, a rotation among them: the same columns of the same run
    mf = load_model(with_output(write_model(files, NPZ), [8, 9, 3]))
    part = mf.simulate()
    np.testing.assert_array_equal(part.dofs, [8, 9, 3])
    dm = mf.condensation.full.dof_map  # the file's DOF map: tip x, tip ry, node 2 ry
    assert [(dm.nodes[d], dm.directions[d]) for d in part.dofs] == [(5, "x"), (5, "ry"),
                                                                     (2, "ry")]
    assert mf.run_dofs == [0, 1, 2, 3, 4]  # a rotation needs every translation
    with pytest.raises(ModelError, match=r"^dofs: \[0, 1, 2, 3, 4, 5, 6, 7, 8, 9\] is not "
                       r"valid; expected the run to record the DOFs \[0, 1, 2, 3, 4\]") as info:
        mf.recovery().result(r)  # a result already in the file's DOFs
    assert "\n" not in str(info.value)
    for name in ("displacement", "velocity", "acceleration"):
        np.testing.assert_allclose(getattr(part, name), getattr(r, name)[:, [8, 9, 3]],
                                   rtol=0, atol=1e-12 * np.abs(getattr(r, name)).max())


def test_result_files_carry_the_files_dof_numbers(files: Path, tmp_path: Path) -> None:
    """NetCDF (in memory and streamed by the CLI) and CSV label the DOFs by the file's
    numbers; the CSV headers carry the number and each DOF's unit (9 and 3 are rotations ry
    of the file's DOF map: rad), as does the ``dof_unit`` coordinate."""
    model = with_output(write_model(files, NPZ), [9, 8, 3], every=10)
    r = load_model(model).simulate()
    r.save(tmp_path / "mem.nc")
    mem = results_file.load(tmp_path / "mem.nc")
    np.testing.assert_array_equal(mem["dof"].values, [9, 8, 3])
    assert cli_main(["run", str(model), "-q", "-o", str(tmp_path / "stream.nc"), "--stream",
                     "--window", "2000"]) == 0
    streamed = results_file.load(tmp_path / "stream.nc")
    np.testing.assert_array_equal(streamed["dof"].values, [9, 8, 3])
    for name in ("displacement", "velocity", "acceleration"):
        np.testing.assert_array_equal(streamed[name].values, mem[name].values)
    for ds in (mem, streamed):
        assert ds["dof_unit"].values.tolist() == ["rad", "m", "rad"]
        assert ds["velocity"].attrs["units"] == "m/s or rad/s per dof_unit"
    assert cli_main(["run", str(model), "-q", "-o", str(tmp_path / "run.csv")]) == 0
    header = (tmp_path / "run.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header[:4] == ["time [s]", "x9 [rad]", "v9 [rad/s]", "a9 [rad/s^2]"]
    assert [h for h in header if h.startswith("x")] == ["x9 [rad]", "x8 [m]", "x3 [rad]"]
    back = results_file.load(tmp_path / "run.csv")
    np.testing.assert_array_equal(back["dof"].values, [3, 8, 9])
    assert back["dof_unit"].values.tolist() == ["rad", "m", "rad"]
    np.testing.assert_allclose(back["displacement"].sel(dof=9).values,
                               mem["displacement"].sel(dof=9).values, rtol=1e-15)
