"""Craig–Bampton reduction that keeps the gap DOFs physical (docs/beam.md; Craig & Bampton,
*AIAA J.* 6:1313, 1968).

The DOFs are split into boundary DOFs ``b`` (the gap DOFs, kept as they are) and interior DOFs
``i``. The interior motion is the static response to the boundary (constraint modes
``Ψ = −K_ii⁻¹ K_ib``) plus ``n_modes`` fixed-interface modes ``Φ`` of ``(K_ii, M_ii)``: the
lowest, or those of the most effective interface mass (:func:`craig_bampton`'s ``select``)::

    x = T q,   T = [[I, 0], [Ψ, Φ]],   q = [x_b; η]
    M_r = Tᵀ M T,   C_r = Tᵀ C T,   K_r = Tᵀ K T,   f_r = Tᵀ f

A static load at the boundary is reproduced exactly; the dynamic error falls as the kept
interior modes cover the frequencies that the loads and the contacts excite. Loads on interior
DOFs are carried exactly as generalized forces ``Tᵀ f`` (one load per reduced DOF they reach).

**The error check.** :func:`check_reduction` runs the full and the reduced model with the
same integrator and step and compares the gap DOFs' displacement histories, the contact-force
histories and the impact tables; the relative errors it returns are what to quote. A cheaper
check without time integration is :meth:`CraigBampton.frequency_errors` (the reduced model's
frequencies against the full model's).

Example::

    reduced, cb = reduce_model(model, n_modes=20)      # gap DOFs stay physical
    check = check_reduction(model, cb, t_end=0.05, dt=1e-5)
    check.displacement_error, check.force_error         # relative, see ReductionCheck
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import ArrayLike, NDArray

from vibroimpact import _core
from vibroimpact.errors import ModelError
from vibroimpact.fe.condensation import weighted_gap, weighted_loads
from vibroimpact.fe.dofs import DofMap, FEStructure
from vibroimpact.integrators import Integrator
from vibroimpact.model import Gap, Load, Model, Structure

__all__ = [
    "CraigBampton",
    "ReductionCheck",
    "check_reduction",
    "craig_bampton",
    "reduce_model",
]

#: Interior blocks with at most this many DOFs are handled with dense LAPACK calls.
DENSE_REDUCTION_LIMIT = 600


def _parts(structure: Any) -> tuple[Any, Any, Any, DofMap | None, tuple[str, ...]]:
    from vibroimpact.fe.beam import Beam

    if isinstance(structure, Beam):
        structure = structure.fe
    if isinstance(structure, Model):
        structure = structure.structure
    if getattr(structure, "gyroscopic", None) is not None:
        raise ModelError("structure.gyroscopic: a rotor's gyroscopic matrix is not reduced (the "
                         "fixed-interface modes ignore it); expected a structure without one")
    if isinstance(structure, FEStructure):
        massless = structure.massless_dofs
        if massless:
            raise ModelError(
                f"structure.mass: {len(massless)} massless DOFs (first: {massless[0]}); expected "
                "every DOF to carry mass (condense them first: FEStructure.condense_massless(), "
                "then reduce its .structure)"
            )
        return (structure.mass, structure.stiffness, structure.damping, structure.dof_map,
                structure.dof_units)
    if isinstance(structure, Structure):
        c = structure.damping if abs(structure.damping).max() > 0 else None
        return structure.mass, structure.stiffness, c, None, structure.dof_units
    raise ModelError(
        f"structure: {type(structure).__name__} is not valid; expected a Structure, Model, "
        "FEStructure or Beam"
    )


@dataclass(frozen=True)
class CraigBampton:
    """A Craig–Bampton reduced structure: ``transform`` T (n × r, ``x = T q``), the full DOF
    indices kept physical (``boundary``; reduced DOFs ``0 … b−1`` in that order), ``n_modes``
    fixed-interface modes (reduced DOFs ``b …``) with ``interior_frequencies_hz``, the
    reduced ``mass``, ``stiffness``, ``damping`` (r × r), ``mass_projection`` ``TᵀM``
    (r × n, to reduce initial states) and ``dof_units`` (r: the boundary DOFs' own units, then
    ``"kg^0.5 m"`` for the coordinates of the mass-normalised modes, ``φᵀ M φ = 1``);
    ``select`` and ``candidates``: how the modes were chosen, among how many of the lowest
    (:func:`craig_bampton`)."""

    transform: NDArray[np.float64]
    boundary: tuple[int, ...]
    n_modes: int
    interior_frequencies_hz: NDArray[np.float64]
    mass: NDArray[np.float64]
    stiffness: NDArray[np.float64]
    damping: NDArray[np.float64] | None
    dof_map: DofMap | None = None
    mass_projection: NDArray[np.float64] | None = field(default=None, repr=False, compare=False)
    dof_units: tuple[str, ...] | None = None
    select: str = "frequency"
    candidates: int = 0

    @property
    def n_dof(self) -> int:
        """Reduced DOFs ``r = b + n_modes``."""
        return int(self.transform.shape[1])

    @property
    def n_full(self) -> int:
        return int(self.transform.shape[0])

    @property
    def structure(self) -> Structure:
        """The reduced :class:`~vibroimpact.Structure`."""
        return Structure(self.mass, self.stiffness, self.damping, self.dof_units)

    def reduced_dof(self, dof: int) -> int:
        """The reduced index of a boundary DOF (its full index ``dof``)."""
        try:
            return self.boundary.index(int(dof))
        except ValueError:
            raise ModelError(
                f"dof: {dof!r} is not valid; expected a boundary DOF of the reduction "
                f"({len(self.boundary)} kept physical)"
            ) from None

    def reduce_gap(self, gap: Gap) -> Gap:
        """The gap on the reduced coordinates: the same DOFs if they are boundary DOFs, else
        the exact combination ``u = (bᵀ T) q``."""
        dofs, coeffs = gap.dofs, gap.coefficients or (1.0,) * len(gap.dofs)
        if all(d in self.boundary for d in dofs):
            new = [self.reduced_dof(d) for d in dofs]
            return dataclasses.replace(
                gap, dof=new if len(new) > 1 else new[0], coefficients=list(coeffs)
            )
        row = sum(c * self.transform[d] for d, c in zip(dofs, coeffs, strict=True))
        return weighted_gap(gap, np.asarray(row))

    def reduce_load(self, load: Load) -> list[Load]:
        """Loads on the reduced coordinates giving the generalized force ``Tᵀ f``: one load of
        the same kind per distinct weight (boundary DOFs keep weight 1)."""
        return weighted_loads(load, self.transform[list(load.dofs)].sum(axis=0))

    def reduce_state(self, x: ArrayLike | None) -> NDArray[np.float64] | None:
        """The reduced state ``q`` closest to the full ``x`` in the mass norm
        (``q = (TᵀMT)⁻¹ TᵀM x``; exact if ``x`` is in the range of T)."""
        if x is None:
            return None
        v = np.asarray(x, dtype=float)
        if not np.any(v):
            return np.zeros(self.n_dof)
        if self.mass_projection is None:
            raise ModelError("initial: no mass projection stored; expected a zero initial state")
        return np.linalg.solve(self.mass, self.mass_projection @ v)

    def model(
        self,
        gaps: Sequence[Gap] = (),
        loads: Sequence[Load] = (),
        initial_displacement: ArrayLike | None = None,
        initial_velocity: ArrayLike | None = None,
    ) -> Model:
        """The reduced :class:`~vibroimpact.Model` of gaps, loads and initial state given on the
        full DOFs."""
        return Model(
            self.structure,
            gaps=[self.reduce_gap(g) for g in gaps],
            loads=[r for ld in loads for r in self.reduce_load(ld)],
            initial_displacement=self.reduce_state(initial_displacement),
            initial_velocity=self.reduce_state(initial_velocity),
        )

    def reduce_model(self, model: Model) -> Model:
        """:meth:`model` of a full model's gaps, loads and initial state."""
        if model.n_dof != self.n_full:
            raise ModelError(
                f"model: {model.n_dof} DOFs is not valid; expected {self.n_full} (the full model)"
            )
        return self.model(
            model.gaps, model.loads, model.initial_displacement, model.initial_velocity
        )

    def expand(self, q: ArrayLike) -> NDArray[np.float64]:
        """Full DOF values ``x = T q`` of reduced values (a vector or rows of a history)."""
        return np.asarray(q, dtype=float) @ self.transform.T

    def frequency_errors(self, structure: Any, n: int = 10) -> NDArray[np.float64]:
        """Relative errors of the reduced model's first ``n`` elastic frequencies against the
        full ``structure``'s (reduced ≥ full: Rayleigh–Ritz bounds them from above)."""
        from vibroimpact.fe.modal import modes

        full = modes(structure, n).elastic_frequencies_hz
        red = modes((self.mass, self.stiffness), n).elastic_frequencies_hz
        k = min(len(full), len(red))
        return (red[:k] - full[:k]) / full[:k]


