"""Writing a dataset folder: one native HDF5 file per sequence (plus an optional export), and index.json.

Layout of an output folder:
    <name>.h5            the native file of each sequence (always written: it holds the ground truth)
    <name>_e2vid.h5 | <name>_ijrr/ | <name>.mat    the export, when a format other than native is chosen
    index.json           what the folder holds: generator, root seed, format, and per sequence its file, export,
                         seed record, scene, parameters and counts
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sim import EvsimInputError
from sim.seeding import seed_record

from .ahdr import generate_ahdr
from .config import DatasetConfig, build_scene, check_sequence_name, to_ahdr_config
from .formats import export
from .formats.atomic import write_text_atomic

INDEX_FILE = "index.json"
EXPORT_SUFFIX = {"e2vid": "_e2vid.h5", "ijrr": "_ijrr", "akf-mat": ".mat", "e2vid-txt": "_e2vid.zip",
                 "aedat4": ".aedat4", "evt3": "_evt3.raw", "evt2": "_evt2.raw", "dat": "_td.dat"}


def prepare_output_dir(out_dir, overwrite: bool) -> Path:
    """Create out_dir; refuse (EvsimInputError) when it already holds files and overwrite is False."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise EvsimInputError(f"output {out} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not overwrite:
        raise EvsimInputError(f"output folder {out} already exists and is not empty; "
                              "pass --overwrite (overwrite=True) to replace its contents")
    out.mkdir(parents=True, exist_ok=True)
    return out


def write_sequence(out: Path, name: str, scene, ahdr_config, seed, fmt: str, *, progress: bool,
                   metadata: dict | None = None) -> dict:
    """Generate one sequence into out/<name>.h5 (and its export); return its index entry."""
    path = out / f"{check_sequence_name('sequence name', name)}.h5"
    result = generate_ahdr(scene, path, ahdr_config, seed, progress=progress, metadata={"name": name, **(metadata or {})})
    entry = {"name": name, "file": path.name, "seed": seed_record(seed), "scene": scene.describe(),
             "n_events": result.n_events, "n_frames": result.n_frames, "n_dvs_samples": result.n_dvs_samples,
             "duration_us": int(scene.duration_us), **(metadata or {})}
    if fmt != "native":
        target = out / f"{name}{EXPORT_SUFFIX[fmt]}"
        export(path, target, fmt)
        entry["export"] = target.name
    return entry


def write_index(out: Path, index: dict) -> Path:
    """Write index.json atomically."""
    path = out / INDEX_FILE
    write_text_atomic(path, json.dumps(index, indent=2))
    return path


def generate_dataset(config: DatasetConfig, out_dir, *, overwrite: bool = False, progress: bool = True,
                     fmt: str | None = None, seed: int | None = None) -> Path:
    """Generate every sequence of a dataset configuration into out_dir; return the index path.

    fmt and seed override the configuration's format and root seed. Sequence i is seeded with child i of the root
    SeedSequence (recorded in index.json and in each file's metadata).
    """
    fmt = config.format if fmt is None else fmt
    if fmt not in ("native", *EXPORT_SUFFIX):
        raise EvsimInputError(f"unknown format {fmt!r}; one of native, {', '.join(EXPORT_SUFFIX)}")
    wheres = [f"{config.source}: sequence {spec.name!r}" for spec in config.sequences]
    ahdrs = [to_ahdr_config(spec.settings, where=where) for spec, where in zip(config.sequences, wheres)]
    out = prepare_output_dir(out_dir, overwrite)
    root = np.random.SeedSequence(config.seed if seed is None else seed)
    children = root.spawn(len(config.sequences))
    entries = []
    for i, (spec, where, ahdr, child) in enumerate(zip(config.sequences, wheres, ahdrs, children)):
        s = spec.settings
        scene = build_scene(spec.scene, s["height"], s["width"], spec.duration_us, where=f"{where}.scene")
        if progress:
            print(f"[{i + 1}/{len(config.sequences)}] {spec.name}", flush=True)
        entries.append(write_sequence(out, spec.name, scene, ahdr, child, fmt, progress=progress))
    return write_index(out, {"generator": "ahdr", "seed": seed_record(root), "format": fmt,
                             "config_source": config.source, "sequences": entries})
