import json

import numpy as np
import pytest

import sim
from generators import load
from generators.builtin import BUILTIN_SEQUENCES, builtin_dataset
from generators.config import build_scene, load_config, parse_config, to_ahdr_config
from generators.dataset import generate_dataset
from generators.scenes import builtin_hdr_image

CONFIG = """
seed = 5

[defaults]
duration_s = 0.06
height = 12
width = 16
sensor = "ideal"
camera = { fps = 50.0, exposure_us = 3000 }
dvs = { pos_threshold = 0.3 }

[[sequence]]
name = "edge"
speeds = [1.0, 2.0]
scene = { type = "moving_edge", speed_px_per_s = 50.0 }

[[sequence]]
name = "pic"
sensor = "davis346"
output = { labels = true }
scene = { type = "image", path = "img.npy", trajectory = { pan_px_per_s = [20.0, 0.0] } }
"""


def _write(tmp_path, text=CONFIG):
    np.save(tmp_path / "img.npy", np.exp(np.random.default_rng(0).normal(size=(30, 40))).astype(np.float32))
    p = tmp_path / "data.toml"
    p.write_text(text)
    return p


def test_config_resolves_defaults_overrides_speeds_and_paths(tmp_path):
    cfg = load_config(_write(tmp_path))
    assert cfg.seed == 5 and [s.name for s in cfg.sequences] == ["edge_x1", "edge_x2", "pic"]
    assert cfg.sequences[1].scene["speed_px_per_s"] == 100.0
    pic = cfg.sequences[2]
    assert pic.scene["path"] == str(tmp_path / "img.npy")
    assert pic.settings["sensor"] == "davis346" and pic.settings["output"]["labels"] is True
    assert pic.settings["output"]["threshold_maps"] is True  # untouched default
    ahdr = to_ahdr_config(pic.settings)
    assert ahdr.dvs.pos_threshold == 0.3 and ahdr.dvs.threshold_sigma == sim.DVSParams().threshold_sigma
    assert ahdr.camera.fps == 50.0 and ahdr.camera.exposure_us == 3000 and ahdr.labels
    assert ahdr.sampling_quantile == 0.95  # untouched default; a sampling.quantile key reaches the config:
    dense = {**pic.settings, "sampling": {**pic.settings["sampling"], "quantile": 1.0}}
    assert to_ahdr_config(dense).sampling_quantile == 1.0
    scene = build_scene(pic.scene, 12, 16, pic.duration_us)
    assert (scene.height, scene.width, scene.duration_us) == (12, 16, 60_000)
    assert scene.max_speed_px_per_s() == pytest.approx(20.0)


@pytest.mark.parametrize("text, key", [
    ("seed = 1\n[[sequence]]\nscene = { type = 'moving_edge' }\ncolour = 3\n", "sequence[0].colour"),
    ("[[sequence]]\nscene = { type = 'spiral' }\n", "sequence[0].scene.type"),
    ("[[sequence]]\nscene = { type = 'moving_edge' }\ndvs = { threshold = 0.2 }\n", "sequence[0].dvs.threshold"),
    ("[defaults]\nheight = 'tall'\n[[sequence]]\nscene = { type = 'moving_edge' }\n", "defaults.height"),
    ("[[sequence]]\nscene = { type = 'image' }\n", "sequence[0].scene.path"),
    ("[sweep]\nthreshold_sigma = [0.1]\n", "sequence"),
    ("[[sequence]]\nscene = { type = 'moving_edge' }\n[sweep]\ngain = [1]\n", "sweep.gain"),
    ("[[sequence]]\nscene = { type = 'moving_edge' }\nsampling = { mode = 'adaptive', step = 3 }\n",
     "sequence[0].sampling.step"),
    ("[[sequence]]\nsensor = 'davis999'\nscene = { type = 'moving_edge' }\n", "sequence[0].sensor"),
    ("[defaults]\noutput = { compression = 'zstd' }\n[[sequence]]\nscene = { type = 'moving_edge' }\n",
     "defaults.output.compression"),
])
def test_bad_config_names_the_key(tmp_path, text, key):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(sim.InvalidParameterError) as err:
        load_config(p)
    assert key in str(err.value) and str(p) in str(err.value)


