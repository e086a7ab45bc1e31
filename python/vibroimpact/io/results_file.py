"""Result files: NetCDF-4/HDF5 and CSV, written atomically, read back as an ``xarray.Dataset``
(docs/conventions.md §What a run returns).

* ``.nc``, ``.h5``, ``.hdf5``: one NetCDF-4 file (a NetCDF-4 file *is* an HDF5 file: xarray,
  MATLAB's ``ncread``/``h5read``, ``ncdump`` and h5py read it). Dims ``time``, ``dof``, ``gap``,
  ``impact``; units and descriptions as attributes; only numeric and fixed-width char data
  (no bool, object or variable-length string arrays). The model and the solver settings are
  stored so that a file says how it was made: attributes ``model_spec`` and ``method_spec``
  (JSON text) and the variables ``structure_mass``, ``structure_damping``,
  ``structure_stiffness`` (a rotor's ``structure_gyroscopic`` too; its spin speed, run-up
  and unbalance loads are in ``model_spec``), ``initial_displacement`` and
  ``initial_velocity``;
  :func:`model_from_dataset` rebuilds the model and the integrator from them. A sparse
  structure's matrices are stored as their entries (``structure_mass`` on
  ``structure_mass_entry``, with ``structure_mass_row`` and ``structure_mass_col``), never
  densified; :func:`structure_matrix` reads either form.
* Each DOF's displacement unit is the coordinate ``dof_unit`` on ``dof`` (``"m"``, ``"rad"``
  for a rotation of a beam or FE model; velocity per s, acceleration per s²); the ``units``
  attribute of ``displacement``, ``velocity`` and ``acceleration`` is the common unit, or for
  a mixed set ``"m or rad per dof_unit"`` (``"m/s or rad/s per dof_unit"``, ...).
* ``.csv``: ``NAME.csv`` holds the time histories (column names carry each column's unit:
  ``time [s]``, ``x0 [m]``, ``v0 [m/s]``, ``a0 [m/s^2]``, ``x1 [rad]``, ``v1 [rad/s]``,
  ``gap0 penetration [m]``, ``gap0 force [N]``), ``NAME_impacts.csv`` the impact table,
  ``NAME_energy.csv`` the energy account and ``NAME_meta.json`` the attributes and the model.

Every file is first written to a hidden temporary file in the target's folder and then moved
into place with :func:`os.replace`, so a crash leaves either the previous complete file or
none, never a half-written one. ``Ctrl-C`` and ``SIGTERM`` during a write take effect once
every file is complete and in place (:func:`hold_signals`); :class:`KeyboardInterrupt` is then
raised. A long run can stream to disk (:func:`simulate_to_file`): the core hands its rows over
in blocks that are appended to the temporary file while it runs; stopped by a signal or a
solver failure, it leaves the rows up to then, marked incomplete (``complete = 0``), and raises
:class:`~vibroimpact.Interrupted` or :class:`~vibroimpact.SolverError` (``written`` names the
file). Only ``SIGKILL`` or a crash can leave a hidden ``.NAME.*.tmp`` file behind.

Example::

    >>> from vibroimpact.io import results_file
    >>> results_file.save(result, "run.nc")               # doctest: +SKIP
    >>> ds = results_file.load("run.nc")                  # doctest: +SKIP
    >>> model, method = results_file.model_from_dataset(ds)  # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import json
import math
import os
import signal
import tempfile
import threading
import typing
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp

from vibroimpact.errors import ModelError, SolverError
from vibroimpact.result import (
    DOF_UNIT_DESCRIPTION,
    DOF_VARIABLES,
    ENERGY_TERMS,
    dof_variable_units,
)

if TYPE_CHECKING:
    import xarray as xr

    from vibroimpact.fe.condensation import DofRecovery
    from vibroimpact.integrators import Integrator
    from vibroimpact.model import Model
    from vibroimpact.result import Result

__all__ = [
    "CSV_TABLES",
    "DOF_MAP_ATTRIBUTE",
    "ENERGY_TERMS",
    "NETCDF_SUFFIXES",
    "SUFFIXES",
    "atomic_write",
    "csv_paths",
    "dof_units",
    "hold_signals",
    "load",
    "model_from_dataset",
    "netcdf_engine",
    "node_dofs",
    "run_metadata",
    "save",
    "simulate_to_file",
    "to_dataset",
]

#: Suffixes written as NetCDF-4 (HDF5).
NETCDF_SUFFIXES = (".nc", ".h5", ".hdf5")
#: Every suffix :func:`save` and :func:`load` accept.
SUFFIXES = (*NETCDF_SUFFIXES, ".csv")
#: The files a ``.csv`` result consists of, by role: the name's suffix after the stem.
CSV_TABLES = {"time_histories": ".csv", "impacts": "_impacts.csv", "energy": "_energy.csv",
              "metadata": "_meta.json"}
#: Time-history variables on ``(time, gap)`` and their CSV column word and unit.
_GAP_VARIABLES = {"penetration": ("penetration", "m"), "contact_force": ("force", "N")}
#: Model matrices stored as variables (not JSON) so that large FE models stay compact.
_MODEL_MATRICES = {"structure_mass": ("mass", "kg"), "structure_damping": ("damping", "N s/m"),
                   "structure_stiffness": ("stiffness", "N/m"),
                   "structure_gyroscopic": ("gyroscopic", "kg m^2")}  # (a rotor's, if any)
_MODEL_VECTORS = {"initial_displacement": ("x0", "m"), "initial_velocity": ("v0", "m/s")}


# --------------------------------------------------------------------------------------------
# Metadata: how a result was made
# --------------------------------------------------------------------------------------------


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        return x if math.isfinite(x) else None
    return value


def _plain(value: Any) -> Any:
    """Dataclass settings (nested ones included) as plain JSON-ready values."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                if f.init}
    return _jsonable(value)


