"""A video as a radiance source: a video file, a folder of images or a .npy stack, upsampled in time.

Inputs (open_frames):
- a video file OpenCV's VideoCapture reads (.mp4, .avi, .mov, .mkv, ...): 8-bit frames; times k / fps with the
  container's frame rate (or `fps`, or a timestamps file);
- a folder of images in name order, all of one kind and size: PNG/JPG/TIFF/BMP (8 or 16 bit, OpenCV), OpenEXR
  (.exr, the OpenEXR File API) or Radiance (.hdr/.pic, OpenCV); times from `timestamps` (default: the folder's
  timestamps.txt) or `fps`;
- a .npy stack (N, H, W) or (N, H, W, C), integer (LDR) or float (linear); times from `timestamps` or `fps`.
A timestamps file holds one time per input frame and line: integers are microseconds, decimal numbers seconds
(the vid2e convention); they must increase strictly.

- a hybrid recording's frames (an .aedat4 file or an IJRR folder, scenes.recording_frames): times are the
  mid-exposure times, each frame scaled to the first one's exposure time, input CRF the recorded one (a simulated
  recording's) or linear (a DAVIS's APS frames are linear in DN).

Frame rate: the times are those of the capture. A video's rate is, in this order: `fps` (the capture rate, as
given), `slowmo` x the container's rate (a slow-motion clip stored at a playback rate), the capture rate a phone
records in MP4/QuickTime metadata (scenes.capture_rate: Android's com.android.capture.fps), the container's rate.
InputTimingWarning (one line) says when the metadata contradicts a given rate, and when a clip taken at a container
rate of 60 fps or less moves implausibly little per frame (flow upsampling measures it: median largest motion
under 0.25 input pixels per frame), which is what a slow-motion clip looks like at its playback rate.

Each frame becomes linear luminance: integer (LDR) values minus black_level are normalised by the type's maximum
minus black_level and linearised through the inverse of `input_crf` (a crf_models curve, sRGB by default, linear
for a recording), float (HDR) values are taken as linear; colour becomes Rec. 709 luminance
Y = 0.2126 R + 0.7152 G + 0.0722 B (scenes.luminance) or one channel. When the sensor's aspect ratio differs from
the input's, `resize` says what happens: "crop" (default) fills the sensor with the largest centred window of the
input, "pad" shows the whole input centred with black (0) bars, "stretch" shows the whole input distorted. The
result is area-integrated to height x width (cv2.INTER_AREA), in linear radiance. Integer input is then
conditioned (scenes.conditioning, `conditioning`) in its code values, frame by frame in order: read noise and codec
artefacts on still pixels are held back from the DVS (default: on for video files and recordings' frames, off for
image folders and stacks, which are taken as clean unless conditioning is given). The clip runs from the first input
frame at or after start_s to the last at or before stop_s (seconds from the input's first frame); the scene's time 0
is that first frame, at time_origin_us in the input's own time base (a timestamps file's, a recording's), from which
generation writes its times. The DVS is warmed up on the clip's first warm_up_s mirrored in time (a recording's
frames: its camera was running before the clip began; no start-up burst).

Between input frames (`upsample`):
- "flow" (default): motion-compensated interpolation (scenes.flow_interpolation): bidirectional optical flow,
  occlusion by forward-backward consistency, both neighbours warped to the intermediate time and blended in log
  radiance;
- "linear": linear in time in log radiance, log(I + eps) (a cross-fade: moving edges fade instead of moving);
- "none": each input frame is held until the next (what feeding raw frames to a DVS model gives: every change at
  the frame times).
With "flow", the number of key frames between two input frames follows the pair's largest motion (one per
key_step_px pixels, at most max_keys); between keys, and between frames with "linear", the log radiance is linear
in time, which log_linear_until tells the adaptive sampler (generators.sampling), so that the DVS is fed exactly
the key frames (its own interpolation between samples is linear in log too).

Memory does not depend on the video's length: the scene decodes the input sequentially and holds three frames and
the flows of the last two intervals; radiance(t) is meant for increasing t. Going back further restarts the
decoding from the first frame (generate_ahdr does this once, between its DVS pass and its camera pass).
"""

from __future__ import annotations

import threading
import warnings
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from sim import EvsimInputError, EvsimNote, InvalidParameterError, OptionError
from sim.errors import check_int

from ..choices import UPSAMPLE_MODES
from ..formats.common import DatasetFormatError, fail, quiet_native_output
from .base import Scene, positive
from .capture_rate import capture_fps
from .conditioning import ConditioningParams, InputConditioner, condition_linear
from .flow_interpolation import FLOW_SCALE, MAX_KEYS, FlowEstimator, FlowPair, blend_logs, radiance_of_log
from .image_motion import _read_exr
from .luminance import REC709_WEIGHTS, to_luminance
from .recording_frames import RecordingFrames, is_recording, sha256_of

if TYPE_CHECKING:
    import sim

    from ..formats.recording import Recording

LDR_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
HDR_IMAGE_SUFFIXES = (".exr", ".hdr", ".pic")
TIMESTAMPS_FILE = "timestamps.txt"
WARM_UP_S = 0.5  # DVS warm-up of a recording's frames on the clip's start mirrored in time (s; generators.ahdr)
LOG_EPS_FRACTION = 1e-4  # log(I + eps) with eps = this fraction of the first frame's 99th percentile
RESIZE_POLICIES = ("crop", "pad", "stretch")
SLOW_MOTION_MAX_CONTAINER_FPS = 60.0  # a container rate at or below which tiny motion per frame suggests slow motion
SLOW_MOTION_MOTION_PX = 0.25  # median largest motion per frame pair (input pixels) below which the warning is given


