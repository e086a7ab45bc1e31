"""Model files (TOML): the checked schema, the corpus of bad model files, the example models,
the generated reference and the ``vibroimpact run`` command.

Each ``tests/bad_models/*.toml`` starts with a comment saying what is wrong and one
``# expect: <toml path> | <part of the message>`` line per error the loader must report."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.io
import scipy.sparse
import tomli_w
import vibroimpact as vi
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from vibroimpact.cli import run as run_cli
from vibroimpact.errors import ModelError
from vibroimpact.io import ModelFileError, load_model
from vibroimpact.io.model_file import EXAMPLE, SCHEMA, render_reference

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
BAD = ROOT / "tests" / "bad_models"
MODELS = ROOT / "examples" / "models"
BAD_FILES = sorted(BAD.glob("*.toml"))
PREFIX = "vibroimpact: error: "

#: Bad models also run through the command line in a subprocess.
CLI_SAMPLE = [
    "top_unknown_table",
    "syntax_missing_value",
    "structure_kind_unknown",
    "sdof_mass_string",
    "matrices_not_symmetric",
    "matrices_mtx_garbage",
    "gap_dof_out_of_range",
    "gap_coefficients_zero",
    "law_hc_both",
    "law_kv_exponent",
    "geometry_equal_radii",
    "initial_velocity_length",
    "load_table_bad_row",
    "solver_dt_gt_t_end",
    "solver_option_unknown",
    "output_every_zero",
    "multi_five",
    "multi_matrices",
    "matrices_node_without_dof_map",
    "matrices_load_coupled_to_gap",
]


def expectations(path: Path) -> list[tuple[str, str]]:
    """The ``(field path, message part)`` pairs stated at the top of a bad model file."""
    out = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("# expect:"):
            field, part = line.removeprefix("# expect:").split("|", 1)
            out.append((field.strip(), part.strip()))
    return out


def assert_errors_match(errors: list[str], expected: list[tuple[str, str]]) -> None:
    assert len(errors) == len(expected), "\n".join(errors)
    unused = list(errors)
    for field, part in expected:
        hits = [e for e in unused if e.startswith(field + ":") and part in e]
        assert hits, f"no error for {field!r} containing {part!r} in:\n" + "\n".join(errors)
        unused.remove(hits[0])
    for e in errors:
        assert "\n" not in e and "expected" in e, e


def cli(*args: str | os.PathLike[str], cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "vibroimpact", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
    )


# ------------------------------------------------------------------------------------------
# The corpus of bad model files
# ------------------------------------------------------------------------------------------


def test_corpus_is_large_and_annotated() -> None:
    assert len(BAD_FILES) >= 55
    assert sum(len(expectations(f)) > 1 for f in BAD_FILES) >= 3
    for f in BAD_FILES:
        assert expectations(f), f"{f.name} states no expected error"
    assert set(CLI_SAMPLE) <= {f.stem for f in BAD_FILES}
    assert len(CLI_SAMPLE) >= 15


@pytest.mark.parametrize("path", BAD_FILES, ids=[f.stem for f in BAD_FILES])
def test_bad_model_is_refused_with_every_error(path: Path) -> None:
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert_errors_match(info.value.errors, expectations(path))
    assert str(info.value) == "\n".join(info.value.errors)
    assert isinstance(info.value, ModelError)


def test_keys_above_their_header_and_a_single_misplaced_key(tmp_path: Path) -> None:
    """Several keys of another table: one line naming it (here: the header exists, the keys
    are above it); a single key of another table keeps its own "unknown key" line."""
    path = tmp_path / "model.toml"
    path.write_text('kind = "sdof"\nmass = 1.0\n[structure]\nkind = "sdof"\nmass = 100.0\n'
                    "[initial]\nvelocity = 1.0\nevery = 2\n[solver]\ndt = 1e-6\nt_end = 1e-5\n")
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert info.value.errors == [
        "structure: kind, mass belong in [structure]: are they above its header? expected them "
        "under the header [structure]",
        "initial.every: unknown key; expected one of: displacement, velocity",
    ]


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Any, Path]]:
    """Run the sampled bad models through ``python -m vibroimpact run FILE -o OUT.csv``, a few
    processes at a time; each writes into an empty folder of its own."""

    folders = {name: tmp_path_factory.mktemp(name) for name in CLI_SAMPLE}

    def one(name: str) -> tuple[str, tuple[Any, Path]]:
        proc = cli("run", BAD / f"{name}.toml", "-o", folders[name] / "out.csv")
        return name, (proc, folders[name])

    with ThreadPoolExecutor(max_workers=4) as pool:
        return dict(pool.map(one, CLI_SAMPLE))


@pytest.mark.parametrize("name", CLI_SAMPLE)
def test_bad_model_on_the_command_line(name: str, cli_runs: dict[str, tuple[Any, Path]]) -> None:
    proc, out_dir = cli_runs[name]
    expected = expectations(BAD / f"{name}.toml")
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == len(expected), proc.stderr
    assert all(line.startswith(PREFIX) for line in lines), proc.stderr
    assert_errors_match([line.removeprefix(PREFIX) for line in lines], expected)
    assert proc.stdout == ""
    assert list(out_dir.iterdir()) == []  # no output file, no temporary file


# ------------------------------------------------------------------------------------------
# The example models
# ------------------------------------------------------------------------------------------


def test_paper_sdof_example_builds_the_paper_model() -> None:
    mf = load_model(MODELS / "sdof_paper_ln.toml")
    m = mf.model
    np.testing.assert_array_equal(m.structure.mass, [[100.0]])
    np.testing.assert_array_equal(m.structure.stiffness, [[0.0]])
    np.testing.assert_array_equal(m.structure.damping, [[0.0]])
    (gap,) = m.gaps
    assert gap.dofs == (0,) and gap.coefficients == (1.0,)
    assert gap.clearance == 0.005 and gap.side == "both"
    assert isinstance(gap.law, vi.contact.LankaraniNikravesh)
    assert gap.law.restitution == 0.9 and gap.law.exponent == 1.5
    geometry = vi.contact.Geometry(
        "ball-in-socket", radius1=0.010, radius2=0.0099, youngs_modulus=207e9, poisson=0.3
    )
    assert gap.law.stiffness == geometry
    assert gap.law.contact_stiffness == pytest.approx(1.509e11, rel=1e-3)
    np.testing.assert_array_equal(m.initial_velocity, [8.0])
    np.testing.assert_array_equal(m.initial_displacement, [0.0])
    assert m.loads == ()
    assert (mf.dt, mf.t_end, mf.every, mf.dofs) == (1e-6, 0.02, 1, None)
    assert mf.method == vi.Newmark()
    assert mf.path == MODELS / "sdof_paper_ln.toml"


def test_reference_example_is_the_paper_example() -> None:
    a = load_model(MODELS / "sdof_paper_ln.toml")
    path = MODELS / "sdof_paper_ln.toml"
    doc_a = tomllib.loads(path.read_text(encoding="utf-8"))
    doc_b = tomllib.loads(EXAMPLE)
    doc_a["gaps"][0].pop("name")
    assert doc_a == doc_b
    assert a.model.gaps[0].law == vi.contact.LankaraniNikravesh(
        stiffness=a.model.gaps[0].law.stiffness, exponent=1.5, restitution=0.9
    )


def test_two_dof_matrices_example() -> None:
    mf = load_model(MODELS / "two_dof_matrices.toml")
    s = mf.model.structure
    assert s.is_sparse  # matrices models keep their matrices sparse
    np.testing.assert_array_equal(s.mass.toarray(), [[1.0, 0.0], [0.0, 0.5]])
    np.testing.assert_array_equal(s.stiffness.toarray(), [[1500.0, -500.0], [-500.0, 500.0]])
    np.testing.assert_array_equal(s.damping.toarray(), [[0.3, -0.1], [-0.1, 0.1]])
    (gap,) = mf.model.gaps
    assert gap.dofs == (0, 1) and gap.coefficients == (1.0, -1.0)
    assert gap.clearance == 0.001 and gap.side == "both" and gap.name == "relative"
    assert gap.law == vi.contact.HuntCrossley(stiffness=1.0e9, exponent=1.5, restitution=0.8)
    assert mf.model.loads == (vi.HarmonicLoad(dof=1, amplitude=5.0, frequency=5.0, phase=0.0),)
    np.testing.assert_array_equal(mf.model.initial_velocity, [0.0, 0.0])
    assert (mf.dt, mf.t_end, mf.every, mf.dofs) == (1e-5, 1.0, 10, [0, 1])
    assert mf.method == vi.Newmark(gamma=0.5, beta=0.25)


def test_table_load_example_reads_the_csv() -> None:
    mf = load_model(MODELS / "table_load.toml")
    (load,) = mf.model.loads
    assert isinstance(load, vi.TableLoad) and load.dofs == (0,) and load.scale == 1.0
    table = np.loadtxt(MODELS / "table_load.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(load.time, table[:, 0])
    np.testing.assert_array_equal(load.force, table[:, 1])
    s = mf.model.structure
    assert (s.mass[0, 0], s.stiffness[0, 0], s.damping[0, 0]) == (2.0, 2000.0, 1.0)
    assert mf.model.gaps[0].law == vi.contact.Hertz(stiffness=5.0e8, exponent=1.5)
    assert mf.method == vi.Newmark()  # the default method


def test_relative_paths_are_relative_to_the_model_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    mf = load_model(Path(os.path.relpath(MODELS / "table_load.toml", tmp_path)))
    assert mf.model.loads[0].force[1] == 30.0


# ------------------------------------------------------------------------------------------
# Matrices from .npy and Matrix Market files
# ------------------------------------------------------------------------------------------

M = np.array([[2.0, 0.1, 0.0], [0.1, 1.5, 0.0], [0.0, 0.0, 0.7]])
K = np.array([[300.0, -100.0, 0.0], [-100.0, 250.0, -150.0], [0.0, -150.0, 150.0]])
C = np.array([[0.3, -0.1, 0.0], [-0.1, 0.25, -0.15], [0.0, -0.15, 0.15]]) / 7.0

MATRIX_MODEL = """
[structure]
kind = "matrices"
mass = {mass}
stiffness = {stiffness}
damping = {damping}

