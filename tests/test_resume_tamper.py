"""`--resume` keeps only what it verifies (generators.dataset.verify_sequence).

A dataset is generated cleanly (seed 4) and with a foreign seed (5); a copy of the clean one is tampered with (an
export or native file from the foreign run, a flipped bit, a truncation or a deletion of any file a sequence owns,
its manifest included, an extra file in an export folder), then resumed. Exactly the tampered sequences must be
generated again, each with a line naming the file and the reason; the other sequences' files keep their bytes and
mtimes; the result equals the clean run byte for byte (index.json included); index.json is written only once every
sequence is verified or generated again.

test_seeded_tampering_is_always_found is the seeded loop: EVSIM_TAMPER_N rounds (default 9, one per export
format and native; EVSIM_FUZZ_SEED shifts the seeds), each tampering with a random subset of the sequences.
"""

from __future__ import annotations

import os
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import generators.dataset as dataset
from evsim_app.cli import main
from generators.config import load_config
from generators.dataset import EXPORT_SUFFIX, MANIFEST_SUFFIX, generate_dataset, owned_files
from sim import EvsimInputError

CONFIG = """
seed = 4
[defaults]
duration_s = 0.05
height = 12
width = 16
[[sequence]]
name = "edge"
scene = { type = "moving_edge", speed_px_per_s = 80.0 }
[[sequence]]
name = "sun"
scene = { type = "sun", velocity_px_per_s = [40.0, 10.0] }
[[sequence]]
name = "flicker"
scene = { type = "flicker", frequency_hz = 50.0 }
"""
NAMES = ["edge", "sun", "flicker"]
TAMPER_N = int(os.environ.get("EVSIM_TAMPER_N", "9"))
SEED = int(os.environ.get("EVSIM_FUZZ_SEED", "0"))


@pytest.fixture(scope="module")
def config_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cfg") / "tiny.toml"
    path.write_text(CONFIG)
    return path


@pytest.fixture(scope="module")
def reference(config_file, tmp_path_factory):
    """reference(fmt) -> (clean, foreign): the dataset with its own seed and with seed 5, generated once each."""
    made: dict[str, tuple[Path, Path]] = {}

    def get(fmt: str) -> tuple[Path, Path]:
        if fmt not in made:
            base = tmp_path_factory.mktemp(f"ref_{fmt}")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # exports that drop parts of the recording say so
                generate_dataset(load_config(config_file), base / "clean", progress=False, fmt=fmt)
                generate_dataset(load_config(config_file), base / "foreign", progress=False, fmt=fmt, seed=5)
            made[fmt] = base / "clean", base / "foreign"
        return made[fmt]

    return get


def snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    """Every file under folder (relative path) -> (bytes, mtime_ns)."""
    return {p.relative_to(folder).as_posix(): (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if p.is_file() or p.is_symlink()}


def content(snap: dict) -> dict[str, bytes]:
    return {k: v[0] for k, v in snap.items()}


def files_of(snap: dict, name: str, fmt: str) -> dict:
    """The entries of a snapshot that sequence `name` owns, its manifest included."""
    roots = [f"{name}.h5", f"{name}{MANIFEST_SUFFIX}"] + ([f"{name}{EXPORT_SUFFIX[fmt]}"] if fmt != "native" else [])
    return {k: v for k, v in snap.items() if any(k == r or k.startswith(f"{r}/") for r in roots)}


def resume(config_file: Path, out: Path, fmt: str, capsys) -> dict[str, str]:
    """Run generate_dataset(resume=True); return {sequence generated again: the reason it printed}."""
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        generate_dataset(load_config(config_file), out, progress=False, fmt=fmt, resume=True)
    said = capsys.readouterr().out
    redo = dict(re.findall(r"^resume: generating (\S+) again: (.*)$", said, re.M))
    kept = [n for n in NAMES if n not in redo]
    assert f"resume: {len(kept)} of {len(NAMES)} sequence(s) verified" in said
    return redo


def assert_resumed_to_clean(clean: Path, out: Path, before: dict, tampered: set[str], fmt: str,
                            redo: dict[str, str]) -> None:
    assert set(redo) == tampered, redo
    after = snapshot(out)
    for name in set(NAMES) - tampered:  # not rewritten: the same bytes and the same mtimes
        assert files_of(after, name, fmt) == files_of(before, name, fmt), name
    assert content(after) == content(snapshot(clean))


def _export(name: str, fmt: str) -> str:
    return f"{name}{EXPORT_SUFFIX[fmt]}"


def _one_file(out: Path, rel: str) -> Path:
    """rel itself, or the largest file inside it when it is a folder (an IJRR export)."""
    p = out / rel
    return max((q for q in p.rglob("*") if q.is_file()), key=lambda q: q.stat().st_size) if p.is_dir() else p


def _replace(src: Path, dst: Path) -> None:
    if dst.is_dir():
        shutil.rmtree(dst)
    (shutil.copytree if src.is_dir() else shutil.copy2)(src, dst)


def _flip(path: Path, offset: int, bit: int = 0) -> None:
    data = bytearray(path.read_bytes())
    data[offset % len(data)] ^= 1 << bit
    path.write_bytes(bytes(data))


def _truncate(path: Path, size: int) -> None:
    with open(path, "r+b") as f:
        f.truncate(size)


def _delete(path: Path) -> None:
    shutil.rmtree(path) if path.is_dir() else path.unlink()


# (name, what it does to sequence "sun" of a copy of the clean dataset, a regex of the reason said)
TAMPERING = {
    "foreign-seed export": (lambda out, foreign, fmt: _replace(foreign / _export("sun", fmt),
                                                               out / _export("sun", fmt)),
                            r"^sun_\S+ (has \d+ bytes, \d+ recorded|differs from its recorded SHA-256)"),
    "foreign-seed native": (lambda out, foreign, fmt: _replace(foreign / "sun.h5", out / "sun.h5"),
                            r"^sun\.h5 (has \d+ bytes, \d+ recorded|differs from its recorded SHA-256)"),
    "foreign-seed sequence": (lambda out, foreign, fmt: [_replace(foreign / f, out / f) for f in
                                                         ("sun.h5", _export("sun", fmt), f"sun{MANIFEST_SUFFIX}")],
                              r"^configuration or seed changed \(sun\.manifest\.json records another spec_hash\)"),
    "bit flip in native": (lambda out, foreign, fmt: _flip(out / "sun.h5", 2000, 4),
                           r"^sun\.h5 differs from its recorded SHA-256"),
    "bit flip in export": (lambda out, foreign, fmt: _flip(_one_file(out, _export("sun", fmt)), 700, 1),
                           r"^sun_\S+ differs from its recorded SHA-256"),
    "bit flip in manifest": (lambda out, foreign, fmt: _flip(out / f"sun{MANIFEST_SUFFIX}", 130, 0),
                             r"^sun\.manifest\.json is corrupt"),
    "truncated native": (lambda out, foreign, fmt: _truncate(out / "sun.h5", (out / "sun.h5").stat().st_size // 2),
                         r"^sun\.h5 has \d+ bytes, \d+ recorded \(truncated or replaced\)"),
    "truncated export": (lambda out, foreign, fmt: _truncate(_one_file(out, _export("sun", fmt)), 100),
                         r"^sun_\S+ has 100 bytes, \d+ recorded"),
    "truncated manifest": (lambda out, foreign, fmt: _truncate(out / f"sun{MANIFEST_SUFFIX}", 200),
                           r"^sun\.manifest\.json is corrupt"),
    "deleted native": (lambda out, foreign, fmt: _delete(out / "sun.h5"), r"^sun\.h5 is missing"),
    "deleted export": (lambda out, foreign, fmt: _delete(out / _export("sun", fmt)), r"^sun_\S+ is missing"),
    "deleted manifest": (lambda out, foreign, fmt: _delete(out / f"sun{MANIFEST_SUFFIX}"),
                         r"^no sun\.manifest\.json \(an interrupted run, or written by an evsim that recorded no"),
}


@pytest.mark.parametrize("fmt", ["e2vid", "ijrr", "evt3"])
@pytest.mark.parametrize("kind", list(TAMPERING))
def test_resume_regenerates_exactly_the_tampered_sequence(kind, fmt, reference, config_file, tmp_path, capsys):
    clean, foreign = reference(fmt)
    out = tmp_path / "d"
    shutil.copytree(clean, out)
    tamper, reason = TAMPERING[kind]
    tamper(out, foreign, fmt)
    before = snapshot(out)
    assert content(files_of(before, "sun", fmt)) != content(files_of(snapshot(clean), "sun", fmt))  # it did
    redo = resume(config_file, out, fmt, capsys)
    assert re.search(reason, redo.get("sun", "")), redo
    assert_resumed_to_clean(clean, out, before, {"sun"}, fmt, redo)


def test_an_extra_file_in_an_export_folder_is_not_trusted(reference, config_file, tmp_path, capsys):
    clean, _ = reference("ijrr")
    out = tmp_path / "d"
    shutil.copytree(clean, out)
    (out / "sun_ijrr" / "notes.txt").write_text("not written by evsim")
    before = snapshot(out)
    redo = resume(config_file, out, "ijrr", capsys)
    assert redo == {"sun": "sun_ijrr/notes.txt is not in sun.manifest.json"}
    assert_resumed_to_clean(clean, out, before, {"sun"}, "ijrr", redo)  # the folder is replaced whole


def test_a_dataset_without_manifests_is_generated_again(reference, config_file, tmp_path, capsys):
    # what an evsim that recorded no content hashes wrote: every file there, spec_hash in the metadata, no manifest
    clean, _ = reference("e2vid")
    out = tmp_path / "d"
    shutil.copytree(clean, out)
    for p in out.glob(f"*{MANIFEST_SUFFIX}"):
        p.unlink()
    before = snapshot(out)
    redo = resume(config_file, out, "e2vid", capsys)
    assert all(why.startswith(f"no {n}.manifest.json") for n, why in redo.items())
    assert_resumed_to_clean(clean, out, before, set(NAMES), "e2vid", redo)


def test_index_is_written_only_when_every_sequence_is_verified(reference, config_file, tmp_path, capsys,
                                                               monkeypatch):
    clean, foreign = reference("e2vid")
    out = tmp_path / "d"
    shutil.copytree(clean, out)
    _replace(foreign / "sun_e2vid.h5", out / "sun_e2vid.h5")
    real = dataset.make_sequence

    def failing(task, *args, **kwargs):
        if task.name == "sun":
            raise EvsimInputError("sun: the disk is unplugged (test)")
        return real(task, *args, **kwargs)

    monkeypatch.setattr(dataset, "make_sequence", failing)
    with pytest.raises(EvsimInputError, match="unplugged"):
        resume(config_file, out, "e2vid", capsys)
    assert not (out / "index.json").exists()  # removed first, not written: the folder does not claim completeness
    monkeypatch.setattr(dataset, "make_sequence", real)
    before = snapshot(out)
    redo = resume(config_file, out, "e2vid", capsys)  # the foreign export is still not trusted
    assert_resumed_to_clean(clean, out, before, {"sun"}, "e2vid", redo)


def test_cli_resume_replaces_a_foreign_seed_export(reference, config_file, tmp_path, capsys):
    # the reproduction: an e2vid export of another seed beside the right native file
    clean, foreign = reference("e2vid")
    out = tmp_path / "d"
    shutil.copytree(clean, out)
    _replace(foreign / "edge_e2vid.h5", out / "edge_e2vid.h5")
    capsys.readouterr()
    args = ["generate", "ahdr", "--config", str(config_file), "--out", str(out), "--format", "e2vid",
            "--no-progress", "--resume"]
    assert main(args) == 0
    said = capsys.readouterr().out
    assert "resume: 2 of 3 sequence(s) verified (every file matches its manifest), kept: sun, flicker" in said
    assert re.search(r"^resume: generating edge again: edge_e2vid\.h5 (has \d+ bytes|differs)", said, re.M)
    assert (out / "edge_e2vid.h5").read_bytes() == (clean / "edge_e2vid.h5").read_bytes()
    assert (out / "index.json").read_bytes() == (clean / "index.json").read_bytes()


def test_sequences_that_would_write_the_same_file_are_refused(config_file, tmp_path):
    # the e2vid export of "edge" is edge_e2vid.h5, the native file of a sequence named "edge_e2vid"
    (tmp_path / "c.toml").write_text(CONFIG + '[[sequence]]\nname = "edge_e2vid"\nscene = { type = "flicker" }\n')
    with pytest.raises(EvsimInputError, match="'edge' and 'edge_e2vid' would both write edge_e2vid.h5"):
        generate_dataset(load_config(tmp_path / "c.toml"), tmp_path / "d", progress=False, fmt="e2vid")
    assert not (tmp_path / "d").exists()
    generate_dataset(load_config(tmp_path / "c.toml"), tmp_path / "d", progress=False, fmt="ijrr")  # no clash


def _random_tamper(rng: np.random.Generator, out: Path, foreign: Path, name: str, fmt: str) -> str:
    """One random tampering with a file that sequence `name` owns (its manifest included); returns what it did."""
    owned = owned_files(out, name, fmt) + [f"{name}{MANIFEST_SUFFIX}"]
    rel = owned[rng.integers(len(owned))]
    path = out / rel
    ops = ["flip", "truncate", "delete", "foreign", "extra"]
    op = ops[rng.integers(len(ops))]
    if op == "flip":
        _flip(path, int(rng.integers(path.stat().st_size)), int(rng.integers(8)))
    elif op == "truncate" and path.stat().st_size > 0:
        _truncate(path, int(rng.integers(path.stat().st_size)))
    elif op == "foreign" and (foreign / rel).exists():
        _replace(foreign / rel, path)
    elif op == "extra" and fmt == "ijrr":
        (out / f"{name}_ijrr" / "stray.txt").write_bytes(b"x")
    else:
        op = "delete"
        _delete(path)
    return f"{op} {rel}"


@pytest.mark.slow
def test_seeded_tampering_is_always_found(reference, config_file, tmp_path, capsys):
    formats = ["native", *EXPORT_SUFFIX]
    for round_ in range(TAMPER_N):
        fmt = formats[round_ % len(formats)]
        rng = np.random.default_rng([SEED, round_])
        clean, foreign = reference(fmt)
        out = tmp_path / f"r{round_}"
        shutil.copytree(clean, out)
        chosen = [n for n in NAMES if rng.random() < 0.5]
        done = {}
        for name in chosen:
            done[name] = _random_tamper(rng, out, foreign, name, fmt)
        before = snapshot(out)
        # a foreign file can equal the clean one (an export without the seeded parts): then nothing was tampered with
        tampered = {n for n in NAMES
                    if content(files_of(before, n, fmt)) != content(files_of(snapshot(clean), n, fmt))}
        redo = resume(config_file, out, fmt, capsys)
        assert set(redo) == tampered, (round_, fmt, done, redo)
        assert_resumed_to_clean(clean, out, before, tampered, fmt, redo)
        shutil.rmtree(out)