class InputTimingWarning(EvsimNote):
    """The input's frame times look wrong (a slow-motion clip taken at its playback rate, or metadata that
    contradicts the given rate)."""


def read_timestamps(path: str | Path) -> tuple[np.ndarray, str]:
    """Times from a text file, one per line, as int64 microseconds, and the unit found: integers are
    microseconds, decimal numbers seconds. Raises DatasetFormatError when unreadable or not strictly increasing."""
    path = Path(path)
    try:
        tokens = path.read_text().split()
    except OSError as e:
        raise fail(path, f"cannot read the timestamps file: {e.strerror or e}") from None
    try:
        if all(t.lstrip("+-").isdigit() for t in tokens):
            times, unit = np.array([int(t) for t in tokens], dtype=np.int64), "us"
        else:
            times, unit = np.round(np.array([float(t) for t in tokens]) * 1e6).astype(np.int64), "s"
    except ValueError:
        raise fail(path, "expected one time per line: integer microseconds or decimal seconds") from None
    bad = np.flatnonzero(np.diff(times) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise DatasetFormatError(f"{path}: timestamps must increase strictly, but line {i + 1} ({tokens[i]}) "
                                 f"does not come after line {i} ({tokens[i - 1]})")
    return times, unit


class _Frames:
    """Sequential access to the raw frames of an input: times_us (int64, from the input's first frame), size,
    frames(first) yields the raw images (H, W) or (H, W, 3) RGB from index `first` on."""

    kind: str
    counted_to_end = True  # False when a video was counted only up to the stop time
    time_origin_us = 0  # the time of the first frame in the input's own time base (a timestamps file's), us
    exposures_us = None  # (N,) exposure time per frame (us) when the input records it
    path: Path
    times_us: np.ndarray
    size: tuple[int, int]
    sha256: str
    rate: dict

    def _set_times(self, n: int, fps: float | None, timestamps, default_ts: Path | None = None) -> None:
        ts = Path(timestamps) if timestamps is not None else default_ts
        if ts is not None and (timestamps is not None or ts.is_file()):
            times, unit = read_timestamps(ts)
            if times.size != n:
                raise fail(ts, f"{times.size} timestamps for {n} frames of {self.path}")
            self.rate = {"timestamps": str(ts), "unit": unit}
        elif fps is not None:
            times = np.round(np.arange(n) * 1e6 / positive("fps", fps, "video")).astype(np.int64)
            self.rate = {"fps": float(fps)}
        else:
            folder = f" (or put {TIMESTAMPS_FILE} in the folder)" if default_ts else ""
            raise OptionError(f"{self.path}: no frame times: give fps or timestamps (a file of frame times){folder}",
                              f"{self.path}: no frame times: give --input-fps or --timestamps (a file of frame "
                              f"times){folder}")
        self.times_us = times - times[0]
        self.time_origin_us = int(times[0])

    def frames(self, first: int = 0):
        raise NotImplementedError


class _VideoFile(_Frames):
    kind = "video"

    def __init__(self, path: Path, fps: float | None, timestamps, stop_us: int | None, slowmo: float | None = None):
        self.path = path
        cap = self._open()
        container_fps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
        container_fps = container_fps if np.isfinite(container_fps) and container_fps > 0 else None
        self.size = (int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)), int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)))
        self.capture = capture_fps(path)
        use_fps, source = self._capture_rate(fps, timestamps, slowmo, container_fps)
        if timestamps is None and use_fps is None:
            cap.release()
            why = f"{path}: the container gives no frame rate: pass"
            raise OptionError(f"{why} fps or timestamps (a file of frame times)",
                              f"{why} --input-fps or --timestamps (a file of frame times)")
        # Count the frames by decoding (the container's count can be wrong), up to the stop time when known.
        last = None if stop_us is None or use_fps is None else int(np.floor(stop_us * use_fps / 1e6 + 1e-6))
        n = 0
        while (last is None or n <= last) and cap.grab():
            n += 1
        self.counted_to_end = last is None or n <= last
        cap.release()
        if n == 0:
            raise fail(path, "the video holds no frames (empty or unreadable)")
        self._set_times(n, use_fps, timestamps)
        if timestamps is None:
            self.rate = {"fps": use_fps, "from": source}
        if container_fps is not None:
            self.rate["container_fps"] = container_fps
        if self.capture is not None:
            self.rate["capture_fps_metadata"] = {"fps": self.capture[0], "key": self.capture[1]}
        self.sha256 = sha256_of([path])

    def _capture_rate(self, fps, timestamps, slowmo, container_fps) -> tuple[float | None, str]:
        """The rate the frames were captured at and where it comes from (module docstring, Frame rate); warns
        when the metadata's capture rate contradicts a given rate."""
        if slowmo is not None:
            if fps is not None or timestamps is not None:
                raise OptionError(f"{self.path}: slowmo cannot be combined with fps or timestamps: give the capture "
                                  "rate one way", f"{self.path}: --slowmo cannot be combined with --input-fps or "
                                  "--timestamps: give the capture rate one way")
            if container_fps is None:
                why = f"{self.path}: the container gives no frame rate for slowmo to multiply: pass the capture rate as"
                raise OptionError(f"{why} fps", f"{why} --input-fps")
            use, source = container_fps * positive("slowmo", slowmo, "video"), f"container rate x slowmo {slowmo:g}"
        elif fps is not None:
            use, source = float(fps), "fps"
        elif timestamps is not None:
            return None, "timestamps"
        elif self.capture is not None and self.capture[0] > 0:
            return float(self.capture[0]), f"capture-rate metadata ({self.capture[1]})"
        else:
            return container_fps, "container"
        if self.capture is not None and abs(use / self.capture[0] - 1) > 0.02:
            warnings.warn(f"{self.path.name}: its metadata says captured at {self.capture[0]:g} fps "
                          f"({self.capture[1]}), but {use:g} fps is used as given", InputTimingWarning, stacklevel=2)
        return use, source

    def _open(self):
        with quiet_native_output():  # FFmpeg's own complaints ("moov atom not found"): evsim's line says it
            cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            raise fail(self.path, "cannot open as a video (OpenCV VideoCapture: unknown container or codec, or "
                                  "not a video)")
        return cap

    def frames(self, first: int = 0):
        cap = self._open()
        try:
            for _ in range(first):
                if not cap.grab():
                    raise fail(self.path, f"the video ended before frame {first}")
            for k in range(first, self.times_us.size):
                ok, bgr = cap.read()
                if not ok:
                    raise fail(self.path, f"cannot decode frame {k}")
                yield bgr[..., ::-1] if bgr.ndim == 3 else bgr
        finally:
            cap.release()