def test_bad_scene_parameter_and_file_errors(tmp_path):
    cfg = parse_config({"sequence": [{"scene": {"type": "checkerboard", "colour": 1}}]})
    spec = cfg.sequences[0]
    with pytest.raises(sim.InvalidParameterError, match="colour"):
        build_scene(spec.scene, 8, 8, 1000)
    with pytest.raises(sim.EvsimInputError, match="not found"):
        load_config(tmp_path / "missing.toml")
    (tmp_path / "x.toml").write_text("seed = = 1")
    with pytest.raises(sim.EvsimInputError, match="TOML"):
        load_config(tmp_path / "x.toml")


def test_dataset_from_config_writes_every_sequence_and_an_index(tmp_path):
    cfg = load_config(_write(tmp_path))
    index_path = generate_dataset(cfg, tmp_path / "out", progress=False)
    index = json.loads(index_path.read_text())
    assert [e["name"] for e in index["sequences"]] == ["edge_x1", "edge_x2", "pic"]
    assert index["seed"]["entropy"] == 5
    n_events = []
    for i, e in enumerate(index["sequences"]):
        rec = load(tmp_path / "out" / e["file"])
        assert rec.metadata["seed"]["spawn_key"] == [i] and rec.metadata["name"] == e["name"]
        assert (rec.height, rec.width) == (12, 16) and rec.events.size == e["n_events"]
        n_events.append(rec.events.size)
    assert n_events[1] > 1.5 * n_events[0]  # twice the speed: the edge crosses twice as many pixels
    assert rec.event_labels is not None  # "pic" asked for labels
    with pytest.raises(sim.EvsimInputError, match="overwrite"):
        generate_dataset(cfg, tmp_path / "out", progress=False)
    generate_dataset(cfg, tmp_path / "out", overwrite=True, progress=False, fmt="ijrr")
    assert (tmp_path / "out" / "pic_ijrr" / "events.txt").is_file()


def test_builtin_image_is_hdr_and_the_builtin_dataset_needs_no_files():
    img = builtin_hdr_image("astronaut")
    assert img.dtype == np.float32 and img.shape == (512, 512) and img.min() > 0
    p_lo, p_hi = np.percentile(img, [0.5, 99.5])
    assert p_hi / p_lo > 1e3
    cfg = builtin_dataset(duration_s=0.01, height=10, width=12)
    assert [s.name for s in cfg.sequences] == [s["name"] for s in BUILTIN_SEQUENCES]
    for spec in cfg.sequences:
        scene = build_scene(spec.scene, 10, 12, spec.duration_us)
        r = scene.radiance(5_000)
        assert r.shape == (10, 12) and np.all(np.isfinite(r)) and r.min() >= 0
    with pytest.raises(sim.InvalidParameterError, match="built-in"):
        builtin_dataset(names=["nope"])


def test_configuration_errors_speak_toml_not_python(tmp_path):
    # a configuration file's types are TOML's (string, integer, table), not Python's (str, int, dict)
    import re

    from generators.convert_config import load_convert_config
    from generators.scenes.video import read_timestamps

    def convert_video(path):
        read_timestamps(load_convert_config(path)["video"]["timestamps"])

    cases = [(load_config, 'seed = "x"\n', "seed: expected an integer, got a string 'x'"),
             (load_convert_config, "defaults = 3\n", "defaults: expected a table, got an integer"),
             (load_convert_config, "[defaults]\nsensor = 3\n", "defaults.sensor: expected a string, got an integer 3"),
             (convert_video, '[video]\ntimestamps = "nosuch.txt"\n',
              "nosuch.txt: cannot read the timestamps file: No such file or directory")]
    for i, (read, text, message) in enumerate(cases):
        (tmp_path / f"{i}.toml").write_text(text)
        with pytest.raises(sim.EvsimInputError) as e:
            read(tmp_path / f"{i}.toml")
        assert message in str(e.value) and not re.search(r"\b(str|int|dict|Errno)\b", str(e.value))
