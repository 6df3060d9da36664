"""Sensor files (sim.sensor_file): strict reading, exact round trip, and the sensor reaching the events wherever a
preset is accepted (configuration, Python API), recorded in the output."""

import dataclasses
import datetime
import math

import numpy as np
import pytest

import sim
from generators import load
from generators.builtin import ahdr_suite_config
from generators.config import load_config, parse_config, to_ahdr_config
from generators.dataset import generate_dataset
from sim.sensor_file import TABLES, sensor_toml

FITTED = """name = "fitted"
base = "ideal"
description = "an ideal pixel with asymmetric thresholds"

[dvs]
pos_threshold = 0.175
neg_threshold = 0.23

[camera]
fps = 25.0
exposure_us = [1000, 4000]

[provenance]
recording = "synthetic moving edge"
fit = { loss = 0.56, iterations = 40 }
date = 2026-12-02
"""


def _sensor_file(folder, text=FITTED, name="fitted.toml"):
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text)
    return path


def test_a_sensor_file_is_its_base_preset_with_its_tables_over_it(tmp_path):
    s = sim.load_sensor(_sensor_file(tmp_path))
    assert s.name == "fitted" and s.base == "ideal" and s.path == str(tmp_path / "fitted.toml")
    assert s.dvs == sim.DVS_PRESETS["ideal"].replace(pos_threshold=0.175, neg_threshold=0.23)
    assert s.dvs_fields == ("pos_threshold", "neg_threshold")
    assert s.camera == {"fps": 25.0, "exposure_us": (1000, 4000)}
    assert s.provenance["fit"] == {"loss": 0.56, "iterations": 40}
    assert s.provenance["date"] == datetime.date(2026, 12, 2)
    assert sim.load_sensor("noisy") == sim.Sensor.preset("noisy") and sim.load_sensor("noisy").dvs == \
        sim.DVSParams.preset("noisy")


def test_written_sensor_files_read_back_equal(tmp_path):
    rng = np.random.default_rng(7)
    for i in range(20):  # awkward floats (repr round trip), strings needing escapes, nested provenance
        dvs = sim.DVSParams(pos_threshold=float(rng.uniform(0.05, 1)), threshold_sigma=float(rng.uniform(0, 0.1)),
                            dark_fraction=float(10 ** rng.uniform(-6, -0.5)), refractory_us=int(rng.integers(0, 999)),
                            shot_noise_hz=float(rng.uniform(0, 1e-3)) / 3, leak_hz=0.0)
        s = sim.Sensor(f"fit {i} \"q\"\t\x7f", dvs=dvs, base="davis346", description="line1\nline2 é",
                       camera={"read_noise_e": float(rng.uniform(0, 5)), "exposure_us": (500, 8000), "noise": False,
                               "preset": "davis346_aps"},
                       provenance={"loss": float(rng.uniform()), "sha256": "ab" * 32, "odd key.x": [1, 2.5, "s"],
                                   "when": datetime.datetime(2026, 12, 2, 18, 0, 1, 250, tzinfo=datetime.UTC),
                                   "fit": {"grid": [[0.1, 0.2], [0.3]], "ok": True, "inf": math.inf}})
        path = sim.write_sensor(tmp_path / "s.toml", s)
        back = sim.load_sensor(path)
        assert back == s, sensor_toml(s)
        assert all(getattr(back.dvs, f.name) == getattr(dvs, f.name) for f in dataclasses.fields(dvs))
    assert [p.name for p in tmp_path.iterdir()] == ["s.toml"]  # no temporary file left


def test_written_sensor_files_state_units_and_the_base_values(tmp_path):
    text = sim.write_sensor(tmp_path / "s.toml", sim.load_sensor(_sensor_file(tmp_path))).read_text()
    assert "pos_threshold = 0.175  # log units\n" in text and "refractory_us = 0  # us (from ideal)" in text
    assert "fps = 25.0  # frames per second" in text


@pytest.mark.parametrize("text, where, says", [
    ('name = "x"\n[dvs]\npos_threshhold = 0.2\n', "dvs.pos_threshhold", "did you mean 'pos_threshold'?"),
    ('name = "x"\n[camera]\nfsp = 20.0\n', "camera.fsp", "did you mean 'fps'?"),
    ('name = "x"\n[dvss]\npos_threshold = 0.2\n', "dvss", "did you mean 'dvs'?"),
    ('name = "x"\nbase = "davis364"\n', "base", "did you mean 'davis346'?"),
    ('name = "x"\ndescripton = "y"\n', "descripton", "did you mean 'description'?"),
    ('base = "ideal"\n', "name", "missing"),
    ('name = "x"\n[dvs]\npos_threshold = -0.2\n', "dvs", "pos_threshold must be > 0"),
    ('name = "x"\n[dvs]\nrefractory_us = 1.5\n', "dvs", "refractory_us must be an integer"),
    ('name = "x"\n[camera]\nbit_depth = 4\n', "camera", "bit_depth must be an integer in [8, 16]"),
    ('name = 3\n', "name", "expected a string"),
])
def test_bad_sensor_files_name_the_file_and_key_with_the_allowed_names(tmp_path, text, where, says):
    path = _sensor_file(tmp_path, text, "bad.toml")
    with pytest.raises(sim.InvalidParameterError) as err:
        sim.load_sensor(path)
    msg = str(err.value)
    assert str(path) in msg and f": {where}" in msg and says in msg, msg
    if "did you mean" in says:
        assert "allowed: " in msg


