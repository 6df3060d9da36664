"""Seeded mutators for the reader fuzz suite (tests/test_fuzz_readers.py).

Every mutant is a copy of a file (or folder) written by evsim's own writers, changed by one seeded mutation:
structural ones that keep the container readable (an HDF5 attribute or dataset replaced by a hostile value, a
dataset's dtype changed, an object deleted, a text token replaced, a .mat variable replaced) and byte-level ones
(random bytes flipped, truncation, garbage inserted). The oracle lives in the test.
"""

from __future__ import annotations

import shutil
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
