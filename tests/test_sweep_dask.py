"""Sweeps on Dask ``distributed`` (issue 8): a LocalCluster of 2 workers on loopback gives the
same Dataset as the in-process run, also when a worker is killed in the middle of the sweep.
Skipped only when dask.distributed is not importable (it is in the ``test`` extra)."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

pytest.importorskip(
    "distributed",
    reason="dask.distributed is not installed: pip install 'vibroimpact[distributed]'",
)

import vibroimpact as vi
from vibroimpact.cli import main as cli_main
from vibroimpact.sweeps import ChunkEvent, Param, Sweep, load_sweep, run_sweep
from vibroimpact.sweeps.distributed import dask_client

MODEL_FILE = Path(__file__).parents[1] / "examples" / "models" / "impact_oscillator.toml"


def test_cli_dask_local_cluster_equals_in_process(tmp_path: Path) -> None:
    common = ["sweep", str(MODEL_FILE), "--param", "loads.0.frequency=8:30:12",
              "--param", "gaps.0.law.restitution=0.6,0.9", "--transient", "20",
              "--periods", "6", "--chunk-size", "3", "--quiet"]
    assert cli_main([*common, "-o", str(tmp_path / "local.nc")]) == 0
    assert cli_main([*common, "--dask", "--workers", "2", "-o", str(tmp_path / "dask.nc")]) == 0
    local, dask = load_sweep(tmp_path / "local.nc"), load_sweep(tmp_path / "dask.nc")
    assert dask.sizes["loads.0.frequency"] == 12 and dask.sizes["gaps.0.law.restitution"] == 2
    xr.testing.assert_equal(dask, local)
    assert int(local["impact_count"].sum()) > 0


def test_continuation_on_dask_equals_in_process() -> None:
    """Chained chunks (each continuing the previous chunk's final states) as dependent
    tasks."""
    mf = vi.load_model(MODEL_FILE)
    sweep = Sweep.from_model_file(mf, [Param("loads.0.frequency", np.linspace(8, 30, 10))],
                                  transient=10, periods=4, continuation="both", chunk_size=3)
    with dask_client(workers=2) as (client, threads):
        on_dask = run_sweep(sweep, client=client, threads=threads, progress=False)
    xr.testing.assert_equal(on_dask, run_sweep(sweep, progress=False))


def test_killing_a_worker_mid_sweep_still_gives_the_same_dataset() -> None:
    mf = vi.load_model(MODEL_FILE)
    sweep = Sweep.from_model_file(mf, [Param("loads.0.frequency", np.linspace(8, 30, 24))],
                                  transient=60, periods=10, chunk_size=2)
    reference = run_sweep(sweep, progress=False)
    killed: list[int] = []
    with dask_client(workers=2) as (client, threads):
        before = set(client.run(os.getpid).values())

        def kill_one_worker(ev: ChunkEvent) -> None:
            if not killed and not ev.reused and ev.done < ev.total // 2:
                pid = sorted(before)[0]
                os.kill(pid, signal.SIGKILL)  # a worker process this test's cluster started
                killed.append(pid)

        on_dask = run_sweep(sweep, client=client, threads=threads, progress=False,
                            on_chunk=kill_one_worker)
        client.wait_for_workers(2, timeout=30)  # the nanny has restarted the killed worker
        after = set(client.run(os.getpid).values())
    assert killed and killed[0] not in after
    assert on_dask.attrs["chunks_computed"] == 12
    xr.testing.assert_equal(on_dask, reference)
