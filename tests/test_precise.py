"""Precise integration's matrices (paper eqs. 36–41) against SciPy: `Φ = exp(Hη)` from the
core's 2^N algorithm equals ``scipy.linalg.expm`` to 1e-12 relative on structural matrices with
ω·η from 1e-3 to 10, and so do the Duhamel matrices (against ``expm`` of Van Loan's augmented
matrix); the methods are selectable from model files."""

from __future__ import annotations

import numpy as np
import pytest
import vibroimpact as vi
from scipy.linalg import eigh, expm
from vibroimpact import _core

OMEGA_DT = [1e-3, 1e-2, 0.1, 1.0, 10.0]


def _chain() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    m = np.diag([2.0, 1.0, 3.0])
    k1, k2, k3 = 1e6, 5e5, 2e6
    k = np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])
    return m, 0.5 * m + 1e-4 * k, k  # Rayleigh damping


def _stiff_soft() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A light stiff part on a heavy soft one (modes 10 and 1e5 rad/s), as FE models have."""
    m = np.diag([1e-2, 10.0])
    k = np.array([[1e8, -1e8], [-1e8, 1e8 + 1e3]])
    return m, 1e-5 * k, k


STRUCTURES = {
    "sdof": (np.array([[100.0]]), np.array([[2 * 0.02 * np.sqrt(1e8 * 100)]]),
             np.array([[1e8]])),
    "chain": _chain(),
    "stiff-soft": _stiff_soft(),
    "free-mass": (np.array([[100.0]]), np.zeros((1, 1)), np.zeros((1, 1))),
}


def _hamiltonian(m: np.ndarray, c: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Paper eqs. 36–37."""
    mi = np.linalg.inv(m)
    return np.block([[-mi @ c / 2, mi], [c @ mi @ c / 4 - k, -c @ mi / 2]])


def _step(m: np.ndarray, k: np.ndarray, omega_dt: float) -> float:
    omega = np.sqrt(max(eigh(k, m, eigvals_only=True).max(), 1.0))
    return omega_dt / omega


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize("omega_dt", OMEGA_DT)
@pytest.mark.parametrize("name", list(STRUCTURES))
def test_phi_equals_scipy_expm(name: str, omega_dt: float) -> None:
    m, c, k = STRUCTURES[name]
    eta = _step(m, k, omega_dt)
    h = _hamiltonian(m, c, k)
    ours = _core.precise_matrices(m, c, k, eta)
    assert _rel(ours["hamiltonian"], h) < 1e-15
    reference = expm(h * eta)
    assert _rel(ours["phi"], reference) < 1e-12
    assert _rel(_core.expm(h * eta), reference) < 1e-12


@pytest.mark.parametrize("omega_dt", OMEGA_DT)
@pytest.mark.parametrize("name", list(STRUCTURES))
def test_duhamel_matrices_equal_van_loan(name: str, omega_dt: float) -> None:
    """``D_m = η^{m+1} Φ_m(η) [0; I] = η ∫₀¹ e^{Hη(1−s)} [0; I] s^m ds`` (paper eq. 41) from
    SciPy's ``expm`` of ``[[Hη, B, 0, 0], [0, 0, I, 0], [0, 0, 0, I], [0, 0, 0, 0]]``."""
    m, c, k = STRUCTURES[name]
    n = len(m)
    eta = _step(m, k, omega_dt)
    aug = np.zeros((5 * n, 5 * n))
    aug[: 2 * n, : 2 * n] = _hamiltonian(m, c, k) * eta
    aug[n : 2 * n, 2 * n : 3 * n] = np.eye(n)
    aug[2 * n : 3 * n, 3 * n : 4 * n] = np.eye(n)
    aug[3 * n : 4 * n, 4 * n :] = np.eye(n)
    e = expm(aug)
    reference = [eta * e[: 2 * n, 2 * n : 3 * n], eta * e[: 2 * n, 3 * n : 4 * n],
                 2 * eta * e[: 2 * n, 4 * n :]]
    ours = _core.precise_matrices(m, c, k, eta)["duhamel"]
    for d, ref in zip(ours, reference, strict=True):
        assert _rel(d, ref) < 1e-12


def test_expm_of_general_matrices() -> None:
    rng = np.random.default_rng(7)
    for scale in (1e-3, 0.1, 1.0, 5.0):
        a = rng.standard_normal((6, 6)) * scale
        assert _rel(_core.expm(a), expm(a)) < 1e-12


def test_methods_from_model_file_options() -> None:
    from vibroimpact.integrators import method_from_options

    assert method_from_options("precise", {}) == vi.PreciseIntegration()
    assert method_from_options("precise", {"predictor_corrector": True}) == \
        vi.PreciseIntegration(predictor_corrector=True)
    assert method_from_options("bathe", {"gamma": 0.6}) == vi.Bathe(gamma=0.6)
    with pytest.raises(vi.ModelError, match=r"solver\.gamma"):
        vi.Bathe(gamma=1.0)
    with pytest.raises(vi.ModelError, match=r"solver\.predictor_corrector"):
        vi.PreciseIntegration(predictor_corrector=1)  # type: ignore[arg-type]
    with pytest.raises(vi.ModelError, match=r"solver\.adaptive"):
        vi.PreciseIntegration(adaptive=vi.Adaptive())


@pytest.mark.parametrize(("method", "options"), [
    ("precise", 'predictor_corrector = true'),
    ("bathe", 'gamma = 0.5'),
])
def test_model_file_selects_the_method(tmp_path, method: str, options: str) -> None:
    text = f"""
schema_version = 1
[structure]
kind = "sdof"
mass = 2.0
stiffness = 800.0
[initial]
displacement = 1e-3
[solver]
method = "{method}"
{options}
dt = 1e-3
t_end = 0.1
"""
    path = tmp_path / "model.toml"
    path.write_text(text)
    mf = vi.load_model(path)
    assert mf.method.name == method
    r = vi.simulate(mf.model, t_end=mf.t_end, dt=mf.dt, method=mf.method)
    assert r.complete


def test_predictor_corrector_with_two_coupled_gaps_matches_newmark() -> None:
    """Two masses on springs, each hitting its own stop, with the gaps coupled through the
    structure: the precise predictor-corrector against a fine-step Newmark run (the other
    precise tests have one gap)."""
    import numpy as np
    import vibroimpact as vi

    m = np.diag([1.0, 1.5])
    k = np.array([[3e4, -2e4], [-2e4, 2e4]])
    law = vi.contact.Hertz(stiffness=1e9)
    model = vi.Model(
        vi.Structure(m, k),
        gaps=[vi.Gap(dof=0, clearance=1e-3, side="both", law=law),
              vi.Gap(dof=1, clearance=1.5e-3, side="both", law=law)],
        initial_velocity=[0.4, -0.3],
    )
    ref = vi.simulate(model, t_end=0.05, dt=2e-7, every=50)
    pc = vi.simulate(model, t_end=0.05, dt=1e-6, every=10,
                     method=vi.PreciseIntegration(predictor_corrector=True))
    assert len(ref.impacts) > 6 and len(pc.impacts) == len(ref.impacts)
    assert np.max(np.abs(pc.impacts.t_start - ref.impacts.t_start)) < 2e-6
    assert np.max(np.abs(pc.max_abs_displacement - ref.max_abs_displacement)) < 2e-6
