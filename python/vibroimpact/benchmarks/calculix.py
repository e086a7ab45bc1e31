"""CalculiX decks written here (nothing committed) and ``ccx`` run in a folder: the
twenty-node brick meshes of tests/test_calculix.py and of the CalculiX row of
``vibroimpact bench`` (issue 23).

CalculiX 2.20 (Debian ``calculix-ccx``) exports its matrices with
``*FREQUENCY, SOLVER=MATRIXSTORAGE`` (no data line) and integrates in time with
``*DYNAMIC, DIRECT`` (fixed increments)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import NamedTuple

__all__ = ["EXPORT_STEP", "MATERIAL", "BrickMesh", "brick_mesh", "run_ccx"]

MATERIAL = "*MATERIAL, NAME=STEEL\n*ELASTIC\n210e9, 0.3\n*DENSITY\n7800\n"
EXPORT_STEP = "*FREQUENCY, SOLVER=MATRIXSTORAGE\n"


class BrickMesh(NamedTuple):
    """A deck's model data (nodes, elements, material, section; node sets ``FIXED`` at
    ``x = 0``, ``MOVING`` (the others) and ``TIP``) and the label of its tip node (the
    centre of the face at ``x = length``)."""

    model: str
    tip: int


def brick_mesh(element: str, n: tuple[int, int, int] = (2, 1, 2),
               size: tuple[float, float, float] = (0.1, 0.02, 0.04)) -> BrickMesh:
    """A structured mesh of ``n`` twenty-node bricks (``C3D20`` or ``C3D20R``) of steel on a
    block of ``size`` m (node order of CalculiX/ABAQUS: 8 corners, then the midside nodes of
    the bottom, top and vertical edges). The cantilever of issue 23 is ``n = (20, 1, 2)``,
    ``size = (0.5, 0.02, 0.04)``: 393 nodes, 1,140 free DOFs."""
    nx, ny, nz = n
    grid = (2 * nx + 1, 2 * ny + 1, 2 * nz + 1)
    label: dict[tuple[int, int, int], int] = {}
    lines = ["*NODE"]
    for k in range(grid[2]):
        for j in range(grid[1]):
            for i in range(grid[0]):
                if i % 2 + j % 2 + k % 2 > 1:  # face and body centres are not nodes
                    continue
                label[(i, j, k)] = len(label) + 1
                x = [size[a] * c / (grid[a] - 1) for a, c in enumerate((i, j, k))]
                lines.append(f"{label[(i, j, k)]}, {x[0]!r}, {x[1]!r}, {x[2]!r}")
    corners = [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 2), (2, 0, 2), (2, 2, 2),
               (0, 2, 2)]
    edges = [(1, 0, 0), (2, 1, 0), (1, 2, 0), (0, 1, 0), (1, 0, 2), (2, 1, 2), (1, 2, 2),
             (0, 1, 2), (0, 0, 1), (2, 0, 1), (2, 2, 1), (0, 2, 1)]
    lines.append(f"*ELEMENT, TYPE={element}, ELSET=E")
    number = 0
    for ez in range(nz):
        for ey in range(ny):
            for ex in range(nx):
                number += 1
                nodes = [label[(2 * ex + a, 2 * ey + b, 2 * ez + c)] for a, b, c in corners + edges]
                lines.append(f"{number}, " + ", ".join(map(str, nodes[:15])) + ",")
                lines.append(", ".join(map(str, nodes[15:])))
    fixed = [n for (i, _, _), n in label.items() if i == 0]
    moving = [n for (i, _, _), n in label.items() if i > 0]
    tip = label[(2 * nx, ny, nz)]
    lines += ["*NSET, NSET=FIXED", *map(str, fixed), "*NSET, NSET=MOVING", *map(str, moving),
              "*NSET, NSET=TIP", str(tip)]
    model = ("\n".join(lines) + "\n" + MATERIAL
             + "*SOLID SECTION, ELSET=E, MATERIAL=STEEL\n")
    return BrickMesh(model, tip)


def run_ccx(folder: Path, job: str, deck: str, *, threads: int | None = None) -> Path:
    """Write ``deck`` to ``folder/job.inp`` and run ``ccx job`` there (on ``threads`` OpenMP
    threads if given); the job's path (``folder/job``, without suffix). Raises
    :class:`RuntimeError` with the end of CalculiX's output if it did not finish."""
    (folder / f"{job}.inp").write_text(deck, encoding="ascii")
    env = None if threads is None else {**os.environ, "OMP_NUM_THREADS": str(threads)}
    done = subprocess.run(["ccx", job], cwd=folder, capture_output=True, text=True,
                          timeout=600, env=env)
    if done.returncode != 0 or "Job finished" not in done.stdout:
        raise RuntimeError(f"ccx {job}: did not finish: {done.stdout[-2000:]}")
    return folder / job
