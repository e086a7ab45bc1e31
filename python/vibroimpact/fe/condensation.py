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
:class:`CondensationWarning` says so. A force or a contact on a massless DOF changes
``x_s`` instantaneously, statically: see "Gaps on the null space" below (a massless DOF is
one). Recorded histories of condensed DOFs are recovered from
the retained ones (:class:`DofRecovery`).

``K_ss`` is factorised once (sparse LU with symmetric pivoting, which keeps ``K_ss``'s
definiteness visible on the pivots); only the master columns that ``K_sm`` couples are solved
for, so ``T`` and the reduced matrices stay sparse where the model is.

**A general null space.** A consistent mass can be singular without zero rows: reduced
integration (CalculiX's C3D20R: 8 points for 20 nodes, rank 24 of 60 per element) and expanded
shells (S8R) give a positive semi-definite ``M`` whose null space mixes the DOFs. The same
condensation then runs in the eigenvectors of ``M`` (dense, :func:`condense_null_space`):
``M = R Λ Rᵀ`` with ``R`` the orthonormal eigenvectors of the eigenvalues above
``NULL_SPACE_RTOL · λ_max`` and ``Z`` those of the others (an eigenvalue below
``-NULL_SPACE_RTOL · λ_max`` is refused: ``M`` is indefinite), ``x = R q + Z s``; the rows ``Z``
read ``Zᵀ K x = Zᵀ f`` (``Zᵀ M = 0``), so with no force there ``s = -(ZᵀKZ)⁻¹ ZᵀKR q`` and

    x = T q,   T = R - Z (ZᵀKZ)⁻¹ ZᵀKR,   M_r = TᵀMT,   K_r = TᵀKT,   C_r = TᵀCT,

the massless-DOF case with ``R``, ``Z`` the unit vectors of the DOFs with and without mass.
The finite eigenvalues of ``(K, M)`` are exactly those of ``(K_r, M_r)``. The coordinates
``q = Rᵀ x`` are generalized (the retained DOFs are none).

**Gaps on the null space.** Every node of a C3D20R or S8R model has a part in the null space
(and a massless DOF is one): a force ``φ b`` there moves the massless modes statically, ``x =
T q + G b φ`` with ``G = Z (ZᵀKZ)⁻¹ Zᵀ`` (the rows ``Z`` with the force), so the gap
coordinate ``u = bᵀx = (Tᵀb)ᵀq + c φ``, ``c = bᵀGb ≥ 0``: the contact sees the reduced
coordinates through a linear spring of compliance ``c`` in series with its law, exactly. A gap
is reduced to ``u_q = (Tᵀb)ᵀq`` and its law to the same law in series with ``c``
(:class:`~vibroimpact.contact.Hertz` ``compliance``; only an elastic law has a series form
that is a function of the penetration, so a damped law there is refused), and
:class:`DofRecovery` adds ``G b φ`` (and its time derivatives, from the law) to the
recovered DOFs and ``c φ`` to the gap's penetration, which are then the full model's. Two
such gaps would be coupled through ``bᵢᵀ G bⱼ`` (refused unless that vanishes). A load
``f F(t)`` acts on ``q`` as ``Tᵀf F(t)`` exactly (``TᵀKG = 0``, ``MG = 0``) and adds ``G f
F(t)`` to ``x`` (and ``G f Ḟ``, ``G f F̈``: :class:`DofRecovery`); one coupled to such a gap
(``bᵀ G f ≠ 0``) is refused. An initial state must have no part in the null space (``Zᵀx =
0``, ``q = Rᵀx``) or be a state ``T q`` of the condensed model
(:meth:`StaticCondensation.state_problem`).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import ArrayLike, NDArray

from vibroimpact.errors import ModelError

if TYPE_CHECKING:
    from vibroimpact.fe.dofs import DofMap, FEStructure
    from vibroimpact.model import Gap, Load
    from vibroimpact.result import Result

__all__ = [
    "CondensationWarning",
    "DofRecovery",
    "StaticCondensation",
    "condense_massless",
    "condense_null_space",
    "massless_dofs",
    "weighted_gap",
    "weighted_loads",
]

#: ``C_s· T`` relative to ``C`` above this is reported as inexact damping.
DAMPING_TOLERANCE = 1e-9
#: Eigenvalues of ``M`` at or below this times the largest span its null space; a mass whose
#: pivots fall below it (relative to the largest diagonal entry) is singular.
NULL_SPACE_RTOL = 1e-10
#: A gap, load or initial state whose part in the null space of ``M`` exceeds this fraction
#: of it is refused.
NULL_PART_TOLERANCE = 1e-9
#: The general null-space condensation is dense; above this many DOFs it refuses.
NULL_SPACE_LIMIT = 6000


class CondensationWarning(UserWarning):
    """Damping acts on condensed massless DOFs in a way a static condensation cannot carry
    (``C_s· T ≠ 0``, see :mod:`vibroimpact.fe.condensation`)."""


@dataclass(frozen=True)
class StaticCondensation:
    """The result of :func:`condense_massless`.

    ``structure``: the reduced :class:`~vibroimpact.fe.FEStructure` (massless DOFs: on the
    retained DOFs, its DOF map, hence its ``dof_units``, the full map's retained rows; a general
    null space: on generalized coordinates, no DOF map);
    ``retained``/``condensed``: DOF indices of the full structure (retained DOF ``k`` of the
    reduced model is full DOF ``retained[k]``; none for a general null space) and its massless
    DOFs (zero rows of ``M``); ``transform``: ``T`` (n × n_reduced, sparse), ``x = T q``;
    ``damping_residual``: ``‖Zᵀ C T‖ / ‖C‖`` (max-abs norms; 0 when the condensation is exact);
    ``projection``: ``q = P x`` for a state without a null-space part (``Rᵀ``, n_reduced × n);
    ``null_space``: ``Z`` (n × the nullity), orthonormal; ``null_solve``: ``y ↦ (ZᵀKZ)⁻¹ y``
    (factorised once).
    """

    full: FEStructure
    structure: FEStructure
    retained: NDArray[np.int64]
    condensed: NDArray[np.int64]
    transform: sp.csr_array
    damping_residual: float
    projection: sp.csr_array | NDArray[np.float64]
    null_space: sp.csr_array | NDArray[np.float64]
    null_solve: Callable[[NDArray[np.float64]], NDArray[np.float64]]

    def null_part(self, vector: ArrayLike) -> float:
        """``‖Zᵀ b‖ / ‖b‖``: how much of a force or state ``b`` (full DOFs) lies in the null
        space of ``M`` (0 for ``b = 0``)."""
        b = np.asarray(vector, dtype=float)
        size = float(np.linalg.norm(b))
        return float(np.linalg.norm(self.null_space.T @ b)) / size if size > 0 else 0.0

    def static_response(self, vector: ArrayLike) -> NDArray[np.float64]:
        """``G b = Z (ZᵀKZ)⁻¹ Zᵀ b``: the full DOFs' static displacement of the massless modes
        under the force ``b`` with ``q`` held (module docstring, "Gaps on the null space")."""
        zb = np.asarray(self.null_space.T @ np.asarray(vector, dtype=float))
        if not zb.size:
            return np.zeros(self.full.n_dof)
        return np.asarray(self.null_space @ self.null_solve(zb))

    def state_problem(self, x: ArrayLike) -> str | None:
        """Why the full state ``x`` cannot be condensed, as the "expected ..." of an error
        line; None if it can: it has no part in the null space (:meth:`null_part`; the
        massless part is then set from ``q = P x``), or it is a state ``x = T q`` of the
        condensed model (a mode shape: checked by projection, ``‖x − T P x‖ ≤``
        :data:`NULL_PART_TOLERANCE` ``‖x‖``)."""
        v = np.asarray(x, dtype=float)
        size = float(np.linalg.norm(v))
        part = self.null_part(v)
        if part <= NULL_PART_TOLERANCE:
            return None
        off = float(np.linalg.norm(v - self.transform @ (self.projection @ v))) / size
        if off <= NULL_PART_TOLERANCE:
            return None
        return (f"values with no part in the null space of the mass matrix ({part:.2g} of them "
                f"lie in its {self.null_space.shape[1]} massless modes or DOFs, whose state "
                f"follows from the others), or a state x = T q of the condensed model such as "
                f"a mode shape ({off:.2g} of them is not)")

    def _vector(self, dofs: Sequence[int], weights: Sequence[float]) -> NDArray[np.float64]:
        b = np.zeros(self.full.n_dof)
        np.add.at(b, np.asarray(dofs, dtype=np.int64), np.asarray(weights, dtype=float))
        return b

    def gap_compliance(self, gap: Gap) -> float:
        """``c = bᵀGb`` of ``gap`` (full DOFs; 0 if it has no part in the null space)."""
        b = self._vector(gap.dofs, gap.coefficients or (1.0,) * len(gap.dofs))
        if self.null_part(b) <= NULL_PART_TOLERANCE:
            return 0.0
        return float(b @ self.static_response(b))

    def reduce_gap(self, gap: Gap) -> Gap:
        """``gap`` (on full DOFs) on the reduced coordinates: ``u_q = (Tᵀb)ᵀq``, its law in
        series with the compliance :meth:`gap_compliance` of the massless modes (module
        docstring); a :class:`ModelError` for a damped law there."""
        from vibroimpact.contact import Hertz

        b = self._vector(gap.dofs, gap.coefficients or (1.0,) * len(gap.dofs))
        row = np.asarray(self.transform.T @ b)
        if not np.any(row):
            raise ModelError(f"gap.dof: {list(gap.dofs)} is not valid; expected DOFs that the "
                             "condensed model moves (this gap lies in the massless modes only)")
        reduced = weighted_gap(gap, row)
        c = self.gap_compliance(gap)
        if c == 0.0:
            return reduced
        if not isinstance(gap.law, Hertz):
            raise ModelError(
                f"law: {gap.law.kind!r} is not valid on a gap whose DOFs have a part in the "
                f"massless modes (which act as a spring of {c:.3e} m/N in series with the law); "
                "expected hertz (an elastic law: a damped law's rate would split between the "
                "two), or fully integrated elements (C3D20) or a lumped mass"
            )
        law = dataclasses.replace(gap.law, compliance=gap.law.compliance + c)
        return dataclasses.replace(reduced, law=law)

    def reduce_gaps(self, gaps: Sequence[Gap]) -> list[Gap]:
        """:meth:`reduce_gap` of each; a :class:`ModelError` if two of them with a part in the
        massless modes are coupled through them (``bᵢᵀ G bⱼ`` above 1e-9 of
        ``√(cᵢ cⱼ)``: their series springs would not be independent)."""
        return [self.reduce_gap(g) for g in self.check_gaps(gaps)]

    def check_gaps(self, gaps: Sequence[Gap]) -> Sequence[Gap]:
        """``gaps`` if no two of them are coupled through the massless modes (see
        :meth:`reduce_gaps`), else a :class:`ModelError` naming the second one."""
        vectors = [self._vector(g.dofs, g.coefficients or (1.0,) * len(g.dofs)) for g in gaps]
        compliant = [(i, b, self.static_response(b)) for i, (g, b) in
                     enumerate(zip(gaps, vectors, strict=True)) if self.gap_compliance(g) > 0]
        for a, (i, bi, gi) in enumerate(compliant):
            for j, bj, gj in compliant[a + 1:]:
                cross = float(bj @ gi)
                if abs(cross) > 1e-9 * math.sqrt(float(bi @ gi) * float(bj @ gj)):
                    raise ModelError(
                        f"gaps[{j}].dof: {list(gaps[j].dofs)} is not valid; expected a gap not "
                        f"coupled to gaps[{i}] through the massless modes of the mass matrix "
                        f"(bᵀ·G·b' = {cross:.3e} m/N: their series springs interact); put one "
                        "of them on fully integrated elements (C3D20) or a lumped mass"
                    )
        return gaps

    def reduce_load(self, load: Load) -> list[Load]:
        """``load`` (on full DOFs) as loads on the reduced coordinates with the generalized
        force ``Tᵀf`` (:func:`weighted_loads`)."""
        b = self._vector(load.dofs, (1.0,) * len(load.dofs))
        return weighted_loads(load, np.asarray(self.transform.T @ b))

    def load_response(self, load: Load) -> NDArray[np.float64] | None:
        """``G f`` of ``load`` (full DOFs, per newton of ``F(t)``): the static response of the
        massless part, which :class:`DofRecovery` adds times ``F(t)``; None if ``f`` has no
        part in the null space."""
        b = self._vector(load.dofs, (1.0,) * len(load.dofs))
        if self.null_part(b) <= NULL_PART_TOLERANCE:
            return None
        return self.static_response(b)

    def reduce_state(self, x: ArrayLike) -> NDArray[np.float64]:
        """The reduced state ``q = P x`` of a full state that :meth:`state_problem` accepts
        (a :class:`ModelError` otherwise)."""
        v = np.asarray(x, dtype=float)
        problem = self.state_problem(v)
        if problem is not None:
            raise ModelError(f"initial: the state is not valid; expected {problem}")
        return np.asarray(self.projection @ v)

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

    def output(self, dofs: Sequence[int] | None = None, gaps: Sequence[Gap] = (),
               loads: Sequence[Load] = ()) -> DofRecovery:
        """The :class:`DofRecovery` of a run that should report the full DOFs ``dofs`` (None:
        every DOF, the condensed ones included); ``gaps``, ``loads``: the model's gaps and
        loads on the full DOFs (before :meth:`reduce_gaps`, :meth:`reduce_load`), whose forces
        move the massless modes."""
        return DofRecovery(self, dofs, gaps, loads)


@dataclass(frozen=True)
class _CompliantGap:
    """A gap with a part in the massless modes (module docstring, "Gaps on the null space"):
    ``index`` in the model, ``row`` (``u_q = row · x_record``), ``response`` (``G b`` on the
    reported DOFs), its compliance ``c`` (the law's own added), the law's ``K``, ``n`` and
    the total series compliance, and its wall ``signs``."""

    index: int
    row: NDArray[np.float64]
    response: NDArray[np.float64]
    compliance: float
    stiffness: float
    exponent: float
    series: float
    signs: tuple[float, ...]

    def forcing(self, force: NDArray[np.float64], x: NDArray[np.float64],
                v: NDArray[np.float64], a: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The generalized force ``φ = −s F`` on the gap and its two time derivatives at the
        rows with contact force ``force`` and recorded ``x``, ``v``, ``a``: ``F`` is a function
        of the penetration ``δ_q`` (Hertz in series), ``Ḟ = F' δ̇_q``, ``F̈ = F'' δ̇_q² + F' δ̈_q``
        with ``F' = f'/(1 + c f')``, ``F'' = f''/(1 + c f')³`` at the law's own ``δ_l``."""
        u, du, ddu = x @ self.row, v @ self.row, a @ self.row
        side = (np.full(len(u), self.signs[0]) if len(self.signs) == 1
                else np.where(u >= 0, 1.0, -1.0))
        k, n, c = self.stiffness, self.exponent, self.series
        closed = force > 0
        own = np.where(closed, force / k, 1.0) ** (1.0 / n)
        d1 = np.where(closed, n * k * own ** (n - 1), 0.0)
        d2 = np.where(closed, n * (n - 1) * k * own ** (n - 2), 0.0)
        slope, curvature = d1 / (1 + c * d1), d2 / (1 + c * d1) ** 3
        rate, accel = side * du, side * ddu
        return (-side * force, -side * slope * rate,
                -side * (curvature * rate**2 + slope * accel))


class DofRecovery:
    """Time histories of a condensed run in the full model's DOF numbering, the condensed
    DOFs recovered from the retained ones.

    ``x_s = T_s x_m`` (module docstring) is linear and time-independent, so velocities and
    accelerations follow by the same matrix: ``v_s = T_s v_m``, ``a_s = T_s a_m`` (exact when
    the condensation is, see :attr:`StaticCondensation.damping_residual`); a gap with a part
    in the massless modes adds ``G b φ`` and its derivatives, and ``c φ`` to its penetration
    (:class:`_CompliantGap`). ``labels``: the full DOFs reported (the ``dof`` coordinate of
    the results; ``units``: their units, the full structure's ``dof_units``); ``record``: the
    retained (run) DOFs the run must record, those the reported rows of ``T`` and the gaps'
    rows touch; ``matrix``: ``T[labels, record]``, reported = recorded ``@ matrix.T``. One
    object per run: :meth:`rows` keeps the recovered DOFs' peak ``|x|`` over the rows it sees
    (every recorded row; the retained DOFs keep the core's peak over every step).
    """

    def __init__(self, condensation: StaticCondensation, dofs: Sequence[int] | None,
                 gaps: Sequence[Gap] = (), loads: Sequence[Load] = ()) -> None:
        t = condensation.transform
        n = t.shape[0]
        self.labels = np.arange(n) if dofs is None else np.asarray(dofs, dtype=np.int64)
        bad = [int(d) for d in self.labels if not 0 <= d < n]
        if bad:
            raise ModelError(f"output.dofs: {bad[0]} is out of range; expected 0 <= dof < {n}")
        rows = sp.csr_array(t[self.labels])
        compliant = [(i, g) for i, g in enumerate(condensation.check_gaps(gaps))
                     if condensation.gap_compliance(g) > 0]
        gap_rows = [np.asarray(t.T @ condensation._vector(g.dofs, g.coefficients or ()))
                    for _, g in compliant]
        touched = [rows.indices, *(np.flatnonzero(r) for r in gap_rows)]
        self.record: NDArray[np.int64] = np.unique(np.concatenate(touched)).astype(np.int64)
        self.matrix = sp.csr_array(rows[:, self.record])
        self._gaps = []
        for (i, g), row in zip(compliant, gap_rows, strict=True):
            b = condensation._vector(g.dofs, g.coefficients or ())
            c = condensation.gap_compliance(g)
            law = g.law
            self._gaps.append(_CompliantGap(
                i, row[self.record], condensation.static_response(b)[self.labels], c,
                law.contact_stiffness, float(law.exponent), law.compliance + c,
                {"positive": (1.0,), "negative": (-1.0,), "both": (1.0, -1.0)}[g.side]))
        #: loads with a part in the massless modes and their static response ``G f``
        self._loads: list[tuple[Load, NDArray[np.float64]]] = []
        for i, load in enumerate(loads):
            response = condensation.load_response(load)
            if response is None:
                continue
            f = condensation._vector(load.dofs, (1.0,) * len(load.dofs))
            for j, g in compliant:
                cross = float(condensation._vector(g.dofs, g.coefficients or (1.0,) * len(g.dofs))
                              @ response)
                if abs(cross) > 1e-9 * math.sqrt(condensation.gap_compliance(g)
                                                 * float(f @ response)):
                    raise ModelError(
                        f"loads[{i}].dof: {list(load.dofs)} is not valid; expected a load not "
                        f"coupled to gaps[{j}] through the massless modes of the mass matrix "
                        f"(bᵀ·G·f = {cross:.3e} m/N: its static response would move the gap); "
                        "move one of them, or use fully integrated elements (C3D20)")
            self._loads.append((load, response[self.labels]))
        retained = {int(d): k for k, d in enumerate(condensation.retained)}
        position = {int(d): j for j, d in enumerate(self.record)}
        #: column of ``record`` that a reported DOF is, -1 for a recovered (condensed) one
        self._direct = np.array([position[retained[int(d)]]
                                 if int(d) in retained and not (self._gaps or self._loads)
                                 else -1
                                 for d in self.labels], dtype=np.int64)
        self._peak = np.zeros(len(self.labels))
        full_units = condensation.full.dof_units
        #: the unit of each reported DOF (``dof_units`` of the result)
        self.units: tuple[str, ...] = tuple(full_units[int(d)] for d in self.labels)

    def rows(self, raw: Mapping[str, object]) -> dict[str, object]:
        """A block of rows in the core's layout (``on_rows`` of :func:`vibroimpact.simulate`)
        with ``displacement``, ``velocity`` and ``acceleration`` on the reported DOFs (and,
        with gaps on the massless modes, ``gap_penetration`` the full model's)."""
        out = dict(raw)
        recorded = {name: np.asarray(raw[name], dtype=float).reshape(-1, len(self.record))
                    for name in ("displacement", "velocity", "acceleration")}
        for name, x in recorded.items():
            out[name] = np.asarray((self.matrix @ x.T).T).reshape(-1, len(self.labels))
        if self._gaps:
            force = np.asarray(raw["gap_force"], dtype=float)
            force = force.reshape(len(recorded["displacement"]), -1)
            penetration = np.array(raw["gap_penetration"], dtype=float).reshape(force.shape)
            for gap in self._gaps:
                terms = gap.forcing(force[:, gap.index], *recorded.values())
                for name, term in zip(recorded, terms, strict=True):
                    out[name] = out[name] + np.outer(term, gap.response)  # type: ignore[operator]
                penetration[:, gap.index] -= gap.compliance * force[:, gap.index]
            out["gap_penetration"] = penetration
        if self._loads:
            time = np.asarray(raw["time"], dtype=float)
            for load, response in self._loads:
                terms = load.force_and_rates(time)
                for name, term in zip(recorded, terms, strict=True):
                    out[name] = out[name] + np.outer(term, response)  # type: ignore[operator]
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
        rows = self.rows({"time": result.time, "displacement": result.displacement,
                          "velocity": result.velocity,
                          "acceleration": result.acceleration,
                          "gap_force": result.gap_force,
                          "gap_penetration": result.gap_penetration})
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
    """Condense the massless DOFs of ``fe`` statically (module docstring), or, if ``M`` on the
    other DOFs is singular too, its whole null space (:func:`condense_null_space`). ``keep``:
    DOFs that must stay (gaps, loads); a massless one among them is refused with a
    :class:`ModelError`. Raises a :class:`ModelError` if ``K`` does not hold the massless
    DOFs (``K_ss`` singular or not positive definite)."""
    from vibroimpact.model import spd_solver

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
    if spd_solver(fe.mass[m_idx][:, m_idx], NULL_SPACE_RTOL) is None:
        return condense_null_space(fe, keep)
    k = sp.csr_array(fe.stiffness)
    ts, solve = _slave_transform(k, s, m_idx, fe)
    eye = sp.identity(len(m_idx), format="csr")
    # T has rows in full DOF order: retained rows are I, condensed rows are T_s
    blocks = sp.vstack([eye, ts], format="csr")
    order = np.argsort(np.concatenate([m_idx, s]))
    t = sp.csr_array(blocks[order])
    t.eliminate_zeros()
    projection = sp.csr_array(sp.identity(n, format="csr")[m_idx])
    null_space = sp.csr_array(sp.identity(n, format="csr")[:, s])
    dof_map = None if fe.dof_map is None else fe.dof_map.take(m_idx.tolist())
    declared = (None if fe.declared_units is None
                else tuple(fe.declared_units[i] for i in m_idx.tolist()))
    return _condensation(fe, t, m_idx, s, projection, null_space, solve, dof_map, declared)


def condense_null_space(fe: FEStructure, keep: Iterable[int] = ()) -> StaticCondensation:
    """Condense the whole null space of a positive semi-definite ``M`` statically (module
    docstring, "A general null space"; dense, at most :data:`NULL_SPACE_LIMIT` DOFs). The
    reduced coordinates are generalized (``q = Rᵀx``); ``keep``: DOFs that gaps or loads act
    on, refused if they have a part in the null space. A :class:`ModelError` names the
    negative eigenvalue of an indefinite ``M``, or says that ``K`` does not hold the
    massless modes."""
    n = fe.n_dof
    if n > NULL_SPACE_LIMIT:
        raise ModelError(
            f"structure.mass: singular (not definite on the DOFs with mass) with {n} DOFs; "
            f"expected at most {NULL_SPACE_LIMIT} DOFs for the dense condensation of its null "
            "space (export a lumped or a fully integrated mass instead)"
        )
    lam, vec = scipy.linalg.eigh(fe.mass.toarray())
    top = float(lam[-1])
    if top <= 0:
        raise ModelError("structure.mass: all zero; expected at least one DOF with mass")
    tol = NULL_SPACE_RTOL * top
    if lam[0] < -tol:
        raise ModelError(
            f"structure.mass: not positive semi-definite (eigenvalue {lam[0]:.6g}, the largest "
            f"being {top:.6g}: {int(np.count_nonzero(lam < -tol))} below -{NULL_SPACE_RTOL:g} "
            "times it); expected a symmetric positive semi-definite mass matrix"
        )
    null = lam <= tol
    z, r = vec[:, null], vec[:, ~null]
    k = fe.stiffness.toarray()
    kzz = z.T @ k @ z
    factor = None
    if z.shape[1]:
        try:
            factor = scipy.linalg.cho_factor(kzz)
            if not np.all(np.diag(factor[0]) ** 2 > 1e-12 * float(np.abs(np.diag(kzz)).max())):
                factor = None
        except np.linalg.LinAlgError:
            factor = None
        if factor is None:
            raise ModelError(
                f"structure.stiffness: does not hold the {z.shape[1]} massless modes of the "
                "mass matrix (its null space); expected K restricted to them to be positive "
                "definite (support the structure, or give it mass there)"
            )
    t = r if factor is None else r - z @ scipy.linalg.cho_solve(factor, z.T @ k @ r)
    cond_units = fe.dof_units
    # a generalized coordinate takes the unit of its largest component
    declared = tuple(cond_units[i] for i in np.argmax(np.abs(r), axis=0))
    for d in sorted({int(d) for d in keep}):
        problem_vector = np.zeros(n)
        problem_vector[d] = 1.0
        part = float(np.linalg.norm(z.T @ problem_vector))
        if part > NULL_PART_TOLERANCE:
            raise ModelError(
                f"dof: {d} ({_label(fe, d)}) is not valid; expected a DOF with no part in the "
                f"null space of the mass matrix for a gap or a load ({part:.2g} of it lies there)"
            )
    def solve(y: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(scipy.linalg.cho_solve(factor, y))

    return _condensation(fe, sp.csr_array(t), np.zeros(0, dtype=np.int64),
                         massless_dofs(fe.mass), r.T, z, solve, None, declared)


def _condensation(
    fe: FEStructure,
    t: sp.csr_array,
    retained: NDArray[np.int64],
    condensed: NDArray[np.int64],
    projection: sp.csr_array | NDArray[np.float64],
    null_space: sp.csr_array | NDArray[np.float64],
    null_solve: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    dof_map: DofMap | None,
    declared: tuple[str, ...] | None,
) -> StaticCondensation:
    """``M_r = TᵀMT``, ``K_r = TᵀKT``, ``C_r = TᵀCT`` and the damping residual
    ``‖Zᵀ C T‖/‖C‖`` (a :class:`CondensationWarning` above :data:`DAMPING_TOLERANCE`)."""
    from vibroimpact.fe.dofs import FEStructure

    tt = t.T.tocsr()
    m_r = _symmetric(sp.csr_array(tt @ sp.csr_array(fe.mass) @ t))
    k_r = _symmetric(sp.csr_array(tt @ sp.csr_array(fe.stiffness) @ t))
    c_r = None
    residual = 0.0
    nullity = null_space.shape[1]
    if fe.damping is not None:
        c = sp.csr_array(fe.damping)
        c_r = _symmetric(sp.csr_array(tt @ c @ t))
        if nullity:
            r = np.abs(sp.csr_array(null_space.T @ c @ t) if sp.issparse(null_space)
                       else null_space.T @ (c @ t.toarray()))
            scale = float(abs(c).max()) or 1.0
            residual = float(r.max()) / scale if r.size else 0.0
    if residual > DAMPING_TOLERANCE:
        what = (f"{len(condensed)} massless DOFs" if len(retained) else
                f"the {nullity} massless modes of the mass matrix")
        warnings.warn(
            f"structure.damping: acts on {what} (‖Zᵀ·C·T‖/‖C‖ = {residual:.2e}); the static "
            "condensation neglects those damping forces (exact only for no damping, Rayleigh or "
            "modal damping on them)",
            CondensationWarning,
            stacklevel=3,
        )
    g_r = None if fe.gyroscopic is None else sp.csr_array(tt @ fe.gyroscopic @ t)
    reduced = FEStructure(m_r, k_r, c_r, dof_map, declared, gyroscopic=g_r,
                          spin_speed=fe.spin_speed)
    return StaticCondensation(fe, reduced, retained, condensed, t, residual, projection,
                              null_space, null_solve)


def weighted_gap(gap: Gap, row: NDArray[np.float64]) -> Gap:
    """``gap`` on the coordinates ``q`` with ``u = row · q`` (entries below 1e-14 of the
    largest dropped)."""
    keep = np.flatnonzero(np.abs(row) > 1e-14 * np.abs(row).max())
    dofs = [int(j) for j in keep]
    return dataclasses.replace(gap, dof=dofs if len(dofs) > 1 else dofs[0],
                               coefficients=[float(row[j]) for j in keep])


def weighted_loads(load: Load, weights: NDArray[np.float64]) -> list[Load]:
    """Loads of the kind of ``load`` giving the generalized force ``weights · F(t)``: one per
    distinct weight (entries below 1e-14 of the largest dropped)."""
    w = np.array(weights, dtype=float)
    scale = float(np.abs(w).max()) or 1.0
    w[np.abs(w) <= 1e-14 * scale] = 0.0
    groups: dict[float, list[int]] = {}
    for j in np.flatnonzero(w):
        groups.setdefault(float(w[j]), []).append(int(j))
    names = {f.name for f in dataclasses.fields(load)}
    key = "amplitude" if "amplitude" in names else "scale"
    base = float(getattr(load, key))
    return [dataclasses.replace(load, **{key: base * g, "dof": js if len(js) > 1 else js[0]})
            for g, js in groups.items()]


def _slave_transform(
    k: sp.csr_array, s: NDArray[np.int64], m_idx: NDArray[np.int64], fe: FEStructure
) -> tuple[sp.csr_array, Callable[[NDArray[np.float64]], NDArray[np.float64]]]:
    """``T_s = -K_ss⁻¹ K_sm`` (n_s × n_m, sparse), solving only for the coupled columns, and
    ``y ↦ K_ss⁻¹ y`` (the factor it used)."""
    if len(s) == 0:
        return sp.csr_array((0, len(m_idx))), lambda y: y
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
    ), lu.solve


def _symmetric(a: sp.csr_array) -> sp.csr_array:
    """``(A + Aᵀ)/2``: removes the round-off asymmetry of ``Tᵀ A T``."""
    b = sp.csr_array((a + a.T) * 0.5)
    b.eliminate_zeros()
    return b
