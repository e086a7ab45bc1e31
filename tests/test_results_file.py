"""Result files (issue 7): NetCDF-4/HDF5 and CSV round trips, MATLAB-safe contents, the
model stored so that a file can be re-run, atomic writes under failures and signals, runs
streamed to disk, and ``vibroimpact run -o/--quiet/--verbose``."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import netCDF4
import numpy as np
import pandas as pd
import pytest
import vibroimpact as vi
import xarray as xr
from vibroimpact.cli import main as cli_main
from vibroimpact.errors import ModelError
from vibroimpact.io import load_model
from vibroimpact.io import results_file as rf
from vibroimpact.paper import cases

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "examples" / "models"


@pytest.fixture(scope="module")
def sdof() -> vi.Result:
    return vi.simulate(cases.sdof_model("lankarani-nikravesh", 0.9), t_end=0.005, dt=1e-6)


@pytest.fixture(scope="module")
def two_dof() -> vi.Result:
    return load_model(MODELS / "two_dof_matrices.toml").simulate()


def _same(a: xr.Dataset, b: xr.Dataset) -> None:
    assert set(a.variables) == set(b.variables)
    for name in a.variables:
        x, y = a[name].values, b[name].values
        assert x.shape == y.shape, name
        if x.dtype.kind == "f":
            assert np.array_equal(x, y, equal_nan=True), name
        else:
            assert (x.astype(str) == y.astype(str)).all(), name
        assert a[name].attrs.get("units") == b[name].attrs.get("units"), name
    assert a.attrs == b.attrs


@pytest.mark.parametrize("suffix", [".nc", ".h5"])
def test_netcdf_round_trip_same_arrays_and_metadata(sdof: vi.Result, tmp_path: Path,
                                                    suffix: str) -> None:
    path = tmp_path / f"run{suffix}"
    written = sdof.to_xarray()  # carries its creation time: save this very Dataset
    assert rf.save(written, path) == [path]
    with xr.open_dataset(path) as ds:  # plain xarray, no vibroimpact in between
        ds.load()
    _same(written, ds)
    assert sdof.save(tmp_path / f"again{suffix}") == [tmp_path / f"again{suffix}"]
    assert np.array_equal(ds["displacement"].values[:, 0], sdof.displacement[:, 0])
    assert list(ds["impact_side"].values) == list(sdof.impacts.side)
    meta = rf.metadata(ds)
    assert meta["method_spec"]["name"] == "newmark"
    assert meta["method_spec"]["params"]["beta"] == 0.25
    assert meta["model_spec"]["gaps"][0]["law"]["kind"] == "lankarani-nikravesh"
    assert meta["model_spec"]["gaps"][0]["law"]["restitution"] == 0.9
    assert ds["structure_mass"].values.tolist() == [[100.0]]
    assert ds.attrs["steps"] == 5000 and ds.attrs["complete"] == 1
    assert ds.attrs["vibroimpact_version"] == vi.__version__


def test_a_file_says_how_it_was_made_rerun_gives_the_same_result(two_dof: vi.Result,
                                                                  tmp_path: Path) -> None:
    path = tmp_path / "two_dof.nc"
    two_dof.save(path)
    ds = rf.load(path)
    model, method = rf.model_from_dataset(ds)
    assert method == two_dof.method
    again = vi.simulate(model, ds.attrs["t_end"], ds.attrs["dt"], method, every=10)
    assert np.array_equal(again.displacement, two_dof.displacement)
    assert np.array_equal(again.impacts.t_start, two_dof.impacts.t_start)


def test_netcdf_holds_only_types_matlab_reads(sdof: vi.Result, tmp_path: Path) -> None:
    path = tmp_path / "run.nc"
    sdof.save(path)
    with netCDF4.Dataset(path) as nc:
        assert nc.file_format == "NETCDF4"  # HDF5 underneath: h5read works too
        for name, var in nc.variables.items():
            assert var.dtype in (np.dtype("f8"), np.dtype("i8"), np.dtype("S1")), name
            assert "units" in var.ncattrs() or name in ("dof", "dof_unit", "gap"), name
        assert nc.variables["impact_side"].dimensions == ("impact", "string8")
        for key in nc.ncattrs():
            value = nc.getncattr(key)
            assert isinstance(value, (str, np.integer, np.floating, int, float)), key
        json.loads(nc.getncattr("model_spec"))


def test_csv_columns_carry_units_and_round_trip(two_dof: vi.Result, tmp_path: Path) -> None:
    path = tmp_path / "res.csv"
    written = two_dof.to_xarray()
    files = rf.save(written, path)
    assert sorted(p.name for p in files) == sorted(
        ["res.csv", "res_impacts.csv", "res_energy.csv", "res_meta.json"])
    header = path.read_text().splitlines()[0].split(",")
    assert header == ["time [s]", "x0 [m]", "v0 [m/s]", "a0 [m/s^2]", "x1 [m]", "v1 [m/s]",
                      "a1 [m/s^2]", "gap0 penetration [m]", "gap0 force [N]"]
    impacts = pd.read_csv(tmp_path / "res_impacts.csv")
    assert list(impacts.columns) == [
        "gap", "side", "t_start [s]", "t_end [s]", "v_in [m/s]", "v_out [m/s]",
        "restitution_effective", "delta_max [m]", "force_max [N]", "friction_max [N]",
        "impulse [N s]"]
    assert len(impacts) == len(two_dof.impacts)
    energy = pd.read_csv(tmp_path / "res_energy.csv", index_col=0)
    assert energy.index.name == "time [s]"
    assert all(c.endswith(" [J]") for c in energy.columns)
    assert np.array_equal(energy["kinetic [J]"].to_numpy(), two_dof.energy.kinetic)
    balance = (two_dof.energy.balance)
    assert np.allclose(energy["balance [J]"].to_numpy(), balance, rtol=0, atol=1e-12)
    # read back: the same arrays as the Dataset the result gives
    _same(written, rf.load(path))


def test_unknown_suffix_is_a_one_line_error(sdof: vi.Result, tmp_path: Path) -> None:
    with pytest.raises(ModelError, match=r"^path: .*expected a file name ending in \.nc"):
        sdof.save(tmp_path / "x.txt")
    assert list(tmp_path.iterdir()) == []


def test_a_failing_writer_keeps_the_previous_file(sdof: vi.Result, tmp_path: Path) -> None:
    path = tmp_path / "run.nc"
    sdof.save(path)
    before = path.read_bytes()

    def fails(p: Path) -> None:
        p.write_bytes(b"partial")
        raise OSError(28, "No space left on device", str(p))

    with pytest.raises(OSError, match="No space left"):
        rf.atomic_write({path: fails})
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.nc"]


# ------------------------------------------------------------------------------------------
# Killing a process mid-write
# ------------------------------------------------------------------------------------------

#: Writes a large result to argv[1] again and again, announcing each write on stdout.
WRITER = textwrap.dedent("""
    import sys, time
    import numpy as np, xarray as xr
    from vibroimpact.io import results_file as rf
    n = int(sys.argv[2])
    ds = xr.Dataset({"displacement": (("time", "dof"), np.arange(n * 8.0).reshape(n, 8),
                                      {"units": "m"})},
                    coords={"time": np.arange(n) * 1e-6, "dof": np.arange(8)})
    i = 0
    while True:
        ds.attrs["generation"] = i
        print("start", i, time.perf_counter(), flush=True)
        rf.save(ds, sys.argv[1])
        print("done", i, time.perf_counter(), flush=True)
        i += 1
