"""Mode shapes of the structure a result was computed on (its stored ``M`` and ``K``), from
:func:`vibroimpact.fe.modes`."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from vibroimpact.errors import ModelError

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes


def mode_shapes(
    ds: xr.Dataset,
    ax: Axes,
    *,
    label: str | None = None,
    n_modes: int = 4,
    include_rigid: bool = False,
    t_min: float | None = None,
    t_max: float | None = None,
    **style: Any,
) -> None:
    """The first ``n_modes`` elastic modes (and the rigid-body modes with
    ``include_rigid``) of ``K φ = ω² M φ``, each scaled to a largest component of 1 and drawn
    against the DOF index, one line per mode; the legend gives the frequencies. (For shapes
    along a beam, use :func:`vibroimpact.fe.modal.plot_mode_shapes` with the beam.)"""
    from vibroimpact.fe import modes

    if "structure_mass" not in ds or "structure_stiffness" not in ds:
        raise ModelError("mode-shapes: the result holds no model; expected a result written "
                         "by vibroimpact with its structure matrices")
    from vibroimpact.io.results_file import structure_matrix

    m = modes((structure_matrix(ds, "structure_mass"), structure_matrix(ds, "structure_stiffness")),
              int(n_modes))
    first = 0 if include_rigid else m.rigid_body_modes
    last = min(m.shapes.shape[1], m.rigid_body_modes + int(n_modes))
    prefix = "" if label is None else f"{label}: "
    for j in range(first, last):
        phi = m.shapes[:, j]
        scale = float(np.abs(phi).max()) or 1.0
        kind = "rigid" if j < m.rigid_body_modes else f"{m.frequencies_hz[j]:.1f} Hz"
        ax.plot(np.arange(len(phi)), phi / scale, marker=".",
                label=f"{prefix}mode {j + 1}: {kind}", **style)
    ax.set_xlabel("DOF index [-]")
    ax.set_ylabel("mode shape, largest component 1 [-]")
