"""Writing a dataset folder: one native HDF5 file per sequence (plus an optional export), and index.json.

Layout of an output folder:
    <name>.h5            the native file of each sequence (always written: it holds the ground truth)
    <name>_e2vid.h5 | <name>_ijrr/ | <name>.mat    the export, when a format other than native is chosen
    index.json           what the folder holds: generator, root seed, format, and per sequence its file, export,
                         seed record, scene, parameters, counts and spec_hash

Every sequence is one task, make_sequence(task, scene, out, spec_hash) -> its index entry, a pure function of
its arguments run by generators.runner (serially, on local worker processes or on an existing Dask cluster), so
the files are bit-identical whatever the worker count or order. Each file is written atomically.

index.json is removed before a run into an existing folder (--overwrite, --resume) and written last, atomically,
only when every sequence succeeded: a folder that has index.json is complete and consistent.

Resuming (resume=True, `--resume`): a sequence whose native file (and export) is there, readable and records the
same spec_hash is kept; the others are generated again. spec_hash is the SHA-256 of the sequence's name, scene
description (the scene table, or scene.describe(): input files by path, not by content), generation configuration
(AHDRConfig.to_dict()), seed record, export format, extra metadata, the evsim version and the native layout
version; it is recorded in each file's metadata and in its index.json entry.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sim import EvsimInputError
from sim.seeding import seed_record

from .ahdr import AHDRConfig, generate_ahdr
from .config import DatasetConfig, build_scene, check_sequence_name, to_ahdr_config
from .formats import export
from .formats.atomic import discard, write_text_atomic
from .formats.common import json_attr, open_h5
from .formats.native import FORMAT_VERSION
from .runner import check_run_options, raise_failures, run_tasks

if TYPE_CHECKING:
    from sim.source import RadianceSource

    from .scenes import Scene

INDEX_FILE = "index.json"
EXPORT_SUFFIX = {"e2vid": "_e2vid.h5", "ijrr": "_ijrr", "akf-mat": ".mat", "e2vid-txt": "_e2vid.zip",
                 "aedat4": ".aedat4", "evt3": "_evt3.raw", "evt2": "_evt2.raw", "dat": "_td.dat"}


@dataclass(frozen=True)
class SceneRecipe:
    """A scene table (generators.config schema) at a size (pixels) and duration (microseconds), built by the task
    where it runs (so that a cluster receives a few bytes, not images)."""

    table: dict
    height: int
    width: int
    duration_us: int
    where: str = "scene"

    def build(self) -> Scene:
        return build_scene(self.table, self.height, self.width, self.duration_us, where=self.where)

    def describe(self) -> dict:
        return {"table": self.table, "height": self.height, "width": self.width, "duration_us": self.duration_us}


@dataclass(frozen=True)
class SequenceTask:
    """What determines one sequence's files, besides its scene: name, generation configuration, seed, export
    format and extra metadata (stored in the file and in its index entry)."""

    name: str
    ahdr: AHDRConfig
    seed: np.random.SeedSequence
    fmt: str = "native"
    metadata: dict = field(default_factory=dict)


def spec_hash(task: SequenceTask, scene: Scene | SceneRecipe) -> str:
    """SHA-256 (hex) of everything that determines the sequence's files (see the module docstring)."""
    try:
        version = importlib.metadata.version("evsim")
    except importlib.metadata.PackageNotFoundError:
        version = None
    spec = {"name": task.name, "scene": scene.describe(), "config": task.ahdr.to_dict(),
            "seed": seed_record(task.seed), "format": task.fmt, "metadata": task.metadata,
            "evsim": version, "native_format_version": FORMAT_VERSION}
    text = json.dumps(spec, sort_keys=True, separators=(",", ":"), default=_json_default)
    return hashlib.sha256(text.encode()).hexdigest()


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"cannot hash a {type(o).__name__}")


