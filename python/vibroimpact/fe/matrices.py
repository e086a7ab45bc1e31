"""Matrices from other FE programs, read as sparse CSR arrays with DOF maps.

Formats (each reader returns ``scipy.sparse.csr_array``; the structure readers an
:class:`~vibroimpact.fe.FEStructure` whose :class:`~vibroimpact.fe.DofMap` places gaps at
node/direction pairs):

* **Matrix Market** (``.mtx`` starting ``%%MatrixMarket``; NIST's coordinate or array format,
  general or symmetric): :func:`read_matrix_market`, :func:`write_matrix_market`.
* **numpy**: ``.npy`` (one dense array), ``.npz`` written by :func:`scipy.sparse.save_npz`,
  or an ``.npz`` of named arrays (``mass``, ``stiffness``, optional ``damping``, optional
  ``dof_nodes``/``dof_directions``): :func:`read_numpy`, :func:`load_npz`, :func:`save_npz`.
* **CalculiX** ``*FREQUENCY, SOLVER=MATRIXSTORAGE`` (a step of its own, without a data
  line; checked with CalculiX 2.20, Debian's ``calculix-ccx``, whose reader refuses a
  ``*MATRIX STORAGE`` card): ccx writes ``job.sti`` (stiffness), ``job.mas`` (mass) and
  ``job.dof``, then stops. Read from ccx's ``matrixstorage.c``: the ``.sti``/``.mas`` files hold
  one entry per line, ``row column value`` (1-based equation numbers, ``%d %d %20.13e``), the
  diagonal and one triangle of the symmetric matrix, constrained DOFs removed; line ``k`` of
  ``.dof`` is ``node.direction`` of equation ``k`` (direction 1–3 translations, 4–6
  rotations, 0 temperature). Expanded shell and beam elements (S8R, B32R, ...) give each of a
  node's layers through the thickness the original node's label: those DOFs get layers 1, 2,
  ... in file order (:class:`~vibroimpact.fe.DofMap`). :func:`read_calculix`,
  :func:`write_calculix`.
* **ABAQUS** ``*MATRIX GENERATE`` with ``*MATRIX OUTPUT, STIFFNESS, MASS``: files
  ``job_STIF1.mtx`` and ``job_MASS1.mtx`` (``1`` = step number). ``FORMAT=MATRIX INPUT`` (the
  default) writes one entry per line, ``row node, row DOF, column node, column DOF, value``
  (the ``*MATRIX INPUT`` data-line layout; a symmetric matrix as its lower triangle, upper
  triangle or square); ``FORMAT=COORDINATE`` writes ``row, column, value`` with equation
  numbers. Lines starting with ``*`` are comments or keywords. :func:`read_abaqus_mtx`,
  :func:`read_abaqus`, :func:`write_abaqus_mtx`.

Any mix of these (and arrays) is read as one structure by :func:`read_structure` /
:func:`read_matrix_files` (what model files use): the format by suffix and content
(:func:`detect_format`), the DOF map given (:func:`read_dof_map`) or carried by the files.
Massless DOFs (zero rows of ``M``, e.g. the rotations of a lumped-mass export) and any other
null space of a positive semi-definite ``M`` (the consistent mass of reduced-integration solids
such as C3D20R, of expanded shells such as S8R) are kept; condense them with
:meth:`FEStructure.condense_massless` (:mod:`vibroimpact.fe.condensation`).

A one-triangle file is mirrored; a square file must be symmetric. Sparse matrices stay sparse
through :meth:`FEStructure.to_structure` into the core (Newmark-family methods on a banded
or general sparse Cholesky factor); the dense-only methods (precise, Bathe, impulsive) need a
reduced model above 5,000 DOFs (:func:`vibroimpact.fe.craig_bampton`).

Recipe for a CalculiX fixture (what most tests do, no ccx needed): build any structure, write
it with :func:`write_calculix` (the exact ``fprintf`` layout of ccx), read it back. With ccx
(``tests/test_calculix.py`` runs it when ``ccx`` is installed), after the model data::

    *BOUNDARY
    FIXED, 1, 3
    *STEP
    *FREQUENCY, SOLVER=MATRIXSTORAGE
    *END STEP

in ``job.inp``, then ``ccx job`` writes ``job.sti``, ``job.mas``, ``job.dof``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.io
import scipy.sparse as sp
from numpy.typing import NDArray

from vibroimpact.errors import ModelError
from vibroimpact.fe.dofs import DIRECTIONS, DofMap, FEStructure, as_sparse

__all__ = [
    "FORMATS",
    "MatrixSet",
    "detect_format",
    "load_npz",
    "read_abaqus",
    "read_abaqus_mtx",
    "read_calculix",
    "read_calculix_dofs",
    "read_dof_map",
    "read_matrix",
    "read_matrix_files",
    "read_matrix_market",
    "read_numpy",
    "read_structure",
    "save_npz",
    "write_abaqus_mtx",
    "write_calculix",
    "write_matrix_market",
]

PathLike = str | os.PathLike[str]


def _open_text(path: PathLike) -> list[str]:
    p = Path(os.path.expanduser(os.fspath(path)))
    try:
        return p.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as e:
        raise ModelError(
            f"{str(path)!r}: cannot read ({e.strerror or type(e).__name__}); expected an "
            "existing, readable file"
        ) from None


def _symmetrize(
    rows: NDArray[np.int64], cols: NDArray[np.int64], vals: NDArray[np.float64], n: int, name: str
) -> sp.csr_array:
    """CSR from triplets holding one triangle (mirrored) or the whole symmetric matrix."""
    off = rows != cols
    lower = np.any(rows[off] > cols[off])
    upper = np.any(rows[off] < cols[off])
    if lower and upper:
        a = sp.coo_array((vals, (rows, cols)), shape=(n, n)).tocsr()
    else:
        r2 = np.concatenate([rows, cols[off]])
        c2 = np.concatenate([cols, rows[off]])
        v2 = np.concatenate([vals, vals[off]])
        a = sp.coo_array((v2, (r2, c2)), shape=(n, n)).tocsr()
    return as_sparse(a, name)


# --------------------------------------------------------------------------------------------
# Matrix Market and numpy
# --------------------------------------------------------------------------------------------


def read_matrix_market(path: PathLike) -> sp.csr_array:
    """A square, symmetric Matrix Market file as a CSR array."""
    try:
        a = scipy.io.mmread(os.fspath(path))
    except Exception as e:  # a user's file that does not parse is a mistake in the file
        raise ModelError(
            f"{str(path)!r}: not a readable Matrix Market file ({' '.join(str(e).split())[:80]})"
            "; expected a %%MatrixMarket matrix"
        ) from None
    return as_sparse(a, str(path))


def write_matrix_market(path: PathLike, matrix: Any, comment: str = "") -> None:
    """Write ``matrix`` as a symmetric coordinate Matrix Market file (full float precision,
    so that reading it back gives the same numbers)."""
    a = sp.coo_array(as_sparse(matrix, str(path)))
    scipy.io.mmwrite(os.fspath(path), a, comment=comment, symmetry="symmetric", precision=17)


def read_numpy(path: PathLike, key: str | None = None) -> sp.csr_array:
    """A matrix from ``.npy`` (dense), a :func:`scipy.sparse.save_npz` file, or the array
    ``key`` of an ``.npz`` archive."""
    p = os.fspath(path)
    try:
        if p.lower().endswith(".npy"):
            return as_sparse(np.load(p, allow_pickle=False), p)
        with np.load(p, allow_pickle=False) as z:
            files = set(z.files)
            if key is not None:
                if key not in files:
                    raise ModelError(
                        f"{p!r}: no array {key!r}; expected one of {', '.join(sorted(files))}"
                    )
                return as_sparse(z[key], f"{p}[{key}]")
            if not {"format", "shape"} <= files:
                raise ModelError(
                    f"{p!r}: an archive of {', '.join(sorted(files))}; expected a key naming "
                    "the matrix, or a file written by scipy.sparse.save_npz"
                )
        return as_sparse(sp.load_npz(p), p)
    except ModelError:
        raise
    except Exception as e:
        raise ModelError(
            f"{p!r}: not a readable numpy file ({' '.join(str(e).split())[:80]}); expected a "
            ".npy or .npz matrix"
        ) from None


def save_npz(path: PathLike, structure: FEStructure) -> None:
    """Write an :class:`FEStructure` as an ``.npz`` archive (dense arrays ``mass``,
    ``stiffness``, ``damping`` if any, and the DOF map as ``dof_nodes``/``dof_directions``)."""
    arrays: dict[str, Any] = {
        "mass": structure.mass.toarray(),
        "stiffness": structure.stiffness.toarray(),
    }
    if structure.damping is not None:
        arrays["damping"] = structure.damping.toarray()
    if structure.dof_map is not None:
        arrays["dof_nodes"] = np.asarray(structure.dof_map.nodes, dtype=np.int64)
        arrays["dof_directions"] = np.asarray(structure.dof_map.directions, dtype="U8")
        if any(structure.dof_map.layers):
            arrays["dof_layers"] = np.asarray(structure.dof_map.layers, dtype=np.int64)
    np.savez(os.fspath(path), **arrays)


def load_npz(path: PathLike) -> FEStructure:
    """Read an archive written by :func:`save_npz` (or any ``.npz`` with ``mass`` and
    ``stiffness`` arrays)."""
    p = os.fspath(path)
    try:
        with np.load(p, allow_pickle=False) as z:
            files = set(z.files)
            if not {"mass", "stiffness"} <= files:
                raise ModelError(
                    f"{p!r}: arrays {', '.join(sorted(files))}; expected mass and stiffness"
                )
            m, k = z["mass"], z["stiffness"]
            c = z["damping"] if "damping" in files else None
            dm = None
            if "dof_nodes" in files and "dof_directions" in files:
                layers = z["dof_layers"].tolist() if "dof_layers" in files else None
                dm = DofMap(z["dof_nodes"].tolist(), [str(d) for d in z["dof_directions"]],
                            layers)
    except ModelError:
        raise
    except Exception as e:
        raise ModelError(
            f"{p!r}: not a readable .npz archive ({' '.join(str(e).split())[:80]})"
        ) from None
    return FEStructure(m, k, c, dm)


# --------------------------------------------------------------------------------------------
# CalculiX
# --------------------------------------------------------------------------------------------


def _read_triplets(
    path: PathLike, name: str
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    rows, cols, vals = [], [], []
    for lineno, line in enumerate(_open_text(path), 1):
        s = line.strip()
        if not s or s.startswith(("*", "#", "%")):
            continue
        parts = s.replace(",", " ").split()
        try:
            if len(parts) != 3:
                raise ValueError
            i, j, v = int(parts[0]), int(parts[1]), float(parts[2].replace("D", "E"))
            if i < 1 or j < 1 or not np.isfinite(v):
                raise ValueError
        except ValueError:
            raise ModelError(
                f"{name}: line {lineno} ({s[:40]!r}) is not valid; expected 'row column value' "
                "with 1-based indices"
            ) from None
        rows.append(i - 1)
        cols.append(j - 1)
        vals.append(v)
    if not rows:
        raise ModelError(f"{name}: no entries; expected 'row column value' lines")
    return np.array(rows), np.array(cols), np.array(vals)


def _calculix_paths(job: PathLike) -> tuple[Path, Path, Path]:
    p = Path(os.path.expanduser(os.fspath(job)))
    if p.suffix.lower() in (".sti", ".mas", ".dof", ".inp"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".sti"), p.with_name(p.name + ".mas"), p.with_name(p.name + ".dof")


def read_calculix(job: PathLike) -> FEStructure:
    """The stiffness (``job.sti``), mass (``job.mas``) and DOF map (``job.dof``, optional)
    that CalculiX's ``*MATRIX STORAGE`` writes (format: the module docstring). ``job`` is the
    job name or the path of any of the three files."""
    sti, mas, _ = _calculix_paths(job)
    return read_structure(mas, sti, format="calculix")


def read_calculix_dofs(path: PathLike) -> DofMap:
    """A CalculiX ``job.dof`` file: line ``k`` is ``node.direction`` of equation ``k``; a
    node/direction given more than once (the layers of an expanded shell node) gets layers
    1, 2, ... in file order (:meth:`DofMap.numbered_layers`)."""
    nodes, dirs = [], []
    for lineno, line in enumerate(_open_text(path), 1):
        s = line.strip()
        if not s:
            continue
        m = re.fullmatch(r"(-?\d+)\.(\d+)", s)
        if m is None:
            raise ModelError(
                f"{path}: line {lineno} ({s[:40]!r}) is not valid; expected node.direction"
            )
        nodes.append(int(m.group(1)))
        dirs.append(int(m.group(2)))
    return DofMap.numbered_layers(nodes, dirs)


def _upper_triplets(
    a: sp.csr_array,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Diagonal and upper triangle as CalculiX orders them (by column, then row)."""
    coo = sp.triu(a, format="coo")
    order = np.lexsort((coo.row, coo.col))
    return coo.row[order], coo.col[order], coo.data[order]


