"""Every sim.DVSParams and sim.CameraParams field from the command line (--dvs / --camera FIELD=VALUE) reaches the
parameters a run uses, through the same checks as the TOML tables; --help lists every field with its unit;
--sensor-size and convert --config."""

import dataclasses
import re

import numpy as np
import pytest

import generators.convert
import generators.dataset
import generators.sweep
import sim
from evsim_app.cli import main
from evsim_app.model_flags import parse_assignments
from generators.config import parse_config
from sim import camera_params, dvs_params
from sim.sensor_file import _toml_value

# values that differ from every default and are valid alone (the others: default x 1.5 + 0.25, or + 7)
_SPECIAL = {"first_frame_us": 1234, "frame_times_us": [5000, 15000], "exposure_us": [1000, 8000],
            "reference_exposure_us": 2000, "n_subframes": 3, "bit_depth": 12, "noise": False, "reference_fill": 0.75,
            "hot_pixel_fraction": 0.002}


def _new_value(field: dataclasses.Field, default: object) -> object:
    if field.name in _SPECIAL:
        return _SPECIAL[field.name]
    return default + 7 if isinstance(default, int) else default * 1.5 + 0.25


def _values(cls) -> dict:
    defaults = cls()
    values = {f.name: _new_value(f, getattr(defaults, f.name)) for f in dataclasses.fields(cls)}
    assert all(values[k] != getattr(defaults, k) for k in values)
    return values


def _flag_args(flag: str, values: dict) -> list[str]:
    return [a for k, v in values.items() for a in (flag, f"{k}={_toml_value(k, v)}")]


def _assert_reached(config, kind: str, values: dict) -> None:
    params = config.dvs if kind == "dvs" else config.camera
    for name, v in values.items():
        assert getattr(params, name) == (tuple(v) if isinstance(v, list) else v), name
    if "full_illumination" in values:  # given: generation keeps it (no automatic illumination)
        assert not config.auto_illumination
    if "reference_radiance" in values:
        assert not config.auto_exposure


class Captured(BaseException):  # not caught by main (it reports Exceptions)
    pass


@pytest.fixture
def captured(monkeypatch):
    """Stop each command where it hands its generation configuration (AHDRConfig) over, and keep it."""
    box = {}

    def dataset(config, *a, **k):
        jobs, _ = generators.dataset.dataset_jobs(config)
        box["config"] = jobs[0][0].ahdr
        raise Captured

    def sweep(scene, out, grid, config, *a, **k):
        box["config"] = config
        raise Captured

    def sequence(out, name, scene, config, *a, **k):
        box["config"] = config
        raise Captured

    monkeypatch.setattr(generators.dataset, "generate_dataset", dataset)
    monkeypatch.setattr(generators.convert, "generate_dataset", dataset)
    monkeypatch.setattr(generators.sweep, "generate_sweep", sweep)
    monkeypatch.setattr(generators.dataset, "write_sequence", sequence)
    return box


def _run(box, args, tmp_path):
    with pytest.raises(Captured):
        main([*args, "--out", str(tmp_path / "o"), "--no-progress"])
    return box.pop("config")


@pytest.mark.parametrize("kind, cls", [("dvs", sim.DVSParams), ("camera", sim.CameraParams)])
def test_every_model_field_set_on_the_command_line_reaches_the_run(kind, cls, captured, tmp_path):
    np.save(tmp_path / "clip.npy", np.full((3, 6, 8), 100, np.uint8))
    values = _values(cls)
    for name, value in values.items():  # one at a time: generate ahdr
        config = _run(captured, ["generate", "ahdr", "--scene", "moving_edge", f"--{kind}",
                                 f"{name}={_toml_value(name, value)}"], tmp_path)
        _assert_reached(config, kind, {name: value})
    all_flags = _flag_args(f"--{kind}", values)
    for command in (["generate", "ahdr", "--scene", "moving_edge"], ["generate", "sweep", "--scene", "moving_edge"],
                    ["convert", str(tmp_path / "clip.npy"), "--fps", "10"], ["demo"]):
        _assert_reached(_run(captured, [*command, *all_flags], tmp_path), kind, values)


def test_the_flags_and_the_toml_tables_give_the_same_parameters_and_the_same_messages(captured, tmp_path):
    flags = _run(captured, ["generate", "ahdr", "--scene", "moving_edge", "--dvs", "pos_threshold=0.3,leak_hz=0",
                            "--camera", "exposure_us=[1000, 8000]", "--camera", "noise=false"], tmp_path)
    table = parse_config({"defaults": {"dvs": {"pos_threshold": 0.3, "leak_hz": 0},
                                       "camera": {"exposure_us": [1000, 8000], "noise": False}},
                          "sequence": [{"scene": {"type": "moving_edge"}}]})
    from generators.config import to_ahdr_config

    assert to_ahdr_config(table.sequences[0].settings) == flags
    for bad, says in [("pos_threshold=-1", "pos_threshold must be > 0, got -1"),
                      ("refractory_us=2.5", "refractory_us must be an integer (microseconds), got float 2.5")]:
        with pytest.raises(sim.InvalidParameterError) as toml_error:
            parse_config({"defaults": {"dvs": dict([parse_assignments("--dvs", [bad]).popitem()])},
                          "sequence": [{"scene": {"type": "moving_edge"}}]})
        assert toml_error.value.args[0].endswith(says)
        assert main(["generate", "ahdr", "--dvs", bad, "--out", str(tmp_path / "x")]) == 2