def method_settings(method: Integrator) -> dict[str, Any]:
    """The integrator as ``{"name", "params", "newton"}``: its name in
    :data:`vibroimpact.integrators.METHODS`, its constructor fields (nested settings such as
    adaptive stepping as objects) and its Newton options; :func:`method_from_settings`
    rebuilds it."""
    params = {f.name: _plain(getattr(method, f.name)) for f in dataclasses.fields(method)
              if f.init and f.name != "newton"}
    return {"name": method.name, "params": params, "newton": _plain(method.newton),
            "spec": _jsonable(method.to_spec())}


def _build(cls: type, values: Mapping[str, Any]) -> Any:
    """``cls(**values)`` with nested dataclass fields rebuilt from their dicts."""
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for f in dataclasses.fields(cls):
        if not f.init or f.name not in values:
            continue
        value = values[f.name]
        if isinstance(value, dict):
            hint = hints.get(f.name)
            options = typing.get_args(hint) or (hint,)
            target = next((t for t in options if dataclasses.is_dataclass(t)), None)
            if target is not None:
                value = _build(target, value)
        kwargs[f.name] = value
    return cls(**kwargs)


def method_from_settings(settings: Mapping[str, Any]) -> Integrator:
    """Rebuild an integrator from :func:`method_settings`."""
    from vibroimpact.integrators import METHODS, NewtonOptions

    name = settings.get("name", "newmark")
    if name not in METHODS:
        raise ModelError(f"result file: method {name!r} is not known to this vibroimpact "
                         f"version; expected one of {', '.join(METHODS)}")
    newton = _build(NewtonOptions, settings.get("newton", {}))
    return _build(METHODS[name], {**settings.get("params", {}), "newton": newton})


def run_metadata(result: Result) -> tuple[dict[str, Any], dict[str, tuple[tuple[str, ...],
                                                                          Any, dict[str, str]]]]:
    """Attributes and variables that say how ``result`` was made: ``(attrs, variables)``
    where ``variables`` maps a name to ``(dims, data, attrs)``. Used by
    :meth:`vibroimpact.Result.to_xarray`."""
    from vibroimpact import __version__, build_profile

    attrs: dict[str, Any] = {
        "title": "vibroimpact result",
        "Conventions": "CF-1.8",
        "source": f"vibroimpact {__version__} (core build: {build_profile})",
        "history": f"{_dt.datetime.now(_dt.timezone.utc).isoformat(timespec='seconds')} "
                   "vibroimpact.simulate",
        "vibroimpact_version": __version__,
        "rejected_steps": result.stats.rejected_steps,
        "step_cuts": result.stats.step_cuts,
        "wall_time_s": result.stats.wall_time_s,
    }
    variables: dict[str, tuple[tuple[str, ...], Any, dict[str, str]]] = {}
    if result.method is not None:
        attrs["method_spec"] = json.dumps(method_settings(result.method))
    if result.model is not None:
        spec = result.model.to_spec()
        model = {k: v for k, v in spec.items() if k not in ("mass", "damping", "stiffness",
                                                            "gyroscopic", "x0", "v0")}
        model["n_dof"] = result.model.n_dof
        model["dof_units"] = list(result.model.structure.dof_units)
        for g, gap in zip(model["gaps"], result.model.gaps, strict=True):
            g["name"] = gap.name
        attrs["model_spec"] = json.dumps(_jsonable(model))
        for name, (key, unit) in _MODEL_MATRICES.items():
            if spec[key] is not None:
                variables.update(_matrix_variables(name, spec[key], f"structure {key} matrix",
                                                   unit))
        for name, (key, unit) in _MODEL_VECTORS.items():
            variables[name] = (("model_dof",), np.asarray(spec[key], dtype=float),
                               {"units": unit, "long_name": name.replace("_", " ")})
    if result.dof_map is not None:
        attrs[DOF_MAP_ATTRIBUTE] = json.dumps({"nodes": list(result.dof_map.nodes),
                                               "directions": list(result.dof_map.directions)})
    return attrs, variables