def write_calculix(job: PathLike, structure: FEStructure) -> tuple[Path, Path, Path]:
    """Write ``job.sti``, ``job.mas`` and ``job.dof`` exactly as ccx's ``matrixstorage.c``
    does (``%d %d %20.13e``; the test fixture recipe). Returns the three paths."""
    sti, mas, dof = _calculix_paths(job)
    for path, a in ((sti, structure.stiffness), (mas, structure.mass)):
        r, c, v = _upper_triplets(a)
        with open(path, "w", encoding="ascii") as f:
            for i, j, x in zip(r, c, v, strict=True):
                f.write(f"{i + 1} {j + 1} {x:20.13e}\n")
    dm = structure.dof_map or DofMap(range(1, structure.n_dof + 1), ["x"] * structure.n_dof)
    with open(dof, "w", encoding="ascii") as f:
        for node, d in zip(dm.nodes, dm.directions, strict=True):
            num = DIRECTIONS.index(d) + 1 if d in DIRECTIONS else int(d)
            f.write(f"{node}.{num}\n")
    return sti, mas, dof


# --------------------------------------------------------------------------------------------
# ABAQUS
# --------------------------------------------------------------------------------------------


def _abaqus_entries(path: PathLike) -> tuple[list[tuple[Any, Any, float]], bool]:
    """Entries ``(row key, column key, value)``; keys are ``(node, dof)`` pairs (5-field
    lines) or equation numbers (3-field lines). Returns the entries and whether keyed by
    node."""
    entries: list[tuple[Any, Any, float]] = []
    by_node: bool | None = None
    name = str(path)
    for lineno, line in enumerate(_open_text(path), 1):
        s = line.strip()
        if not s or s.startswith("*"):
            continue
        parts = [x.strip() for x in s.rstrip(",").split(",")]
        if len(parts) == 1:
            parts = s.split()
        try:
            if len(parts) == 5:
                key = True
                rk: Any = (int(parts[0]), int(parts[1]))
                ck: Any = (int(parts[2]), int(parts[3]))
                v = float(parts[4].replace("D", "E"))
            elif len(parts) == 3:
                key = False
                rk, ck = int(parts[0]), int(parts[1])
                v = float(parts[2].replace("D", "E"))
                if rk < 1 or ck < 1:
                    raise ValueError
            else:
                raise ValueError
            if not np.isfinite(v):
                raise ValueError
        except ValueError:
            raise ModelError(
                f"{name}: line {lineno} ({s[:40]!r}) is not valid; expected 'node, dof, node, "
                "dof, value' (FORMAT=MATRIX INPUT) or 'row, column, value' (FORMAT=COORDINATE)"
            ) from None
        if by_node is None:
            by_node = key
        elif by_node != key:
            raise ModelError(
                f"{name}: line {lineno} mixes the 5-field and the 3-field layouts; expected one"
            )
        entries.append((rk, ck, v))
    if not entries:
        raise ModelError(f"{name}: no matrix entries; expected an ABAQUS .mtx matrix file")
    return entries, bool(by_node)


