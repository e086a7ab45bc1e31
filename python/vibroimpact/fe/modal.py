"""Natural frequencies and mode shapes of ``K φ = ω² M φ`` (paper §3.2, Table 4).

Small models (or ``method="dense"``) use LAPACK's symmetric-definite solver
(:func:`scipy.linalg.eigh`); large sparse models use ARPACK in shift-invert mode
(:func:`scipy.sparse.linalg.eigsh`) about a small negative shift ``σ``, so that ``K − σM`` is
positive definite even for free–free structures whose ``K`` is singular. Rigid-body modes are
those with ``ω² <= tol · max_i(K_ii / M_ii)`` (``tol = 1e-11``: ``max K_ii/M_ii`` bounds the
largest eigenvalue from below, and the round-off of a zero eigenvalue is about
``n · ε · λ_max``); their frequencies are reported as 0.

Example::

    >>> from vibroimpact.fe import Beam, Material, Section, modes
    >>> steel = Material(youngs_modulus=207e9, poisson=0.3, density=7850.0)
    >>> beam = Beam(length=1.0, elements=20, section=Section.circle(0.02), material=steel,
    ...             theory="euler-bernoulli")
    >>> m = modes(beam, 3)
    >>> m.rigid_body_modes, len(m.elastic_frequencies_hz)
    (2, 3)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from vibroimpact.errors import ModelError
from vibroimpact.fe.dofs import DofMap, FEStructure, direction_name
from vibroimpact.model import Model, Structure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from vibroimpact.fe.beam import Beam

__all__ = [
    "Modes",
    "highest_angular_frequency",
    "modes",
    "plot_mode_shapes",
    "rigid_body_threshold",
]

#: Models with at most this many DOFs are solved densely by ``method="auto"``.
DENSE_MODAL_LIMIT = 600

#: Relative tolerance of the rigid-body test (see the module docstring).
RIGID_BODY_RTOL = 1e-11


def _diag(a: Any) -> NDArray[np.float64]:
    return np.asarray(a.diagonal() if sp.issparse(a) else np.diag(a), dtype=float)


def rigid_body_threshold(stiffness: Any, mass: Any, rtol: float = RIGID_BODY_RTOL) -> float:
    """Eigenvalues ``ω²`` (rad²/s²) at or below this are rigid-body modes."""
    k, m = _diag(stiffness), _diag(mass)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(m > 0, np.abs(k) / m, 0.0)
    scale = float(ratio.max()) if ratio.size else 0.0
    return rtol * scale if scale > 0 else 0.0


@dataclass(frozen=True)
class Modes:
    """Modes in ascending order: ``eigenvalues`` ω² (rad²/s²), mass-normalised ``shapes``
    (one column per mode, ``φᵀMφ = 1``), the number of ``rigid_body_modes`` (the first ones)
    and the structure's :class:`~vibroimpact.fe.DofMap` if it has one."""

    eigenvalues: NDArray[np.float64]
    shapes: NDArray[np.float64]
    rigid_body_modes: int
    dof_map: DofMap | None = None

    @property
    def angular_frequencies(self) -> NDArray[np.float64]:
        """ω in rad/s (0 for the rigid-body modes)."""
        w = np.sqrt(np.clip(self.eigenvalues, 0.0, None))
        w[: self.rigid_body_modes] = 0.0
        return w

    @property
    def frequencies_hz(self) -> NDArray[np.float64]:
        """f = ω/2π in Hz, rigid-body modes (0 Hz) first."""
        return self.angular_frequencies / (2 * math.pi)

    @property
    def elastic_frequencies_hz(self) -> NDArray[np.float64]:
        """The frequencies of the elastic modes, Hz."""
        return self.frequencies_hz[self.rigid_body_modes :]

    @property
    def elastic_shapes(self) -> NDArray[np.float64]:
        return self.shapes[:, self.rigid_body_modes :]

    def to_records(self) -> list[dict[str, Any]]:
        """One row per mode: ``mode`` (from 1), ``kind`` (rigid/elastic), ``frequency_hz``,
        ``angular_frequency_rad_s``."""
        f, w = self.frequencies_hz, self.angular_frequencies
        return [
            {
                "mode": i + 1,
                "kind": "rigid" if i < self.rigid_body_modes else "elastic",
                "frequency_hz": float(f[i]),
                "angular_frequency_rad_s": float(w[i]),
            }
            for i in range(len(f))
        ]