def craig_bampton(
    structure: Any,
    boundary: Iterable[int],
    n_modes: int,
    *,
    select: str = "frequency",
    candidates: int | None = None,
) -> CraigBampton:
    """Reduce ``structure`` (a :class:`~vibroimpact.Structure`, :class:`~vibroimpact.Model`,
    :class:`~vibroimpact.fe.FEStructure` or :class:`~vibroimpact.fe.Beam`; sparse matrices
    stay sparse) keeping the DOFs ``boundary`` physical and ``n_modes`` fixed-interface modes.

    ``select`` says which modes: ``"frequency"``, the lowest ``n_modes``; ``"interface-mass"``,
    the ``n_modes`` of the lowest ``candidates`` (default ``4 n_modes``) that carry the most
    effective interface mass (Kammer & Triller, *J. Vib. Acoust.* 118:264, 1996): mode ``i``'s
    participation ``L_i = φ_iᵀ (M_ib + M_ii Ψ)`` (its coupling to the boundary in ``M_r``)
    gives its effective mass ``L_iᵀ L_i`` relative to the boundary, and the modes are ranked
    by its share of each boundary DOF's mass ``M̂ = T_bᵀ M T_b``, ``Σ_j L_ij² / M̂_jj``. It
    keeps the modes a contact at the boundary excites (local ones far above the lowest), at
    the price of ``candidates`` modes in the eigensolution (benchmarks/solid-reduction.md).

    The interior stiffness ``K_ii`` must be non-singular: the boundary DOFs must hold the
    structure against rigid-body motion (add boundary DOFs otherwise)."""
    m, k, c, dof_map, units = _parts(structure)
    n = int(m.shape[0])
    b = list(dict.fromkeys(int(d) for d in boundary))
    if not b or any(not 0 <= d < n for d in b):
        raise ModelError(
            f"boundary: {b!r} is not valid; expected a non-empty list of DOFs 0 <= dof < {n}"
        )
    interior = np.setdiff1d(np.arange(n), b)
    ni = interior.size
    if not (isinstance(n_modes, int) and 0 <= n_modes <= ni):
        raise ModelError(
            f"n_modes: {n_modes!r} is not valid; expected an integer 0 .. {ni} (interior DOFs)"
        )
    n_eig = _candidates(select, candidates, n_modes, ni)
    sparse = sp.issparse(k) and ni > DENSE_REDUCTION_LIMIT
    ms, ks = sp.csc_array(m), sp.csc_array(k)
    k_ii = ks[interior][:, interior]
    k_ib = ks[interior][:, b].toarray()
    m_ii = ms[interior][:, interior]
    factor = None
    if ni == 0:
        psi = np.zeros((0, len(b)))
    elif sparse:
        k_rows = sp.csr_array(k_ii)
        k_rows.sum_duplicates()
        k_rows.sort_indices()
        try:  # the core's sparse Cholesky, as a run factors its effective stiffness
            factor = _core.CholeskyFactor(k_rows)
        except _core.ModelError:
            raise ModelError(_singular_message(len(b))) from None
        psi = -factor.solve(k_ib)
    else:
        try:
            kd = k_ii.toarray()
            cho = scipy.linalg.cho_factor(kd)
            psi = -scipy.linalg.cho_solve(cho, k_ib)
        except np.linalg.LinAlgError:
            raise ModelError(_singular_message(len(b))) from None
    if ni and not np.all(np.isfinite(psi)):
        raise ModelError(_singular_message(len(b)))
    if n_modes:
        if sparse and n_eig < ni - 1:
            assert factor is not None  # shift-invert about 0 reuses the factor of K_ii
            k_inv = spla.LinearOperator((ni, ni), matvec=factor.solve, dtype=float)
            lam, phi = spla.eigsh(
                sp.csc_array(k_ii), k=n_eig, M=sp.csc_array(m_ii), sigma=0.0, which="LM",
                OPinv=k_inv,
            )
            order = np.argsort(lam)
            lam, phi = lam[order], phi[:, order]
        else:
            lam, phi = scipy.linalg.eigh(
                k_ii.toarray(), m_ii.toarray(), subset_by_index=[0, n_eig - 1]
            )
        norms = np.sqrt(np.einsum("ij,ij->j", phi, m_ii @ phi))
        phi = phi / norms
        if n_eig > n_modes:
            m_ib = ms[interior][:, b].toarray()
            coupling = m_ib + m_ii @ psi  # M_ib + M_ii Ψ
            boundary_mass = (ms[b][:, b].diagonal() + np.einsum("ij,ij->j", m_ib, psi)
                             + np.einsum("ij,ij->j", psi, coupling))  # diag(T_bᵀ M T_b)
            share = ((phi.T @ coupling) ** 2 / boundary_mass).sum(axis=1)
            keep = np.sort(np.argsort(-share, kind="stable")[:n_modes])
            lam, phi = lam[keep], phi[:, keep]
    else:
        lam, phi = np.zeros(0), np.zeros((ni, 0))
    t = np.zeros((n, len(b) + n_modes))
    t[b, np.arange(len(b))] = 1.0
    t[np.ix_(interior, np.arange(len(b)))] = psi
    t[np.ix_(interior, len(b) + np.arange(n_modes))] = phi
    tm = np.asarray((ms @ t).T)  # Tᵀ M (r × n)
    mr = tm @ t
    kr = np.asarray((ks @ t).T) @ t
    cr = None if c is None else np.asarray((sp.csc_array(c) @ t).T) @ t
    sym = [0.5 * (a + a.T) if a is not None else None for a in (mr, kr, cr)]
    cb = CraigBampton(
        transform=t,
        boundary=tuple(b),
        n_modes=n_modes,
        interior_frequencies_hz=np.sqrt(np.clip(lam, 0, None)) / (2 * math.pi),
        mass=sym[0],  # type: ignore[arg-type]
        stiffness=sym[1],  # type: ignore[arg-type]
        damping=sym[2],
        dof_map=dof_map,
        mass_projection=tm,
        dof_units=tuple(units[d] for d in b) + ("kg^0.5 m",) * n_modes,
        select=select,
        candidates=n_eig,
    )
    return cb


