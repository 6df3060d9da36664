"""Bad input and interrupted writes on `evsim calibrate` and `evsim export`, and failed runs of `convert` and
`generate`: one line "evsim: error: ..." naming the problem (exit 2), the output checks made before any work, and
nothing that looks complete left behind (no output file, no temporary, no empty output folder); Ctrl-C exits 130
with the same guarantee."""

import errno
from pathlib import Path

import numpy as np
import pytest

import generators.formats.atomic
import generators.formats.native
from evsim_app.cli import main
from generators.formats import export

from recordings import make_recording


def _one_error_line(capfd) -> str:
    """The single stderr line (OpenCV and other C libraries write to fd 2 directly: capfd sees them)."""
    err = capfd.readouterr().err
    assert "Traceback" not in err and "WARN" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("evsim: error: "), err
    return lines[0]


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.fixture
def inputs(tmp_path):
    """Bad inputs in tmp_path/in: a text file, a PNG, an events-only recording, an IJRR folder whose images are
    missing; and a tiny hybrid recording (tiny.h5)."""
    import cv2

    d = tmp_path / "in"
    d.mkdir()
    (d / "notes.txt").write_text("hello\n")
    cv2.imwrite(str(d / "image.png"), np.zeros((8, 8), np.uint8))
    rec = make_recording()
    export(rec, d / "tiny.h5", "native")
    events_only = make_recording()
    events_only.frames = events_only.frame_t_start_us = events_only.frame_t_mid_us = None
    events_only.frame_t_end_us = events_only.reference = events_only.reference_t_us = None
    export(events_only, d / "events_only.h5", "native")
    export(rec, d / "ijrr", "ijrr")
    for png in (d / "ijrr" / "images").glob("*.png"):
        png.unlink()
    return d


@pytest.mark.parametrize("name, says", [
    ("notes.txt", "notes.txt: unknown layout"),
    ("image.png", "image.png: unknown layout"),
    ("missing.aedat4", "missing.aedat4: no such file"),
    ("ijrr", "missing or unreadable image: no such file (listed in images.txt)"),
])
def test_calibrate_bad_recordings(inputs, tmp_path, capfd, name, says):
    out = tmp_path / "cam.toml"
    assert main(["calibrate", str(inputs / name), "--out", str(out), "--no-progress"]) == 2
    assert says in _one_error_line(capfd)
    assert not out.exists() and _leftovers(tmp_path) == ["in"]


def test_calibrate_fits_a_recording_without_frames_and_refuses_thresholds_with_frames(inputs, tmp_path, capfd):
    """events_only.h5 is calibrated from its events (evsim_eval.calibrate.events_only; was refused); --thresholds,
    for a recording without frames, is refused for one with frames, naming the flag."""
    out = tmp_path / "cam.toml"
    assert main(["calibrate", str(inputs / "events_only.h5"), "--out", str(out), "--no-progress"]) == 0
    assert "not fitted" in out.read_text()
    capfd.readouterr()
    assert main(["calibrate", str(inputs / "tiny.h5"), "--out", str(tmp_path / "b.toml"), "--thresholds", "0.2",
                 "0.2", "--no-progress"]) == 2
    assert "--thresholds" in _one_error_line(capfd) and not (tmp_path / "b.toml").exists()


def test_calibrate_windows_without_events_are_refused_before_the_work(inputs, tmp_path, capfd):
    out = tmp_path / "cam.toml"
    assert main(["calibrate", str(inputs / "tiny.h5"), "--out", str(out), "--window", "10", "20",
                 "--no-progress"]) == 2
    line = _one_error_line(capfd)
    assert "0 ON and 0 OFF events in the window 10-20 s" in line and "at least 20 of each" in line
    assert not out.exists()


def test_calibrate_outputs_are_checked_before_the_recording_is_read(tmp_path, capfd):
    """The recording does not exist: each output problem is reported first (a calibration takes minutes)."""
    missing = str(tmp_path / "none.aedat4")
    (tmp_path / "old.toml").write_text("precious")
    (tmp_path / "folder").mkdir()
    for out, says in ((tmp_path / "old.toml", "old.toml already exists; pass --overwrite to replace it"),
                      (tmp_path / "cam.txt", "a sensor file is a .toml file"),
                      (tmp_path / "folder", "is a folder, not a file")):
        assert main(["calibrate", missing, "--out", str(out), "--no-progress"]) == 2
        assert says in _one_error_line(capfd)
    assert main(["calibrate", missing, "--out", str(tmp_path / "new.toml"), "--json", str(tmp_path / "old.toml"),
                 "--no-progress"]) == 2
    assert "--json" in _one_error_line(capfd)
    assert (tmp_path / "old.toml").read_text() == "precious"
    assert _leftovers(tmp_path) == ["folder", "old.toml"]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc")