def _matrix_variables(
    name: str, a: Any, desc: str, unit: str
) -> dict[str, tuple[tuple[str, ...], Any, dict[str, str]]]:
    """The variables of one model matrix: dense on ``(model_dof, model_dof_col)``, or for a
    SciPy sparse matrix its entries on ``NAME_entry`` with ``NAME_row`` and ``NAME_col``."""
    if not sp.issparse(a):
        return {name: (("model_dof", "model_dof_col"), np.asarray(a, dtype=float),
                       {"units": unit, "long_name": desc})}
    coo = sp.coo_array(a)
    entry = (f"{name}_entry",)
    return {
        name: (entry, coo.data.astype(float), {"units": unit, "long_name": f"{desc}: stored "
                                               f"entries (rows {name}_row, columns {name}_col)"}),
        f"{name}_row": (entry, coo.row.astype(np.int64), {"long_name": f"row of {name}"}),
        f"{name}_col": (entry, coo.col.astype(np.int64), {"long_name": f"column of {name}"}),
    }


def structure_matrix(ds: xr.Dataset, name: str) -> Any:
    """A model matrix stored in a result (``structure_mass``, ``…_stiffness``, ``…_damping``):
    a dense array, or the CSR array of a sparse structure."""
    if f"{name}_row" not in ds:
        return ds[name].values
    n = ds.sizes["model_dof"]
    rows, cols = ds[f"{name}_row"].values, ds[f"{name}_col"].values
    return sp.csr_array((ds[name].values, (rows, cols)), shape=(n, n))


def metadata(ds: xr.Dataset) -> dict[str, Any]:
    """The attributes of a result file with ``model_spec`` and ``method_spec`` parsed from
    JSON (``{}`` when absent)."""
    out: dict[str, Any] = {}
    for key, value in ds.attrs.items():
        if key in ("model_spec", "method_spec"):
            out[key] = json.loads(value) if value else {}
        else:
            out[key] = value.item() if isinstance(value, np.generic) else value
    out.setdefault("model_spec", {})
    out.setdefault("method_spec", {})
    return out


#: The result file's attribute holding the DOF map: JSON ``{"nodes": [...], "directions":
#: [...]}``, one entry per DOF of the model (or of the model file's DOFs, condensed ones too).
DOF_MAP_ATTRIBUTE = "dof_map"


def node_dofs(ds: xr.Dataset, node: int) -> tuple[int, int]:
    """The DOFs ``(ix, iy)`` of ``node``'s x and y in the DOF map of a result file; a
    :class:`ModelError` naming ``--node`` if the file has no map or the node no x and y."""
    text = ds.attrs.get(DOF_MAP_ATTRIBUTE, "")
    if not text:
        raise ModelError(f"--node: {node} cannot be found: the result file has no DOF map "
                         "(written by `vibroimpact run` from a beam, a matrices file with a DOF "
                         "map or a Jeffcott rotor); expected --dof IX --dof IY")
    numbers = json.loads(text)
    pairs = list(zip(numbers["nodes"], numbers["directions"], strict=True))
    found = {d: i for i, (n, d) in enumerate(pairs) if n == node and d in ("x", "y")}
    if len(found) != 2:
        nodes = sorted({n for n, d in pairs if d == "x"} & {n for n, d in pairs if d == "y"})
        shown = ", ".join(str(n) for n in nodes[:20]) + (", ..." if len(nodes) > 20 else "")
        raise ModelError(f"--node: {node} has no x and y DOFs in the result's DOF map; "
                         f"expected a node with both ({shown or 'none has'})")
    return found["x"], found["y"]


def model_from_dataset(ds: xr.Dataset) -> tuple[Model, Integrator]:
    """Rebuild the :class:`~vibroimpact.Model` and the integrator a result was made with, so
    that any result file can be re-run: ``vi.simulate(model, ds.t_end, ds.dt, method)``."""
    from vibroimpact.model import Model

    meta = metadata(ds)
    spec, msettings = meta["model_spec"], meta["method_spec"]
    if not spec or "structure_mass" not in ds:
        raise ModelError("result file: no model stored; expected a file written by vibroimpact")
    matrices = {key: structure_matrix(ds, name) for name, (key, _) in _MODEL_MATRICES.items()
                if name in ds}
    model = Model.from_spec(dict(spec, **matrices, x0=ds["initial_displacement"].values,
                                 v0=ds["initial_velocity"].values),
                            dof_units=spec.get("dof_units"))
    return model, method_from_settings(msettings)


# --------------------------------------------------------------------------------------------
# Atomic writes
# --------------------------------------------------------------------------------------------