def test_unknown_sensor_names_and_unreadable_files_are_clear(tmp_path):
    with pytest.raises(sim.InvalidParameterError,
                       match=r"unknown sensor 'davis364' \(did you mean 'davis346'\?\)"
                             r".*a preset \(ideal, davis346, davis346_road, noisy\) or a sensor file"):
        sim.load_sensor("davis364")
    with pytest.raises(sim.EvsimInputError, match="does not exist"):
        sim.load_sensor(tmp_path / "none.toml")
    (tmp_path / "bad.toml").write_text("name = = 1")
    with pytest.raises(sim.EvsimInputError, match="not valid TOML"):
        sim.load_sensor(tmp_path / "bad.toml")


def test_every_table_of_a_sensor_file_has_a_validator():
    assert {"dvs", "camera", "provenance"} <= set(TABLES) and all(callable(v) for v in TABLES.values())


def test_a_config_sensor_path_is_relative_to_the_config_and_camera_tables_override_the_sensors(tmp_path):
    _sensor_file(tmp_path / "sensors")
    cfg_text = ('[defaults]\nsensor = "sensors/fitted.toml"\ncamera = { fps = 50.0 }\n'
                '[[sequence]]\nscene = { type = "moving_edge" }\n'
                '[[sequence]]\nsensor = "noisy"\ndvs = { leak_hz = 0.0 }\nscene = { type = "moving_edge" }\n')
    (tmp_path / "data.toml").write_text(cfg_text)
    cfg = load_config(tmp_path / "data.toml")
    first, second = (to_ahdr_config(s.settings) for s in cfg.sequences)
    assert first.dvs.pos_threshold == 0.175 and first.dvs.shot_noise_hz == 0.0  # the file over its base, ideal
    assert first.camera.fps == 50.0 and first.camera.exposure_us == (1000, 4000)  # explicit over the file's camera
    assert first.sensor["name"] == "fitted" and first.sensor["provenance"]["recording"] == "synthetic moving edge"
    assert second.dvs == sim.DVSParams.preset("noisy", leak_hz=0.0) and second.sensor["name"] == "noisy"
    assert second.camera.fps == 50.0 and second.camera.exposure_us == 10_000  # no sensor camera defaults
    with pytest.raises(sim.InvalidParameterError, match=r"defaults\.sensor: .*none\.toml does not exist"):
        parse_config({"defaults": {"sensor": "none.toml"}, "sequence": [{"scene": {"type": "moving_edge"}}]},
                     base_dir=tmp_path)


def test_the_events_follow_the_sensor_file_and_the_output_records_it(tmp_path):
    """An ideal pixel crossing a 1:20 edge fires floor(ln(20.0 / 1.0) / C_on) ON events and no OFF event: with the
    file's C_on = 0.175, 17 per pixel (the davis346 preset's 0.2 would give 14)."""
    _sensor_file(tmp_path)
    (tmp_path / "data.toml").write_text(
        '[defaults]\nsensor = "fitted.toml"\nduration_s = 0.05\nheight = 4\nwidth = 16\ncamera = { fps = 100.0 }\n'
        '[[sequence]]\nname = "edge"\nscene = { type = "moving_edge", speed_px_per_s = 100.0, x0 = 4.0 }\n')
    generate_dataset(load_config(tmp_path / "data.toml"), tmp_path / "out", progress=False)
    rec = load(tmp_path / "out" / "edge.h5")
    dark = 1e-4 * 1.0  # dark_fraction x full_illumination (the scene's 99th percentile, 1.0)
    expected = math.floor(math.log((1.0 + dark) / (0.05 + dark)) / 0.175)
    on = rec.events[rec.events["p"] > 0]
    counts = np.bincount(on["x"], minlength=16) / 4  # per pixel of a column
    assert expected == 17 and np.all(counts[5:9] == expected) and not np.any(rec.events["p"] < 0)
    assert np.allclose(rec.threshold_maps[0], 0.175) and np.allclose(rec.threshold_maps[1], 0.23)
    sensor = rec.metadata["config"]["sensor"]
    assert sensor["name"] == "fitted" and sensor["file"] == str(tmp_path / "fitted.toml")
    assert sensor["provenance"] == {"recording": "synthetic moving edge", "fit": {"loss": 0.56, "iterations": 40},
                                    "date": "2026-12-02"}


def test_the_python_api_takes_a_sensor_where_it_takes_a_preset(tmp_path):
    path = _sensor_file(tmp_path)
    by_file, by_object = ahdr_suite_config(path), ahdr_suite_config(sim.load_sensor(path))
    assert by_file.dvs == by_object.dvs == sim.load_sensor(path).dvs
    assert by_file.camera.fps == 25.0 and by_file.camera.reference_radiance == 1.0  # the suite's x = radiance
    assert ahdr_suite_config("davis346").dvs == sim.DVSParams.preset("davis346")
    assert ahdr_suite_config(path, dvs={"pos_threshold": 0.3}).dvs.pos_threshold == 0.3