def read_abaqus_mtx(
    path: PathLike, dof_map: DofMap | None = None
) -> tuple[sp.csr_array, DofMap | None]:
    """One ABAQUS ``*MATRIX OUTPUT`` file. With node/DOF entries the DOF map is ``dof_map``
    if given (entries must be in it), else every ``(node, dof)`` present, sorted; with
    equation-number entries the map is ``dof_map`` (or None)."""
    got = read_matrix_files({"matrix": path}, format="abaqus", dof_map=dof_map)
    if got.errors:
        raise ModelError(got.errors["matrix"])
    return got.matrices["matrix"], got.dof_map


def read_abaqus(
    stiffness: PathLike, mass: PathLike, damping: PathLike | None = None
) -> FEStructure:
    """An :class:`FEStructure` from ABAQUS ``*MATRIX OUTPUT`` files (``job_STIF1.mtx``,
    ``job_MASS1.mtx``, optionally ``job_DMPV1.mtx``). The DOF map is every ``(node, dof)``
    of any of the files, sorted by node then DOF."""
    return read_structure(mass, stiffness, damping, format="abaqus")


def write_abaqus_mtx(path: PathLike, matrix: Any, dof_map: DofMap) -> None:
    """Write ``matrix`` in the ``FORMAT=MATRIX INPUT`` layout (lower triangle, one
    ``node, dof, node, dof, value`` line per entry, DOF numbers 1–6) for test fixtures."""
    a = sp.tril(as_sparse(matrix, str(path)), format="coo")
    order = np.lexsort((a.col, a.row))
    num = [DIRECTIONS.index(d) + 1 if d in DIRECTIONS else int(d) for d in dof_map.directions]
    with open(path, "w", encoding="ascii") as f:
        f.write("** written by vibroimpact.fe.matrices.write_abaqus_mtx\n")
        for i, j, v in zip(a.row[order], a.col[order], a.data[order], strict=True):
            f.write(f"{dof_map.nodes[i]},{num[i]}, {dof_map.nodes[j]},{num[j]}, {float(v)!r}\n")


