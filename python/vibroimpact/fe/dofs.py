"""DOF maps and sparse finite-element structures: which ``(node, direction)`` each row of
``M, C, K`` belongs to, so that gaps and loads are placed at node/direction pairs.

Directions are named ``"x", "y", "z"`` (translations, m) and ``"rx", "ry", "rz"`` (rotations
about those axes, rad); the integer DOF numbers of ABAQUS and CalculiX (1–6 in that order) are
accepted wherever a direction is. Other DOF numbers (CalculiX 0 = temperature, ABAQUS 7 =
warping, 8 = pressure, ...) are kept as their number written as a string (``"8"``).

Example::

    >>> import numpy as np
    >>> from vibroimpact.fe import DofMap, FEStructure
    >>> fe = FEStructure(np.eye(2), [[2.0, -1.0], [-1.0, 1.0]],
    ...                  dof_map=DofMap([1, 2], ["x", "x"]))
    >>> fe.dof(node=2, direction=1)
    1
"""

from __future__ import annotations

import csv
import os
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from vibroimpact.contact import ContactLaw
from vibroimpact.errors import ModelError
from vibroimpact.model import Gap, Model, Structure, check_dof_units

if TYPE_CHECKING:
    from vibroimpact.fe.condensation import StaticCondensation
    from vibroimpact.fe.damping import Damping
    from vibroimpact.model import Load

__all__ = [
    "DIRECTIONS",
    "ROTATIONS",
    "DofMap",
    "FEStructure",
    "as_sparse",
    "direction_name",
]

#: Direction names in the order of the ABAQUS/CalculiX DOF numbers 1–6.
DIRECTIONS: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz")
#: The rotations among :data:`DIRECTIONS` (unit rad).
ROTATIONS: tuple[str, ...] = DIRECTIONS[3:]

def direction_name(direction: str | int) -> str:
    """Canonical name of a direction: ``"x"``…``"rz"`` or the ABAQUS/CalculiX number 1–6 of
    one (``3 -> "z"``, ``"5" -> "ry"``); other integers are kept as strings."""
    if isinstance(direction, (int, np.integer)) and not isinstance(direction, bool):
        d = int(direction)
        return DIRECTIONS[d - 1] if 1 <= d <= 6 else str(d)
    if isinstance(direction, str):
        s = direction.strip().lower()
        if s in DIRECTIONS:
            return s
        if s.lstrip("-").isdigit():
            return direction_name(int(s))
    raise ModelError(
        f"direction: {direction!r} is not valid; expected one of "
        f"{', '.join(DIRECTIONS)} (or the DOF numbers 1-6)"
    )


