"""Writing a dataset folder: one native HDF5 file per sequence (plus an optional export), a manifest per sequence
and index.json.

Layout of an output folder:
    <name>.h5            the native file of each sequence (always written: it holds the ground truth)
    <name>_e2vid.h5 | <name>_ijrr/ | <name>.mat    the export, when a format other than native is chosen
    <name>.manifest.json the sequence's spec_hash and the size and SHA-256 of every file it owns (the native file and
                         each file of its export), written last, atomically, once those files are complete
    index.json           what the folder holds: generator, root seed, format, and per sequence its file, export,
                         seed record, scene, parameters, counts and spec_hash

Every sequence is one task, make_sequence(task, scene, out, spec_hash) -> its index entry, a pure function of
its arguments run by generators.runner (serially, on local worker processes or on an existing Dask cluster), so
the files are bit-identical whatever the worker count or order. Each file is written atomically; the task deletes
the sequence's manifest before it writes anything, so a manifest never vouches for files in the middle of a change.

index.json is removed before a run into an existing folder (--overwrite, --resume) and written last, atomically,
only when every sequence succeeded: a folder that has index.json is complete and consistent.

Resuming (resume=True, `--resume`): a sequence is kept only when verify_sequence finds its manifest intact (its own
SHA-256 matches), recording the same spec_hash, and the files it owns exactly those the manifest lists, each with
the recorded size and SHA-256; every other sequence is generated again, and a line per sequence names the file and
the reason (a sequence without a manifest, from an interrupted run or an older evsim, is generated again too).
spec_hash is the SHA-256 of the sequence's name, scene description (the scene table, or scene.describe(): input
files by path, not by content), generation configuration (AHDRConfig.to_dict()), seed record, export format, extra
metadata, the evsim version and the native layout version; it is recorded in the native file's metadata, in the
manifest and in the index.json entry.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sim import EvsimInputError, EvsimNote, OptionError
from sim.seeding import seed_record

from .ahdr import AHDRConfig, generate_ahdr
from .choices import INDEX_FILE, MANIFEST_SUFFIX
from .config import DatasetConfig, build_scene, check_sequence_name, to_ahdr_config
from .formats import HOLDS, ExportDropWarning, export
from .formats.atomic import discard, write_text_atomic
from .formats.common import json_attr, open_h5
from .formats.native import FORMAT_VERSION
from .formats.registry import REGISTRY
from .runner import check_run_options, raise_failures, run_tasks

if TYPE_CHECKING:
    from sim.source import RadianceSource

    from .scenes import Scene

#: the name suffix of a sequence's export in each format but native ("<name><suffix>"; generators.formats.registry)
EXPORT_SUFFIX = {f.name: f.export_suffix for f in REGISTRY if f.exportable and f.name != "native"}
MANIFEST_VERSION = 1
_MANIFEST_MAX_BYTES = 16 << 20  # a manifest lists a few files (an IJRR folder: one per frame); larger is not one


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
        what = f"output folder {out} already exists and is not empty; pass"
        raise OptionError(f"{what} overwrite=True to replace its contents, or resume=True to complete it",
                          f"{what} --overwrite to replace its contents, or --resume to complete it")
    out.mkdir(parents=True, exist_ok=True)
    return out


def write_sequence(out: Path, name: str, scene: RadianceSource, ahdr_config: AHDRConfig | None,
                   seed: int | np.random.SeedSequence, fmt: str, *, progress: bool,
                   metadata: dict | None = None) -> dict:
    """Generate one sequence into out/<name>.h5 (and its export); return its index entry."""
    path = out / f"{check_sequence_name('sequence name', name)}.h5"
    metadata = metadata or {}
    config = ahdr_config or AHDRConfig()
    for note in getattr(scene, "generation_notes", lambda camera, outputs: [])(config.camera, config.outputs):
        warnings.warn(note, EvsimNote, stacklevel=2)
    generate_ahdr(scene, path, ahdr_config, seed, progress=progress, metadata={"name": name, **metadata})
    if fmt != "native":
        with warnings.catch_warnings():  # said once per run by run_sequences (export_note)
            warnings.simplefilter("ignore", ExportDropWarning)
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
    """One sequence as a task: delete its manifest, build the scene (a SceneRecipe) if needed, write its file(s),
    then its manifest (write_manifest); return its index entry. digest is spec_hash(task, scene), recorded in the
    native file's metadata and in the manifest."""
    name = check_sequence_name("sequence name", task.name)
    (out / f"{name}{MANIFEST_SUFFIX}").unlink(missing_ok=True)  # nothing vouches for the files while they change
    if isinstance(scene, SceneRecipe):
        scene = scene.build()
    entry = write_sequence(out, name, scene, task.ahdr, task.seed, task.fmt, progress=progress,
                           metadata={**task.metadata, "spec_hash": digest})
    write_manifest(out, name, task.fmt, digest)
    return entry


