"""Fuzz of the TOML configuration and regression tests of the public API's bounds (issue 12's reproductions).

Config fuzz: seeded mutants of a valid configuration (a leaf replaced by a hostile value, a key deleted or added,
or a token of the TOML text corrupted). Each must either resolve into sequences whose AHDRConfig and scene build
and render a finite, non-negative first frame, or raise an EvsimInputError subclass; never another exception.
EVSIM_FUZZ_N (default 40) scales the number of mutants (x 4).
"""

from __future__ import annotations

import copy
import dataclasses
import inspect
import math
import os
from pathlib import Path

import numpy as np
import pytest

import akf
import crf_models
import evsim_eval
import sim
from akf.params import AKFParams
from generators.ahdr import MAX_REFERENCE_FRAMES, AHDRConfig, _reference_times
from generators.config import build_scene, load_config, parse_config, to_ahdr_config
from generators.scenes import Trajectory
from sim import EvsimInputError, InvalidParameterError

pytestmark = pytest.mark.slow  # hundreds of mutated configurations and API calls: left out of the fast loop

N = 4 * int(os.environ.get("EVSIM_FUZZ_N", "40"))

BASE = {
    "seed": 3,
    "format": "native",
    "defaults": {"duration_s": 0.2, "height": 12, "width": 16, "sensor": "ideal",
                 "dvs": {"pos_threshold": 0.2}, "camera": {"fps": 20.0, "exposure_us": 5000},
                 "crf": {"name": "gamma", "params": {}},
                 "sampling": {"mode": "adaptive", "fraction": 0.5, "min_step_us": 10, "max_step_us": 5000,
                              "rate_hz": 2000.0},
                 "output": {"labels": False, "threshold_maps": True, "reference_times_us": [1000],
                            "reference_rate_hz": 10.0, "compression": "gzip"}},
    "sequence": [
        {"name": "board", "speeds": [0.5, 1.0],
         "scene": {"type": "checkerboard", "square_px": 4.0, "velocity_px_per_s": [40.0, 10.0]}},
        {"name": "edge", "scene": {"type": "moving_edge", "speed_px_per_s": 60.0}},
        {"name": "flicker", "height": 8, "scene": {"type": "flicker", "frequency_hz": 50.0}},
        {"name": "sun", "scene": {"type": "sun", "velocity_px_per_s": [40.0, 10.0]}},
        {"name": "disk", "scene": {"type": "rotating_disk", "angular_speed_deg_s": 90.0}},
    ],
    "sweep": {"threshold_sigma": [0.0, 0.03]},
}
HOSTILE = [float("nan"), float("inf"), -1, 0, -1.5, 1e300, 2**63 - 1, True, "", "x", "../x", "/abs", "a/b", ".h",
           [], [float("nan")], [-1.0], {}, {"type": "sun"}, 0.5, 7]


