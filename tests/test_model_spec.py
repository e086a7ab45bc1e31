"""The model's typed crossing into the core (``_core.ModelSpec``): a run of the typed spec
equals a run of the spec dict bit for bit, and ``with_value`` (the one implementation of the
``sweep --param`` / ``continue --param`` paths) sets exactly the number a path names: its run
equals the run of the dict with that number set here, by hand."""

from __future__ import annotations

import copy
import pickle
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.sparse as sp
import vibroimpact as vi
from vibroimpact import _core
from vibroimpact.errors import ModelError
from vibroimpact.simulate import _run_core
from vibroimpact.sweeps.grid import apply, numeric_paths

MODELS = Path(__file__).resolve().parents[1] / "examples" / "models"

#: The models: an SDOF impact oscillator, a Jeffcott rotor in a radial gap (and its run-up),
#: a beam of finite elements and a model of FE matrices (both CSR); steps per test run.
CASES = {
    "sdof": ("impact_oscillator", 400),
    "radial-gap-rotor": ("jeffcott_rub", 400),
    "run-up": ("jeffcott_runup", 400),
    "beam": ("hollow_shaft", 60),
    "matrices-csr": ("lumped_cantilever", 60),
}


def _case(name: str) -> tuple[vi.Model, float, int]:
    stem, steps = CASES[name]
    mf = vi.load_model(MODELS / f"{stem}.toml")
    return mf.model, float(mf.dt), steps


def _run(model_part: dict[str, Any], dt: float, steps: int) -> dict[str, Any] | str:
    """The core's run of ``model_part`` (the model's fields, or ``{"model": ModelSpec}``)
    with Newmark: its histories and impacts, or the error it was refused with."""
    job = dict(model_part, **vi.Newmark()._run_spec(), t_end=steps * dt, dt=dt, every=1,
               record_dofs=None)
    try:
        return _run_core(job, on_rows=None, chunk_rows=None, progress=None)[0]
    except ModelError as e:
        return str(e)


def _assert_same_run(a: dict[str, Any] | str, b: dict[str, Any] | str) -> None:
    assert type(a) is type(b), (a, b)
    if isinstance(a, str):
        assert a == b
        return
    assert isinstance(b, dict)
    for key in ("time", "displacement", "velocity"):
        assert np.array_equal(a[key], b[key]), key
    assert np.array_equal(a["impacts"]["t_start"], b["impacts"]["t_start"])


def _set_by_hand(spec: dict[str, Any], path: str, value: float) -> dict[str, Any]:
    """``spec`` with the number at ``path`` (indices given) set: the test's own reading of
    the paths (docs/sweeps.md)."""
    out = copy.deepcopy({k: v for k, v in spec.items()})
    p = path.split(".")
    if p[0] == "structure" and p[1] in ("mass", "damping", "stiffness"):
        i, j = (int(p[2]), int(p[3])) if len(p) == 4 else (0, 0)
        a = out[p[1]]
        a = a.tolil() if sp.issparse(a) else np.array(a, dtype=float)
        a[i, j] = a[j, i] = value
        out[p[1]] = sp.csr_array(a) if sp.issparse(spec[p[1]]) else a
    elif p[0] == "structure":
        out[p[1]] = value
    elif p[0] == "initial":
        key = {"displacement": "x0", "velocity": "v0"}[p[1]]
        out[key] = np.array(out[key], dtype=float)
        out[key][int(p[2]) if len(p) == 3 else 0] = value
    elif p[0] == "gaps" and p[2] == "law":
        out["gaps"][int(p[1])]["law"][p[3]] = value
    elif p[0] == "gaps" and p[2] == "coefficients":
        out["gaps"][int(p[1])]["coefficients"][int(p[3])] = value
    else:
        out[p[0]][int(p[1])][p[2]] = value
    return out


def _number_at(spec: dict[str, Any], path: str) -> float:
    """The number at ``path`` of a spec dict (the test's own reading)."""
    p = path.split(".")
    if p[0] == "structure" and p[1] in ("mass", "damping", "stiffness"):
        i, j = (int(p[2]), int(p[3])) if len(p) == 4 else (0, 0)
        return float(spec[p[1]][i, j])
    if p[0] == "structure":
        return float(spec[p[1]])
    if p[0] == "initial":
        key = {"displacement": "x0", "velocity": "v0"}[p[1]]
        return float(np.asarray(spec[key])[int(p[2]) if len(p) == 3 else 0])
    if p[0] == "gaps" and p[2] == "law":
        return float(spec["gaps"][int(p[1])]["law"][p[3]])
    if p[0] == "gaps" and p[2] == "coefficients":
        return float(spec["gaps"][int(p[1])]["coefficients"][int(p[3])])
    return float(spec[p[0]][int(p[1])][p[2]])


def _concrete(path: str, n: int) -> str:
    """A listed path with its placeholders filled: the last DOF (I, J: the last diagonal
    entry, a coupling entry for a model of several DOFs) and coefficient 0."""
    path = path.replace("coefficients.J", "coefficients.0")
    if path.endswith(".I.J"):
        return path.replace("I.J", f"{n - 1}.{max(n - 2, 0)}")
    return path.replace(".I", f".{n - 1}")


