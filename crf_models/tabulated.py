"""Tabulated (LUT) curves, and loaders for the DoRF database and the EMoR model (Grossberg and Nayar).

A TabulatedCRF is piecewise linear between its knots (as colour.LUT1D's default linear interpolation), so its
inverse is exact and its derivative is the slope of the knot interval (right-hand slope at a knot). Its params
hold the table itself, so a curve loaded from a file is rebuilt without the file; `source` is a free label.

References (docs/models/references.md): Grossberg and Nayar 2003 [Grossberg2003] (DoRF, EMoR) and 2004
[Grossberg2004].
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .base import CRF, CRFError, as_float_array

if TYPE_CHECKING:
    import os

    import numpy.typing as npt


class TabulatedCRF(CRF):
    """y = LUT(x) through knots (x[i], y[i]).

    Beyond x[-1] the curve holds y[-1] (clipped); below x[0] it holds y[0], clipped when x[0] > 0.

    Parameters
    ----------
    y : array_like
        1-D table of normalised responses in [0, 1], at least 2 knots; non-decreasing, strictly increasing except
        for a flat run at either end, which is a clipped range (break_ties() removes interior ties).
    x : array_like, optional
        Normalised scaled irradiance of the knots, strictly increasing, >= 0, as long as y (default:
        linspace(0, 1, len(y))).
    source : str, optional
        A free label (where the table came from).
    **kw
        ``weighting`` (see CRF).
    """

    name = "tabulated"

    def __init__(self, y: npt.ArrayLike, x: npt.ArrayLike | None = None, source: str = "", **kw: Any) -> None:
        super().__init__(**kw)
        y = as_float_array(y, "y")
        x = np.linspace(0.0, 1.0, y.size) if x is None else as_float_array(x, "x")
        if y.ndim != 1 or x.shape != y.shape or y.size < 2:
            raise CRFError(f"x and y must be 1-D tables of the same length >= 2, got {x.shape} and {y.shape}")
        if x[0] < 0 or np.any(np.diff(x) <= 0):
            raise CRFError("x must be >= 0 and strictly increasing")
        if y[0] < 0 or y[-1] > 1:
            raise CRFError(f"y must lie in [0, 1], got [{y.min()}, {y.max()}]")
        dy = np.diff(y)
        if np.any(dy < 0):
            raise CRFError(f"y must be non-decreasing; it decreases after index {int(np.flatnonzero(dy < 0)[0])}")
        rising = np.flatnonzero(dy > 0)
        if rising.size == 0:
            raise CRFError("y is constant")
        first, last = rising[0], rising[-1] + 1  # knots bounding the strictly increasing part
        if np.any(dy[first:last] == 0):
            i = first + int(np.flatnonzero(dy[first:last] == 0)[0])
            raise CRFError(f"y has an interior flat run at index {i}; use break_ties() on measured data")
        self.x, self.y, self.source = x, y, str(source)
        self._kx, self._ky = x[first : last + 1], y[first : last + 1]
        self._slopes = np.diff(self._ky) / np.diff(self._kx)
        self._set_range(self._kx[0], self._kx[-1], clip_low=bool(self._kx[0] > 0))

    def _f(self, x):
        return np.interp(x, self._kx, self._ky)

    def _finv(self, y):
        return np.interp(y, self._ky, self._kx)

    def _df(self, x):
        i = np.clip(np.searchsorted(self._kx, x, side="right") - 1, 0, self._slopes.size - 1)
        return self._slopes[i]

    def _own_params(self):
        return {"y": self.y.tolist(), "x": self.x.tolist(), "source": self.source}


def break_ties(y: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Make interior flat runs of a non-decreasing table strictly increasing by linear interpolation from the
    run's value towards the next larger value (measured tables such as DoRF have float32 ties; the change is
    smaller than that gap). Flat runs at either end (clipped ranges) are kept.

    Parameters
    ----------
    y : array_like
        A non-decreasing 1-D table of responses.

    Returns
    -------
    numpy.ndarray
        A float64 copy with its interior ties broken.
    """
    y = np.array(y, dtype=np.float64)
    start = 0
    for i in range(1, y.size + 1):
        if i < y.size and y[i] == y[start]:
            continue
        if start > 0 and i < y.size and i - start > 1:
            y[start:i] = y[start] + (y[i] - y[start]) * np.arange(i - start) / (i - start)
        start = i
    return y


