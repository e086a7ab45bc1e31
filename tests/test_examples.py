"""Every example runs (issue 7): each ``examples/*.py`` script in a subprocess (in parallel,
with a timeout), and each ``examples/models/*.toml`` through ``vibroimpact run --json``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from vibroimpact.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "examples").glob("*.py"))
MODELS = sorted((ROOT / "examples" / "models").glob("*.toml"))
TIMEOUT_S = 180


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=TIMEOUT_S)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, subprocess.CompletedProcess]:
    jobs = {}
    for script in SCRIPTS:
        out = tmp_path_factory.mktemp(script.stem)
        jobs[script.name] = ([sys.executable, str(script), str(out / "output")], out)
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        futures = {name: pool.submit(_run, args, cwd) for name, (args, cwd) in jobs.items()}
        return {name: f.result() for name, f in futures.items()}


def test_there_are_examples() -> None:
    names = [p.name for p in SCRIPTS]
    assert names[:2] == ["01_impact_oscillator.py", "02_two_dof_relative_gap.py"]
    assert len(MODELS) >= 3


@pytest.mark.parametrize("script", [p.name for p in SCRIPTS])
def test_example_script_runs(runs: dict, script: str) -> None:
    proc = runs[script]
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip(), "an example says what it did"
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("model", [p.name for p in MODELS])
def test_example_model_runs(model: str, capsys: pytest.CaptureFixture[str]) -> None:
    # `vibroimpact run MODEL --json`, in this process (the command line itself is run in a
    # subprocess by tests/test_cli.py and tests/test_model_file.py)
    assert cli_main(["run", str(ROOT / "examples" / "models" / model), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["complete"] is True
    assert summary["energy_balance_error"] < 1e-2