def _image_size(path: Path) -> tuple[int, int]:
    """(height, width) of an image file from its header where possible."""
    suffix = path.suffix.lower()
    if suffix == ".exr":
        import OpenEXR

        try:
            (x0, y0), (x1, y1) = OpenEXR.File(str(path), header_only=True).header()["dataWindow"]
        except Exception as e:  # the OpenEXR binding raises plain exceptions for unreadable files
            raise fail(path, f"cannot read OpenEXR header: {e}") from None
        return int(y1 - y0 + 1), int(x1 - x0 + 1)
    if suffix in LDR_IMAGE_SUFFIXES:
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(path) as im:
                return im.size[1], im.size[0]
        except (OSError, UnidentifiedImageError) as e:
            raise fail(path, f"cannot read image header: {e}") from None
    return _read_image(path).shape[:2]


def _read_image(path: Path) -> np.ndarray:
    if path.suffix.lower() == ".exr":
        try:
            return _read_exr(path)
        except EvsimInputError as e:
            raise fail(path, str(e)) from None
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise fail(path, "cannot read the image (OpenCV)")
    if img.ndim == 3:
        img = img[..., :3][..., ::-1]
    return img


class _ImageFolder(_Frames):
    kind = "folder"

    def __init__(self, folder: Path, fps: float | None, timestamps):
        self.path = folder
        suffixes = LDR_IMAGE_SUFFIXES + HDR_IMAGE_SUFFIXES
        self.paths = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in suffixes)
        if not self.paths:
            raise fail(folder, f"no images ({', '.join(suffixes)}) in the folder")
        kinds = {p.suffix.lower().replace(".jpeg", ".jpg").replace(".tiff", ".tif") for p in self.paths}
        if len(kinds) > 1:
            raise fail(folder, f"the folder mixes image formats ({', '.join(sorted(kinds))}): one kind per clip")
        sizes = {}
        for p in self.paths:
            sizes.setdefault(_image_size(p), p)
        if len(sizes) > 1:
            (s0, p0), (s1, p1) = list(sizes.items())[:2]
            raise fail(folder, f"the images have different sizes: {p0.name} is {s0[1]}x{s0[0]}, "
                               f"{p1.name} is {s1[1]}x{s1[0]}")
        self.size = next(iter(sizes))
        self._set_times(len(self.paths), fps, timestamps, folder / TIMESTAMPS_FILE)
        ts = [Path(self.rate["timestamps"])] if "timestamps" in self.rate else []
        self.sha256 = sha256_of(self.paths + ts)

    def frames(self, first: int = 0):
        for p in self.paths[first:]:
            img = _read_image(p)
            if img.shape[:2] != self.size:
                raise fail(p, f"size {img.shape[1]}x{img.shape[0]} differs from the folder's "
                              f"{self.size[1]}x{self.size[0]}")
            yield img


class _NpyStack(_Frames):
    kind = "npy"

    def __init__(self, path: Path, fps: float | None, timestamps):
        self.path = path
        self._stack = s = self._load(path)
        self.size = tuple(s.shape[1:3])
        self._set_times(s.shape[0], fps, timestamps)
        self.sha256 = sha256_of([path])

    @staticmethod
    def _load(path: Path) -> np.ndarray:
        """The stack, memory-mapped (read frame by frame), checked."""
        try:
            s = np.load(path, mmap_mode="r", allow_pickle=False)
        except (OSError, ValueError) as e:
            raise fail(path, f"not a readable .npy array: {e}") from None
        if s.ndim not in (3, 4) or s.shape[0] == 0 or (s.ndim == 4 and s.shape[3] not in (1, 3, 4)):
            raise fail(path, f"expected a stack (N, H, W) or (N, H, W, C) of N >= 1 frames, got shape {s.shape}")
        if not (np.issubdtype(s.dtype, np.integer) or np.issubdtype(s.dtype, np.floating)):
            raise fail(path, f"expected integer (LDR) or float (linear) frames, got {s.dtype}")
        return s

    @classmethod
    def shape(cls, path: Path) -> tuple[int, ...]:
        return cls._load(path).shape

    def frames(self, first: int = 0):
        for k in range(first, self._stack.shape[0]):
            yield np.asarray(self._stack[k])


