"""The monodromy of a large structure in a reduced basis (docs/periodic-orbits.md, "Large
structures"): the gap coordinates plus retained fixed-interface modes (Craig–Bampton,
:mod:`vibroimpact.fe.reduction`), and the remaining fixed-interface modes (the complement) each
moved by its own linear map.

With the boundary DOFs ``b`` (the gaps') and the interior ``i``, every displacement is
``x_b = q_b``, ``x_i = Ψ q_b + Φ_k η_k + Φ_h η_h`` (``Ψ = −K_ii⁻¹ K_ib``; ``Φ = [Φ_k, Φ_h]``
all the mass-normalised modes of ``(K_ii, M_ii)``, the first ``k`` retained), so
``η = Φᵀ M_ii (x_i − Ψ x_b)``; velocities alike. In these coordinates the full map's Jacobian
is approximated block-diagonally: the reduced model's monodromy ``Φ_r`` (the core's, on the
``b + k`` retained coordinates) and, per complement mode ``j``, the ``2 × 2`` map ``E_j`` of
``η'' + c_j η' + ω_j² η = 0`` (``c_j = φ_jᵀ C_ii φ_j``; exact for proportional damping) by the
run's own scheme (the Newmark family's discrete map at the run's step, closed form per mode).
The neglected blocks are the complement's coupling to the boundary (through ``M_hb``, ``C_hb``
and the contact forces on the boundary): Newton with this Jacobian is a quasi-Newton
iteration on the full residual, so the orbit is the full model's to the Newton tolerance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray

from vibroimpact.errors import ModelError
from vibroimpact.fe.reduction import CraigBampton, craig_bampton
from vibroimpact.integrators import Integrator
from vibroimpact.model import Model

__all__ = ["MIN_MODES", "MODE_FREQUENCY_FACTOR", "BlockJacobian", "OrbitBasis", "default_modes"]

#: The default basis keeps every fixed-interface mode up to this many times the highest
#: forcing frequency ...
MODE_FREQUENCY_FACTOR = 10.0
#: ... and at least this many.
MIN_MODES = 20


def default_modes(frequencies_hz: NDArray[np.float64], forcing_hz: float) -> int:
    """The modes kept by default: every fixed-interface mode up to
    :data:`MODE_FREQUENCY_FACTOR` × ``forcing_hz``, at least :data:`MIN_MODES` (at most all)."""
    within = int(np.count_nonzero(frequencies_hz <= MODE_FREQUENCY_FACTOR * forcing_hz))
    return min(len(frequencies_hz), max(MIN_MODES, within))


def _newmark_mode_maps(omega: NDArray[np.float64], c: NDArray[np.float64], h: float,
                       steps: int, p: dict[str, float]) -> NDArray[np.float64]:
    """Per mode, the ``2 × 2`` map of ``(η, η̇)`` over ``steps`` steps of ``h`` of the α-form
    Newmark scheme (``alpha_m``, ``alpha_f``, ``gamma``, ``beta``) on ``η'' + c η' + ω² η = 0``,
    started from the acceleration in equilibrium (as the core's runs): the step
    ``S a₁ = −[α_m a₀ + (1−α_f)(c ṽ + k x̃) + α_f (c v₀ + k x₀)]``,
    ``S = 1 − α_m + (1−α_f)(hγ c + h²β k)``, ``x̃ = x₀ + h v₀ + h²(½−β) a₀``,
    ``ṽ = v₀ + h(1−γ) a₀`` (docs/periodic-orbits.md), as a ``3 × 3`` matrix on ``(x, v, a)``."""
    am, af, g, b = p["alpha_m"], p["alpha_f"], p["gamma"], p["beta"]
    k = omega**2
    s = 1 - am + (1 - af) * (h * g * c + h * h * b * k)
    m = len(omega)
    step = np.zeros((m, 3, 3))
    step[:, 2, 0] = -k / s
    step[:, 2, 1] = -(c + (1 - af) * k * h) / s
    step[:, 2, 2] = -(am + (1 - af) * (c * h * (1 - g) + k * h * h * (0.5 - b))) / s
    step[:, 0, :] = [1.0, h, h * h * (0.5 - b)]
    step[:, 0, :] += h * h * b * step[:, 2, :]
    step[:, 1, :] = [0.0, 1.0, h * (1 - g)]
    step[:, 1, :] += h * g * step[:, 2, :]
    lift = np.zeros((m, 3, 2))
    lift[:, 0, 0] = lift[:, 1, 1] = 1.0
    lift[:, 2, 0], lift[:, 2, 1] = -k, -c
    return (np.linalg.matrix_power(step, steps) @ lift)[:, :2, :]


@dataclass
class OrbitBasis:
    """The basis of a large model's monodromy: ``cb`` (the gap DOFs plus ``cb.n_modes``
    retained fixed-interface modes; its reduced model carries the monodromy ``Φ_r``) and the
    complement's modes ``complement`` (interior × h, mass-normalised) with their angular
    frequencies ``omega`` and modal damping ``damping`` (``c_j``)."""

    cb: CraigBampton
    interior: NDArray[np.intp]
    mass_ii: sp.csr_array
    complement: NDArray[np.float64]
    omega: NDArray[np.float64]
    damping: NDArray[np.float64]

    @classmethod
    def of(cls, model: Model, modes: int | None, forcing_hz: float) -> OrbitBasis:
        """The basis of ``model`` with ``modes`` retained modes (None: :func:`default_modes`).
        Every interior mode is computed once (dense, ``O(n³)``)."""
        boundary = list(dict.fromkeys(d for g in model.gaps for d in g.dofs))
        if not boundary:
            raise ModelError("gaps: [] is not valid for a reduced basis; expected a model with "
                             "gaps (their DOFs are the basis's physical coordinates)")
        st = model.structure
        n = model.n_dof
        interior = np.setdiff1d(np.arange(n), boundary)
        m = sp.csr_array(st.mass)
        k = sp.csr_array(st.stiffness)
        m_ii = sp.csr_array(m[interior][:, interior])
        lam, phi = scipy.linalg.eigh(k[interior][:, interior].toarray(), m_ii.toarray())
        frequencies = np.sqrt(np.clip(lam, 0.0, None)) / (2 * math.pi)
        if modes is None:
            modes = default_modes(frequencies, forcing_hz)
        elif not (isinstance(modes, int) and not isinstance(modes, bool)
                  and 0 <= modes <= interior.size):
            raise ModelError(f"modes: {modes!r} is not valid; expected an integer 0 .. "
                             f"{interior.size} (the interior DOFs' fixed-interface modes)")
        cb = craig_bampton(model, boundary, modes)
        rest = phi[:, modes:]
        c = sp.csr_array(st.damping)[interior][:, interior] if st.damping is not None else None
        damping = (np.zeros(rest.shape[1]) if c is None
                   else np.einsum("ij,ij->j", rest, c @ rest))
        return cls(cb=cb, interior=interior, mass_ii=m_ii, complement=rest,
                   omega=np.sqrt(np.clip(lam[modes:], 0.0, None)), damping=damping)

    @property
    def boundary(self) -> list[int]:
        return list(self.cb.boundary)

    @property
    def n_retained(self) -> int:
        """``b + k``: the reduced model's DOFs."""
        return self.cb.n_dof

    def describe(self) -> str:
        """The basis in words: which coordinates, how many modes, up to which frequency."""
        f = self.cb.interior_frequencies_hz
        top = f" up to {f[-1]:.6g} Hz" if len(f) else ""
        return (f"{len(self.cb.boundary)} gap coordinates (DOFs {self.boundary}) + "
                f"{self.cb.n_modes} fixed-interface modes{top} (Craig-Bampton); complement: "
                f"{self.complement.shape[1]} modes, each by its own linear map")

    def _split(self, x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(q_b, η_k)`` and ``η_h`` of the displacements (or velocities) ``x``."""
        cb, b = self.cb, self.boundary
        xb = x[b]
        rel = self.mass_ii @ (x[self.interior] - cb.transform[self.interior, :len(b)] @ xb)
        retained = np.concatenate([xb, cb.transform[self.interior, len(b):].T @ rel])
        return retained, self.complement.T @ rel

    def coordinates(self, z: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                           NDArray[np.float64]]:
        """The retained coordinates (``2(b + k)``: displacements then velocities, the reduced
        model's state) and the complement's (``h × 2``: each mode's ``(η, η̇)``) of ``z``."""
        n = len(z) // 2
        rx, hx = self._split(z[:n])
        rv, hv = self._split(z[n:])
        return np.concatenate([rx, rv]), np.column_stack([hx, hv])

    def state(self, retained: NDArray[np.float64],
              complement: NDArray[np.float64]) -> NDArray[np.float64]:
        """The full state of retained and complement coordinates (:meth:`coordinates`'s
        inverse)."""
        r = self.n_retained
        parts = []
        for i in range(2):
            x = self.cb.expand(retained[i * r:(i + 1) * r])
            x[self.interior] += self.complement @ complement[:, i]
            parts.append(x)
        return np.concatenate(parts)

    def adjoint(self, a: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                       NDArray[np.float64]]:
        """``Lᵀ a`` for :meth:`state`'s linear map ``L`` (retained, complement ``h × 2``): the
        row ``a · L`` of a linear condition ``a · z`` on the full state in the coordinates."""
        n, t = len(a) // 2, self.cb.transform
        halves = [(t.T @ a[i * n:(i + 1) * n], self.complement.T @ a[i * n:(i + 1) * n][
            self.interior]) for i in range(2)]
        return (np.concatenate([halves[0][0], halves[1][0]]),
                np.column_stack([halves[0][1], halves[1][1]]))

    def complement_maps(self, method: Integrator, dt: float, duration: float
                        ) -> NDArray[np.float64]:
        """Each complement mode's ``2 × 2`` map over ``duration`` by ``method`` (the Newmark
        family at steps of ``dt``): :func:`_newmark_mode_maps`."""
        steps = round(duration / dt)
        parameters = method._run_spec()["method"].newmark_parameters()
        return _newmark_mode_maps(self.omega, self.damping, duration / steps, steps,
                                  parameters)


@dataclass
class BlockJacobian:
    """``∂P^N/∂z`` of the full map in :class:`OrbitBasis` coordinates, block-diagonal: the
    reduced model's monodromy ``phi_r`` on the retained coordinates and each complement mode's
    ``2 × 2`` map ``maps[j]`` (module doc). Offers what Newton and the continuation need
    without a ``2n × 2n`` matrix: solves with ``Φ − I`` (bordered or not), the determinants of
    ``Φ ± I`` and the multipliers."""

    basis: OrbitBasis
    phi_r: NDArray[np.float64]
    maps: NDArray[np.float64]

    @property
    def monodromy(self) -> NDArray[np.float64]:
        """``Φ_r`` (the retained block; its eigenvalues are :attr:`multipliers`)."""
        return self.phi_r

    @property
    def multipliers(self) -> NDArray[np.complex128]:
        """The eigenvalues of ``Φ_r``, largest modulus first."""
        return _sorted(np.linalg.eigvals(self.phi_r))

    @property
    def complement_multipliers(self) -> NDArray[np.complex128]:
        """The eigenvalues of the complement's maps, largest modulus first."""
        return _sorted(np.linalg.eigvals(self.maps).ravel())

    def solve(self, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        """``δ`` with ``(Φ − I) δ = rhs``: the retained block by a dense solve, each complement
        mode in closed form, lifted back to the full state."""
        r_retained, r_complement = self.basis.coordinates(rhs)
        d_retained = np.linalg.solve(self.phi_r - np.eye(len(self.phi_r)), r_retained)
        d_complement = np.linalg.solve(self.maps - np.eye(2), r_complement[..., None])[..., 0]
        return self.basis.state(d_retained, d_complement)

    def _bordered(self, column: NDArray[np.float64], weights: NDArray[np.float64],
                  row: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                     NDArray[np.float64], NDArray[np.float64]]:
        """The complement eliminated from ``[[Φ − I, c], [row ⊙ w]]`` (Schur complement, its
        ``2 × 2`` blocks in closed form): the retained bordered matrix, the complement's
        ``(E_j − I)⁻¹``, its column ``(E_j − I)⁻¹ c_j`` and its part of the row."""
        c_retained, c_complement = self.basis.coordinates(column)
        rho_retained, rho_complement = self.basis.adjoint(row[:-1] * weights[:-1])
        inverse = np.linalg.inv(self.maps - np.eye(2))
        beta = (inverse @ c_complement[..., None])[..., 0]
        r = len(self.phi_r)
        matrix = np.empty((r + 1, r + 1))
        matrix[:r, :r] = self.phi_r - np.eye(r)
        matrix[:r, r] = c_retained
        matrix[r, :r] = rho_retained
        matrix[r, r] = row[-1] * weights[-1] - float(np.sum(rho_complement * beta))
        return matrix, inverse, beta, rho_complement

    def solve_bordered(self, column: NDArray[np.float64], weights: NDArray[np.float64],
                       row: NDArray[np.float64], rhs: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
        """``du`` with ``[[Φ − I, c] / w, row] du = rhs`` (pseudo-arclength's bordered system
        in the scaled unknowns ``u = w ⊙ (z, p)``): the complement's blocks eliminated in
        closed form (:meth:`_bordered`), a dense solve of the retained ``2(b + k) + 1``."""
        matrix, inverse, beta, rho_complement = self._bordered(column, weights, row)
        r_retained, r_complement = self.basis.coordinates(rhs[:-1])
        alpha = (inverse @ r_complement[..., None])[..., 0]
        reduced_rhs = np.append(r_retained, rhs[-1] - float(np.sum(rho_complement * alpha)))
        solution = np.linalg.solve(matrix, reduced_rhs)
        dp = solution[-1]
        dz = self.basis.state(solution[:-1], alpha - beta * dp)
        return np.append(dz, dp) * weights

    def bordered_determinant(self, column: NDArray[np.float64], weights: NDArray[np.float64],
                             row: NDArray[np.float64]) -> float:
        """``det [[Φ − I, c], [row ⊙ w]]`` in the basis coordinates (a change of coordinates
        of determinant 1): the retained Schur complement's times the complement's
        ``det(E_j − I)``; the sign of ``det([[Φ − I, c] / w, row])``."""
        matrix = self._bordered(column, weights, row)[0]
        return float(np.linalg.det(matrix) * self._complement_det(-1.0))

    def _complement_det(self, shift: float) -> float:
        return float(np.prod(np.linalg.det(self.maps + shift * np.eye(2))))

    def determinant(self, shift: float) -> float:
        """``det(Φ + shift · I)``: ``Φ_r``'s times the complement's blocks'."""
        return float(np.linalg.det(self.phi_r + shift * np.eye(len(self.phi_r)))
                     * self._complement_det(shift))

    def pair_test(self) -> float:
        """The Neimark–Sacker test ``Π (μ_i μ_j − 1)``: over the pairs of ``Φ_r``'s multipliers
        and each complement block's own pair (``det E_j − 1``); pairs across blocks are left
        out (they vanish only at a neutral saddle's ``μ_i μ_j = 1``, not a bifurcation)."""
        mu = self.multipliers
        pairs = [mu[i] * mu[j] - 1 for i in range(mu.size) for j in range(i + 1, mu.size)]
        own = np.linalg.det(self.maps) - 1
        return float((np.prod(pairs) * np.prod(own)).real)


def _sorted(values: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """``values`` as complex, largest modulus first."""
    values = np.asarray(values).astype(complex)
    return values[np.argsort(-np.abs(values), kind="stable")]
