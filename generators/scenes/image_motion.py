"""A still HDR image under continuous camera motion (pan, zoom, rotation, hand-held shake).

The output image at time t samples the source image through a homography H(t) that maps output pixel coordinates
to source pixel coordinates (cv2.warpPerspective, or the equivalent warpAffine when bilinear and H is affine, with
WARP_INVERSE_MAP, bilinear or bicubic interpolation, a reflective or constant border). Loading: OpenEXR (.exr, the
OpenEXR File API), Radiance (.hdr/.pic, OpenCV), numpy (.npy), or an LDR image (.png, .jpg, .tif, ...) linearised
through an inverse CRF from crf_models.
Colour is reduced to luminance (see luminance.py) unless a channel is selected.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from sim import EvsimInputError, InvalidParameterError, OptionError
from sim.errors import check_int

from ..formats.common import quiet_native_output
from .base import Scene, level, number, numbers, positive
from .luminance import to_luminance

_INTERPOLATION = {"linear": cv2.INTER_LINEAR, "cubic": cv2.INTER_CUBIC}
_BORDER = {"reflect": cv2.BORDER_REFLECT_101, "constant": cv2.BORDER_CONSTANT}
# Hand-held shake: three sinusoids per axis at these multiples of shake_hz, with these relative amplitudes.
_SHAKE_HARMONICS = np.array([1.0, 1.7, 2.9])
_SHAKE_WEIGHTS = np.array([1.0, 0.5, 0.25])
# Prefiltered rendering under zoom: box filters for footprints 2**(1/48) (1.5 %) apart, the nearest one used (the
# image then changes by a small fraction of a DVS threshold when the level changes).
_LEVELS_PER_OCTAVE = 48
#: the largest zoom in over a sequence, as a log magnification (e^50, about 5e21 x: far past any use, far inside
#: float64's range; the maths fails near e^700). Zooming out is bounded by the image: see ImageMotionScene.
MAX_LOG_ZOOM_IN = 50.0
#: the farthest the view may travel over a sequence (pan) or swing (shake amplitude), in output pixels: 1e8 was
#: measured to render, 1e11 does not (OpenCV's warp coordinates)
MAX_TRAVEL_PX = 1e7


@dataclass(frozen=True)
class Trajectory:
    """A smooth camera motion, as seen in the output image.

    Hand-held shake is a sum of three sinusoids per axis at shake_hz * (1, 1.7, 2.9) with relative amplitudes
    (1, 0.5, 0.25) and phases drawn from shake_seed.

    Attributes
    ----------
    pan_px_per_s : tuple of float
        (vx, vy) velocity of the view over the source (output pixels per second; the content moves the opposite
        way). Default (0, 0).
    zoom_per_s : float
        Magnification rate (1/s): magnification(t) = exp(zoom_per_s * t), t in seconds; > 0 zooms in. Default 0.
    rotation_deg_per_s : float
        Rotation of the view about the image centre (degrees per second). Default 0.
    shake_px, shake_deg : float
        Amplitudes of hand-held shake in translation (output pixels) and rotation (degrees), >= 0. Default 0.
    shake_hz : float
        The shake's base frequency (Hz, > 0). Default 2.
    shake_seed : int
        Seed of the shake's phases (>= 0). Default 0.
    """

    pan_px_per_s: tuple[float, float] = (0.0, 0.0)
    zoom_per_s: float = 0.0
    rotation_deg_per_s: float = 0.0
    shake_px: float = 0.0
    shake_deg: float = 0.0
    shake_hz: float = 2.0
    shake_seed: int = 0

    def __post_init__(self):
        object.__setattr__(self, "pan_px_per_s", numbers("pan_px_per_s", self.pan_px_per_s, "Trajectory"))
        for name in ("zoom_per_s", "rotation_deg_per_s"):
            object.__setattr__(self, name, number(name, getattr(self, name), "Trajectory"))
        for name in ("shake_px", "shake_deg", "shake_hz"):
            object.__setattr__(self, name, positive(name, getattr(self, name), "Trajectory",
                                                    allow_zero=name != "shake_hz"))
        object.__setattr__(self, "shake_seed", check_int("Trajectory: shake_seed", self.shake_seed, minimum=0))
        phases = np.random.default_rng(self.shake_seed).uniform(0, 2 * np.pi, size=(3, 3))
        object.__setattr__(self, "_phases", phases)

    def _shake(self, t_s: float) -> np.ndarray:
        """(dx px, dy px, dtheta deg) of the shake at t_s seconds."""
        w = 2 * np.pi * self.shake_hz * _SHAKE_HARMONICS
        s = (_SHAKE_WEIGHTS[None, :] * np.sin(w[None, :] * t_s + self._phases)).sum(axis=1)
        return s * np.array([self.shake_px, self.shake_px, self.shake_deg])

    def homography(self, t_us: int, out_size: tuple[int, int], src_centre: tuple[float, float],
                   scale: float) -> np.ndarray:
        """The matrix mapping output (x, y, 1) to source coordinates at a time.

        Parameters
        ----------
        t_us : int
            Scene time (us).
        out_size : tuple of int
            (height, width) of the output (pixels).
        src_centre : tuple of float
            (x, y) source point shown at the output centre at t = 0 (source pixels).
        scale : float
            Source pixels per output pixel at t = 0.

        Returns
        -------
        numpy.ndarray
            float64 (3, 3) homography, output pixel coordinates -> source pixel coordinates.
        """
        t = t_us * 1e-6
        dx, dy, dtheta = self._shake(t)
        theta = math.radians(self.rotation_deg_per_s * t + dtheta)
        s = scale * math.exp(-self.zoom_per_s * t)
        c, si = math.cos(theta), math.sin(theta)
        cx_out, cy_out = (out_size[1] - 1) / 2, (out_size[0] - 1) / 2
        tx = src_centre[0] + scale * (self.pan_px_per_s[0] * t + dx)
        ty = src_centre[1] + scale * (self.pan_px_per_s[1] * t + dy)
        a = s * np.array([[c, -si], [si, c]])
        m = np.eye(3)
        m[:2, :2] = a
        m[:2, 2] = np.array([tx, ty]) - a @ np.array([cx_out, cy_out])
        return m

    def max_speed_px_per_s(self, out_size: tuple[int, int], duration_us: int) -> float:
        """Upper bound of the image-plane speed over a duration.

        Parameters
        ----------
        out_size : tuple of int
            (height, width) of the output (pixels).
        duration_us : int
            The motion is bounded over [0, duration_us] (us).

        Returns
        -------
        float
            The bound (output pixels per second).
        """
        r = math.hypot(out_size[0], out_size[1]) / 2
        w = 2 * np.pi * self.shake_hz * _SHAKE_HARMONICS
        shake_v = float((_SHAKE_WEIGHTS * w).sum())
        mag = math.exp(abs(self.zoom_per_s) * duration_us * 1e-6)
        trans = math.hypot(*self.pan_px_per_s) + math.sqrt(2) * self.shake_px * shake_v
        rot = math.radians(abs(self.rotation_deg_per_s) + self.shake_deg * shake_v)
        return mag * trans + (abs(self.zoom_per_s) + rot) * r

    def describe(self) -> dict:
        """JSON-serialisable description, recorded in the metadata.

        Returns
        -------
        dict
            The fields by name (units as the Attributes), pan_px_per_s as a list.
        """
        d = asdict(self)
        d["pan_px_per_s"] = list(self.pan_px_per_s)
        return d


def load_image(path: str | Path, *, channel: str | int | None = None, crf: str | object = "srgb",
               crf_params: dict | None = None) -> np.ndarray:
    """Load an image as linear luminance (or the selected channel).

    .exr (OpenEXR), .hdr/.pic (Radiance) and .npy are taken as linear radiance. Any other format OpenCV reads is an
    LDR image: its values are normalised to [0, 1] by the integer type's maximum and linearised with the inverse of
    `crf`.

    Parameters
    ----------
    path : str or Path
        The image file.
    channel : str or int, optional
        As to_luminance's: None (default) for Rec. 709 luminance, or "R"/"G"/"B"/an index.
    crf : str or object, optional
        For LDR images: a crf_models name (default "srgb"), built with crf_params, or an object with an
        inverse(response) method.
    crf_params : dict, optional
        Parameters of the named CRF.

    Returns
    -------
    numpy.ndarray
        float32 (H, W) linear luminance (the file's radiance units; an LDR image's in the CRF's linear units), >= 0.
    """
    path = Path(path)
    if not path.is_file():
        raise EvsimInputError(f"image file not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".exr":
        img = _read_exr(path)
    elif suffix in (".hdr", ".pic"):
        with quiet_native_output():  # OpenCV's own complaints about a corrupt file: evsim's line says it
            img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if img is None:
            raise EvsimInputError(f"cannot read Radiance image {path}")
        img = img[..., ::-1] if img.ndim == 3 else img
    elif suffix == ".npy":
        try:
            img = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as e:  # not .npy, truncated, or an object array (pickles refused)
            raise EvsimInputError(f"cannot read {path} as a numpy array: {e}") from None
    else:
        with quiet_native_output():
            raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if raw is None:
            raise EvsimInputError(f"cannot read image {path} (supported: .exr, .hdr, .npy and OpenCV's LDR formats)")
        if raw.ndim == 3:
            raw = raw[..., :3][..., ::-1]
        img = linearise_ldr(raw, crf, crf_params)
    try:
        return to_luminance(img, channel)
    except EvsimInputError as e:
        raise EvsimInputError(f"{path}: {e}") from None


def _read_exr(path: Path) -> np.ndarray:
    import OpenEXR

    try:
        with quiet_native_output():  # the binding prints its decoder's warnings (on stdout)
            channels = OpenEXR.File(str(path)).channels()
            for key in ("RGB", "RGBA"):
                if key in channels:
                    return np.asarray(channels[key].pixels)[..., :3]
            if all(k in channels for k in "RGB"):
                return np.stack([np.asarray(channels[k].pixels) for k in "RGB"], axis=-1)
            if "Y" in channels:
                return np.asarray(channels["Y"].pixels)
    except Exception as e:  # the OpenEXR binding raises plain exceptions for unreadable files
        raise EvsimInputError(f"cannot read OpenEXR file {path}: {e}") from None
    raise EvsimInputError(f"OpenEXR file {path} has no RGB, RGBA or Y channels (has {sorted(channels)})")


def linearise_ldr(image: np.ndarray, crf: str | object = "srgb", crf_params: dict | None = None) -> np.ndarray:
    """Linearise an integer LDR image (any channels) with the inverse CRF.

    Parameters
    ----------
    image : numpy.ndarray
        Integer image (any shape); its values are normalised to [0, 1] by the dtype's maximum.
    crf, crf_params
        As load_image's.

    Returns
    -------
    numpy.ndarray
        float32 linear values of the same shape, in the CRF's linear units.
    """
    img = np.asarray(image)
    if not np.issubdtype(img.dtype, np.integer):
        raise EvsimInputError(f"an LDR image must have an integer dtype, got {img.dtype}")
    if isinstance(crf, str):
        import crf_models

        try:
            crf = crf_models.get(crf, **(crf_params or {}))
        except crf_models.CRFError as e:
            raise InvalidParameterError(str(e)) from None
    response = img.astype(np.float64) / np.iinfo(img.dtype).max
    return np.asarray(crf.inverse(response), dtype=np.float32)


def _box_taps(width: float) -> np.ndarray:
    """1-D taps of a centred box of `width` pixels (>= 1) on the pixel grid: each tap weighted by its overlap."""
    half = width / 2
    n = math.ceil(half - 0.5 - 1e-9)
    offsets = np.arange(-n, n + 1, dtype=np.float64)
    taps = np.clip(np.minimum(offsets + 0.5, half) - np.maximum(offsets - 0.5, -half), 0.0, None)
    return taps / taps.sum()


def _box_taps_with_variance(variance: float) -> np.ndarray:
    """The _box_taps whose variance (pixels squared) is `variance` (bisection on the width; [1] for <= 0)."""
    def var(w):
        t = _box_taps(w)
        m = np.arange(t.size) - t.size // 2
        return float((t * m * m).sum())

    lo, hi = 1.0, 2 * math.sqrt(3 * max(variance, 0.0)) + 3
    if variance <= 0:
        return np.ones(1)
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if var(mid) < variance else (lo, mid)
    return _box_taps((lo + hi) / 2)


class ImageMotionScene(Scene):
    """A still linear image seen by a moving camera.

    When scale > 1 the source has detail finer than an
    output pixel, and each output pixel integrates the image over its area: the warp renders a grid `supersample`
    times finer in each axis, which is then area-averaged (the source is first area-reduced to at most `supersample`
    source pixels per output pixel, so the warp never decimates, which would alias). Point-sampling a source reduced
    to one pixel per output pixel would instead give every pixel the same sub-pixel phase under a pan, and the
    image-wide rate of log change (the DVS event rate) would pulse each time the view moves by one pixel.
    prefilter (default True): bilinear affine views (pans, zooms, rotations, shake) get the same integration from one
    warp straight to the output grid: the source (area-reduced, or enlarged bilinearly, to `supersample` pixels per
    output pixel) is filtered once per zoom level with a separable box whose variance matches the fine grid's
    average (less the warp's own bilinear blur when enlarged). For a pan of an area-reduced source this is the fine
    grid's image exactly; on the built-in photos and Desk.exr at 346x260 it gives the fine grid's event count
    within 0.2 % at about a tenth of the rendering cost. False, cubic interpolation and perspective views render
    the fine grid.

    Parameters
    ----------
    image : numpy.ndarray
        (H, W) linear radiance (radiance units), or (H, W, C) colour, reduced with `channel` as in to_luminance.
    duration_us : int
        Duration (us), >= 1.
    trajectory : Trajectory, optional
        The camera motion (default Trajectory(): none).
    height, width : int, optional
        Output size (pixels; default: the source size).
    scale : float, optional
        Source pixels per output pixel at t = 0 (default: the largest view that fits inside the source).
    channel : str or int, optional
        As to_luminance's.
    interpolation : {"linear", "cubic"}, optional
        Bilinear (default) or bicubic (negative overshoots are clipped to 0).
    border : {"reflect", "constant"}, optional
        Mirror without repeating the edge pixel (default), or border_value.
    border_value : float, optional
        Radiance outside the image with border "constant" (radiance units, >= 0; default 0).
    gain : float, optional
        Factor applied to the image's radiance (dimensionless, > 0; default 1).
    supersample : int, optional
        Fine-grid factor per axis when scale > 1 (>= 1; default 3).
    prefilter : bool, optional
        Render bilinear affine views from a box-filtered source (default True).
    name : str, optional
        The image's name in describe() (e.g. its path).
    """

    def __init__(self, image: np.ndarray, duration_us: int, trajectory: Trajectory | None = None, *,
                 height: int | None = None, width: int | None = None, scale: float | None = None,
                 channel: str | int | None = None, interpolation: str = "linear", border: str = "reflect",
                 border_value: float = 0.0, gain: float = 1.0, supersample: int = 3, prefilter: bool = True,
                 name: str | None = None):
        src = to_luminance(image, channel)
        sh, sw = src.shape
        height = sh if height is None else height
        width = sw if width is None else width
        self._init_size(height, width, duration_us)
        if interpolation not in _INTERPOLATION:
            raise InvalidParameterError(f"ImageMotionScene: interpolation must be one of {sorted(_INTERPOLATION)}, "
                                        f"got {interpolation!r}")
        if border not in _BORDER:
            raise InvalidParameterError(f"ImageMotionScene: border must be one of {sorted(_BORDER)}, got {border!r}")
        self.trajectory = trajectory or Trajectory()
        self.interpolation, self.border = interpolation, border
        self.border_value = level("border_value", border_value, "ImageMotionScene", allow_zero=True)
        self.gain = level("gain", gain, "ImageMotionScene")
        self.name = name
        scale = (min(sh / self.height, sw / self.width) if scale is None
                 else positive("scale", scale, "ImageMotionScene"))
        supersample = check_int("ImageMotionScene: supersample", supersample, minimum=1)
        if not isinstance(prefilter, (bool, np.bool_)):
            raise InvalidParameterError(f"ImageMotionScene: prefilter must be a bool, got {prefilter!r}")
        if trajectory is not None and not isinstance(trajectory, Trajectory):
            raise InvalidParameterError(f"ImageMotionScene: trajectory must be a Trajectory, got "
                                        f"{type(trajectory).__name__}")
        self._check_motion(max(sh, sw) / scale)
        self.scale = scale
        self.supersample = int(supersample) if scale > 1 else 1
        self.prefilter = bool(prefilter)
        if scale > self.supersample:
            nw, nh = max(1, round(sw * self.supersample / scale)), max(1, round(sh * self.supersample / scale))
            src = cv2.resize(src, (nw, nh), interpolation=cv2.INTER_AREA)
            scale = scale * nw / sw
            sh, sw = nh, nw
        self._src = src * np.float32(self.gain)
        # The homography maps to view units: _unit source pixels each, so that when scale > 1 the view has one unit
        # per output pixel at t=0 whatever the supersampling.
        self._unit = scale if scale > 1 else 1.0
        self._src_scale = scale / self._unit
        self._src_centre = ((sw / self._unit - 1) / 2, (sh / self._unit - 1) / 2)
        # The prefiltered path (_render_prefiltered) warps a working copy of the source with about `supersample`
        # pixels per output pixel: the source itself when it was area-reduced to that, else the source enlarged
        # bilinearly (the samples the supersampled grid would take at t=0). _to_work maps source to working pixels.
        self._work, self._to_work, self._footprint0 = self._src, np.eye(3), scale
        self._enlarged = 1 < scale < self.supersample
        if self._enlarged:
            nw, nh = round(sw * self.supersample / scale), round(sh * self.supersample / scale)
            self._work = cv2.resize(self._src, (nw, nh), interpolation=cv2.INTER_LINEAR)
            rx, ry = nw / sw, nh / sh
            self._to_work = np.array([[rx, 0, (rx - 1) / 2], [0, ry, (ry - 1) / 2], [0, 0, 1]])
            self._footprint0 = scale * math.sqrt(rx * ry)
        self._filtered = {}  # box-filtered working sources by footprint level (see _render_prefiltered)

    def _check_motion(self, fit_px: float) -> None:
        """sim.OptionError naming the parameter (as a keyword, and as the flag of `evsim generate ahdr --image`)
        and the range that works when the trajectory leaves what can be rendered over the duration: a zoom in past
        e^MAX_LOG_ZOOM_IN, a zoom out past the point where the whole image lies within one output pixel (2 x fit_px,
        the image's larger side in output pixels at t=0: the box prefilter would then grow without end), a pan
        travel or a shake amplitude over MAX_TRAVEL_PX."""
        tr, seconds = self.trajectory, self.duration_us * 1e-6
        log_zoom = tr.zoom_per_s * seconds
        out_limit = math.log(max(2 * fit_px, 1.0))
        if log_zoom > MAX_LOG_ZOOM_IN or -log_zoom > out_limit:
            why = (f"over {seconds:g} s magnifies by e^{log_zoom:.4g}: zooming in works up to e^{MAX_LOG_ZOOM_IN:g}"
                   f" and out, for this image and size, up to e^-{out_limit:.3g} (beyond, the whole image lies "
                   f"within one pixel), so it must be in {-out_limit / seconds:.4g}..{MAX_LOG_ZOOM_IN / seconds:.4g}"
                   " per second")
            raise OptionError(f"ImageMotionScene: trajectory zoom_per_s {tr.zoom_per_s:g} {why}",
                              f"--zoom {tr.zoom_per_s:g} (trajectory.zoom_per_s) {why}")
        travel = math.hypot(*tr.pan_px_per_s) * seconds
        if travel > MAX_TRAVEL_PX or tr.shake_px > MAX_TRAVEL_PX:
            why = (f"over {seconds:g} s the view travels {travel:.3g} output pixels, with a shake of "
                   f"{tr.shake_px:g} pixels: each must be at most {MAX_TRAVEL_PX:g} pixels")
            raise OptionError(f"ImageMotionScene: trajectory pan_px_per_s {list(tr.pan_px_per_s)} and shake_px: {why}",
                              f"--pan {' '.join(f'{v:g}' for v in tr.pan_px_per_s)} and --shake-px "
                              f"(trajectory.pan_px_per_s, shake_px): {why}")

    @classmethod
    def from_file(cls, path: str | Path, duration_us: int, trajectory: Trajectory | None = None, *,
                  channel: str | int | None = None, crf: str | object = "srgb", crf_params: dict | None = None,
                  **kwargs: Any) -> ImageMotionScene:
        """Build from an image file (see load_image).

        Parameters
        ----------
        path : str or Path
            The image file.
        duration_us, trajectory
            As the constructor's.
        channel, crf, crf_params
            As load_image's.
        **kwargs
            The constructor's other keywords (name defaults to the path).

        Returns
        -------
        ImageMotionScene
            The scene.
        """
        img = load_image(path, channel=channel, crf=crf, crf_params=crf_params)
        return cls(img, duration_us, trajectory, name=kwargs.pop("name", str(path)), **kwargs)

    def homography(self, t_us: int) -> np.ndarray:
        """The output-to-source homography at a time.

        Parameters
        ----------
        t_us : int
            Scene time (us).

        Returns
        -------
        numpy.ndarray
            float64 (3, 3) matrix, output pixel coordinates -> source coordinates in view units: pixels of the
            source when scale <= 1, else of the source area-reduced to one pixel per output pixel at t = 0.
        """
        return self.trajectory.homography(t_us, (self.height, self.width), self._src_centre, self._src_scale)

    def _render(self, t_us):
        k, u = self.supersample, self._unit
        view_to_src = np.array([[u, 0, (u - 1) / 2], [0, u, (u - 1) / 2], [0, 0, 1]])
        m = view_to_src @ self.homography(t_us)  # output pixel -> source pixel (pixel centres at integers)
        if k > 1 and self.prefilter and self.interpolation == "linear" and np.array_equal(m[2], [0.0, 0.0, 1.0]):
            return self._render_prefiltered((self._to_work @ m)[:2])
        # fine grid -> output pixels
        fine_to_out = np.array([[1 / k, 0, (1 - k) / (2 * k)], [0, 1 / k, (1 - k) / (2 * k)], [0, 0, 1]])
        m = m @ fine_to_out
        # pans, zooms, rotations and shake are affine: bilinear warpAffine gives the same image as warpPerspective
        affine = self.interpolation == "linear" and np.array_equal(m[2], [0.0, 0.0, 1.0])
        warp, m = (cv2.warpAffine, m[:2]) if affine else (cv2.warpPerspective, m)
        img = warp(self._src, m, (k * self.width, k * self.height),
                   flags=_INTERPOLATION[self.interpolation] | cv2.WARP_INVERSE_MAP,
                   borderMode=_BORDER[self.border], borderValue=self.border_value * self.gain)
        if self.interpolation == "cubic":
            np.maximum(img, 0.0, out=img)
        return img if k == 1 else cv2.resize(img, (self.width, self.height), interpolation=cv2.INTER_AREA)

    def _render_prefiltered(self, m: np.ndarray) -> np.ndarray:
        """Bilinear, affine views: one warp straight to the output grid from the source box-filtered over an
        output pixel's footprint (about 9x cheaper than a 3x grid). For a pan of a source of k pixels per output
        pixel this equals the k x k grid's area average exactly (bilinear interpolation commutes with whole-pixel
        shifts); under zoom the footprint is rounded to the nearest of _LEVELS_PER_OCTAVE levels per octave."""
        footprint = math.sqrt(abs(m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]))  # source pixels per output pixel
        return self._warp_level(round(_LEVELS_PER_OCTAVE * math.log2(footprint / self._footprint0)), m)

    def _warp_level(self, level: int, m: np.ndarray) -> np.ndarray:
        src = self._filtered.get(level)
        if src is None:
            if len(self._filtered) >= 4:
                self._filtered.clear()
            # the supersampled grid averages k x k samples spaced footprint / k apart: variance (k^2 - 1) / 12 *
            # (footprint / k)^2 per axis; a bilinear warp from an enlarged working copy blurs by a further 1/6 of
            # a working pixel squared on average (its sub-pixel phases), which the filter leaves out
            k, footprint = self.supersample, self._footprint0 * 2 ** (level / _LEVELS_PER_OCTAVE)
            variance = (k * k - 1) / 12 * (footprint / k) ** 2 - (1 / 6 if self._enlarged else 0.0)
            taps = _box_taps_with_variance(variance).astype(np.float32)
            src = self._filtered[level] = cv2.sepFilter2D(self._work, cv2.CV_32F, taps, taps,
                                                          borderType=_BORDER[self.border])
        return cv2.warpAffine(src, m, (self.width, self.height), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                              borderMode=_BORDER[self.border], borderValue=self.border_value * self.gain)

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion, for the adaptive DVS sampling.

        Returns
        -------
        float
            The trajectory's bound over the duration (output pixels per second).
        """
        return self.trajectory.max_speed_px_per_s((self.height, self.width), self.duration_us)

    def _params(self):
        return {"image": self.name, "trajectory": self.trajectory.describe(), "scale": self.scale,
                "interpolation": self.interpolation, "border": self.border, "gain": self.gain,
                "supersample": self.supersample, "prefilter": self.prefilter}
