"""The IJRR "Event Camera Dataset" text layout (Mueggler et al. 2017 [Mueggler2017]), plus evsim's extensions.

A folder holding:
    events.txt      lines "t x y p": t in seconds written with exactly 6 decimals (so microseconds round-trip
                    exactly), x y pixel coordinates, p 1 = ON / 0 = OFF
    images.txt      lines "t images/frame_00000000.png": t = mid-exposure time in seconds
    images/         the frames as PNG (8-bit, or 16-bit for bit depth > 8), written and read with OpenCV
    exposures.txt   (extension) lines "t_start t_end" in seconds, one per line of images.txt (read also under
                    the name frame_exposures.txt, as other exporters write it)
    evsim.json      (extension) height, width, frame_bit_depth, crf, metadata
    threshold_maps.npy   (extension) (2, H, W) float32 ON/OFF contrast thresholds
    event_labels.txt     (extension) one label per event line (0 signal, 1 shot, 2 leak, 3 hot)
    reference/      (extension) HDR reference frames as an EXR sequence (see exr.py)
Reading accepts the original dataset too: extra files (calib.txt, imu.txt, groundtruth.txt) are ignored; times
are rounded to the nearest microsecond (9-decimal text included), exactly for microsecond-resolution times below
2**51 us (about 71 years: Unix time included); missing exposures give t_start = t_mid = t_end; colour PNGs are
converted to grey; without evsim.json or images the sensor size is max(x) + 1 by max(y) + 1.

The E2VID text flavour ("e2vid-txt", rpg_e2vid's input) is one file: a first line "width height", then the
same "t x y p" event lines; written zipped (one member, as rpg_e2vid's extract_events_from_rosbag.py does) when
the path ends in .zip, else plain text. It holds events and the sensor size only.

References (docs/models/references.md): Mueggler et al. 2017 [Mueggler2017], the IJRR layout; Rebecq et al.
2021 [Rebecq2021], E2VID and its text input.
"""

from __future__ import annotations

import io
import json
import tokenize
import warnings
import zipfile
import zlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from sim import EvsimInputError

from .atomic import atomic_path
from .common import (
    DatasetFormatError,
    events_from_columns,
    fail,
    polarity_pm1,
    quiet_native_output,
    to_json,
)
from .exr import read_exr_sequence, write_exr_sequence
from .native import recording_event_chunks
from .recording import Recording, validate_recording

_FORMAT_ROWS = 100_000  # events formatted per string operation
EXPOSURE_FILES = ("exposures.txt", "frame_exposures.txt")  # frame exposure windows: evsim's name, then others'


def seconds_text(t_us: int) -> str:
    """Microseconds as exact decimal seconds with 6 decimals ("-0.000001" for -1)."""
    t_us = int(t_us)
    sign, a = ("-" if t_us < 0 else ""), abs(t_us)
    return f"{sign}{a // 1_000_000}.{a % 1_000_000:06d}"


