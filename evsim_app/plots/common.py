"""Shared plotting machinery: the lazy matplotlib import, the one tone-mapping operator, atomic figure saving,
and a recording prepared for reconstruction (CRF object, contrast thresholds, reference in the CRF's units).

Tone mapping (the only operator used in every figure): global Reinhard on luminance,
    Ls = KEY * I / Iw,   D = (Ls / (1 + Ls)) ** (1 / 2.2),
with KEY = 0.18 and Iw the log-average (geometric mean) of the HDR reference image, and the same Iw applied to
every panel of a figure, so equal radiance gives equal grey across panels.

References (full citations also in docs/models/references.md):

- Reinhard E, Stark M, Shirley P, Ferwerda J (2002). Photographic tone reproduction for digital images. ACM
  Transactions on Graphics 21(3):267-276 (SIGGRAPH 2002).
"""

from __future__ import annotations

import json
import types
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from generators.formats import load
from generators.formats.atomic import atomic_path
from generators.formats.recording import Recording, missing_part_error
from sim import EvsimInputError

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from numpy.typing import ArrayLike

    from crf_models import CRF

MATPLOTLIB_HINT = "matplotlib is not installed: pip install 'evsim[plot]'"
REINHARD_KEY = 0.18
DISPLAY_GAMMA = 2.2
ON_COLOUR, OFF_COLOUR = (0.84, 0.15, 0.16), (0.12, 0.47, 0.71)  # RGB: red ON, blue OFF in every figure


def read_json(path: Path, missing: str) -> Any:
    """The JSON content of the file `path`; EvsimInputError(missing) when there is no such file, one naming the
    file when it is not valid JSON text."""
    if not path.is_file():
        raise EvsimInputError(missing)
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise EvsimInputError(f"{path}: not valid JSON: {e}") from None


class PlotDependencyError(EvsimInputError):
    """An optional plotting dependency (matplotlib, ffmpeg) is missing; the message says how to get it."""


def pyplot() -> types.ModuleType:
    """matplotlib.pyplot on the non-interactive Agg backend; PlotDependencyError when matplotlib is missing."""
    try:
        import matplotlib
    except ImportError:
        raise PlotDependencyError(MATPLOTLIB_HINT) from None
    if not isinstance(matplotlib, types.ModuleType):  # colour-science installs a MagicMock when it is missing
        raise PlotDependencyError(MATPLOTLIB_HINT)
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Figure, path: str | Path) -> Path:
    """Save fig to path (format from the suffix, e.g. .png, .pdf, .svg) atomically, close it, return the path."""
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    plt = pyplot()
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format=fmt, dpi=fig.dpi, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


@dataclass(frozen=True)
class ToneMap:
    """Global Reinhard on luminance (see the module docstring): D = (s I / (1 + s I)) ** (1 / 2.2), s = KEY / Iw."""

    log_average: float

    @classmethod
    def from_reference(cls, image: ArrayLike, eps: float = 1e-6) -> ToneMap:
        """Iw = exp(mean(log(eps + I))) of the HDR reference image (linear, >= 0)."""
        img = np.asarray(image, np.float64)
        return cls(float(np.exp(np.mean(np.log(eps + np.clip(img, 0, None))))))

    def __call__(self, image) -> np.ndarray:
        """Display values in [0, 1] of a linear image (negative values count as 0)."""
        ls = REINHARD_KEY / self.log_average * np.clip(np.asarray(image, np.float64), 0, None)
        return (ls / (1 + ls)) ** (1 / DISPLAY_GAMMA)

    def describe(self) -> str:
        return (f"global Reinhard on luminance, key {REINHARD_KEY} over the reference's log-average "
                f"{self.log_average:.3g}, gamma 1/{DISPLAY_GAMMA}")


@dataclass
class Prepared:
    """A recording ready for akf (built with evsim_eval.evaluate's helpers, so plots and scores agree).

    crf: the recorded CRF object (linear when the layout records none). contrast: the nominal (on, off) thresholds
    given to the reconstructions (log units; the per-pixel maps would be an oracle). thresholds: (2, H, W) float64
    per-pixel ON / OFF thresholds for drawing the DVS reference level: the stored maps, else the nominal ones.
    to_x: factor from reference radiance to the CRF's scaled irradiance x of frame 0's exposure, or None when the
    recording has no reference or does not say how (then reference_x is None). leak_rate_hz: the recorded DVS leak
    rate given to the AKF (0 when unknown).
    """

    rec: Recording
    crf: CRF
    contrast: tuple[float, float]
    thresholds: np.ndarray
    to_x: float | None
    leak_rate_hz: float = 0.0

    @property
    def reference_x(self) -> np.ndarray | None:
        """(R, H, W) float64 reference in the CRF's scaled-irradiance units, or None."""
        if self.to_x is None:
            return None
        return self.rec.reference.astype(np.float64) * self.to_x

    def reconstruct_args(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, CRF]:
        """The positional arguments (events, frames, t_start, t_end, crf) shared by akf methods."""
        r = self.rec
        return r.events, r.frames, r.frame_t_start_us, r.frame_t_end_us, self.crf


def load_recording(path: str | Path) -> Recording:
    """generators.load(path), with a missing path reported as EvsimInputError naming it."""
    path = Path(path)
    if not path.exists():
        raise EvsimInputError(f"dataset not found: {path}")
    return load(path)


def prepare(rec: Recording, *, need_reference: bool = False) -> Prepared:
    """Check that rec has frames (and a reference in known units when asked) and derive what akf needs."""
    from evsim_eval.protocols import recording_contrast, recording_crf, recording_leak_rate, reference_to_x

    if rec.frames is None or rec.frames.shape[0] == 0:
        raise missing_part_error("the dataset has no LDR frames: this plot needs frames and events", rec, "frames")
    to_x = None
    if rec.reference is not None and rec.reference.shape[0]:
        try:
            to_x = reference_to_x(rec)
        except EvsimInputError:
            if need_reference:
                raise
    elif need_reference:
        raise missing_part_error("the dataset has no HDR reference frames: this plot compares against them", rec,
                                 "reference")
    contrast = recording_contrast(rec)
    maps = rec.threshold_maps
    if maps is None:
        maps = np.stack([np.full((rec.height, rec.width), c) for c in contrast])
    return Prepared(rec, recording_crf(rec)[0], contrast, np.asarray(maps, np.float64), to_x,
                    recording_leak_rate(rec))


def inner_reference_indices(rec: Recording) -> np.ndarray:
    """Indices of the reference frames strictly between the first and last frame's mid-exposure times (where
    every method has a frame on either side)."""
    t = rec.reference_t_us
    return np.flatnonzero((t > rec.frame_t_mid_us[0]) & (t < rec.frame_t_mid_us[-1]))


def default_time_us(rec: Recording) -> int:
    """The reference time nearest the middle of the frames (us), used when no time is given."""
    inner = inner_reference_indices(rec)
    if inner.size == 0:
        raise EvsimInputError("the dataset has no reference frame between its first and last LDR frame")
    mid = 0.5 * (rec.frame_t_mid_us[0] + rec.frame_t_mid_us[-1])
    t = rec.reference_t_us[inner]
    return int(t[np.argmin(np.abs(t - mid))])
