"""Per-DOF units: rotations of beams and of FE matrices with a DOF map are in rad (rad/s,
rad/s²), translations in m, through the structure (``Structure.dof_units``), static
condensation and recovery, Craig–Bampton, the result (``dof_unit`` coordinate, ``units``
attributes), CSV headers, NetCDF files (in memory and streamed) and plot axes.

Independent check that a DOF labelled ``rad`` holds a rotation: the static tip deflection and
tip slope of a cantilever under a tip force ``P`` (Euler–Bernoulli, exact at the nodes for
cubic elements): ``x = P L³ / 3EI`` (m) and ``θ = P L² / 2EI`` (rad, the slope ``dx/dz``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib
import numpy as np
import pytest
import scipy.sparse as sp
import vibroimpact as vi
import xarray as xr
from vibroimpact import fe, plotting
from vibroimpact.cli import main as cli_main
from vibroimpact.errors import ModelError
from vibroimpact.io import load_model
from vibroimpact.io import results_file as rf

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
LENGTH, ELEMENTS, DIAMETER, E = 1.0, 4, 0.02, 2.0e11  # m, -, m, Pa
EI = E * math.pi * DIAMETER**4 / 64  # N·m²


def cantilever(dofs_per_node: int = 2) -> fe.Beam:
    return fe.Beam(length=LENGTH, elements=ELEMENTS, section=fe.Section.circle(DIAMETER),
                   material=fe.Material(youngs_modulus=E, poisson=0.3, density=7800.0),
                   theory="euler-bernoulli", dofs_per_node=dofs_per_node,
                   supports=[fe.Support(node="start")])


@pytest.fixture(scope="module")
def beam() -> fe.Beam:
    return cantilever()


@pytest.fixture(scope="module")
def beam_model(beam: fe.Beam) -> vi.Model:
    """The cantilever rattling in stops 0.1 mm off its tip, driven at the tip."""
    law = vi.contact.Hertz(stiffness=1e10)
    return beam.model([beam.gap(law, node="end", direction="x", clearance=1e-4)],
                      [beam.load(vi.HarmonicLoad, nodes=["end"], direction="x",
                                 amplitude=50.0, frequency=40.0)])


@pytest.fixture(scope="module")
def beam_result(beam_model: vi.Model) -> vi.Result:
    return vi.simulate(beam_model, t_end=0.02, dt=1e-5)


def test_a_rad_dof_of_a_beam_holds_the_slope(beam: fe.Beam) -> None:
    units = beam.structure.dof_units
    assert units == tuple("rad" if d == "ry" else "m" for d in beam.dof_map.directions)
    assert units.count("rad") == units.count("m") == ELEMENTS
    p = 100.0  # N at the tip, along x
    k = beam.structure.stiffness
    f = np.zeros(beam.n_dof)
    f[beam.dof(node="end", direction="x")] = p
    x = np.linalg.solve(k.toarray() if sp.issparse(k) else k, f)
    tip_x, tip_ry = beam.dof(node="end", direction="x"), beam.dof(node="end", direction="ry")
    assert units[tip_x] == "m" and units[tip_ry] == "rad"
    assert x[tip_x] == pytest.approx(p * LENGTH**3 / (3 * EI), rel=1e-10)
    assert x[tip_ry] == pytest.approx(p * LENGTH**2 / (2 * EI), rel=1e-10)


def test_a_3d_beam_has_rad_on_rx_ry_rz() -> None:
    b = cantilever(dofs_per_node=6)
    expected = {"x": "m", "y": "m", "z": "m", "rx": "rad", "ry": "rad", "rz": "rad"}
    assert b.structure.dof_units == tuple(expected[d] for d in b.dof_map.directions)


def test_structure_dof_units_default_and_errors() -> None:
    assert vi.Structure.sdof(mass=1.0).dof_units == ("m",)
    assert vi.Structure(np.eye(2), dof_units=["m", "rad"]).dof_units == ("m", "rad")
    with pytest.raises(ModelError, match=r"^structure\.dof_units: \['m'\] is not valid; "
                       r"expected 2 units \(one per DOF\)$"):
        vi.Structure(np.eye(2), dof_units=["m"])
    with pytest.raises(ModelError, match=r"^structure\.dof_units: 'deg' is not valid; "
                       r"expected 'm' or 'rad' or 'kg\^0\.5 m'$"):
        vi.Structure(np.eye(2), dof_units=["m", "deg"])


def test_the_result_labels_each_dof(beam: fe.Beam, beam_model: vi.Model,
                                    beam_result: vi.Result) -> None:
    r = beam_result
    assert r.complete and len(r.impacts) > 0
    assert r.dof_units == beam.structure.dof_units
    ds = r.to_xarray()
    assert ds["dof_unit"].dims == ("dof",)
    assert ds["dof_unit"].values.tolist() == list(beam.structure.dof_units)
    assert ds["displacement"].attrs["units"] == "m or rad per dof_unit"
    assert ds["velocity"].attrs["units"] == "m/s or rad/s per dof_unit"
    assert ds["acceleration"].attrs["units"] == "m/s^2 or rad/s^2 per dof_unit"
    assert ds["penetration"].attrs["units"] == "m"  # gaps act on translations
    assert r.summary()["dof_units"] == list(beam.structure.dof_units)
    cols = r.to_dataframe().columns.tolist()
    assert cols[:6] == ["x0 [m]", "v0 [m/s]", "a0 [m/s^2]", "x1 [rad]", "v1 [rad/s]",
                        "a1 [rad/s^2]"]
    # only translations recorded: the plain unit again
    tips = vi.simulate(beam_model, t_end=0.002, dt=1e-5, dofs=[0, 2])
    assert tips.dof_units == ("m", "m")
    assert tips.to_xarray()["displacement"].attrs["units"] == "m"
    rot = vi.simulate(beam_model, t_end=0.002, dt=1e-5, dofs=[3])
    assert rot.to_xarray()["acceleration"].attrs["units"] == "rad/s^2"


def test_csv_headers_name_each_columns_unit(beam_result: vi.Result, tmp_path: Path) -> None:
    path = tmp_path / "beam.csv"
    written = beam_result.to_xarray()
    rf.save(written, path)
    header = path.read_text(encoding="utf-8").splitlines()[0].split(",")
    units = beam_result.dof_units
    expected = ["time [s]"]
    for d, u in zip(beam_result.dofs, units, strict=True):
        expected += [f"x{d} [{u}]", f"v{d} [{u}/s]", f"a{d} [{u}/s^2]"]
    expected += ["gap0 penetration [m]", "gap0 force [N]"]
    assert header == expected
    assert "x1 [rad]" in header and "a7 [rad/s^2]" in header
    back = rf.load(path)
    assert back["dof_unit"].values.tolist() == list(units)
    for name in ("displacement", "velocity", "acceleration"):
        assert back[name].attrs["units"] == written[name].attrs["units"]


@pytest.mark.parametrize("suffix", [".nc", ".h5"])
def test_netcdf_round_trip_keeps_dof_unit(beam_model: vi.Model, beam_result: vi.Result,
                                          tmp_path: Path, suffix: str) -> None:
    written = beam_result.to_xarray()
    rf.save(written, tmp_path / f"beam{suffix}")
    back = rf.load(tmp_path / f"beam{suffix}")
    assert "dof_unit" in back.coords
    xr.testing.assert_identical(back["dof_unit"], written["dof_unit"])
    for name in ("displacement", "velocity", "acceleration"):
        assert back[name].attrs["units"] == written[name].attrs["units"]
    model, _ = rf.model_from_dataset(back)  # the rebuilt model keeps the units too
    assert model.structure.dof_units == beam_model.structure.dof_units


def test_files_without_dof_unit_read_as_metres(beam_result: vi.Result, tmp_path: Path) -> None:
    """A file written before ``dof_unit`` existed: every DOF is taken to be in m."""
    old = beam_result.to_xarray().drop_vars("dof_unit")
    assert rf.dof_units(old) == ["m"] * len(beam_result.dofs)
    rf.save(old, tmp_path / "old.csv")
    header = (tmp_path / "old.csv").read_text(encoding="utf-8").splitlines()[0]
    assert "x1 [m]" in header and "[rad" not in header
    fig = plotting.plot(old, "displacement", dofs=[1])
    assert fig.axes[0].get_ylabel() == "displacement [m]"


def test_a_streamed_beam_file_equals_the_in_memory_file(beam_model: vi.Model,
                                                        tmp_path: Path) -> None:
    whole = vi.simulate(beam_model, 0.02, 1e-5, every=2)
    rf.save(whole, tmp_path / "whole.nc")
    summary = rf.simulate_to_file(beam_model, tmp_path / "streamed.nc", 0.02, 1e-5, every=2,
                                  window_steps=400)
    assert summary["windows"] >= 3 and summary["dof_units"] == list(whole.dof_units)
    streamed, mem = rf.load(tmp_path / "streamed.nc"), rf.load(tmp_path / "whole.nc")
    volatile = {"history": 0, "wall_time_s": 0}
    xr.testing.assert_identical(streamed.assign_attrs(volatile), mem.assign_attrs(volatile))
    assert streamed["dof_unit"].values.tolist() == list(whole.dof_units)
    assert streamed["velocity"].attrs["units"] == "m/s or rad/s per dof_unit"


def _partly_massless() -> tuple[fe.FEStructure, list[int]]:
    """The cantilever with lumped mass (its rotations keep HRZ rotary mass) and the mass of
    the translation of node 2 removed: a massless translation among rotations with mass."""
    b = fe.Beam(length=LENGTH, elements=ELEMENTS, section=fe.Section.circle(DIAMETER),
                material=fe.Material(youngs_modulus=E, poisson=0.3, density=7800.0),
                theory="euler-bernoulli", lumped_mass=True, supports=[fe.Support(node="start")])
    m = b.fe.mass.toarray()
    gone = [b.dof(node=2, direction="x")]
    m[gone, :] = 0.0
    m[:, gone] = 0.0
    assert np.all(np.diag(m)[[i for i in range(b.n_dof) if i not in gone]] > 0)
    return fe.FEStructure(m, b.fe.stiffness, dof_map=b.dof_map), gone


def test_condensation_keeps_the_units_of_the_retained_dofs() -> None:
    full, gone = _partly_massless()
    cond = full.condense_massless()
    assert cond.condensed.tolist() == gone
    kept = tuple(full.dof_units[i] for i in cond.retained)
    assert "rad" in kept and "m" in kept
    assert cond.structure.dof_units == kept
    assert cond.structure.to_structure().dof_units == kept
    # a run of the condensed model reported on the full DOFs: the recovered translation in m
    law = vi.contact.Hertz(stiffness=1e10)
    tip = cond.reduced_index(full.dof(node=ELEMENTS, direction="x"))
    model = vi.Model(cond.structure.to_structure(), gaps=[vi.Gap(dof=tip, clearance=1e-4,
                                                                 side="both", law=law)],
                     loads=[vi.HarmonicLoad(dof=tip, amplitude=50.0, frequency=40.0)])
    recovery = cond.output(None)
    r = recovery.result(vi.simulate(model, 0.005, 1e-5, dofs=recovery.record.tolist()))
    assert r.dofs.tolist() == list(range(full.n_dof))
    assert r.dof_units == full.dof_units
    assert r.to_xarray()["dof_unit"].values.tolist() == list(full.dof_units)


def test_a_calculix_model_file_labels_its_rotations_rad(tmp_path: Path) -> None:
    """``lumped_cantilever.toml``: CalculiX files whose ``.dof`` map gives directions 1 (x)
    and 5 (ry); the massless rotations are condensed out and recovered in the results."""
    mf = load_model(ROOT / "examples" / "models" / "lumped_cantilever.toml")
    full = mf.condensation.full
    lines = (ROOT / "examples" / "models" / "lumped_cantilever" / "cantilever.dof").read_text()
    directions = [line.split(".")[1] for line in lines.split()]
    assert full.dof_units == tuple("rad" if d == "5" else "m" for d in directions)
    assert mf.model.structure.dof_units == ("m",) * mf.model.n_dof  # the translations kept
    rf.simulate_to_file(mf.model, tmp_path / "cantilever.nc", 0.01, mf.dt, mf.method,
                        every=mf.every, dofs=mf.run_dofs, recovery=mf.recovery())
    ds = rf.load(tmp_path / "cantilever.nc")
    assert ds["dof_unit"].values.tolist() == list(full.dof_units)
    assert ds["displacement"].attrs["units"] == "m or rad per dof_unit"


def test_run_prints_each_peak_in_its_unit(capsys: pytest.CaptureFixture[str]) -> None:
    model = ROOT / "examples" / "models" / "lumped_cantilever.toml"
    assert cli_main(["run", str(model)]) == 0
    peaks = [line.split() for line in capsys.readouterr().out.splitlines() if "peak |x" in line]
    assert len(peaks) == 20  # every DOF of the file, the recovered rotations included
    assert [p[-1] for p in peaks] == ["m", "rad"] * 10  # cantilever.dof: 1, 5, 1, 5, ...
    assert cli_main(["run", str(model), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["dof_units"] == ["m", "rad"] * 10


def test_craig_bampton_keeps_the_boundary_units(beam: fe.Beam) -> None:
    tip_x, tip_ry = beam.dof(node="end", direction="x"), beam.dof(node="end", direction="ry")
    cb = fe.craig_bampton(beam, [tip_ry, tip_x], 3)
    assert cb.structure.dof_units == ("rad", "m", "kg^0.5 m", "kg^0.5 m", "kg^0.5 m")
    # the modal coordinates' unit: φᵀ M φ = 1 (kg^0.5 m for a mass in kg on DOFs in m)
    modal = cb.transform[:, 2:]
    m = beam.structure.mass
    m = m.toarray() if sp.issparse(m) else m
    np.testing.assert_allclose(modal.T @ m @ modal, np.eye(3), atol=1e-10)


@pytest.mark.parametrize(("kind", "dofs", "label"), [
    ("displacement", [1], "displacement [rad]"),
    ("velocity", [1, 3], "velocity [rad/s]"),
    ("acceleration", [1], "acceleration [rad/s²]"),
    ("displacement", [0], "displacement [m]"),
    ("displacement", [1, 0], "displacement [m or rad]"),
    ("spectrum", [3], "displacement amplitude [rad]"),
    ("penetration", None, "penetration δ [m] (< 0: open)"),
])
def test_plots_label_rotation_axes_in_rad(beam_result: vi.Result, kind: str,
                                          dofs: list[int] | None, label: str) -> None:
    options = {} if dofs is None else {"dofs": dofs}
    fig = beam_result.plot(kind, **options)
    assert fig.axes[0].get_ylabel() == label


def test_phase_portrait_of_a_rotation(beam_result: vi.Result) -> None:
    ax = beam_result.plot("phase", dofs=[7]).axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("displacement [rad]", "velocity [rad/s]")


def _matrices_file(tmp_path: Path, extra: str) -> Path:
    """A 3-DOF ``kind = "matrices"`` model (translation, rotation, massless translation)."""
    text = f"""
