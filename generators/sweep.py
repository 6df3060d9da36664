"""The sweep generator: one scene, a grid over DVS noise and threshold parameters, one sequence per grid point.

The grid is the Cartesian product of lists of values for any of GRID_KEYS (sim.DVSParams fields). Point i is
simulated with the base configuration's DVS parameters replaced by the point's values, seeded with child i of
one root SeedSequence (spawn). The output folder holds sweep_<i>.h5 per point and index.json recording the grid,
the root seed and, per point, its parameters and seed.
"""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import TYPE_CHECKING

from sim import InvalidParameterError
from sim.seeding import as_seed_sequence, child_seed, seed_record

from .ahdr import AHDRConfig
from .config import SWEEP_KEYS, check_sweep_values
from .dataset import EXPORT_SUFFIX, SceneRecipe, SequenceTask, run_sequences

if TYPE_CHECKING:
    import numpy as np

    from .scenes import Scene

GRID_KEYS = SWEEP_KEYS
DEFAULT_GRID = {"threshold_sigma": [0.0, 0.05], "shot_noise_hz": [0.0, 2.0]}


def grid_points(grid: dict) -> list[dict]:
    """The Cartesian product of the grid; every value is checked as its sim.DVSParams field (InvalidParameterError
    naming sweep.<key>[i]).

    Parameters
    ----------
    grid : dict
        GRID_KEYS name -> non-empty list of values (in the field's units, sim.dvs_params.FIELD_UNITS).

    Returns
    -------
    list of dict
        One {name: value} per point, in the order of the keys (the last key varies fastest).
    """
    for key, values in grid.items():
        if key not in GRID_KEYS:
            raise InvalidParameterError(f"sweep: unknown parameter {key!r}; one of {', '.join(GRID_KEYS)}")
        if not isinstance(values, (list, tuple)) or len(values) == 0:
            raise InvalidParameterError(f"sweep: {key} needs a non-empty list of values, got {values!r}")
        check_sweep_values("sweep", key, list(values))
    keys = list(grid)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(grid[k] for k in keys))]


def generate_sweep(scene: Scene | SceneRecipe, out_dir: str | Path, grid: dict | None = None,
                   config: AHDRConfig | None = None, seed: int | np.random.SeedSequence = 0, *, overwrite: bool = False,
                   progress: bool = True, fmt: str = "native", workers: int | None = None, scheduler: str | None = None,
                   resume: bool = False) -> Path:
    """Write one sequence per grid point for a scene.

    Parameters
    ----------
    scene : Scene or SceneRecipe
        The scene (sent to a cluster once).
    out_dir : str or Path
        The output folder (sweep_<i>.h5 per point and index.json).
    grid : dict, optional
        GRID_KEYS name -> list of values (the fields' units; default DEFAULT_GRID).
    config : AHDRConfig, optional
        The base configuration (default AHDRConfig()); each point replaces its DVS fields.
    seed : int or numpy.random.SeedSequence, optional
        The root seed (default 0): point i is seeded with child i.
    overwrite, progress, workers, scheduler, resume
        As for generators.dataset.generate_dataset.
    fmt : str, optional
        "native" (default) or an export format.

    Returns
    -------
    Path
        The index.json written.
    """
    grid = DEFAULT_GRID if grid is None else grid
    config = config or AHDRConfig()
    points = grid_points(grid)
    if fmt != "native" and fmt not in EXPORT_SUFFIX:
        raise InvalidParameterError(f"unknown format {fmt!r}; one of native, {', '.join(EXPORT_SUFFIX)}")
    # validate every point before writing anything
    dvs_points = [dataclasses.replace(config.dvs, **p) for p in points]
    root = as_seed_sequence(seed)
    width = max(3, len(str(len(points) - 1)))
    jobs = [(SequenceTask(f"sweep_{i:0{width}d}", dataclasses.replace(config, dvs=dvs), child_seed(root, i), fmt,
                          {"sweep_point": point}), scene)
            for i, (point, dvs) in enumerate(zip(points, dvs_points))]
    header = {"generator": "sweep", "seed": seed_record(root), "format": fmt,
              "grid": {k: list(v) for k, v in grid.items()}}
    return run_sequences(out_dir, jobs, header, overwrite=overwrite, resume=resume, workers=workers,
                         scheduler=scheduler, progress=progress)
