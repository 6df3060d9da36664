"""Seeded mutators for the reader fuzz suite (tests/test_fuzz_readers.py).

Every mutant is a copy of a file (or folder) written by evsim's own writers, changed by one seeded mutation:
structural ones that keep the container readable (an HDF5 attribute or dataset replaced by a hostile value, a
dataset's dtype changed, an object deleted, a text token replaced, a .mat variable replaced), byte-level ones
(random bytes flipped, truncation, garbage inserted) and time-order ones that keep everything else intact (a time
that goes back, a reversed block, a time that jumps ahead, a wrap word of a Prophesee stream that goes back or a
time just before 0 that a 32-bit counter stores near the top of its range). The oracle lives in the test.
"""

from __future__ import annotations

import io
import shutil
import zipfile
from pathlib import Path

import h5py
import numpy as np
import scipy.io

HOSTILE_NUMBERS = [0, -1, 1, 2, 3, 4, 255, 256, 65535, 65536, -65536, 2**31, 2**62 + 1, 2**63 - 1, -(2**63),
                   1e300, -1e300, 0.5, -0.5]
HOSTILE_FLOATS = [float("nan"), float("inf"), float("-inf")]
HOSTILE_TEXT = ["nan", "inf", "-1", "1e300", "abc", "", "{", "[1, 2", "null", "9" * 30, "0x10", "-0", "1.5",
                "65536", "18446744073709551615", "9223372036854775807", "\x00", "é"]


def hostile_value(rng: np.random.Generator):
    pool = HOSTILE_NUMBERS + HOSTILE_FLOATS
    return pool[rng.integers(len(pool))]


def hostile_text(rng: np.random.Generator) -> str:
    return HOSTILE_TEXT[rng.integers(len(HOSTILE_TEXT))]


# ----- byte level ------------------------------------------------------------------------------------------

def mutate_bytes(path: Path, rng: np.random.Generator) -> str:
    """Flip, truncate or insert bytes of one file in place; returns a description."""
    data = bytearray(path.read_bytes())
    kind = rng.integers(3)
    if kind == 0 and data:
        n = int(rng.integers(1, 9))
        for i in rng.integers(0, len(data), n):
            data[i] ^= 1 << int(rng.integers(8))
        desc = f"flip {n} bits"
    elif kind == 1:
        cut = int(rng.integers(0, max(1, len(data))))
        data = data[:cut]
        desc = f"truncate at {cut}"
    else:
        at = int(rng.integers(0, len(data) + 1))
        data[at:at] = rng.integers(0, 256, int(rng.integers(1, 64)), dtype=np.uint8).tobytes()
        desc = f"insert garbage at {at}"
    path.write_bytes(bytes(data))
    return f"{path.name}: {desc}"


# ----- HDF5 ------------------------------------------------------------------------------------------------

def _h5_objects(f: h5py.File) -> tuple[list[str], list[tuple[str, str]]]:
    datasets, attrs = [], [("/", k) for k in f.attrs]

    def visit(name, obj):  # must return None, or visititems stops
        if isinstance(obj, h5py.Dataset):
            datasets.append(name)
        attrs.extend((name, k) for k in obj.attrs)

    f.visititems(visit)
    return datasets, attrs