# --------------------------------------------------------------------------------------------
# By suffix and content
# --------------------------------------------------------------------------------------------


def read_matrix(path: PathLike, key: str | None = None) -> sp.csr_array:
    """A matrix file by its suffix and content: ``.npy``/``.npz`` (:func:`read_numpy`),
    ``.mtx`` starting ``%%MatrixMarket`` (:func:`read_matrix_market`), another ``.mtx``
    (ABAQUS, :func:`read_abaqus_mtx`), ``.sti``/``.mas`` (CalculiX triplets)."""
    p = os.fspath(path)
    low = p.lower()
    if low.endswith((".npy", ".npz")):
        return read_numpy(p, key)
    if low.endswith((".sti", ".mas")):
        r, c, v = _read_triplets(p, p)
        return _symmetrize(r, c, v, int(max(r.max(), c.max())) + 1, p)
    head = _open_text(p)[:1]
    if head and head[0].lstrip().lower().startswith("%%matrixmarket"):
        return read_matrix_market(p)
    return read_abaqus_mtx(p)[0]


# --------------------------------------------------------------------------------------------
# A structure from a set of files (model files: [structure] kind = "matrices")
# --------------------------------------------------------------------------------------------

#: Matrix file formats: ``auto`` (by suffix and content, :func:`detect_format`), ``mtx``
#: (Matrix Market), ``npy``, ``npz``, ``calculix`` (``.sti``/``.mas``), ``abaqus`` (``.mtx``).
FORMATS: tuple[str, ...] = ("auto", "mtx", "npy", "npz", "calculix", "abaqus")

