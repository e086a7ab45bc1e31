"""Per-DOF units of sweep Datasets: a ``dof_unit`` coordinate on ``dof`` and a
``model_dof_unit`` one on ``model_dof``, and the ``units`` of the variables on them ("rad" for
rotations, "m or rad per dof_unit" for a mixed set) equal to those of a single run of the same
model (:meth:`vibroimpact.Result.to_xarray`), through files, the command line and the plot axes.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import numpy as np
import pytest
import vibroimpact as vi
import xarray as xr
from vibroimpact import fe
from vibroimpact.cli import main as cli_main
from vibroimpact.sweeps import (
    Param,
    Sweep,
    load_sweep,
    plot_bifurcation,
    plot_response,
    run_sweep,
    save_sweep,
)
from vibroimpact.sweeps.runner import DOF_QUANTITIES

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def beam() -> fe.Beam:
    """A steel cantilever (1 m, 20 mm round, 2 elements: DOFs x, ry, x, ry)."""
    return fe.Beam(length=1.0, elements=2, section=fe.Section.circle(0.02),
                   material=fe.Material(youngs_modulus=2.0e11, poisson=0.3, density=7800.0),
                   theory="euler-bernoulli", supports=[fe.Support(node="start")])


@pytest.fixture(scope="module")
def beam_model(beam: fe.Beam) -> vi.Model:
    """The cantilever rattling in stops 0.1 mm off its tip, driven at the tip."""
    return beam.model([beam.gap(vi.contact.Hertz(stiffness=1e10), node="end", direction="x",
                                clearance=1e-4)],
                      [beam.load(vi.HarmonicLoad, nodes=["end"], direction="x",
                                 amplitude=50.0, frequency=40.0)])


def _sweep(model: vi.Model, dofs: list[int] | None = None) -> Sweep:
    return Sweep(model=model, params=[Param("loads.0.frequency", [30.0, 40.0])], dt=1e-5,
                 transient=2, periods=3, dofs=dofs)


@pytest.fixture(scope="module")
def beam_sweep(beam_model: vi.Model) -> xr.Dataset:
    return run_sweep(_sweep(beam_model), progress=False)


def test_a_beam_sweep_labels_each_dof_like_a_single_run(beam: fe.Beam, beam_model: vi.Model,
                                                        beam_sweep: xr.Dataset) -> None:
    units = beam.structure.dof_units
    assert units == ("m", "rad", "m", "rad")
    ds = beam_sweep
    assert ds["dof"].values.tolist() == [0, 1, 2, 3]  # every DOF of a model of <= 8
    assert ds["dof_unit"].values.tolist() == list(units)
    assert ds["dof_unit"].dims == ("dof",)
    assert ds["model_dof_unit"].values.tolist() == list(units)
    assert ds["model_dof_unit"].dims == ("model_dof",)
    single = vi.simulate(beam_model, t_end=1e-3, dt=1e-5).to_xarray()
    assert single["dof_unit"].values.tolist() == ds["dof_unit"].values.tolist()
    assert ds["dof_unit"].attrs == single["dof_unit"].attrs
    for name, quantity in DOF_QUANTITIES.items():
        expected = single[quantity].attrs["units"]
        if ds[name].dims[-1] == "model_dof":
            expected = expected.replace("per dof_unit", "per model_dof_unit")
        assert ds[name].attrs["units"] == expected, name
    assert ds["poincare_displacement"].attrs["units"] == "m or rad per dof_unit"
    assert ds["displacement_rms"].attrs["units"] == "m or rad per dof_unit"
    assert ds["poincare_velocity"].attrs["units"] == "m/s or rad/s per dof_unit"
    assert ds["final_displacement"].attrs["units"] == "m or rad per model_dof_unit"
    assert ds["final_velocity"].attrs["units"] == "m/s or rad/s per model_dof_unit"
    # the swept values and the other variables keep their own units
    assert ds["loads.0.frequency"].attrs["units"] == "Hz"
    assert ds["impact_velocity"].attrs["units"] == "m/s"
    assert ds["forcing_period"].attrs["units"] == "s"
    assert not ds["failed"].any()


def test_rotation_or_translation_subsets_have_one_unit(beam_model: vi.Model) -> None:
    rot = run_sweep(_sweep(beam_model, dofs=[1, 3]), progress=False)
    assert rot["dof_unit"].values.tolist() == ["rad", "rad"]
    assert rot["poincare_displacement"].attrs["units"] == "rad"
    assert rot["displacement_max"].attrs["units"] == "rad"
    assert rot["poincare_velocity"].attrs["units"] == "rad/s"
    assert rot["final_displacement"].attrs["units"] == "m or rad per model_dof_unit"
    tr = run_sweep(_sweep(beam_model, dofs=[2]), progress=False)
    assert tr["dof_unit"].values.tolist() == ["m"]
    assert tr["poincare_displacement"].attrs["units"] == "m"
    assert tr["poincare_velocity"].attrs["units"] == "m/s"


def test_a_translation_only_sweep_is_in_m() -> None:
    model = vi.Model(vi.Structure.sdof(1.0, (2 * math.pi) ** 2, 0.6),
                     gaps=[vi.Gap(dof=0, clearance=0.05, side="positive",
                                  law=vi.contact.KelvinVoigt(stiffness=2e3, damping=2.0))],
                     loads=[vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=1.0)])
    ds = run_sweep(Sweep(model=model, params=[Param("loads.0.frequency", [0.8, 1.2])],
                         dt=2e-3, transient=2, periods=2), progress=False)
    assert ds["dof_unit"].values.tolist() == ["m"]
    assert ds["model_dof_unit"].values.tolist() == ["m"]
    for name, quantity in DOF_QUANTITIES.items():
        assert ds[name].attrs["units"] == {"displacement": "m", "velocity": "m/s"}[quantity]


@pytest.mark.parametrize("suffix", [".nc", ".h5"])
def test_sweep_file_round_trip_keeps_the_units(beam_sweep: xr.Dataset, tmp_path: Path,
                                               suffix: str) -> None:
    save_sweep(beam_sweep, tmp_path / f"beam{suffix}")
    back = load_sweep(tmp_path / f"beam{suffix}")
    xr.testing.assert_identical(back, beam_sweep)
    assert back["dof_unit"].values.tolist() == ["m", "rad", "m", "rad"]
    assert back["model_dof_unit"].values.tolist() == ["m", "rad", "m", "rad"]
    assert back["poincare_displacement"].attrs["units"] == "m or rad per dof_unit"


@pytest.mark.parametrize(("plot", "options", "label"), [
    (plot_bifurcation, {"dof": 1}, "displacement at the forcing phase, DOF 1 [rad]"),
    (plot_bifurcation, {"dof": 3, "quantity": "velocity"},
     "velocity at the forcing phase, DOF 3 [rad/s]"),
    (plot_bifurcation, {}, "displacement at the forcing phase, DOF 0 [m]"),
    (plot_bifurcation, {"quantity": "impact-velocity"}, "approach speed at impact, gap 0 [m/s]"),
    (plot_response, {"dof": 3}, "largest |displacement|, DOF 3 [rad]"),
    (plot_response, {"dof": 2, "quantity": "rms"}, "RMS displacement, DOF 2 [m]"),
])
def test_sweep_plots_label_rotation_axes_in_rad(beam_sweep: xr.Dataset, plot: object,
                                                options: dict, label: str) -> None:
    fig = plot(beam_sweep, **options)  # type: ignore[operator]
    assert fig.axes[0].get_ylabel() == label


def test_a_sweep_file_without_dof_unit_plots_in_m(beam_sweep: xr.Dataset) -> None:
    """Files written before the coordinate existed: every DOF in m, as they were labelled."""
    old = beam_sweep.drop_vars(["dof_unit", "model_dof_unit"])
    fig = plot_bifurcation(old, dof=1)
    assert fig.axes[0].get_ylabel() == "displacement at the forcing phase, DOF 1 [m]"


def test_cli_sweep_of_a_beam_model_file_writes_the_units(tmp_path: Path) -> None:
    """``hollow_shaft.toml`` cut to 2 elements: the sampled DOFs given by ``--dof``."""
    text = (ROOT / "examples" / "models" / "hollow_shaft.toml").read_text()
    text = text.replace("elements = 20", "elements = 2").replace("dt = 5e-6", "dt = 2e-5")
    text = text.replace("dofs = [0, 20, 40]", "dofs = [0, 1]")
    model = tmp_path / "shaft.toml"
    model.write_text(text)
    out = tmp_path / "shaft.nc"
    assert cli_main(["sweep", str(model), "--param", "loads.0.frequency=10,12", "--transient",
                     "1", "--periods", "2", "--dof", "0", "--dof", "3", "-o", str(out),
                     "--json", "--quiet"]) == 0
    ds = load_sweep(out)
    assert ds["dof_unit"].values.tolist() == ["m", "rad"]
    assert ds["model_dof_unit"].values.tolist() == ["m", "rad"] * 3
    assert ds["poincare_displacement"].attrs["units"] == "m or rad per dof_unit"
    assert ds["final_velocity"].attrs["units"] == "m/s or rad/s per model_dof_unit"
    fig = tmp_path / "shaft.png"
    assert cli_main(["plot", str(out), "--kind", "bifurcation", "--dof", "3", "-o",
                     str(fig)]) == 0
    assert fig.stat().st_size > 1000
    assert not ds["failed"].any() and np.isfinite(ds["poincare_displacement"].values).all()