#: The ``select`` values of :func:`craig_bampton`.
SELECTIONS = ("frequency", "interface-mass")


def _candidates(select: str, candidates: int | None, n_modes: int, ni: int) -> int:
    """How many of the lowest fixed-interface modes to compute for ``select``."""
    if select not in SELECTIONS:
        raise ModelError(f"select: {select!r} is not valid; expected one of {list(SELECTIONS)}")
    if select == "frequency":
        if candidates is not None:
            raise ModelError(f"candidates: {candidates!r} is not valid with select = "
                             "'frequency'; expected it only with select = 'interface-mass'")
        return n_modes
    if candidates is None:
        return min(4 * n_modes, ni)
    if not (isinstance(candidates, int) and n_modes <= candidates <= ni):
        raise ModelError(f"candidates: {candidates!r} is not valid; expected an integer "
                         f"{n_modes} .. {ni} (n_modes .. interior DOFs)")
    return candidates


def _singular_message(nb: int) -> str:
    return (
        f"boundary: {nb} boundary DOF(s) leave the interior free to move as a rigid body "
        "(K_ii is singular); expected boundary DOFs that hold the structure (add DOFs)"
    )


def reduce_model(
    model: Model,
    n_modes: int,
    *,
    boundary: Iterable[int] = (),
    select: str = "frequency",
    candidates: int | None = None,
) -> tuple[Model, CraigBampton]:
    """Craig–Bampton reduction of a full ``model``: the gap DOFs (plus ``boundary``) stay
    physical, ``n_modes`` fixed-interface modes are kept (``select``, ``candidates``: which,
    see :func:`craig_bampton`). Returns the reduced model and the :class:`CraigBampton` (for
    :meth:`~CraigBampton.expand` and :func:`check_reduction`)."""
    dofs = [d for g in model.gaps for d in g.dofs] + [int(d) for d in boundary]
    if not dofs:
        raise ModelError("boundary: [] is not valid; expected gaps or boundary DOFs to keep")
    cb = craig_bampton(model, dofs, n_modes, select=select, candidates=candidates)
    return cb.reduce_model(model), cb


