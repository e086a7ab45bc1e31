"""What the plots need from a result, whatever it came as (a :class:`~vibroimpact.Result`, an
``xarray.Dataset`` or a result file), and the selections they share."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Union

import numpy as np
from numpy.typing import NDArray

from vibroimpact.errors import ModelError
from vibroimpact.model import spec_load_frequency

if TYPE_CHECKING:
    import xarray as xr

    from vibroimpact.result import Result

#: What a plot accepts as its data.
Source = Union["Result", "xr.Dataset", str, os.PathLike]

Array = NDArray[np.float64]


def dataset(source: Source) -> xr.Dataset:
    """The Dataset of a Result, a Dataset, or a result file path."""
    import xarray as xr

    from vibroimpact.io import results_file

    if isinstance(source, xr.Dataset):
        return source
    if isinstance(source, (str, os.PathLike)):
        return results_file.load(source)
    return results_file.to_dataset(source)


def time_mask(ds: xr.Dataset, t_min: float | None, t_max: float | None) -> NDArray[np.bool_]:
    t = ds["time"].values
    mask = np.ones(t.shape, dtype=bool)
    if t_min is not None:
        mask &= t >= t_min
    if t_max is not None:
        mask &= t <= t_max
    return mask


def select(ds: xr.Dataset, dim: str, wanted: Sequence[int] | int | None) -> list[tuple[int, int]]:
    """``(position, label)`` of the wanted ``dof``/``gap`` labels (default: all)."""
    labels = [int(v) for v in ds[dim].values] if dim in ds.coords else []
    if wanted is None:
        return list(enumerate(labels))
    wanted = [wanted] if isinstance(wanted, (int, np.integer)) else list(wanted)
    out = []
    for w in wanted:
        if int(w) not in labels:
            raise ModelError(f"--{dim}: {w!r} is not valid; expected one of the recorded "
                             f"{dim}s {labels}")
        out.append((labels.index(int(w)), int(w)))
    return out


def model_spec(ds: xr.Dataset) -> dict[str, Any]:
    import json

    text = ds.attrs.get("model_spec", "")
    return json.loads(text) if text else {}


def penetration_rate(ds: xr.Dataset, position: int) -> Array:
    """``dδ/dt`` of gap ``position`` (m/s): exact from the recorded velocities when the file
    holds the gap's definition and its DOFs were recorded, else the time derivative of the
    recorded penetration."""
    spec = model_spec(ds)
    gaps = spec.get("gaps", [])
    dofs = [int(d) for d in ds["dof"].values] if "dof" in ds.coords else []
    if position < len(gaps) and all(d in dofs for d in gaps[position]["dofs"]):
        g = gaps[position]
        x = ds["displacement"].values
        v = ds["velocity"].values
        u = sum(c * x[:, dofs.index(d)] for d, c in zip(g["dofs"], g["coefficients"], strict=True))
        du = sum(c * v[:, dofs.index(d)] for d, c in zip(g["dofs"], g["coefficients"], strict=True))
        side = g["side"]
        if side == "positive":
            return np.asarray(du, dtype=float)
        if side == "negative":
            return -np.asarray(du, dtype=float)
        return np.where(np.asarray(u) >= 0.0, 1.0, -1.0) * du
    pen = ds["penetration"].values[:, position]
    t = ds["time"].values
    return np.gradient(pen, t) if len(t) > 1 else np.zeros_like(pen)


def harmonic_period(ds: xr.Dataset) -> float | None:
    """The period (s) of the model's first periodic load (harmonic, or an unbalance at a
    constant spin speed: :func:`~vibroimpact.model.spec_load_frequency`), if any."""
    spec = model_spec(ds)
    for i in range(len(spec.get("loads", []))):
        if (f := spec_load_frequency(spec, i)) > 0:
            return 1.0 / f
    return None