def load_dorf(path: str | os.PathLike[str], index: int) -> TabulatedCRF:
    """Curve `index` (0-based) of the DoRF database (Columbia CAVE, 201 measured curves, B(I) on 1024 samples;
    Grossberg and Nayar 2003 [Grossberg2003]).

    Reads the MATLAB layout (.mat with arrays I and B, one curve per row, e.g. 201_CRF_data.mat) or the
    original text layout (dorfCurves.txt: per curve a name line, a channel line, "I =" then 1024 numbers,
    "B =" then 1024 numbers). Interior float ties are removed with break_ties().

    Parameters
    ----------
    path : str or os.PathLike
        The DoRF file (.mat, or the text layout).
    index : int
        The curve, 0-based; out of range raises CRFError.

    Returns
    -------
    TabulatedCRF
        The curve B(I), its source naming the file, the index and the curve's name.
    """
    path = Path(path)
    if not path.is_file():
        raise CRFError(f"DoRF file not found: {path}")
    if path.suffix.lower() == ".mat":
        try:
            import scipy.io  # (here: it takes a tenth of a second to import, and only .mat files need it)

            data = scipy.io.loadmat(path)
            I, B = np.atleast_2d(data["I"]), np.atleast_2d(data["B"])
        except (ValueError, KeyError, OSError) as exc:
            raise CRFError(f"{path} is not a DoRF .mat file with arrays I and B: {exc}") from exc
        names = [f"#{i}" for i in range(B.shape[0])]
    else:
        names, I, B = _parse_dorf_text(path)
    if not 0 <= index < len(names):
        raise CRFError(f"DoRF index {index} out of range: {path} holds {len(names)} curves")
    return TabulatedCRF(break_ties(B[index]), x=I[index], source=f"DoRF {path.name} [{index}] {names[index]}")


_NUMBER = re.compile(r"^[\s\d.eE+\-]+$")


def _parse_dorf_text(path: Path):
    """names, I rows, B rows of a dorfCurves.txt-style file."""
    names, rows_i, rows_b = [], [], []
    name, key, values = [], None, {"I": [], "B": []}

    def flush():
        if key is not None:
            if not values["I"] or not values["B"] or len(values["I"]) != len(values["B"]):
                raise CRFError(f"{path}: curve {' '.join(name)!r} lacks matching I and B tables")
            names.append(" ".join(name))
            rows_i.append(np.array(values["I"]))
            rows_b.append(np.array(values["B"]))

    for line in path.read_text().splitlines():
        head = re.match(r"^\s*([IB])\s*=(.*)$", line)
        if head:
            key, line = head.group(1), head.group(2)
        elif line.strip() and not _NUMBER.match(line):
            if key == "B":  # a name line after a complete curve starts the next one
                flush()
                name, key, values = [], None, {"I": [], "B": []}
            name.append(line.strip())
            continue
        if key is not None and line.strip():
            values[key].extend(float(v) for v in line.split())
    flush()
    if not names:
        raise CRFError(f"{path}: no DoRF curves found (expected 'I =' and 'B =' blocks)")
    return names, rows_i, rows_b


def load_emor(path: str | os.PathLike[str], coeffs: npt.ArrayLike = ()) -> TabulatedCRF:
    """The EMoR model f = f0 + sum_n coeffs[n] h_n (Grossberg and Nayar 2003 [Grossberg2003], 2004
    [Grossberg2004]) from emor.txt (blocks "E =", "f0 =", "h(1)=", ... of 1024 values), tabulated on E.

    Parameters
    ----------
    path : str or os.PathLike
        The emor.txt file.
    coeffs : array_like, optional
        The coefficients of the basis curves h(1), h(2), ...; at most as many as the file holds (default: none,
        the mean curve f0).

    Returns
    -------
    TabulatedCRF
        f clipped to [0, 1] with its ties broken, on the knots E.
    """
    path = Path(path)
    if not path.is_file():
        raise CRFError(f"EMoR file not found: {path}")
    blocks, key = {}, None
    for line in path.read_text().splitlines():
        head = re.match(r"^\s*([A-Za-z]\w*(?:\(\d+\))?)\s*=(.*)$", line)
        if head:
            key, line = head.group(1), head.group(2)
            blocks[key] = []
        if key is not None and line.strip():
            blocks[key].extend(float(v) for v in line.split())
    if "E" not in blocks or "f0" not in blocks:
        raise CRFError(f"{path} is not an EMoR file (blocks E and f0 missing)")
    coeffs = as_float_array(coeffs, "coeffs").ravel()
    basis = [np.array(blocks[f"h({n + 1})"]) for n in range(coeffs.size) if f"h({n + 1})" in blocks]
    if len(basis) < coeffs.size:
        raise CRFError(f"{path} has {len(basis)} basis curves, {coeffs.size} coefficients given")
    f = np.array(blocks["f0"]) + sum((c * h for c, h in zip(coeffs, basis)), np.zeros(len(blocks["f0"])))
    label = f"EMoR {path.name} coeffs={coeffs.tolist()}"
    return TabulatedCRF(break_ties(np.clip(f, 0.0, 1.0)), x=np.array(blocks["E"]), source=label)