def prepare_output_dir(out_dir: str | Path, overwrite: bool) -> Path:
    """Create out_dir; refuse (EvsimInputError) when it already holds files and overwrite is False."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise EvsimInputError(f"output {out} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not overwrite:
        raise EvsimInputError(f"output folder {out} already exists and is not empty; "
                              "pass --overwrite (overwrite=True) to replace its contents, or --resume "
                              "(resume=True) to complete it")
    out.mkdir(parents=True, exist_ok=True)
    return out


def write_sequence(out: Path, name: str, scene: RadianceSource, ahdr_config: AHDRConfig | None,
                   seed: int | np.random.SeedSequence, fmt: str, *, progress: bool,
                   metadata: dict | None = None) -> dict:
    """Generate one sequence into out/<name>.h5 (and its export); return its index entry."""
    path = out / f"{check_sequence_name('sequence name', name)}.h5"
    metadata = metadata or {}
    generate_ahdr(scene, path, ahdr_config, seed, progress=progress, metadata={"name": name, **metadata})
    if fmt != "native":
        export(path, out / f"{name}{EXPORT_SUFFIX[fmt]}", fmt)
    return index_entry(out, name, fmt, tuple(metadata))


def index_entry(out: Path, name: str, fmt: str, extra_keys: tuple[str, ...] = ()) -> dict:
    """The index entry of the sequence written as out/<name>.h5, read from its metadata (so a resumed dataset's
    index equals a fresh one's): name, file, seed, scene, counts, duration, the extra metadata keys, export."""
    path = out / f"{name}.h5"
    with open_h5(path) as f:
        meta = json_attr(f, "metadata", {})
    entry = {"name": name, "file": path.name, "seed": meta["seed"], "scene": meta["scene"],
             "n_events": meta["n_events"], "n_frames": meta["n_frames"], "n_dvs_samples": meta["n_dvs_samples"],
             "duration_us": meta["duration_us"], **{k: meta[k] for k in extra_keys}}
    if fmt != "native":
        entry["export"] = f"{name}{EXPORT_SUFFIX[fmt]}"
    return entry


def make_sequence(task: SequenceTask, scene: RadianceSource | SceneRecipe, out: Path, digest: str,
                  progress: bool = False) -> dict:
    """One sequence as a task: build the scene (a SceneRecipe) if needed, write its file(s); return its index
    entry. digest is spec_hash(task, scene), recorded in the file's metadata."""
    if isinstance(scene, SceneRecipe):
        scene = scene.build()
    return write_sequence(out, task.name, scene, task.ahdr, task.seed, task.fmt, progress=progress,
                          metadata={**task.metadata, "spec_hash": digest})


def write_index(out: Path, index: dict) -> Path:
    """Write index.json atomically."""
    path = out / INDEX_FILE
    write_text_atomic(path, json.dumps(index, indent=2))
    return path


def _resume_state(out: Path, task: SequenceTask, digest: str) -> tuple[dict | None, str]:
    """(the index entry of a complete matching sequence, "") or (None, why it must be generated)."""
    path = out / f"{task.name}.h5"
    if not path.is_file():
        return None, "no file"
    try:
        with open_h5(path) as f:
            meta = json_attr(f, "metadata", {})
    except (EvsimInputError, ValueError):
        return None, "unreadable file"
    if meta.get("spec_hash") != digest:
        return None, "configuration or seed changed" if "spec_hash" in meta else "no recorded hash"
    if task.fmt != "native" and not (out / f"{task.name}{EXPORT_SUFFIX[task.fmt]}").exists():
        return None, f"no {task.fmt} export"
    try:
        return index_entry(out, task.name, task.fmt, (*task.metadata, "spec_hash")), ""
    except (EvsimInputError, ValueError, KeyError):
        return None, "incomplete metadata"


def _discard_stale_temporaries(out: Path, tasks: list[SequenceTask]) -> None:
    """Delete the temporary files (generators.formats.atomic names) that a killed run left for these sequences."""
    prefixes = tuple(f".{t.name}{suffix}." for t in tasks for suffix in (".h5", EXPORT_SUFFIX.get(t.fmt, ".h5")))
    for p in out.iterdir():
        if p.name.startswith(prefixes) and p.name.endswith(".tmp"):
            discard(p)


def _names(names: list[str], limit: int = 8) -> str:
    return ", ".join(names[:limit]) + (f", ... ({len(names) - limit} more)" if len(names) > limit else "")


def run_sequences(out_dir: str | Path, jobs: list[tuple[SequenceTask, Scene | SceneRecipe]], header: dict, *,
                  overwrite: bool = False, resume: bool = False, workers: int | None = None,
                  scheduler: str | None = None, progress: bool = True) -> Path:
    """Generate (task, scene) jobs into out_dir and write index.json = header + {"sequences": entries} last;
    return its path. When sequences fail, raises generators.runner.TasksFailed once the others are written
    (EvsimInputError when all failed on bad input), and index.json is not written. See the module docstring for
    overwrite and resume."""
    check_run_options(workers, scheduler)
    if overwrite and resume:
        raise EvsimInputError("--resume and --overwrite exclude each other: --resume keeps the complete, "
                              "matching files, --overwrite generates everything again")
    out = prepare_output_dir(out_dir, overwrite or resume).resolve()
    (out / INDEX_FILE).unlink(missing_ok=True)  # from here on the folder does not claim to be complete
    digests = [spec_hash(task, scene) for task, scene in jobs]
    entries: list[dict | None] = [None] * len(jobs)
    todo = list(range(len(jobs)))
    if resume:
        states = [_resume_state(out, task, d) for (task, _), d in zip(jobs, digests)]
        entries = [entry for entry, _ in states]
        todo = [i for i, (entry, _) in enumerate(states) if entry is None]
        kept = [jobs[i][0].name for i in range(len(jobs)) if entries[i] is not None]
        redo = [f"{jobs[i][0].name} ({states[i][1]})" for i in todo]
        print(f"resume: {len(kept)} of {len(jobs)} sequence(s) complete and unchanged, kept"
              f"{': ' + _names(kept) if kept else ''}; {len(todo)} to generate{': ' + _names(redo) if redo else ''}",
              flush=True)
    _discard_stale_temporaries(out, [jobs[i][0] for i in todo])
    serial = workers is None and scheduler is None
    tasks = [(jobs[i][0].name, (jobs[i][0], jobs[i][1], out, digests[i]), {"progress": progress and serial})
             for i in todo]
    failures = []
    for i, outcome in zip(todo, run_tasks(make_sequence, tasks, workers=workers, scheduler=scheduler,
                                          progress=progress)):
        if outcome.ok:
            entries[i] = outcome.value
        else:
            failures.append(outcome)
    raise_failures("sequences", failures, len(tasks),
                   f"the other files in {out} are complete; index.json was not written (rerun with --resume to "
                   "generate the failed sequences)")
    return write_index(out, {**header, "sequences": entries})


def dataset_jobs(config: DatasetConfig, *, fmt: str | None = None,
                 seed: int | None = None) -> tuple[list[tuple[SequenceTask, SceneRecipe]], dict]:
    """The (task, scene recipe) of every sequence of a configuration (all validated first) and the index header.
    Sequence i is seeded with child i of the root SeedSequence."""
    fmt = config.format if fmt is None else fmt
    if fmt not in ("native", *EXPORT_SUFFIX):
        raise EvsimInputError(f"unknown format {fmt!r}; one of native, {', '.join(EXPORT_SUFFIX)}")
    root = np.random.SeedSequence(config.seed if seed is None else seed)
    jobs = []
    for spec, child in zip(config.sequences, root.spawn(len(config.sequences))):
        where = f"{config.source}: sequence {spec.name!r}"
        s = spec.settings
        jobs.append((SequenceTask(spec.name, to_ahdr_config(s, where=where), child, fmt),
                     SceneRecipe(spec.scene, s["height"], s["width"], spec.duration_us, where=f"{where}.scene")))
    header = {"generator": "ahdr", "seed": seed_record(root), "format": fmt, "config_source": config.source}
    return jobs, header


def generate_dataset(config: DatasetConfig, out_dir: str | Path, *, overwrite: bool = False, progress: bool = True,
                     fmt: str | None = None, seed: int | None = None, workers: int | None = None,
                     scheduler: str | None = None, resume: bool = False) -> Path:
    """Generate every sequence of a dataset configuration into out_dir; return the index path.

    fmt and seed override the configuration's format and root seed. Sequence i is seeded with child i of the root
    SeedSequence (recorded in index.json and in each file's metadata). workers=N runs the sequences on a local
    Dask cluster of N processes, scheduler=ADDRESS on an existing one (see generators.runner); resume=True keeps
    the complete sequences of an earlier run with the same configuration and seed. Failed sequences raise
    generators.runner.TasksFailed once the others are written.
    """
    jobs, header = dataset_jobs(config, fmt=fmt, seed=seed)
    return run_sequences(out_dir, jobs, header, overwrite=overwrite, resume=resume, workers=workers,
                         scheduler=scheduler, progress=progress)