def owned_files(out: Path, name: str, fmt: str) -> list[str]:
    """The files (paths relative to out, with /) that sequence `name` owns besides its manifest, as they are on
    disk: <name>.h5 and the export (every entry of an export folder such as <name>_ijrr/, sorted)."""
    found = []
    for root in [f"{name}.h5"] + ([f"{name}{EXPORT_SUFFIX[fmt]}"] if fmt != "native" else []):
        top = out / root
        if top.is_dir() and not top.is_symlink():
            for folder, dirs, files in os.walk(top):
                here = Path(folder)
                # a link to a folder is listed as an entry (not followed): it is nothing a writer makes
                found += [(here / f).relative_to(out).as_posix()
                          for f in files + [d for d in dirs if (here / d).is_symlink()]]
        elif top.exists() or top.is_symlink():
            found.append(root)
    return sorted(found)


def _sha256(path: Path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def write_manifest(out: Path, name: str, fmt: str, digest: str) -> dict[str, dict]:
    """Write out/<name>.manifest.json atomically: spec_hash `digest`, the size and SHA-256 of every file
    owned_files lists, and the SHA-256 of the manifest's own content; return the files' {"bytes", "sha256"}."""
    files = {rel: {"bytes": (out / rel).stat().st_size, "sha256": _sha256(out / rel)}
             for rel in owned_files(out, name, fmt)}
    body = {"evsim_manifest": MANIFEST_VERSION, "sequence": name, "spec_hash": digest, "files": files}
    write_text_atomic(out / f"{name}{MANIFEST_SUFFIX}", json.dumps({**body, "sha256": _body_hash(body)}, indent=1))
    return files


def _body_hash(body: dict) -> str:
    return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def read_manifest(path: Path) -> dict | None:
    """The manifest at path ({"evsim_manifest", "sequence", "spec_hash", "files"}), or None when it cannot be read,
    is not one, or its content does not match its own SHA-256."""
    try:
        if path.stat().st_size > _MANIFEST_MAX_BYTES:
            return None
        data = json.loads(path.read_bytes())
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or set(data) != {"evsim_manifest", "sequence", "spec_hash", "files", "sha256"}:
        return None
    body = {k: v for k, v in data.items() if k != "sha256"}
    if data["sha256"] != _body_hash(body) or data["evsim_manifest"] != MANIFEST_VERSION:
        return None
    files = data["files"]
    if not isinstance(files, dict) or not all(
            isinstance(v, dict) and set(v) == {"bytes", "sha256"} and type(v["bytes"]) is int
            and isinstance(v["sha256"], str) for v in files.values()):
        return None
    return body


def verify_sequence(out: Path, name: str, fmt: str, digest: str) -> str:
    """"" when sequence `name` can be trusted as written: its manifest is intact and records spec_hash `digest`,
    and the files it owns (owned_files) are exactly those the manifest lists, each of the recorded size and
    SHA-256. Otherwise why not, naming the file."""
    manifest_path = out / f"{name}{MANIFEST_SUFFIX}"
    if not manifest_path.exists():
        if not owned_files(out, name, fmt):
            return f"not written yet (no {name}.h5)"
        return (f"no {manifest_path.name} (an interrupted run, or written by an evsim that recorded no content "
                "hashes): nothing vouches for its files")
    manifest = read_manifest(manifest_path)
    if manifest is None:
        return f"{manifest_path.name} is corrupt (unreadable, or its content does not match its own SHA-256)"
    if manifest["sequence"] != name:
        return f"{manifest_path.name} describes sequence {manifest['sequence']!r}"
    if manifest["spec_hash"] != digest:
        return f"configuration or seed changed ({manifest_path.name} records another spec_hash)"
    recorded, present = manifest["files"], owned_files(out, name, fmt)
    roots = [f"{name}.h5"] + ([f"{name}{EXPORT_SUFFIX[fmt]}"] if fmt != "native" else [])
    for root in roots:
        if not any(rel == root or rel.startswith(f"{root}/") for rel in recorded):
            return f"{manifest_path.name} lists no {root}"
    missing = [rel for rel in recorded if rel not in present]
    if missing:
        return f"{missing[0]} is missing"
    extra = [rel for rel in present if rel not in recorded]
    if extra:
        return f"{extra[0]} is not in {manifest_path.name}"
    for rel, rec in recorded.items():  # sizes first: a truncated file is found without reading the others
        path = out / rel
        if not path.is_file():
            return f"{rel} is not a file"
        size = path.stat().st_size
        if size != rec["bytes"]:
            return f"{rel} has {size} bytes, {rec['bytes']} recorded (truncated or replaced)"
    for rel, rec in recorded.items():
        try:
            if _sha256(out / rel) != rec["sha256"]:
                return f"{rel} differs from its recorded SHA-256 (changed since it was written)"
        except OSError as e:
            return f"{rel} cannot be read ({e.strerror or e})"
    return ""


def export_note(tasks: list[SequenceTask]) -> str:
    """"" when every sequence's export holds all its file holds, else one sentence naming what the exports leave
    out (the native files keep it)."""
    dropped: dict[str, list[str]] = {}
    for t in tasks:
        if t.fmt == "native":
            continue
        parts = ["events", *t.ahdr.outputs, "threshold_maps" * t.ahdr.threshold_maps, "event_labels" * t.ahdr.labels,
                 "crf", "metadata"]
        for part in parts:
            if part and part not in HOLDS[t.fmt] and part not in dropped.setdefault(t.fmt, []):
                dropped[t.fmt].append(part)
    return "; ".join(f"{fmt} holds {', '.join(HOLDS[fmt])} and the sensor size: its exports leave out "
                     f"{', '.join(parts)} (the native .h5 files keep them)" for fmt, parts in dropped.items() if parts)


def write_index(out: Path, index: dict) -> Path:
    """Write index.json atomically."""
    path = out / INDEX_FILE
    write_text_atomic(path, json.dumps(index, indent=2))
    return path


def _resume_state(out: Path, task: SequenceTask, digest: str) -> tuple[dict | None, str]:
    """(the index entry of a verified sequence, "") or (None, why it must be generated, naming the file)."""
    why = verify_sequence(out, task.name, task.fmt, digest)
    if why:
        return None, why
    try:
        entry = index_entry(out, task.name, task.fmt, (*task.metadata, "spec_hash"))
    except (EvsimInputError, ValueError, KeyError):
        return None, f"{task.name}.h5 has incomplete metadata"
    if entry["spec_hash"] != digest:
        return None, f"{task.name}.h5 records another spec_hash than its manifest"
    return entry, ""


def _discard_stale_temporaries(out: Path, tasks: list[SequenceTask]) -> None:
    """Delete the temporary files (generators.formats.atomic names) that a killed run left for these sequences."""
    prefixes = tuple(f".{t.name}{suffix}." for t in tasks
                     for suffix in (".h5", MANIFEST_SUFFIX, EXPORT_SUFFIX.get(t.fmt, ".h5")))
    for p in out.iterdir():
        if p.name.startswith(prefixes) and p.name.endswith(".tmp"):
            discard(p)


def _sequence_files(task: SequenceTask) -> list[str]:
    """The names of the files and folders sequence `task` writes in the output folder: <name>.h5, its manifest and
    its export (a folder for ijrr, a file for the others)."""
    name = check_sequence_name("sequence name", task.name)
    exports = [f"{name}{EXPORT_SUFFIX[task.fmt]}"] if task.fmt != "native" else []
    return [f"{name}.h5", f"{name}{MANIFEST_SUFFIX}", *exports]


def _check_file_names(tasks: list[SequenceTask]) -> None:
    """EvsimInputError when two sequences would write the same file (the e2vid export of "a", a_e2vid.h5, is the
    native file of a sequence named "a_e2vid")."""
    owner: dict[str, str] = {}
    for t in tasks:
        for file in _sequence_files(t):
            if owner.setdefault(file, t.name) != t.name:
                raise EvsimInputError(f"sequences {owner[file]!r} and {t.name!r} would both write {file}: rename one")


def _check_targets(out: Path, tasks: list[SequenceTask]) -> None:
    """Before any work: EvsimInputError naming the path when the output folder `out` holds a folder where the run
    writes a file (index.json, a sequence's .h5, manifest or export file), which no overwrite replaces."""
    folders = {f"{t.name}{EXPORT_SUFFIX['ijrr']}" for t in tasks if t.fmt == "ijrr"}  # exports that are folders
    for name in [INDEX_FILE, *(f for t in tasks for f in _sequence_files(t))]:
        if name not in folders and (out / name).is_dir():
            raise EvsimInputError(f"{out / name} is a folder where this run writes a file: remove it or choose "
                                  "another output folder")


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
        why = "keeps the complete, matching files, {} generates everything again"
        raise OptionError("resume=True and overwrite=True exclude each other: resume "
                          + why.format("overwrite"), "--resume and --overwrite exclude each other: --resume "
                          + why.format("--overwrite"))
    _check_file_names([task for task, _ in jobs])
    _check_targets(Path(out_dir), [task for task, _ in jobs])
    created = first_missing(Path(out_dir))
    out = prepare_output_dir(out_dir, overwrite or resume).resolve()
    try:
        return _run_into(out, jobs, header, resume, workers, scheduler, progress)
    except BaseException:  # failed or interrupted: no empty folder left behind
        remove_if_empty(Path(out_dir), created)
        raise


def first_missing(folder: Path) -> Path | None:
    """The outermost of `folder` and its parents that does not exist yet (what creating it creates), or None."""
    folder = Path(folder).absolute()
    missing = None
    for p in (folder, *folder.parents):
        if p.exists() or p.is_symlink():
            break
        missing = p
    return missing


def remove_if_empty(folder: Path, up_to: Path | None) -> None:
    """Remove `folder` if it is an empty folder (so that a failed or interrupted run leaves nothing that looks like
    a result), then its parents while they are empty, up to `up_to` (the outermost folder the run created:
    first_missing before it); nothing when up_to is None (the folder existed before) or does not contain folder."""
    if up_to is None:
        return
    folder, up_to = Path(folder).absolute(), Path(up_to).absolute()
    for p in (folder, *folder.parents):
        if p != up_to and up_to not in p.parents:
            return
        try:
            p.rmdir()
        except OSError:  # not empty (complete sequences are kept for --resume), or gone
            return


def _run_into(out: Path, jobs: list[tuple[SequenceTask, Scene | SceneRecipe]], header: dict, resume: bool,
              workers: int | None, scheduler: str | None, progress: bool) -> Path:
    (out / INDEX_FILE).unlink(missing_ok=True)  # from here on the folder does not claim to be complete
    digests = [spec_hash(task, scene) for task, scene in jobs]
    entries: list[dict | None] = [None] * len(jobs)
    todo = list(range(len(jobs)))
    if resume:
        states = [_resume_state(out, task, d) for (task, _), d in zip(jobs, digests)]
        entries = [entry for entry, _ in states]
        todo = [i for i, (entry, _) in enumerate(states) if entry is None]
        kept = [jobs[i][0].name for i in range(len(jobs)) if entries[i] is not None]
        redo = [jobs[i][0].name for i in todo]
        print(f"resume: {len(kept)} of {len(jobs)} sequence(s) verified (every file matches its manifest)"
              f"{', kept: ' + _names(kept) if kept else ''}; {len(todo)} to generate"
              f"{': ' + _names(redo) if redo else ''}", flush=True)
        for i in todo:
            print(f"resume: generating {jobs[i][0].name} again: {states[i][1]}", flush=True)
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
    hint = f"the other files in {out} are complete; index.json was not written (rerun with {{}} to generate the " \
           "failed sequences)"
    raise_failures("sequences", failures, len(tasks), hint.format("resume=True"), cli_hint=hint.format("--resume"))
    index = write_index(out, {**header, "sequences": entries})
    # what the exports leave out is said once the dataset is complete (after a failure, the failure is the message)
    note = export_note([task for task, _ in jobs])
    if note:
        warnings.warn(note, ExportDropWarning, stacklevel=2)
    return index


def dataset_jobs(config: DatasetConfig, *, fmt: str | None = None,
                 seed: int | None = None) -> tuple[list[tuple[SequenceTask, SceneRecipe]], dict]:
    """The work of a configuration, every sequence validated first. Sequence i is seeded with child i of the root
    SeedSequence.

    Parameters
    ----------
    config : DatasetConfig
        The configuration.
    fmt, seed : optional
        As generate_dataset's.

    Returns
    -------
    jobs : list of (SequenceTask, SceneRecipe)
        The task and scene recipe of every sequence.
    header : dict
        The index header (generator, seed record, format, config_source).
    """
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
    """Generate every sequence of a dataset configuration into out_dir.

    Sequence i is seeded with child i of the root SeedSequence (recorded in index.json and in each file's
    metadata). Failed sequences raise generators.runner.TasksFailed once the others are written.

    Parameters
    ----------
    config : DatasetConfig
        The configuration (generators.config.load_config / parse_config).
    out_dir : str or Path
        The dataset folder (see the module for its layout).
    overwrite : bool, optional
        Write into a folder that holds files already (default False: refused).
    progress : bool, optional
        Show progress bars (default True).
    fmt : str, optional
        Override the configuration's format ("native" or an export format).
    seed : int, optional
        Override the configuration's root seed.
    workers : int, optional
        Run the sequences on a local Dask cluster of this many processes (see generators.runner); default serial.
    scheduler : str, optional
        The address of an existing Dask scheduler to run them on.
    resume : bool, optional
        Keep the sequences of an earlier run with the same configuration and seed whose files match their
        manifests (verify_sequence) and generate the others again (default False).

    Returns
    -------
    Path
        The index.json written.
    """
    jobs, header = dataset_jobs(config, fmt=fmt, seed=seed)
    return run_sequences(out_dir, jobs, header, overwrite=overwrite, resume=resume, workers=workers,
                         scheduler=scheduler, progress=progress)