def open_frames(path: str | Path, *, fps: float | None = None, timestamps: str | Path | None = None,
                stop_us: int | None = None, slowmo: float | None = None, recording: Recording | None = None
                ) -> _Frames:
    """The frame source for a video file, an image folder, a .npy stack or a recording's frames (module docstring).

    Parameters
    ----------
    path : str or Path
        The input.
    fps : float, optional
        The rate its frames were captured at (frames per second; image folders and stacks need it or timestamps).
    timestamps : str or Path, optional
        A file of frame times, one per line (integer microseconds or decimal seconds).
    stop_us : int, optional
        A video is counted only up to here (microseconds from its first frame).
    slowmo : float, optional
        Video files only: the capture rate is this times the container's.
    recording : Recording, optional
        The recording at `path`, already loaded by the caller (read again otherwise).

    Returns
    -------
    frame source
        Sequential access to the frames: times_us, size, rate, frames(first).
    """
    path = Path(path)
    if not path.exists():
        raise fail(path, "no such file or folder")
    if recording is not None or is_recording(path):
        return RecordingFrames(path, recording)
    if slowmo is not None and (path.is_dir() or path.suffix.lower() == ".npy"):
        raise EvsimInputError(f"{path}: slowmo applies to video files; give an image folder or a stack its capture "
                              "rate as fps or a timestamps file")
    if path.is_dir():
        return _ImageFolder(path, fps, timestamps)
    if path.suffix.lower() == ".npy":
        return _NpyStack(path, fps, timestamps)
    return _VideoFile(path, fps, timestamps, stop_us, slowmo)


def _conditioning_for(option: ConditioningParams | dict | str | None, kind: str) -> ConditioningParams:
    """The conditioning of an input kind: by default temporal with key frames for video files, temporal for a
    recording's frames (a real camera's read noise) and off for image folders and stacks (taken as clean); a mode
    or table without key_frames gets key frames for video files only (a camera's frames have no codec)."""
    if option is None:
        option = "temporal" if kind in ("video", "recording") else "off"
    if isinstance(option, str):
        option = {"mode": option}
    if isinstance(option, dict) and "key_frames" not in option:
        option = {**option, "key_frames": kind == "video"}
    return ConditioningParams.from_option(option)


def input_size(path: str | Path) -> tuple[int, int]:
    """The size of an input's frames, read cheaply (no decoding of a whole video; a recording is read whole).

    Parameters
    ----------
    path : str or Path
        A video file, image folder, .npy stack or recording.

    Returns
    -------
    height, width : int
        Pixels.
    """
    path = Path(path)
    if not path.exists():
        raise fail(path, "no such file or folder")
    if is_recording(path):
        return RecordingFrames(path).size
    if path.is_dir():
        frames = sorted(p for p in path.iterdir() if p.suffix.lower() in LDR_IMAGE_SUFFIXES + HDR_IMAGE_SUFFIXES)
        if not frames:
            raise fail(path, "no images in the folder")
        return _image_size(frames[0])
    if path.suffix.lower() == ".npy":
        return _NpyStack.shape(path)[1:3]
    with quiet_native_output():
        cap = cv2.VideoCapture(str(path))
    try:
        opened = cap.isOpened()
        size = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)), int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
    finally:
        cap.release()
    if not opened or min(size) <= 0:
        raise fail(path, "cannot open as a video (OpenCV VideoCapture: unknown container or codec, or not a video)")
    return size


