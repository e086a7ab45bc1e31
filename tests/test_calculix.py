"""CalculiX round trips (issue 23): small models written as ``.inp`` decks (the bricks by
:func:`vibroimpact.benchmarks.calculix.brick_mesh`, the shells here), exported by
``ccx`` with ``*FREQUENCY, SOLVER=MATRIXSTORAGE`` (the recipe of docs/beam.md), imported, and
their frequencies compared with CalculiX's own ``*FREQUENCY`` step on the same deck.

Models (steel, clamped at x = 0): a 0.1 × 0.02 × 0.04 m block of 2 × 1 × 2 twenty-node bricks,
C3D20 (full integration, definite mass) and C3D20R (reduced integration: a positive
semi-definite mass, 30 massless modes of 114 DOFs), and a 0.1 × 0.04 m plate of 2 × 1 S8R
shells, 2 mm thick (CalculiX expands each node into two or three layers: repeated labels in
``job.dof``, a singular mass). CalculiX prints 7 digits, so 1e-6 is the comparison's floor.
Skipped without ``ccx`` (Debian/Ubuntu: ``apt-get install calculix-ccx``; ``.ci/run`` does).
"""

from __future__ import annotations

import json
import re
import shutil
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse.linalg
from vibroimpact import ContactResolutionWarning, Gap, HarmonicLoad, Model, Newmark, simulate
from vibroimpact.benchmarks.calculix import EXPORT_STEP, MATERIAL, brick_mesh, run_ccx
from vibroimpact.cli import main as cli_main
from vibroimpact.contact import Hertz
from vibroimpact.fe import FEStructure, modes
from vibroimpact.fe.matrices import read_calculix
from vibroimpact.io.model_file import load_model

pytestmark = pytest.mark.skipif(
    shutil.which("ccx") is None,
    reason="CalculiX is not installed (no ccx on PATH; apt-get install calculix-ccx, as "
    ".ci/run does)",
)

FREQUENCY = "*FREQUENCY\n10\n"


def shell_mesh(nx: int = 2, ny: int = 1) -> str:
    """Eight-node S8R shells on a 0.1 × 0.04 m plate, 2 mm thick, clamped at x = 0."""
    grid = (2 * nx + 1, 2 * ny + 1)
    label: dict[tuple[int, int], int] = {}
    lines = ["*NODE"]
    for j in range(grid[1]):
        for i in range(grid[0]):
            if i % 2 and j % 2:
                continue
            label[(i, j)] = len(label) + 1
            lines.append(f"{label[(i, j)]}, {0.1 * i / (grid[0] - 1)!r}, "
                         f"{0.04 * j / (grid[1] - 1)!r}, 0.0")
    pattern = [(0, 0), (2, 0), (2, 2), (0, 2), (1, 0), (2, 1), (1, 2), (0, 1)]
    lines.append("*ELEMENT, TYPE=S8R, ELSET=E")
    for e, (ey, ex) in enumerate(((ey, ex) for ey in range(ny) for ex in range(nx)), 1):
        nodes = [label[(2 * ex + a, 2 * ey + b)] for a, b in pattern]
        lines.append(f"{e}, " + ", ".join(map(str, nodes)))
    lines += ["*NSET, NSET=FIXED", *(str(n) for (i, _), n in label.items() if i == 0)]
    return ("\n".join(lines) + "\n" + MATERIAL
            + "*SHELL SECTION, ELSET=E, MATERIAL=STEEL\n0.002\n")


def ccx(folder: Path, job: str, model: str, step: str) -> Path:
    """Run ``ccx job`` on ``model`` + a clamped ``step`` in ``folder``; the job's path."""
    return run_ccx(folder, job, model + "*BOUNDARY\nFIXED, 1, 3\n*STEP\n" + step
                   + "*END STEP\n")


def calculix_frequencies(dat: Path) -> np.ndarray:
    """The real frequencies (Hz) of the eigenvalue table of a ccx ``.dat`` file (modes with
    a negative or round-off eigenvalue, which ccx lists with an imaginary part or 0 Hz,
    dropped)."""
    text = dat.read_text()
    table = text[text.index("E I G E N V A L U E   O U T P U T"):]
    table = table[: table.index("P A R T I C I P A T I O N")]
    rows = [[float(x) for x in line.split()[1:]] for line in table.splitlines()
            if re.match(r"\s+\d+\s+-?\d\.\d+E[+-]\d+", line)]
    lam = np.array([r[0] for r in rows])
    hz = np.array([r[2] for r in rows])
    return hz[lam > 1e-6 * lam.max()]