""")
N_ROWS = 200_000  # 13 MB a write


def _check_complete(path: Path) -> int:
    ds = rf.load(path)
    assert ds["displacement"].shape == (N_ROWS, 8)
    assert np.array_equal(ds["displacement"].values, np.arange(N_ROWS * 8.0).reshape(N_ROWS, 8))
    return int(ds.attrs["generation"])


def _interrupt_mid_write(tmp_path: Path, sig: int, fraction: float) -> tuple[int, list[str]]:
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    target = tmp_path / "out" / "result.nc"
    target.parent.mkdir()
    proc = subprocess.Popen([sys.executable, str(script), str(target), str(N_ROWS)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        start, durations = 0.0, []
        for line in proc.stdout:
            word, _, t = line.split()
            if word == "start":
                start = float(t)
            else:
                durations.append(float(t) - start)
                if len(durations) == 3:
                    break
        proc.stdout.readline()  # "start 3": the fourth write has begun
        time.sleep(fraction * min(durations))  # well inside it, even on a loaded machine
        proc.send_signal(sig)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    leftovers = [p.name for p in target.parent.iterdir() if p != target]
    return _check_complete(target), leftovers


@pytest.mark.parametrize("fraction", [0.2, 0.5])
def test_sigkill_mid_write_leaves_the_previous_complete_file(tmp_path: Path,
                                                             fraction: float) -> None:
    # a write that went faster than the three timed before it can end before the kill; the
    # target is complete either way (checked each time), and one of three kills lands inside
    for attempt in range(3):
        (tmp_path / str(attempt)).mkdir()
        generation, leftovers = _interrupt_mid_write(tmp_path / str(attempt), signal.SIGKILL,
                                                     fraction)
        assert generation >= 0
        if leftovers:
            break
    # the kill did land inside a write: its hidden temporary file is left (a killed process
    # cannot clean up), and the target is the previous complete file
    assert len(leftovers) == 1
    assert leftovers[0].startswith(".result.nc.") and leftovers[0].endswith(".tmp")


def test_sigterm_mid_write_removes_the_temporary_file(tmp_path: Path) -> None:
    generation, leftovers = _interrupt_mid_write(tmp_path, signal.SIGTERM, 0.5)
    assert generation >= 0
    assert leftovers == []


# ------------------------------------------------------------------------------------------
# Streaming long runs to disk
# ------------------------------------------------------------------------------------------


def _pressed_model() -> vi.Model:
    """A 1 kg mass pushed by 10 N onto a critically damped wall 1 mm away: it reaches the wall
    after 14 ms and stays pressed against it (a contact that lasts to the end)."""
    law = vi.contact.KelvinVoigt(stiffness=1e6, damping=2000.0)
    return vi.Model(vi.Structure.sdof(mass=1.0), gaps=[vi.Gap(dof=0, clearance=1e-3, law=law)],
                    loads=[vi.ConstantLoad(dof=0, amplitude=10.0)])


def _assert_same_file(streamed: xr.Dataset, whole: xr.Dataset) -> None:
    """Same variables, values (bit for bit), dims, variable attributes and global attributes
    (but the creation time and the wall time)."""
    volatile = ("history", "wall_time_s")
    a = streamed.assign_attrs({k: 0 for k in volatile})
    b = whole.assign_attrs({k: 0 for k in volatile})
    xr.testing.assert_identical(a, b)
    assert set(streamed.attrs) == set(whole.attrs)


@pytest.mark.parametrize("case", ["two_dof_matrices.toml", "table_load.toml", "pressed",
                                  "adaptive"])
def test_a_streamed_file_equals_the_in_memory_results_file(tmp_path: Path, case: str) -> None:
    if case == "pressed":  # the contact still closed when the run ends
        model, t_end, dt, method, every, dofs = _pressed_model(), 0.5, 1e-5, vi.Newmark(), 7, None
    elif case == "adaptive":
        model, t_end, dt, every, dofs = cases.sdof_model("lankarani-nikravesh"), 0.02, 1e-6, 2, None
        method = vi.Newmark(adaptive=vi.Adaptive(rtol=1e-4, dt_max=1e-4))
    else:
        mf = load_model(MODELS / case)
        model, t_end, dt, method, every, dofs = (mf.model, mf.t_end, mf.dt, mf.method, mf.every,
                                                 mf.dofs)
    whole = vi.simulate(model, t_end, dt, method, every=every, dofs=dofs)
    rf.save(whole, tmp_path / "whole.nc")
    fractions: list[float] = []
    summary = rf.simulate_to_file(model, tmp_path / "streamed.nc", t_end, dt, method,
                                  every=every, dofs=dofs, window_steps=50 * every,
                                  progress=fractions.append)
    n = len(whole.time)
    # blocks of 50 rows, then the rest with the impact table and the attributes; the blocks
    # ready at a poll are written together, at most three (the one waited for and the two the
    # core's bounded channel held), so the number of writes depends on the core's speed only
    # between these bounds
    blocks = n // 50
    assert -(-blocks // 3) + 1 <= summary["windows"] <= blocks + 1 and blocks >= 3
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    streamed = rf.load(tmp_path / "streamed.nc")
    _assert_same_file(streamed, rf.load(tmp_path / "whole.nc"))
    assert streamed.sizes["time"] == n
    expected = {**whole.summary(), "wall_time_s": summary["wall_time_s"]}
    assert {k: v for k, v in summary.items() if k not in ("windows", "steps_computed")} \
        == expected
    assert sorted(os.listdir(tmp_path)) == ["streamed.nc", "whole.nc"]
    model2, method2 = rf.model_from_dataset(streamed)
    assert model2.n_dof == model.n_dof and method2 == method


def test_a_streamed_run_holds_a_few_blocks_not_the_run(tmp_path: Path) -> None:
    """The rows reach the writer in blocks while the core runs and the result returned at the
    end holds only those after the last block (the writer does not accumulate)."""
    model = cases.sdof_model("lankarani-nikravesh")
    blocks: list[int] = []
    r = vi.simulate(model, 0.02, 1e-6, every=10, chunk_rows=300,
                    on_rows=lambda rows: blocks.append(len(rows["time"])))
    # whole blocks of 300 rows; those ready at a poll come together, at most three (two in
    # the core's bounded channel and the one being waited for)
    assert sum(blocks) == 1800 and all(b % 300 == 0 and b <= 900 for b in blocks)
    assert len(r.time) == 2001 - 1800
    whole = vi.simulate(model, 0.02, 1e-6, every=10)
    assert np.array_equal(r.time, whole.time[1800:])
    assert r.energy.balance_error == whole.energy.balance_error
    assert len(r.impacts) == len(whole.impacts) and r.complete


def test_a_failing_writer_stops_the_run_and_its_error_is_raised() -> None:
    """If writing a block fails (a full disk), the core is asked to stop (within 64 steps, not
    after the 1e9 steps of this run) and the writer's error is raised."""
    from vibroimpact import _core

    def full_disk(rows: dict[str, object]) -> None:
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space left"):
        vi.simulate(cases.sdof_model("hertz"), 1000.0, 1e-6, every=1000, chunk_rows=10,
                    on_rows=full_disk)
    assert not _core.interrupt_requested()


