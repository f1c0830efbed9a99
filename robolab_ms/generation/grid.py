"""RoboLab's single-pass baseline for scene generation (`--method grid`).

The model picks objects and an R x C grid over the reachable part of the table and puts each object in a cell;
each object goes to its cell's centre moved by a uniform draw of up to a quarter cell along x and along y, with no
stacking or containment and no second round; then the same physics settle as the solver's scenes. Rows run along
x (row 0 nearest the robot), columns along y (column 0 on the robot's right).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robolab_ms.catalog import Catalog
from robolab_ms.errors import did_you_mean
from robolab_ms.generation.proposal import FRAME, MAX_OBJECTS
from robolab_ms.generation.solver import REACH, Pose

GRID_MARKER = "[grid baseline]"
MAX_CELLS = 6  # per side


def grid_system_prompt(catalog: Catalog, required: list[str] | None = None) -> str:
    """The baseline's instructions: objects, a grid and a cell per object, as one JSON object."""
    lines = [
        f"{GRID_MARKER} You lay out tabletop scenes for a robot benchmark. Answer with ONE JSON object:",
        '{"objects": [{"name": "<unique name>", "asset": "<catalog name>"}, ...], "grid": {"rows": R, "columns": C}, '
        '"cells": {"<name>": [row, column], ...}}',
        FRAME,
        f"The grid covers x {REACH['x'][0]}..{REACH['x'][1]} m (row 0 nearest the robot) and y "
        f"{REACH['y'][0]}..{REACH['y'][1]} m (column 0 on the robot's right). One object per cell, at most "
        f"{MAX_OBJECTS} objects, rows and columns at most {MAX_CELLS}.",
    ]
    if required:
        lines.append("The scene must contain these catalog objects: " + ", ".join(required) + ".")
    lines.append("Catalog: " + ", ".join(name for name in catalog.names() if not catalog[name].is_fixture))
    return "\n".join(lines)


def grid_poses(answer: dict[str, Any], catalog: Catalog, seed: int = 0) -> tuple[list[Pose], list[str]]:
    """Poses from a grid answer (cell centre plus a uniform quarter-cell jitter, yaw 0), and the answer's problems
    (unknown objects, cells outside the grid or used twice are left out and reported)."""
    rng = np.random.default_rng(seed)
    problems: list[str] = []
    grid = answer.get("grid") or {}
    rows, columns = grid.get("rows"), grid.get("columns")
    objects = answer.get("objects") or []
    if not all(isinstance(value, int) and 1 <= value <= MAX_CELLS for value in (rows, columns)):
        problems.append(f'"grid" must have integer "rows" and "columns" in 1..{MAX_CELLS}, got {grid!r}')
        count = max(1, len(objects))
        columns = math.ceil(math.sqrt(count))
        rows = math.ceil(count / columns)
    cells = answer.get("cells") or {}
    cell_x = (REACH["x"][1] - REACH["x"][0]) / rows
    cell_y = (REACH["y"][1] - REACH["y"][0]) / columns
    used: set[tuple[int, int]] = set()
    poses = []
    for index, item in enumerate(objects[:MAX_OBJECTS]):
        item = {"asset": item} if isinstance(item, str) else item
        asset = str(item.get("asset", "")) if isinstance(item, dict) else ""
        name = str(item.get("name") or asset) if isinstance(item, dict) else ""
        if asset not in catalog.names() or catalog[asset].is_fixture:
            problems.append(
                f"objects[{index}]: unknown catalog object '{asset}'. {did_you_mean(asset, catalog.names())}"
            )
            continue
        cell = cells.get(name)
        if (
            not (
                isinstance(cell, list)
                and len(cell) == 2
                and all(isinstance(v, int) for v in cell)
                and 0 <= cell[0] < rows
                and 0 <= cell[1] < columns
            )
            or tuple(cell) in used
        ):
            problems.append(f"cells: '{name}' has no free cell of the {rows} x {columns} grid (got {cell!r})")
            continue
        used.add(tuple(cell))
        centre_x = REACH["x"][0] + (cell[0] + 0.5) * cell_x
        centre_y = REACH["y"][0] + (cell[1] + 0.5) * cell_y
        x = centre_x + rng.uniform(-cell_x / 4, cell_x / 4)
        y = centre_y + rng.uniform(-cell_y / 4, cell_y / 4)
        poses.append(Pose(name, asset, (round(float(x), 4), round(float(y), 4)), 0.0))
    return poses, problems