@pytest.mark.parametrize("command", [["generate", "ahdr"], ["generate", "sweep"], ["convert"], ["demo"]])
def test_help_lists_every_model_field_with_its_unit(command, capsys):
    assert main([*command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for units in (dvs_params.FIELD_UNITS, camera_params.FIELD_UNITS):
        for name, unit in units.items():
            assert f"{name} ({unit}" in text, name
    for cls, units in ((sim.DVSParams, dvs_params.FIELD_UNITS), (sim.CameraParams, camera_params.FIELD_UNITS)):
        assert set(units) == {f.name for f in dataclasses.fields(cls)}  # the table covers the fields, no more
    for name, (h, w) in sim.SENSOR_SIZES.items():
        assert f"{name} ({h}x{w})" in text


def test_sensor_size_sets_height_and_width(captured, tmp_path, monkeypatch):
    sizes = {}
    real = generators.dataset.dataset_jobs

    def jobs(config, **k):
        sizes["hw"] = (config.sequences[0].settings["height"], config.sequences[0].settings["width"])
        return real(config, **k)

    monkeypatch.setattr(generators.dataset, "dataset_jobs", jobs)
    _run(captured, ["generate", "ahdr", "--scene", "moving_edge", "--sensor-size", "davis346"], tmp_path)
    assert sizes["hw"] == (260, 346)
    np.save(tmp_path / "clip.npy", np.full((3, 60, 80), 100, np.uint8))
    _run(captured, ["convert", str(tmp_path / "clip.npy"), "--fps", "10", "--sensor-size", "prophesee_gen4"],
         tmp_path)
    assert sizes["hw"] == (720, 1280)


def test_convert_config_sets_what_the_flags_do_and_the_flags_override_it(captured, tmp_path, monkeypatch):
    np.save(tmp_path / "clip.npy", np.full((3, 30, 40), 100, np.uint8))
    (tmp_path / "cfg").mkdir()
    sim.write_sensor(tmp_path / "cfg" / "s.toml", sim.Sensor("mine", dvs=sim.DVSParams(pos_threshold=0.33)))
    (tmp_path / "cfg" / "convert.toml").write_text(
        'seed = 9\n[defaults]\nsensor = "s.toml"\nheight = 15\nwidth = 20\ndvs = { leak_hz = 0.0, cutoff_hz = 50.0 }\n'
        'camera = { fps = 20.0 }\n[video]\nfps = 50.0\nupsample = "linear"\n')
    seen = {}
    real = generators.dataset.dataset_jobs

    def jobs(config, **k):
        seen["config"] = config
        return real(config, **k)

    monkeypatch.setattr(generators.dataset, "dataset_jobs", jobs)
    args = ["convert", str(tmp_path / "clip.npy"), "--config", str(tmp_path / "cfg" / "convert.toml")]
    config = _run(captured, [*args, "--dvs", "cutoff_hz=80"], tmp_path)
    spec = seen["config"].sequences[0]
    assert config.dvs.pos_threshold == 0.33 and config.sensor["name"] == "mine"  # the config's sensor file
    assert config.dvs.leak_hz == 0.0 and config.dvs.cutoff_hz == 80.0  # the flag over the config's table
    assert config.camera.fps == 20.0 and (spec.settings["height"], spec.settings["width"]) == (15, 20)
    assert spec.scene["fps"] == 50.0 and spec.scene["upsample"] == "linear" and seen["config"].seed == 9
    config = _run(captured, [*args, "--camera-fps", "40", "--upsample", "none", "--width", "10", "--seed", "2"],
                  tmp_path)
    spec = seen["config"].sequences[0]
    assert config.camera.fps == 40.0 and spec.scene["upsample"] == "none" and seen["config"].seed == 2
    assert (spec.settings["height"], spec.settings["width"]) == (8, 10)  # --width alone keeps the input's aspect


@pytest.mark.parametrize("text, says", [
    ("seed = 1\nsede = 2\n", r"sede: unknown key 'sede' \(did you mean 'seed'\?\); allowed: seed, format, defaults"),
    ("[defaults]\nduration_s = 2.0\n", "defaults.duration_s: the clip sets the duration"),
    ("[video]\nupsampel = 'flow'\n", r"video.upsampel: unknown key 'upsampel' \(did you mean 'upsample'\?\)"),
    ("[defaults]\ndvs = { leak = 0.1 }\n", r"defaults.dvs.leak: unknown DVS field 'leak' \(did you mean 'leak_hz'"),
])
def test_bad_convert_configs_name_the_key(tmp_path, capsys, text, says):
    np.save(tmp_path / "clip.npy", np.full((3, 6, 8), 100, np.uint8))
    (tmp_path / "c.toml").write_text(text)
    assert main(["convert", str(tmp_path / "clip.npy"), "--config", str(tmp_path / "c.toml"), "--out",
                 str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert re.search(says, err) and str(tmp_path / "c.toml") in err, err


@pytest.mark.slow
def test_the_model_flags_and_sensor_files_load_no_numpy():
    """`evsim --help` lists the fields from the parameter modules: they import no numpy (nor numba)."""
    import subprocess
    import sys

    code = ("import sys, evsim_app.model_flags, sim.sensor_file; "
            "assert not {'numpy', 'numba'} & set(sys.modules), sorted({'numpy', 'numba'} & set(sys.modules))")
    subprocess.run([sys.executable, "-c", code], check=True)
    # the whole parser, every subcommand's help included, as `evsim --help` and `evsim plot realism --help` build it
    code = ("import sys, contextlib, io; from evsim_app.cli import main\n"
            "for argv in (['--help'], ['plot', 'realism', '--help'], ['convert', '--help']):\n"
            "    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit): main(argv)\n"
            "assert not {'numpy', 'numba'} & set(sys.modules), sorted({'numpy', 'numba'} & set(sys.modules))")
    subprocess.run([sys.executable, "-c", code], check=True)
