"""Absurd numbers are refused before the run, and no library's warning text reaches the
terminal (issue 18, item A).

A state or parameter whose energy, force or time scale is not a finite double is one line
naming the field (exit code 2, no output file): checked for the cases of the issue, at the
boundary against the energy computed here in Python floats, through the Python API, over the
whole bad-input corpus and over a few hundred seeded random mutations of a good model file
(run in-process with every warning turned into an error), and in a few real subprocesses."""

from __future__ import annotations

import contextlib
import copy
import io
import logging
import math
import random
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
import vibroimpact as vi
from vibroimpact.cli import main as cli_main
from vibroimpact.errors import ContactResolutionWarning, ModelError

ROOT = Path(__file__).resolve().parents[1]
BAD_FILES = sorted((ROOT / "tests" / "bad_models").glob("*.toml"))

#: Library warning text that must never reach stderr.
FORBIDDEN = ("Warning:", "site-packages", "RuntimeWarning", "Traceback")

#: A good model: one mass on a spring between two walls, thrown and shaken; 20 steps.
GOOD: dict[str, Any] = {
    "schema_version": 1,
    "structure": {"kind": "sdof", "mass": 100.0, "stiffness": 1e3, "damping": 1.0},
    "gaps": [{"dof": 0, "clearance": 0.005, "side": "both",
              "law": {"kind": "lankarani-nikravesh", "stiffness": 1.5e11, "exponent": 1.5,
                      "restitution": 0.9}}],
    "initial": {"displacement": 0.001, "velocity": 8.0},
    "loads": [{"kind": "harmonic", "dof": 0, "amplitude": 10.0, "frequency": 50.0}],
    "solver": {"method": "newmark", "dt": 1e-6, "t_end": 2e-5},
    "output": {"every": 1},
}


def _with(changes: dict[str, Any], base: dict[str, Any] = GOOD) -> dict[str, Any]:
    """``base`` with ``changes`` merged in (tables recursively; ``[[arrays]]`` by their first
    table)."""
    out = copy.deepcopy(base)
    for key, value in changes.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _with(value, out[key])
        elif isinstance(value, dict) and isinstance(out.get(key), list):
            out[key][0] = _with(value, out[key][0])
        else:
            out[key] = value
    return out


def _run(argv: list[str]) -> tuple[int, str]:
    """``vibroimpact ARGV`` in this process with every warning an error: exit code, stderr."""
    err = io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stderr(err), \
            contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("error")
        code = cli_main(argv)
    return code, err.getvalue()


def _run_doc(folder: Path, doc: dict[str, Any]) -> tuple[int, str, Path]:
    model = folder / "model.toml"
    model.write_text(tomli_w.dumps(doc))
    out = folder / "out.nc"
    out.unlink(missing_ok=True)
    code, err = _run(["run", str(model), "-q", "-o", str(out)])
    return code, err, out


def _assert_clean(err: str) -> None:
    for text in FORBIDDEN:
        assert text not in err, err


# ------------------------------------------------------------------------------------------
# The cases of the issue: one line naming the field, exit code 2, no file
# ------------------------------------------------------------------------------------------

