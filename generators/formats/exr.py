"""OpenEXR reference frames (linear HDR radiance) through the OpenEXR package's File API.

One image: a single "Y" channel, float32 or half (float16), ZIP-compressed. A sequence is a folder of
frame_000000.exr, frame_000001.exr, ... with a sidecar `timestamps.txt` of lines "t_us file_name" (int64
microseconds): EXR header attributes are 32-bit, so microsecond times are never stored there.
Half floats keep about 3 significant digits (relative error <= 2**-11) and saturate at 65504.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sim import EVENT_DTYPE, EvsimInputError

from .atomic import atomic_path
from .common import fail, quiet_native_output
from .recording import MAX_TIME_US, Recording, missing_part_error

TIMES_FILE = "timestamps.txt"

if TYPE_CHECKING:
    import OpenEXR


def _exr_file(image: np.ndarray, half: bool) -> OpenEXR.File:
    image = np.asarray(image)
    if image.ndim != 2:
        raise EvsimInputError(f"EXR image must be (H, W), got shape {image.shape}")
    if not np.all(np.isfinite(image)):
        raise EvsimInputError("EXR image must be finite")
    pixels = np.ascontiguousarray(image, dtype=np.float16 if half else np.float32)
    import OpenEXR  # (on first use: `evsim info` and other readers need not load it)

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    return OpenEXR.File(header, {"Y": pixels})


def write_exr(path: str | Path, image: np.ndarray, *, half: bool = False) -> None:
    """Write one (H, W) float image as a single-channel EXR, atomically."""
    f = _exr_file(image, half)
    with atomic_path(path) as tmp:
        f.write(str(tmp))


def read_exr(path: str | Path) -> np.ndarray:
    """Read a single-channel (or "Y") EXR image as float32 (H, W)."""
    path = Path(path)
    if not path.is_file():
        raise fail(path, "no such file")
    import OpenEXR

    try:
        with quiet_native_output():  # OpenEXR's own "Warning: ..." (on stdout) on a corrupt file
            channels = OpenEXR.File(str(path), separate_channels=True).channels()
    except Exception as e:  # the binding raises plain RuntimeError/Exception for every decoding failure
        raise fail(path, f"not a readable OpenEXR file: {e}") from e
    name = "Y" if "Y" in channels else (next(iter(channels)) if len(channels) == 1 else None)
    if name is None:
        raise fail(path, f"expected a single or 'Y' channel, found {sorted(channels)}")
    return np.asarray(channels[name].pixels, dtype=np.float32)


def write_exr_recording(rec: Recording, directory: str | Path, *, half: bool = False) -> None:
    """Write a Recording's reference frames as an EXR folder (write_exr_sequence); the "exr" format's writer.

    Parameters
    ----------
    rec : Recording
        A recording with reference frames (linear radiance) and their times.
    directory : str or Path
        The folder to write, atomically.
    half : bool
        Write float16 instead of float32 pixels.
    """
    if rec.reference is None:
        raise missing_part_error("exr export needs reference frames: the recording has none", rec, "reference")
    write_exr_sequence(directory, rec.reference, rec.reference_t_us, half=half)


def write_exr_sequence(directory: str | Path, images: np.ndarray, t_us: np.ndarray, *, half: bool = False) -> None:
    """Write (R, H, W) images with their int64 microsecond times as an EXR folder, atomically (whole folder)."""
    t_us = np.asarray(t_us, dtype=np.int64)
    if len(images) != t_us.shape[0]:
        raise EvsimInputError(f"{len(images)} images but {t_us.shape[0]} timestamps")
    with atomic_path(directory, directory=True) as tmp:
        lines = ["# t_us file (int64 microseconds)\n"]
        for i, (img, t) in enumerate(zip(images, t_us)):
            name = f"frame_{i:06d}.exr"
            _exr_file(img, half).write(str(tmp / name))
            lines.append(f"{int(t)} {name}\n")
        (tmp / TIMES_FILE).write_text("".join(lines))


def read_exr_sequence(directory: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read an EXR folder written by write_exr_sequence: (R, H, W) float32 images and (R,) int64 times (us).

    What it holds is checked as the radiance of a reference: times in timestamps.txt that never decrease and lie
    within +-2**62 us, frames of one size with finite pixels >= 0; anything else (or an unreadable file) is a
    DatasetFormatError naming the file and the line or frame."""
    directory = Path(directory)
    times = directory / TIMES_FILE
    if not times.is_file():
        raise fail(directory, f"no {TIMES_FILE} (lines 't_us file_name')")
    try:
        text = times.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise fail(times, f"unreadable: {e}") from e
    t, names = [], []
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        parts = line.split()
        if len(parts) != 2 or not re.fullmatch(r"-?[0-9]+", parts[0]):  # (not isdigit: "--5", "²" pass it)
            raise fail(times, f"line {n}: expected 't_us file_name', got {line!r}")
        ti = int(parts[0])
        if abs(ti) > MAX_TIME_US:
            raise fail(times, f"line {n}: time {ti} us outside +-2**62 us")
        if t and ti < t[-1]:
            raise fail(times, f"line {n}: time {ti} us is before the previous frame's {t[-1]} us (times must not "
                              "decrease)")
        t.append(ti)
        names.append(parts[1])
    if not names:
        return np.zeros((0, 0, 0), np.float32), np.zeros(0, np.int64)
    images = []
    for name in names:
        img = read_exr(directory / name)
        if img.ndim != 2 or not img.size:
            raise fail(directory / name, f"expected a non-empty (H, W) image, got shape {img.shape}")
        if not np.isfinite(img).all():
            raise fail(directory / name, "pixels must be finite radiance: found NaN or infinite values")
        if (img < 0).any():
            raise fail(directory / name, f"pixels must be radiance >= 0: found {float(img.min())}")
        images.append(img)
    if len({im.shape for im in images}) != 1:
        raise fail(directory, "EXR frames differ in size")
    return np.stack(images), np.array(t, dtype=np.int64)


def read_exr_recording(directory: str | Path) -> Recording:
    """An EXR folder (read_exr_sequence) as a Recording that holds its frames as the reference and no events."""
    images, t = read_exr_sequence(directory)
    if not len(images):
        raise fail(directory, f"{TIMES_FILE} lists no frames")
    return Recording(events=np.zeros(0, EVENT_DTYPE), height=images.shape[1], width=images.shape[2],
                     reference=images, reference_t_us=t, metadata={"exr_folder": str(directory)})