MODELS = {
    "C3D20": lambda: brick_mesh("C3D20").model,
    "C3D20R": lambda: brick_mesh("C3D20R").model,
    "S8R": shell_mesh,
}


@pytest.fixture(scope="module", params=sorted(MODELS))
def exported(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
             ) -> tuple[str, Path, np.ndarray]:
    """(element, the exported job, CalculiX's own frequencies) per model."""
    folder = tmp_path_factory.mktemp(request.param)
    model = MODELS[request.param]()
    job = ccx(folder, "export", model, EXPORT_STEP)
    dat = ccx(folder, "frequency", model, FREQUENCY).with_suffix(".dat")
    return request.param, job, calculix_frequencies(dat)


def test_imported_frequencies_equal_calculix_frequencies(exported: tuple[str, Path, np.ndarray]
                                                         ) -> None:
    element, job, reference = exported
    fe = read_calculix(job)
    assert fe.singular_mass == (element != "C3D20")
    found = modes(fe, len(reference)).elastic_frequencies_hz
    np.testing.assert_allclose(found, reference, rtol=1e-6)
    assert len(reference) >= 8


def test_expanded_shell_layers_are_labelled(exported: tuple[str, Path, np.ndarray]) -> None:
    element, job, _ = exported
    dm = read_calculix(job).dof_map
    assert dm is not None
    labels = dm.labels()
    assert len(set(labels)) == len(labels)
    if element != "S8R":
        assert not any(dm.layers)
        return
    # node 3 is a free corner (3 layers), node 2 a free midside node (2 layers)
    assert [lab for lab in labels if lab.startswith("3.x")] == ["3.x@1", "3.x@2", "3.x@3"]
    assert [lab for lab in labels if lab.startswith("2.x")] == ["2.x@1", "2.x@2"]
    assert dm.layer_dofs(3, "x") == [i for i, lab in enumerate(labels) if lab.startswith("3.x")]


def tip_dof(job: Path) -> int:
    """The z DOF of the last node (at x = 0.1, a corner: for S8R its first layer)."""
    dm = read_calculix(job).dof_map
    assert dm is not None
    tip = max(dm.nodes)
    return (dm.layer_dofs(tip, "z") or [dm.index(tip, "z")])[0]