@dataclass(frozen=True)
class ReductionCheck:
    """Full against reduced run (same integrator and step):

    * ``displacement_error``: ``max_t |x_full − x_red| / max_t |x_full|`` over the gap DOFs;
    * ``force_error``: ``max_t |F_full − F_red| / max_t |F_full|`` over the gaps' contact
      forces (0 if no gap closed in either run);
    * ``peak_force_error``: relative error of each gap's largest contact force (worst gap);
    * ``impacts_full``, ``impacts_reduced``: impact counts;
    * ``wall_time_full_s``, ``wall_time_reduced_s``: the core's run times.
    """

    displacement_error: float
    force_error: float
    peak_force_error: float
    impacts_full: int
    impacts_reduced: int
    wall_time_full_s: float
    wall_time_reduced_s: float

    def passed(self, tolerance: float) -> bool:
        """True if the displacement and peak-force errors are within ``tolerance`` and the
        impact counts agree."""
        return (
            self.displacement_error <= tolerance
            and self.peak_force_error <= tolerance
            and self.impacts_full == self.impacts_reduced
        )


def check_reduction(
    model: Model,
    reduction: CraigBampton,
    t_end: float,
    dt: float,
    method: Integrator | None = None,
    *,
    reduced: Model | None = None,
) -> ReductionCheck:
    """Run ``model`` and its reduction (``reduced``, default ``reduction.reduce_model(model)``)
    and compare them (:class:`ReductionCheck`). Only the gap DOFs are recorded."""
    from vibroimpact.simulate import simulate

    red = reduction.reduce_model(model) if reduced is None else reduced
    gap_dofs = list(dict.fromkeys(d for g in model.gaps for d in g.dofs))
    physical = [d for d in gap_dofs if d in reduction.boundary]
    if not physical:
        raise ModelError("model.gaps: none on a boundary DOF; expected gaps kept physical")
    full_run = simulate(model, t_end, dt, method, dofs=physical)
    red_run = simulate(red, t_end, dt, method, dofs=[reduction.reduced_dof(d) for d in physical])
    xf, xr = full_run.displacement, red_run.displacement
    disp = float(np.abs(xf - xr).max() / max(float(np.abs(xf).max()), np.finfo(float).tiny))
    ff, fr = full_run.gap_force, red_run.gap_force
    fmax = float(np.abs(ff).max()) if ff.size else 0.0
    force = float(np.abs(ff - fr).max() / fmax) if fmax > 0 else float(np.abs(fr).max() > 0)
    peaks_f = np.abs(ff).max(axis=0) if ff.size else np.zeros(0)
    peaks_r = np.abs(fr).max(axis=0) if fr.size else np.zeros(0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(peaks_f > 0, np.abs(peaks_f - peaks_r) / peaks_f, (peaks_r > 0) * 1.0)
    return ReductionCheck(
        displacement_error=disp,
        force_error=force,
        peak_force_error=float(rel.max()) if rel.size else 0.0,
        impacts_full=len(full_run.impacts),
        impacts_reduced=len(red_run.impacts),
        wall_time_full_s=full_run.stats.wall_time_s,
        wall_time_reduced_s=red_run.stats.wall_time_s,
    )