class _Interrupts:
    """Signals received while held (see :func:`hold_signals`)."""

    def __init__(self) -> None:
        self.signum: int | None = None

    def check(self) -> None:
        """Raise :class:`KeyboardInterrupt` (its ``signum`` the signal's number) if ``Ctrl-C``
        or ``SIGTERM`` arrived."""
        if self.signum is not None:
            signum, self.signum = self.signum, None
            error = KeyboardInterrupt(f"signal {signum}")
            error.signum = signum  # type: ignore[attr-defined]
            raise error


#: The hold in force on the main thread, if any (holds nest: the outermost one decides).
_HELD: list[_Interrupts] = []


@contextlib.contextmanager
def hold_signals() -> Iterator[_Interrupts]:
    """Inside the block, ``Ctrl-C`` (SIGINT) and ``SIGTERM`` are noted in ``.signum`` instead
    of acted on, so that a result being converted or written is completed (an exception raised
    from a signal handler inside a NetCDF/HDF5 call can also leave the library's locks taken,
    and the process then hangs). The caller acts on ``.signum`` after the block; a second
    signal interrupts at once (:class:`KeyboardInterrupt`). Inside an outer hold (``vibroimpact
    run`` holds from the end of the run to the end of the writing), the outer one is yielded;
    a run started inside (:func:`vibroimpact.simulate`) catches the signals itself."""
    if _HELD or threading.current_thread() is not threading.main_thread():
        yield _HELD[0] if _HELD else _Interrupts()
        return
    state = _Interrupts()

    def handler(signum: int, frame: Any) -> None:
        if state.signum is not None:
            raise KeyboardInterrupt(f"signal {signum}")
        state.signum = signum

    previous: dict[int, Any] = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, handler)
    except (ValueError, OSError):  # pragma: no cover - signals not available here
        pass
    _HELD.append(state)
    try:
        yield state
    finally:
        _HELD.pop()
        for sig, old in previous.items():
            signal.signal(sig, old)


def _temp_path(target: Path) -> Path:
    fd, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    os.close(fd)
    return Path(name)


def atomic_write(writers: Mapping[str | os.PathLike[str], Callable[[Path], None]]) -> list[Path]:
    """Write each target through ``writer(temporary_path)``, then move all into place.

    The temporary files live in the targets' folders (so the final :func:`os.replace` is
    atomic), are flushed to disk first and get the permissions a new file would get. If any
    writer fails, or the process is interrupted (``Ctrl-C``, ``SIGTERM``), the temporary
    files are removed and the targets are left as they were. ``Ctrl-C`` or ``SIGTERM``
    during the writing lets every file be completed and moved into place first, then raises
    :class:`KeyboardInterrupt` (inside :func:`hold_signals`, the holder acts instead). Raises
    :class:`OSError` on failure. Returns the targets.

    **Example:** ``atomic_write({"a.txt": lambda p: p.write_text("hello")})``
    """
    umask = os.umask(0)
    os.umask(umask)
    temps: list[tuple[Path, Path]] = []
    nested = bool(_HELD)
    with hold_signals() as held:
        try:
            for target, write in writers.items():
                target = Path(target)
                tmp = _temp_path(target)
                temps.append((tmp, target))
                write(tmp)
                os.chmod(tmp, 0o666 & ~umask)
                with open(tmp, "rb") as fh:
                    os.fsync(fh.fileno())
            for tmp, target in temps:
                os.replace(tmp, target)
        finally:
            for tmp, _ in temps:
                tmp.unlink(missing_ok=True)
    if not nested:
        held.check()
    return [target for _, target in temps]


# --------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------


def to_dataset(source: Result | xr.Dataset) -> xr.Dataset:
    """The Dataset of a :class:`~vibroimpact.Result` (``result.to_xarray()``) or the Dataset
    itself."""
    import xarray as xr

    if isinstance(source, xr.Dataset):
        return source
    if hasattr(source, "to_xarray"):
        return source.to_xarray()
    raise ModelError(f"result: {type(source).__name__} is not valid; expected a "
                     "vibroimpact.Result or an xarray.Dataset")


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise ModelError(f"path: {str(path)!r} is not valid; expected a file name ending in "
                         f"{', '.join(SUFFIXES)}")
    return suffix


def csv_paths(path: str | os.PathLike[str]) -> dict[str, Path]:
    """The files of a CSV result ``NAME.csv``: ``time_histories`` (``NAME.csv``),
    ``impacts`` (``NAME_impacts.csv``), ``energy`` (``NAME_energy.csv``) and ``metadata``
    (``NAME_meta.json``)."""
    path = Path(path)
    return {role: path.with_name(path.stem + suffix) for role, suffix in CSV_TABLES.items()}


