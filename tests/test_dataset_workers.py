"""Datasets of many sequences on Dask workers: the same files as a serial run, resumable after a killed worker or
an interrupted run, failures reported while the others complete (generators.runner, generators.dataset).

One LocalCluster of 2 worker processes (the one `--workers 2` starts) is shared by the tests of this module.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
import cloudpickle  # noqa: E402
import dask  # noqa: E402

import sim  # noqa: E402
from evsim_app.cli import main  # noqa: E402
from generators.config import load_config  # noqa: E402
from generators.dataset import generate_dataset  # noqa: E402
from generators.formats import load  # noqa: E402
from generators.runner import TasksFailed, local_cluster  # noqa: E402
from generators.scenes import MovingEdge  # noqa: E402
from generators.sweep import generate_sweep  # noqa: E402

pytestmark = pytest.mark.slow  # Dask clusters of worker processes: left out of the fast loop

ROOT = Path(__file__).resolve().parents[1]
CONFIG = """
seed = 4
[defaults]
duration_s = 0.2
height = 32
width = 40
[[sequence]]
name = "edge"
scene = { type = "moving_edge", speed_px_per_s = 80.0 }
[[sequence]]
name = "sun"
scene = { type = "sun", velocity_px_per_s = [40.0, 10.0] }
[[sequence]]
name = "board"
scene = { type = "checkerboard", square_px = 8.0, velocity_px_per_s = [40.0, 10.0], low = 0.02, high = 400.0 }
[[sequence]]
name = "flicker"
scene = { type = "flicker", frequency_hz = 50.0 }
"""
NAMES = ["edge", "sun", "board", "flicker"]


@pytest.fixture(scope="module")
def config_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("cfg") / "dataset.toml"
    path.write_text(CONFIG)
    return path


@pytest.fixture(scope="module")
def serial(config_file, tmp_path_factory):
    """The reference: the dataset generated serially in this process (this also fills the numba cache)."""
    out = tmp_path_factory.mktemp("serial") / "d"
    generate_dataset(load_config(config_file), out, progress=False)
    return out


@pytest.fixture(scope="module")
def cluster(serial):
    """The scheduler address of a 2-process LocalCluster; a worker that dies fails its task at once."""
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), local_cluster(2) as c:
        yield c.scheduler_address


def _h5_tree(path: Path) -> dict:
    """Every dataset's array and every attribute of an HDF5 file (metadata JSON decoded)."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()]
            for k, v in obj.attrs.items():
                out[f"{name}@{k}"] = json.loads(v) if k in ("metadata", "crf") else v

        visit("/", f)
        f.visititems(visit)
    return out


def assert_same_dataset(a: Path, b: Path) -> None:
    names = sorted(p.name for p in a.iterdir())
    assert sorted(p.name for p in b.iterdir()) == names  # no stray or temporary files either
    assert json.loads((a / "index.json").read_text()) == json.loads((b / "index.json").read_text())
    for name in names:
        if name.endswith(".h5"):
            ta, tb = _h5_tree(a / name), _h5_tree(b / name)
            assert ta.keys() == tb.keys(), name
            for k in ta:
                np.testing.assert_array_equal(ta[k], tb[k], err_msg=f"{name}: {k}")


def test_workers_write_the_serial_files_and_index(serial, cluster, config_file, tmp_path):
    out = tmp_path / "d"
    generate_dataset(load_config(config_file), out, scheduler=cluster, progress=False)
    assert_same_dataset(serial, out)
    index = json.loads((out / "index.json").read_text())
    assert [e["name"] for e in index["sequences"]] == NAMES  # the configuration's order, whatever finished first
    for e in index["sequences"]:
        meta = load(out / e["file"]).metadata
        assert meta["spec_hash"] == e["spec_hash"] and len(e["spec_hash"]) == 64
        assert meta["n_events"] > 0
    assert len({e["spec_hash"] for e in index["sequences"]}) == len(NAMES)