[[gaps]]
dof = 2
clearance = 0.001
[gaps.law]
kind = "hertz"
stiffness = 1e9

[solver]
dt = 1e-5
t_end = 0.01
"""


def write_matrix_model(folder: Path, **values: str) -> Path:
    path = folder / "model.toml"
    path.write_text(MATRIX_MODEL.format(**values), encoding="utf-8")
    return path


def inline(a: np.ndarray) -> str:
    return tomli_w.dumps({"a": a.tolist()}).removeprefix("a = ").strip()


def test_npy_and_mtx_matrices_load_like_inline_arrays(tmp_path: Path) -> None:
    ref = load_model(
        write_matrix_model(tmp_path, mass=inline(M), stiffness=inline(K), damping=inline(C))
    ).model.structure
    (tmp_path / "mats").mkdir()
    np.save(tmp_path / "mats" / "mass.npy", M)
    np.save(tmp_path / "mats" / "stiffness.npy", K)
    scipy.io.mmwrite(tmp_path / "mats" / "damping.mtx", C)  # dense (array format)
    scipy.io.mmwrite(tmp_path / "mats" / "stiffness.mtx", scipy.sparse.coo_matrix(K))
    scipy.io.mmwrite(tmp_path / "mats" / "mass.mtx", scipy.sparse.coo_matrix(M))
    for names in (
        ("mass.npy", "stiffness.npy", "damping.mtx"),
        ("mass.mtx", "stiffness.mtx", "damping.mtx"),
    ):
        keys = ("mass", "stiffness", "damping")
        quoted = {k: f'"mats/{n}"' for k, n in zip(keys, names, strict=True)}
        s = load_model(write_matrix_model(tmp_path, **quoted)).model.structure
        for key in ("mass", "stiffness", "damping"):
            np.testing.assert_array_equal(getattr(s, key).toarray(), getattr(ref, key).toarray(),
                                          err_msg=key)


def test_bad_matrix_files_are_refused(tmp_path: Path) -> None:
    np.save(tmp_path / "cube.npy", np.zeros((2, 2, 2)))
    np.save(tmp_path / "objects.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    np.save(tmp_path / "complex.npy", np.eye(3) * (1 + 1j))
    (tmp_path / "truncated.npy").write_bytes(b"\x93NUMPY\x01\x00")
    np.save(tmp_path / "asym.npy", K + np.triu(np.ones((3, 3)), 1))
    np.save(tmp_path / "small.npy", np.eye(2))
    path = write_matrix_model(
        tmp_path,
        mass='"cube.npy"',
        stiffness='"objects.npy"',
        damping='"complex.npy"',
    )
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert_errors_match(
        info.value.errors,
        [
            ("structure.mass", "expected a square matrix"),
            ("structure.stiffness", "readable .npy"),
            ("structure.damping", "real matrix"),
        ],
    )
    path = write_matrix_model(
        tmp_path, mass='"truncated.npy"', stiffness='"asym.npy"', damping='"small.npy"'
    )
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert_errors_match(
        info.value.errors,
        [
            ("structure.mass", "readable .npy"),
            ("structure.stiffness", "symmetric"),
            ("structure.damping", "shape (3, 3)"),
        ],
    )
    path = write_matrix_model(
        tmp_path, mass=inline(M), stiffness='"asym.npy"', damping='"small.npy"'
    )
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert_errors_match(
        info.value.errors,
        [("structure.stiffness", "symmetric"), ("structure.damping", "shape (3, 3)")],
    )


# ------------------------------------------------------------------------------------------
# Loader details
# ------------------------------------------------------------------------------------------


def test_missing_and_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(ModelFileError) as info:
        load_model(tmp_path / "nope.toml")
    assert len(info.value.errors) == 1 and "cannot read the model file" in str(info.value)
    bad = tmp_path / "latin1.toml"
    bad.write_bytes(b'[structure]\nkind = "sdof"\n# caf\xe9\n')
    with pytest.raises(ModelFileError) as info:
        load_model(bad)
    assert info.value.errors == [
        "latin1.toml:3: invalid TOML (byte 0xe9 is not UTF-8); expected a UTF-8 text file"
    ]


def test_error_line_format() -> None:
    with pytest.raises(ModelFileError) as info:
        load_model(BAD / "law_restitution_above_one.toml")
    assert info.value.errors == [
        "gaps[1].law.restitution: 1.2 is not valid; expected a number with 0 <= restitution <= 1"
    ]
    with pytest.raises(ModelFileError) as info:
        load_model(BAD / "gap_unknown_key.toml")
    assert info.value.errors == [
        "gaps[0].clearence: unknown key; did you mean 'clearance'? expected one of: kind, "
        "dof, coefficients, clearance, side, name, law"
    ]


def test_the_schema_is_one_table() -> None:
    paths = [f.path for f in SCHEMA]
    for required in ("structure.kind", "gaps[].law.geometry.poisson", "loads[].file"):
        assert required in paths
    for f in SCHEMA:
        assert f.description and f.type, f.path


def test_reference_docs_are_generated_from_the_schema() -> None:
    committed = (ROOT / "docs" / "model-file.md").read_text(encoding="utf-8")
    assert committed == render_reference(), (
        "docs/model-file.md is stale; run: python -m vibroimpact.docs"
    )


# ------------------------------------------------------------------------------------------
# The run command
# ------------------------------------------------------------------------------------------


def test_run_json_reproduces_the_paper_peak(tmp_path: Path) -> None:
    proc = cli("run", MODELS / "sdof_paper_ln.toml", "--json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    for key in (
        "max_abs_displacement",
        "impacts",
        "steps",
        "newton_iterations",
        "wall_time_s",
        "energy_balance_error",
    ):
        assert key in summary
    assert summary["max_abs_displacement"][0] == pytest.approx(6.19e-3, abs=0.05e-3)
    assert summary["steps"] == 20000
    assert summary["step_path"] == "fixed-size N=1"  # the 1-DOF model's compiled step
    assert len(summary["impacts"]) >= 5
    assert {"t_start", "v_in", "v_out", "delta_max", "force_max"} <= set(summary["impacts"][0])
    assert list(tmp_path.iterdir()) == []


def run_args(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="vibroimpact")
    run_cli.add_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args(["run", *argv])


def test_run_writes_results_and_impacts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "res.csv"
    assert run_cli.main(run_args(str(MODELS / "table_load.toml"), "-o", str(out))) == 0
    text = capsys.readouterr().out
    assert "peak |x0|" in text and " m\n" in text and "impacts" in text
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "res.csv", "res_energy.csv", "res_impacts.csv", "res_meta.json"
    ]
    header = out.read_text().splitlines()[0].split(",")
    assert header[:3] == ["time [s]", "x0 [m]", "v0 [m/s]"]
    impacts = (tmp_path / "res_impacts.csv").read_text().splitlines()
    assert impacts[0].startswith("gap,side,t_start [s],t_end [s],v_in [m/s]")
    assert len(impacts) == 1 + 3
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask  # not the 0o600 of a temporary file


def test_run_refuses_other_suffixes_before_running(tmp_path: Path) -> None:
    proc = cli("run", MODELS / "sdof_paper_ln.toml", "-o", tmp_path / "res.txt")
    assert proc.returncode == 2
    assert proc.stderr.splitlines() == [
        PREFIX + f"-o: {str(tmp_path / 'res.txt')!r} is not valid; expected a file name ending "
        "in .nc or .h5 or .hdf5 or .csv"
    ]
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ModelFileError) as info:
        run_cli.main(run_args(str(BAD / "sdof_mass_zero.toml"), "-o", str(tmp_path / "x/y.csv")))
    assert [e.split(":")[0] for e in info.value.errors] == ["structure.mass", "-o"]


def test_a_failed_write_leaves_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import pandas as pd

    to_csv = pd.DataFrame.to_csv

    def failing(self: pd.DataFrame, path: Any, *args: Any, **kwargs: Any) -> None:
        if "_impacts" in str(path):
            Path(path).write_text("partial")
            raise OSError(28, "No space left on device", str(path))
        to_csv(self, path, *args, **kwargs)

    monkeypatch.setattr(pd.DataFrame, "to_csv", failing)
    with pytest.raises(ModelError, match=r"^-o: cannot write .*No space left on device$"):
        run_cli.main(run_args(str(MODELS / "sdof_paper_ln.toml"), "-o", str(tmp_path / "r.csv")))
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------------------
# Property: whatever the document, the loader answers with a ModelFileError (or a model)
# ------------------------------------------------------------------------------------------

KEYS = sorted({part for f in SCHEMA for part in f.path.replace("[]", "").split(".")})
WORDS = [
    "sdof", "matrices", "both", "positive", "hertz", "hunt-crossley", "lankarani-nikravesh",
    "kelvin-voigt", "ball-in-socket", "sphere-plane", "harmonic", "table", "constant",
    "newmark", "", ".", "model.toml", "x.npy", "x.mtx", "x.csv",
    "calculix", "abaqus", "npz", "x.sti", "x.dof", "101.x", "ry", "all",
]  # fmt: skip

keys = st.one_of(st.sampled_from(KEYS), st.text(max_size=6))
scalars = st.one_of(
    st.integers(min_value=-(2**66), max_value=2**66),
    st.floats(),
    st.booleans(),
    st.sampled_from(WORDS),
    st.text(max_size=8),
    st.dates(),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(keys, inner, max_size=4)),
    max_leaves=12,
)


def check_loader_on(doc: dict[str, Any], folder: Path) -> None:
    path = folder / "model.toml"
    path.write_text(tomli_w.dumps(doc), encoding="utf-8")
    try:
        load_model(path)
    except ModelFileError as e:
        assert e.errors
        for line in e.errors:
            assert line and "\n" not in line and ": " in line
            assert "expected" in line


@pytest.fixture(scope="module")
def scratch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("hypothesis")


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(doc=st.dictionaries(keys, values, max_size=7))
def test_random_documents_give_only_model_file_errors(doc: dict[str, Any], scratch: Path) -> None:
    check_loader_on(doc, scratch)


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*prefix, i))
    return out


def _absolute_paths(doc: dict[str, Any], folder: Path) -> dict[str, Any]:
    """``doc`` with its matrix file paths made absolute (the mutants are written elsewhere)."""
    for key in ("mass", "stiffness", "damping"):
        if isinstance(doc["structure"].get(key), str):
            doc["structure"][key] = str(folder / doc["structure"][key])
    return doc


BASES = [
    _absolute_paths(tomllib.loads((MODELS / name).read_text(encoding="utf-8")), MODELS)
    for name in ("sdof_paper_ln.toml", "two_dof_matrices.toml", "lumped_cantilever.toml")
]


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_mutated_models_give_only_model_file_errors(data: st.DataObject, scratch: Path) -> None:
    doc = json.loads(json.dumps(data.draw(st.sampled_from(BASES))))
    for _ in range(data.draw(st.integers(1, 3))):
        target = data.draw(st.sampled_from(_paths(doc)))
        *parents, last = target
        node = doc
        for p in parents:
            node = node[p]
        action = data.draw(st.sampled_from(["replace", "delete", "add"]))
        if action == "delete" and isinstance(node, dict):
            del node[last]
        elif action == "add" and isinstance(node, dict):
            node[data.draw(keys)] = data.draw(values)
        else:
            node[last] = data.draw(values)
    check_loader_on(doc, scratch)
