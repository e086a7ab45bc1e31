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

__all__ = ["MIN_MODES", "MODE_FREQUENCY_FACTOR", "OrbitBasis", "default_modes"]

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

    def complement_maps(self, method: Integrator, dt: float, duration: float
                        ) -> NDArray[np.float64]:
        """Each complement mode's ``2 × 2`` map over ``duration`` by ``method`` (the Newmark
        family at steps of ``dt``): :func:`_newmark_mode_maps`."""
        steps = round(duration / dt)
        parameters = method._run_spec()["method"].newmark_parameters()
        return _newmark_mode_maps(self.omega, self.damping, duration / steps, steps,
                                  parameters)
