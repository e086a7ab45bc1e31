"""Imported FE matrices (vibroimpact.fe.matrices): Matrix Market, numpy, scipy.sparse, CalculiX
``*MATRIX STORAGE`` and ABAQUS ``*MATRIX GENERATE`` files, with DOF maps to place gaps.

Fixture recipe: the CalculiX and ABAQUS files are written here, either literally (a few lines
in the documented layout, checked entry by entry) or by ``write_calculix``/``write_abaqus_mtx``
from a beam (the exact ``fprintf`` layout of ccx's matrixstorage.c, and the ABAQUS
``FORMAT=MATRIX INPUT`` data lines), then read back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import vibroimpact as vi
from vibroimpact.errors import ModelError
from vibroimpact.fe import Beam, DofMap, FEStructure, Material, Section, Support, modes
from vibroimpact.fe.matrices import (
    load_npz,
    read_abaqus,
    read_abaqus_mtx,
    read_calculix,
    read_matrix,
    read_matrix_market,
    read_numpy,
    save_npz,
    write_abaqus_mtx,
    write_calculix,
    write_matrix_market,
)

LAW = vi.contact.Hertz(stiffness=1e10)


def shaft(**kw: object) -> Beam:
    return Beam(1.0, 10, Section.tube(0.190, 0.005), Material(207e9, 0.3, 34410.0),
                **kw)  # type: ignore[arg-type]


def run(fe: FEStructure | Beam) -> vi.Result:
    """The hollow-shaft-like run: gaps at nodes 0 and 10 in x, a harmonic load at node 5."""
    gaps = [fe.gap(LAW, node=n, direction="x", clearance=1e-5, side="both") for n in (0, 10)]
    load = vi.HarmonicLoad(dof=fe.dof(node=5, direction="x"), amplitude=2e4, frequency=200.0)
    return vi.simulate(fe.model(gaps, [load]), t_end=0.01, dt=5e-6)


# ------------------------------------------------------------------------------------------
# Matrix Market and numpy
# ------------------------------------------------------------------------------------------


def test_mtx_export_and_reimport_gives_identical_results(tmp_path: Path) -> None:
    beam = shaft()
    write_matrix_market(tmp_path / "K.mtx", beam.fe.stiffness)
    write_matrix_market(tmp_path / "M.mtx", beam.fe.mass)
    beam.dof_map.write_csv(tmp_path / "dofs.csv")
    k, m = read_matrix_market(tmp_path / "K.mtx"), read_matrix_market(tmp_path / "M.mtx")
    assert isinstance(k, sp.csr_array)
    assert (k != beam.fe.stiffness).nnz == 0 and (m != beam.fe.mass).nnz == 0  # bit for bit
    fe = FEStructure(m, k, dof_map=DofMap.read_csv(tmp_path / "dofs.csv"))
    assert fe.dof_map == beam.dof_map
    a, b = run(beam), run(fe)
    assert len(a.impacts) > 0
    np.testing.assert_array_equal(a.displacement, b.displacement)
    np.testing.assert_array_equal(a.gap_force, b.gap_force)
    assert a.impacts.to_records() == b.impacts.to_records()


def test_numpy_files_and_scipy_sparse(tmp_path: Path) -> None:
    beam = shaft()
    np.save(tmp_path / "K.npy", beam.structure.stiffness.toarray())
    assert (read_numpy(tmp_path / "K.npy") != beam.fe.stiffness).nnz == 0
    sp.save_npz(tmp_path / "M_sparse.npz", sp.csr_matrix(beam.fe.mass))
    assert (read_matrix(tmp_path / "M_sparse.npz") != beam.fe.mass).nnz == 0
    np.savez(tmp_path / "both.npz", K=beam.structure.stiffness.toarray())
    assert (read_numpy(tmp_path / "both.npz", key="K") != beam.fe.stiffness).nnz == 0
    with pytest.raises(ModelError, match="expected a key naming the matrix"):
        read_numpy(tmp_path / "both.npz")
    save_npz(tmp_path / "shaft.npz", beam.fe)
    back = load_npz(tmp_path / "shaft.npz")
    assert back.dof_map == beam.dof_map and (back.stiffness != beam.fe.stiffness).nnz == 0
    # scipy.sparse input stays sparse, in the core's structure too
    fe = FEStructure(sp.csc_matrix(beam.fe.mass), sp.coo_matrix(beam.fe.stiffness))
    assert sp.issparse(fe.mass) and sp.issparse(fe.stiffness) and fe.to_structure().is_sparse
    assert (fe.to_structure().stiffness != beam.structure.stiffness).nnz == 0


# ------------------------------------------------------------------------------------------
# CalculiX *MATRIX STORAGE
# ------------------------------------------------------------------------------------------

#: Two nodes with x and y each (4 equations): what ccx writes for a small model, per its
#: matrixstorage.c: "%d %d %20.13e", the diagonal and the upper triangle, sorted by column.
CCX_STI = """\
1 1  4.0000000000000e+03
2 2  4.0000000000000e+03
1 3 -2.0000000000000e+03
3 3  2.0000000000000e+03
2 4 -2.0000000000000e+03
4 4  2.0000000000000e+03
"""
CCX_MAS = """\
1 1  2.0000000000000e+00
2 2  2.0000000000000e+00
1 3  5.0000000000000e-01
3 3  1.0000000000000e+00
4 4  1.0000000000000e+00
"""
CCX_DOF = "7.1\n7.2\n9.1\n9.2\n"


def test_calculix_fixture_is_read_entry_by_entry(tmp_path: Path) -> None:
    for suffix, text in ((".sti", CCX_STI), (".mas", CCX_MAS), (".dof", CCX_DOF)):
        (tmp_path / f"job{suffix}").write_text(text)
    fe = read_calculix(tmp_path / "job")
    k = np.array([[4e3, 0, -2e3, 0], [0, 4e3, 0, -2e3], [-2e3, 0, 2e3, 0], [0, -2e3, 0, 2e3]])
    m = np.array([[2.0, 0, 0.5, 0], [0, 2.0, 0, 0], [0.5, 0, 1.0, 0], [0, 0, 0, 1.0]])
    np.testing.assert_array_equal(fe.stiffness.toarray(), k)
    np.testing.assert_array_equal(fe.mass.toarray(), m)
    assert fe.dof_map is not None and fe.dof_map.labels() == ["7.x", "7.y", "9.x", "9.y"]
    assert fe.dof(node=9, direction="y") == 3 and fe.dof(node=9, direction=2) == 3
    assert read_calculix(tmp_path / "job.sti").dof_map == fe.dof_map  # any of the files


def test_calculix_round_trip_of_a_3d_beam(tmp_path: Path) -> None:
    beam = shaft(dofs_per_node=6, supports=[Support(node="start", kind="pinned")])
    sti, _mas, dof = write_calculix(tmp_path / "shaft", beam.fe)
    assert dof.read_text().splitlines()[0] == "0.4"  # node 0, rotation about x (4)
    first = sti.read_text().splitlines()[0]
    assert first.split()[:2] == ["1", "1"] and "e+" in first
    fe = read_calculix(tmp_path / "shaft")
    assert fe.dof_map == beam.dof_map
    scale = abs(beam.fe.stiffness).max()
    assert abs(fe.stiffness - beam.fe.stiffness).max() <= 1e-12 * scale  # 14 digits written
    f_ccx = modes(fe, 6).elastic_frequencies_hz
    np.testing.assert_allclose(f_ccx, modes(beam, 6).elastic_frequencies_hz, rtol=1e-10)


# ------------------------------------------------------------------------------------------
# ABAQUS *MATRIX GENERATE
# ------------------------------------------------------------------------------------------

#: FORMAT=MATRIX INPUT: "row node, row dof, column node, column dof, value", lower triangle.
ABQ_STIF = """\
** ASSEMBLED STIFFNESS MATRIX written by *MATRIX OUTPUT
1,1, 1,1, 3.0e+04
1,2, 1,2, 3.0e+04
1,6, 1,6, 12.5
2,1, 1,1, -1.0e+04
2,1, 2,1, 1.0e+04
2,2, 1,2, -1.0e+04
2,2, 2,2, 1.0e+04
2,6, 1,6, -2.5
2,6, 2,6, 2.5
"""
ABQ_MASS = """\
1,1, 1,1, 2.0
1,2, 1,2, 2.0
1,6, 1,6, 0.01
2,1, 2,1, 1.0
2,2, 2,2, 1.0
2,6, 2,6, 0.005
"""


def test_abaqus_fixture_is_read_with_its_dof_map(tmp_path: Path) -> None:
    (tmp_path / "job_STIF1.mtx").write_text(ABQ_STIF)
    (tmp_path / "job_MASS1.mtx").write_text(ABQ_MASS)
    fe = read_abaqus(tmp_path / "job_STIF1.mtx", tmp_path / "job_MASS1.mtx")
    assert fe.dof_map is not None
    assert fe.dof_map.labels() == ["1.x", "1.y", "1.rz", "2.x", "2.y", "2.rz"]
    k = fe.stiffness.toarray()
    assert k[0, 0] == 3e4 and k[3, 0] == k[0, 3] == -1e4 and k[5, 2] == k[2, 5] == -2.5
    np.testing.assert_array_equal(np.diag(fe.mass.toarray()), [2.0, 2.0, 0.01, 1.0, 1.0, 0.005])
    # a gap at node 2 in y and a run on the imported structure
    gap = fe.gap(LAW, node=2, direction="y", clearance=1e-3, side="positive")
    assert gap.dof == 4
    v0 = np.zeros(6)
    v0[4] = 1.0
    r = vi.simulate(fe.model([gap], initial_velocity=v0), t_end=0.02, dt=1e-6, dofs=[4])
    assert len(r.impacts) >= 1 and r.impacts.v_in[0] > 0.5


def test_abaqus_coordinate_format_and_round_trip(tmp_path: Path) -> None:
    (tmp_path / "coord.mtx").write_text("1,1, 2.0\n2,1, -1.0\n2,2, 2.0\n3,2, -1.0\n3,3, 1.0\n")
    a, dm = read_abaqus_mtx(tmp_path / "coord.mtx")
    assert dm is None
    np.testing.assert_array_equal(a.toarray(), [[2, -1, 0], [-1, 2, -1], [0, -1, 1]])
    beam = shaft(dofs_per_node=6)
    write_abaqus_mtx(tmp_path / "b_STIF1.mtx", beam.fe.stiffness, beam.dof_map)
    write_abaqus_mtx(tmp_path / "b_MASS1.mtx", beam.fe.mass, beam.dof_map)
    fe = read_abaqus(tmp_path / "b_STIF1.mtx", tmp_path / "b_MASS1.mtx")
    assert fe.dof_map == beam.dof_map
    assert (fe.stiffness != beam.fe.stiffness).nnz == 0 and (fe.mass != beam.fe.mass).nnz == 0
    # .mtx by content: ABAQUS here, Matrix Market when it starts with %%MatrixMarket
    assert (read_matrix(tmp_path / "b_STIF1.mtx") != beam.fe.stiffness).nnz == 0


# ------------------------------------------------------------------------------------------
# Mistakes
# ------------------------------------------------------------------------------------------


def test_bad_files_are_one_line_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad_STIF1.mtx"
    bad.write_text("1,1, 1,1, 2.0\n1,1, 2,1, oops\n")
    with pytest.raises(ModelError, match=r"line 2 \('1,1, 2,1, oops'\) is not valid; expected"):
        read_abaqus_mtx(bad)
    (tmp_path / "j.sti").write_text("1 1 1.0\n1 2 5.0\n2 1 4.0\n2 2 1.0\n")
    (tmp_path / "j.mas").write_text("1 1 1.0\n2 2 1.0\n")
    with pytest.raises(ModelError, match="not symmetric"):
        read_calculix(tmp_path / "j")
    with pytest.raises(ModelError, match="cannot read"):
        read_calculix(tmp_path / "missing")
    with pytest.raises(ModelError, match=r"^node: 99 is not valid; expected a node of the model"):
        shaft().fe.dof(node=99, direction="x")
    with pytest.raises(ModelError) as info:
        FEStructure(np.eye(2), np.eye(3))
    assert "\n" not in str(info.value) and "structure.stiffness" in str(info.value)
