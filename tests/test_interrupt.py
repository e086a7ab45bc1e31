"""Interruptions (issue 10, item 3): Ctrl-C (SIGINT) or SIGTERM during a run stops it within
a few steps, writes the results up to then (atomically, marked incomplete: ``complete = 0``)
and leaves no temporary file; exit codes 130 and 143."""

from __future__ import annotations

import functools
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import vibroimpact as vi
from test_impulsive_driver import E, oscillator
from vibroimpact import _core
from vibroimpact.io import results_file
from vibroimpact.paper import cases

PAPER = Path(__file__).parents[1] / "examples" / "models" / "sdof_paper_ln.toml"

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="POSIX signals and /proc")


def _long_model(tmp_path: Path, every: int = 100000) -> Path:
    """The paper's SDOF case run for 1000 s at 1 µs (1e9 steps: minutes), every k-th step
    kept."""
    text = PAPER.read_text().replace("t_end = 0.02 ", "t_end = 1000.0 ")
    path = tmp_path / "long.toml"
    path.write_text(text + f"\n[output]\nevery = {every}\n")
    return path


@functools.cache
def _startup_cpu_seconds() -> float:
    """CPU seconds of a whole short ``vibroimpact run`` (imports, the run, the file written):
    an upper bound on what a run spends before its time loop."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as folder:
        subprocess.run([sys.executable, "-m", "vibroimpact", "run", str(PAPER), "-o",
                        str(Path(folder) / "short.nc"), "--quiet"], check=True,
                       capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _cpu_seconds(pid: int) -> float:
    """CPU seconds (user + system) used so far by process ``pid`` (Linux ``/proc``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _signal_once_running(proc: subprocess.Popen[str], sig: int) -> None:
    """Send ``sig`` once ``proc`` is in its time loop: when it has used a second of CPU more
    than a whole short run does (CPU time, unlike a fixed sleep, does not stretch when the
    machine is loaded)."""
    threshold = _startup_cpu_seconds() + 1.0
    deadline = time.monotonic() + 300
    while proc.poll() is None and time.monotonic() < deadline:
        if _cpu_seconds(proc.pid) >= threshold:
            break
        time.sleep(0.05)
    proc.send_signal(sig)


def _interrupt_cli(tmp_path: Path, sig: int, out: str) -> subprocess.CompletedProcess[str]:
    model = _long_model(tmp_path)
    proc = subprocess.Popen(
        [sys.executable, "-m", "vibroimpact", "run", str(model), "-o", str(tmp_path / out),
         "--json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    _signal_once_running(proc, sig)
    started = time.monotonic()
    stdout, stderr = proc.communicate(timeout=60)
    assert time.monotonic() - started < 20, "the run did not stop promptly"
    return subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)


def _no_temporary_files(folder: Path) -> None:
    assert not [p.name for p in folder.iterdir() if p.name.endswith(".tmp")]


@pytest.mark.parametrize(("sig", "code", "name"), [(signal.SIGINT, 130, "SIGINT"),
                                                   (signal.SIGTERM, 143, "SIGTERM")])
def test_a_signal_stops_the_run_and_keeps_what_was_computed(
        tmp_path: Path, sig: int, code: int, name: str) -> None:
    proc = _interrupt_cli(tmp_path, sig, "out.nc")
    assert proc.returncode == code, proc.stderr
    assert "Traceback" not in proc.stderr
    first = proc.stderr.splitlines()[0]
    assert first.startswith("vibroimpact: interrupted: interrupted at t = ") and name in first
    ds = results_file.load(tmp_path / "out.nc")
    assert int(ds.attrs["complete"]) == 0
    assert "interrupted at t = " in ds.attrs["message"]
    t_stop = float(ds.time[-1])
    assert 0.0 < t_stop < 1000.0
    assert np.all(np.diff(ds.time.values) > 0)
    assert ds.sizes["impact"] > 0 and np.all(ds.impact_t_start.values <= t_stop)
    summary = json.loads(proc.stdout)
    assert summary["complete"] is False
    _no_temporary_files(tmp_path)


def test_an_interrupted_csv_result_is_marked_incomplete(tmp_path: Path) -> None:
    proc = _interrupt_cli(tmp_path, signal.SIGINT, "out.csv")
    assert proc.returncode == 130, proc.stderr
    meta = json.loads((tmp_path / "out_meta.json").read_text())
    assert meta["complete"] == 0
    for name in ("out.csv", "out_impacts.csv", "out_energy.csv"):
        assert (tmp_path / name).exists()
    _no_temporary_files(tmp_path)


def _signal_soon(sig: int, delay: float = 0.3) -> threading.Timer:
    timer = threading.Timer(delay, os.kill, (os.getpid(), sig))
    timer.start()
    return timer


def _rigid_stop() -> vi.Model:
    """tests/test_impulsive_driver.py's impact oscillator with a rigid stop, at 1.8 Hz."""
    return oscillator(1.8, vi.contact.Rigid(restitution=E))


# (model, run options, those of a short run): runs of minutes, every 1e4–1e5-th step kept
IN_PROCESS_RUNS = {
    "newmark": (lambda: cases.sdof_model("lankarani-nikravesh"),
                dict(t_end=1000.0, dt=1e-6, every=100000), dict(t_end=0.002, dt=1e-6)),
    "event-driven": (_rigid_stop, dict(t_end=1e4, dt=1e-4, every=10000,
                                       method=vi.EventDriven()),
                     dict(t_end=1.0, dt=1e-4, method=vi.EventDriven())),
    "moreau-jean": (_rigid_stop, dict(t_end=1e5, dt=1e-4, every=100000,
                                      method=vi.MoreauJean()),
                    dict(t_end=1.0, dt=1e-4, method=vi.MoreauJean())),
}


@pytest.mark.parametrize("method", list(IN_PROCESS_RUNS))
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_in_process_a_signal_raises_interrupted_with_the_partial_result(
        sig: int, method: str) -> None:
    """The impulsive methods (their impacts kept by their own table) stop as the others."""
    build, options, short = IN_PROCESS_RUNS[method]
    model = build()
    t_end = options["t_end"]
    term_handler = signal.getsignal(signal.SIGTERM)
    timer = _signal_soon(sig)
    try:
        with pytest.raises(vi.Interrupted) as err:
            vi.simulate(model, **options)
    finally:
        timer.cancel()
    e = err.value
    assert isinstance(e, vi.SolverError) and e.signum == sig
    assert "interrupted at t = " in str(e) and signal.Signals(sig).name in str(e)
    partial = e.partial
    assert partial is not None and not partial.complete
    assert 0 < partial.time[-1] < t_end
    assert len(partial.impacts) > 0 and np.all(partial.impacts.t_start <= partial.time[-1])
    # the handler is restored and the flag withdrawn: the next run completes
    assert signal.getsignal(signal.SIGTERM) == term_handler
    assert not _core.interrupt_requested()
    assert vi.simulate(model, **short).complete


def test_a_stale_interrupt_request_does_not_stop_the_next_run() -> None:
    _core.request_interrupt()
    r = vi.simulate(cases.sdof_model("hertz"), t_end=0.002, dt=1e-6)
    assert r.complete and not _core.interrupt_requested()


def test_simulate_in_a_worker_thread_runs_directly() -> None:
    model = cases.sdof_model("hertz")
    box: dict[str, object] = {}
    worker = threading.Thread(
        target=lambda: box.update(r=vi.simulate(model, t_end=0.002, dt=1e-6)))
    worker.start()
    worker.join(30)
    result = box["r"]
    assert isinstance(result, vi.Result) and result.complete
    reference = vi.simulate(model, t_end=0.002, dt=1e-6)
    assert np.array_equal(result.displacement, reference.displacement)


@pytest.mark.parametrize(("sig", "code", "flags"), [(signal.SIGINT, 130, ["--stream"]),
                                                    (signal.SIGTERM, 143, ["--window", "200000"])])
def test_a_streamed_run_keeps_the_rows_written(tmp_path: Path, sig: int, code: int,
                                               flags: list[str]) -> None:
    model = _long_model(tmp_path, every=1000)
    proc = subprocess.Popen(
        [sys.executable, "-m", "vibroimpact", "run", str(model), "-o", str(tmp_path / "w.nc"),
         *flags, "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    _signal_once_running(proc, sig)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == code, stderr
    assert "Traceback" not in stderr and "marked incomplete" in stderr
    ds = results_file.load(tmp_path / "w.nc")
    assert int(ds.attrs["complete"]) == 0 and "interrupted at t = " in ds.attrs["message"]
    t_stop = float(ds.time[-1])
    assert 0.2 < t_stop < 1000.0 and np.all(np.diff(ds.time.values) > 0)
    assert ds.attrs["steps"] == round(t_stop / 1e-6)
    _no_temporary_files(tmp_path)
    # the rows streamed before the signal are those of an uninterrupted run
    ref = vi.simulate(cases.sdof_model("lankarani-nikravesh"), t_end=0.2, dt=1e-6, every=1000)
    n = len(ref.time)
    np.testing.assert_allclose(ds.time.values[:n], ref.time, rtol=1e-12)
    np.testing.assert_allclose(ds.displacement.values[:n], ref.displacement, rtol=1e-9,
                               atol=1e-15)
    assert np.all(ds.impact_t_start.values <= t_stop)


@pytest.mark.parametrize(("sig", "flags", "out"), [
    (signal.SIGTERM, [], "r.nc"),
    (signal.SIGINT, ["--stream"], "r.nc"),
    (signal.SIGTERM, [], "r.csv"),
])
def test_a_signal_while_the_result_is_written_still_gives_the_complete_file(
        tmp_path: Path, sig: int, flags: list[str], out: str) -> None:
    """Issue 10: a signal that arrives after the core has finished, while the result is
    converted and written, lets the complete file be written, leaves no temporary file and
    exits with 128 + the signal. The test hook ``VIBROIMPACT_TEST_SIGNAL_AFTER_RUN`` makes the
    process send itself the signal at exactly that moment."""
    from vibroimpact.simulate import SIGNAL_AFTER_RUN_ENV

    env = {**os.environ, SIGNAL_AFTER_RUN_ENV: signal.Signals(sig).name}
    proc = subprocess.run(
        [sys.executable, "-m", "vibroimpact", "run", str(PAPER), "-o", str(tmp_path / out),
         *flags, "--quiet"],
        capture_output=True, text=True, env=env, timeout=120,
    )
    assert proc.returncode == 128 + sig, proc.stderr
    assert proc.stderr.splitlines() == [
        f"vibroimpact: interrupted: {signal.Signals(sig).name} received after the run "
        f"finished; the complete results were written to {tmp_path / out}"]
    ds = results_file.load(tmp_path / out)
    assert int(ds.attrs["complete"]) == 1 and ds.attrs["message"] == "completed"
    reference = vi.simulate(cases.sdof_model("lankarani-nikravesh"), t_end=0.02, dt=1e-6)
    assert np.array_equal(ds.time.values, reference.time)
    assert ds.sizes["impact"] == len(reference.impacts) == 9
    _no_temporary_files(tmp_path)