def mutate_h5(path: Path, rng: np.random.Generator) -> str:
    """One structural mutation of an HDF5 file, in place."""
    with h5py.File(path, "r+") as f:
        datasets, attrs = _h5_objects(f)
        kind = rng.integers(7)
        if kind == 0 and attrs:  # an attribute becomes a hostile number or text
            obj, key = attrs[rng.integers(len(attrs))]
            v = hostile_value(rng) if rng.random() < 0.6 else hostile_text(rng)
            try:
                f[obj].attrs[key] = v
            except (TypeError, OverflowError, ValueError):  # e.g. HDF5 strings cannot hold NUL
                f[obj].attrs[key] = np.bytes_(str(v).encode())
            return f"attr {obj}:{key} = {v!r}"
        if kind == 1 and attrs:  # delete an attribute
            obj, key = attrs[rng.integers(len(attrs))]
            del f[obj].attrs[key]
            return f"del attr {obj}:{key}"
        if not datasets:
            return "no dataset"
        name = datasets[rng.integers(len(datasets))]
        ds = f[name]
        if kind == 2:  # delete a dataset
            del f[name]
            return f"del {name}"
        data = ds[()]
        a = np.array(data, copy=True)
        keep_attrs = dict(ds.attrs)
        if kind == 3 and a.size:  # one element becomes hostile, in the dataset's dtype when it fits
            v = hostile_value(rng)
            flat = a.reshape(-1)
            i = int(rng.integers(flat.size))
            if a.dtype.kind in "iub":  # (float stores may overflow on purpose: float16 and friends)
                a = a.astype(np.float64) if (isinstance(v, float) and not float(v).is_integer()) else a
                try:
                    flat = a.reshape(-1)
                    flat[i] = v
                except (OverflowError, ValueError):
                    a = a.astype(np.float64)
                    a.reshape(-1)[i] = v
            else:
                with np.errstate(over="ignore"):
                    flat[i] = v
            desc = f"{name}[{i}] = {v!r} ({a.dtype})"
        elif kind == 4:  # a different dtype
            dt = [np.float64, np.int8, np.int16, np.uint64, np.int64, np.float16, "S4"][rng.integers(7)]
            try:
                a = a.astype(dt)
            except (ValueError, TypeError, OverflowError):
                a = np.asarray(a).astype("S8")
            desc = f"{name} as {np.dtype(dt)}"
        elif kind == 5 and a.ndim:  # drop or duplicate rows, or reverse them
            op = rng.integers(3)
            a = a[: a.shape[0] // 2] if op == 0 else (np.concatenate([a, a]) if op == 1 else a[::-1])
            desc = f"{name} rows {'halved' if op == 0 else 'doubled' if op == 1 else 'reversed'}"
        else:  # a different shape
            a = a.reshape(-1) if a.ndim > 1 else (a[None] if a.ndim == 1 else np.array([a, a]))
            desc = f"{name} reshaped to {a.shape}"
        del f[name]
        new = f.create_dataset(name, data=a)
        new.attrs.update(keep_attrs)
        return desc


# ----- text (IJRR folders) ---------------------------------------------------------------------------------

def mutate_text(path: Path, rng: np.random.Generator) -> str:
    """Replace a token, drop, duplicate or swap lines of a text file, in place."""
    lines = path.read_text(encoding="utf-8", errors="replace").splitlines(keepends=True)
    if not lines:
        path.write_text(hostile_text(rng))
        return f"{path.name}: empty -> hostile"
    kind = rng.integers(4)
    i = int(rng.integers(len(lines)))
    if kind == 0:
        tokens = lines[i].split()
        if tokens:
            j = int(rng.integers(len(tokens)))
            tokens[j] = hostile_text(rng) if rng.random() < 0.5 else repr(hostile_value(rng))
            lines[i] = " ".join(tokens) + "\n"
        desc = f"line {i} token -> {lines[i]!r:.60}"
    elif kind == 1:
        del lines[i]
        desc = f"drop line {i}"
    elif kind == 2:
        lines.insert(i, lines[i])
        desc = f"duplicate line {i}"
    else:
        j = int(rng.integers(len(lines)))
        lines[i], lines[j] = lines[j], lines[i]
        desc = f"swap lines {i}, {j}"
    path.write_text("".join(lines), encoding="utf-8")
    return f"{path.name}: {desc}"


def mutate_json(path: Path, rng: np.random.Generator) -> str:
    import json

    try:
        info = json.loads(path.read_text())
    except ValueError:
        return mutate_text(path, rng)
    keys = sorted(info) if isinstance(info, dict) else []
    if not keys or rng.random() < 0.2:
        path.write_text(hostile_text(rng))
        return f"{path.name}: replaced by text"
    k = keys[rng.integers(len(keys))]
    v = [hostile_value(rng), hostile_text(rng), None, [], {}, {"name": 3}][rng.integers(6)]
    if rng.random() < 0.2:
        del info[k]
        desc = f"del {k}"
    else:
        info[k] = v
        desc = f"{k} = {v!r}"
    path.write_text(json.dumps(info))  # NaN/inf are written as NaN/Infinity, which Python's json accepts
    return f"{path.name}: {desc}"


def mutate_npy(path: Path, rng: np.random.Generator) -> str:
    a = np.load(path)
    if rng.random() < 0.5 and a.size:
        a = a.copy()
        a.reshape(-1)[rng.integers(a.size)] = hostile_value(rng)
        desc = "hostile element"
    else:
        a = a.reshape(-1)[: max(0, a.size - 1)]
        desc = "flattened and shortened"
    np.save(path, a)
    return f"{path.name}: {desc}"


def mutate_folder(folder: Path, rng: np.random.Generator) -> str:
    """One mutation of one file of an IJRR folder (text, JSON, .npy, PNG or EXR)."""
    files = sorted(p for p in folder.rglob("*") if p.is_file())
    p = files[rng.integers(len(files))]
    if rng.random() < 0.25 or p.suffix in (".png", ".exr"):
        return mutate_bytes(p, rng) if rng.random() < 0.9 else _delete(p)
    if p.suffix == ".json":
        return mutate_json(p, rng)
    if p.suffix == ".npy":
        return mutate_npy(p, rng)
    return mutate_text(p, rng)


def _delete(p: Path) -> str:
    p.unlink()
    return f"delete {p.name}"


# ----- MATLAB .mat -----------------------------------------------------------------------------------------

def mutate_mat(path: Path, rng: np.random.Generator) -> str:
    m = {k: v for k, v in scipy.io.loadmat(path).items() if not k.startswith("__")}
    keys = sorted(m)
    k = keys[rng.integers(len(keys))]
    a = np.asarray(m[k])
    kind = rng.integers(5)
    if kind == 0:
        del m[k]
        desc = f"del {k}"
    elif kind == 1 and a.size and a.dtype.kind in "iuf":
        a = a.astype(np.float64)
        a.reshape(-1)[rng.integers(a.size)] = hostile_value(rng)
        m[k] = a
        desc = f"{k}: hostile element"
    elif kind == 2:
        m[k] = a.reshape(-1)[: max(0, a.size // 2)] if a.dtype.kind != "U" else np.array([hostile_text(rng)])
        desc = f"{k}: flattened/halved"
    elif kind == 3:
        m[k] = np.array(hostile_text(rng)) if rng.random() < 0.5 else np.array(hostile_value(rng))
        desc = f"{k}: replaced by a scalar"
    else:
        m[k] = a.T if a.ndim >= 2 else a
        desc = f"{k}: transposed"
    scipy.io.savemat(path, m)
    return f"{path.name}: {desc}"


def copy_input(src: Path, dst: Path) -> Path:
    if src.is_dir():
        shutil.copytree(src, dst)
    else:
        shutil.copyfile(src, dst)
    return dst


# ----- time order ------------------------------------------------------------------------------------------

BACK_US = [1, 7, 1000, 65_536, 1_000_000, 1 << 24, 1 << 31]  # how far a time goes back or jumps ahead


def disorder(t: np.ndarray, rng: np.random.Generator, per_us: float = 1.0) -> tuple[np.ndarray, str]:
    """One time-order corruption of a copy of the time vector t (per_us: units per microsecond, 1e-6 for seconds):
    a time that goes back, a reversed block, or a time that jumps ahead (never the last: the next then goes back;
    a later last time is a valid file that no reader can tell from the original)."""
    t = np.array(t, copy=True)
    if t.size < 2:
        return t, "too short to disorder"
    kind = rng.integers(3)
    d = BACK_US[rng.integers(len(BACK_US))]
    if kind == 0:
        i = int(rng.integers(1, t.size))
        t[i] = t[i - 1] - (d * per_us if t.dtype.kind == "f" else int(d * per_us) or 1)
        return t, f"t[{i}] {d} us before t[{i - 1}]"
    if kind == 1:
        i = int(rng.integers(0, t.size - 1))
        j = min(t.size, i + int(rng.integers(2, 64)))
        t[i:j] = t[i:j][::-1].copy()
        return t, f"t[{i}:{j}] reversed"
    i = int(rng.integers(0, t.size - 1))
    t[i] = t[i] + (d * per_us if t.dtype.kind == "f" else int(d * per_us) or 1)
    return t, f"t[{i}] {d} us ahead"


_H5_TIMES = {"events/t": 1.0, "events/ts": 1e-6, "frames/t_start_us": 1.0, "frames/t_mid_us": 1.0,
             "frames/t_end_us": 1.0, "reference/t_us": 1.0, "evsim/reference/t_us": 1.0}


def mutate_time_h5(path: Path, rng: np.random.Generator) -> str:
    """A time-order corruption of one time dataset (events most often) or of E2VID image timestamps, in place."""
    with h5py.File(path, "r+") as f:
        names = [n for n in _H5_TIMES if n in f and f[n].ndim == 1 and f[n].shape[0] >= 2]
        images = sorted(f["images"]) if "images" in f and "frames" not in f else []
        if images and rng.random() < 0.25:  # E2VID: image timestamp attributes
            i = int(rng.integers(1, len(images)))
            a, prev = f["images"][images[i]].attrs, f["images"][images[i - 1]].attrs
            d = BACK_US[rng.integers(len(BACK_US))]
            a["timestamp"] = prev["timestamp"] - d * 1e-6
            if "t_mid_us" in a:
                a["t_mid_us"] = int(prev["t_mid_us"]) - d
            return f"image {images[i]} timestamp {d} us before the previous image's"
        name = names[0] if rng.random() < 0.5 else names[rng.integers(len(names))]
        t, desc = disorder(f[name][()], rng, _H5_TIMES[name])
        f[name][...] = t
        return f"{name}: {desc}"


def _disorder_lines(lines: list[str], rng: np.random.Generator, per_us: float, fmt) -> tuple[list[str], str]:
    """Time-order corruption of text lines whose first token is a time: a reversed block of lines, or one time
    moved back or ahead (fmt formats a time)."""
    rows = [i for i, ln in enumerate(lines) if ln.strip() and not ln.startswith("#")]
    if len(rows) < 2:
        return lines, "too few lines"
    if rng.random() < 0.35:
        a = int(rng.integers(0, len(rows) - 1))
        b = min(len(rows), a + int(rng.integers(2, 64)))
        block = [lines[i] for i in rows[a:b]][::-1]
        for i, ln in zip(rows[a:b], block):
            lines[i] = ln
        return lines, f"lines {rows[a]}..{rows[b - 1]} reversed"
    t = np.array([float(lines[i].split()[0]) for i in rows])
    t2, desc = disorder(t, rng, per_us)
    k = int(np.flatnonzero(t2 != t)[0]) if (t2 != t).any() else 0
    tokens = lines[rows[k]].split()
    lines[rows[k]] = " ".join([fmt(t2[k]), *tokens[1:]]) + "\n"
    return lines, desc


def _seconds(v: float) -> str:
    return f"{v:.6f}"


def _micros(v: float) -> str:
    return str(int(round(v)))


def mutate_time_folder(folder: Path, rng: np.random.Generator) -> str:
    """A time-order corruption of an IJRR folder (events.txt most often, images.txt, exposures.txt, the
    reference's timestamps.txt) or of an EXR folder (timestamps.txt), in place."""
    choices = [p for p in (folder / "events.txt", folder / "images.txt", folder / "exposures.txt",
                           folder / "reference" / "timestamps.txt", folder / "timestamps.txt") if p.is_file()]
    p = choices[0] if rng.random() < 0.5 else choices[rng.integers(len(choices))]
    us = p.name == "timestamps.txt"
    lines, desc = _disorder_lines(p.read_text().splitlines(keepends=True), rng, 1.0 if us else 1e-6,
                                  _micros if us else _seconds)
    p.write_text("".join(lines))
    return f"{p.relative_to(folder)}: {desc}"


def mutate_time_e2vid_text(path: Path, rng: np.random.Generator) -> str:
    """A time-order corruption of E2VID text (its first line "width height" kept), plain or zipped, in place."""
    if path.suffix == ".zip":
        with zipfile.ZipFile(path) as z:
            name = z.namelist()[0]
            text = z.read(name).decode("ascii")
    else:
        text = path.read_text()
    lines = text.splitlines(keepends=True)
    body, desc = _disorder_lines(lines[1:], rng, 1e-6, _seconds)
    text = "".join(lines[:1] + body)
    if path.suffix == ".zip":
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
            z.writestr(name, text)
        path.write_bytes(buf.getvalue())
    else:
        path.write_text(text)
    return f"{path.name}: {desc}"


def mutate_time_mat(path: Path, rng: np.random.Generator) -> str:
    """A time-order corruption of an AKF .mat: event times (rows reversed with their events), frame or reference
    times, in place."""
    m = {k: v for k, v in scipy.io.loadmat(path).items() if not k.startswith("__")}
    names = [k for k in ("time_image", "evsim_frame_t_start_us", "evsim_frame_t_end_us", "evsim_reference_t_us")
             if k in m and np.asarray(m[k]).size >= 2]
    if rng.random() < 0.5 or not names:
        ev = np.array(m["events"], dtype=np.float64)
        if rng.random() < 0.3:
            i = int(rng.integers(0, len(ev) - 1))
            j = min(len(ev), i + int(rng.integers(2, 64)))
            ev[i:j] = ev[i:j][::-1].copy()
            desc = f"events rows {i}:{j} reversed"
        else:
            t, desc = disorder(ev[:, 0], rng)
            ev[:, 0] = t
        m["events"] = ev
        scipy.io.savemat(path, m)
        return f"{path.name}: events {desc}"
    k = names[rng.integers(len(names))]
    a = np.asarray(m[k], dtype=np.float64)
    t, desc = disorder(a.ravel(), rng)
    m[k] = t.reshape(a.shape)
    scipy.io.savemat(path, m)
    return f"{path.name}: {k} {desc}"


def _header_end(data: bytes) -> int:
    pos = 0
    while data[pos : pos + 1] == b"%":
        nl = data.index(b"\n", pos) + 1
        if data[pos:nl].strip() == b"% end":
            return nl
        pos = nl
    return pos


def mutate_time_prophesee(path: Path, rng: np.random.Generator) -> str:
    """A time-order corruption of a Prophesee file, in place: .dat event times (one back, one ahead, a reversed
    block, one just before 0: near the top of the 32-bit range); EVT 2.0 / EVT 3.0 words (a TIME_HIGH that goes
    back, one that jumps to the top of its range, a time low that goes back, a reversed block of words)."""
    data = path.read_bytes()
    start = _header_end(data)
    if path.suffix == ".dat":
        start += 2  # event type and size
        d = np.frombuffer(data[start:], [("t", "<u4"), ("xyp", "<u4")]).copy()
        if rng.random() < 0.2:
            i = int(rng.integers(1, d.size))
            back = int(d["t"][i - 1]) + int(rng.integers(1, 1 << 20))
            d["t"][i] = (int(d["t"][i - 1]) - back) % (1 << 32)
            desc = f"t[{i}] {back} us before t[{i - 1}], stored in 32 bits"
        elif rng.random() < 0.3:
            i = int(rng.integers(0, d.size - 1))
            j = min(d.size, i + int(rng.integers(2, 64)))
            d[i:j] = d[i:j][::-1].copy()
            desc = f"events {i}:{j} reversed"
        else:
            t, desc = disorder(d["t"].astype(np.int64), rng)
            d["t"] = t % (1 << 32)
        path.write_bytes(data[:start] + d.tobytes())
        return f"{path.name}: {desc}"
    evt3 = b"evt 3.0" in data[:start] or b"EVT3" in data[:start]
    dt, bits, typ_th = ("<u2", 12, 0x8) if evt3 else ("<u4", 28, 0x8)
    shift = 12 if evt3 else 28
    w = np.frombuffer(data[start:], dt).copy()
    typ = w >> shift
    th = np.flatnonzero(typ == typ_th)
    mask = (1 << bits) - 1
    kind = rng.integers(4)
    if kind <= 1 and th.size > 2:
        k = int(rng.integers(1, th.size - 1))  # not the last: a later last time is a valid file (see disorder)
        prev = int(w[th[k - 1]]) & mask
        if kind == 0:
            new = (prev - int(rng.integers(1, 1 << min(bits, 12)))) % (1 << bits)
            desc = f"TIME_HIGH word {th[k]} goes back from {prev} to {new}"
        else:
            new = mask - int(rng.integers(0, 4))
            desc = f"TIME_HIGH word {th[k]} jumps from {prev} to the top ({new})"
        w[th[k]] = (typ_th << shift) | new
    elif kind == 2:
        low = np.flatnonzero(typ == 0x6) if evt3 else np.flatnonzero(typ <= 1)
        i = int(low[rng.integers(low.size)])
        if evt3:
            w[i] = 0x6000 | max(0, (int(w[i]) & 0xFFF) - int(rng.integers(1, 4096)))
        else:
            w[i] = int(w[i]) & ~(63 << 22)  # time low bits 0: earlier than the event before, most often
        desc = f"time low of word {i} goes back"
    else:
        i = int(rng.integers(0, w.size - 1))
        j = min(w.size, i + int(rng.integers(2, 64)))
        w[i:j] = w[i:j][::-1].copy()
        desc = f"words {i}:{j} reversed"
    path.write_bytes(data[:start] + w.tobytes())
    return f"{path.name}: {desc}"


def aedat4_event_times(path: Path) -> tuple[np.ndarray, int, int]:
    """(event times, byte offset of the first event's time, bytes per event) of an uncompressed AEDAT4 file with
    one event packet, found by searching the bytes for the times the aedat decoder reports."""
    import aedat

    t = np.concatenate([p["events"]["t"] for p in aedat.Decoder(str(path)) if "events" in p]).astype(np.int64)
    data = path.read_bytes()
    first = data.find(int(t[0]).to_bytes(8, "little", signed=True))
    stride = data.find(int(t[1]).to_bytes(8, "little", signed=True), first + 1) - first
    assert first > 0 and stride > 0
    return t, first, stride


def mutate_time_aedat4(path: Path, rng: np.random.Generator) -> str:
    """A time-order corruption of the event times of an uncompressed AEDAT4 file (one event packet), in place."""
    t, first, stride = aedat4_event_times(path)
    t2, desc = disorder(t, rng)
    data = bytearray(path.read_bytes())
    for i in np.flatnonzero(t2 != t):
        at = first + stride * int(i)
        data[at : at + 8] = int(t2[i]).to_bytes(8, "little", signed=True)
    path.write_bytes(bytes(data))
    return f"{path.name}: {desc}"


# ----- polarity, coordinate and unit fields: mutants every reader must refuse ----------------------------------------

BAD_POLARITY = [2, 4, 7, -2, 0.5, 1.5, -0.5]
_EVT_HEADER_UNITS = [(b"evsim_time_base us", [b"evsim_time_base ns", b"evsim_time_base ms", b"evsim_time_base s ",
                                              b"evsim_time_base 1u"]),
                     (b"evsim_polarity 1=ON 0=OFF", [b"evsim_polarity 0=ON 1=OFF", b"evsim_polarity 1=ON -1=OFF"])]


def mutate_fields(path: Path, rng: np.random.Generator, width: int = 8, height: int = 6) -> str:
    """One field of one event made invalid, in place, in the layout's own terms: a polarity outside the format's
    encodings, a coordinate outside the width x height sensor, or a unit the reader must not guess (an evsim header
    key with another time base or polarity code; E2VID times stored as integer microseconds). Every mutant must be
    refused."""
    suffix = path.suffix
    if suffix == ".h5":
        return _fields_e2vid(path, rng, width, height)
    if suffix == ".mat":
        return _fields_mat(path, rng, width, height)
    data = path.read_bytes()
    units = [(old, new) for old, news in _EVT_HEADER_UNITS for new in news if old in data]
    if units and rng.random() < 0.25:  # (none left when a first mutation changed them)
        old, new = units[rng.integers(len(units))]
        return f"{path.name}: header {old.decode()!r} -> {new.decode()!r} ({_replace(path, data, old, new)})"
    if suffix == ".aedat2":
        return _fields_aedat2(path, data, rng, width, height)
    start = _header_end(data)
    if suffix == ".dat":
        d = np.frombuffer(data[start + 2 :], [("t", "<u4"), ("xyp", "<u4")]).copy()
        i, kind = int(rng.integers(d.size)), rng.integers(3)
        xyp = int(d["xyp"][i])
        if kind == 0:
            v = int(rng.integers(width, 1 << 14))
            xyp, desc = (xyp & ~0x3FFF) | v, f"x = {v}"
        elif kind == 1:
            v = int(rng.integers(height, 1 << 14))
            xyp, desc = (xyp & ~(0x3FFF << 14)) | (v << 14), f"y = {v}"
        else:
            v = int(rng.integers(2, 16))
            xyp, desc = (xyp & 0x0FFF_FFFF) | (v << 28), f"polarity {v}"
        d["xyp"][i] = xyp
        path.write_bytes(data[: start + 2] + d.tobytes())
        return f"{path.name}: event {i} {desc}"
    evt3 = b"evt 3.0" in data[:start]
    w = np.frombuffer(data[start:], "<u2" if evt3 else "<u4").copy()
    typ = w >> (12 if evt3 else 28)
    kind = rng.integers(3)
    if evt3:  # polarity is one bit: coordinates (x in ADDR_X words, y in ADDR_Y words) and undefined word types
        if kind == 0 and rng.random() < 0.3:
            i, v = int(rng.integers(w.size)), int(rng.choice([0x1, 0x9, 0xB, 0xC, 0xD]))
            w[i], desc = (int(w[i]) & 0x0FFF) | (v << 12), f"word {i}: undefined type {v:#x}"
        elif kind == 2:
            at = np.flatnonzero(typ == 0x0)
            i, v = int(at[rng.integers(at.size)]), int(rng.integers(height, 1 << 11))
            w[i], desc = v, f"ADDR_Y word {i}: y = {v}"
        else:
            at = np.flatnonzero(typ == 0x2)
            i, v = int(at[rng.integers(at.size)]), int(rng.integers(width, 1 << 11))
            w[i], desc = (int(w[i]) & 0xF800) | v, f"ADDR_X word {i}: x = {v}"
    else:
        at = np.flatnonzero(typ <= 1)
        i = int(at[rng.integers(at.size)])
        word = int(w[i])
        if kind == 0:
            v = int(rng.integers(width, 1 << 11))
            w[i], desc = (word & ~(0x7FF << 11)) | (v << 11), f"CD word {i}: x = {v}"
        elif kind == 1:
            v = int(rng.integers(height, 1 << 11))
            w[i], desc = (word & ~0x7FF) | v, f"CD word {i}: y = {v}"
        else:
            v = int(rng.choice([2, 3, 4, 5, 6, 7, 9, 11, 12, 13]))
            w[i], desc = (word & 0x0FFF_FFFF) | (v << 28), f"CD word {i}: type (polarity) {v:#x}"
    path.write_bytes(data[:start] + w.tobytes())
    return f"{path.name}: {desc}"


def _replace(path: Path, data: bytes, old: bytes, new: bytes) -> str:
    path.write_bytes(data.replace(old, new, 1))
    return "same length" if len(old) == len(new) else f"{len(new) - len(old):+d} bytes"


def _fields_aedat2(path: Path, data: bytes, rng: np.random.Generator, width: int, height: int) -> str:
    """AEDAT 2.0 (DAVIS layout): an x or y field beyond the sensor (polarity is one bit)."""
    start = data.index(b"# End Of ASCII Header") + len(b"# End Of ASCII Header\r\n")
    d = np.frombuffer(data[start:], [("a", ">u4"), ("t", ">u4")]).copy()
    dvs = np.flatnonzero((d["a"] >> 31 == 0) & ((d["a"] >> 10) & 1 == 0))
    i = int(dvs[rng.integers(dvs.size)])
    a = int(d["a"][i])
    if rng.random() < 0.5:
        v = int(rng.integers(width, 1 << 10))
        a, desc = (a & ~(0x3FF << 12)) | (v << 12), f"x field {v}"
    else:
        v = int(rng.integers(height, 1 << 9))
        a, desc = (a & ~(0x1FF << 22)) | (v << 22), f"y field {v}"
    d["a"][i] = a
    path.write_bytes(data[:start] + d.tobytes())
    return f"{path.name}: event {i} {desc}"


def _fields_e2vid(path: Path, rng: np.random.Generator, width: int, height: int) -> str:
    """E2VID HDF5: ps values outside bool / 0-1 / -1+1, an xs or ys beyond the sensor, or ts as int64 us."""
    with h5py.File(path, "r+") as f:
        ev = f["events"]
        n, kind = ev["ps"].shape[0], rng.integers(4)
        i = int(rng.integers(n))
        if kind == 0:
            ps = ev["ps"][()].astype(np.float64)
            bad = BAD_POLARITY[rng.integers(len(BAD_POLARITY))]
            ps[i] = bad
            if rng.random() < 0.5:  # every ON event the same other value, as the 4 and 2
                ps[ps == 1] = bad
            del ev["ps"]
            ev["ps"] = ps
            return f"{path.name}: ps[{i}] = {bad}"
        if kind == 3:
            ts = np.rint(ev["ts"][()] * 1e6).astype(np.int64)
            del ev["ts"]
            ev["ts"] = ts
            return f"{path.name}: ts stored as int64 microseconds"
        name, side = ("xs", width) if kind == 1 else ("ys", height)
        v = int(rng.integers(side, 1 << 15))
        ev[name][i] = v
        return f"{path.name}: {name}[{i}] = {v}"


def _fields_mat(path: Path, rng: np.random.Generator, width: int, height: int) -> str:
    """AKF .mat: a polarity outside -1/0/1, or a 1-based x or y beyond the sensor."""
    m = {k: v for k, v in scipy.io.loadmat(path).items() if not k.startswith("__")}
    ev = np.array(m["events"], np.float64)
    i, kind = int(rng.integers(ev.shape[0])), rng.integers(3)
    if kind == 0:
        bad = BAD_POLARITY[rng.integers(len(BAD_POLARITY))]
        ev[i, 3], desc = bad, f"polarity {bad}"
    else:
        col, side = (1, width) if kind == 1 else (2, height)
        v = int(rng.integers(side + 1, 1 << 16))
        ev[i, col], desc = v, f"{'xy'[col - 1]} (1-based) {v}"
    m["events"] = ev
    scipy.io.savemat(path, m)
    return f"{path.name}: event {i} {desc}"