#: Suffixes of matrix files.
SUFFIXES: tuple[str, ...] = (".npy", ".mtx", ".npz", ".sti", ".mas")


def detect_format(path: PathLike) -> str:
    """The format of a matrix file: ``.npy``, ``.npz``; ``.sti``/``.mas``: ``calculix``;
    ``.mtx``: ``mtx`` if it starts ``%%MatrixMarket``, else ``abaqus``."""
    p = os.fspath(path)
    suffix = Path(p).suffix.lower()
    if suffix in (".npy", ".npz"):
        return suffix[1:]
    if suffix in (".sti", ".mas"):
        return "calculix"
    if suffix == ".mtx":
        head = next((x for x in _open_text(p) if x.strip()), "")
        return "mtx" if head.lstrip().lower().startswith("%%matrixmarket") else "abaqus"
    raise ModelError(
        f"{p!r}: suffix {suffix or '(none)'!r} is not valid; expected one of "
        f"{', '.join(SUFFIXES)} (or give the format)"
    )


def read_dof_map(value: PathLike | Sequence[str]) -> DofMap:
    """A DOF map from a ``.csv`` file (:meth:`DofMap.write_csv`), a CalculiX ``.dof`` file
    (:func:`read_calculix_dofs`) or a list of ``"node.direction"`` labels (``"12.x"``,
    ``"12.5"``, a layer ``"12.x@2"``; :meth:`DofMap.labels`)."""
    if isinstance(value, (str, os.PathLike)):
        p = os.fspath(value)
        if p.lower().endswith(".dof"):
            return read_calculix_dofs(p)
        if p.lower().endswith(".csv"):
            _open_text(p)  # a clear error for a missing file
            return DofMap.read_csv(p)
        raise ModelError(f"dof_map: {p!r} is not valid; expected a .csv or .dof file")
    nodes, dirs, layers = [], [], []
    for i, label in enumerate(value):
        m = re.fullmatch(r"\s*(-?\d+)\.(\w+)(?:@(\d+))?\s*", str(label))
        if m is None:
            raise ModelError(
                f"dof_map[{i}]: {label!r} is not valid; expected \"node.direction\" "
                "(\"12.x\" or \"12.1\"; a layer: \"12.x@2\")"
            )
        nodes.append(int(m.group(1)))
        dirs.append(m.group(2))
        layers.append(int(m.group(3) or 0))
    return DofMap(nodes, dirs, layers)


