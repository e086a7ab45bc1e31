"""Static (Guyan) condensation of massless DOFs, in sparse form.

FE models with lumped mass often leave rotations (or other DOFs) without mass: their rows of
``M`` are zero, ``M`` is singular and the core's explicit-in-``M`` time loop cannot carry them.
Partition the DOFs into the retained ``m`` (with mass) and the condensed ``s`` (massless, no
gap, no load). The rows ``s`` of ``M ẍ + C ẋ + K x = F`` read ``C_s· ẋ + K_ss x_s + K_sm x_m =
0``; without damping on those rows they are the static relation ``x_s = -K_ss⁻¹ K_sm x_m``, so
``x = T x_m`` with ``T = [I; -K_ss⁻¹ K_sm]`` and (Guyan, AIAA J. 3(2):380, 1965)

    M_r = Tᵀ M T = M_mm,   K_r = Tᵀ K T = K_mm - K_ms K_ss⁻¹ K_sm,   C_r = Tᵀ C T.

This is **exact** (not an approximation) when the damping forces on the condensed DOFs vanish
along ``x = T x_m``, i.e. ``C_s· T = 0``: no damping on those rows, stiffness-proportional or
Rayleigh damping ``αM + βK`` (``C_s· = βK_s·``, and ``K_s· T = 0``) and modal damping built
from ``M`` (``C_s· = 0`` because ``M_s· = 0``). Any other damping on a massless DOF makes its
row a first-order equation ``C_s· ẋ + ... = 0`` that a static relation cannot represent: the
condensation then neglects the damping force on those rows (keeping ``Tᵀ C T``), which is an
approximation; :attr:`StaticCondensation.damping_residual` measures it and a
:class:`CondensationWarning` says so. A force or a contact on a massless DOF would change
``x_s`` instantaneously; such DOFs cannot be condensed and are refused (give them mass or move
the gap or load to a DOF with mass). Recorded histories of condensed DOFs are recovered from
the retained ones (:class:`DofRecovery`).

``K_ss`` is factorised once (sparse LU with symmetric pivoting, which keeps ``K_ss``'s
definiteness visible on the pivots); only the master columns that ``K_sm`` couples are solved
for, so ``T`` and the reduced matrices stay sparse where the model is.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import ArrayLike, NDArray

from vibroimpact.errors import ModelError

if TYPE_CHECKING:
    from vibroimpact.fe.dofs import FEStructure
    from vibroimpact.result import Result

__all__ = [
    "CondensationWarning",
    "DofRecovery",
    "StaticCondensation",
    "condense_massless",
    "massless_dofs",
]

#: ``C_s· T`` relative to ``C`` above this is reported as inexact damping.
DAMPING_TOLERANCE = 1e-9


class CondensationWarning(UserWarning):
    """Damping acts on condensed massless DOFs in a way a static condensation cannot carry
    (``C_s· T ≠ 0``, see :mod:`vibroimpact.fe.condensation`)."""


@dataclass(frozen=True)
class StaticCondensation:
    """The result of :func:`condense_massless`.

    ``structure``: the reduced :class:`~vibroimpact.fe.FEStructure` on the retained DOFs (its
    DOF map, hence its ``dof_units``, is the full map's retained rows);
    ``retained``/``condensed``: DOF indices of the full structure (retained DOF ``k`` of the
    reduced model is full DOF ``retained[k]``); ``transform``: ``T`` (n × n_retained,
    sparse), ``x = T x_r``; ``damping_residual``: ``‖C_s· T‖ / ‖C‖`` (max-abs norms; 0 when
    the condensation is exact).
    """

    full: FEStructure
    structure: FEStructure
    retained: NDArray[np.int64]
    condensed: NDArray[np.int64]
    transform: sp.csr_array
    damping_residual: float

    def reduced_index(self, dof: int) -> int:
        """The reduced index of the full DOF ``dof``; a :class:`ModelError` if it was
        condensed."""
        k = int(np.searchsorted(self.retained, dof))
        if k < len(self.retained) and self.retained[k] == dof:
            return k
        raise ModelError(
            f"dof: {dof} ({_label(self.full, dof)}) is not valid; expected a DOF that carries "
            "mass (massless DOFs are condensed out)"
        )

    def recover(self, x_retained: ArrayLike) -> NDArray[np.float64]:
        """Full DOF values (``x = T x_r``) from retained ones: a vector of ``n_retained`` or
        an array with ``n_retained`` columns (a time history, one row per sample)."""
        x = np.asarray(x_retained, dtype=float)
        if x.ndim == 1:
            return np.asarray(self.transform @ x)
        return np.asarray((self.transform @ x.T).T)

    def output(self, dofs: Sequence[int] | None = None) -> DofRecovery:
        """The :class:`DofRecovery` of a run that should report the full DOFs ``dofs`` (None:
        every DOF, the condensed ones included)."""
        return DofRecovery(self, dofs)


class DofRecovery:
    """Time histories of a condensed run in the full model's DOF numbering, the condensed
    DOFs recovered from the retained ones.

    ``x_s = T_s x_m`` (module docstring) is linear and time-independent, so velocities and
    accelerations follow by the same matrix: ``v_s = T_s v_m``, ``a_s = T_s a_m`` (exact when
    the condensation is, see :attr:`StaticCondensation.damping_residual`). ``labels``: the full
    DOFs reported (the ``dof`` coordinate of the results; ``units``: their units, the full
    structure's ``dof_units``); ``record``: the retained (run) DOFs the run must record, those
    the reported rows of ``T`` touch; ``matrix``: ``T[labels,
    record]``, reported = recorded ``@ matrix.T``. One object per run: :meth:`rows` keeps the
    recovered DOFs' peak ``|x|`` over the rows it sees (every recorded row; the retained DOFs
    keep the core's peak over every step).
    """

    def __init__(self, condensation: StaticCondensation, dofs: Sequence[int] | None) -> None:
        t = condensation.transform
        n = t.shape[0]
        self.labels = np.arange(n) if dofs is None else np.asarray(dofs, dtype=np.int64)
        bad = [int(d) for d in self.labels if not 0 <= d < n]
        if bad:
            raise ModelError(f"output.dofs: {bad[0]} is out of range; expected 0 <= dof < {n}")
        rows = sp.csr_array(t[self.labels])
        self.record: NDArray[np.int64] = np.unique(rows.indices).astype(np.int64)
        self.matrix = sp.csr_array(rows[:, self.record])
        retained = {int(d): k for k, d in enumerate(condensation.retained)}
        position = {int(d): j for j, d in enumerate(self.record)}
        #: column of ``record`` that a reported DOF is, -1 for a recovered (condensed) one
        self._direct = np.array([position[retained[int(d)]] if int(d) in retained else -1
                                 for d in self.labels], dtype=np.int64)
        self._peak = np.zeros(len(self.labels))
        full_units = condensation.full.dof_units
        #: the unit of each reported DOF (``dof_units`` of the result)
        self.units: tuple[str, ...] = tuple(full_units[int(d)] for d in self.labels)

    def rows(self, raw: Mapping[str, object]) -> dict[str, object]:
        """A block of rows in the core's layout (``on_rows`` of :func:`vibroimpact.simulate`)
        with ``displacement``, ``velocity`` and ``acceleration`` on the reported DOFs."""
        out = dict(raw)
        for name in ("displacement", "velocity", "acceleration"):
            x = np.asarray(raw[name], dtype=float).reshape(-1, len(self.record))
            out[name] = np.asarray((self.matrix @ x.T).T).reshape(-1, len(self.labels))
        x = out["displacement"]
        assert isinstance(x, np.ndarray)
        if len(x):
            self._peak = np.maximum(self._peak, np.abs(x).max(axis=0))
        return out

    def result(self, result: Result) -> Result:
        """``result`` (recording :attr:`record`) on the reported DOFs; call once, after every
        block of a streamed run has passed :meth:`rows`."""
        if not np.array_equal(result.dofs, self.record):
            raise ModelError(f"dofs: {result.dofs.tolist()} is not valid; expected the run to "
                             f"record the DOFs {self.record.tolist()} of DofRecovery.record")
        rows = self.rows({"displacement": result.displacement, "velocity": result.velocity,
                          "acceleration": result.acceleration})
        direct = self._direct >= 0
        peak = self._peak.copy()
        peak[direct] = np.asarray(result.max_abs_displacement, dtype=float)[self._direct[direct]]
        return dataclasses.replace(result, dofs=self.labels, dof_units=self.units,
                                   max_abs_displacement=peak, **rows)


def _label(fe: FEStructure, dof: int) -> str:
    if fe.dof_map is None:
        return f"DOF {dof}"
    return f"node {fe.dof_map.nodes[dof]} direction {fe.dof_map.directions[dof]!r}"


def massless_dofs(mass: sp.csr_array) -> NDArray[np.int64]:
    """The DOFs whose row of ``mass`` is zero."""
    a = sp.csr_array(mass)
    a.eliminate_zeros()
    return np.flatnonzero(np.diff(a.indptr) == 0)


def condense_massless(fe: FEStructure, keep: Iterable[int] = ()) -> StaticCondensation:
    """Condense the massless DOFs of ``fe`` statically (module docstring). ``keep``: DOFs
    that must stay (gaps, loads); a massless one among them is refused with a
    :class:`ModelError`. Raises a :class:`ModelError` if ``K`` does not hold the massless
    DOFs (``K_ss`` singular or not positive definite)."""
    from vibroimpact.fe.dofs import FEStructure

    n = fe.n_dof
    s = massless_dofs(fe.mass)
    kept = sorted({int(d) for d in keep})
    bad = [d for d in kept if d in set(s.tolist())]
    if bad:
        raise ModelError(
            f"dof: {bad[0]} ({_label(fe, bad[0])}) is not valid; expected a DOF that carries "
            "mass for a gap or a load (massless DOFs are condensed out statically)"
        )
    m_idx = np.setdiff1d(np.arange(n), s)
    if len(m_idx) == 0:
        raise ModelError("structure.mass: all zero; expected at least one DOF with mass")
    k = sp.csr_array(fe.stiffness)
    ts = _slave_transform(k, s, m_idx, fe)
    eye = sp.identity(len(m_idx), format="csr")
    # T has rows in full DOF order: retained rows are I, condensed rows are T_s
    blocks = sp.vstack([eye, ts], format="csr")
    order = np.argsort(np.concatenate([m_idx, s]))
    t = sp.csr_array(blocks[order])
    t.eliminate_zeros()
    tt = t.T.tocsr()
    m_r = sp.csr_array(fe.mass[m_idx][:, m_idx])
    k_r = _symmetric(sp.csr_array(tt @ k @ t))
    c_r = None
    residual = 0.0
    if fe.damping is not None:
        c = sp.csr_array(fe.damping)
        c_r = _symmetric(sp.csr_array(tt @ c @ t))
        if len(s):
            r = sp.csr_array(c[s] @ t)
            scale = float(abs(c).max()) or 1.0
            residual = float(abs(r).max()) / scale if r.nnz else 0.0
    if residual > DAMPING_TOLERANCE:
        warnings.warn(
            f"structure.damping: acts on {len(s)} massless DOFs (‖C_s·T‖/‖C‖ = {residual:.2e}); "
            "the static condensation neglects those damping forces (exact only for no damping, "
            "Rayleigh or modal damping on them)",
            CondensationWarning,
            stacklevel=2,
        )
    dof_map = None if fe.dof_map is None else fe.dof_map.take(m_idx.tolist())
    declared = (None if fe.declared_units is None
                else tuple(fe.declared_units[i] for i in m_idx.tolist()))
    reduced = FEStructure(m_r, k_r, c_r, dof_map, declared)
    return StaticCondensation(fe, reduced, m_idx, s, t, residual)


def _slave_transform(
    k: sp.csr_array, s: NDArray[np.int64], m_idx: NDArray[np.int64], fe: FEStructure
) -> sp.csr_array:
    """``T_s = -K_ss⁻¹ K_sm`` (n_s × n_m, sparse), solving only for the coupled columns."""
    if len(s) == 0:
        return sp.csr_array((0, len(m_idx)))
    kss = sp.csc_array(k[s][:, s])
    ksm = sp.csc_array(k[s][:, m_idx])
    try:
        lu = spla.splu(kss, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
        pivots = lu.U.diagonal()
    except RuntimeError:
        pivots = np.zeros(1)
    scale = float(abs(kss).max()) if kss.nnz else 0.0
    if not (scale > 0 and np.all(pivots > 1e-12 * scale)):
        raise ModelError(
            f"structure.stiffness: does not hold the {len(s)} massless DOFs (first: "
            f"{_label(fe, int(s[0]))}); expected K restricted to the massless DOFs to be positive "
            "definite (support them, or give them mass)"
        )
    cols = np.flatnonzero(np.diff(ksm.indptr))
    ts = np.zeros((len(s), len(cols)))
    if len(cols):
        ts = -lu.solve(ksm[:, cols].toarray())
    out = sp.coo_array(ts)
    return sp.csr_array(
        (out.data, (out.row, cols[out.col])), shape=(len(s), len(m_idx))
    )


def _symmetric(a: sp.csr_array) -> sp.csr_array:
    """``(A + Aᵀ)/2``: removes the round-off asymmetry of ``Tᵀ A T``."""
    b = sp.csr_array((a + a.T) * 0.5)
    b.eliminate_zeros()
    return b