REFUSED = {
    "displacement_1e308": (
        {"initial": {"displacement": 1e308}},
        "initial.displacement = 1e+308: the strain energy 1/2 x^T K x is not a finite number "
        "(overflows a double); expected a displacement whose energy is finite "
        "(structure.stiffness up to 1000 N/m)"),
    "displacement_1e308_without_spring": (
        {"structure": {"stiffness": 0.0}, "initial": {"displacement": 1e308}},
        "initial.displacement = 1e+308: the contact force of gaps[0] (lankarani-nikravesh) at "
        "the initial penetration 1e+308 m"),
    "velocity_1e300": (
        {"initial": {"velocity": 1e300}},
        "initial.velocity = 1e+300: the kinetic energy 1/2 v^T M v is not a finite number "
        "(overflows a double); expected a speed whose energy is finite"),
    "strain_energy": (
        {"structure": {"stiffness": 1e308}, "initial": {"displacement": 2.0},
         "gaps": {"clearance": 10.0}},
        "initial.displacement = 2: the strain energy 1/2 x^T K x is not a finite number"),
    "law_stiffness_at_penetration": (
        {"gaps": {"law": {"stiffness": 1e308}}, "initial": {"displacement": 2.0}},
        "initial.displacement = 2: the contact force of gaps[0]"),
    "structure_stiffness_over_mass": (
        {"structure": {"mass": 1e-300, "stiffness": 1e300}, "initial": {"displacement": 0.0}},
        "structure.stiffness = 1e+300: the squared frequency K_ii / M_ii with structure.mass "
        "1e-300 kg is not a finite number"),
    "load_amplitude": (
        {"loads": {"amplitude": 1e308}},
        "loads[0].amplitude = 1e+308: the energy 1/2 (F t_end)^2 / m of its impulse over the "
        "run"),
    "contact_period": (
        {"structure": {"mass": 1e-300, "stiffness": 0.0, "damping": 0.0},
         "gaps": [{"dof": 0, "law": {"kind": "hertz", "stiffness": 1e308, "exponent": 1.0}}],
         "initial": {"displacement": 0.0, "velocity": 1e150}, "loads": []},
        "gaps[0].law: the estimated contact period 2 pi sqrt(m_eff / k) = 0 s"),
    "steps": (
        {"solver": {"dt": 1e-300}},
        "solver.dt = 1e-300: t_end / dt = 2e+295 steps (t_end = 2e-05 s) is more than 1e+10"),
}


@pytest.mark.parametrize("name", list(REFUSED))
def test_absurd_number_is_one_line_naming_the_field(name: str, tmp_path: Path) -> None:
    changes, message = REFUSED[name]
    code, err, out = _run_doc(tmp_path, _with(changes))
    assert code == 2, err
    assert err.startswith(f"vibroimpact: error: {message}"), err
    assert err.count("\n") == 1 and "expected" in err, err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["model.toml"]


def test_table_load_scale_whose_force_overflows(tmp_path: Path) -> None:
    (tmp_path / "force.csv").write_text("0, 0\n1, 1e10\n")
    doc = _with({"loads": [{"kind": "table", "dof": 0, "file": "force.csv", "scale": 1e300}]})
    code, err, out = _run_doc(tmp_path, doc)
    assert code == 2 and not out.exists(), err
    assert err.startswith("vibroimpact: error: loads[0].scale = 1e+300: the largest force "
                          "scale * |F| (|F| up to 1e+10 N) is not a finite number"), err


@pytest.mark.parametrize("velocity", [1e150, 1e153, 2e154, 1e160, 1e300])
def test_kinetic_energy_boundary_is_that_of_a_double(velocity: float) -> None:
    """Refused exactly when 1/2 m v² overflows (computed here in Python floats), far from the
    rounding at the boundary (5e307 J at 1e153 m/s, 2e310 J at 2e154 m/s)."""
    overflows = not math.isfinite(0.5 * 100.0 * velocity * velocity)
    structure = vi.Structure.sdof(mass=100.0)
    if overflows:
        with pytest.raises(ModelError, match=r"^initial\.velocity = .*kinetic energy"):
            vi.Model(structure, initial_velocity=velocity)
    else:
        vi.Model(structure, initial_velocity=velocity)


# ------------------------------------------------------------------------------------------
# The Python API refuses the same, without warnings
# ------------------------------------------------------------------------------------------


def _law_model(**changes: Any) -> vi.Model:
    args: dict[str, Any] = {
        "structure": vi.Structure.sdof(mass=100.0),
        "gaps": [vi.Gap(dof=0, clearance=0.005, side="both",
                        law=vi.contact.Hertz(stiffness=1.5e11))],
        "initial_velocity": 8.0,
    }
    args.update(changes)
    return vi.Model(**args)