@dataclass(frozen=True)
class MatrixSet:
    """What :func:`read_matrix_files` read: the matrices by name (symmetric CSR, all n×n),
    the DOF map (given, or carried by the files; None if neither) and one error line per
    name that could not be read (``"<shown> ... is not valid; expected ..."``)."""

    matrices: dict[str, sp.csr_array]
    dof_map: DofMap | None
    errors: dict[str, str]


@dataclass
class _Pending:
    """A file parsed but not yet sized: 0-based triplets, or ABAQUS node-keyed entries."""

    rows: Any
    cols: Any
    vals: NDArray[np.float64]
    keys: list[tuple[Any, Any, float]] | None = None
    dof_map: Any = None  # set before sizing node-keyed entries


def _strip(message: str, path: str) -> str:
    for prefix in (f"{path!r}: ", f"{path}: "):
        if message.startswith(prefix):
            return message[len(prefix) :]
    return message


def read_matrix_files(
    sources: Mapping[str, Any],
    *,
    format: str = "auto",
    dof_map: DofMap | None = None,
    shown: Mapping[str, str] | None = None,
) -> MatrixSet:
    """Read the matrices ``sources`` (name -> a path or an array/scipy.sparse matrix) as one
    structure. ``format`` applies to every file (``auto``: :func:`detect_format` per file).

    The DOF map is ``dof_map`` if given (the files' own maps are then not read), else the
    CalculiX ``job.dof`` beside a ``.sti``/``.mas`` file, the ``dof_nodes``/``dof_directions``
    of an ``.npz`` archive, or the
    ``(node, DOF)`` pairs of the ABAQUS node-keyed files (sorted; their union, so a mass file
    without the massless DOFs still fits). The size is the map's, else the largest matrix's;
    a triplet file (CalculiX, ABAQUS) may stop short of it (its trailing rows are zero).
    An ``.npz`` archive of named arrays gives the array of the source's name
    (``mass``, ``stiffness``, ``damping``). ``shown``: how each source is named in errors."""
    if format not in FORMATS:
        raise ModelError(f"format: {format!r} is not valid; expected one of {', '.join(FORMATS)}")
    shown = dict(shown or {})
    errors: dict[str, str] = {}
    parsed: dict[str, Any] = {}
    found_maps: list[DofMap] = []
    for name, src in sources.items():
        label = shown.setdefault(name, repr(os.fspath(src)) if _is_path(src) else name)
        if not _is_path(src):
            parsed[name] = src
            continue
        p = os.fspath(src)
        try:
            fmt = detect_format(p) if format == "auto" else format
            carried = None if dof_map is not None else found_maps
            parsed[name] = _parse_file(p, fmt, name, carried)
        except ModelError as e:
            errors[name] = f"{label}: {_strip(str(e), p)}"
    if dof_map is None and found_maps:
        dof_map = found_maps[0]
    abaqus = [x for x in parsed.values() if isinstance(x, _Pending) and x.keys is not None]
    if dof_map is None and abaqus:
        keys = sorted({k for x in abaqus for e in x.keys or () for k in e[:2]})
        dof_map = DofMap([k[0] for k in keys], [k[1] for k in keys])
    for x in abaqus:
        x.dof_map = dof_map
    shaped = [k for k, x in parsed.items() if not isinstance(x, _Pending)]
    if dof_map is not None:
        n, ref = len(dof_map), "one row per DOF of the DOF map"
    elif shaped:
        n, ref = _size(parsed[shaped[0]]), f"the shape of {shown[shaped[0]]}"
    else:
        n, ref = max((_size(x) for x in parsed.values()), default=0), ""
    out: dict[str, sp.csr_array] = {}
    for name, x in parsed.items():
        try:
            out[name] = _sized(x, n, ref, shown[name])
        except ModelError as e:
            errors[name] = f"{shown[name]}: {_strip(str(e), shown[name])}"
    return MatrixSet(out, dof_map, errors)


def _is_path(src: Any) -> bool:
    return isinstance(src, (str, os.PathLike))


