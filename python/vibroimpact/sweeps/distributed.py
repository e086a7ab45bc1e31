"""Sweeps on Dask ``distributed`` (an optional extra: ``pip install "vibroimpact[distributed]"``).

Each chunk of parameter points is one task, which calls the parallel core on its worker; the
client writes each finished chunk to the resumable parts as it arrives, so the Dataset is the
same, number for number, as the in-process run. A worker that dies mid-sweep loses only its
running chunks, which the scheduler runs again on another worker.

Example::

    from vibroimpact.sweeps import run_sweep
    from vibroimpact.sweeps.distributed import dask_client
    with dask_client(workers=4) as (client, threads):            # a LocalCluster
        ds = run_sweep(sweep, client=client, threads=threads, output="sweep.nc")
    with dask_client(scheduler="tcp://host:8786") as (client, threads):  # an existing cluster
        ds = run_sweep(sweep, client=client, output="sweep.nc")
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, Any

from vibroimpact.errors import ModelError

if TYPE_CHECKING:
    from vibroimpact.sweeps.runner import _Chunk, _Plan

__all__ = ["available", "dask_client", "run_on_dask"]

_INSTALL = "pip install 'vibroimpact[distributed]'"


def available() -> bool:
    """Whether ``dask.distributed`` can be imported."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def _require(flag: str) -> Any:
    try:
        import distributed
    except ImportError:
        raise ModelError(f"{flag}: dask.distributed is not installed; expected it installed "
                         f"with {_INSTALL}") from None
    return distributed


@contextlib.contextmanager
def dask_client(*, workers: int | None = None, scheduler: str | None = None,
                quiet: bool = True) -> Iterator[tuple[Any, int | None]]:
    """A Dask client and the core threads each task should use.

    With ``scheduler`` (``tcp://host:8786``): a client of that existing cluster; threads None
    (each task uses all cores of its worker's machine). Otherwise a ``LocalCluster`` on the
    loopback interface with ``workers`` worker processes (default: one per core) of one
    thread each, torn down on exit; each task's core then uses ``cores // workers`` threads,
    so that the workers share the machine's cores without oversubscribing them.
    """
    distributed = _require("--scheduler" if scheduler else "--dask")
    if scheduler is not None:
        try:
            client = distributed.Client(scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as e:
            raise ModelError(f"--scheduler: cannot connect to {scheduler!r} ({e}); expected "
                             "the address of a running dask scheduler, e.g. "
                             "tcp://host:8786") from None
        try:
            yield client, None
        finally:
            client.close()
        return
    cores = os.cpu_count() or 1
    n = cores if workers is None else int(workers)
    if n < 1:
        raise ModelError(f"--workers: {workers!r} is not valid; expected an integer >= 1")
    cluster = distributed.LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address="127.0.0.1:0",  # any free port: never clashes with another cluster
        silence_logs=logging.ERROR if quiet else logging.WARNING,
    )
    try:
        client = distributed.Client(cluster)
        try:
            yield client, max(1, cores // n)
        finally:
            client.close()
    finally:
        cluster.close()


def run_on_dask(client: Any, plan: _Plan, chunks: Sequence[_Chunk], todo: Iterable[int],
                results: dict[int, dict[str, Any]], threads: int | None,
                done: Callable[[_Chunk, dict[str, Any]], None], digest: str) -> None:
    """Submits the chunks in ``todo`` as tasks (a chunk that continues another's chains
    depends on that task) and hands each result to ``done`` as it arrives."""
    distributed = _require("--dask")
    from vibroimpact.sweeps.runner import compute_chunk

    todo = sorted(todo)
    if not todo:
        return
    plan_future = client.scatter(plan, broadcast=True, hash=False)
    futures: dict[int, Any] = {}
    for i in todo:  # dependencies have lower indices: submitted first
        c = chunks[i]
        deps = [futures[d] if d in futures else results[d] for d in c.deps]
        futures[i] = client.submit(compute_chunk, plan_future, c, threads, deps,
                                   key=f"vibroimpact-sweep-{digest}-{i:05d}", retries=2)
    index = {f.key: i for i, f in futures.items()}
    try:
        for fut in distributed.as_completed(list(futures.values())):
            r = fut.result()
            if "model_error" in r:
                raise ModelError(r["model_error"])
            i = index[fut.key]
            results[i] = r
            done(chunks[i], r)
    except BaseException:
        client.cancel(list(futures.values()))
        raise
    finally:
        del plan_future