# ------------------------------------------------------------------------------------------
# vibroimpact run
# ------------------------------------------------------------------------------------------


def test_run_writes_netcdf_quietly_and_logs_when_verbose(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "r.nc"
    assert cli_main(["run", str(MODELS / "sdof_paper_ln.toml"), "-o", str(out), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    ds = rf.load(out)
    assert ds.attrs["steps"] == 20000 and ds.sizes["impact"] == 9
    assert cli_main(["run", str(MODELS / "sdof_paper_ln.toml"), "--verbose"]) == 0
    log = capsys.readouterr().err.splitlines()
    assert any("20000 steps" in line and "step cuts" in line for line in log)
    assert any("Newton iterations" in line and "energy balance error" in line for line in log)
    assert sum(line.startswith("vibroimpact: contact: gap 0") for line in log) == 9


def test_run_streams_with_window(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = str(MODELS / "two_dof_matrices.toml")
    assert cli_main(["run", model, "-o", str(tmp_path / "w.h5"), "--window", "20000",
                     "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    # 100,000 steps in 5 blocks of 20,000 (+ the closing write); blocks that wait together in
    # the core's channel of two (a loaded machine) are written as one, so at least 2 + 1
    assert summary["windows"] >= 3
    assert cli_main(["run", model, "-o", str(tmp_path / "s.nc"), "--stream", "--quiet"]) == 0
    assert cli_main(["run", model, "-o", str(tmp_path / "m.nc"), "--quiet"]) == 0
    capsys.readouterr()
    streamed, whole = rf.load(tmp_path / "w.h5"), rf.load(tmp_path / "m.nc")
    assert streamed.sizes["time"] == 10001
    _assert_same_file(streamed, whole)
    _assert_same_file(rf.load(tmp_path / "s.nc"), whole)
    for flags in (["--window", "20000"], ["--stream"], ["-o", str(tmp_path / "x.csv"),
                                                        "--stream"]):
        assert cli_main(["run", model, *flags]) == 2
        err = capsys.readouterr().err
        assert flags[-2 if flags[0] == "--window" else -1] in err and len(err.splitlines()) == 1
    assert sorted(os.listdir(tmp_path)) == ["m.nc", "s.nc", "w.h5"]


def test_run_streams_by_itself_above_the_size_threshold(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import importlib

    run_module = importlib.import_module("vibroimpact.cli.run")
    model = str(MODELS / "sdof_paper_ln.toml")
    # (20,000 steps + 2) rows of 1 + 3 + 2 + 6 columns (time, x v a, gap, energy)
    assert run_module._history_bytes(load_model(model)) == 8 * 20002 * 12
    assert cli_main(["run", model, "-o", str(tmp_path / "m.nc"), "--json"]) == 0
    assert "windows" not in json.loads(capsys.readouterr().out)  # held in memory
    monkeypatch.setattr(run_module, "STREAM_ABOVE_BYTES", 8 * 20002 * 12 - 1)
    assert cli_main(["run", model, "-o", str(tmp_path / "s.nc"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["windows"] >= 1  # streamed
    _assert_same_file(rf.load(tmp_path / "s.nc"), rf.load(tmp_path / "m.nc"))
    assert cli_main(["run", model, "-o", str(tmp_path / "c.csv"), "--json"]) == 0
    assert "windows" not in json.loads(capsys.readouterr().out)  # CSV: from memory