def test_outputs_where_nothing_can_be_written_are_refused_even_for_root(inputs, capfd):
    """Permission bits do not tell (root, /proc, read-only mounts): the folder is tried."""
    assert main(["calibrate", str(inputs / "tiny.h5"), "--out", "/proc/evsim_cam.toml", "--no-progress"]) == 2
    assert "/proc is not writable" in _one_error_line(capfd)
    assert main(["export", str(inputs / "tiny.h5"), "/proc/evsim.h5", "--format", "native", "--no-progress"]) == 2
    assert "DST /proc/evsim.h5 cannot be created: /proc is not writable" in _one_error_line(capfd)


def test_calibrate_interrupted_leaves_nothing(inputs, tmp_path, monkeypatch, capfd):
    from evsim_eval.calibrate.simulation import RecordingSimulation

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(RecordingSimulation, "simulate", interrupted)
    out = tmp_path / "o" / "cam.toml"
    (tmp_path / "o").mkdir()
    assert main(["calibrate", str(inputs / "tiny.h5"), "--out", str(out), "--json", str(tmp_path / "o" / "c.json"),
                 "--window", "0.1", "1.0", "--no-progress"]) == 130
    assert "evsim: interrupted" in capfd.readouterr().err
    assert _leftovers(tmp_path / "o") == []


@pytest.mark.parametrize("failure, code", [(KeyboardInterrupt, 130), (OSError(errno.ENOSPC, "No space left"), 2)])
def test_sensor_file_write_interrupted_or_disk_full_leaves_nothing(inputs, tmp_path, monkeypatch, capfd, failure,
                                                                    code):
    """The calibration runs (a tiny one); its sensor file's write fails at the last moment: no file, no temporary."""
    import sim.sensor_file

    def fail(fd):
        raise failure

    monkeypatch.setattr(sim.sensor_file.os, "fsync", fail)
    (tmp_path / "o").mkdir()
    assert main(["calibrate", str(inputs / "tiny.h5"), "--out", str(tmp_path / "o" / "cam.toml"), "--window", "0.1",
                 "1.0", "--max-evaluations", "3", "--no-progress"]) == code
    err = capfd.readouterr().err
    assert "Traceback" not in err and ("evsim: interrupted" in err if code == 130 else "disk full" in err), err
    assert _leftovers(tmp_path / "o") == []


@pytest.mark.parametrize("name, says", [
    ("notes.txt", "notes.txt: unknown layout"),
    ("image.png", "image.png: unknown layout"),
    ("ijrr", "missing or unreadable image: no such file (listed in images.txt)"),
])
def test_export_bad_sources(inputs, tmp_path, capfd, name, says):
    assert main(["export", str(inputs / name), str(tmp_path / "o.h5"), "--format", "native", "--no-progress"]) == 2
    assert says in _one_error_line(capfd)
    assert _leftovers(tmp_path) == ["in"]


def test_export_interrupted_at_the_last_moment_leaves_nothing(inputs, tmp_path, monkeypatch, capfd):
    def interrupted(tmp, path):
        raise KeyboardInterrupt

    monkeypatch.setattr(generators.formats.atomic, "commit", interrupted)  # atomic_path's (the IJRR writer's)
    monkeypatch.setattr(generators.formats.native, "commit", interrupted)  # the native writer's own
    for fmt, dst in (("native", "o.h5"), ("ijrr", "o_ijrr")):
        assert main(["export", str(inputs / "tiny.h5"), str(tmp_path / dst), "--format", fmt, "--no-progress"]) == 130
        assert "evsim: interrupted" in capfd.readouterr().err
    assert _leftovers(tmp_path) == ["in"]


@pytest.mark.parametrize("argv", [
    ["convert", "{in}/image.png", "--out", "{out}"],  # one frame: the error comes once the folder is made
    ["generate", "ahdr", "--image", "{in}/notes.txt", "--out", "{out}"],
])
def test_failed_convert_and_generate_leave_no_empty_output_folder(inputs, tmp_path, capfd, argv):
    out = tmp_path / "new" / "deeper"
    assert main([a.format(**{"in": inputs, "out": out}) for a in argv] + ["--no-progress"]) == 2
    _one_error_line(capfd)
    assert _leftovers(tmp_path) == ["in"]  # neither the output folder nor the parent the run created
    (tmp_path / "kept").mkdir()  # a folder that was there before stays
    assert main([a.format(**{"in": inputs, "out": tmp_path / "kept"}) for a in argv] + ["--no-progress"]) == 2
    assert (tmp_path / "kept").is_dir()
