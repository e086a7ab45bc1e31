"""The model: a linear structure ``M, C, K`` (paper eq. 1), gaps with contact laws, external
loads and initial conditions (paper eq. 2; docs/conventions.md). Plain data, validated on creation.

Example — the paper's SDOF case (a 100 kg block between two walls 5 mm away)::

    >>> import vibroimpact as vi
    >>> law = vi.contact.Hertz(stiffness=1.509e11)
    >>> model = vi.Model(
    ...     structure=vi.Structure.sdof(mass=100.0),
    ...     gaps=[vi.Gap(dof=0, clearance=0.005, side="both", law=law)],
    ...     initial_velocity=8.0,
    ... )
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, TypeAlias

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import ArrayLike, NDArray

from vibroimpact import _core
from vibroimpact.contact import LAWS, REMOVED_LAWS, ContactLaw
from vibroimpact.errors import ModelError, require

if TYPE_CHECKING:
    from vibroimpact.fe.dofs import DofMap

__all__ = [
    "DOF_UNITS",
    "ConstantLoad",
    "Gap",
    "HarmonicLoad",
    "Load",
    "Model",
    "Structure",
    "TableLoad",
    "UnbalanceLoad",
    "model_default",
    "spd_solver",
    "spec_load_frequency",
]

Side = Literal["positive", "negative", "both"]

#: The units a DOF's displacement can have (velocity: per s, acceleration: per s²): ``"m"``
#: (a translation), ``"rad"`` (a rotation) or ``"kg^0.5 m"`` (the coordinate of a
#: mass-normalised mode, ``φᵀMφ = 1``: a Craig–Bampton interior mode).
DOF_UNITS: tuple[str, ...] = ("m", "rad", "kg^0.5 m")

#: The core's catalog of the model's fields besides its matrices and laws
#: (``_core.model_catalog()``): by part (``structure``, ``gap``, ``radial-gap``,
#: ``load.<kind>``), each field's ``default`` (``None``: none), ``unit``, ``expected`` (what a
#: valid value is) and ``choices`` (the words a word field takes). The classes below take their
#: defaults from it and ask the core to check those fields; they only word the messages.
MODEL_CATALOG: dict[str, dict[str, dict[str, Any]]] = _core.model_catalog()


def model_default(part: str, name: str) -> Any:
    """The core's default of field ``name`` of ``part`` (:data:`MODEL_CATALOG`; a list as a
    tuple; ``None``: none, it must be given)."""
    default = MODEL_CATALOG[part][name]["default"]
    return tuple(default) if isinstance(default, list) else default


def _core_checked(part: str, name: str, value: Any, field_name: str) -> Any:
    """``value`` (a number as a ``float``) if the core accepts it for field ``name`` of ``part``
    (a number: finite and in range; a word: one of its choices), else the one-line
    :class:`ModelError` naming ``field_name``."""
    f = MODEL_CATALOG[part][name]
    number = not f["choices"]
    typed = (isinstance(value, (int, float, np.floating, np.integer))
             and not isinstance(value, bool)) if number else isinstance(value, str)
    require(typed and _core.model_field_accepts(part, name, value), field_name, value,
            f["expected"])
    return float(value) if number else value


#: ``structure.spin_profile``: a constant spin speed, or a linear run-up (or run-down).
SPIN_PROFILES: tuple[str, ...] = tuple(MODEL_CATALOG["structure"]["spin_profile"]["choices"])

#: The spin profile's fields of a structure and of a model spec.
SPIN_KEYS = ("spin_profile", "spin_speed_end", "run_up_time")

#: A structure matrix: a dense array, or a SciPy CSR array for large (e.g. FE) models.
Matrix: TypeAlias = "NDArray[np.float64] | sp.csr_array"


def _finite_number(value: Any, field_name: str, expected: str) -> float:
    ok = isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
    require(ok and math.isfinite(float(value)), field_name, value, expected)
    return float(value)


def _matrix(value: Any, field_name: str, n: int | None = None, *, skew: bool = False) -> Matrix:
    """A validated square, finite, symmetric (``skew``: skew-symmetric) matrix: a CSR array
    (canonical: sorted indices, no duplicates) if ``value`` is a SciPy sparse matrix, else a
    dense array."""
    a: Matrix
    try:
        if sp.issparse(value):
            a = sp.csr_array(value, dtype=float, copy=True)
            a.sum_duplicates()
        else:
            a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{field_name}: not a numeric matrix; expected an n x n array") from None
    if a.ndim == 0:
        a = np.asarray(a).reshape(1, 1)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ModelError(f"{field_name}: shape {a.shape} is not valid; expected a square matrix")
    if n is not None and a.shape[0] != n:
        raise ModelError(f"{field_name}: shape {a.shape} does not match; expected ({n}, {n})")
    values = a.data if sp.issparse(a) else a
    if not np.all(np.isfinite(values)):
        raise ModelError(f"{field_name}: contains NaN or infinity; expected finite values")
    scale = max(float(np.abs(values).max(initial=0.0)), np.finfo(float).tiny)
    if skew:
        off = float(abs(a + a.T).max())
        if off > 1e-9 * scale:
            raise ModelError(f"{field_name}: not skew-symmetric (max |G + G^T| = {off:.3e}); "
                             "expected G = -G^T")
        return a
    asym = float(abs(a - a.T).max())
    if asym > 1e-9 * scale:
        raise ModelError(
            f"{field_name}: not symmetric (max |A - A^T| = {asym:.3e}); expected a symmetric matrix"
        )
    return a


def largest(values: ArrayLike | sp.sparray) -> float:
    """The largest ``|value|`` of an array or sparse matrix (0 if empty), for error lines."""
    data = values.data if sp.issparse(values) else np.asarray(values, dtype=float)
    return float(np.abs(data).max(initial=0.0))


def not_finite(field_name: str, shown: str, quantity: str, expected: str) -> ModelError:
    """The one-line error for a derived ``quantity`` (energy, force, time scale) of the field
    ``field_name`` (its value ``shown``) that is not a finite number."""
    return ModelError(f"{field_name} = {shown}: {quantity} is not a finite number (overflows "
                      f"a double); expected {expected}")


def _shown(a: NDArray[np.float64]) -> str:
    """An initial state in an error line: the number of a single DOF, else its largest
    entry."""
    if a.size == 1:
        return f"{float(a[0]):g}"
    k = int(np.argmax(np.abs(a)))
    return f"{float(a[k]):g} (DOF {k})"


def spd_solver(
    a: Matrix, rtol: float = 0.0
) -> Callable[[NDArray[np.float64]], NDArray[np.float64]] | None:
    """A solver of ``A x = b`` if the symmetric ``a`` is positive definite, else ``None``.

    Dense: Cholesky. Sparse (never densified): SuperLU with diagonal pivots only
    (``diag_pivot_thresh=0``, symmetric mode) in a fill-reducing symmetric ordering, so that
    ``P A Pᵀ = L D Lᵀ`` with ``D`` the diagonal of ``U``: by Sylvester's law of inertia ``A``
    is positive definite iff the row and column orders agree and every pivot is > 0
    (Golub & Van Loan, *Matrix Computations*, 4th ed., §4.2). ``rtol``: every pivot must
    exceed ``rtol`` times the largest diagonal entry (a numerically singular matrix, whose
    round-off pivots may be positive, is then not definite)."""
    scale = float(np.abs(a.diagonal() if sp.issparse(a) else np.diag(a)).max(initial=0.0))
    floor = rtol * scale
    if sp.issparse(a):
        try:
            lu = spla.splu(sp.csc_array(a), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                           options={"SymmetricMode": True})
        except RuntimeError:  # an exactly zero pivot
            return None
        pivots = lu.U.diagonal()
        if not (np.array_equal(lu.perm_r, lu.perm_c) and np.all(pivots > floor)):
            return None
        return lu.solve  # type: ignore[no-any-return]
    try:
        factor = scipy.linalg.cho_factor(a)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.diag(factor[0]) ** 2 > floor):
        return None
    return lambda b: scipy.linalg.cho_solve(factor, b)  # type: ignore[no-any-return]


@dataclass(frozen=True)
class Structure:
    """Linear structure: mass ``M`` (kg), damping ``C`` (N·s/m) and stiffness ``K`` (N/m),
    symmetric n×n matrices; ``M`` positive definite. Dense arrays stay dense; if any of the
    three is a SciPy sparse matrix all three are kept as CSR arrays (``scipy.sparse.csr_array``)
    and stay sparse through validation and the core (issue 6: large FE models).

    ``dof_units``: the unit of each DOF's displacement, one of :data:`DOF_UNITS` per DOF
    (default ``"m"`` for all; a rotation is ``"rad"``, its rows of ``M`` and ``K`` then in
    kg·m² and N·m/rad). Results label each DOF with it (``dof_unit`` coordinate).

    A rotor (docs/rotors.md): ``spin_speed`` Ω (rad/s, default 0) and ``gyroscopic`` ``G``
    (kg·m², skew-symmetric; None: no gyroscopic forces) make the equation of motion
    ``M x'' + (C + Ω G) x' + K x = F``; unbalance loads (:class:`UnbalanceLoad`) turn at Ω.

    ``dof_map``: the node and direction of each DOF (a :class:`vibroimpact.fe.DofMap`: a
    beam's, an FE structure's, a Jeffcott rotor's node 0 x and y; None: unknown), which
    results keep (:attr:`vibroimpact.Result.dof_map`: ``plot --kind orbit --node N``)."""

    mass: Matrix
    stiffness: Matrix
    damping: Matrix
    dof_units: tuple[str, ...]
    gyroscopic: Matrix | None
    spin_speed: float
    spin_profile: str
    spin_speed_end: float | None
    run_up_time: float | None
    dof_map: DofMap | None

    def __init__(
        self,
        mass: ArrayLike | sp.sparray | sp.spmatrix,
        stiffness: ArrayLike | sp.sparray | sp.spmatrix | None = None,
        damping: ArrayLike | sp.sparray | sp.spmatrix | None = None,
        dof_units: Sequence[str] | None = None,
        *,
        gyroscopic: ArrayLike | sp.sparray | sp.spmatrix | None = None,
        spin_speed: float = model_default("structure", "spin_speed"),
        spin_profile: str = model_default("structure", "spin_profile"),
        spin_speed_end: float | None = None,
        run_up_time: float | None = None,
        dof_map: DofMap | None = None,
    ) -> None:
        m = _matrix(mass, "structure.mass")
        n = m.shape[0]
        sparse = any(sp.issparse(a) for a in (mass, stiffness, damping, gyroscopic))
        zero = sp.csr_array((n, n)) if sparse else np.zeros((n, n))
        k = zero.copy() if stiffness is None else _matrix(stiffness, "structure.stiffness", n)
        c = zero.copy() if damping is None else _matrix(damping, "structure.damping", n)
        g = None if gyroscopic is None else _matrix(gyroscopic, "structure.gyroscopic", n,
                                                    skew=True)
        if g is not None and largest(g) == 0:
            g = None
        if sparse:
            m, k, c = (sp.csr_array(a) for a in (m, k, c))
            g = None if g is None else sp.csr_array(g)
        if spd_solver(m) is None:
            raise ModelError(
                "structure.mass: not positive definite; expected every DOF to carry mass"
            )
        _check_rates(m, k, c)
        if not sparse:  # (SciPy canonicalises sparse arrays in place: left writable)
            for a in (m, k, c) if g is None else (m, k, c, g):
                a.setflags(write=False)
        object.__setattr__(self, "mass", m)
        object.__setattr__(self, "stiffness", k)
        object.__setattr__(self, "damping", c)
        object.__setattr__(self, "dof_units", check_dof_units(dof_units, n))
        object.__setattr__(self, "gyroscopic", g)
        object.__setattr__(self, "spin_speed", _core_checked(
            "structure", "spin_speed", spin_speed, "structure.spin_speed"))
        object.__setattr__(self, "spin_profile", _core_checked(
            "structure", "spin_profile", spin_profile, "structure.spin_profile"))
        for name, value in (("spin_speed_end", spin_speed_end), ("run_up_time", run_up_time)):
            if spin_profile == "constant":
                require(value is None, f"structure.{name}", value,
                        "no value with spin_profile = 'constant' (a run-up: 'linear')")
            else:
                expected = MODEL_CATALOG["structure"][name]["expected"]
                require(value is not None, f"structure.{name}", value,
                        f"{expected} with spin_profile = 'linear'")
                value = _core_checked("structure", name, value, f"structure.{name}")
            object.__setattr__(self, name, value)
        if dof_map is not None:
            require(len(dof_map.nodes) == n, "structure.dof_map", f"{len(dof_map.nodes)} DOFs",
                    f"a DOF map of the structure's {n} DOFs")
        object.__setattr__(self, "dof_map", dof_map)

    @classmethod
    def sdof(cls, mass: float, stiffness: float = 0.0, damping: float = 0.0) -> Structure:
        """Single DOF: ``mass`` in kg, ``stiffness`` in N/m, ``damping`` in N·s/m."""
        m = _finite_number(mass, "structure.mass", "a mass > 0 in kg")
        require(m > 0, "structure.mass", mass, "a mass > 0 in kg")
        k = _finite_number(stiffness, "structure.stiffness", "a stiffness >= 0 in N/m")
        require(k >= 0, "structure.stiffness", stiffness, "a stiffness >= 0 in N/m")
        c = _finite_number(damping, "structure.damping", "a damping >= 0 in N·s/m")
        require(c >= 0, "structure.damping", damping, "a damping >= 0 in N·s/m")
        return cls([[m]], [[k]], [[c]])

    @classmethod
    def jeffcott(cls, mass: float, stiffness: float | Sequence[float],
                 damping: float | Sequence[float] = 0.0, spin_speed: float = 0.0) -> Structure:
        """A Jeffcott rotor (a disc of ``mass`` kg on a massless shaft): DOF 0 = x, 1 = y,
        ``stiffness`` (N/m) and ``damping`` (N·s/m) to ground in each direction (one number
        for both, or ``[x, y]``), spinning at ``spin_speed`` rad/s (no gyroscopic forces: the
        disc does not tilt); its DOF map: node 0, x and y."""
        m = _finite_number(mass, "structure.mass", "a mass > 0 in kg")
        require(m > 0, "structure.mass", mass, "a mass > 0 in kg")
        per = []
        for name, value, unit in (("stiffness", stiffness, "N/m"), ("damping", damping,
                                                                   "N·s/m")):
            pair = [value, value] if not isinstance(value, (list, tuple, np.ndarray)) else value
            expected = f"a {name} >= 0 in {unit}, or two ([x, y])"
            require(len(pair) == 2, f"structure.{name}", value, expected)
            per.append([_finite_number(v, f"structure.{name}", expected) for v in pair])
            require(min(per[-1]) >= 0, f"structure.{name}", value, expected)
        from vibroimpact.fe.dofs import DofMap

        return cls(np.diag([m, m]), np.diag(per[0]), np.diag(per[1]), spin_speed=spin_speed,
                   dof_map=DofMap([0, 0], ["x", "y"]))

    def at_speed(self, spin_speed: float) -> Structure:
        """This structure spinning at the constant ``spin_speed`` (rad/s) instead."""
        return Structure(self.mass, self.stiffness, self.damping, self.dof_units,
                         gyroscopic=self.gyroscopic, spin_speed=spin_speed,
                         dof_map=self.dof_map)

    def run_up(self, spin_speed_end: float, run_up_time: float) -> Structure:
        """This structure run up (or down) from its spin speed Ω₀ to ``spin_speed_end`` Ω₁
        (rad/s) over ``run_up_time`` T (s), then held: ``Ω(t) = Ω₀ + (Ω₁ − Ω₀) t / T``
        (``spin_profile = "linear"``)."""
        return Structure(self.mass, self.stiffness, self.damping, self.dof_units,
                         gyroscopic=self.gyroscopic, spin_speed=self.spin_speed,
                         spin_profile="linear", spin_speed_end=spin_speed_end,
                         run_up_time=run_up_time, dof_map=self.dof_map)

    def spin(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                         NDArray[np.float64]]:
        """``Ω(t)`` (rad/s), ``Ω̇(t)`` (rad/s²) and the angle turned ``∫₀ᵗ Ω dt`` (rad) at the
        times ``t`` ≥ 0 (s) of its spin profile."""
        tt = np.asarray(t, dtype=float)
        w0 = self.spin_speed
        if self.spin_profile == "constant":
            return np.full(tt.shape, w0), np.zeros(tt.shape), w0 * tt
        w1, duration = float(self.spin_speed_end), float(self.run_up_time)  # type: ignore[arg-type]
        slope = (w1 - w0) / duration
        ramp = tt < duration
        omega = np.where(ramp, w0 + slope * tt, w1)
        angle = np.where(ramp, (w0 + 0.5 * slope * tt) * tt,
                         0.5 * (w0 + w1) * duration + w1 * (tt - duration))
        return omega, np.where(ramp, slope, 0.0), angle

    @property
    def fastest_spin(self) -> float:
        """The largest ``|Ω|`` of its spin profile, rad/s."""
        return max(abs(self.spin_speed), abs(self.spin_speed_end or 0.0))

    @property
    def n_dof(self) -> int:
        return int(self.mass.shape[0])

    @property
    def is_sparse(self) -> bool:
        """Whether the matrices are CSR arrays (else dense arrays)."""
        return sp.issparse(self.mass)

    def dense_matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                      NDArray[np.float64]]:
        """``M, K, C`` as dense arrays (new copies when sparse): for small models and dense
        tools only, ``8 n²`` bytes each."""
        m, k, c = (a.toarray() if sp.issparse(a) else a for a in (self.mass, self.stiffness,
                                                                   self.damping))
        return m, k, c


def _check_rates(m: Matrix, k: Matrix, c: Matrix) -> None:
    """The structure's time scales, ``K_ii / M_ii`` (a squared natural frequency, 1/s²) and
    ``C_ii / M_ii`` (a decay rate, 1/s) on every DOF, must be finite doubles."""
    mass = m.diagonal()  # > 0: M is positive definite
    for name, a, quantity, unit in (
        ("structure.stiffness", k, "the squared frequency K_ii / M_ii", "N/m"),
        ("structure.damping", c, "the decay rate C_ii / M_ii", "N·s/m"),
    ):
        with np.errstate(over="ignore"):
            rate = np.abs(a.diagonal()) / mass
        if not np.all(np.isfinite(rate)):
            i = int(np.argmin(np.isfinite(rate)))
            raise not_finite(
                name, f"{float(a.diagonal()[i]):g}" + (f" (DOF {i})" if mass.size > 1 else ""),
                f"{quantity} with structure.mass {float(mass[i]):g} kg",
                f"a {name.split('.')[1]} in {unit} whose ratio to the mass is finite",
            )


def check_dof_units(value: Sequence[str] | None, n: int) -> tuple[str, ...]:
    """``value`` checked as one of :data:`DOF_UNITS` per DOF (None: ``"m"`` for all)."""
    if value is None:
        return ("m",) * n
    units = (value,) if isinstance(value, str) else tuple(value)
    require(len(units) == n, "structure.dof_units", list(units), f"{n} units (one per DOF)")
    for u in units:
        require(u in DOF_UNITS, "structure.dof_units", u, " or ".join(map(repr, DOF_UNITS)))
    return units


def _dofs(value: int | Sequence[int], field_name: str) -> tuple[int, ...]:
    items = [value] if isinstance(value, (int, np.integer)) else list(value)
    require(len(items) > 0, field_name, value, "a DOF index or a non-empty list of them")
    for d in items:
        ok = isinstance(d, (int, np.integer)) and not isinstance(d, bool) and d >= 0
        require(ok, field_name, d, "a DOF index (integer >= 0)")
    return tuple(int(d) for d in items)


@dataclass(frozen=True)
class Gap:
    """A clearance on the gap coordinate ``u = Σ cᵢ x[dofᵢ]`` (docs/conventions.md §Gaps).

    ``dof``: one DOF index or a list; ``coefficients``: one per DOF (default 1 each; use
    ``dof=[i, j], coefficients=[1, -1]`` for the relative displacement of two DOFs).
    ``clearance`` in m; ``side``: ``"positive"`` (wall at ``u = +d``), ``"negative"``
    (wall at ``u = −d``) or ``"both"``; ``law``: a :mod:`vibroimpact.contact` law.
    """

    dof: int | Sequence[int]
    law: ContactLaw
    clearance: float = model_default("gap", "clearance")
    side: Side = model_default("gap", "side")
    coefficients: Sequence[float] | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        dofs = _dofs(self.dof, "gap.dof")
        object.__setattr__(self, "dof", dofs if len(dofs) > 1 else dofs[0])
        coeffs = (1.0,) * len(dofs) if self.coefficients is None else tuple(self.coefficients)
        require(
            len(coeffs) == len(dofs)
            and all(isinstance(c, (int, float)) and math.isfinite(c) for c in coeffs)
            and any(c != 0 for c in coeffs),
            "gap.coefficients",
            self.coefficients,
            f"{len(dofs)} finite numbers, not all zero (one per DOF)",
        )
        object.__setattr__(self, "coefficients", tuple(float(c) for c in coeffs))
        _core_checked("gap", "clearance", self.clearance, "gap.clearance")
        _core_checked("gap", "side", self.side, "gap.side")
        require(isinstance(self.law, ContactLaw), "gap.law", self.law, "a vibroimpact.contact law")

    @property
    def dofs(self) -> tuple[int, ...]:
        return self.dof if isinstance(self.dof, tuple) else (int(self.dof),)  # type: ignore[arg-type]

    def to_spec(self) -> dict[str, Any]:
        return {
            "dofs": list(self.dofs),
            "coefficients": list(self.coefficients or ()),
            "clearance": float(self.clearance),
            "side": self.side,
            "law": self.law.to_spec(),
        }


FrictionLaw = Literal["coulomb", "regularised"]


@dataclass(frozen=True)
class RadialGap(Gap):
    """A circular stator around two DOFs ``dof = [ix, iy]`` (docs/rotors.md §Radial gaps):
    penetration ``δ = |(x − x_s, y − y_s)| − clearance`` with the stator centre ``center``
    (m); the law's normal force acts along the contact normal and the friction
    ``F_T = friction · F_N`` opposes the sliding speed ``v_rel = R Ω + ρ θ̇`` at the contact
    (``radius`` R in m, required when ``friction > 0``; Ω the structure's spin speed).
    ``friction_law``: ``"coulomb"`` (a crossing of ``v_rel = 0`` in contact stops the run:
    sticking is not modelled) or ``"regularised"``, ``F_T = μ F_N tanh(v_rel / v_reg)`` with
    ``regularisation_speed`` v_reg (m/s)."""

    dof: int | Sequence[int] = ()
    law: ContactLaw = None  # type: ignore[assignment]
    center: Sequence[float] = model_default("radial-gap", "center")
    friction: float = model_default("radial-gap", "friction")
    radius: float | None = model_default("radial-gap", "radius")
    friction_law: FrictionLaw = model_default("radial-gap", "friction_law")
    regularisation_speed: float | None = model_default("radial-gap", "regularisation_speed")
    side: Side = "radial"  # type: ignore[assignment]

    def __post_init__(self) -> None:
        items = [self.dof] if isinstance(self.dof, (int, np.integer)) else list(self.dof)
        require(len(items) == 2, "gap.dof", self.dof, "two DOFs [ix, iy] for a radial gap")
        dofs = _dofs(items, "gap.dof")
        require(dofs[0] != dofs[1], "gap.dof", list(dofs), "two different DOFs [ix, iy]")
        object.__setattr__(self, "dof", dofs)
        # the x direction's coefficients: what the contact time-scale estimates use
        object.__setattr__(self, "coefficients", (1.0, 0.0))
        _core_checked("radial-gap", "clearance", self.clearance, "gap.clearance")
        require(self.side == "radial", "gap.side", self.side, "radial (a RadialGap's only side)")
        require(isinstance(self.law, ContactLaw) and not self.law.impulsive, "gap.law", self.law,
                "a vibroimpact.contact force law (not rigid)")
        center = list(self.center) if isinstance(self.center, (list, tuple, np.ndarray)) else []
        expected = MODEL_CATALOG["radial-gap"]["center"]["expected"]
        require(len(center) == 2, "gap.center", self.center, expected)
        object.__setattr__(self, "center", tuple(
            _core_checked("radial-gap", "center", v, "gap.center") for v in center))
        mu = _core_checked("radial-gap", "friction", self.friction, "gap.friction")
        if mu > 0:
            require(self.radius is not None, "gap.radius", self.radius,
                    MODEL_CATALOG["radial-gap"]["radius"]["expected"])
        if self.radius is not None:
            _core_checked("radial-gap", "radius", self.radius, "gap.radius")
        _core_checked("radial-gap", "friction_law", self.friction_law, "gap.friction_law")
        if self.friction_law == "regularised":
            expected = MODEL_CATALOG["radial-gap"]["regularisation_speed"]["expected"]
            require(self.regularisation_speed is not None, "gap.regularisation_speed", None,
                    f"{expected} with friction_law = 'regularised'")
            _core_checked("radial-gap", "regularisation_speed", self.regularisation_speed,
                          "gap.regularisation_speed")
        elif self.regularisation_speed is not None:
            require(False, "gap.regularisation_speed", self.regularisation_speed,
                    "no value with friction_law = 'coulomb' (or friction_law = 'regularised')")

    def penetration(self, x: ArrayLike, v: ArrayLike) -> tuple[float, float]:
        """``δ = ρ − c`` and ``δ̇ = n·(ẋ, ẏ)`` at DOF displacements ``x`` and velocities ``v``."""
        x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
        ix, iy = self.dofs
        p = np.array([x[ix] - self.center[0], x[iy] - self.center[1]])
        rho = float(np.hypot(*p))
        n = p / rho if rho > 0 else np.array([1.0, 0.0])
        return rho - float(self.clearance), float(n @ v[[ix, iy]])

    def to_spec(self) -> dict[str, Any]:
        return {
            "dofs": list(self.dofs),
            "coefficients": [1.0, 1.0],
            "clearance": float(self.clearance),
            "side": "radial",
            "center": [float(c) for c in self.center],
            "friction": float(self.friction),
            "radius": float(self.radius or 0.0),
            "friction_law": self.friction_law,
            "regularisation_speed": float(self.regularisation_speed or 0.0),
            "law": self.law.to_spec(),
        }


@dataclass(frozen=True)
class Load:
    """Base of the loads: applied to each DOF in ``dof``."""

    dof: int | Sequence[int]

    def __post_init__(self) -> None:
        dofs = _dofs(self.dof, "load.dof")
        object.__setattr__(self, "dof", dofs if len(dofs) > 1 else dofs[0])

    @property
    def dofs(self) -> tuple[int, ...]:
        return self.dof if isinstance(self.dof, tuple) else (int(self.dof),)  # type: ignore[arg-type]

    @property
    def peak(self) -> float:
        """The largest ``|F|`` of the load, N."""
        raise NotImplementedError

    def force_and_rates(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                     NDArray[np.float64]]:
        """``F``, ``Ḟ`` and ``F̈`` (N, N/s, N/s²) at the times ``t`` (s)."""
        raise NotImplementedError

    def to_spec(self) -> dict[str, Any]:
        raise NotImplementedError


@dataclass(frozen=True)
class ConstantLoad(Load):
    """``F = amplitude`` (N)."""

    amplitude: float

    def __post_init__(self) -> None:
        super().__post_init__()
        _core_checked("load.constant", "amplitude", self.amplitude, "load.amplitude")

    @property
    def peak(self) -> float:
        return abs(float(self.amplitude))

    def force_and_rates(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                     NDArray[np.float64]]:
        zero = np.zeros(np.shape(t))
        return zero + float(self.amplitude), zero, zero.copy()

    def to_spec(self) -> dict[str, Any]:
        return {"kind": "constant", "dofs": list(self.dofs), "amplitude": float(self.amplitude)}


@dataclass(frozen=True)
class HarmonicLoad(Load):
    """``F = amplitude · sin(2π · frequency · t + phase)``: N, Hz, rad."""

    amplitude: float
    frequency: float
    phase: float = model_default("load.harmonic", "phase")

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in ("amplitude", "frequency", "phase"):
            _core_checked("load.harmonic", name, getattr(self, name), f"load.{name}")

    @property
    def peak(self) -> float:
        return abs(float(self.amplitude))

    def force_and_rates(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                     NDArray[np.float64]]:
        w = 2 * math.pi * float(self.frequency)
        angle = w * np.asarray(t, dtype=float) + float(self.phase)
        a = float(self.amplitude)
        return a * np.sin(angle), a * w * np.cos(angle), -a * w * w * np.sin(angle)

    def to_spec(self) -> dict[str, Any]:
        return {
            "kind": "harmonic",
            "dofs": list(self.dofs),
            "amplitude": float(self.amplitude),
            "frequency": float(self.frequency),
            "phase": float(self.phase),
        }


@dataclass(frozen=True)
class UnbalanceLoad:
    """A rotating unbalance on the DOF pair ``dof = [ix, iy]`` (x and y of one node) of a
    structure spinning at Ω (:attr:`Structure.spin_speed`): ``magnitude`` m·e (kg·m) at
    ``phase`` φ (rad) gives ``F = m e Ω² (cos(Ωt + φ), sin(Ωt + φ))`` (N); during a run-up
    (``Structure.run_up``) ``F = m e (Ω² cos θ + Ω̇ sin θ, Ω² sin θ − Ω̇ cos θ)`` with
    ``θ = ∫Ω dt + φ`` (the reaction of the eccentric mass's acceleration)."""

    dof: Sequence[int]
    magnitude: float
    phase: float = model_default("load.unbalance", "phase")

    def __post_init__(self) -> None:
        dofs = _dofs(self.dof, "load.dof")
        require(len(dofs) == 2 and dofs[0] != dofs[1], "load.dof", self.dof,
                "two distinct DOFs [ix, iy] (x and y of one node)")
        object.__setattr__(self, "dof", dofs)
        for name in ("magnitude", "phase"):
            _core_checked("load.unbalance", name, getattr(self, name), f"load.{name}")

    @property
    def dofs(self) -> tuple[int, ...]:
        return tuple(self.dof)

    def to_spec(self) -> dict[str, Any]:
        """The core applies it at the structure's spin profile (``Load::unbalance``)."""
        return {"kind": "unbalance", "dofs": list(self.dofs),
                "magnitude": float(self.magnitude), "phase": float(self.phase)}

    def harmonics(self, spin_speed: float) -> tuple[HarmonicLoad, HarmonicLoad]:
        """The two harmonic loads it is at the spin speed Ω (x: ``cos θ = sin(θ + π/2)``; a
        negative Ω turns the other way: ``θ = |Ω| t`` with the y force and phase negated)."""
        w, phase = abs(float(spin_speed)), float(self.phase)
        sign = 1.0 if spin_speed >= 0 else -1.0
        force = float(self.magnitude) * w * w
        ix, iy = self.dof
        return (HarmonicLoad(dof=ix, amplitude=force, frequency=w / (2 * math.pi),
                             phase=sign * phase + math.pi / 2),
                HarmonicLoad(dof=iy, amplitude=sign * force, frequency=w / (2 * math.pi),
                             phase=sign * phase))


@dataclass(frozen=True)
class TableLoad(Load):
    """Tabulated force ``scale · F(t)``: ``time`` (s, increasing) and ``force`` (N), linearly
    interpolated and held at the end values outside the table."""

    time: Sequence[float]
    force: Sequence[float]
    scale: float = model_default("load.table", "scale")

    def __post_init__(self) -> None:
        super().__post_init__()
        t = np.asarray(self.time, dtype=float)
        f = np.asarray(self.force, dtype=float)
        require(
            t.ndim == 1 and t.shape == f.shape and t.size >= 2,
            "load.table",
            f"{t.size} times, {f.size} forces",
            "two equal-length columns with at least 2 rows",
        )
        require(
            bool(np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)),
            "load.table.time",
            "non-increasing or non-finite times",
            "strictly increasing times in s",
        )
        require(bool(np.all(np.isfinite(f))), "load.table.force", "NaN", "finite forces in N")
        scale = _core_checked("load.table", "scale", self.scale, "load.scale")
        with np.errstate(over="ignore"):
            peak = scale * np.abs(f).max()
        if not math.isfinite(peak):
            raise not_finite("load.scale", f"{scale:g}", f"the largest force scale * |F| "
                             f"(|F| up to {largest(f):g} N)", "a factor whose force is finite")
        object.__setattr__(self, "time", tuple(t.tolist()))
        object.__setattr__(self, "force", tuple(f.tolist()))

    @property
    def peak(self) -> float:
        return abs(float(self.scale)) * max(abs(f) for f in self.force)

    def force_and_rates(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                     NDArray[np.float64]]:
        """Piecewise linear: ``Ḟ`` is the slope of the segment ``t`` is in (0 outside the
        table), ``F̈`` is 0 (its impulses at the table's corners are not represented)."""
        time, force = np.asarray(self.time), float(self.scale) * np.asarray(self.force)
        tt = np.asarray(t, dtype=float)
        segment = np.clip(np.searchsorted(time, tt, side="right") - 1, 0, len(time) - 2)
        slope = np.diff(force)[segment] / np.diff(time)[segment]
        inside = (tt >= time[0]) & (tt < time[-1])
        return np.interp(tt, time, force), np.where(inside, slope, 0.0), np.zeros(tt.shape)

    def to_spec(self) -> dict[str, Any]:
        return {
            "kind": "table",
            "dofs": list(self.dofs),
            "amplitude": float(self.scale),
            "time": list(self.time),
            "value": list(self.force),
        }


def spec_load_frequency(spec: dict[str, Any], i: int) -> float:
    """The frequency (Hz) of load ``i`` of a model spec (:meth:`Model.to_spec`, or the part of
    it a result file stores): a harmonic load's, or an unbalance's ``|Ω| / 2π`` at a constant
    spin speed; 0 for any other (a constant load, a table, an unbalance during a run-up: none
    that is periodic). The core's ``load_frequency``, as the sweeps use it."""
    return float(_core.load_frequency(spec["loads"][i], spec.get("spin_speed"),
                                      spec.get("spin_profile")))


def _initial(value: ArrayLike | None, n: int, field_name: str, unit: str) -> NDArray[np.float64]:
    if value is None:
        return np.zeros(n)
    a = np.atleast_1d(np.asarray(value, dtype=float))
    if a.shape != (n,):
        raise ModelError(
            f"{field_name}: {a.size} values is not valid; expected {n} (one per DOF, in {unit})"
        )
    if not np.all(np.isfinite(a)):
        raise ModelError(f"{field_name}: contains NaN or infinity; expected finite values")
    return a


@dataclass(frozen=True)
class Model:
    """Structure + gaps + loads + initial state (``x(0)`` in m, ``x'(0)`` in m/s; rad and
    rad/s on the rotations, see :attr:`Structure.dof_units`)."""

    structure: Structure
    gaps: Sequence[Gap] = ()
    loads: Sequence[Load | UnbalanceLoad] = ()
    initial_displacement: ArrayLike | None = None
    initial_velocity: ArrayLike | None = None

    def __post_init__(self) -> None:
        require(
            isinstance(self.structure, Structure), "structure", self.structure, "a Structure"
        )
        n = self.structure.n_dof
        object.__setattr__(self, "gaps", tuple(self.gaps))
        object.__setattr__(self, "loads", tuple(self.loads))
        for i, g in enumerate(self.gaps):
            require(isinstance(g, Gap), f"gaps[{i}]", g, "a vibroimpact.Gap")
            bad = [d for d in g.dofs if d >= n]
            require(not bad, f"gaps[{i}].dof", bad[0] if bad else None, f"0 <= dof < {n}")
        for i, ld in enumerate(self.loads):
            require(isinstance(ld, (Load, UnbalanceLoad)), f"loads[{i}]", ld,
                    "a vibroimpact load")
            bad = [d for d in ld.dofs if d >= n]
            require(not bad, f"loads[{i}].dof", bad[0] if bad else None, f"0 <= dof < {n}")
        x0 = _initial(self.initial_displacement, n, "initial.displacement", "m")
        v0 = _initial(self.initial_velocity, n, "initial.velocity", "m/s")
        object.__setattr__(self, "initial_displacement", x0)
        object.__setattr__(self, "initial_velocity", v0)
        self._check_initial_state()

    def _check_initial_state(self) -> None:
        """The initial kinetic energy ``½ vᵀMv``, strain energy ``½ xᵀKx`` and the contact
        force of every gap at the penetration ``x(0)`` gives it must be finite doubles."""
        st = self.structure
        x0, v0 = self.initial_displacement, self.initial_velocity
        with np.errstate(all="ignore"):  # an overflow is an inf, refused here
            kinetic = float(v0 @ (st.mass @ v0)) if v0.any() else 0.0
            strain = float(x0 @ (st.stiffness @ x0)) if x0.any() else 0.0
        for name, state, energy, matrix, quantity, what in (
            ("initial.velocity", v0, kinetic, st.mass, "the kinetic energy 1/2 v^T M v",
             "a speed whose energy is finite (structure.mass up to {:g} kg)"),
            ("initial.displacement", x0, strain, st.stiffness, "the strain energy 1/2 x^T K x",
             "a displacement whose energy is finite (structure.stiffness up to {:g} N/m)"),
        ):
            if not math.isfinite(energy):
                raise not_finite(name, _shown(state), quantity, what.format(largest(matrix)))
        for g, gap in enumerate(self.gaps):
            if gap.law.impulsive:
                continue
            b = np.asarray(gap.coefficients, dtype=float)
            with np.errstate(over="ignore", invalid="ignore"):
                u, rate = float(b @ x0[list(gap.dofs)]), float(b @ v0[list(gap.dofs)])
            clearance = float(gap.clearance)
            with np.errstate(over="ignore", invalid="ignore"):
                walls = [gap.penetration(x0, v0)] if isinstance(gap, RadialGap) else [
                    (sign * u - clearance, sign * rate)
                    for sign in {"positive": (1,), "negative": (-1,), "both": (1, -1)}[gap.side]]
            for penetration, wall_rate in walls:
                if not penetration > 0:
                    continue
                # at rest first (the displacement's fault), then at the gap's speed
                for name, state, speed in (("initial.displacement", x0, 0.0),
                                           ("initial.velocity", v0, wall_rate)):
                    finite = math.isfinite(penetration) and math.isfinite(speed)
                    if finite and math.isfinite(
                            gap.law.force(penetration, speed, abs(speed) or 1.0)[0]):
                        continue
                    raise not_finite(
                        name, _shown(state), f"the contact force of gaps[{g}] "
                        f"({gap.law.kind}) at the initial penetration {penetration:g} m and "
                        f"speed {speed:g} m/s", "a state whose contact force is finite")

    @property
    def n_dof(self) -> int:
        return self.structure.n_dof

    @property
    def applied_loads(self) -> tuple[Load, ...]:
        """The loads as time functions: each :class:`UnbalanceLoad` as its two harmonic loads
        at the structure's spin speed (what the core applies at a constant speed; during a
        run-up at its fastest ``|Ω|``, the bound of its ``Ω²`` force the run's checks use)."""
        st = self.structure
        speed = st.spin_speed if st.spin_profile == "constant" else st.fastest_spin
        out: list[Load] = []
        for ld in self.loads:
            out += ld.harmonics(speed) if isinstance(ld, UnbalanceLoad) else [ld]
        return tuple(out)

    def gap_flexibility(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Per gap, with ``b`` its coefficients on the DOFs: ``b M⁻¹ bᵀ`` (the inverse of its
        effective mass) and ``b K⁻¹ bᵀ`` (its compliance; ``inf`` unless ``K`` is positive
        definite). Read-only arrays, computed once for a dense structure (its matrices are
        read-only) and at every call for a sparse one (SciPy leaves those writable)."""
        cached: tuple[NDArray[np.float64], NDArray[np.float64]] | None = self.__dict__.get(
            "_gap_flexibility")
        if cached is not None:
            return cached
        st, n_gaps = self.structure, len(self.gaps)
        b = np.zeros((self.n_dof, n_gaps))
        for g, gap in enumerate(self.gaps):
            for d, c in zip(gap.dofs, gap.coefficients or (1.0,) * len(gap.dofs), strict=True):
                b[d, g] += c
        with np.errstate(all="ignore"):  # absurd masses: infs, refused by contact_periods
            out = self._flexibility(b)
        for a in out:
            a.setflags(write=False)
        if not st.is_sparse:
            object.__setattr__(self, "_gap_flexibility", out)
        return out

    def _flexibility(self, b: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                           NDArray[np.float64]]:
        """:meth:`gap_flexibility` for the gaps' coefficient columns ``b``, computed."""
        st = self.structure
        mass = st.mass
        diagonal = mass.diagonal()
        nonzero = mass.count_nonzero() if sp.issparse(mass) else np.count_nonzero(mass)
        if nonzero == np.count_nonzero(diagonal):  # lumped: no solve
            flexibility = np.einsum("ig,ig->g", b, b / diagonal[:, None])
        else:
            solve_mass = spd_solver(mass)
            assert solve_mass is not None  # checked by Structure
            flexibility = np.einsum("ig,ig->g", b, solve_mass(b))
        compliance = np.full(b.shape[1], math.inf)
        if abs(st.stiffness).max() > 0 and (solve_stiffness := spd_solver(st.stiffness)):
            compliance = np.einsum("ig,ig->g", b, solve_stiffness(b))
        return flexibility, compliance

    def _core_spec(self) -> _core.ModelSpec:
        """The model as the core's typed ``ModelSpec`` (its structure, gaps, loads and
        initial state, read once; compiled at the first run). With a dense structure (nothing
        in the model can then change, as for :meth:`gap_flexibility`) it is made once and
        kept, so later runs reuse the compiled system; a sparse one is read at each call."""
        spec = self.__dict__.get("_core_model")
        if spec is None:
            spec = _core.ModelSpec(self.to_spec())
            if not self.structure.is_sparse:
                object.__setattr__(self, "_core_model", spec)
        return spec

    def _run_spec(self) -> dict[str, Any]:
        """The model's part of a run's spec for the core: :meth:`_core_spec` and the initial
        state (which may change: it is not kept)."""
        return {
            "model": self._core_spec(),
            "x0": np.asarray(self.initial_displacement, dtype=float),
            "v0": np.asarray(self.initial_velocity, dtype=float),
        }

    def __getstate__(self) -> dict[str, Any]:
        """Pickled and copied without the core's spec (:meth:`_core_spec`)."""
        return {k: v for k, v in self.__dict__.items() if k != "_core_model"}

    @classmethod
    def from_spec(cls, spec: dict[str, Any],
                  dof_units: Sequence[str] | None = None) -> Model:
        """The model of a :meth:`to_spec` dict (a gap's optional ``name`` kept): what a
        parameter path set in a spec (:func:`vibroimpact.sweeps.apply`) is as a model."""
        structure = Structure(spec["mass"], spec["stiffness"], spec["damping"],
                              dof_units=dof_units, gyroscopic=spec.get("gyroscopic"),
                              **{k: spec[k] for k in ("spin_speed", *SPIN_KEYS)
                                 if spec.get(k) is not None})
        gaps = []
        for i, g in enumerate(spec["gaps"]):
            kind = g["law"]["kind"]
            if kind in REMOVED_LAWS:
                raise ModelError(f"gaps[{i}].law.kind: {REMOVED_LAWS[kind]}")
            if kind not in LAWS:
                raise ModelError(f"gaps[{i}].law.kind: {kind!r} is not known to this "
                                 "vibroimpact version")
            law = LAWS[kind](**{k: v for k, v in g["law"].items()
                                if k != "kind" and v is not None})
            if g["side"] == "radial":
                regularised = g["friction_law"] == "regularised"
                gaps.append(RadialGap(
                    dof=g["dofs"], law=law, clearance=g["clearance"], center=g["center"],
                    friction=g["friction"], radius=g["radius"] or None,
                    friction_law=g["friction_law"],
                    regularisation_speed=g["regularisation_speed"] if regularised else None,
                    name=g.get("name")))
                continue
            gaps.append(Gap(dof=g["dofs"], coefficients=g["coefficients"],
                            clearance=g["clearance"], side=g["side"], law=law,
                            name=g.get("name")))
        loads: list[Load | UnbalanceLoad] = []
        for i, ld in enumerate(spec["loads"]):
            kind = ld["kind"]
            if kind == "unbalance":
                loads.append(UnbalanceLoad(dof=ld["dofs"], magnitude=ld["magnitude"],
                                           phase=ld["phase"]))
            elif kind == "constant":
                loads.append(ConstantLoad(dof=ld["dofs"], amplitude=ld["amplitude"]))
            elif kind == "harmonic":
                loads.append(HarmonicLoad(dof=ld["dofs"], amplitude=ld["amplitude"],
                                          frequency=ld["frequency"], phase=ld["phase"]))
            elif kind == "table":
                loads.append(TableLoad(dof=ld["dofs"], time=ld["time"], force=ld["value"],
                                       scale=ld["amplitude"]))
            else:
                raise ModelError(f"loads[{i}].kind: {kind!r} is not known to this "
                                 "vibroimpact version")
        return cls(structure, gaps=gaps, loads=loads, initial_displacement=spec["x0"],
                   initial_velocity=spec["v0"])

    def to_spec(self) -> dict[str, Any]:
        """Plain dict of arrays and numbers that the Rust core compiles."""
        s = self.structure
        return {
            "mass": s.mass,
            "damping": s.damping,
            "stiffness": s.stiffness,
            "gaps": [g.to_spec() for g in self.gaps],
            "loads": [ld.to_spec() for ld in self.loads],
            "gyroscopic": s.gyroscopic,
            "spin_speed": s.spin_speed,
            **{k: getattr(s, k) for k in SPIN_KEYS},
            "x0": np.asarray(self.initial_displacement, dtype=float),
            "v0": np.asarray(self.initial_velocity, dtype=float),
        }