class VideoScene(Scene):
    """Radiance from a video file, image folder or .npy stack (module docstring), upsampled in time.

    height, width: sensor size in pixels (default: the input's; one of them alone keeps the aspect ratio).
    fps: the input's capture rate (frames per second; overrides a video's); slowmo: a video captured this many
        times faster than its container's rate; timestamps: a timestamps file (module docstring, Frame rate).
    start_s, stop_s: the part of the input to use, in seconds from its first frame.
    upsample: "flow" | "linear" | "none"; flow: "dis" | "farneback"; flow_preset: DIS preset (ultrafast, fast,
        medium); flow_scale: the flow is computed on the frames resized by this factor (0 < flow_scale <= 1) and
        resized back; key_step_px: largest motion between motion-compensated key frames (pixels;
        flow_interpolation); max_keys: at most this many key intervals per frame pair (faster motion spaces the
        keys further apart than key_step_px).
    input_crf, input_crf_params: the crf_models curve whose inverse linearises LDR (integer) input.
    channel: None for Rec. 709 luminance, or "R" / "G" / "B" / an index.
    resize: "crop" | "pad" | "stretch" (module docstring). conditioning: None (by input kind), "temporal", "off", a
        table of scenes.conditioning.ConditioningParams fields or an instance; a table without key_frames detects
        key frames in video files only.
    log_eps: the offset of log(I + eps) used for interpolation (radiance units; default 1e-4 x the first frame's
        99th percentile).
    black_level: the integer input's value for no light (subtracted before linearising: the normalised value is
        (raw - black_level) / (max - black_level), clipped to [0, 1]).
    warm_up_s: the DVS is warmed up on this much of the clip's start mirrored in time (the camera was running
        before the first frame; generators.dvs_input.warm_up_input), at most the clip's length; default WARM_UP_S
        for a recording's frames, 0 for other inputs.
    recording: the generators.formats Recording at `path` when the caller has loaded it already (it is not read
        again).
    Frames whose exposure times the input records (a recording) are scaled to the first frame's exposure. The
    scene's time_origin_us is the time of its t = 0 in the input's own time base (a timestamps file's first time,
    a recording's first mid-exposure): generation writes its times from there.
    """

    # frames are checked as they are decoded (to_luminance; an exposure ratio of recorded frames, integer codes, keeps
    # them far below float32's limit) and the blends' exp is clamped: radiance() need not check each render
    renders_finite = True

    def __init__(self, path: str | Path, *, height: int | None = None, width: int | None = None,
                 fps: float | None = None, timestamps: str | Path | None = None, start_s: float = 0.0,
                 stop_s: float | None = None, upsample: str = "flow", flow: str = "dis", flow_preset: str = "medium",
                 flow_scale: float = FLOW_SCALE, key_step_px: float = 0.5, max_keys: int = MAX_KEYS,
                 input_crf: str | None = None, input_crf_params: dict | None = None,
                 channel: str | int | None = None, log_eps: float | None = None, slowmo: float | None = None,
                 resize: str = "crop", conditioning: ConditioningParams | dict | str | None = None,
                 black_level: float = 0.0, warm_up_s: float | None = None, recording: Recording | None = None):
        if upsample not in UPSAMPLE_MODES:
            raise InvalidParameterError(f"upsample must be one of {', '.join(UPSAMPLE_MODES)}, got {upsample!r}")
        if resize not in RESIZE_POLICIES:
            raise InvalidParameterError(f"resize must be one of {', '.join(RESIZE_POLICIES)}, got {resize!r}")
        self.resize = resize
        start_us = int(round(positive("start_s", start_s, "VideoScene", allow_zero=True) * 1e6))
        stop_us = None if stop_s is None else int(round(positive("stop_s", stop_s, "VideoScene") * 1e6))
        if stop_us is not None and stop_us <= start_us:
            raise InvalidParameterError(f"VideoScene: start_s={start_s} must come before stop_s={stop_s}")
        self._input = open_frames(path, fps=fps, timestamps=timestamps, stop_us=stop_us, slowmo=slowmo,
                                  recording=recording)
        self.path = Path(path)
        self._conditioner = InputConditioner(_conditioning_for(conditioning, self._input.kind))
        t = self._input.times_us
        keep = np.flatnonzero((t >= start_us) & (t <= (t[-1] if stop_us is None else stop_us)))
        if keep.size < 2:
            raise EvsimInputError(f"{path}: {keep.size} input frame(s) between start_s={start_s} and "
                                  f"stop_s={stop_s} (the input has {t.size} frames over {t[-1] / 1e6:g} s); "
                                  "need at least 2")
        self._first = int(keep[0])
        self.times = t[keep] - t[keep[0]]
        self.start_s, self.stop_s = start_s, stop_s
        self.upsample, self.channel = upsample, channel
        self.key_step_px = positive("key_step_px", key_step_px, "VideoScene")
        self.max_keys = check_int("VideoScene: max_keys", max_keys, minimum=1)
        if input_crf is None and self._input.kind == "recording":  # its recorded CRF, else linear (DAVIS APS)
            self.input_crf = {"name": self._input.crf["name"],
                              "params": dict(input_crf_params or self._input.crf.get("params", {}))}
        else:
            self.input_crf = {"name": input_crf or "srgb", "params": dict(input_crf_params or {})}
        self.black_level = positive("black_level", black_level, "VideoScene", allow_zero=True)
        # the clip was running before its first frame: the DVS is warmed up on its start mirrored (generators.ahdr)
        if warm_up_s is None:
            warm_up_s = WARM_UP_S if self._input.kind == "recording" else 0.0
        self.warm_up_us = min(int(round(positive("warm_up_s", warm_up_s, "VideoScene", allow_zero=True) * 1e6)),
                              int(self.times[-1]))
        # the scene's time 0 in the input's own time base (a timestamps file's, a recording's)
        self.time_origin_us = int(self._input.time_origin_us + t[keep[0]])
        exposures = self._input.exposures_us
        self._exposure_gain = None
        if exposures is not None and np.all(exposures[keep] > 0):  # radiance in units of the first frame's exposure
            self._exposure_gain = (exposures[keep[0]] / exposures[keep]).astype(np.float32)
        h0, w0 = self._input.size
        if height is None and width is None:
            height, width = h0, w0
        elif height is None:
            height = max(1, round(width * h0 / w0))
        elif width is None:
            width = max(1, round(height * w0 / h0))
        self._init_size(height, width, int(self.times[-1]))
        self._crop = self._crop_box(h0, w0) if resize == "crop" else (0, h0, 0, w0)
        self._place = self._pad_box(h0, w0) if resize == "pad" else (0, self.height, 0, self.width)
        self._timing_checked = False
        self._luts: dict = {}
        self._is_ldr = None
        first = self._luminance(next(iter(self._input.frames(self._first))), 0)
        self.log_eps = (positive("log_eps", log_eps, "VideoScene") if log_eps is not None
                        else max(float(np.percentile(first, 99)), 1e-30) * LOG_EPS_FRACTION)
        self._flow = None
        if upsample == "flow":
            low, high = np.percentile(np.log(first + np.float32(self.log_eps)), [0.5, 99.5])
            pad = 0.25 * (high - low) + 0.5  # room for brightness changes later in the clip
            self._flow = FlowEstimator((float(low - pad), float(high + pad)), flow, flow_preset, flow_scale)
        self._window: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._pairs: dict[int, FlowPair] = {}
        self._pair_motion = np.full(self.times.size - 1, np.nan)  # largest displacement per interval (px)
        self._lock = threading.RLock()  # the decoding and the pairs: the caller's thread and the look-ahead's
        self._generation = 0  # passes over the clip (restarts)
        self._worker: ThreadPoolExecutor | None = None
        self._ahead: Future | None = None  # the look-ahead's pair
        self._restart()

    @property
    def input_bit_depth(self) -> int:
        """The input frames' bit depth: a recording's recorded one, else 8 (videos; images are linearised by their
        own depth)."""
        return int(getattr(self._input, "bit_depth", 8))

    # ----- geometry and linearisation ------------------------------------------------------------------
    def _crop_box(self, h0: int, w0: int) -> tuple[int, int, int, int]:
        """(y0, y1, x0, x1): the largest centred window of the input with the sensor's aspect ratio."""
        if w0 * self.height > h0 * self.width:  # the input is wider: crop the sides
            cw = max(1, min(w0, round(h0 * self.width / self.height)))
            x0 = (w0 - cw) // 2
            return 0, h0, x0, x0 + cw
        ch = max(1, min(h0, round(w0 * self.height / self.width)))
        y0 = (h0 - ch) // 2
        return y0, y0 + ch, 0, w0

    def _pad_box(self, h0: int, w0: int) -> tuple[int, int, int, int]:
        """(y0, y1, x0, x1): where the whole input lands on the sensor when its aspect ratio is kept (centred)."""
        if w0 * self.height > h0 * self.width:  # the input is wider: bars above and below
            ih = max(1, min(self.height, round(self.width * h0 / w0)))
            y0 = (self.height - ih) // 2
            return y0, y0 + ih, 0, self.width
        iw = max(1, min(self.width, round(self.height * w0 / h0)))
        x0 = (self.width - iw) // 2
        return 0, self.height, x0, x0 + iw

    def _linear(self, raw: np.ndarray) -> np.ndarray:
        """Linear radiance of a raw frame (any channels): the inverse CRF of integer values, floats as they are."""
        is_ldr = np.issubdtype(raw.dtype, np.integer)
        if self._is_ldr is None:
            self._is_ldr = is_ldr
        if not is_ldr:
            return raw.astype(np.float32, copy=False)
        if raw.dtype not in self._luts:
            if raw.dtype.itemsize > 2:
                raise DatasetFormatError(f"{self.path}: integer frames of {raw.dtype} are not supported (8 or 16 bit)")
            import crf_models

            try:
                crf = crf_models.get(self.input_crf["name"], **self.input_crf["params"])
            except crf_models.CRFError as e:
                raise InvalidParameterError(f"input_crf: {e}") from None
            top = np.iinfo(raw.dtype).max
            if not self.black_level < top:
                raise InvalidParameterError(f"black_level {self.black_level} must lie below the frames' maximum "
                                            f"value {top}")
            codes = np.arange(np.iinfo(raw.dtype).min, top + 1, dtype=np.float64)
            levels = np.clip((codes - self.black_level) / (top - self.black_level), 0.0, 1.0)
            self._luts[raw.dtype] = np.asarray(crf.inverse(levels), dtype=np.float32)
        lut = self._luts[raw.dtype]
        return lut[raw.astype(np.int64) - np.iinfo(raw.dtype).min] if raw.dtype.kind == "i" else lut[raw]

    def _luminance(self, raw: np.ndarray, index: int) -> np.ndarray:
        """Linear luminance (float32) of a raw frame at the sensor size (clip frame `index`, for messages)."""
        try:
            y = to_luminance(self._linear(raw), self.channel)
        except EvsimInputError as e:
            raise DatasetFormatError(f"{self.path}: frame {self._first + index}: {e}") from None
        if self._exposure_gain is not None:
            y = y * self._exposure_gain[index]
        y0, y1, x0, x1 = self._crop
        y = np.ascontiguousarray(y[y0:y1, x0:x1])
        p0, p1, q0, q1 = self._place
        if y.shape != (p1 - p0, q1 - q0):
            y = cv2.resize(y, (q1 - q0, p1 - p0), interpolation=cv2.INTER_AREA)
        if y.shape != (self.height, self.width):  # pad: black bars around the whole input
            out = np.zeros((self.height, self.width), np.float32)
            out[p0:p1, q0:q1] = y
            y = out
        return y

    def _process(self, raw: np.ndarray, index: int, conditioner: InputConditioner) -> tuple[np.ndarray, np.ndarray]:
        """(linear luminance, log(luminance + log_eps)) of a raw frame at the sensor size, conditioned
        (scenes.conditioning) in the input's code values when the input is integer (LDR)."""
        y = self._luminance(raw, index)
        if self._is_ldr and conditioner.params.mode != "off":
            y = condition_linear(conditioner, y, self._luts[raw.dtype])
        return y, np.log(y + np.float32(self.log_eps))

    # ----- the sliding window --------------------------------------------------------------------------
    def _restart(self) -> None:
        """Decode from the first frame of the clip again (forgetting the window)."""
        with self._lock:
            self._generation += 1  # a pending look-ahead of the old pass does nothing
            self._window.clear()
            self._pairs.clear()
            self._conditioner.reset()
            self._raw = iter(self._input.frames(self._first))
            self._next = 0

    def _frame(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """(linear, log) of clip frame i; keeps the last three decoded frames."""
        got = self._window.get(i)  # (a dict look-up is atomic: no lock while the look-ahead decodes)
        if got is not None:
            return got
        with self._lock:
            if i in self._window:
                return self._window[i]
            if i < self._next:  # behind the window: decode again from the start of the clip
                self._restart()
            while self._next <= i:
                raw = next(self._raw, None)
                if raw is None:
                    raise fail(self.path, f"the input ended before frame {self._first + self._next}")
                try:
                    self._window[self._next] = self._process(raw, self._next, self._conditioner)
                except BaseException:
                    # the stream is past a frame it could not use: the next request decodes from the start again
                    # (and fails at this frame again), so that no later frame takes its place
                    self._restart()
                    raise
                self._next += 1
                while len(self._window) > 3:
                    self._window.pop(min(self._window))
            return self._window[i]

    def _pair(self, k: int) -> FlowPair:
        """The flows of interval k (frames k, k + 1); keeps the last two intervals. The next interval's frame is
        decoded and its flows computed on a thread of their own meanwhile (the look-ahead: both cores stay busy
        while the caller feeds the DVS)."""
        pair = self._pairs.get(k)
        if pair is None:
            pair = self._make_pair(k)
        if k + 2 < self.times.size and k + 1 not in self._pairs and (self._ahead is None or self._ahead.done()):
            if self._worker is None:
                self._worker = ThreadPoolExecutor(1, thread_name_prefix="evsim-video")
            self._ahead = self._worker.submit(self._make_pair, k + 1, self._generation)
        return pair

    def _make_pair(self, k: int, generation: int | None = None) -> FlowPair | None:
        """Pair k made (or found) under the lock, ready for synthesis; None for a look-ahead (generation: the pass
        it was asked in) of a past pass."""
        with self._lock:
            if generation is not None and generation != self._generation:
                return None
            if k not in self._pairs:
                log1 = self._frame(k + 1)[1]
                log0 = self._frame(k)[1]
                prev = self._pairs.get(k - 1)  # its frame 1, upsampled, is this pair's frame 0
                up0 = prev.upsampled1 if prev is not None and prev.log1 is log0 else None
                pair = self._flow.pair(log0, log1, key_step_px=self.key_step_px, max_keys=self.max_keys,
                                       upsampled0=up0, lowest=np.log(np.float32(self.log_eps)))
                pair.prepare()
                self._pairs[k] = pair
                self._pair_motion[k] = pair.max_motion_px
                while len(self._pairs) > 2:  # the farthest from k (a step back must not drop pair k itself)
                    self._pairs.pop(max(self._pairs, key=lambda j: abs(j - k)))
            return self._pairs[k]

    # ----- the radiance source -------------------------------------------------------------------------
    def _interval(self, t_us: int) -> tuple[int, float]:
        """The input frame interval k holding t_us (frames k, k + 1; the last one at the end) and t_us's place in it,
        a in [0, 1]."""
        k = min(int(np.searchsorted(self.times, t_us, side="right")) - 1, self.times.size - 2)
        return k, (t_us - self.times[k]) / (self.times[k + 1] - self.times[k])

    def _render(self, t_us):
        k, a = self._interval(t_us)
        if a >= 1:
            return self._frame(k + 1)[0]
        if a == 0 or self.upsample == "none":
            return self._frame(k)[0]
        if self.upsample == "flow":
            return self._pair(k).radiance_at(a, self.log_eps)
        return radiance_of_log(self._frame(k)[1], self.log_eps, self._frame(k + 1)[1], a)

    def has_log_at(self, offset: float) -> bool:
        """Whether offset_log(t_us, offset) is the interpolation's own log: offset within 1e-6 of log_eps, relative
        (the DVS's dark level, from the same frame's 99th percentile, can differ from it by a float32 rounding; the
        logs then differ by at most 1e-6, at black, against DVS thresholds of about 0.2).

        Parameters
        ----------
        offset : float
            Radiance units.

        Returns
        -------
        bool
            True when offset_log at this offset needs no exp and no log.
        """
        return abs(float(offset) - self.log_eps) <= 1e-6 * self.log_eps

    def offset_log(self, t_us: int, offset: float) -> np.ndarray:
        """log(radiance(t_us) + offset) as float32: at an offset has_log_at accepts, the interpolation's own log
        (the key frames' blend: no exp here and no log in a DVS fed it, DVSEmulator.feed_log), else computed from
        the radiance.

        Parameters
        ----------
        t_us : int
            Scene time (us), in [0, duration_us].
        offset : float
            Added to the radiance before the log (radiance units), > 0.

        Returns
        -------
        numpy.ndarray
            float32 (height, width) natural log (read-only: it may be a key frame the scene keeps).
        """
        if not self.has_log_at(offset):
            return np.log(self.radiance(t_us) + np.float32(offset))
        self._check_time(t_us)
        k, a = self._interval(t_us)
        if a >= 1 or a == 0 or self.upsample == "none":
            kept = self._frame(k + 1 if a >= 1 else k)[1]
        elif self.upsample == "flow":
            kept = self._pair(k).log_at(a)
        else:
            return blend_logs(self._frame(k)[1], self._frame(k + 1)[1], np.float32(a))
        view = kept.view()
        view.flags.writeable = False
        return view

    def log_linear_until(self, t_us: int) -> int:
        """The end of the piece from t_us over which log(radiance + log_eps) is linear in time: the next key frame
        (flow), the next input frame (linear), or, holding frames (none), one microsecond before the next input
        frame and then that frame (a switch within a microsecond). Used by the adaptive sampler.

        Parameters
        ----------
        t_us : int
            Scene time, microseconds.

        Returns
        -------
        int
            The piece's end, microseconds (at most the duration).
        """
        t_us = int(t_us)
        if t_us >= self.duration_us:
            return self.duration_us
        k = self._interval(t_us)[0]
        t0, t1 = int(self.times[k]), int(self.times[k + 1])
        if self.upsample == "none":
            return t1 - 1 if t_us < t1 - 1 else t1
        if self.upsample == "linear":
            return t1
        keys = self._pair(k).n_keys
        j = int((t_us - t0) * keys // (t1 - t0)) + 1  # the first key after t_us
        return min(t0 + -(-(j * (t1 - t0)) // keys), t1)  # rounded up to the microsecond

    @property
    def capture_fps(self) -> float:
        """The rate the clip's frames were captured at (frames per second): the rate used (module docstring,
        Frame rate), or with a timestamps file the frames used over their time span."""
        rate = self._input.rate.get("fps")
        return float(rate) if rate is not None else float((self.times.size - 1) * 1e6 / self.times[-1])

    def max_speed_px_per_s(self) -> float:
        """The largest image speed of the clip: with flow upsampling the largest optical-flow speed (intervals not
        yet decoded are scanned first, so asking before the first pass costs one pass of flow); otherwise one pixel
        per shortest input interval.

        Returns
        -------
        float
            Pixels per second.
        """
        intervals = np.diff(self.times).astype(np.float64)
        if self.upsample != "flow":
            return 1e6 / float(intervals.min())
        if np.isnan(self._pair_motion).any():
            self._scan_motion()
        self._check_timing()
        return float(np.max(self._pair_motion * 1e6 / intervals))

    def _check_timing(self) -> None:
        """Warn (InputTimingWarning, once) when a video taken at its container's low rate moves implausibly
        little per frame: the median over frame pairs of the largest motion, in input pixels, below
        SLOW_MOTION_MOTION_PX, over at least 16 pairs with some motion somewhere, looks like slow motion."""
        rate = self._input.rate
        if self._timing_checked or rate.get("from") != "container" or self.times.size < 17:
            return
        self._timing_checked = True
        scale = max(self._input.size[1] / self.width, self._input.size[0] / self.height)
        motion = self._pair_motion * scale
        if (rate["fps"] <= SLOW_MOTION_MAX_CONTAINER_FPS and np.median(motion) < SLOW_MOTION_MOTION_PX
                and np.max(motion) * (self.times.size - 1) > 4 * SLOW_MOTION_MOTION_PX):
            said = (f"{self.path.name}: at its container rate of {rate['fps']:g} fps it moves only "
                    f"{np.median(motion):.2f} px per frame (median): if it is a slow-motion clip, give")
            warnings.warn(InputTimingWarning(f"{said} slowmo=FACTOR or fps (the capture rate)",
                                             f"{said} --slowmo FACTOR or --input-fps"), stacklevel=3)

    def _scan_motion(self) -> None:
        """Fill _pair_motion for the intervals not yet seen, with a separate decoder (the window is untouched)."""
        prev = None
        conditioner = InputConditioner(self._conditioner.params)
        for i, raw in enumerate(self._input.frames(self._first)):
            if i >= self.times.size:
                break
            cur = self._process(raw, i, conditioner)[1]
            if prev is not None and np.isnan(self._pair_motion[i - 1]):
                self._pair_motion[i - 1] = self._flow.pair(prev, cur).max_motion_px
            prev = cur

    def generation_notes(self, camera: sim.CameraParams, outputs: tuple[str, ...]) -> list[str]:
        """What a user converting this clip should know, before the work (generators.dataset says them as notes):
        a sensor larger than the input (upscaled) and LDR frames at another rate than the input's.

        Parameters
        ----------
        camera : sim.CameraParams
            The LDR camera of the generation.
        outputs : tuple of str
            What the generation writes (generators.choices.OUTPUTS).

        Returns
        -------
        list of str
            The notes (in command-line flags), [] when there is nothing to say.
        """
        notes = []
        h0, w0 = self._input.size
        y0, y1, x0, x1 = self._crop
        if self.height > y1 - y0 or self.width > x1 - x0:
            notes.append(f"{self.path.name}: its {w0}x{h0} frames are upscaled to the {self.width}x{self.height} "
                         "sensor (--height/--width/--sensor-size): neighbouring pixels see interpolated radiance, so "
                         "their events are more alike than a real sensor's")
        rate = self.capture_fps
        if "frames" in outputs and camera.frame_times_us is None and abs(camera.fps - rate) > 0.01 * rate:
            exposure = camera.exposure_us if isinstance(camera.exposure_us, int) else list(camera.exposure_us)
            notes.append(f"{self.path.name}: the input is {rate:.4g} fps; the LDR camera writes {camera.fps:.4g} fps "
                         f"with {exposure} us exposures (--camera-fps and --exposure-us, or a sensor file's "
                         "[camera], set them)")
        return notes

    def _params(self):
        inp = self._input
        lin = (f"inverse {self.input_crf['name']} CRF of the integer values normalised to [0, 1]"
               if self._is_ldr else "none (float input taken as linear radiance)")
        up = {"mode": self.upsample}
        if self.upsample == "flow":
            up.update(self._flow.describe(), occlusion="forward-backward consistency", blend="log radiance",
                      key_step_px=self.key_step_px, max_keys=self.max_keys)
            note = self._flow.flow_note((self.height, self.width))
            if note:
                up["note"] = note
        elif self.upsample == "linear":
            up["blend"] = "linear in time in log(I + log_eps)"
        return {
            "time_origin_us": self.time_origin_us, "black_level": self.black_level, "warm_up_us": self.warm_up_us,
            "exposure_normalised": self._exposure_gain is not None,
            "input": {"path": str(self.path), "kind": inp.kind, "sha256": inp.sha256, "size": list(inp.size),
                      ("n_frames" if inp.counted_to_end else "n_frames_read"): int(inp.times_us.size), **inp.rate},
            "frames_used": [self._first, self._first + int(self.times.size) - 1],
            "start_s": self.start_s, "stop_s": self.stop_s,
            "linearisation": {"method": lin, **({"crf": self.input_crf} if self._is_ldr else {})},
            "luminance": ("Rec. 709: Y = {:.4f} R + {:.4f} G + {:.4f} B".format(*REC709_WEIGHTS) if self.channel is None
                          else f"channel {self.channel}"),
            "capture_fps": self.capture_fps,
            "crop": list(self._crop),
            "resize": {"policy": self.resize, "placement": list(self._place),
                       "method": "cv2.INTER_AREA (area integration in linear radiance)"
                                 + (", black (0) bars around the input" if self.resize == "pad" else "")},
            "conditioning": (self._conditioner.describe() if self._is_ldr else
                             {"mode": "off", "why": "float input is taken as clean linear radiance"}),
            "upsample": up, "log_eps": self.log_eps,
        }
