"""Singular masses without zero rows, damping rules and node outputs on ``kind = "matrices"``
model files (issue 23 items 2 and 3).

The structure: the lumped-mass cantilever of ``test_fe_condensation`` (5 elements, mass on the
translations ``x``, massless rotations ``ry``) in mixed coordinates: the four DOFs of nodes 4
and 5 are replaced by a random orthogonal combination of them, so that ``M`` keeps the zero
rows of nodes 1–3's rotations and gains a null space that is no set of rows (as a C3D20R or S8R
mass has). The reference removes that null space by hand: undo the rotation (the test knows
it), condense the rotations with NumPy (``K_r = K_mm − K_ms K_ss⁻¹ K_sm``), integrate with
the same integrator, recover the rotations and rotate back.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import vibroimpact as vi
from test_fe_condensation import ELEMENTS, lumped_cantilever
from vibroimpact.fe.matrices import read_structure, write_calculix
from vibroimpact.io import ModelFileError, load_model

MIXED = [6, 7, 8, 9]  # node 4 x, ry and node 5 x, ry
ROTATION = np.linalg.qr(np.random.default_rng(23).standard_normal((4, 4)))[0]
GAP_DOF, LOAD_DOF = 4, 2  # node 3 x and node 2 x: untouched, in the range of M
DT, T_END = 5e-6, 0.02


def mixing() -> np.ndarray:
    """``x = Q y``: identity but on the DOFs MIXED."""
    q = np.eye(2 * ELEMENTS)
    q[np.ix_(MIXED, MIXED)] = ROTATION
    return q


def plain() -> tuple[np.ndarray, np.ndarray]:
    fe = lumped_cantilever()
    return fe.mass.toarray(), fe.stiffness.toarray()


def mixed_files(folder: Path) -> None:
    m, k = plain()
    q = mixing()
    np.save(folder / "M.npy", q @ m @ q.T)
    np.save(folder / "K.npy", q @ k @ q.T)


def by_hand(y0_velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M_r, K_r, T) of the unmixed model, the rotations condensed with NumPy: y = T y_m."""
    m, k = plain()
    s = np.arange(1, 2 * ELEMENTS, 2)
    mm = np.arange(0, 2 * ELEMENTS, 2)
    ts = -np.linalg.solve(k[np.ix_(s, s)], k[np.ix_(s, mm)])
    t = np.zeros((2 * ELEMENTS, ELEMENTS))
    t[mm] = np.eye(ELEMENTS)
    t[s] = ts
    return m[np.ix_(mm, mm)], t.T @ k @ t, t


MODEL = """\
[structure]
kind = "matrices"
mass = "M.npy"
stiffness = "K.npy"
{damping}
[[gaps]]
dof = {gap}
clearance = 2e-5
side = "both"
[gaps.law]
kind = "hertz"
stiffness = 1e9

[[loads]]
kind = "harmonic"
dof = {load}
amplitude = 40.0
frequency = 30.0

[initial]
velocity = {velocity}

[solver]
method = "newmark"
dt = {dt}
t_end = {t_end}
"""


def write(folder: Path, damping: str = "", velocity: list[float] | None = None) -> Path:
    v = velocity if velocity is not None else [0.05 if i in (0, 2, 4) else 0.0
                                               for i in range(2 * ELEMENTS)]
    path = folder / "model.toml"
    path.write_text(MODEL.format(damping=damping, gap=GAP_DOF, load=LOAD_DOF, velocity=v,
                                 dt=DT, t_end=T_END), encoding="utf-8")
    return path