def test_model_file_modal_and_a_gap_on_the_null_space(
    exported: tuple[str, Path, np.ndarray], capsys: pytest.CaptureFixture[str]
) -> None:
    """``vibroimpact modal`` on a model file of the exported files gives CalculiX's
    frequencies; a Hertz gap on a node runs on every model (on C3D20R and S8R every node has
    a part in the massless modes: the law in series with their compliance), a damped law
    there is refused in one line."""
    element, job, reference = exported
    model = job.parent / "model.toml"
    structure = (f'[structure]\nkind = "matrices"\nmass = "{job.name}.mas"\n'
                 f'stiffness = "{job.name}.sti"\n')
    model.write_text(structure, encoding="utf-8")
    assert cli_main(["modal", str(model), "--modes", str(len(reference)), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(got["frequencies_hz"], reference, rtol=1e-6)
    dof = tip_dof(job)
    gap = (f'[[gaps]]\ndof = {dof}\nclearance = 1e-6\n[gaps.law]\nkind = "{{}}"\n'
           'stiffness = 1e10\n{}[solver]\ndt = 1e-6\nt_end = 2e-5\n')
    model.write_text(structure + gap.format("hertz", ""), encoding="utf-8")
    code = cli_main(["run", str(model), "-o", str(job.parent / "out.nc")])
    assert code == 0, capsys.readouterr().err
    capsys.readouterr()
    model.write_text(structure + gap.format("hunt-crossley", "restitution = 0.8\n"),
                     encoding="utf-8")
    code = cli_main(["run", str(model), "-o", str(job.parent / "damped.nc")])
    err = capsys.readouterr().err
    if element == "C3D20":
        assert code == 0, err
        return
    assert code == 2, err
    assert err.count("\n") == 1 and "error: gaps[0].law: 'hunt-crossley' is not valid" in err
    assert "expected hertz" in err and not (job.parent / "damped.nc").exists()


def dense_newmark(fe: FEStructure, dof: int, law: Hertz, clearance: float,
                  v0: np.ndarray, dt: float, steps: int, x0: np.ndarray | None = None,
                  force: Callable[[float], np.ndarray] | None = None) -> np.ndarray:
    """Average-acceleration Newmark on the full matrices (a singular ``M`` as it is: the
    massless rows are static equations in the step's ``(K + 4M/dt²) x = ...``) from ``x0``
    (default 0) and ``v0``, under ``force(t)`` (full DOFs) if given, with a Hertz wall on
    ``dof`` solved by Newton: the displacement history, one row per step."""
    m, k = fe.mass.toarray(), fe.stiffness.toarray()
    load = force or (lambda t: np.zeros(fe.n_dof))
    x = np.zeros(fe.n_dof) if x0 is None else x0.copy()
    v = v0.copy()
    a = np.linalg.lstsq(m, load(0.0) - k @ x, rcond=None)[0]  # only M a enters the steps
    keff = k + 4 / dt**2 * m
    rows = [x]
    for n in range(steps):
        rhs = m @ (4 / dt**2 * x + 4 / dt * v + a) + load((n + 1) * dt)
        xn = np.linalg.solve(keff, rhs)
        for _ in range(50):
            p = xn[dof] - clearance
            f, df = ((law.stiffness * p**1.5, 1.5 * law.stiffness * p**0.5) if p > 0
                     else (0.0, 0.0))
            r = keff @ xn - rhs
            r[dof] += f
            j = keff.copy()
            j[dof, dof] += df
            step = np.linalg.solve(j, -r)
            xn = xn + step
            if np.abs(step).max() <= 1e-14 * np.abs(xn).max():
                break
        an = 4 / dt**2 * (xn - x) - 4 / dt * v - a  # M an = f - K xn (not an itself)
        v, a, x = v + dt / 2 * (a + an), an, xn
        rows.append(x)
    return np.array(rows)


@pytest.mark.parametrize("exported", ["C3D20", "C3D20R"], indirect=True)
def test_a_gap_on_the_massless_modes_equals_the_full_singular_model(
    exported: tuple[str, Path, np.ndarray]
) -> None:
    """A Hertz wall on the tip of the condensed model (its law in series with the massless
    modes' compliance, the recovery adding their static response to the contact force) gives
    the displacements and the penetration of Newmark on the full, singular matrices stepped
    here with the original law, to round-off; the reduced velocities and ``M a`` too (the
    massless DOFs' own velocity is the exact derivative here, a Newmark recursion there)."""
    element, job, _ = exported
    fe = read_calculix(job)
    cond = fe.condense_massless()
    dof, clearance, dt, steps = tip_dof(job), 2e-6, 2.5e-7, 400
    gap = Gap(dof=dof, law=Hertz(stiffness=1e9), clearance=clearance)
    assert (cond.gap_compliance(gap) > 0) == (element != "C3D20")
    _, phi = scipy.linalg.eigh(cond.structure.stiffness.toarray(),
                               cond.structure.mass.toarray())
    tip_velocity = (cond.transform @ phi[:, :6])[dof]
    mode = int(np.argmax(np.abs(tip_velocity)))
    q0 = phi[:, mode] * 0.3 / tip_velocity[mode]  # the tip towards the wall at 0.3 m/s
    model = Model(cond.structure.to_structure(), gaps=cond.reduce_gaps([gap]),
                  initial_velocity=q0)
    recovery = cond.output(None, [gap])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ContactResolutionWarning)
        run = simulate(model, steps * dt, dt, Newmark(), dofs=recovery.record.tolist())
    got = recovery.result(run)
    x = dense_newmark(fe, dof, gap.law, clearance, np.asarray(cond.transform @ q0), dt, steps)
    assert got.gap_force.max() > 10  # in contact for most of the run
    scale = np.abs(x).max()
    np.testing.assert_allclose(got.displacement, x, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(got.gap_penetration[:, 0], x[:, dof] - clearance, rtol=0,
                               atol=1e-9 * scale)
    if element == "C3D20R":  # without the contact's static part the tip would be off
        plain = np.asarray(cond.transform @ run.displacement.T).T
        assert np.abs(plain[:, dof] - x[:, dof]).max() > 1e-4 * scale


@pytest.mark.parametrize("exported", ["C3D20R"], indirect=True)
def test_a_load_and_a_mode_shape_on_the_massless_modes_equal_the_full_singular_model(
    exported: tuple[str, Path, np.ndarray]
) -> None:
    """A tip load of the C3D20R block has a part in the massless modes (which respond to it
    statically, ``G f F(t)``, added by the recovery): its static deflection ``T K_r⁻¹ Tᵀ f +
    G f`` equals ``K⁻¹ f`` of the full matrices, and a harmonic load on a run started from a
    mode shape ``T φ`` (not refused: it is a state of the condensed model, though ``Zᵀ T φ ≠
    0``) gives the displacements of Newmark on the full, singular matrices to round-off."""
    _, job, _ = exported
    fe = read_calculix(job)
    cond = fe.condense_massless()
    dof, dt, steps = tip_dof(job), 2.5e-7, 300
    load = HarmonicLoad(dof=dof, amplitude=200.0, frequency=20e3)
    f = np.zeros(fe.n_dof)
    f[dof] = 1.0
    assert cond.null_part(f) > 1e-3 and cond.load_response(load) is not None
    t = cond.transform.toarray()
    static = (t @ np.linalg.solve(cond.structure.stiffness.toarray(), t.T @ f)
              + cond.load_response(load))
    full = np.linalg.solve(fe.stiffness.toarray(), f)
    np.testing.assert_allclose(static, full, rtol=0, atol=1e-10 * np.abs(full).max())

    _, phi = scipy.linalg.eigh(cond.structure.stiffness.toarray(),
                               cond.structure.mass.toarray())
    x0 = t @ phi[:, 0] * 1e-7 / np.abs(t @ phi[:, 0]).max()
    assert cond.null_part(x0) > 1e-3  # refused by a test on Zᵀx alone
    model = Model(cond.structure.to_structure(), loads=cond.reduce_load(load),
                  initial_displacement=cond.reduce_state(x0))
    recovery = cond.output(None, [], [load])
    got = recovery.result(simulate(model, steps * dt, dt, Newmark(),
                                   dofs=recovery.record.tolist()))
    x = dense_newmark(fe, dof, Hertz(stiffness=1.0), 1.0, np.zeros(fe.n_dof), dt, steps, x0,
                      lambda time: f * load.force_and_rates(time)[0])
    scale = np.abs(x).max()
    assert np.abs(x[:, dof]).max() > 3 * np.abs(x0[dof])  # the load moves the tip
    np.testing.assert_allclose(got.displacement, x, rtol=0, atol=1e-9 * scale)
    without = got.displacement - np.outer(load.force_and_rates(got.time)[0],
                                          cond.load_response(load))
    assert np.abs(without - x).max() > 1e-4 * scale  # the static part matters here


def _plate_static(tmp_path: Path, tip_index: int, direction: int
                  ) -> tuple[FEStructure, dict[int, list[float]], list[int], int, float]:
    """A 4 × 2 S8R plate (supported at x = 0 and in z at x = 12.5 mm) exported by ccx, and
    ccx's own ``*STATIC`` displacements at every free node for a 1 N load in ``direction``
    (1-3) on the ``tip_index``-th node of the tip edge: (fe, printed, free nodes, the loaded
    node, the printed peak)."""
    model = shell_mesh(4, 2)
    xyz = {int(a[0]): float(a[1]) for a in (line.split(",") for line in
                                            model.split("*ELEMENT")[0].splitlines()[1:])}
    support = [n for n, x in xyz.items() if abs(x - 0.0125) < 1e-9]
    free = [n for n, x in xyz.items() if x > 0.013]
    tip = [n for n, x in xyz.items() if abs(x - 0.1) < 1e-9][tip_index]
    model += ("*NSET, NSET=SUPPORT\n" + "\n".join(map(str, support))
              + "\n*NSET, NSET=FREE\n" + "\n".join(map(str, free)) + "\n"
              "*BOUNDARY\nFIXED, 1, 3\nSUPPORT, 3, 3\n")
    job = run_ccx(tmp_path, "export", model + "*STEP\n" + EXPORT_STEP + "*END STEP\n")
    static = run_ccx(tmp_path, "static", model + f"*STEP\n*STATIC\n*CLOAD\n{tip}, {direction}, "
                     "1.0\n*NODE PRINT, NSET=FREE\nU\n*END STEP\n")
    printed = {int(p[0]): [float(v) for v in p[1:]] for p in
               (line.split() for line in static.with_suffix(".dat").read_text().splitlines())
               if len(p) == 4 and p[0].isdigit()}
    assert sorted(printed) == sorted(free)
    peak = max(abs(v) for row in printed.values() for v in row)
    return read_calculix(job), printed, free, tip, peak


def _shell_nodes(fe: FEStructure, x: np.ndarray, nodes: list[int]) -> dict[int, list[float]]:
    """Each shell node's x, y, z displacement: the mean of its layers (shell_weights)."""
    dm = fe.dof_map
    assert dm is not None
    return {n: [float(np.dot(x[d], w)) for d, w in (dm.shell_weights(n, c) for c in "xyz")]
            for n in nodes}


def test_a_shell_node_is_the_mean_of_its_layers(tmp_path: Path) -> None:
    """CalculiX's own ``*STATIC`` result at every free node of an S8R plate (4 × 2 shells,
    supported at x = 0 and in z at x = 12.5 mm, a 1 N z load at the midside node of the tip
    edge) equals ``DofMap.shell_weights`` applied to the solve with the exported stiffness,
    the load spread over the layers by the same weights, to 1e-6 of the peak (CalculiX
    prints 7 digits); a model file's gap by that node acts on those weights."""
    fe, printed, free, tip, peak = _plate_static(tmp_path, 1, 3)  # midside, 2 layers
    dm = fe.dof_map
    assert dm is not None
    dofs, weights = dm.shell_weights(tip, "z")
    assert weights == [0.5, 0.5]
    f = np.zeros(fe.n_dof)
    f[dofs] = weights
    x = scipy.sparse.linalg.spsolve(fe.stiffness.tocsc(), f)
    ours = _shell_nodes(fe, x, free)
    assert {len(dm.layer_dofs(n, "x")) for n in free} == {2, 3}  # midside and corner nodes
    for n in free:
        np.testing.assert_allclose(ours[n], printed[n], rtol=0, atol=1e-6 * peak)
    layers = np.array([x[d] for d in dm.layer_dofs(tip, "x")])
    assert np.abs(layers).max() > 1e-3 * peak  # the layers differ: the mean matters

    toml = tmp_path / "model.toml"
    toml.write_text(f'[structure]\nkind = "matrices"\nmass = "export.mas"\n'
                    f'stiffness = "export.sti"\n[[gaps]]\nnode = {tip}\ndirection = "z"\n'
                    'clearance = 1e-6\n[gaps.law]\nkind = "hertz"\nstiffness = 1e9\n'
                    '[solver]\ndt = 1e-6\nt_end = 1e-5\n', encoding="utf-8")
    gap = load_model(toml).file_gaps[0]
    assert list(gap.dofs) == dofs and list(gap.coefficients) == weights


@pytest.mark.parametrize("direction", [1, 3])
def test_a_load_on_a_shell_corner_is_spread_as_calculix_spreads_it(
        tmp_path: Path, direction: int) -> None:
    """A 1 N ``*CLOAD`` on a corner node of the S8R plate's tip (3 layers), in x (in-plane)
    and z (bending): ccx ties the loaded node to its layers by ``2u = −u₁ + 4u₂ − u₃`` (its
    gen3dforc), so the force does work on them as −1/2, 2, −1/2
    (``DofMap.shell_load_weights``), and the solve with the exported stiffness gives ccx's
    own displacement at every free node to 1e-6 of the peak (measured 1e-7 and 3e-7), where
    the mean's weights 1/6, 2/3, 1/6 are 8e-6 and 9e-4 off. A model file's load by
    ``nodes = [corner]`` is spread the same way (its loads' weights sum to these)."""
    fe, printed, free, tip, peak = _plate_static(tmp_path, 0, direction)
    dm = fe.dof_map
    assert dm is not None
    c = "xyz"[direction - 1]
    dofs, weights = dm.shell_load_weights(tip, c)
    assert weights == [-0.5, 2.0, -0.5]

    def worst(w: list[float]) -> float:
        f = np.zeros(fe.n_dof)
        f[dofs] = w
        ours = _shell_nodes(fe, scipy.sparse.linalg.spsolve(fe.stiffness.tocsc(), f), free)
        return max(abs(a - b) for n in free for a, b in zip(ours[n], printed[n], strict=True))

    assert worst(weights) < 1e-6 * peak
    assert worst(dm.shell_weights(tip, c)[1]) > 5e-6 * peak  # the mean's weights are not it

    toml = tmp_path / "model.toml"
    toml.write_text(f'[structure]\nkind = "matrices"\nmass = "export.mas"\n'
                    f'stiffness = "export.sti"\n[[loads]]\nkind = "constant"\n'
                    f'nodes = [{tip}]\ndirection = "{c}"\namplitude = 1.0\n'
                    '[solver]\ndt = 1e-6\nt_end = 1e-5\n', encoding="utf-8")
    spread = np.zeros(fe.n_dof)
    for ld in load_model(toml).file_loads:
        spread[list(ld.dofs)] += ld.amplitude
    expected = np.zeros(fe.n_dof)
    expected[dofs] = weights
    np.testing.assert_array_equal(spread, expected)