@pytest.mark.filterwarnings("error")
def test_api_refuses_absurd_states_and_parameters() -> None:
    with pytest.raises(ModelError, match=r"^initial\.velocity = 1e\+300: the kinetic energy"):
        _law_model(initial_velocity=1e300)
    with pytest.raises(ModelError, match=r"^initial\.displacement = 1e\+308: the contact force"):
        _law_model(initial_displacement=1e308)
    with pytest.raises(ModelError, match=r"^structure\.stiffness = 1e\+300: the squared"):
        vi.Structure.sdof(mass=1e-300, stiffness=1e300)
    with pytest.raises(ModelError, match=r"^load\.scale = 1e\+300: the largest force"):
        vi.TableLoad(dof=0, time=(0.0, 1.0), force=(0.0, 1e10), scale=1e300)
    loaded = _law_model(loads=[vi.HarmonicLoad(dof=0, amplitude=1e308, frequency=5.0)])
    with pytest.raises(ModelError, match=r"^loads\[0\]\.amplitude = 1e\+308: the energy"):
        vi.simulate(loaded, t_end=1e-4, dt=1e-6)
    with pytest.raises(ModelError, match=r"^solver\.dt = 1e-300: t_end / dt"):
        vi.simulate(_law_model(), t_end=1e-4, dt=1e-300)
    tiny = _law_model(structure=vi.Structure.sdof(mass=1e-300), initial_velocity=1e150,
                      gaps=[vi.Gap(dof=0, law=vi.contact.Hertz(stiffness=1e308, exponent=1.0))])
    with pytest.raises(ModelError, match=r"^gaps\[0\]\.law: the estimated contact period"):
        vi.simulate(tiny, t_end=1e-4, dt=1e-6)
    # the same loads at a sane amplitude run
    fine = _law_model(loads=[vi.HarmonicLoad(dof=0, amplitude=1e3, frequency=5.0)])
    assert vi.simulate(fine, t_end=1e-4, dt=1e-6).complete


# ------------------------------------------------------------------------------------------
# No library warning text on stderr: the bad-input corpus, random mutations, the terminal
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("path", BAD_FILES, ids=[f.stem for f in BAD_FILES])
def test_bad_corpus_stderr_has_no_library_text(path: Path, tmp_path: Path) -> None:
    out = tmp_path / "out.nc"
    code, err = _run(["run", str(path), "-o", str(out)])
    assert code == 2 and not out.exists(), err
    _assert_clean(err)
    assert all(line.startswith("vibroimpact: error: ") for line in err.splitlines()), err


#: What a mutation puts in place of a value.
EXTREMES: tuple[Any, ...] = (
    0, 0.0, -1, -1.0, 0.5, 1e10, 1e100, 1e150, -1e150, 1e300, 1e308, -1e308, 1e-100, 1e-300,
    1e-308, 5e-324, math.nan, math.inf, -math.inf, "nan", "1e308", "text", 2**63 - 1, -(2**63),
    True, [], {}, [1e308, 1.0],
)
MUTATIONS = 300