def test_sweep_on_workers_equals_serial(cluster, tmp_path):
    scene = MovingEdge(16, 20, 100_000, speed_px_per_s=80.0)  # one scene shared by every point: sent once
    grid = {"shot_noise_hz": [0.0, 50.0]}
    a = generate_sweep(scene, tmp_path / "a", grid, seed=2, progress=False).parent
    b = generate_sweep(scene, tmp_path / "b", grid, seed=2, progress=False, scheduler=cluster).parent
    assert_same_dataset(a, b)


class _KillOnce(distributed.WorkerPlugin):
    """Kills its worker process (SIGKILL) when a task whose key names `sequence` starts, once (marker file)."""

    def __init__(self, sequence: str, marker: str):
        self.sequence, self.marker = sequence, marker

    def transition(self, key, start, finish, **kwargs):
        if finish == "executing" and str(key).endswith(f"-{self.sequence}") and not os.path.exists(self.marker):
            Path(self.marker).touch()
            os.kill(os.getpid(), signal.SIGKILL)


cloudpickle.register_pickle_by_value(sys.modules[__name__])


def test_a_killed_worker_costs_only_its_task_and_resume_completes(serial, cluster, config_file, tmp_path, capsys):
    out = tmp_path / "d"
    with distributed.Client(cluster) as client:
        client.register_plugin(_KillOnce("sun", str(tmp_path / "killed")), name="kill-once")
        try:
            with pytest.raises(TasksFailed) as info:
                generate_dataset(load_config(config_file), out, scheduler=cluster, progress=False)
        finally:
            client.unregister_worker_plugin("kill-once")
    assert (tmp_path / "killed").exists()
    assert [f.name for f in info.value.failures] == ["sun"] and info.value.failures[0].kind == "lost"
    assert "--resume" in str(info.value)
    assert not (out / "index.json").exists()  # the folder does not claim to be complete
    assert {p.name for p in out.glob("*.h5")} == {"edge.h5", "board.h5", "flicker.h5"}
    kept = {n: (out / f"{n}.h5").stat().st_mtime_ns for n in ("edge", "board", "flicker")}
    capsys.readouterr()
    generate_dataset(load_config(config_file), out, scheduler=cluster, progress=False, resume=True)
    said = capsys.readouterr().out
    assert "3 of 4 sequence(s) verified (every file matches its manifest), kept: edge, board, flicker" in said
    assert "resume: generating sun again: not written yet (no sun.h5)" in said
    assert {n: (out / f"{n}.h5").stat().st_mtime_ns for n in kept} == kept  # not rewritten
    assert_same_dataset(serial, out)