def netcdf_engine() -> str:
    """The xarray engine that writes NetCDF-4 here: netCDF4, else h5netcdf with h5py."""
    for module, engine in (("netCDF4", "netcdf4"), ("h5netcdf", "h5netcdf")):
        try:
            __import__(module)
            if engine == "h5netcdf":
                __import__("h5py")
            return engine
        except ImportError:
            continue
    raise ModelError("path: writing NetCDF needs the netCDF4 package (pip install netCDF4); "
                     "or write .csv")


def _netcdf_ready(ds: xr.Dataset) -> tuple[xr.Dataset, dict[str, dict[str, Any]]]:
    """A copy of ``ds`` whose every variable MATLAB and NetCDF-4 accept, and the encoding:
    strings become fixed-width char arrays, booleans int8."""
    out = ds.copy()
    encoding: dict[str, dict[str, Any]] = {}
    for name, var in out.variables.items():
        kind = var.dtype.kind
        if kind == "b":
            out[name] = var.astype(np.int8)
        elif kind in ("U", "O", "S"):
            values = np.asarray(var.values).astype(str)
            out[name] = (var.dims, values, var.attrs)
            encoding[str(name)] = {"dtype": "S1"}
        elif kind in "fc":
            encoding[str(name)] = {"_FillValue": None}
            if name in _MODEL_MATRICES and var.size > 1:
                # FE matrices are mostly zeros: compressed they cost little
                encoding[str(name)].update(zlib=True, complevel=4)
    for key, value in list(out.attrs.items()):
        if isinstance(value, (bool, np.bool_)):
            out.attrs[key] = int(value)
        elif value is None:
            out.attrs[key] = ""
    return out, encoding


def _write_netcdf(ds: xr.Dataset, path: Path) -> None:
    ready, encoding = _netcdf_ready(ds)
    ready.to_netcdf(path, engine=netcdf_engine(), format="NETCDF4", encoding=encoding)