def _matrices(structure: Any) -> tuple[Any, Any, DofMap | None]:
    from vibroimpact.fe.beam import Beam

    if isinstance(structure, Beam):
        return structure.fe.stiffness, structure.fe.mass, structure.dof_map
    if isinstance(structure, FEStructure):
        return structure.stiffness, structure.mass, structure.dof_map
    if isinstance(structure, Model):
        structure = structure.structure
    if isinstance(structure, Structure):
        return structure.stiffness, structure.mass, None
    if isinstance(structure, tuple) and len(structure) == 2:
        m, k = structure
        return k, m, None
    raise ModelError(
        f"structure: {type(structure).__name__} is not valid; expected a Structure, Model, "
        "FEStructure, Beam or a (mass, stiffness) pair"
    )


def modes(
    structure: Any,
    n_modes: int = 10,
    *,
    method: Literal["auto", "dense", "sparse"] = "auto",
    rigid_body_modes: int | None = None,
    shift: float | None = None,
) -> Modes:
    """The rigid-body modes and the first ``n_modes`` elastic modes of ``structure``
    (a :class:`~vibroimpact.Structure`, :class:`~vibroimpact.Model`,
    :class:`~vibroimpact.fe.FEStructure`, :class:`~vibroimpact.fe.Beam` or ``(M, K)``).

    ``method``: ``"dense"`` (:func:`scipy.linalg.eigh`), ``"sparse"`` (ARPACK shift-invert
    about ``-shift`` rad²/s²) or ``"auto"`` (dense up to :data:`DENSE_MODAL_LIMIT` DOFs).
    ``rigid_body_modes``: the number of rigid-body modes if known (otherwise detected).

    An :class:`~vibroimpact.fe.FEStructure` with a singular mass (massless DOFs, or any null
    space of ``M``) is condensed first (:meth:`~vibroimpact.fe.FEStructure.condense_massless`,
    exact for the finite eigenvalues: the massless rows read ``Zᵀ K φ = 0``) and its shapes are
    expanded back to every DOF (``φ = T φ_r``).
    """
    if isinstance(structure, FEStructure) and structure.singular_mass:
        c = structure.condense_massless()
        md = modes(c.structure, n_modes, method=method, rigid_body_modes=rigid_body_modes,
                   shift=shift)
        shapes = np.asarray(c.transform @ md.shapes)
        return Modes(md.eigenvalues, shapes, md.rigid_body_modes, structure.dof_map)
    k, m, dof_map = _matrices(structure)
    n = int(m.shape[0])
    if not (isinstance(n_modes, int) and not isinstance(n_modes, bool) and n_modes >= 1):
        raise ModelError(f"modes: {n_modes!r} is not valid; expected an integer >= 1")
    if method not in ("auto", "dense", "sparse"):
        raise ModelError(f"method: {method!r} is not valid; expected auto, dense or sparse")
    dense = method == "dense" or (method == "auto" and n <= DENSE_MODAL_LIMIT)
    threshold = rigid_body_threshold(k, m)
    extra = 6 if rigid_body_modes is None else int(rigid_body_modes)
    count = min(n, n_modes + extra)
    while True:
        if dense or count >= n - 1:
            lam, phi = _dense(k, m, count)
        else:
            lam, phi = _sparse(k, m, count, shift)
        n_rigid = (
            int(np.count_nonzero(lam <= threshold))
            if rigid_body_modes is None
            else min(int(rigid_body_modes), len(lam))
        )
        if len(lam) - n_rigid >= n_modes or count >= n:
            break
        count = min(n, count + max(6, n_modes))
    keep = min(len(lam), n_rigid + n_modes)
    lam, phi = lam[:keep], phi[:, :keep]
    return Modes(eigenvalues=lam, shapes=phi, rigid_body_modes=n_rigid, dof_map=dof_map)