def _parse_file(p: str, fmt: str, name: str, found_maps: list[DofMap] | None) -> Any:
    """One matrix file; the DOF map it carries (job.dof beside CalculiX files, an .npz's)
    is appended to ``found_maps`` (None: a map was given, the files' own are not read)."""
    if fmt == "mtx":
        return read_matrix_market(p)
    if fmt == "npy":
        return _read_npy(p)
    if fmt == "npz":
        with np.load(p, allow_pickle=False) as z:
            files = set(z.files)
        if found_maps is not None and {"dof_nodes", "dof_directions"} <= files:
            found_maps.append(load_npz(p).dof_map)  # type: ignore[arg-type]
        return read_numpy(p, None if {"format", "shape"} <= files else name)
    if fmt == "calculix":
        dof = Path(p).with_suffix(".dof")
        if found_maps is not None and dof.is_file():
            found_maps.append(read_calculix_dofs(dof))
        r, c, v = _read_triplets(p, p)
        return _Pending(r, c, v)
    entries, by_node = _abaqus_entries(p)
    if by_node:
        return _Pending(None, None, np.array([e[2] for e in entries]), entries)
    return _Pending(
        np.array([e[0] - 1 for e in entries]), np.array([e[1] - 1 for e in entries]),
        np.array([e[2] for e in entries]),
    )


def _read_npy(p: str) -> Any:
    try:
        a = np.load(p, allow_pickle=False)
    except Exception as e:  # a user's file that does not parse is a mistake in the file
        raise ModelError(
            f"{p!r}: not a readable .npy matrix file ({' '.join(str(e).split())[:80]}); "
            "expected a .npy array"
        ) from None
    if a.dtype.kind not in "biuf":
        raise ModelError(f"{p!r}: a {a.dtype} array is not valid; expected a real matrix")
    return a


def _size(x: Any) -> int:
    """The number of rows of a matrix, or the largest equation number of triplets."""
    if isinstance(x, _Pending):
        return 0 if x.keys is not None else int(max(x.rows.max(), x.cols.max())) + 1
    shape = np.shape(x)
    return int(shape[0]) if len(shape) >= 1 else 1


def _sized(x: Any, n: int, ref: str, label: str) -> sp.csr_array:
    if not isinstance(x, _Pending):
        shape = x.shape if sp.issparse(x) else np.shape(x)
        a = as_sparse(x, label)
        if a.shape != (n, n):
            raise ModelError(f"shape {tuple(shape)} is not valid; expected shape ({n}, {n}), {ref}")
        return a
    if x.keys is not None:
        # the DOF map of node-keyed files is theirs, or the given one: look every key up
        rows, cols = [], []
        dof_map = x.dof_map
        for rk, ck, _ in x.keys:
            for key in (rk, ck):
                try:
                    dof_map.index(key[0], key[1])
                except ModelError:
                    raise ModelError(
                        f"node {key[0]} DOF {key[1]} is not valid; expected a node and DOF of "
                        "the DOF map"
                    ) from None
            rows.append(dof_map.index(*rk))
            cols.append(dof_map.index(*ck))
        return _symmetrize(np.array(rows), np.array(cols), x.vals, n, label)
    if _size(x) > n:
        raise ModelError(
            f"equation {_size(x)} is not valid; expected at most {n} ({ref or 'the DOF count'})"
        )
    return _symmetrize(x.rows, x.cols, x.vals, n, label)


def read_structure(
    mass: Any,
    stiffness: Any,
    damping: Any = None,
    *,
    format: str = "auto",
    dof_map: DofMap | PathLike | Sequence[str] | None = None,
) -> FEStructure:
    """An :class:`FEStructure` from matrix files of any format (or arrays), read as
    :func:`read_matrix_files` does; ``dof_map`` may also be a file or labels
    (:func:`read_dof_map`). Massless DOFs are kept (condense them with
    :meth:`FEStructure.condense_massless`)."""
    dm = dof_map if dof_map is None or isinstance(dof_map, DofMap) else read_dof_map(dof_map)
    sources = {"mass": mass, "stiffness": stiffness}
    if damping is not None:
        sources["damping"] = damping
    got = read_matrix_files(sources, format=format, dof_map=dm)
    if got.errors:
        name, line = next(iter(got.errors.items()))
        raise ModelError(f"structure.{name}: {line}")
    m = got.matrices
    return FEStructure(m["mass"], m["stiffness"], m.get("damping"), got.dof_map)