def _events_text(ev: np.ndarray) -> str:
    t = ev["t"]
    if t.size and t[0] < 0:
        raise EvsimInputError("the IJRR text layout stores non-negative event times; got t < 0")
    cols = np.column_stack([t // 1_000_000, t % 1_000_000, ev["x"], ev["y"], ev["p"] > 0]).astype(np.int64)
    return ("%d.%06d %d %d %d\n" * ev.size) % tuple(cols.ravel().tolist())


def write_ijrr(rec: Recording, directory: str | Path, *, event_source: Iterator | None = None) -> None:
    """Write a Recording as an IJRR text folder, atomically (the whole folder appears at the end)."""
    validate_recording(rec)
    with atomic_path(directory, directory=True) as tmp:
        with open(tmp / "events.txt", "w") as fe, open(tmp / "event_labels.txt", "w") as fl:
            has_labels = False
            for chunk, labels in event_source if event_source is not None else recording_event_chunks(rec):
                for i in range(0, chunk.size, _FORMAT_ROWS):
                    fe.write(_events_text(chunk[i : i + _FORMAT_ROWS]))
                if labels is not None:
                    has_labels = True
                    fl.write("".join(f"{v}\n" for v in labels.tolist()))
        if not has_labels:
            (tmp / "event_labels.txt").unlink()
        if rec.frames is not None:
            import cv2  # (on first use: readers of other layouts need not load OpenCV)

            (tmp / "images").mkdir()
            depth = np.uint8 if rec.frame_bit_depth == 8 else np.uint16
            img_lines, exp_lines = [], []
            for i, img in enumerate(rec.frames):
                name = f"images/frame_{i:08d}.png"
                ok, png = cv2.imencode(".png", np.ascontiguousarray(img, dtype=depth))
                if not ok:
                    raise OSError(f"OpenCV could not write frame {i} as PNG")
                (tmp / name).write_bytes(png.tobytes())  # (written here, a full disk is an OSError)
                img_lines.append(f"{seconds_text(rec.frame_t_mid_us[i])} {name}\n")
                exp_lines.append(f"{seconds_text(rec.frame_t_start_us[i])} {seconds_text(rec.frame_t_end_us[i])}\n")
            (tmp / "images.txt").write_text("".join(img_lines))
            (tmp / "exposures.txt").write_text("".join(exp_lines))
        if rec.threshold_maps is not None:
            np.save(tmp / "threshold_maps.npy", np.asarray(rec.threshold_maps, dtype=np.float32))
        if rec.reference is not None:
            write_exr_sequence(tmp / "reference", rec.reference, rec.reference_t_us)
        info = {"height": rec.height, "width": rec.width, "frame_bit_depth": rec.frame_bit_depth,
                "crf": rec.crf, "metadata": rec.metadata}
        (tmp / "evsim.json").write_text(to_json(info))


def is_ijrr(directory: Path) -> bool:
    return (Path(directory) / "events.txt").is_file()


def _seconds_to_us(s) -> np.ndarray:
    return np.rint(np.asarray(s, dtype=np.float64) * 1e6).astype(np.int64)


def _load_table(path: Path, ncols: int, dtype=np.float64, usecols=None) -> np.ndarray:
    if path.stat().st_size == 0:
        return np.zeros((0, ncols), dtype)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data" for comment-only files
            a = np.loadtxt(path, dtype=dtype, ndmin=2, comments="#", usecols=usecols)
    except ValueError as e:
        raise fail(path, f"malformed line: {e}") from e
    if a.size and a.shape[1] != ncols:
        raise fail(path, f"expected {ncols} columns, got {a.shape[1]}")
    return a.reshape(-1, ncols)


def read_ijrr(directory: str | Path) -> Recording:
    """Read an IJRR text folder (ours or the original dataset's) into a Recording."""
    d = Path(directory)
    if d.is_file() and d.name == "events.txt":
        d = d.parent
    if not is_ijrr(d):
        raise fail(d, "no events.txt: not an IJRR text folder")
    info = {}
    if (d / "evsim.json").is_file():
        try:
            info = json.loads((d / "evsim.json").read_text())
        except ValueError as e:
            raise fail(d / "evsim.json", f"invalid JSON: {e}") from e
    ev = _load_table(d / "events.txt", 4)
    events = events_from_columns(d / "events.txt", _seconds_to_us(ev[:, 0]), ev[:, 1], ev[:, 2],
                                 polarity_pm1(d / "events.txt", ev[:, 3]))
    del ev
    frames, t_start, t_mid, t_end, depth = _read_frames(d)
    if "height" in info and "width" in info:
        h, w = int(info["height"]), int(info["width"])
    elif frames is not None:
        h, w = frames.shape[1:]
    elif events.size:
        h, w = int(events["y"].max()) + 1, int(events["x"].max()) + 1
    else:
        raise fail(d, "sensor size unknown: no evsim.json, no images and no events")
    labels = None
    if (d / "event_labels.txt").is_file():
        labels = _load_table(d / "event_labels.txt", 1, dtype=np.int64)[:, 0]
        if labels.size and (labels.min() < 0 or labels.max() > 255):
            raise fail(d / "event_labels.txt", f"labels must be 0..3, got {labels.min()}..{labels.max()}")
        labels = labels.astype(np.uint8)
        if labels.shape[0] != events.size:
            raise fail(d / "event_labels.txt", f"{labels.shape[0]} labels for {events.size} events")
    reference = reference_t = None
    if (d / "reference").is_dir():
        reference, reference_t = read_exr_sequence(d / "reference")
    thr = _load_npy(d / "threshold_maps.npy") if (d / "threshold_maps.npy").is_file() else None
    return Recording(events=events, height=h, width=w, frames=frames, frame_t_start_us=t_start,
                     frame_t_mid_us=t_mid, frame_t_end_us=t_end,
                     frame_bit_depth=int(info.get("frame_bit_depth", depth)), reference=reference,
                     reference_t_us=reference_t, crf=info.get("crf"), threshold_maps=thr, event_labels=labels,
                     metadata=info.get("metadata", {}))


def _load_npy(path: Path) -> np.ndarray:
    """np.load of a .npy file (no pickles); what numpy raises on a corrupt header (its parser raises
    tokenize.TokenError and SyntaxError too) is a DatasetFormatError naming the file."""
    try:
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, SyntaxError, TypeError, tokenize.TokenError) as e:
        raise fail(path, f"not a readable .npy array (corrupt?): {type(e).__name__}: {e}") from e


def _read_frames(d: Path):
    import cv2

    path = d / "images.txt"
    if not path.is_file():
        return None, None, None, None, 8
    rows = [ln.split() for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    if any(len(r) != 2 for r in rows):
        raise fail(path, "expected lines 't images/frame_XXXXXXXX.png'")
    if not rows:
        return None, None, None, None, 8
    try:
        t_mid = _seconds_to_us([r[0] for r in rows])
    except ValueError as e:
        raise fail(path, f"bad time: {e}") from e
    images = []
    for _, name in rows:
        if not (d / name).is_file():  # said here: OpenCV would print its own warning first
            raise fail(d / name, f"missing or unreadable image: no such file (listed in {path.name})")
        with quiet_native_output():  # libpng's and OpenCV's messages on a corrupt image: evsim's error says it
            img = cv2.imread(str(d / name), cv2.IMREAD_UNCHANGED)
        if img is None:
            raise fail(d / name, "missing or unreadable image")
        images.append(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img)
    if len({im.shape for im in images}) != 1 or len({im.dtype for im in images}) != 1:
        raise fail(path, "images differ in size or bit depth")
    frames = np.stack(images)
    if frames.dtype.kind != "u":
        raise fail(path, f"images must be unsigned integer PNGs, got {frames.dtype}")
    exp = next((d / n for n in EXPOSURE_FILES if (d / n).is_file()), d / EXPOSURE_FILES[0])
    if exp.is_file():
        e = _load_table(exp, 2)
        if e.shape[0] != len(rows):
            raise fail(exp, f"{e.shape[0]} exposure lines for {len(rows)} images")
        t_start, t_end = _seconds_to_us(e[:, 0]), _seconds_to_us(e[:, 1])
    else:
        t_start, t_end = t_mid.copy(), t_mid.copy()
    return frames, t_start, t_mid, t_end, 8 * frames.dtype.itemsize


# -- the E2VID text flavour -------------------------------------------------------------------------------------
def write_e2vid_txt(rec: Recording, path: str | Path, *, event_source: Iterator | None = None) -> None:
    """Write the events as rpg_e2vid's text input (header "width height"), zipped when path ends in .zip;
    streamed chunk by chunk and atomic."""
    validate_recording(rec)
    path = Path(path)
    chunks = event_source if event_source is not None else recording_event_chunks(rec)
    with atomic_path(path) as tmp:
        if path.suffix.lower() == ".zip":
            with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as z, \
                    z.open(path.with_suffix(".txt").name, "w", force_zip64=True) as raw, \
                    io.TextIOWrapper(raw, encoding="ascii") as fe:
                _write_e2vid_lines(fe, rec, chunks)
        else:
            with open(tmp, "w", encoding="ascii") as fe:
                _write_e2vid_lines(fe, rec, chunks)


def _write_e2vid_lines(fe, rec: Recording, chunks) -> None:
    fe.write(f"{rec.width} {rec.height}\n")
    for chunk, _ in chunks:
        for i in range(0, chunk.size, _FORMAT_ROWS):
            fe.write(_events_text(chunk[i : i + _FORMAT_ROWS]))


def is_e2vid_txt(path: str | Path) -> bool:
    """True for a .txt or .zip file whose first line is two integers ("width height")."""
    return e2vid_txt_problem(path) is None


def e2vid_txt_problem(path: str | Path) -> str | None:
    """None when `path` is a .txt or .zip file whose first line is two integers ("width height"), else why it is
    not E2VID text (the reader's own words: a .zip with more than one member, a byte-order mark, ...)."""
    path = Path(path)
    if not path.is_file():
        return "no such file"
    if path.suffix.lower() not in (".txt", ".zip"):
        return "E2VID text is a .txt or .zip file"
    try:
        with _open_e2vid_text(path) as f:
            first = f.readline(1024).split()
    except DatasetFormatError as e:
        return str(e).removeprefix(f"{path}: ")
    except (OSError, zipfile.BadZipFile, zlib.error, EOFError, UnicodeDecodeError, RuntimeError,
            NotImplementedError) as e:  # zipfile: encrypted members, unsupported compression
        return f"unreadable ({type(e).__name__}: {e})"
    if len(first) != 2 or not all(tok.isdigit() for tok in first):
        return f"its first line must be 'width height', got {' '.join(first)[:60]!r}"
    return None


_BOMS = {b"\xef\xbb\xbf": "UTF-8", b"\xff\xfe": "UTF-16", b"\xfe\xff": "UTF-16"}


def _open_e2vid_text(path: Path):
    if path.suffix.lower() != ".zip":
        raw = open(path, "rb")
    else:
        z = zipfile.ZipFile(path)
        names = z.namelist()
        if len(names) != 1:
            z.close()
            raise fail(path, f"an E2VID .zip holds one text file, found {len(names)} members "
                             f"({', '.join(names[:3])}{', ...' if len(names) > 3 else ''})")
        raw = z.open(names[0])
    head = raw.peek(3)[:3] if hasattr(raw, "peek") else b""
    for bom, name in _BOMS.items():
        if head.startswith(bom):
            raw.close()
            raise fail(path, f"starts with a {name} byte-order mark: E2VID text is plain ASCII (save it without "
                             "a BOM)")
    return io.TextIOWrapper(raw, encoding="ascii")


def read_e2vid_txt(path: str | Path) -> Recording:
    """Read rpg_e2vid's text input (plain or zipped): header "width height", then "t x y p" lines."""
    path = Path(path)
    if not path.is_file():
        raise fail(path, "no such file")
    try:
        with _open_e2vid_text(path) as f:
            header = f.readline().split()
            if len(header) != 2 or not all(tok.isdigit() for tok in header):
                raise fail(path, f"first line must be 'width height', got {' '.join(header)!r}")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
                ev = np.loadtxt(f, dtype=np.float64, ndmin=2, comments="#")
    except DatasetFormatError:
        raise
    except (zipfile.BadZipFile, zlib.error, UnicodeDecodeError, OSError, EOFError) as e:
        raise fail(path, f"unreadable E2VID text file (truncated or corrupt?): {e}") from e
    except ValueError as e:
        raise fail(path, f"malformed line: {e}") from e
    ev = ev.reshape(-1, 4) if ev.size else np.zeros((0, 4))
    width, height = int(header[0]), int(header[1])
    events = events_from_columns(path, _seconds_to_us(ev[:, 0]), ev[:, 1], ev[:, 2], polarity_pm1(path, ev[:, 3]))
    if events.size and (events["x"].max() >= width or events["y"].max() >= height):
        raise fail(path, f"event coordinates exceed the header's sensor size {width}x{height}")
    rec = Recording(events=events, height=height, width=width,
                    metadata={"source": {"format": "e2vid-txt", "path": str(path)}})
    return rec  # load() validates it
