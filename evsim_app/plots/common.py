"""Shared plotting machinery: the lazy matplotlib import, the one tone-mapping operator, atomic figure saving,
and a recording prepared for reconstruction (CRF object, contrast thresholds, reference in the CRF's units).

Tone mapping (the only operator used for every HDR image in every figure): a global logarithmic map,
    D = clip(log(max(I, f) / f) / log(T / f), 0, 1),
from a floor f to a top T (both in x, the CRF's scaled irradiance, x = 1 the full well), shared by every panel of a
figure and drawn as grey levels, so equal radiance gives equal grey across panels and equal ratios give equal grey
steps anywhere in the range. T is the HDR reference's 99.9th percentile (a few hot pixels do not compress the rest);
f is the reference's 1st percentile, but not below 1e-3 of the frames' top CRF^-1(1) (nor of T when the frames'
top is not given), which keeps a black or zero-padded reference from spending the grey range on noise. The range
holds reconstructions far above the frames' clip (hundreds of x on real HDR photos, where the frames stop at about
0.36 x with the AHDR window CRF) as well as shadows below the frames' floor. It is the plain form of Drago et al.'s
adaptive logarithmic mapping, without its bias curve: a reconstruction error of a given ratio then looks the same
in highlights and in shadows, which is what the figures compare. Global Reinhard (Reinhard et al. 2002), used
before, maps everything above about 10 x the reference's log-average into the top few grey levels, so the highlight
detail the events recover was invisible.

References (docs/models/references.md): Drago et al. 2003 [Drago2003], the global log map; Reinhard et al. 2002
[Reinhard2002], the tone map before issue 33.
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
TONE_LOW_PERCENTILE = 1.0  # the tone map's floor: this percentile of the reference (see ToneMap.from_reference)
TONE_HIGH_PERCENTILE = 99.9  # the tone map's top: this percentile of the reference
TONE_FLOOR_RATIO = 1e-3  # the floor is at least this fraction of the frames' top CRF^-1(1)
TONE_MIN_RANGE = 10.0  # the top is at least this factor above the floor
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
    """Global logarithmic tone map from `floor` to `top` (x units, 0 < floor < top; see the module docstring).

    Parameters
    ----------
    floor : float
        Radiance (x) shown black; anything darker is shown black too.
    top : float
        Radiance (x) shown white; anything brighter is shown white too (no bound on the images given).

    References
    ----------
    Drago F, Myszkowski K, Annen T, Chiba N (2003). Adaptive logarithmic mapping for displaying high contrast
    scenes. Computer Graphics Forum 22(3):419-426 (its mapping without the bias curve).
    """

    floor: float
    top: float

    def __post_init__(self):
        if not (np.isfinite(self.floor) and np.isfinite(self.top) and 0 < self.floor < self.top):
            raise EvsimInputError(f"tone map: need 0 < floor < top (x units), got floor {self.floor!r}, "
                                  f"top {self.top!r}")

    @classmethod
    def from_reference(cls, reference: ArrayLike, frames_top: float | None = None) -> ToneMap:
        """The tone map of one figure, from its HDR reference image (linear x, any range).

        Parameters
        ----------
        reference : array_like
            The HDR reference image (x units); values <= 0 count as black.
        frames_top : float, optional
            The frames' top CRF^-1(1) (x units); the floor is at least TONE_FLOOR_RATIO of it (default: of the top).

        Returns
        -------
        ToneMap
            top = the reference's TONE_HIGH_PERCENTILE-th percentile, floor = its TONE_LOW_PERCENTILE-th percentile
            but at least TONE_FLOOR_RATIO * frames_top; top is raised to TONE_MIN_RANGE * floor when the reference
            is flatter than that (a uniform image).

        Raises
        ------
        EvsimInputError
            When the reference has no positive value and no frames_top is given (nothing sets the scale).
        """
        img = np.asarray(reference, np.float64)
        lo, hi = np.percentile(img, [TONE_LOW_PERCENTILE, TONE_HIGH_PERCENTILE])
        floor = max(float(lo), TONE_FLOOR_RATIO * float(hi if frames_top is None else frames_top))
        if not floor > 0:
            raise EvsimInputError("tone map: the reference image has no positive value to scale the display to")
        return cls(floor, max(float(hi), TONE_MIN_RANGE * floor))

    def __call__(self, image: ArrayLike) -> np.ndarray:
        """Display values in [0, 1] (0 black at or below floor, 1 white at or above top) of a linear image (x)."""
        return np.clip(self.log(image) / np.log(self.top / self.floor), 0.0, 1.0)

    def log(self, image: ArrayLike) -> np.ndarray:
        """log(max(I, floor) / floor) of a linear image (x): natural log units above the floor.

        Parameters
        ----------
        image : array_like
            Linear intensity (x units).

        Returns
        -------
        numpy.ndarray
            float64 log values (natural log units), >= 0, of image's shape.
        """
        return np.log(np.maximum(np.asarray(image, np.float64), self.floor) / self.floor)

    def log_error(self, image: ArrayLike, reference: ArrayLike) -> np.ndarray:
        """log(max(I, floor)) - log(max(R, floor)), natural log units: > 0 where the image is brighter than the
        reference (0.69 is a factor 2), 0 where both are at or below the floor.

        Parameters
        ----------
        image, reference : array_like
            Linear intensities (x units) of one shape.

        Returns
        -------
        numpy.ndarray
            float64 log errors (natural log units).
        """
        return self.log(image) - self.log(reference)

    def describe(self) -> str:
        """One line for figure titles and command output: the operator and its range in x.

        Returns
        -------
        str
            The description.
        """
        return (f"global log map from {self.floor:.3g} x (black) to {self.top:.3g} x (white), "
                f"{np.log10(self.top / self.floor):.1f} decades")


@dataclass
class Prepared:
    """A recording ready for akf (built with evsim_eval.evaluate's helpers, so plots and scores agree).

    Attributes
    ----------
    rec : Recording
        The recording.
    crf : CRF
        The recorded CRF object (linear when the layout records none).
    contrast : tuple of float
        The nominal (on, off) thresholds given to the reconstructions (log units; the per-pixel maps would be an
        oracle).
    thresholds : numpy.ndarray
        (2, H, W) float64 per-pixel ON / OFF thresholds for drawing the DVS reference level: the stored maps, else the
        nominal ones.
    to_x : float or None
        Factor from reference radiance to the CRF's scaled irradiance x of frame 0's exposure, or None when the
        recording has no reference or does not say how (then reference_x is None).
    leak_rate_hz : float
        The recorded DVS leak rate given to the AKF (Hz; 0 when unknown).
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

    def frames_range(self) -> tuple[np.ndarray, np.ndarray]:
        """(F,) float64 lowest and highest radiance (x) each frame records: CRF^-1(0) and CRF^-1(1) times T_0 / T_k,
        frame 0's exposure time over frame k's (x is in frame 0's units); outside it the frame is clipped.

        Returns
        -------
        lo, hi : numpy.ndarray
            (F,) float64, x units.
        """
        from evsim_eval.scoring import exposure_gains

        gain = exposure_gains(self.rec.frame_t_start_us, self.rec.frame_t_end_us)
        return float(self.crf.inverse(0.0)) * gain, float(self.crf.inverse(1.0)) * gain

    def reconstruct_args(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, CRF]:
        """The positional arguments (events, frames, t_start, t_end, crf) shared by akf methods.

        Returns
        -------
        tuple
            (events, frames, frame_t_start_us, frame_t_end_us, crf).
        """
        r = self.rec
        return r.events, r.frames, r.frame_t_start_us, r.frame_t_end_us, self.crf


def load_recording(path: str | Path) -> Recording:
    """generators.load(path), with a missing path reported as EvsimInputError naming it.

    Parameters
    ----------
    path : str or pathlib.Path
        A recording file or folder.

    Returns
    -------
    Recording
        The recording.
    """
    path = Path(path)
    if not path.exists():
        raise EvsimInputError(f"dataset not found: {path}")
    return load(path)


def prepare(rec: Recording, *, need_reference: bool = False) -> Prepared:
    """Check that rec has frames (and a reference in known units when asked) and derive what akf needs.

    Parameters
    ----------
    rec : Recording
        The recording.
    need_reference : bool, optional
        Require HDR reference frames in known units (default False).

    Returns
    -------
    Prepared
        The recording with its CRF, thresholds and reference scale.
    """
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
    every method has a frame on either side).

    Parameters
    ----------
    rec : Recording
        The recording.

    Returns
    -------
    numpy.ndarray
        The indices.
    """
    t = rec.reference_t_us
    return np.flatnonzero((t > rec.frame_t_mid_us[0]) & (t < rec.frame_t_mid_us[-1]))


def default_time_us(rec: Recording) -> int:
    """The reference time nearest the middle of the frames (us), used when no time is given.

    Parameters
    ----------
    rec : Recording
        The recording.

    Returns
    -------
    int
        The time, int64 us.
    """
    inner = inner_reference_indices(rec)
    if inner.size == 0:
        raise EvsimInputError("the dataset has no reference frame between its first and last LDR frame")
    mid = 0.5 * (rec.frame_t_mid_us[0] + rec.frame_t_mid_us[-1])
    t = rec.reference_t_us[inner]
    return int(t[np.argmin(np.abs(t - mid))])
