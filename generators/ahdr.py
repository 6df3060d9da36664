"""The AHDR generator: one scene -> one hybrid event/frame sequence with HDR ground truth.

generate_ahdr() streams the scene through both sensor models into a native HDF5 file:
- DVS: the scene is sampled by the adaptive (or fixed-rate) sampler and fed to sim.DVSEmulator in chunks;
- LDR camera: sim.LDRCamera captures frames (exposure, motion blur, noise, the CRF; AHDR "window" by default);
- reference: the scene radiance at every frame's mid-exposure time, plus optional extra times or a regular rate;
- frames and reference are written when AHDRConfig.outputs names them (the events always);
- threshold maps and per-event labels when requested; metadata: the resolved configuration, the seed (entropy and
  spawn key), package versions, the CRF, the number of DVS samples, and reference_to_crf_x: the factor from
  reference radiance to the CRF's scaled irradiance x of frame 0's exposure (the units of akf's output), and
  reference_white_radiance: the radiance the evaluation's [0, 1] protocol maps to 1 (98th percentile at t = 0).
A scene that started before its t = 0 (scene.warm_up_us > 0: a recorded clip) is fed to the DVS mirrored in time
over its first warm_up_us before t = 0, so that the DVS starts in a running state (generators.dvs_input, the DVS
pass that conversion and calibration share).
Times are written in the scene's own time base: scene time + scene.time_origin_us when the scene has one (a
recording's frames or a timestamps file: the simulated events carry the times of the input), recorded as
metadata "time_origin_us".
Memory stays flat in the sequence length: one chunk of samples and one frame are alive at a time.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.metadata
import math
import platform
import time
from collections.abc import Iterable
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from tqdm.auto import tqdm

import crf_models
import sim
from sim import InvalidParameterError
from sim.seeding import as_seed_sequence, child_seed, seed_record

from .choices import OUTPUTS
from .dvs_input import MAX_FIXED_SAMPLES, DVSInput
from .formats.native import NativeWriter, check_compression
from .sampling import read_ahead

if TYPE_CHECKING:
    from collections.abc import Iterator

    from sim.source import RadianceSource

__all__ = ["AHDRConfig", "check_outputs", "GenerationResult", "generate_ahdr", "resolve_sensors", "package_versions",
           "REFERENCE_WHITE_PERCENTILE", "MAX_RATE_HZ", "MAX_REFERENCE_FRAMES", "MAX_FIXED_SAMPLES"]

_PACKAGES = ("evsim", "numpy", "numba", "scipy", "opencv-python-headless", "h5py", "OpenEXR", "colour-science",
             "scikit-image", "tqdm", "isal")
REFERENCE_WHITE_PERCENTILE = 98.0  # of the radiance at t = 0: what the evaluation's [0, 1] protocol maps to 1
MAX_RATE_HZ = 1e6  # reference and fixed sampling rates: at most one per microsecond (the clock's resolution)
MAX_REFERENCE_FRAMES = 100_000  # reference frames per sequence (each a float32 H x W image)
_CHUNK_PIXEL_SAMPLES = 1 << 23  # DVS input per feed() call: about 32 MB of float32 (8 key frames at 720p)


@dataclass(frozen=True)
class AHDRConfig:
    """How to turn a scene into a sequence.

    auto_exposure and auto_illumination adapt the sensors to the scene's arbitrary radiance units; the resolved
    values are recorded in the metadata. The events are the same whatever the outputs (the DVS input is sampled at
    the frame and reference times either way).

    Attributes
    ----------
    dvs : sim.DVSParams
        The DVS parameters (default the davis346 preset).
    camera : sim.CameraParams
        The LDR camera's parameters (default CameraParams()).
    sensor : dict
        The sensor model they came from, as sim.Sensor.describe() gives it (name, base, file, provenance; {} when
        the parameters were given directly); recorded in the metadata.
    crf : str
        The camera response's name (``crf_models.get(crf, **crf_params)``); default the AHDR "window".
    crf_params : dict
        Its parameters (default {}).
    auto_exposure : bool
        Set camera.reference_radiance so that the scene's median radiance at t = 0 gives the mid response
        (crf.inverse(0.5)); default True.
    auto_illumination : bool
        Set dvs.full_illumination to the scene's 99th-percentile radiance at t = 0 (the DVS bandwidth and dark level
        are relative to it); default True.
    sampling : {"adaptive", "fixed"}
        How the DVS input is sampled in time: adaptive steps (default) or rate_hz samples per second (at most
        MAX_RATE_HZ and MAX_FIXED_SAMPLES per sequence).
    sampling_fraction : float
        Adaptive: the fraction of the smaller mean threshold (log units) allowed per sample (default 0.5).
    sampling_quantile : float
        Adaptive: the quantile of the per-pixel log change that fraction bounds, in [0.5, 1] (default 0.95; 1.0:
        the worst pixel, about 10x denser; on the built-in 346x260 pans and zooms 0.95 gives the same event count
        within 0.2 %, per-pixel count correlation 0.9998, event times within 14 us median, 277 us at the 99th
        percentile).
    min_step_us, max_step_us : int
        Adaptive: the bounds of a step (us; default 10 and 5000).
    rate_hz : float
        Fixed: samples per second (Hz, in (0, MAX_RATE_HZ]; default 2000).
    reference_times_us : tuple of int
        Extra HDR reference times (us; default none).
    reference_rate_hz : float
        Extra references on a regular grid (Hz; 0, the default: none; at most MAX_RATE_HZ, and MAX_REFERENCE_FRAMES
        references per sequence).
    threshold_maps : bool
        Store the per-pixel contrast thresholds (default True).
    labels : bool
        Store the per-event labels (default False).
    compression : {"gzip", "lzf", None}
        Of the HDF5 datasets: "gzip" (default: HDF5's standard shuffle + deflate filters, compressed by ISA-L,
        generators.formats.native), "lzf" (h5py's filter: other HDF5 tools need a plugin) or None.
    outputs : tuple of str
        What the file holds, of generators.choices.OUTPUTS: "events" (always), "frames" (the LDR camera's frames;
        without it the camera is not run) and "reference" (the HDR reference frames). Default all.
    """

    dvs: sim.DVSParams = field(default_factory=lambda: sim.DVSParams.preset("davis346"))
    camera: sim.CameraParams = field(default_factory=sim.CameraParams)
    sensor: dict = field(default_factory=dict)
    crf: str = "window"
    crf_params: dict = field(default_factory=dict)
    auto_exposure: bool = True
    auto_illumination: bool = True
    sampling: str = "adaptive"
    sampling_fraction: float = 0.5
    sampling_quantile: float = 0.95
    min_step_us: int = 10
    max_step_us: int = 5000
    rate_hz: float = 2000.0
    reference_times_us: tuple[int, ...] = ()
    reference_rate_hz: float = 0.0
    threshold_maps: bool = True
    labels: bool = False
    compression: str | None = "gzip"
    outputs: tuple[str, ...] = OUTPUTS

    def __post_init__(self):
        object.__setattr__(self, "outputs", check_outputs(self.outputs))
        if not isinstance(self.dvs, sim.DVSParams) or not isinstance(self.camera, sim.CameraParams):
            raise InvalidParameterError("AHDRConfig: dvs must be a sim.DVSParams and camera a sim.CameraParams")
        object.__setattr__(self, "reference_times_us", tuple(int(t) for t in self.reference_times_us))
        if not (math.isfinite(self.reference_rate_hz) and 0 <= self.reference_rate_hz <= MAX_RATE_HZ):
            raise InvalidParameterError(f"reference_rate_hz must be in [0, {MAX_RATE_HZ:g}] Hz, got "
                                        f"{self.reference_rate_hz}")
        if not (math.isfinite(self.rate_hz) and 0 < self.rate_hz <= MAX_RATE_HZ):
            raise InvalidParameterError(f"rate_hz must be in (0, {MAX_RATE_HZ:g}] Hz, got {self.rate_hz}")
        check_compression(self.compression)
        if not 0.5 <= self.sampling_quantile <= 1:
            raise InvalidParameterError(f"sampling_quantile must be in [0.5, 1], got {self.sampling_quantile!r}")
        if self.sampling not in ("adaptive", "fixed"):
            raise InvalidParameterError(f"sampling must be 'adaptive' or 'fixed', got {self.sampling!r}")

    def to_dict(self) -> dict:
        """JSON-serialisable form, recorded in the metadata and hashed into a dataset's spec_hash.

        Returns
        -------
        dict
            The fields by name (units as the Attributes), the sensor parameters as dicts, tuples as lists.
        """
        return _jsonable(dataclasses.asdict(self))


def check_outputs(outputs: Iterable[str]) -> tuple[str, ...]:
    """The outputs checked: names of OUTPUTS, "events" among them; InvalidParameterError naming an unknown one.

    Parameters
    ----------
    outputs : iterable of str
        Output names.

    Returns
    -------
    tuple of str
        The outputs in OUTPUTS order.
    """
    if isinstance(outputs, str) or not all(isinstance(o, str) for o in outputs):
        raise InvalidParameterError(f"outputs must be a list of names ({', '.join(OUTPUTS)}), got {outputs!r}")
    unknown = [o for o in outputs if o not in OUTPUTS]
    if unknown:
        raise InvalidParameterError(f"unknown output {unknown[0]!r}; outputs are {', '.join(OUTPUTS)}")
    if "events" not in outputs:
        raise InvalidParameterError(f"outputs must include events (the DVS output), got {', '.join(outputs) or 'none'}")
    return tuple(o for o in OUTPUTS if o in outputs)


def _jsonable(v):
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


@dataclass
class GenerationResult:
    """What generate_ahdr wrote: the file, counts, and the split of the work in seconds by stage.

    Attributes
    ----------
    path : Path
        The native file.
    n_events, n_frames, n_references : int
        Events, LDR frames and HDR reference frames written.
    n_dvs_samples : int
        Radiance samples the DVS was fed.
    timings_s : dict
        Wall-clock seconds by stage, of the calling thread: "scene" (during the DVS pass, waiting for the scene,
        which is rendered on a thread of its own meanwhile; rendering for the camera), "dvs" (the emulator),
        "camera" (exposure, noise, CRF; without rendering), "writing" (the HDF5 file), "total" (the whole call).
    cpu_s : dict
        CPU seconds of the process over the same intervals (time.process_time: all threads, so a stage counts the
        work of the threads running beside it, the scene's during the DVS pass).
    """

    path: Path
    n_events: int
    n_frames: int
    n_references: int
    n_dvs_samples: int
    timings_s: dict
    cpu_s: dict = field(default_factory=dict)


class _Clock:
    """Wall-clock and CPU seconds added up per stage."""

    def __init__(self, stages):
        self.wall = dict.fromkeys(stages, 0.0)
        self.cpu = dict.fromkeys(stages, 0.0)

    @staticmethod
    def now() -> tuple[float, float]:
        return time.perf_counter(), time.process_time()

    def add(self, stage: str, since: tuple[float, float], minus: tuple[float, float] = (0.0, 0.0)) -> None:
        """Add the time elapsed since `since` (a now() pair), less `minus` (wall, cpu), to `stage`."""
        wall, cpu = self.now()
        self.wall[stage] += wall - since[0] - minus[0]
        self.cpu[stage] += cpu - since[1] - minus[1]


@functools.lru_cache(maxsize=1)
def _versions() -> tuple:
    out = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return tuple(out.items())


def package_versions() -> dict:
    """Versions of Python and the packages that determine the output (read once per process).

    Returns
    -------
    dict
        Name -> version string ("python" and the packages; None for a package that is not installed).
    """
    return dict(_versions())


def resolve_sensors(scene: RadianceSource,
                    config: AHDRConfig) -> tuple[sim.DVSParams, sim.CameraParams, crf_models.CRF]:
    """The DVS and camera parameters after auto exposure / illumination, and the CRF object.

    Parameters
    ----------
    scene : RadianceSource
        The scene (its radiance at t = 0 sets the exposure and illumination).
    config : AHDRConfig
        The configuration.

    Returns
    -------
    dvs : sim.DVSParams
        With full_illumination set when config.auto_illumination (radiance units).
    camera : sim.CameraParams
        With reference_radiance set when config.auto_exposure (radiance units).
    crf : crf_models.CRF
        The camera response.
    """
    try:
        crf = crf_models.get(config.crf, **config.crf_params)
    except crf_models.CRFError as e:
        raise InvalidParameterError(f"crf: {e}") from None
    dvs, camera = config.dvs, config.camera
    if config.auto_exposure or config.auto_illumination:
        first = scene.radiance(0)
        if config.auto_exposure:
            median = float(np.median(first))
            if median > 0:
                x_mid = float(crf.inverse(0.5))
                camera = dataclasses.replace(camera, reference_radiance=median * camera.reference_fill / x_mid)
        if config.auto_illumination:
            bright = float(np.percentile(first, 99))
            if bright > 0:
                dvs = dataclasses.replace(dvs, full_illumination=bright)
    return dvs, camera, crf


class _TimedSource:
    """A RadianceSource proxy that adds up the time spent in radiance() and offset_log() (scene rendering):
    seconds = (wall, cpu)."""

    def __init__(self, source):
        self._source = source
        self.height, self.width, self.duration_us = source.height, source.width, source.duration_us
        self.seconds = (0.0, 0.0)

    def radiance(self, t_us):
        return self._timed(self._source.radiance, t_us)

    def offset_log(self, t_us, offset):
        return self._timed(self._source.offset_log, t_us, offset)

    def _timed(self, render, *args):
        w0, c0 = _Clock.now()
        img = render(*args)
        w1, c1 = _Clock.now()
        self.seconds = (self.seconds[0] + w1 - w0, self.seconds[1] + c1 - c0)
        return img

    def max_speed_px_per_s(self):
        return self._source.max_speed_px_per_s()

    def __getattr__(self, name):  # optional source methods (e.g. log_linear_until, for the sampler) pass through
        return getattr(self._source, name)


def _reference_times(config: AHDRConfig, duration_us: int) -> list[int]:
    times = set(config.reference_times_us)
    n = len(times) + duration_us * 1e-6 * config.reference_rate_hz
    if n > MAX_REFERENCE_FRAMES:
        raise InvalidParameterError(f"{n:.3g} reference frames requested (reference_rate_hz "
                                    f"{config.reference_rate_hz:g} over {duration_us} us): at most "
                                    f"{MAX_REFERENCE_FRAMES}")
    if config.reference_rate_hz > 0:
        step = 1e6 / config.reference_rate_hz
        times.update(int(round(k * step)) for k in range(int(duration_us / step) + 1))
    bad = [t for t in times if not 0 <= t <= duration_us]
    if bad:
        raise InvalidParameterError(f"reference time {min(bad)} us lies outside the scene [0, {duration_us}] us")
    return sorted(times)


def _rates(t_us: int, duration_us: int, frames: int, events: int, bar: tqdm) -> str:
    """The DVS progress text: scene time done, input frames and events per second of wall time."""
    elapsed = max(bar.format_dict["elapsed"], 1e-9)
    return (f"{t_us * 1e-6:.3g}/{duration_us * 1e-6:.3g} s of scene, {frames / elapsed:.3g} frames/s, "
            f"{events / elapsed:.3g} events/s")


def generate_ahdr(scene: RadianceSource, path: str | Path, config: AHDRConfig | None = None,
                  seed: int | np.random.SeedSequence = 0, *, progress: bool = True,
                  metadata: dict | None = None) -> GenerationResult:
    """Simulate `scene` (a sim.source.RadianceSource) into a native HDF5 file at `path` (written atomically).

    Parameters
    ----------
    scene : RadianceSource
        The scene (radiance(t_us) -> (H, W) float32 linear radiance over [0, duration_us]).
    path : str or Path
        The native HDF5 file to write.
    config : AHDRConfig, optional
        How to turn the scene into a sequence (default AHDRConfig()).
    seed : int or numpy.random.SeedSequence
        Child 0 seeds the DVS, child 1 the camera; the same seed and configuration give bit-identical events and
        frames.
    progress : bool
        Show progress bars (scene time for the DVS, frames for the camera).
    metadata : dict, optional
        Extra keys stored with the sequence (e.g. its name).

    Returns
    -------
    GenerationResult
        The file, the counts and the time per stage.
    """
    clock = _Clock(("scene", "dvs", "camera", "writing", "total"))
    t_total = clock.now()
    config = config or AHDRConfig()
    ss = as_seed_sequence(seed)
    src = _TimedSource(scene)
    h, w = scene.height, scene.width
    dvs_params, cam_params, crf = resolve_sensors(scene, config)
    schedule = cam_params.schedule(h, int(scene.duration_us))
    refs = _reference_times(config, int(scene.duration_us))
    # The DVS is sampled at every reference and frame time too, so its input is exact there.
    dvs_input = DVSInput(scene, config, dvs_params, breakpoints_us=[*refs, *schedule[:, 1].tolist()], source=src)
    dvs = sim.DVSEmulator(h, w, dvs_params, child_seed(ss, 0), return_labels=config.labels)
    camera = sim.LDRCamera(h, w, cam_params, crf, child_seed(ss, 1))
    warm_stack, warm_times = dvs_input.warm_up()
    if warm_stack:  # the scene started before its t = 0 (a recorded clip): the DVS enters t = 0 running
        dvs.feed(np.stack(warm_stack), warm_times)
    meta = _metadata(scene, config, ss, dvs_params, cam_params, crf, schedule, dvs_input.time_origin_us, metadata)
    counts = {"events": 0, "frames": 0, "references": 0}
    with NativeWriter(path, h, w, metadata=meta, frame_bit_depth=cam_params.bit_depth,
                      compression=config.compression) as writer:
        writer.set_crf(meta["crf"])
        if config.threshold_maps:
            writer.set_threshold_maps(dvs.threshold_map)
        log_in = _holds_the_log_response(scene, dvs, dvs_input)
        sampler = dvs_input.sampler(dvs.dark_level if log_in else None)
        _run_dvs(writer, dvs, dvs_input, sampler, log_in, config, set(refs) | set(schedule[:, 1].tolist()), counts,
                 clock, progress)
        rendered_for_dvs = src.seconds
        if "frames" in config.outputs:
            _run_camera(writer, camera, src, len(schedule), dvs_input.time_origin_us, counts, clock, progress)
        writer.update_metadata({"n_dvs_samples": sampler.n_samples,
                                "n_dvs_evaluations": getattr(sampler, "n_evaluations", sampler.n_samples),
                                "n_events": counts["events"], "n_frames": counts["frames"],
                                "n_references": counts["references"]})
        t_close = clock.now()
    clock.add("writing", t_close)
    for which, d in ((clock.wall, 0), (clock.cpu, 1)):  # rendering for the camera
        which["scene"] += src.seconds[d] - rendered_for_dvs[d]
    clock.add("total", t_total)
    return GenerationResult(Path(path), counts["events"], counts["frames"], counts["references"],
                            sampler.n_samples, clock.wall, clock.cpu)


def _metadata(scene: RadianceSource, config: AHDRConfig, ss: np.random.SeedSequence, dvs_params: sim.DVSParams,
              cam_params: sim.CameraParams, crf: crf_models.CRF, schedule: np.ndarray, origin: int,
              extra: dict | None) -> dict:
    """The sequence's metadata: the resolved configuration, seed, scene, time origin, CRF, unit conversions and
    package versions, with the caller's extra keys."""
    resolved = config.to_dict()
    resolved["dvs"] = _jsonable(dataclasses.asdict(dvs_params))
    resolved["camera"] = _jsonable(dataclasses.asdict(cam_params))
    return {
        "generator": "ahdr",
        "seed": seed_record(ss),
        "config": resolved,
        "scene": scene.describe() if hasattr(scene, "describe") else {"type": type(scene).__name__},
        "duration_us": int(scene.duration_us),
        "time_origin_us": origin,
        "crf": {"name": crf.name, "params": _jsonable(crf.params)},
        # reference radiance -> the CRF's scaled irradiance x of frame 0's exposure (the units of akf's output)
        "reference_to_crf_x": (cam_params.electrons_per_radiance_us * int(schedule[0, 2] - schedule[0, 0])
                               / cam_params.full_well_e) if len(schedule) else None,
        # the paper's [0, 1] protocol: the radiance that maps to 1 (the AHDR rule: the 98th percentile at t = 0)
        "reference_white_radiance": float(np.percentile(scene.radiance(0), REFERENCE_WHITE_PERCENTILE)),
        "packages": package_versions(),
        **(extra or {}),
    }


def _holds_the_log_response(scene: RadianceSource, dvs: sim.DVSEmulator, dvs_input: DVSInput) -> bool:
    """Whether the scene holds the DVS's log response, log(radiance + dark level), without an exp (has_log_at the
    dark level): the pass then samples it (offset_log; the adaptive sampler only in log-linear pieces) and feeds it
    to DVSEmulator.feed_log."""
    return (getattr(scene, "has_log_at", lambda offset: False)(dvs.dark_level)
            and (dvs_input.mode == "fixed" or getattr(scene, "log_linear_until", None) is not None))


def _run_dvs(writer: NativeWriter, dvs: sim.DVSEmulator, dvs_input: DVSInput, sampler: Iterator, log_in: bool,
             config: AHDRConfig, ref_times: set[int], counts: dict, clock: _Clock, progress: bool) -> None:
    """The DVS pass: the scene's samples (its radiance, or with log_in its log response) fed to the DVS in chunks
    (about 32 MB each; a run of key frames of one group as a view of it, _planes_in_a_row), its events and the
    reference images written as they come (every reference time is a sampler breakpoint: the image the pass
    rendered there is the reference, or with log_in the radiance rendered there beside it)."""
    duration = int(dvs_input.source.duration_us)
    origin = dvs_input.time_origin_us

    def write(method, *args):
        t0 = clock.now()
        getattr(writer, method)(*args)
        clock.add("writing", t0)

    chunk = max(2, _CHUNK_PIXEL_SAMPLES // (writer.height * writer.width))
    block = np.empty((chunk, writer.height, writer.width), np.float32)  # reused: a new one each time costs page faults
    # a scene whose renders are finite by construction (its inputs checked where they enter) makes its log samples
    # the same way, at or above its floor: the DVS need not check them again
    trusted = bool(getattr(dvs_input.source, "renders_finite", False))

    def feed(stack, times):
        t0 = clock.now()
        run = _planes_in_a_row(stack)
        samples = run if run is not None else np.stack(stack, out=block[:len(stack)])
        times = np.asarray(times, dtype=np.int64)
        out = dvs.feed_log(samples, times, check_finite=not trusted) if log_in else dvs.feed(samples, times)
        clock.add("dvs", t0)
        events, labels = dvs_input.scene_events(*(out if config.labels else (out, None)))
        write("add_events", events, labels)
        counts["events"] += events.size

    # over scene time (its ETA is the run's), showing the DVS input frames and events per second of wall time
    with tqdm(total=duration, desc="events", disable=not progress, leave=False,
              bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]") as bar:
        # the first feed() compiles the DVS kernels on an empty numba cache (tens of seconds): say so
        bar.set_postfix_str("first chunk: loading or compiling the DVS kernels (slow on a first run)")
        stack, times, n_fed, run = [], [], 0, True
        references = "reference" in config.outputs

        def with_references():  # (on read_ahead's thread: the only one rendering the scene meanwhile)
            for t, img in sampler:
                reference = references and t in ref_times
                yield t, img, (dvs_input.source.radiance(t) if log_in else img) if reference else None

        with closing(read_ahead(with_references(), 2 * chunk)) as samples:  # rendered while the DVS runs
            while True:
                t0 = clock.now()
                item = next(samples, None)
                clock.add("scene", t0)  # waiting for rendering and step control
                if item is None:
                    break
                t, img, reference = item
                if reference is not None:
                    write("add_reference", reference, t + origin)
                    counts["references"] += 1
                follows = bool(stack) and _follows(stack[-1], img)
                if stack and run and not follows and (len(stack) > 1 or img.base is not None):
                    feed(stack, times)  # a run of key frames, fed without a copy (_planes_in_a_row), ends here
                    n_fed += len(stack)
                    stack, times = [], []
                run = not stack or (run and follows)  # the stack's images lie one after the other in one array
                stack.append(img)
                times.append(t)
                if len(stack) == chunk:
                    feed(stack, times)
                    n_fed += len(stack)
                    bar.set_postfix_str(_rates(t, duration, n_fed, counts["events"], bar), refresh=False)
                    bar.update(t - bar.n)
                    stack, times = [], []
        if stack:
            feed(stack, times)
            n_fed += len(stack)
        bar.set_postfix_str(_rates(duration, duration, n_fed, counts["events"], bar), refresh=False)
        bar.update(duration - bar.n)
        bar.refresh()  # the final rates, however soon after the last update


def _follows(prev: np.ndarray, image: np.ndarray) -> bool:
    """Whether image is the plane right after prev in one array (consecutive key frames of a group)."""
    return (prev.base is not None and image.base is prev.base and image.shape == prev.shape
            and image.dtype == prev.dtype and prev.flags.c_contiguous and image.flags.c_contiguous
            and image.__array_interface__["data"][0] == prev.__array_interface__["data"][0] + prev.nbytes)


def _planes_in_a_row(images: list[np.ndarray]) -> np.ndarray | None:
    """images as one (n, H, W) array without a copy when they lie one after the other in one array (a group of key
    frames of a video, scenes.flow_interpolation: _follows) or when there is one, else None."""
    first = images[0]
    if not all(_follows(a, b) for a, b in zip(images, images[1:])):
        return None
    # (writeable as the planes are: a read-only array would be another type to numba, compiled again)
    return np.lib.stride_tricks.as_strided(first, (len(images), *first.shape), (first.nbytes, *first.strides))


def _run_camera(writer: NativeWriter, camera: sim.LDRCamera, src: _TimedSource, n_frames: int, origin: int,
                counts: dict, clock: _Clock, progress: bool) -> None:
    """The LDR camera's pass: every frame captured (exposure, noise, CRF) and written with its exposure window in
    the scene's time base; the camera's time excludes the scene rendering it asks for."""
    with tqdm(total=n_frames, unit="frame", desc="frames", disable=not progress, leave=False) as bar:
        bar.set_postfix_str("first frame: loading or compiling the camera kernels (slow on a first run)")
        frames = camera.capture(src, irradiance=False, clean_response=False)
        while True:
            t0, s0 = clock.now(), src.seconds
            frame = next(frames, None)
            clock.add("camera", t0, minus=(src.seconds[0] - s0[0], src.seconds[1] - s0[1]))
            if frame is None:
                break
            t0 = clock.now()
            writer.add_frame(frame.image, *(int(t) + origin for t in (frame.t_start_us, frame.t_mid_us,
                                                                     frame.t_end_us)))
            clock.add("writing", t0)
            counts["frames"] += 1
            if counts["frames"] == 1:
                bar.set_postfix_str("", refresh=False)
            bar.update(1)