[structure]
kind = "matrices"
mass = [[2.0, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.0]]
stiffness = [[3e4, 1e3, -1e4], [1e3, 500.0, 0.0], [-1e4, 0.0, 2e4]]
{extra}

[[gaps]]
dof = 0
clearance = 1e-3
side = "both"
law = {{ kind = "hertz", stiffness = 1e9 }}

[initial]
velocity = [0.5, 0.0, 0.0]

[solver]
dt = 1e-5
t_end = 0.01
"""
    path = tmp_path / "model.toml"
    path.write_text(text)
    return path


def test_matrices_model_file_declares_dof_units(tmp_path: Path) -> None:
    """``structure.dof_units`` for matrices without a DOF map: kept through the static
    condensation of the massless DOF (the run's DOFs are the retained ones) and recovered on
    the full model's DOFs; given with a DOF map, or with a unit that is not m or rad, it is a
    one-line model-file error."""
    mf = load_model(_matrices_file(tmp_path, 'dof_units = ["m", "rad", "m"]'))
    assert mf.condensation.full.dof_units == ("m", "rad", "m")
    assert mf.model.structure.dof_units == ("m", "rad")
    r = mf.recovery().result(vi.simulate(mf.model, 0.01, 1e-5,
                                         dofs=mf.recovery().record.tolist()))
    assert r.dof_units == ("m", "rad", "m")
    with pytest.raises(ModelError, match=r"structure\.dof_units: .*expected one of them"):
        load_model(_matrices_file(tmp_path, 'dof_units = ["m", "rad", "m"]\n'
                                            'dof_map = ["1.x", "1.ry", "2.x"]'))
    with pytest.raises(ModelError, match=r"structure\.dof_units.*'deg'"):
        load_model(_matrices_file(tmp_path, 'dof_units = ["m", "deg", "m"]'))