def _column(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit else name


def dof_units(ds: xr.Dataset) -> list[str]:
    """The displacement unit of each DOF of a result Dataset: its ``dof_unit`` coordinate
    (``"m"`` for every DOF in a file written before it existed)."""
    n = ds.sizes.get("dof", 0)
    if "dof_unit" not in ds.coords:
        return ["m"] * n
    return [str(u) for u in np.asarray(ds["dof_unit"].values).astype(str)]


def _time_histories_frame(ds: xr.Dataset) -> Any:
    import pandas as pd

    cols: dict[str, Any] = {}
    dofs = ds["dof"].values if "dof" in ds.coords else []
    units = {name: dof_variable_units(name, dof_units(ds))[0] for name in DOF_VARIABLES}
    for j, d in enumerate(dofs):
        for name, (prefix, _) in DOF_VARIABLES.items():
            if name in ds:
                cols[f"{prefix}{int(d)} [{units[name][j]}]"] = ds[name].values[:, j]
    gaps = ds["gap"].values if "gap" in ds.coords else []
    for g_index, g in enumerate(gaps):
        for name, (word, unit) in _GAP_VARIABLES.items():
            if name in ds:
                cols[f"gap{int(g)} {word} [{unit}]"] = ds[name].values[:, g_index]
    return pd.DataFrame(cols, index=pd.Index(ds["time"].values, name="time [s]"))


def energy_frame(ds: xr.Dataset) -> Any:
    """The energy account as a DataFrame indexed by ``time [s]``: each term, ``total`` and
    the ``balance`` (``total + dissipated − total(0) − external work``), J."""
    import pandas as pd

    terms = {t: ds[f"energy_{t}"].values for t in ENERGY_TERMS if f"energy_{t}" in ds}
    frame = pd.DataFrame({f"{t} [J]": v for t, v in terms.items()},
                         index=pd.Index(ds["time"].values, name="time [s]"))
    if len(terms) == len(ENERGY_TERMS):
        total = terms["kinetic"] + terms["strain"] + terms["contact_potential"]
        frame["total [J]"] = total
        frame["balance [J]"] = (total + terms["damping_dissipated"]
                                + terms["contact_dissipated"] - total[:1] - terms["external_work"])
    return frame


def impacts_frame(ds: xr.Dataset) -> Any:
    """The impact table as a DataFrame whose column names carry units (``t_start [s]``)."""
    import pandas as pd

    cols = {}
    for name in ds.data_vars:
        if str(name).startswith("impact_") and ds[name].dims == ("impact",):
            values = ds[name].values
            if values.dtype.kind in ("S", "O"):
                values = values.astype(str)
            cols[_column(str(name)[len("impact_"):], ds[name].attrs.get("units", ""))] = values
    return pd.DataFrame(cols)


def _meta_json(ds: xr.Dataset) -> str:
    meta = metadata(ds)
    for name in (*_MODEL_MATRICES, *_MODEL_VECTORS):
        for var in (name, f"{name}_row", f"{name}_col"):
            if var in ds:
                meta[var] = ds[var].values
    for name in ("dof", "gap"):
        if name in ds.coords:
            meta[name] = ds[name].values
    return json.dumps(_jsonable(meta), indent=1)


def save(source: Result | xr.Dataset, path: str | os.PathLike[str]) -> list[Path]:
    """Write a result to ``path`` atomically: ``.nc``/``.h5``/``.hdf5`` as NetCDF-4, ``.csv``
    as the four files of :func:`csv_paths`. Returns the files written. Raises
    :class:`~vibroimpact.ModelError` for a suffix it does not know and :class:`OSError` if the
    files cannot be written (the targets are then untouched)."""
    path = Path(path)
    suffix = _suffix(path)
    ds = to_dataset(source)
    if suffix in NETCDF_SUFFIXES:
        netcdf_engine()
        return atomic_write({path: lambda p: _write_netcdf(ds, p)})
    files = csv_paths(path)
    histories, impacts, energy = _time_histories_frame(ds), impacts_frame(ds), energy_frame(ds)
    meta = _meta_json(ds)
    return atomic_write({
        files["time_histories"]: lambda p: histories.to_csv(p),
        files["impacts"]: lambda p: impacts.to_csv(p, index=False),
        files["energy"]: lambda p: energy.to_csv(p),
        files["metadata"]: lambda p: p.write_text(meta, encoding="utf-8"),
    })


# --------------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------------


def _split_unit(column: str) -> tuple[str, str]:
    if column.endswith("]") and " [" in column:
        name, unit = column[:-1].rsplit(" [", 1)
        return name, unit
    return column, ""


def _load_csv(path: Path) -> xr.Dataset:
    import pandas as pd
    import xarray as xr

    files = csv_paths(path)
    hist = pd.read_csv(files["time_histories"], index_col=0)
    time = hist.index.to_numpy(dtype=float)
    meta: dict[str, Any] = {}
    if files["metadata"].exists():
        meta = json.loads(files["metadata"].read_text(encoding="utf-8"))
    by_prefix = {prefix: name for name, (prefix, _) in DOF_VARIABLES.items()}
    dof_cols: dict[str, dict[int, np.ndarray]] = {}
    gap_cols: dict[str, dict[int, np.ndarray]] = {}
    dof_unit: dict[int, str] = {}
    for col in hist.columns:
        label, unit = _split_unit(col)
        if label.startswith("gap") and " " in label:
            g, word = label[3:].split(" ", 1)
            name = next(n for n, (w, _) in _GAP_VARIABLES.items() if w == word)
            gap_cols.setdefault(name, {})[int(g)] = hist[col].to_numpy(dtype=float)
        elif label[:1] in by_prefix and label[1:].isdigit():
            name = by_prefix[label[:1]]
            dof_cols.setdefault(name, {})[int(label[1:])] = hist[col].to_numpy(dtype=float)
            if name == "displacement":
                dof_unit[int(label[1:])] = unit
    data: dict[str, Any] = {}
    dofs = sorted(next(iter(dof_cols.values()), {}))
    gaps = sorted(next(iter(gap_cols.values()), {}))
    units = [dof_unit.get(d, "m") for d in dofs]
    for name, cols in dof_cols.items():
        unit = dof_variable_units(name, units)[1]
        data[name] = (("time", "dof"), np.column_stack([cols[d] for d in dofs]),
                      {"units": unit, "long_name": name})
    for name, cols in gap_cols.items():
        unit = _GAP_VARIABLES[name][1]
        data[name] = (("time", "gap"), np.column_stack([cols[g] for g in gaps]),
                      {"units": unit, "long_name": name.replace("_", " ")})
    if files["energy"].exists():
        energy = pd.read_csv(files["energy"], index_col=0)
        for col in energy.columns:
            label, unit = _split_unit(col)
            if label in ENERGY_TERMS:
                data[f"energy_{label}"] = (("time",), energy[col].to_numpy(dtype=float),
                                           {"units": unit, "long_name": label})
    if files["impacts"].exists():
        impacts = pd.read_csv(files["impacts"], keep_default_na=True)
        for col in impacts.columns:
            label, unit = _split_unit(col)
            values = impacts[col].to_numpy()
            if label == "side":
                values = values.astype(str)
            elif label == "gap":
                values = values.astype(np.int64)
            else:
                values = values.astype(float)
            data[f"impact_{label}"] = (("impact",), values, {"units": unit, "long_name": label})
    coords: dict[str, Any] = {"time": ("time", time, {"units": "s", "long_name": "time"})}
    if dofs:
        coords["dof"] = np.asarray(dofs, dtype=np.int64)
        coords["dof_unit"] = ("dof", np.array(units, dtype=str),
                              {"long_name": DOF_UNIT_DESCRIPTION})
    if gaps:
        coords["gap"] = np.asarray(gaps, dtype=np.int64)
    for name, (key, unit) in _MODEL_MATRICES.items():
        if name in meta:
            value = np.asarray(meta.pop(name), dtype=float)
            if f"{name}_row" in meta:  # a sparse structure's entries
                rows, cols = (np.asarray(meta.pop(f"{name}_{p}")) for p in ("row", "col"))
                n = len(meta.get("initial_displacement", ()))
                value = sp.csr_array((value, (rows, cols)), shape=(n, n))
            data.update(_matrix_variables(name, value, f"structure {key} matrix", unit))
    for name, (_, unit) in _MODEL_VECTORS.items():
        if name in meta:
            desc = name.replace("_", " ")
            data[name] = (("model_dof",), np.asarray(meta.pop(name), dtype=float),
                          {"units": unit, "long_name": desc})
    meta.pop("dof", None)
    meta.pop("gap", None)
    for key in ("model_spec", "method_spec"):
        if key in meta:
            meta[key] = json.dumps(meta[key])
    attrs = {k: v for k, v in meta.items() if isinstance(v, (str, int, float))}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def load(path: str | os.PathLike[str]) -> xr.Dataset:
    """Read a result written by :func:`save` (or ``vibroimpact run -o``) into memory as an
    ``xarray.Dataset``; the file is closed on return. For ``.csv`` give the main file
    ``NAME.csv``; its ``_impacts``, ``_energy`` and ``_meta`` companions are read too."""
    import xarray as xr

    path = Path(path)
    suffix = _suffix(path)
    if not path.is_file():
        raise ModelError(f"path: {str(path)!r} is not valid; expected an existing result file")
    if suffix == ".csv":
        return _load_csv(path)
    try:
        return xr.load_dataset(path, engine=netcdf_engine())
    except (OSError, ValueError) as e:
        raise ModelError(f"path: {str(path)!r} is not valid; expected a NetCDF-4 result file "
                         f"({e})") from None


# --------------------------------------------------------------------------------------------
# Streaming long runs to disk
# --------------------------------------------------------------------------------------------


#: HDF5 chunk cache of each streamed variable, bytes.
CHUNK_CACHE_BYTES = 1 << 20


class _NetcdfStream:
    """Appends blocks of rows (``vibroimpact.result.time_columns``) to the
    :data:`~vibroimpact.result.TIME_VARIABLES` of a NetCDF-4 file with an unlimited ``time``
    dimension; :meth:`finish` adds everything else from the finished result's Dataset."""

    def __init__(self, path: Path, n_dofs: int, n_gaps: int) -> None:
        import netCDF4

        from vibroimpact.result import TIME_VARIABLES

        self.path = path
        self.nc = netCDF4.Dataset(path, "w", format="NETCDF4")
        self.nc.createDimension("time", None)
        self.nc.createDimension("dof", n_dofs)
        self.nc.createDimension("gap", n_gaps)
        self.n = 0
        sizes = {"time": 4096, "dof": max(n_dofs, 1), "gap": max(n_gaps, 1)}
        # chunks of a few thousand samples: appends stay fast, reads of a stretch too
        self.vars = {"time": self.nc.createVariable("time", "f8", ("time",),
                                                    chunksizes=(4096,))}
        self.vars["time"].units = "s"
        for name, (dims, units, desc, _) in TIME_VARIABLES.items():
            v = self.nc.createVariable(name, "f8", dims,
                                       chunksizes=[sizes[d] for d in dims])
            v.units, v.long_name = units, desc
            self.vars[name] = v
        for v in self.vars.values():
            # appends touch each chunk once: a small cache (the library's default, 16-64 MiB
            # per variable, would grow to hundreds of MiB over a long run)
            v.set_var_chunk_cache(size=CHUNK_CACHE_BYTES)

    def append(self, raw: Mapping[str, Any]) -> None:
        """Append a block of rows in the core's layout (``on_rows`` of ``simulate``)."""
        from vibroimpact.result import time_columns

        columns = time_columns(dict(raw))
        m = len(columns["time"])
        if m:
            for name, values in columns.items():
                self.vars[name][self.n:self.n + m, ...] = values
            self.n += m

    def finish(self, result: Result) -> None:
        """Write ``result``'s remaining rows and the units of its DOFs (the ``units`` of
        ``displacement``, ``velocity``, ``acceleration``), then its every variable not on
        ``time`` (impact table, model matrices, ``dof``/``dof_unit``/``gap``) and its
        attributes, exactly as :func:`save` writes them; close the file."""
        from vibroimpact.result import TIME_VARIABLES

        self.append({"time": result.time, "displacement": result.displacement,
                     "velocity": result.velocity, "acceleration": result.acceleration,
                     "gap_penetration": result.gap_penetration, "gap_force": result.gap_force,
                     "energy": {t: getattr(result.energy, t) for t in ENERGY_TERMS}})
        ds = result.to_xarray()
        for name in DOF_VARIABLES:
            self.vars[name].units = ds[name].attrs["units"]
        self.nc.close()
        rest = ds.drop_vars(["time", *TIME_VARIABLES])
        ready, encoding = _netcdf_ready(rest)
        ready.to_netcdf(self.path, mode="a", engine="netcdf4", format="NETCDF4",
                        encoding=encoding)

    def close(self) -> None:
        if self.nc.isopen():
            self.nc.close()


def simulate_to_file(
    model: Model,
    path: str | os.PathLike[str],
    t_end: float,
    dt: float,
    method: Integrator | None = None,
    *,
    every: int = 1,
    dofs: Sequence[int] | None = None,
    window_steps: int = 200_000,
    progress: Callable[[float], None] | None = None,
    progress_bar: bool = False,
    recovery: DofRecovery | None = None,
    dof_map: Any = None,
) -> dict[str, Any]:
    """Run ``model`` from 0 to ``t_end`` and write its time histories to the NetCDF-4 file
    ``path`` (``.nc``/``.h5``) while it runs, so that memory holds a few blocks of rows, not
    the whole run (``vibroimpact run --stream``): the core hands over the recorded rows every
    ``window_steps // every`` rows (a bounded channel of two blocks: if writing falls behind,
    the core waits) and each block is appended to a temporary file (unlimited ``time``
    dimension). When the run ends, the impact table, the model and the attributes are added,
    and the file is moved into place atomically: it then holds exactly what
    :func:`save` writes for the same run held in memory. A solver failure or a signal
    (``Ctrl-C``, SIGTERM: the run stops within 64 steps) leaves the rows up to then, marked
    incomplete (``complete = 0``), and raises the error (:class:`~vibroimpact.SolverError` or
    :class:`~vibroimpact.Interrupted`) with ``written = [path]`` (its ``partial`` result holds
    the rows after the last block). A signal after the run has
    finished lets the file be completed first, then raises :class:`KeyboardInterrupt`. The
    impact table is kept in memory (one row per contact), as are the impulsive methods' rows.

    Returns the summary of :meth:`vibroimpact.Result.summary` plus ``windows`` (the blocks
    written) and ``steps_computed``. ``progress(fraction)`` is called after each block;
    ``progress_bar`` draws :class:`vibroimpact.simulate.ProgressBar` on a terminal.
    ``recovery`` (:meth:`vibroimpact.io.ModelFile.recovery`): write the DOFs of a condensed
    model's file instead, the massless ones recovered (the run records its ``record``, whatever
    ``dofs`` says). ``dof_map``: the :attr:`vibroimpact.Result.dof_map` the file keeps (default
    the model's, ``model.structure.dof_map``).
    """
    from vibroimpact.simulate import simulate

    path = Path(path)
    if _suffix(path) not in NETCDF_SUFFIXES:
        raise ModelError(f"path: {str(path)!r} is not valid; streaming writes .nc or .h5")
    if not (isinstance(window_steps, int) and not isinstance(window_steps, bool)
            and window_steps >= 2):
        raise ModelError(f"window_steps: {window_steps!r} is not valid; expected an integer >= 2")
    if not (isinstance(every, int) and every >= 1):
        raise ModelError(f"output.every: {every!r} is not valid; expected an integer >= 1")
    netcdf_engine()
    n_dofs = model.n_dof if dofs is None else len(dofs)
    if recovery is not None:
        dofs, n_dofs = recovery.record.tolist(), len(recovery.labels)
    blocks = 0
    failure: SolverError | None = None
    tmp = _temp_path(path)
    stream: _NetcdfStream | None = None
    nested = bool(_HELD)
    with hold_signals() as held:
        try:
            stream = _NetcdfStream(tmp, n_dofs, len(model.gaps))

            def on_rows(rows: dict[str, Any]) -> None:
                nonlocal blocks
                assert stream is not None
                stream.append(rows if recovery is None else recovery.rows(rows))
                blocks += 1
                if progress is not None and len(rows["time"]):
                    progress(min(float(rows["time"][-1]) / t_end, 1.0))

            try:
                result = simulate(model, t_end, dt, method, every=every, dofs=dofs,
                                  progress=progress_bar, on_rows=on_rows,
                                  chunk_rows=max(1, window_steps // every))
            except SolverError as e:  # Interrupted too
                if e.partial is None:
                    raise
                result, failure = e.partial, e
            if recovery is not None:
                result = recovery.result(result)
            if dof_map is not None:
                result = dataclasses.replace(result, dof_map=dof_map)
            if failure is not None:
                failure.partial = result
            stream.finish(result)
            blocks += 1
            if progress is not None and failure is None:
                progress(1.0)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
            with open(tmp, "rb") as fh:
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        finally:
            if stream is not None:
                stream.close()
            tmp.unlink(missing_ok=True)
    if failure is not None:
        failure.written = [path]
        raise failure
    if not nested:
        held.check()
    return {**result.summary(), "windows": blocks, "steps_computed": result.stats.steps}
