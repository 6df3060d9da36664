"""The built-in HDR photo scene: a scikit-image sample photo made HDR (needs no files).

builtin_hdr_image(name) turns a scikit-image sample photo into an HDR radiance map: the 8-bit sRGB values are
linearised with the inverse sRGB curve (crf_models "srgb"), reduced to Rec. 709 luminance, and given a synthetic
HDR boost: a bright "window" region (x 8, soft edges), a "sun" disk (radiance 30 with a soft halo) and a
shadowed corner (x 0.02), over a floor of 1e-3. The photo's own range is about 1e-3..1, so the result spans
more than 1e4:1, of which the AHDR window CRF keeps only a narrow band.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from sim import InvalidParameterError

from .image_motion import ImageMotionScene, Trajectory, linearise_ldr
from .luminance import to_luminance

#: the scikit-image photos builtin_hdr_image turns into HDR radiance (no download needed)
BUILTIN_IMAGES = ("astronaut", "camera", "coffee", "chelsea")
WINDOW_GAIN, SUN_RADIANCE, SHADOW_GAIN, FLOOR = 8.0, 30.0, 0.02, 1e-3


def builtin_hdr_image(name: str = "astronaut") -> np.ndarray:
    """An HDR radiance map made from a scikit-image sample photo (see the module docstring).

    Parameters
    ----------
    name : str, optional
        One of BUILTIN_IMAGES (default "astronaut"): the photo skimage.data.<name>().

    Returns
    -------
    numpy.ndarray
        float32 (H, W) linear radiance (relative units: the photo's own range is about 1e-3..1, the sun 30).
    """
    if name not in BUILTIN_IMAGES:
        raise InvalidParameterError(f"unknown built-in image {name!r}; one of {', '.join(BUILTIN_IMAGES)}")
    import skimage.data

    img = getattr(skimage.data, name)()
    y = to_luminance(linearise_ldr(img, "srgb"))
    h, w = y.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)

    def soft_box(x0, y0, x1, y1, soft):
        fx = np.clip((xx - x0) / soft, 0, 1) * np.clip((x1 - xx) / soft, 0, 1)
        fy = np.clip((yy - y0) / soft, 0, 1) * np.clip((y1 - yy) / soft, 0, 1)
        return fx * fy

    window = soft_box(0.62 * w, 0.05 * h, 0.95 * w, 0.40 * h, 0.02 * w)
    shadow = soft_box(-w, 0.70 * h, 0.35 * w, 2 * h, 0.05 * w)
    y = y * (1 + (WINDOW_GAIN - 1) * window) * (1 - (1 - SHADOW_GAIN) * shadow)
    r = np.hypot(xx - 0.80 * w, yy - 0.18 * h)
    sun = np.clip(1.0 - (r - 0.03 * w) / 3.0, 0, 1) + 0.05 * np.exp(-(r / (0.08 * w)) ** 2)
    y = y + SUN_RADIANCE * sun.astype(np.float32) + FLOOR
    return cv2.GaussianBlur(y, (0, 0), 0.5)  # the hard sun edge would alias under sub-pixel motion


def builtin_image_scene(height: int, width: int, duration_us: int, trajectory: Trajectory | None = None, *,
                        image: str = "astronaut", **kwargs: Any) -> ImageMotionScene:
    """An ImageMotionScene of builtin_hdr_image(image) at the requested output size.

    Parameters
    ----------
    height, width : int
        Output size (pixels).
    duration_us : int
        Duration (us).
    trajectory : Trajectory, optional
        The camera motion (default: none).
    image : str, optional
        One of BUILTIN_IMAGES (default "astronaut").
    **kwargs
        ImageMotionScene's other keywords.

    Returns
    -------
    ImageMotionScene
        The scene.
    """
    return ImageMotionScene(builtin_hdr_image(image), duration_us, trajectory, height=height, width=width,
                            name=f"skimage.data.{image} (HDR boosted)", **kwargs)