@pytest.mark.filterwarnings("ignore:gap 0. dt")  # the short test runs do not resolve contacts
@pytest.mark.parametrize("name", list(CASES))
def test_the_typed_spec_runs_as_the_dict_bit_for_bit(name: str) -> None:
    model, dt, steps = _case(name)
    spec = model.to_spec()
    typed = _core.ModelSpec(spec)
    by_dict = _run(spec, dt, steps)
    assert isinstance(by_dict, dict) and by_dict["displacement"].shape[0] == steps + 1
    _assert_same_run(_run({"model": typed}, dt, steps), by_dict)
    # its dict and its pickle give back the same model
    _assert_same_run(_run({"model": _core.ModelSpec(typed.to_dict())}, dt, steps), by_dict)
    _assert_same_run(_run({"model": pickle.loads(pickle.dumps(typed))}, dt, steps), by_dict)
    # the API's run (the kept ModelSpec of a dense model, a fresh one of a sparse model)
    result = vi.simulate(model, t_end=steps * dt, dt=dt, method=vi.Newmark())
    assert np.array_equal(result.displacement, by_dict["displacement"])


@pytest.mark.parametrize("name", list(CASES))
def test_every_listed_path_sets_its_number_as_by_hand(name: str) -> None:
    """Each path the model lists (``numeric_paths``) is set by ``with_value`` where the
    test's own reading of the path puts it, and the run equals the run of the dict set by
    hand bit for bit (the small models: every path; the FE models: one of each kind)."""
    model, dt, steps = _case(name)
    spec = model.to_spec()
    typed = _core.ModelSpec(spec)
    paths = typed.numeric_paths()
    assert paths == numeric_paths(spec)
    kinds: set[str] = set()
    for listed in paths:
        path = _concrete(listed, model.n_dof)
        old = _number_at(spec, path)
        value = 0.8 * old if old != 0 else 1e-3
        moved = typed.with_value(path, value)
        assert _number_at(moved.to_dict(), path) == value, path
        assert _number_at(apply(spec, path, value), path) == value, path
        assert _number_at(typed.to_dict(), path) == old, path  # the original is kept
        kind = re.sub(r"\d+", "N", listed)
        if model.n_dof > 2 and kind in kinds:
            continue
        kinds.add(kind)
        _assert_same_run(_run({"model": moved}, dt, steps),
                         _run(_set_by_hand(spec, path, value), dt, steps))


def test_a_sparse_entry_set_to_zero_is_not_stored_and_a_new_one_is() -> None:
    model, _, _ = _case("beam")
    spec = model.to_spec()
    k = sp.csr_array(spec["stiffness"])
    zero = next((i, j) for i in range(k.shape[0]) for j in range(k.shape[0])
                if i != j and k[i, j] == 0)
    i, j = zero
    moved = _core.ModelSpec(spec).with_value(f"structure.stiffness.{i}.{j}", 5.0).to_dict()
    assert moved["stiffness"].nnz == k.nnz + 2 and moved["stiffness"][j, i] == 5.0
    back = _core.ModelSpec(moved).with_value(f"structure.stiffness.{i}.{j}", 0.0).to_dict()
    assert back["stiffness"].nnz == k.nnz
    assert (back["stiffness"] != k).nnz == 0


@pytest.mark.parametrize("path, why", [
    ("gaps.0.nope", "not a numeric parameter"),
    ("gaps.3.clearance", "'3' is not an index below 1"),
    ("loads.0.magnitude", "load 0 has no magnitude"),
    ("structure.mass.0", "not a matrix entry"),
    ("structure.spin_speed_end", "the structure has no spin_speed_end"),
    ("initial.velocity.0.1", "not an initial-state entry"),
    ("solver.dt", "not a model parameter"),
])
def test_an_unknown_path_is_refused_in_one_line_listing_the_valid_ones(path: str,
                                                                       why: str) -> None:
    model, _, _ = _case("sdof")
    typed = _core.ModelSpec(model.to_spec())
    with pytest.raises(ModelError) as e:
        typed.with_value(path, 1.0)
    message = str(e.value)
    assert "\n" not in message
    assert message.startswith(f"--param {path}: {why}")
    assert message.endswith("; expected one of " + ", ".join(typed.numeric_paths()))


def test_a_bad_value_is_refused_at_the_check_naming_its_field() -> None:
    model, _, _ = _case("sdof")
    typed = _core.ModelSpec(model.to_spec()).with_value("gaps.0.clearance", -1.0)
    with pytest.raises(ModelError, match=re.escape(
            "gaps[0].clearance: -1 is not valid; expected a clearance >= 0 in m")):
        typed.check()


def test_the_load_frequencies_follow_the_swept_numbers() -> None:
    rotor, _, _ = _case("radial-gap-rotor")
    spec = rotor.to_spec()
    typed = _core.ModelSpec(spec).with_value("structure.spin_speed", 300.0)
    assert typed.load_frequencies() == [300.0 / (2 * np.pi)]
    sdof, _, _ = _case("sdof")
    typed = _core.ModelSpec(sdof.to_spec()).with_value("loads.0.frequency", 7.5)
    assert typed.load_frequencies() == [7.5]