def highest_angular_frequency(structure: Any) -> float:
    """The largest natural angular frequency ω (rad/s) of ``structure`` (as for
    :func:`modes`; an :class:`~vibroimpact.fe.FEStructure`'s massless DOFs condensed first),
    0 if no eigenvalue ``ω²`` is positive: LAPACK's largest eigenvalue up to
    :data:`DENSE_MODAL_LIMIT` DOFs, else ARPACK's (:func:`scipy.sparse.linalg.eigsh`,
    ``which="LA"``)."""
    if isinstance(structure, FEStructure) and structure.singular_mass:
        return highest_angular_frequency(structure.condense_massless().structure)
    k, m, _ = _matrices(structure)
    n = int(m.shape[0])
    if n <= DENSE_MODAL_LIMIT:
        kd = k.toarray() if sp.issparse(k) else np.asarray(k, dtype=float)
        md = m.toarray() if sp.issparse(m) else np.asarray(m, dtype=float)
        lam = float(scipy.linalg.eigh(kd, md, eigvals_only=True,
                                      subset_by_index=[n - 1, n - 1])[0])
    else:
        lam = float(spla.eigsh(sp.csc_array(k), k=1, M=sp.csc_array(m), which="LA",
                               return_eigenvectors=False, tol=1e-8)[0])
    return math.sqrt(lam) if lam > 0 else 0.0


def _dense(k: Any, m: Any, count: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    kd = k.toarray() if sp.issparse(k) else np.asarray(k, dtype=float)
    md = m.toarray() if sp.issparse(m) else np.asarray(m, dtype=float)
    try:
        lam, phi = scipy.linalg.eigh(kd, md, subset_by_index=[0, count - 1])
    except np.linalg.LinAlgError:
        raise ModelError(
            "structure.mass: not positive definite; expected every DOF to carry mass"
        ) from None
    return lam, phi


def _sparse(
    k: Any, m: Any, count: int, shift: float | None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    ks, ms = sp.csc_array(k), sp.csc_array(m)
    if shift is None:
        # a shift well below the first elastic eigenvalue keeps K + shift·M definite
        kd, md = _diag(ks), _diag(ms)
        shift = 1e-6 * float(np.median(np.abs(kd) / md)) or 1.0
    try:
        lam, phi = spla.eigsh(ks, k=count, M=ms, sigma=-float(shift), which="LM")
    except (RuntimeError, spla.ArpackError) as e:
        raise ModelError(f"modes: the sparse eigensolver failed ({e}); try method='dense'") from e
    order = np.argsort(lam)
    lam, phi = lam[order], phi[:, order]
    # mass-normalise (ARPACK returns M-orthogonal vectors up to round-off)
    norms = np.sqrt(np.einsum("ij,ij->j", phi, ms @ phi))
    return lam, phi / norms


def plot_mode_shapes(
    mode_set: Modes,
    beam: Beam | None = None,
    *,
    n_modes: int = 4,
    direction: str = "x",
    include_rigid: bool = False,
    ax: Any = None,
) -> Figure:
    """Plot mode shapes (matplotlib). With a :class:`~vibroimpact.fe.Beam`, the ``direction``
    component of each shape along the beam (position in m, constrained nodes at 0); otherwise
    the component of each DOF in ``direction`` (or every DOF) against its index. Shapes are
    scaled to a largest component of 1; the legend gives the frequencies in Hz."""

    if ax is None:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
    else:
        fig = ax.figure
    first = 0 if include_rigid else mode_set.rigid_body_modes
    idx = range(first, min(first + n_modes, mode_set.shapes.shape[1]))
    d = direction_name(direction)
    for j in idx:
        phi = mode_set.shapes[:, j]
        if beam is not None:
            x, y = beam.node_positions, beam.node_values(phi, d)
            xlabel = "position along the beam [m]"
        elif mode_set.dof_map is not None:
            sel = [i for i, dd in enumerate(mode_set.dof_map.directions) if dd == d]
            x, y = np.arange(len(sel)), phi[sel]
            xlabel = f"DOF in direction {d} (order of the DOF map)"
        else:
            x, y = np.arange(len(phi)), phi
            xlabel = "DOF index"
        scale = float(np.abs(y).max()) or 1.0
        f = mode_set.frequencies_hz[j]
        ax.plot(x, y / scale, marker=".", label=f"mode {j + 1}: {f:.1f} Hz")
    ax.set_xlabel(xlabel if idx else "DOF index")
    ax.set_ylabel(f"normalised displacement {d} [-]")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.legend(loc="best", fontsize="small")
    ax.set_title("mode shapes")
    return fig