@dataclass(frozen=True)
class DofMap:
    """The ``(node, direction)`` of every DOF (row of ``M, C, K``), in DOF order.

    ``nodes``: node label per DOF (an integer: the beam's node index, or the node number of
    the FE program); ``directions``: direction per DOF (:func:`direction_name`); ``layers``:
    per DOF 0, or the layer ``1, 2, ...`` of a node/direction that has several DOFs (CalculiX
    expands a shell node into two or three node layers through the thickness and its
    ``job.dof`` gives each the shell node's label: the layers are numbered in file order).
    A pair with layers is addressed by DOF index (:meth:`layer_dofs` lists them).
    """

    nodes: tuple[int, ...]
    directions: tuple[str, ...]
    layers: tuple[int, ...]
    _index: dict[tuple[int, str], int] = field(init=False, repr=False, compare=False)
    _layered: dict[tuple[int, str], list[int]] = field(init=False, repr=False, compare=False)

    def __init__(
        self,
        nodes: Iterable[int],
        directions: Iterable[str | int],
        layers: Iterable[int] | None = None,
    ) -> None:
        n = tuple(int(x) for x in nodes)
        d = tuple(direction_name(x) for x in directions)
        if len(n) != len(d):
            raise ModelError(
                f"dof_map: {len(n)} nodes and {len(d)} directions; expected one of each per DOF"
            )
        lay = tuple(int(x) for x in layers) if layers is not None else (0,) * len(n)
        if len(lay) != len(n):
            raise ModelError(
                f"dof_map: {len(lay)} layers for {len(n)} DOFs; expected one layer per DOF"
            )
        index: dict[tuple[int, str], int] = {}
        layered: dict[tuple[int, str], list[int]] = {}
        seen: dict[tuple[int, str, int], int] = {}
        for i, key in enumerate(zip(n, d, strict=True)):
            full = (*key, lay[i])
            if full in seen:
                first = seen[full]
                layer = f" layer {lay[i]}" if lay[i] else ""
                raise ModelError(
                    f"dof_map: node {key[0]} direction {key[1]!r}{layer} appears twice (DOFs "
                    f"{first} and {i}); expected each node/direction once"
                )
            seen[full] = i
            if lay[i]:
                layered.setdefault(key, []).append(i)
            else:
                index[key] = i
        both = sorted(set(index) & set(layered))
        if both:
            raise ModelError(
                f"dof_map: node {both[0][0]} direction {both[0][1]!r} has a DOF with and one "
                "without a layer; expected layers on all of its DOFs or on none"
            )
        object.__setattr__(self, "nodes", n)
        object.__setattr__(self, "directions", d)
        object.__setattr__(self, "layers", lay)
        object.__setattr__(self, "_index", index)
        object.__setattr__(self, "_layered", layered)

    @classmethod
    def numbered_layers(cls, nodes: Sequence[int], directions: Sequence[str | int]) -> DofMap:
        """A map in which a node/direction that occurs more than once gets layers 1, 2, ...
        in order of occurrence (CalculiX's ``job.dof`` of expanded shells); one that occurs
        once gets layer 0."""
        keys = [(int(x), direction_name(y)) for x, y in zip(nodes, directions, strict=True)]
        counts = Counter(keys)
        seen: Counter[tuple[int, str]] = Counter()
        layers = []
        for key in keys:
            seen[key] += 1
            layers.append(seen[key] if counts[key] > 1 else 0)
        return cls(nodes, directions, layers)

    def __len__(self) -> int:
        return len(self.nodes)

    @property
    def node_labels(self) -> list[int]:
        """The distinct node labels, in order of first appearance."""
        return list(dict.fromkeys(self.nodes))

    def layer_dofs(self, node: int, direction: str | int) -> list[int]:
        """The DOF indices of the layers of ``(node, direction)`` (empty if it has none)."""
        return list(self._layered.get((int(node), direction_name(direction)), []))

    def shell_weights(self, node: int, direction: str | int) -> tuple[list[int], list[float]]:
        """The DOFs and weights that make the shell node's displacement in ``direction`` from
        its layers: CalculiX's mean through the thickness (its ``map3dto1d2d``, which gives
        the shell node's results): ``1/6, 2/3, 1/6`` over the three layers of a corner node
        (Simpson's rule on the quadratic field), ``1/2, 1/2`` over the two of a midside node
        (a linear one); ``([index], [1.0])`` for a pair without layers. As a gap's
        coefficients they make the gap act on the shell node."""
        return self._layer_weights(node, direction, {2: [0.5, 0.5], 3: [1 / 6, 2 / 3, 1 / 6]})

    def shell_load_weights(self, node: int, direction: str | int
                           ) -> tuple[list[int], list[float]]:
        """The DOFs and weights over which CalculiX spreads a force on the shell node (its
        ``gen3dforc``: the loaded node is tied to its layers by ``2u = u₁ + u₃`` at a midside
        node and ``2u = −u₁ + 4u₂ − u₃`` at a corner node, so a force ``F`` on it does work
        on them as ``F/2, F/2`` and ``−F/2, 2F, −F/2``); ``([index], [1.0])`` for a pair
        without layers."""
        return self._layer_weights(node, direction, {2: [0.5, 0.5], 3: [-0.5, 2.0, -0.5]})

    def _layer_weights(self, node: int, direction: str | int,
                       table: dict[int, list[float]]) -> tuple[list[int], list[float]]:
        layered = self.layer_dofs(node, direction)
        if not layered:
            return [self.index(node, direction)], [1.0]
        weights = table.get(len(layered))
        if weights is None:
            raise ModelError(
                f"node: {node!r} is not valid with direction {direction_name(direction)!r}; "
                f"expected 2 or 3 layers through the thickness (CalculiX's expanded shell), "
                f"not {len(layered)} (DOFs {', '.join(map(str, layered))})"
            )
        return layered, weights

    def index(self, node: int, direction: str | int) -> int:
        """The DOF index of ``(node, direction)``; a :class:`ModelError` names what exists."""
        d = direction_name(direction)
        try:
            return self._index[(int(node), d)]
        except (KeyError, TypeError, ValueError):
            pass
        layered = self._layered.get((node, d))
        if layered:
            raise ModelError(
                f"node: {node!r} is not valid with direction {d!r} alone; expected a DOF "
                f"index (its {len(layered)} layers through the thickness, as CalculiX expanded "
                f"the shell node, are DOFs {', '.join(map(str, layered))})"
            )
        have = sorted({dd for (nn, dd) in (*self._index, *self._layered) if nn == node},
                      key=_direction_order)
        if have:
            raise ModelError(
                f"direction: {direction!r} is not valid at node {node}; expected one of "
                f"{', '.join(have)} (the other DOFs are constrained or absent)"
            )
        labels = self.node_labels
        shown = f"{labels[0]} .. {labels[-1]}" if labels else "none"
        raise ModelError(
            f"node: {node!r} is not valid; expected a node of the model (labels {shown}, "
            f"{len(labels)} nodes)"
        )

    def indices(self, nodes: Iterable[int], direction: str | int) -> list[int]:
        """The DOF indices of ``direction`` at each of ``nodes``."""
        return [self.index(n, direction) for n in nodes]

    def all_dofs(self, nodes: Iterable[int], directions: Iterable[str | int]) -> list[int]:
        """Every DOF of ``directions`` at ``nodes``, layers included (node by node, in the
        order given); a :class:`ModelError` if a pair has no DOF."""
        out: list[int] = []
        for node in nodes:
            for direction in directions:
                layered = self.layer_dofs(node, direction)
                out += layered or [self.index(node, direction)]
        return out

    def take(self, dofs: Sequence[int]) -> DofMap:
        """The map of the DOFs ``dofs`` (in that order), e.g. after a reduction."""
        return DofMap([self.nodes[i] for i in dofs], [self.directions[i] for i in dofs],
                      [self.layers[i] for i in dofs])

    def units(self) -> tuple[str, ...]:
        """The unit of each DOF's displacement: ``"rad"`` for the rotations ``rx, ry, rz``
        (ABAQUS/CalculiX 4–6), ``"m"`` for the others (:attr:`vibroimpact.Structure.dof_units`)."""
        return tuple("rad" if d in ROTATIONS else "m" for d in self.directions)

    def labels(self) -> list[str]:
        """``"node.direction"`` per DOF (``"12.x"``; a layer as ``"12.x@2"``)."""
        return [f"{n}.{d}" + (f"@{k}" if k else "")
                for n, d, k in zip(self.nodes, self.directions, self.layers, strict=True)]

    def write_csv(self, path: str | os.PathLike[str]) -> None:
        """Write ``dof,node,direction`` rows (DOF index from 0; a ``layer`` column too if any
        DOF has a layer)."""
        with_layers = any(self.layers)
        with open(path, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(["dof", "node", "direction", *(["layer"] if with_layers else [])])
            for i, (n, d, k) in enumerate(zip(self.nodes, self.directions, self.layers,
                                              strict=True)):
                w.writerow([i, n, d, *([k] if with_layers else [])])

    @classmethod
    def read_csv(cls, path: str | os.PathLike[str]) -> DofMap:
        """Read a map written by :meth:`write_csv` (rows in DOF order)."""
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        try:
            rows.sort(key=lambda r: int(r["dof"]))
            layers = [int(r["layer"]) for r in rows] if rows and "layer" in rows[0] else None
            return cls([int(r["node"]) for r in rows], [r["direction"] for r in rows], layers)
        except (KeyError, ValueError, TypeError):
            raise ModelError(
                f"dof_map: {str(path)!r} is not valid; expected CSV rows dof,node,direction"
            ) from None


def _direction_order(d: str) -> tuple[int, str]:
    return (DIRECTIONS.index(d) if d in DIRECTIONS else 99, d)


def as_sparse(value: Any, name: str, n: int | None = None) -> sp.csr_array:
    """``value`` (dense array, nested lists or any scipy.sparse matrix) as a symmetric, finite,
    square CSR array; ``name`` labels the error messages."""
    if sp.issparse(value):
        a = sp.csr_array(value, dtype=float)
    else:
        try:
            dense = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{name}: not a numeric matrix; expected an n x n array") from None
        if dense.ndim == 0:
            dense = dense.reshape(1, 1)
        if dense.ndim != 2:
            raise ModelError(f"{name}: shape {dense.shape} is not valid; expected a square matrix")
        a = sp.csr_array(dense)
    if a.shape[0] != a.shape[1] or a.shape[0] == 0:
        raise ModelError(f"{name}: shape {a.shape} is not valid; expected a square matrix")
    if n is not None and a.shape[0] != n:
        raise ModelError(f"{name}: shape {a.shape} does not match; expected ({n}, {n})")
    a.sum_duplicates()
    a.eliminate_zeros()
    if not np.all(np.isfinite(a.data)):
        raise ModelError(f"{name}: contains NaN or infinity; expected finite values")
    scale = float(np.abs(a.data).max()) if a.nnz else 0.0
    diff = a - a.T
    asym = float(np.abs(diff.data).max()) if diff.nnz else 0.0
    if asym > 1e-9 * max(scale, np.finfo(float).tiny):
        raise ModelError(
            f"{name}: not symmetric (max |A - A^T| = {asym:.3e}); expected a symmetric matrix"
        )
    return a


@dataclass(frozen=True)
class FEStructure:
    """A linear structure kept sparse (``M`` kg, ``C`` N·s/m, ``K`` N/m as CSR arrays) with an
    optional :class:`DofMap`. Build the (sparse) :class:`~vibroimpact.Structure` the core runs
    with :meth:`to_structure`, or reduce it first (:func:`vibroimpact.fe.craig_bampton`).
    ``declared_units``: each DOF's unit ("m" or "rad") for a structure without a DOF map
    (a map's directions give them). A rotor: ``gyroscopic`` ``G`` (kg·m², skew-symmetric) and
    ``spin_speed`` Ω (rad/s), as on :class:`~vibroimpact.Structure`."""

    mass: sp.csr_array
    stiffness: sp.csr_array
    damping: sp.csr_array | None = None
    dof_map: DofMap | None = None
    declared_units: tuple[str, ...] | None = None
    gyroscopic: sp.csr_array | None = None
    spin_speed: float = 0.0

    def __init__(
        self,
        mass: Any,
        stiffness: Any,
        damping: Any = None,
        dof_map: DofMap | None = None,
        declared_units: Sequence[str] | None = None,
        *,
        gyroscopic: Any = None,
        spin_speed: float = 0.0,
    ) -> None:
        m = as_sparse(mass, "structure.mass")
        n = m.shape[0]
        k = as_sparse(stiffness, "structure.stiffness", n)
        c = None if damping is None else as_sparse(damping, "structure.damping", n)
        g = None if gyroscopic is None else sp.csr_array(gyroscopic, dtype=float)
        if g is not None and g.shape != (n, n):
            raise ModelError(f"structure.gyroscopic: shape {g.shape} does not match; expected "
                             f"({n}, {n})")
        object.__setattr__(self, "gyroscopic", g)
        object.__setattr__(self, "spin_speed", spin_speed)
        if dof_map is not None and len(dof_map) != n:
            raise ModelError(
                f"dof_map: {len(dof_map)} DOFs is not valid; expected {n} (one per matrix row)"
            )
        # a zero diagonal entry is a massless DOF (condense_massless) only if its row is zero
        diag = m.diagonal()
        row_nnz = np.diff(m.indptr)
        bad_rows = np.flatnonzero((diag < 0) | ((diag == 0) & (row_nnz > 0)))
        if len(bad_rows):
            bad = int(bad_rows[0])
            raise ModelError(
                f"structure.mass: diagonal entry {bad} is {float(diag[bad])!r}; expected > 0, "
                "or 0 with the whole row zero (a massless DOF)"
            )
        object.__setattr__(self, "mass", m)
        object.__setattr__(self, "stiffness", k)
        object.__setattr__(self, "damping", c)
        object.__setattr__(self, "dof_map", dof_map)
        if declared_units is not None:
            if dof_map is not None:
                raise ModelError(
                    "structure.dof_units: given with a DOF map; expected one of them (the map's "
                    "directions give each DOF's unit)"
                )
            declared_units = check_dof_units(declared_units, n)
        object.__setattr__(self, "declared_units", declared_units)

    @property
    def n_dof(self) -> int:
        return int(self.mass.shape[0])

    @property
    def dof_units(self) -> tuple[str, ...]:
        """The unit of each DOF (:meth:`DofMap.units`; else the declared units, or ``"m"`` for
        all)."""
        if self.dof_map is not None:
            return self.dof_map.units()
        return self.declared_units or ("m",) * self.n_dof

    def with_damping(self, damping: Damping | Any) -> FEStructure:
        """A copy with damping ``C``: a :class:`~vibroimpact.fe.Rayleigh` or
        :class:`~vibroimpact.fe.ModalDamping` rule, or a matrix."""
        from vibroimpact.fe.damping import Damping

        c = damping.matrix(self.mass, self.stiffness) if isinstance(damping, Damping) else damping
        return FEStructure(self.mass, self.stiffness, c, self.dof_map, self.declared_units,
                           gyroscopic=self.gyroscopic, spin_speed=self.spin_speed)

    @property
    def massless_dofs(self) -> list[int]:
        """The DOFs without mass (zero rows of ``M``)."""
        from vibroimpact.fe.condensation import massless_dofs

        return massless_dofs(self.mass).tolist()

    @property
    def singular_mass(self) -> bool:
        """Whether ``M`` is singular: massless DOFs (zero rows), or ``M`` on the other DOFs
        not definite (to :data:`~vibroimpact.fe.condensation.NULL_SPACE_RTOL`: reduced
        integration, expanded shells); :meth:`condense_massless` removes either."""
        from vibroimpact.fe.condensation import NULL_SPACE_RTOL
        from vibroimpact.model import spd_solver

        if self.massless_dofs:
            return True
        return spd_solver(self.mass, NULL_SPACE_RTOL) is None

    def condense_massless(self, keep: Iterable[int] = ()) -> StaticCondensation:
        """Static (Guyan) condensation of the massless DOFs, or of the whole null space of a
        singular ``M``; ``keep``: DOFs that must stay (see
        :func:`vibroimpact.fe.condensation.condense_massless`)."""
        from vibroimpact.fe.condensation import condense_massless

        return condense_massless(self, keep)

    def to_structure(self) -> Structure:
        """The :class:`~vibroimpact.Structure` that the core integrates, with these sparse
        (CSR) matrices: nothing is densified."""
        massless = self.massless_dofs
        if massless:
            raise ModelError(
                f"structure.mass: {len(massless)} massless DOFs (first: {massless[0]}); expected "
                "every DOF to carry mass (condense them with FEStructure.condense_massless())"
            )
        if self.singular_mass:
            raise ModelError(
                "structure.mass: singular (massless modes without zero rows, e.g. reduced "
                "integration); expected a positive definite mass (condense its null space "
                "with FEStructure.condense_massless())"
            )
        return Structure(self.mass, self.stiffness, self.damping, self.dof_units,
                         gyroscopic=self.gyroscopic, spin_speed=self.spin_speed,
                         dof_map=self.dof_map)

    # ---- addressing by node and direction ----

    def _map(self) -> DofMap:
        if self.dof_map is None:
            raise ModelError(
                "dof_map: missing; expected a DofMap to address DOFs by node and direction"
            )
        return self.dof_map

    def dof(self, node: int, direction: str | int) -> int:
        """The DOF index of ``direction`` at ``node``."""
        return self._map().index(node, direction)

    def dofs(self, nodes: Iterable[int] | str, direction: str | int) -> list[int]:
        """The DOF indices of ``direction`` at each of ``nodes`` (``"all"``: every node that
        has that direction)."""
        m = self._map()
        if isinstance(nodes, str):
            if nodes != "all":
                raise ModelError(f"nodes: {nodes!r} is not valid; expected 'all' or a list")
            d = direction_name(direction)
            return [i for i, dd in enumerate(m.directions) if dd == d]
        return m.indices(nodes, direction)

    def gap(
        self,
        law: ContactLaw,
        *,
        node: int,
        direction: str | int,
        clearance: float = 0.0,
        side: str = "both",
        name: str | None = None,
    ) -> Gap:
        """A :class:`~vibroimpact.Gap` on the DOF ``(node, direction)``."""
        return Gap(
            dof=self.dof(node, direction),
            law=law,
            clearance=clearance,
            side=side,  # type: ignore[arg-type]
            name=name or f"{node}.{direction_name(direction)}",
        )

    def model(
        self,
        gaps: Sequence[Gap] = (),
        loads: Sequence[Load] = (),
        initial_displacement: ArrayLike | None = None,
        initial_velocity: ArrayLike | None = None,
    ) -> Model:
        """A :class:`~vibroimpact.Model` of this structure (sparse, see :meth:`to_structure`)."""
        return Model(
            self.to_structure(),
            gaps=gaps,
            loads=loads,
            initial_displacement=initial_displacement,
            initial_velocity=initial_velocity,
        )

