"""Sweep parameters: a path to a numeric model parameter and its values, parsed from the
command line (``loads.0.frequency=5:50:400``), and applied to a model spec.

Paths name a number of the model (the dict of :meth:`vibroimpact.Model.to_spec`), with the
model file's names; ``gaps[0].law.restitution`` and ``gaps.0.law.restitution`` are the same:

==================================  ==========================================================
``structure.mass``                  mass of a single-DOF structure, kg (``structure.mass.i.j``:
                                    entry ``(i, j)`` and ``(j, i)`` of the matrix)
``structure.stiffness``             likewise, N/m
``structure.damping``               likewise, N·s/m
``structure.spin_speed``            spin speed Ω of a rotor, rad/s (its gyroscopic forces and
                                    unbalance loads follow; a run-up's start)
``structure.spin_speed_end``        a run-up's final spin speed, rad/s
``structure.run_up_time``           a run-up's duration, s
``gaps.G.clearance``                clearance of gap ``G``, m
``gaps.G.law.KEY``                  a number of gap ``G``'s contact law: ``stiffness``
                                    (N/mⁿ), ``exponent``, ``restitution``, ``damping`` …
``gaps.G.coefficients.J``           coefficient ``J`` of the gap coordinate
``loads.L.amplitude``               amplitude of load ``L``, N
``loads.L.frequency``               frequency of harmonic load ``L``, Hz
``loads.L.phase``                   phase of harmonic or unbalance load ``L``, rad
``loads.L.magnitude``               unbalance m·e of load ``L``, kg·m
``initial.displacement[.I]``        initial displacement of DOF ``I`` (no index: single DOF), m
``initial.velocity[.I]``            initial velocity, m/s
==================================  ==========================================================
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibroimpact.errors import ModelError

__all__ = ["Param", "apply", "canonical_path", "numeric_paths", "parse_param", "units_of"]

#: Units of the parameters by their last name.
_UNITS = {
    "mass": "kg",
    "stiffness": "N/m",
    "damping": "N s/m",
    "clearance": "m",
    "amplitude": "N",
    "frequency": "Hz",
    "phase": "rad",
    "displacement": "m",
    "velocity": "m/s",
    "restitution": "1",
    "exponent": "1",
    "coefficients": "1",
    "spin_speed": "rad/s",
    "spin_speed_end": "rad/s",
    "run_up_time": "s",
    "magnitude": "kg m",
}

_MATRICES = {"mass", "stiffness", "damping"}
#: The structure's numbers that are not matrices: a rotor's spin (keys of the spec).
_SPIN = ("spin_speed", "spin_speed_end", "run_up_time")
#: The numbers of a load, by kind.
_LOAD_NUMBERS = ("amplitude", "frequency", "phase", "magnitude")
_INITIAL = {"displacement": "x0", "velocity": "v0"}


def canonical_path(path: str) -> str:
    """``gaps[0].law.restitution`` → ``gaps.0.law.restitution`` (whitespace removed)."""
    p = re.sub(r"\[\s*(\d+)\s*\]", r".\1", path.strip())
    return ".".join(part.strip() for part in p.split(".") if part.strip() != "")


def units_of(path: str) -> str:
    """SI unit of the parameter at ``path`` (``"1"`` for dimensionless)."""
    parts = canonical_path(path).split(".")
    named = [p for p in parts if not p.isdigit()]
    if named and named[0] == "gaps" and named[-1] == "stiffness":
        return "N/m^n"
    if named and named[0] == "gaps" and named[-1] == "damping":
        return "N s/m^n"
    return _UNITS.get(named[-1], "") if named else ""


@dataclass(frozen=True)
class Param:
    """A swept parameter: ``path`` (see the module doc) and its ``values``."""

    path: str
    values: NDArray[np.float64]

    def __init__(self, path: str, values: Sequence[float] | NDArray[np.float64]) -> None:
        p = canonical_path(path)
        if not p:
            raise ModelError(f"--param: {path!r} is not valid; expected a parameter path such "
                             "as loads.0.frequency")
        v = np.atleast_1d(np.asarray(values, dtype=float)).ravel()
        if v.size == 0 or not np.all(np.isfinite(v)):
            raise ModelError(f"--param {p}: {values!r} is not valid; expected one or more "
                             "finite numbers")
        v.setflags(write=False)
        object.__setattr__(self, "path", p)
        object.__setattr__(self, "values", v)

    @property
    def units(self) -> str:
        return units_of(self.path)

    def __len__(self) -> int:
        return int(self.values.size)

    def to_json(self) -> dict[str, Any]:
        return {"path": self.path, "values": [float(x) for x in self.values]}

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Param) and other.path == self.path
                and np.array_equal(other.values, self.values))

    def __hash__(self) -> int:
        return hash((self.path, self.values.tobytes()))


_SPEC_HELP = "PATH=A:B:N (N values from A to B), PATH=A:B:N:log or PATH=V1,V2,..."


def parse_param(text: str) -> Param:
    """``loads.0.frequency=5:50:400`` (linear), ``…=1e-4:1e-2:50:log`` (logarithmic) or
    ``…=0.5,0.7,0.9`` (a list)."""
    path, sep, spec = text.partition("=")
    if not sep or not path.strip() or not spec.strip():
        raise ModelError(f"--param: {text!r} is not valid; expected {_SPEC_HELP}")
    spec = spec.strip()
    bad = ModelError(f"--param {canonical_path(path)}: {spec!r} is not valid; expected "
                     f"{_SPEC_HELP}")
    if ":" in spec:
        parts = [s.strip() for s in spec.split(":")]
        log = len(parts) == 4 and parts[3].lower() == "log"
        if len(parts) not in (3, 4) or (len(parts) == 4 and not log):
            raise bad
        try:
            a, b = float(parts[0]), float(parts[1])
            n = int(parts[2])
        except ValueError:
            raise bad from None
        if n < 1 or not (math.isfinite(a) and math.isfinite(b)):
            raise bad
        if log:
            if a <= 0 or b <= 0:
                raise ModelError(f"--param {canonical_path(path)}: {spec!r} is not valid; "
                                 "expected A > 0 and B > 0 for log spacing")
            values = np.geomspace(a, b, n)
        else:
            values = np.linspace(a, b, n)
        return Param(path, values)
    try:
        values = [float(s) for s in spec.split(",") if s.strip() != ""]
    except ValueError:
        raise bad from None
    if not values:
        raise bad
    return Param(path, values)


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def numeric_paths(spec: Mapping[str, Any]) -> list[str]:
    """Every parameter path of ``spec`` that a sweep can set."""
    out: list[str] = []
    for name in sorted(_MATRICES):
        if np.shape(spec[name]) == (1, 1):
            out.append(f"structure.{name}")
        else:
            out.append(f"structure.{name}.I.J")
    rotor = (spec.get("gyroscopic") is not None or bool(spec.get("spin_speed"))
             or any(ld["kind"] == "unbalance" for ld in spec.get("loads", [])))
    out.extend(f"structure.{k}" for k in _SPIN if rotor and _is_number(spec.get(k)))
    for key, name in (("x0", "displacement"), ("v0", "velocity")):
        out.append(f"initial.{name}" if np.asarray(spec[key]).size == 1
                   else f"initial.{name}.I")
    for i, g in enumerate(spec.get("gaps", [])):
        out.append(f"gaps.{i}.clearance")
        out.extend(f"gaps.{i}.law.{k}" for k, v in g["law"].items() if _is_number(v))
        out.append(f"gaps.{i}.coefficients.J")
    for i, ld in enumerate(spec.get("loads", [])):
        out.extend(f"loads.{i}.{k}" for k in _LOAD_NUMBERS if _is_number(ld.get(k)))
    return out


def _fail(path: str, spec: Mapping[str, Any], why: str) -> ModelError:
    return ModelError(f"--param {path}: {why}; expected one of "
                      + ", ".join(numeric_paths(spec)))


def _index(part: str, size: int, path: str, spec: Mapping[str, Any]) -> int:
    if not part.isdigit() or int(part) >= size:
        raise _fail(path, spec, f"{part!r} is not an index below {size}")
    return int(part)


def apply(spec: dict[str, Any], path: str, value: float) -> dict[str, Any]:
    """A copy of ``spec`` with the parameter at ``path`` set to ``value`` (only the dicts,
    lists and arrays on the path are copied). Raises :class:`ModelError` naming the path and
    the paths that exist if ``path`` is not a numeric parameter of the model."""
    parts = canonical_path(path).split(".")
    value = float(value)
    out = dict(spec)
    head = parts[0]
    if head == "structure" and len(parts) == 2 and parts[1] in _SPIN:
        if not _is_number(spec.get(parts[1])):
            raise _fail(path, spec, f"the structure has no {parts[1]} (spin_speed_end and "
                        "run_up_time: a run-up, spin_profile = 'linear')")
        out[parts[1]] = value
        return out
    if head == "structure":
        if len(parts) < 2 or parts[1] not in _MATRICES:
            raise _fail(path, spec, "not a structure matrix")
        src = spec[parts[1]]
        a = src.tolil() if sp.issparse(src) else np.array(src, dtype=float)
        n = a.shape[0]
        if len(parts) == 2:
            if n != 1:
                raise _fail(path, spec, f"the structure has {n} DOFs; name an entry I.J")
            i = j = 0
        elif len(parts) == 4:
            i, j = (_index(p, n, path, spec) for p in parts[2:])
        else:
            raise _fail(path, spec, "not a matrix entry")
        a[i, j] = a[j, i] = value
        out[parts[1]] = sp.csr_array(a) if sp.issparse(src) else a
        return out
    if head == "initial":
        if len(parts) < 2 or parts[1] not in _INITIAL:
            raise _fail(path, spec, "not an initial state")
        key = _INITIAL[parts[1]]
        x = np.array(spec[key], dtype=float)
        if len(parts) == 2:
            if x.size != 1:
                raise _fail(path, spec, f"the structure has {x.size} DOFs; name a DOF")
            i = 0
        elif len(parts) == 3:
            i = _index(parts[2], x.size, path, spec)
        else:
            raise _fail(path, spec, "not an initial-state entry")
        x[i] = value
        out[key] = x
        return out
    if head in ("gaps", "loads"):
        items = list(spec.get(head, []))
        if len(parts) < 3:
            raise _fail(path, spec, f"incomplete {head} path")
        k = _index(parts[1], len(items), path, spec)
        item = dict(items[k])
        rest = parts[2:]
        if head == "gaps" and rest[0] == "law" and len(rest) == 2:
            law = dict(item["law"])
            if not _is_number(law.get(rest[1])):
                raise _fail(path, spec, f"gap {k}'s {law.get('kind')} law has no number "
                            f"{rest[1]!r}")
            law[rest[1]] = value
            item["law"] = law
        elif head == "gaps" and rest[0] == "coefficients" and len(rest) == 2:
            coeffs = list(item["coefficients"])
            coeffs[_index(rest[1], len(coeffs), path, spec)] = value
            item["coefficients"] = coeffs
        elif len(rest) == 1 and rest[0] in (("clearance",) if head == "gaps"
                                            else _LOAD_NUMBERS):
            if not _is_number(item.get(rest[0])):
                raise _fail(path, spec, f"{head[:-1]} {k} has no {rest[0]}")
            item[rest[0]] = value
        else:
            raise _fail(path, spec, "not a numeric parameter")
        items[k] = item
        out[head] = items
        return out
    raise _fail(path, spec, "not a model parameter")