def _leaves(doc: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    if isinstance(doc, dict):
        return [p for k, v in doc.items() for p in _leaves(v, (*path, k))]
    if isinstance(doc, list) and doc and isinstance(doc[0], dict):
        return [p for i, v in enumerate(doc) for p in _leaves(v, (*path, i))]
    return [path]


def _mutant(rng: random.Random) -> dict[str, Any]:
    """GOOD with one to three values set to extremes or dropped (and sometimes DOP853 or a
    linear law), its time span kept short."""
    doc = copy.deepcopy(GOOD)
    if rng.random() < 0.3:
        doc["solver"]["method"] = "dop853"
    if rng.random() < 0.2:
        doc["gaps"][0]["law"] = {"kind": "hertz", "stiffness": 1e9, "exponent": 1.0}
    for _ in range(rng.choice((1, 1, 2, 3))):
        path = rng.choice(_leaves(doc))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        if rng.random() < 0.1:
            del parent[path[-1]]
        else:
            parent[path[-1]] = rng.choice(EXTREMES)
    solver = doc.get("solver")
    if isinstance(solver, dict) and solver.get("method") == "dop853":
        t_end = solver.get("t_end")  # no long adaptive run: fixed steps are capped at 1e10
        if not (isinstance(t_end, float) and 0 < t_end <= GOOD["solver"]["t_end"]):
            solver["method"] = "newmark"
    return doc


def test_random_mutations_are_refused_or_run_without_library_text(tmp_path: Path) -> None:
    rng = random.Random(18)
    codes: dict[int, int] = {}
    for i in range(MUTATIONS):
        doc = _mutant(rng)
        code, err, out = _run_doc(tmp_path, doc)
        codes[code] = codes.get(code, 0) + 1
        where = f"mutation {i}: {doc}\n{err}"
        _assert_clean(err)
        assert code in (0, 2, 3), where
        if code == 2:
            assert not out.exists(), where
            assert all(line.startswith("vibroimpact: error: ")
                       for line in err.splitlines()), where
    # the mutations exercise all three outcomes
    assert codes.get(0, 0) >= 20 and codes.get(2, 0) >= 100 and codes.get(3, 0) >= 1, codes


def test_escaped_warnings_are_printed_as_our_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    """A warning that escapes (a library's, or ours) and a library's log record become
    ``vibroimpact: warning: ...`` lines, without Python's file:line: Category: form."""
    from vibroimpact.cli import run

    def handler(args: Any) -> int:
        with np.errstate(over="warn"):
            np.array([1e308]) * 10.0
        warnings.warn("gap 0: a contact message", ContactResolutionWarning, stacklevel=1)
        logging.getLogger("somelibrary").warning("a library's\nlog record")
        return 0

    monkeypatch.setattr(run, "main", handler)
    err = io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stderr(err):
        warnings.simplefilter("always")
        assert cli_main(["run", "x.toml"]) == 0
    lines = err.getvalue().splitlines()
    assert lines == [
        f"vibroimpact: warning: a computation in {__name__} reported a problem (overflow "
        "encountered in multiply); the results may be affected: please report it",
        "vibroimpact: warning: gap 0: a contact message",
        "vibroimpact: warning: somelibrary: a library's log record",
    ]


@pytest.mark.parametrize("doc", [
    _with({"initial": {"velocity": 1e300}}),
    _with({"initial": {"displacement": 1e308}}),
    _with({"gaps": {"clearance": 1e300}, "solver": {"t_end": 1e150}}),
], ids=["velocity", "displacement", "clearance_and_t_end"])
def test_terminal_path(doc: dict[str, Any], tmp_path: Path) -> None:
    """The real command in a subprocess, with Python's default warning filters."""
    model = tmp_path / "model.toml"
    model.write_text(tomli_w.dumps(doc))
    proc = subprocess.run(
        [sys.executable, "-m", "vibroimpact", "run", str(model), "-o", str(tmp_path / "o.nc")],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("vibroimpact: error: ") and proc.stderr.count("\n") == 1
    _assert_clean(proc.stderr)
    assert not (tmp_path / "o.nc").exists()


def test_spectrum_of_a_body_at_rest_plots_without_warning(tmp_path: Path) -> None:
    """An all-zero spectrum gets a linear axis (matplotlib warns that it cannot log-scale)."""
    rest = _with({"initial": {"displacement": 0.0, "velocity": 0.0}, "loads": []})
    code, err, out = _run_doc(tmp_path, rest)
    assert code == 0, err
    png = tmp_path / "spectrum.png"
    code, err = _run(["plot", str(out), "--kind", "spectrum", "-o", str(png)])
    assert code == 0 and err == "" and png.stat().st_size > 0, err


@pytest.mark.parametrize("argv", [
    ["impact", "--law", "hertz", "--stiffness", "1e9", "--mass", "1", "--velocity", "1e-300"],
    ["impact", "--law", "hertz", "--stiffness", "1e9", "--mass", "1e-300", "--velocity",
     "1e300"],
    ["laws", "--restitution", "0.5", "--stiffness", "1e9", "--mass", "1e300", "--velocity",
     "1e300"],
], ids=["impact_slow", "impact_light_fast", "laws_heavy_fast"])
def test_impact_tools_refuse_absurd_impacts(argv: list[str]) -> None:
    code, err = _run(argv)
    assert code == 2 and err.startswith("vibroimpact: error: ") and err.count("\n") == 1, err
    assert "is not a finite number" in err or "are not finite numbers" in err, err
