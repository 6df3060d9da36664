"""The configuration files shipped in examples/configs/ load, and a tiny run with each gives events and frames
whose parameters are the file's."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import sim
from evsim_app.cli import main
from generators import load
from generators.config import load_config
from generators.convert_config import load_convert_config
from generators.dataset import generate_dataset

CONFIGS = Path(__file__).resolve().parents[1] / "examples" / "configs"
SENSOR_FILES = ("davis346.toml", "v2e_noisy.toml")


def _resolved_dvs(meta: dict) -> sim.DVSParams:
    return sim.DVSParams(**meta["config"]["dvs"])


def test_every_shipped_configuration_is_tested():
    assert {p.name for p in CONFIGS.glob("*.toml")} == {*SENSOR_FILES, "ahdr_dataset.toml", "convert.toml"}


def test_the_davis346_sensor_file_is_the_preset_with_the_aps_camera(tmp_path, capsys):
    s = sim.load_sensor(CONFIGS / "davis346.toml")
    assert s.dvs == sim.DVS_PRESETS["davis346"] and s.camera == {"preset": "davis346_aps"}
    assert "not fitted" in s.provenance["status"]
    out = tmp_path / "o"
    assert main(["generate", "ahdr", "--scene", "moving_edge", "--sensor", str(CONFIGS / "davis346.toml"),
                 "--duration-s", "0.2", "--sensor-size", "davis240", "--out", str(out), "--no-progress"]) == 0
    rec = load(out / "moving_edge.h5")
    assert (rec.height, rec.width) == (180, 240) and rec.events.size > 0
    dvs = _resolved_dvs(rec.metadata)
    assert dvs == dataclasses.replace(s.dvs, full_illumination=dvs.full_illumination)  # illumination: the scene's
    aps = sim.CAMERA_PRESETS["davis346_aps"]
    assert np.all(np.diff(rec.frame_t_mid_us) == round(1e6 / aps.fps))  # 25 fps
    assert np.all(rec.frame_t_end_us - rec.frame_t_start_us == aps.exposure_us)
    cam = rec.metadata["config"]["camera"]
    assert (cam["full_well_e"], cam["read_noise_e"], cam["dsnu_e"]) == (aps.full_well_e, aps.read_noise_e, aps.dsnu_e)
    assert rec.metadata["config"]["sensor"]["file"] == str(CONFIGS / "davis346.toml")
    capsys.readouterr()
    assert main(["info", str(out / "moving_edge.h5")]) == 0
    assert f"  model       davis346 ({CONFIGS / 'davis346.toml'})\n" in capsys.readouterr().out


def test_the_v2e_noisy_sensor_file_gives_its_threshold_spread_and_no_hot_pixels(tmp_path):
    s = sim.load_sensor(CONFIGS / "v2e_noisy.toml")
    assert (s.dvs.threshold_sigma, s.dvs.cutoff_hz, s.dvs.refractory_us, s.dvs.hot_pixel_fraction) == \
        (0.05, 30.0, 0, 0.0)
    out = tmp_path / "o"
    assert main(["generate", "ahdr", "--scene", "moving_edge", "--sensor", str(CONFIGS / "v2e_noisy.toml"),
                 "--duration-s", "0.1", "--height", "60", "--width", "80", "--labels", "--out", str(out),
                 "--no-progress"]) == 0
    rec = load(out / "moving_edge.h5")
    for polarity in (0, 1):  # 4800 per-pixel thresholds: their spread is the file's 0.05 (+-5 %)
        thr = rec.threshold_maps[polarity]
        assert thr.mean() == pytest.approx(0.2, abs=0.005) and thr.std() == pytest.approx(0.05, rel=0.05)
    assert not np.any(rec.event_labels == 3)  # no hot-pixel events
    assert rec.metadata["config"]["sensor"]["name"] == "v2e_noisy"


def test_the_dataset_configuration_runs_with_its_sensor_file_and_overrides(tmp_path):
    cfg = load_config(CONFIGS / "ahdr_dataset.toml")
    davis = sim.load_sensor(CONFIGS / "davis346.toml")
    assert [s.name for s in cfg.sequences] == ["astronaut_pan", "edge_noisy"]
    assert all((s.settings["height"], s.settings["width"]) == (260, 346) for s in cfg.sequences)
    for spec in cfg.sequences:  # tiny: the parameters are what is tested
        spec.settings.update(duration_s=0.1, height=26, width=34)
    generate_dataset(cfg, tmp_path / "o", progress=False)
    for spec in cfg.sequences:
        rec = load(tmp_path / "o" / f"{spec.name}.h5")
        want = davis.dvs.replace(**spec.settings["dvs"])
        dvs = _resolved_dvs(rec.metadata)
        assert dvs == dataclasses.replace(want, full_illumination=dvs.full_illumination)
        assert np.all(np.diff(rec.frame_t_mid_us) == 40_000)  # fps = 25 (the config over the sensor's camera)
        assert np.all(rec.frame_t_end_us - rec.frame_t_start_us == 5000)
        assert rec.metadata["config"]["camera"]["full_well_e"] == sim.CAMERA_PRESETS["davis346_aps"].full_well_e
    assert _resolved_dvs(rec.metadata).shot_noise_hz == 2.0  # the second sequence's own dvs table


def test_the_convert_configuration_runs_a_clip_with_its_sensor_file(tmp_path):
    cfg = load_convert_config(CONFIGS / "convert.toml")
    assert cfg["settings"]["sensor"] == str(CONFIGS / "v2e_noisy.toml") and cfg["video"]["upsample"] == "flow"
    t = np.arange(6)[:, None, None]
    x = np.arange(40)[None, None, :]
    clip = np.broadcast_to(np.where((x - 3 * t) % 16 < 8, 200, 30), (6, 30, 40)).astype(np.uint8)
    np.save(tmp_path / "clip.npy", clip)
    out = tmp_path / "o"
    assert main(["convert", str(tmp_path / "clip.npy"), "--config", str(CONFIGS / "convert.toml"), "--fps", "30",
                 "--height", "15", "--width", "20", "--out", str(out), "--no-progress"]) == 0
    rec = load(out / "clip.h5")
    assert (rec.height, rec.width) == (15, 20) and rec.events.size > 0 and rec.crf["name"] == "srgb"
    dvs = _resolved_dvs(rec.metadata)
    assert dvs == dataclasses.replace(sim.load_sensor(CONFIGS / "v2e_noisy.toml").dvs,
                                      full_illumination=dvs.full_illumination)
    assert rec.metadata["config"]["compression"] == "lzf" and rec.metadata["scene"]["upsample"]["mode"] == "flow"
    assert rec.frames is None and rec.reference is None  # the file's output table keeps convert's events-only default
    index = json.loads((out / "index.json").read_text())
    assert index["seed"]["entropy"] == 0
