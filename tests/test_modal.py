"""Modal analysis (vibroimpact.fe.modal) and ``vibroimpact modal``: dense and sparse solvers
agree, shapes are mass-normalised, rigid-body modes are counted, plots and the command line."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact.cli import main as cli_main
from vibroimpact.errors import ModelError
from vibroimpact.fe import Beam, FEStructure, Material, Section, Support, modes, plot_mode_shapes

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
SHAFT_FILE = ROOT / "examples" / "models" / "hollow_shaft.toml"
STEEL = Material(youngs_modulus=207e9, poisson=0.3, density=7850.0)


def shaft(elements: int = 20, **kw: object) -> Beam:
    return Beam(1.0, elements, Section.tube(0.190, 0.005),
                Material(207e9, 0.3, 34410.0), **kw)  # type: ignore[arg-type]


def test_dense_and_sparse_solvers_agree_on_a_free_free_beam() -> None:
    beam = shaft(150)  # 302 DOFs
    dense = modes(beam, 6, method="dense")
    sparse = modes(beam, 6, method="sparse")
    assert dense.rigid_body_modes == sparse.rigid_body_modes == 2
    np.testing.assert_allclose(sparse.elastic_frequencies_hz, dense.elastic_frequencies_hz,
                               rtol=1e-9)
    m = beam.fe.mass
    for shapes in (dense.shapes, sparse.shapes):
        np.testing.assert_allclose(shapes.T @ m @ shapes, np.eye(shapes.shape[1]), atol=1e-8)


def test_auto_uses_the_sparse_solver_for_large_models() -> None:
    beam = shaft(400)  # 802 DOFs > DENSE_MODAL_LIMIT
    m = modes(beam, 3)
    assert m.rigid_body_modes == 2
    f = modes(shaft(100), 3).elastic_frequencies_hz
    np.testing.assert_allclose(m.elastic_frequencies_hz, f, rtol=1e-3)


def test_structure_model_and_matrix_pairs_are_accepted() -> None:
    s = vi.Structure([[2.0, 0.0], [0.0, 1.0]], [[600.0, -200.0], [-200.0, 200.0]])
    exact = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(s.mass, s.stiffness)).real))
    for arg in (s, vi.Model(s), (s.mass, s.stiffness), FEStructure(s.mass, s.stiffness)):
        m = modes(arg, 2)
        np.testing.assert_allclose(m.angular_frequencies, exact, rtol=1e-12)
        assert m.rigid_body_modes == 0
    with pytest.raises(ModelError, match=r"^modes: 0 is not valid"):
        modes(s, 0)


def test_more_modes_than_dofs_returns_what_exists() -> None:
    m = modes(vi.Structure.sdof(mass=2.0, stiffness=8.0), 5)
    assert len(m.elastic_frequencies_hz) == 1
    assert m.elastic_frequencies_hz[0] == pytest.approx(2.0 / (2 * math.pi))


def test_rigid_body_modes_of_a_chain_of_masses() -> None:
    # three masses on two springs: one rigid-body mode (translation)
    k = 1e5 * np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    m = modes(vi.Structure(np.eye(3), k), 2)
    assert m.rigid_body_modes == 1
    np.testing.assert_allclose(m.angular_frequencies[1:] ** 2, [1e5, 3e5], rtol=1e-12)
    assert modes(vi.Structure(np.eye(3), k), 2, rigid_body_modes=1).rigid_body_modes == 1


def test_records_and_plot(tmp_path: Path) -> None:
    beam = shaft(20, supports=[Support(node="start")])
    m = modes(beam, 3)
    rows = m.to_records()
    assert [r["kind"] for r in rows] == ["elastic"] * 3
    fig = plot_mode_shapes(m, beam, n_modes=3)
    assert len(fig.axes[0].lines) == 3 + 1  # three shapes and the zero line
    assert "[m]" in fig.axes[0].get_xlabel()
    fig.savefig(tmp_path / "modes.png")
    fig2 = plot_mode_shapes(modes(beam.fe, 2), n_modes=2)  # by DOF map, no beam
    assert "direction x" in fig2.axes[0].get_xlabel()


# ------------------------------------------------------------------------------------------
# vibroimpact modal
# ------------------------------------------------------------------------------------------


def test_modal_json_on_the_hollow_shaft_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["modal", str(SHAFT_FILE), "--json", "--modes", "3"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["rigid_body_modes"] == 2
    assert len(out["frequencies_hz"]) == 3
    np.testing.assert_allclose(out["frequencies_hz"], modes(shaft(), 3).elastic_frequencies_hz,
                               rtol=1e-12)
    assert out["frequencies_hz"] == sorted(out["frequencies_hz"])


def test_modal_table_and_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "shapes.png"
    assert cli_main(["modal", str(SHAFT_FILE), "--modes", "2", "--plot", str(png)]) == 0
    text = capsys.readouterr().out
    assert "2 rigid-body mode(s)" in text and "elastic" in text and "frequency [Hz]" in text
    assert png.stat().st_size > 1000


def test_modal_without_solver_table_and_its_mistakes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "m.toml"
    f.write_text('[structure]\nkind = "matrices"\nmass = [[1.0]]\nstiffness = [[4.0]]\n')
    assert cli_main(["modal", str(f), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["frequencies_hz"] == pytest.approx([1 / math.pi])
    f.write_text('[structure]\nkind = "beam"\nlength = 1.0\nelements = 2\n')
    assert cli_main(["modal", str(f)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [
        "vibroimpact: error: structure.section: missing; expected a table [structure.section]",
        "vibroimpact: error: structure.material: missing; expected a table [structure.material]",
    ]
    assert cli_main(["modal", str(SHAFT_FILE), "--modes", "0"]) == 2
    assert "--modes: 0 is not valid" in capsys.readouterr().err


def test_modal_runs_as_a_program() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "vibroimpact", "modal", str(SHAFT_FILE), "--json", "--modes", "1"],
        capture_output=True, text=True, check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["frequencies_hz"][0] == pytest.approx(477.7, abs=0.05)