def test_time_response_equals_the_null_space_removed_by_hand(tmp_path: Path) -> None:
    mixed_files(tmp_path)
    mf = load_model(write(tmp_path))
    cond = mf.condensation
    assert cond is not None and len(cond.retained) == 0  # generalized coordinates
    assert cond.null_space.shape == (2 * ELEMENTS, ELEMENTS)
    assert list(cond.condensed) == [1, 3, 5]  # the zero rows left: rotations of nodes 1-3
    ours = mf.simulate()
    assert len(ours.impacts) >= 2

    v0 = np.array([0.05 if i in (0, 2, 4) else 0.0 for i in range(2 * ELEMENTS)])
    m_r, k_r, t = by_hand(v0)
    law = vi.contact.Hertz(stiffness=1e9)
    model = vi.Model(
        vi.Structure(m_r, k_r),  # y_m = x of nodes 1..5 (DOFs 0, 2, ..., 8 of y)
        gaps=[vi.Gap(dof=GAP_DOF // 2, law=law, clearance=2e-5, side="both")],
        loads=[vi.HarmonicLoad(dof=LOAD_DOF // 2, amplitude=40.0, frequency=30.0)],
        initial_velocity=v0[0::2],
    )
    ref = vi.simulate(model, t_end=T_END, dt=DT, method=vi.integrators.Newmark())
    x_ref = (mixing() @ t @ np.asarray(ref.displacement).T).T
    scale = np.abs(x_ref).max()
    np.testing.assert_allclose(ours.time, ref.time, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ours.displacement, x_ref, rtol=0, atol=1e-9 * scale)
    a, b = ours.impacts.to_records(), ref.impacts.to_records()
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x["t_start"] == pytest.approx(y["t_start"], abs=1e-12)
        assert x["force_max"] == pytest.approx(y["force_max"], rel=1e-7)


def test_states_on_the_null_space_are_refused_gaps_there_are_not(tmp_path: Path) -> None:
    """A gap on a DOF with a part in the null space runs (its law in series with the massless
    modes' compliance, tests/test_calculix.py); an initial state there is refused."""
    mixed_files(tmp_path)
    v = [0.05 if i in (0, 2, 8) else 0.0 for i in range(2 * ELEMENTS)]  # DOF 8 is mixed
    text = write(tmp_path, velocity=v).read_text().replace(f"dof = {GAP_DOF}", "dof = 6")
    (tmp_path / "model.toml").write_text(text, encoding="utf-8")
    with pytest.raises(ModelFileError) as e:
        load_model(tmp_path / "model.toml")
    errors = e.value.errors
    assert len(errors) == 1, errors
    assert errors[0].startswith("initial.velocity: [") and "no part in the null space" in errors[0]


def test_an_indefinite_mass_names_its_negative_eigenvalue(tmp_path: Path) -> None:
    m, k = plain()
    m[7, 7] = 1e-3  # node 4: ry with a little inertia, coupled to x (0.16 kg) too strongly
    m[6, 7] = m[7, 6] = 0.1
    np.save(tmp_path / "M.npy", m)
    np.save(tmp_path / "K.npy", k)
    lam = np.linalg.eigvalsh(m)[0]
    assert lam < 0
    with pytest.raises(ModelFileError) as e:
        load_model(write(tmp_path))
    assert e.value.errors == [
        f"structure.mass: not positive semi-definite (eigenvalue {lam:.6g}, the largest being "
        f"{np.linalg.eigvalsh(m)[-1]:.6g}: 1 below -1e-10 times it); expected a symmetric "
        "positive semi-definite mass matrix"
    ]


def damping_ratios(structure: vi.Structure) -> tuple[np.ndarray, np.ndarray]:
    """(ω, ζ) of the damped modes, from the state-space eigenvalues of (M, C, K)."""
    m, c, k = (np.asarray(a.toarray() if hasattr(a, "toarray") else a)
               for a in (structure.mass, structure.damping, structure.stiffness))
    n = m.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    return np.abs(lam), -lam.real / np.abs(lam)


@pytest.mark.parametrize("rule", ["rayleigh", "modal"])
def test_damping_rules_give_the_requested_modal_ratios(tmp_path: Path, rule: str) -> None:
    mixed_files(tmp_path)
    m_r, k_r, _ = by_hand(np.zeros(2 * ELEMENTS))
    omega = np.sqrt(scipy.linalg.eigh(k_r, m_r, eigvals_only=True))
    f = omega / (2 * np.pi)
    if rule == "rayleigh":
        table = ('[structure.damping]\nkind = "rayleigh"\n'
                 f"frequencies = [{float(f[0])!r}, {float(f[2])!r}]\nratios = [0.02, 0.05]\n")
        modes, wanted = [0, 2], [0.02, 0.05]
    else:
        table = '[structure.damping]\nkind = "modal"\nratios = [0.01, 0.03, 0.02]\n'
        modes, wanted = [0, 1, 2, 3], [0.01, 0.03, 0.02, 0.02]
    mf = load_model(write(tmp_path, damping=table))
    w, zeta = damping_ratios(mf.model.structure)
    # classical damping: the damped eigenvalues are -ζω ± iω√(1-ζ²) of the undamped modes
    np.testing.assert_allclose(w, omega, rtol=1e-9)
    np.testing.assert_allclose(zeta[modes], wanted, rtol=1e-9)


def test_output_by_node_and_direction(tmp_path: Path) -> None:
    fe = lumped_cantilever()
    write_calculix(tmp_path / "ccx", fe)
    text = write(tmp_path).read_text().replace('"M.npy"', '"ccx.mas"').replace('"K.npy"',
                                                                              '"ccx.sti"')
    cases = (('nodes = [5]\ndirections = ["x"]', [8]), ("nodes = [5, 2]", [8, 9, 2, 3]))
    for output, dofs in cases:
        (tmp_path / "model.toml").write_text(text + f"[output]\n{output}\n", encoding="utf-8")
        mf = load_model(tmp_path / "model.toml")
        assert mf.dofs == dofs
        assert mf.simulate().dofs.tolist() == dofs
    (tmp_path / "model.toml").write_text(text + "[output]\ndofs = [1]\nnodes = [5]\n",
                                         encoding="utf-8")
    with pytest.raises(ModelFileError) as e:
        load_model(tmp_path / "model.toml")
    assert e.value.errors == ["output.nodes: [5] is not valid; expected exactly one of dofs or "
                              "nodes"]


def test_an_explicit_dof_map_wins_over_job_dof(tmp_path: Path) -> None:
    fe = lumped_cantilever()
    write_calculix(tmp_path / "ccx", fe)
    (tmp_path / "ccx.dof").write_text("not a dof file\n", encoding="ascii")
    labels = [f"{100 + n}.{d}" for n, d in zip(fe.dof_map.nodes, fe.dof_map.directions,
                                                strict=True)]  # type: ignore[union-attr]
    got = read_structure(tmp_path / "ccx.mas", tmp_path / "ccx.sti", dof_map=labels)
    assert got.dof_map is not None and got.dof_map.labels() == labels
