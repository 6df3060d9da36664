"""Validation and normalisation of the inputs shared by the AKF and the baselines (the API boundary)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

import crf_models
from sim.errors import EvsimInputError, InvalidParameterError, TimeOrderError, check_int, check_number, check_real_array
from sim.events import check_times_us, validate_events

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True)
class Inputs:
    """Validated inputs. Contrast maps are flat float64 (H*W,), log units, both > 0 (c_off is the OFF magnitude);
    gaps: (G, 2) int64 us [start, end) spans of missing events (sim.gaps), sorted and disjoint."""

    events: np.ndarray
    frames: np.ndarray
    t_start: np.ndarray
    t_end: np.ndarray
    tau: np.ndarray
    out_t: np.ndarray
    c_on: np.ndarray
    c_off: np.ndarray
    full_scale: int
    gaps: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))

    @property
    def shape(self) -> tuple[int, int]:
        return self.frames.shape[1], self.frames.shape[2]

    def exposure_gain(self, k: int) -> float:
        """T_0 / T_k: multiplies frame k's scaled irradiance so that all frames share frame 0's exposure units
        (1 when the exposure times are equal or zero)."""
        t0, tk = self.t_end[0] - self.t_start[0], self.t_end[k] - self.t_start[k]
        return float(t0) / float(tk) if t0 > 0 and tk > 0 else 1.0

    def response(self, k: int) -> npt.NDArray[np.float64]:
        """Frame k as normalised response y = DN / (2^bit_depth - 1), float64 (H, W)."""
        return self.frames[k].astype(np.float64) / self.full_scale


def as_crf(crf: crf_models.CRF | str) -> crf_models.CRF:
    """A crf_models curve from a curve object or a registered name ("window", "linear", ...: crf_models.get(name)
    with its default parameters)."""
    if isinstance(crf, str):
        try:
            return crf_models.get(crf)
        except crf_models.CRFError as e:
            raise InvalidParameterError(f"crf: {e}") from None
    if not (hasattr(crf, "inverse") and hasattr(crf, "variance")):
        raise InvalidParameterError(f"crf must be a crf_models curve or its name, got {type(crf).__name__}")
    return crf


def check_max_intensity(max_intensity: float | None) -> None:
    """The output bound of the log-domain methods (x units; None: unbounded) must be a finite number > 0."""
    if max_intensity is not None:
        check_number("max_intensity (x units, or None: unbounded)", max_intensity, positive=True)


def _times(a, name: str, n: int | None = None) -> np.ndarray:
    a = np.asarray(a)
    if a.ndim != 1 or (n is not None and a.shape[0] != n):
        length = "" if n is None else f" of length {n}"
        raise EvsimInputError(f"{name} must be one-dimensional{length}, got shape {a.shape}")
    return check_times_us(a, name)  # integer, no int64 wrap of uint64 >= 2**63, |t| <= 2**62 us


MAX_CONTRAST = 5.0  # log units: a factor e**5 (about 150) per event; real sensors use 0.1..1


def contrast_maps(contrast: npt.ArrayLike,
                  shape: tuple[int, int]) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Nominal contrast thresholds as flat (c_on, c_off) maps from a scalar, an (on, off) pair or a (2, H, W) array."""
    c = check_real_array("contrast", contrast, error=InvalidParameterError)
    n = shape[0] * shape[1]
    if c.ndim == 0:
        c_on = c_off = np.full(n, float(c))
    elif c.shape == (2,):
        c_on, c_off = np.full(n, c[0]), np.full(n, c[1])
    elif c.shape == (2, *shape):
        c_on, c_off = c[0].ravel().copy(), c[1].ravel().copy()
    else:
        raise InvalidParameterError(f"contrast must be a scalar, an (on, off) pair or a (2, {shape[0]}, {shape[1]}) "
                                    f"array, got shape {c.shape}")
    if not (np.all(np.isfinite(c_on)) and np.all(np.isfinite(c_off)) and c_on.min() > 0 and c_off.min() > 0
            and max(c_on.max(), c_off.max()) <= MAX_CONTRAST):
        raise InvalidParameterError(f"contrast thresholds must be finite, > 0 and <= {MAX_CONTRAST:g} (log units; "
                                    "give the OFF threshold as a magnitude)")
    return c_on, c_off


def validate_inputs(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                    frame_t_end_us: npt.ArrayLike, output_times_us: npt.ArrayLike, contrast: npt.ArrayLike,
                    bit_depth: int) -> Inputs:
    """Check everything at the boundary and return normalised arrays (raises sim.errors subclasses naming the
    problem)."""
    events = validate_events(events)
    frames = np.asarray(frames)
    if frames.ndim != 3 or frames.shape[0] < 1:
        raise EvsimInputError(f"frames must be an (N, H, W) array with N >= 1, got shape {frames.shape}")
    if not np.issubdtype(frames.dtype, np.unsignedinteger):
        raise EvsimInputError(f"frames must be unsigned integer raw responses, got dtype {frames.dtype}")
    check_int("bit_depth", bit_depth, minimum=1, maximum=16)
    full_scale = (1 << int(bit_depth)) - 1
    if frames.size and int(frames.max()) > full_scale:
        raise EvsimInputError(f"frames contain {int(frames.max())} > {full_scale}, the maximum of "
                              f"bit_depth={bit_depth}")
    nf, h, w = frames.shape
    ts = _times(frame_t_start_us, "frame_t_start_us", nf)
    te = _times(frame_t_end_us, "frame_t_end_us", nf)
    if np.any(te < ts):
        k = int(np.flatnonzero(te < ts)[0])
        raise TimeOrderError(f"frame {k}: exposure end {te[k]} us is before its start {ts[k]} us")
    if nf > 1 and np.any(ts[1:] < te[:-1]):
        k = int(np.flatnonzero(ts[1:] < te[:-1])[0])
        raise TimeOrderError(f"frame {k + 1} starts at {ts[k + 1]} us, before frame {k} ends at {te[k]} us")
    tau = (ts + te) / 2.0
    if nf > 1 and np.any(np.diff(tau) <= 0):
        raise TimeOrderError("frame mid-exposure times must be strictly increasing")
    out_t = _times(output_times_us, "output_times_us")
    if out_t.size and np.any(np.diff(out_t) < 0):
        raise TimeOrderError("output_times_us must be non-decreasing")
    if out_t.size and out_t[0] < ts[0]:
        raise TimeOrderError(f"output time {out_t[0]} us is before the first exposure starts ({ts[0]} us)")
    if events.size and (int(events["x"].max()) >= w or int(events["y"].max()) >= h):
        raise EvsimInputError(f"event coordinates exceed the frame size {w}x{h} (W x H)")
    c_on, c_off = contrast_maps(contrast, (h, w))
    return Inputs(events, frames, ts, te, tau, out_t, c_on, c_off, full_scale)