def _leaves(d, prefix=()):
    if isinstance(d, dict):
        for k, v in d.items():
            yield prefix + (k,), v
            yield from _leaves(v, prefix + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield prefix + (i,), v
            yield from _leaves(v, prefix + (i,))


def mutate_config(rng) -> tuple[dict, str]:
    data = copy.deepcopy(BASE)
    paths = [p for p, _ in _leaves(data)]
    path = paths[rng.integers(len(paths))]
    parent = data
    for k in path[:-1]:
        parent = parent[k]
    kind = rng.integers(4)
    if kind == 0 and isinstance(parent, dict):
        del parent[path[-1]]
        return data, f"del {path}"
    if kind == 1 and isinstance(parent, dict):
        parent["bogus_key"] = 1
        return data, f"add bogus key at {path[:-1]}"
    v = HOSTILE[rng.integers(len(HOSTILE))]
    parent[path[-1]] = copy.deepcopy(v)
    return data, f"{path} = {v!r}"


def check_config_outcome(build) -> str:
    try:
        cfg = build()
        for spec in cfg.sequences:
            s = spec.settings
            to_ahdr_config(s, where=spec.name)
            scene = build_scene(spec.scene, s["height"], s["width"], spec.duration_us, where=spec.name)
            if s["height"] * s["width"] <= 100_000:
                img = np.asarray(scene.radiance(0))
                if img.shape != (s["height"], s["width"]) or not (np.isfinite(img).all() and img.min() >= 0):
                    return f"silent acceptance: scene {spec.name} renders {img.shape} min {img.min()}"
    except EvsimInputError:
        return "error"
    except Exception as e:  # noqa: BLE001 - the point of the test
        return f"undocumented {type(e).__name__}: {e}"
    return "valid"


def test_mutated_configurations_resolve_or_raise_evsim_input_error():
    assert check_config_outcome(lambda: parse_config(copy.deepcopy(BASE))) == "valid"
    failures, outcomes = [], {"valid": 0, "error": 0}
    for i in range(N):
        rng = np.random.default_rng([7, i])
        data, desc = mutate_config(rng)
        if rng.random() < 0.3:
            data2, desc2 = mutate_config(rng)
            data["defaults"] = data2.get("defaults", data.get("defaults"))
            desc += f"; defaults from ({desc2})"
        out = check_config_outcome(lambda data=data: parse_config(data))
        outcomes[out if out in outcomes else "bad"] = outcomes.get(out, 0) + 1
        if out not in ("valid", "error"):
            failures.append(f"#{i} {desc}: {out}")
    assert not failures, "\n".join(failures[:20])
    assert outcomes["error"] > N // 4
    print(outcomes)


TOML = """seed = 1
[defaults]
duration_s = 0.2
height = 12
width = 16
camera = { fps = 20.0, exposure_us = 5000 }
output = { reference_rate_hz = 10.0 }
[[sequence]]
name = "board"
speeds = [0.5, 2.0]
scene = { type = "checkerboard", square_px = 4.0, velocity_px_per_s = [40.0, 10.0] }
"""
TOKENS = ["nan", "inf", "-1", "\"../x\"", "\"\"", "[", "}", "=", "1e999", "\"a/b\"", "0", "true", "[nan]", "-inf"]


def test_mutated_toml_text_loads_or_raises_evsim_input_error(tmp_path):
    failures = []
    for i in range(N // 2):
        rng = np.random.default_rng([11, i])
        words = TOML.replace("=", " = ").split(" ")
        j = int(rng.integers(len(words)))
        words[j] = TOKENS[rng.integers(len(TOKENS))] + ("\n" if words[j].endswith("\n") else "")
        path = tmp_path / f"c{i}.toml"
        path.write_text(" ".join(words))
        out = check_config_outcome(lambda path=path: load_config(path))
        if out not in ("valid", "error"):
            failures.append(f"#{i}: {out}\n{path.read_text()}")
    assert not failures, "\n".join(failures[:10])


# ----- regression tests: issue 12's reproductions --------------------------------------------------------------

@pytest.mark.parametrize("name", ["../x", "/tmp/abs", "sub/dir", "", ".hidden", "a\\b"])
def test_sequence_names_that_would_escape_or_hide_are_refused(name):
    data = copy.deepcopy(BASE)
    data["sequence"][1]["name"] = name
    with pytest.raises(InvalidParameterError, match="name"):
        parse_config(data)


def test_write_sequence_refuses_bad_names_from_python(tmp_path):
    from generators.dataset import write_sequence

    with pytest.raises(InvalidParameterError, match="plain file name"):
        write_sequence(tmp_path, "../escape", None, None, None, "native", progress=False)
    assert not (tmp_path.parent / "escape.h5").exists()


@pytest.mark.parametrize("speeds, match", [([float("nan")], "finite"), ([-1.0], "finite"), ([0.0], "finite"),
                                           ([], "non-empty")])
def test_bad_speed_factors_are_refused(speeds, match):
    data = copy.deepcopy(BASE)
    data["sequence"][0]["speeds"] = speeds
    with pytest.raises(InvalidParameterError, match=match):
        parse_config(data)


def test_speeds_that_would_be_ignored_are_refused():
    data = copy.deepcopy(BASE)
    data["sequence"][1] = {"name": "edge", "speeds": [2.0], "scene": {"type": "moving_edge"}}
    with pytest.raises(InvalidParameterError, match="would be ignored"):
        parse_config(data)
    data["sequence"][1]["scene"]["speed_px_per_s"] = 10.0
    names = [s.name for s in parse_config(data).sequences]
    assert "edge_x2" in names


@pytest.mark.parametrize("key, value", [("height", 0), ("width", 70_000), ("duration_s", float("nan"))])
def test_sensor_sizes_and_durations_are_bounded(key, value):
    data = copy.deepcopy(BASE)
    data["defaults"][key] = value
    with pytest.raises(InvalidParameterError, match=key):
        parse_config(data)
    data["defaults"].update(height=10_000, width=10_000)
    with pytest.raises(InvalidParameterError, match="at most"):
        parse_config(data)


def test_trajectory_with_nan_pan_is_refused():
    with pytest.raises(InvalidParameterError, match="pan_px_per_s"):
        Trajectory(pan_px_per_s=(float("nan"), float("nan")))
    with pytest.raises(InvalidParameterError, match="pan_px_per_s"):
        Trajectory(pan_px_per_s=(1.0, float("inf")))


@pytest.mark.parametrize("value", [1.5, "10", True, (1000, 2.5)])
def test_camera_exposure_must_be_integer_microseconds(value):
    with pytest.raises(InvalidParameterError, match="exposure_us"):
        sim.CameraParams(exposure_us=value)
    assert sim.CameraParams(exposure_us=np.int64(1000)).exposures == (1000,)


def test_reference_and_sampling_rates_are_bounded():
    with pytest.raises(InvalidParameterError, match="reference_rate_hz"):
        AHDRConfig(reference_rate_hz=1e9)
    with pytest.raises(InvalidParameterError, match="rate_hz"):
        AHDRConfig(sampling="fixed", rate_hz=float("nan"))
    # the count is bounded too, before any reference is rendered (1 MHz over 1 s)
    with pytest.raises(InvalidParameterError, match=str(MAX_REFERENCE_FRAMES)):
        _reference_times(AHDRConfig(reference_rate_hz=1e6), 1_000_000)
    assert len(_reference_times(AHDRConfig(reference_rate_hz=10.0), 1_000_000)) == 11


def test_emulator_refuses_a_time_gap_it_would_spend_hours_on():
    frames = np.ones((2, 4, 4))
    with pytest.raises(InvalidParameterError, match="MAX_TIME_GAP_US"):
        sim.emulate(frames, np.array([0, 10**13]), sim.DVSParams.preset("davis346"))
    emu = sim.DVSEmulator(4, 4, sim.DVSParams.preset("ideal"))
    emu.feed(frames[0], 0)
    with pytest.raises(InvalidParameterError, match="MAX_TIME_GAP_US"):
        emu.feed(frames[1], sim.dvs.MAX_TIME_GAP_US + 1)
    assert emu.feed(2 * frames[1], sim.dvs.MAX_TIME_GAP_US).size > 0  # the bound itself is accepted


def test_uint64_times_beyond_int64_are_refused_not_wrapped():
    t = np.array([0, 2**63 + 10], dtype=np.uint64)
    with pytest.raises(EvsimInputError, match="2\\*\\*62"):
        sim.emulate(np.ones((2, 4, 4)), t, sim.DVSParams.preset("ideal"))
    with pytest.raises(EvsimInputError, match="2\\*\\*62"):
        sim.make_events(t, [0, 0], [0, 0], [1, 1])
    with pytest.raises(EvsimInputError, match="x"):
        sim.make_events([0], [-1], [0], [1])


def _akf_inputs():
    rng = np.random.default_rng(0)
    frames = rng.integers(50, 200, (3, 6, 8)).astype(np.uint8)
    t0 = np.array([0, 10_000, 20_000])
    ev = sim.make_events([5000, 15000], [1, 2], [1, 2], [1, -1])
    return ev, frames, t0, t0 + 1000, crf_models.get("linear")


def test_akf_contrast_is_bounded_at_its_boundary():
    ev, frames, ts, te, crf = _akf_inputs()
    for contrast in (1e300, float("nan"), 0.0, -0.2, (0.2, 50.0)):
        with pytest.raises(InvalidParameterError, match="contrast"):
            akf.reconstruct(ev, frames, ts, te, crf, [20_500], contrast=contrast)
    out = akf.reconstruct(ev, frames, ts, te, crf, [20_500], contrast=0.2)
    assert np.isfinite(out).all()
    with pytest.raises(EvsimInputError, match="2\\*\\*62"):
        akf.reconstruct(ev, frames, ts, te, crf, np.array([2**63 + 1], np.uint64))
    assert math.isfinite(float(akf.frames_only(ev, frames, ts, te, crf, [20_500]).max()))


def test_reconstruct_refuses_an_existing_output_unless_overwrite(tmp_path):
    from evsim_app.cli import main
    from generators.formats import export

    from recordings import make_recording

    rec = make_recording(n_events=200)
    export(rec, tmp_path / "d.h5", "native")
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    assert main(["reconstruct", str(tmp_path / "d.h5"), "--out", str(out), "--method", "frames"]) == 2
    assert (out / "keep.txt").read_text() == "precious"
    f = tmp_path / "file"
    f.write_text("precious")
    assert main(["reconstruct", str(tmp_path / "d.h5"), "--out", str(f), "--method", "frames"]) == 2
    assert f.read_text() == "precious"
    assert main(["reconstruct", str(tmp_path / "d.h5"), "--out", str(out), "--method", "frames",
                 "--overwrite"]) == 0
    assert (out / "timestamps.txt").is_file() and not list(tmp_path.glob(".*.tmp"))
    assert Path(out).is_dir()


# ----- API fuzz (issue 27): every parameter of the public constructors and methods with hostile kinds ----------

HOSTILE_API = [True, np.bool_(False), "0.2", "", 0.2 + 0j, float("nan"), float("-inf"), -1, 0, 2.5, 1e300, None,
               [], (1.0,), (0.5, 2.0, 3.0), object(), np.float32(0.5), np.int64(3), np.array([1.0, 2.0])]
_NOT_A_NUMBER = (bool, np.bool_, str, complex, type(None), list, tuple)  # (a 2-array is a valid pair)


def _scene_calls():
    from generators.scenes import Checkerboard, FlickeringLight, MovingEdge, RotatingBar, RotatingDisk, SunPatch

    for cls in (MovingEdge, Checkerboard, RotatingBar, RotatingDisk, FlickeringLight, SunPatch):
        names = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
        for name in names:
            def call(v, cls=cls, name=name):
                args = {"height": 8, "width": 8, "duration_us": 1000, name: v}
                scene = cls(args.pop("height"), args.pop("width"), args.pop("duration_us"), **args)
                img = scene.radiance(0)
                assert img.shape == (scene.height, scene.width) and np.isfinite(img).all() and img.min() >= 0, \
                    "bad rendering"
                return scene
            default = inspect.signature(cls.__init__).parameters[name].default
            yield f"{cls.__name__}.{name}", call, default is None, False


def _dataclass_calls():
    for cls in (AKFParams, sim.DVSParams, sim.CameraParams, Trajectory):
        for f in dataclasses.fields(cls):
            yield (f"{cls.__name__}.{f.name}", lambda v, cls=cls, name=f.name: cls(**{name: v}), "None" in f.type,
                   f.type == "bool")


def _function_calls():
    ev, frames, ts, te, crf = _akf_inputs()
    img, ref = np.full((8, 8), 0.5), np.linspace(0.1, 1.0, 64).reshape(8, 8)
    for name in ("contrast", "max_intensity", "bit_depth"):
        yield (f"reconstruct.{name}", lambda v, name=name: akf.reconstruct(ev, frames, ts, te, crf, [20_500],
                                                                            **{name: v}), name == "max_intensity",
               False)
    for name in ("crossover_hz", "alpha", "i0", "adaptive_factor", "adaptive_margin"):
        def cf(v, name=name):
            kw = {name: v} if name != "alpha" else {"alpha": v, "crossover_hz": None}
            return akf.complementary_filter(ev, frames, ts, te, crf, [20_500], **kw)
        yield f"complementary_filter.{name}", cf, name in ("crossover_hz", "alpha"), False
    def image(v):  # a hostile number fills an image; other values are the image
        return np.full((8, 8), v) if isinstance(v, (int, float, complex, np.generic)) else v

    for metric in evsim_eval.metrics.METRICS:
        yield (f"metrics.{metric}", lambda v, metric=metric: evsim_eval.metrics.score(metric, image(v), ref, white=1.0),
               False, False)
    yield "metrics.psnr.data_range", lambda v: evsim_eval.metrics.psnr(img, ref, data_range=v), True, False
    yield ("metrics.pu21_ssim.luminance_scale",
           lambda v: evsim_eval.metrics.pu21_ssim(img, ref, luminance_scale=v), False, False)


def test_api_parameters_of_hostile_kinds_are_refused_naming_the_parameter():
    """Each parameter with each hostile value: accepted only when the value is a real number (a bool only for a
    bool field, None only where None is the documented default), else an EvsimInputError whose message names the
    parameter; never another exception."""
    failures, outcomes = [], {"valid": 0, "error": 0}
    calls = [*_dataclass_calls(), *_scene_calls(), *_function_calls()]
    for what, call, none_ok, bool_field in calls:
        param = what.rsplit(".", 1)[-1]
        for v in HOSTILE_API:
            try:
                call(v)
            except EvsimInputError as e:
                outcomes["error"] += 1
                if param not in str(e) and not what.startswith("metrics."):
                    failures.append(f"{what}={v!r}: the message does not name {param}: {e}")
                continue
            except Exception as e:  # noqa: BLE001 - the point of the test
                failures.append(f"{what}={v!r}: undocumented {type(e).__name__}: {e}")
                continue
            outcomes["valid"] += 1
            kind_ok = (v is None and none_ok) or (isinstance(v, (bool, np.bool_)) and bool_field)
            if (isinstance(v, _NOT_A_NUMBER) or type(v) is object) and not kind_ok and not what.startswith("metrics."):
                failures.append(f"{what}={v!r}: silently accepted")
    assert not failures, f"{len(failures)} failures:\n" + "\n".join(failures[:30])
    assert outcomes["error"] > outcomes["valid"]
    print(len(calls), "parameters,", outcomes)
