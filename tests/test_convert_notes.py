"""What `evsim convert` says before the work about what the user may not expect (issue 34's first contact): a
sensor larger than the input (upscaled), LDR frames at another rate than the input's; and a sensor file's [camera]
table sets the frames of a conversion (the calibrated camera's rate and exposure)."""

from __future__ import annotations

import numpy as np
import pytest
from video_clips import encode_mp4, slow_motion_frames

import sim
from evsim_app.cli import main
from generators.formats import load


@pytest.fixture(scope="module")
def clip_25fps(tmp_path_factory):
    path = tmp_path_factory.mktemp("clip") / "clip.mp4"
    return encode_mp4(path, slow_motion_frames(12)[:, :36, :48], fps=25.0)


def _notes(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith("evsim: note:")]


def test_upscaling_and_another_frame_rate_are_noted(clip_25fps, tmp_path, capsys):
    assert main(["convert", str(clip_25fps), "--out", str(tmp_path / "a"), "--height", "72", "--width", "96",
                 "--outputs", "events,frames", "--no-progress"]) == 0
    notes = _notes(capsys.readouterr().err)
    assert any("48x36 frames are upscaled to the 96x72 sensor" in n for n in notes), notes
    assert any("the input is 25 fps; the LDR camera writes 30 fps with 10000 us exposures" in n for n in notes)


def test_nothing_to_note_at_the_inputs_size_and_rate(clip_25fps, tmp_path, capsys):
    assert main(["convert", str(clip_25fps), "--out", str(tmp_path / "b"), "--outputs", "events,frames",
                 "--camera-fps", "25", "--exposure-us", "20000", "--no-progress"]) == 0
    assert _notes(capsys.readouterr().err) == []
    assert main(["convert", str(clip_25fps), "--out", str(tmp_path / "c"), "--no-progress"]) == 0  # events only
    assert _notes(capsys.readouterr().err) == []


def test_a_sensor_files_camera_sets_the_frames_of_a_conversion(clip_25fps, tmp_path, capsys):
    sensor = sim.Sensor(name="cam", dvs=sim.DVSParams.preset("davis346"),
                        camera={"fps": 25.0, "exposure_us": 500, "bit_depth": 8})
    sim.write_sensor(tmp_path / "cam.toml", sensor)
    assert main(["convert", str(clip_25fps), "--out", str(tmp_path / "d"), "--sensor", str(tmp_path / "cam.toml"),
                 "--outputs", "events,frames", "--no-progress"]) == 0
    assert _notes(capsys.readouterr().err) == []
    rec = load(tmp_path / "d" / "clip.h5")
    assert np.all(rec.frame_t_end_us - rec.frame_t_start_us == 500)
    assert np.median(np.diff(rec.frame_t_mid_us)) == 40_000  # 25 fps


def test_a_calibrations_camera_is_the_recordings_frames():
    from evsim_eval.calibrate.camera import recorded_camera

    from recordings import make_recording

    rec = make_recording(bit_depth=10)
    camera = recorded_camera(rec, read_noise_dn=2.0)
    assert camera["fps"] == pytest.approx(1e6 / np.median(np.diff(rec.frame_t_mid_us)), rel=1e-3)
    assert camera["exposure_us"] == int(np.median(rec.frame_t_end_us - rec.frame_t_start_us))
    assert camera["bit_depth"] == 10
    full_well = sim.CameraParams().full_well_e
    assert camera["read_noise_e"] == pytest.approx(2.0 * full_well / 1023, rel=1e-3)
    sim.CameraParams(**camera)  # a valid camera