def test_an_interrupted_run_resumes_to_the_same_dataset(serial, cluster, config_file, tmp_path, capsys):
    out = tmp_path / "d"
    cmd = [sys.executable, "-m", "evsim_app.cli", "generate", "ahdr", "--config", str(config_file), "--out", str(out),
           "--no-progress"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not list(out.glob("*.manifest.json")) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert proc.poll() is None, "the run ended before it could be interrupted"
        proc.send_signal(signal.SIGKILL)  # mid-way: one file written at least, the others not
    finally:
        proc.wait(timeout=30)
    done = {p.name for p in out.glob("*.manifest.json")}  # a sequence is done when its manifest is written
    assert 1 <= len(done) < len(NAMES) and not (out / "index.json").exists()
    capsys.readouterr()
    args = ["generate", "ahdr", "--config", str(config_file), "--out", str(out), "--no-progress"]
    assert main(args + ["--resume", "--overwrite"]) == 2  # they exclude each other
    assert main(args + ["--resume", "--scheduler", cluster]) == 0
    said = capsys.readouterr().out
    assert f"{len(done)} of 4 sequence(s) verified" in said
    assert_same_dataset(serial, out)  # also: the killed run's temporary file is gone


def test_a_failing_sequence_is_reported_and_the_others_complete(cluster, config_file, tmp_path, capsys):
    bad = config_file.read_text() + '[[sequence]]\nname = "lost"\nscene = { type = "image", path = "nowhere.exr" }\n'
    (tmp_path / "bad.toml").write_text(bad)
    out = tmp_path / "d"
    out.mkdir()
    (out / "index.json").write_text('{"sequences": []}')  # an older dataset: --overwrite removes its index first
    args = ["generate", "ahdr", "--config", str(tmp_path / "bad.toml"), "--out", str(out), "--no-progress",
            "--overwrite", "--scheduler", cluster]
    assert main(args) == 3
    err = capsys.readouterr().err
    assert "1 of 5 sequences failed" in err and "lost: EvsimInputError: image file not found" in err
    assert "Traceback" not in err  # bad input, not a bug
    assert {p.name for p in out.iterdir()} == {f"{n}{s}" for n in NAMES for s in (".h5", ".manifest.json")}
    # no index.json: not complete


@pytest.mark.parametrize("tune", [[], ["--tune", "--no-progress"]], ids=["untuned", "tuned"])
def test_evaluate_on_workers_equals_serial(serial, cluster, tmp_path, capsys, tune):
    # tuning searches in this process, then the sequences are scored where the runner sends them
    common = ["evaluate", str(serial), "--methods", "akf,frames", "--metrics", "mse,ssim", *tune]
    assert main(common + ["--json", str(tmp_path / "a.json")]) == 0
    assert main(common + ["--json", str(tmp_path / "b.json"), "--scheduler", cluster]) == 0
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("a.json", "b.json"))
    assert a == b and set(a["akf"]) == {*NAMES, "mean"}
    if tune:
        assert set(a["tuning"]["akf"]) == {"contrast_scale", "event_noise_scale", "frame_noise_scale",
                                           "smooth_range", "max_intensity"}


def test_resume_redoes_what_changed_or_is_unreadable(tmp_path, capsys):
    text = CONFIG.replace("height = 32", "height = 12").replace("width = 40", "width = 16").replace("0.2", "0.05")
    (tmp_path / "c.toml").write_text(text)
    out = tmp_path / "d"
    generate_dataset(load_config(tmp_path / "c.toml"), out, progress=False)
    first = json.loads((out / "index.json").read_text())
    (tmp_path / "c.toml").write_text(text.replace("speed_px_per_s = 80.0", "speed_px_per_s = 60.0"))
    (out / "board.h5").write_bytes(b"not hdf5")
    before = {n: (out / f"{n}.h5").stat().st_mtime_ns for n in ("sun", "flicker")}
    capsys.readouterr()
    generate_dataset(load_config(tmp_path / "c.toml"), out, progress=False, resume=True)
    said = capsys.readouterr().out
    assert "2 of 4 sequence(s) verified (every file matches its manifest), kept: sun, flicker" in said
    assert "generating edge again: configuration or seed changed (edge.manifest.json records another spec_hash)" in said
    assert "generating board again: board.h5 has 8 bytes" in said
    assert {n: (out / f"{n}.h5").stat().st_mtime_ns for n in before} == before
    second = json.loads((out / "index.json").read_text())
    assert second["sequences"][2] == first["sequences"][2]  # board: regenerated identically
    assert second["sequences"][0]["spec_hash"] != first["sequences"][0]["spec_hash"]
    assert load(out / "edge.h5").metadata["scene"]["speed_px_per_s"] == 60.0
    with pytest.raises(sim.EvsimInputError, match="not empty"):
        generate_dataset(load_config(tmp_path / "c.toml"), out, progress=False)


def test_run_flags_are_checked_before_anything_is_written(config_file, tmp_path, capsys):
    args = ["generate", "ahdr", "--config", str(config_file), "--out", str(tmp_path / "d")]
    assert main(args + ["--workers", "0"]) == 2
    assert main(args + ["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert "not allowed with argument" in capsys.readouterr().err
    with pytest.raises(sim.EvsimInputError, match="positive"):
        generate_dataset(load_config(config_file), tmp_path / "d", workers=0)
    assert not (tmp_path / "d").exists()
