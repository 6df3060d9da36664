"""Colour to luminance.

By default an RGB image becomes relative luminance Y with the Rec. 709 / sRGB weights
Y = 0.2126 R + 0.7152 G + 0.0722 B (linear RGB, ITU-R BT.709 primaries, D65). A single channel can be selected
instead ("R", "G", "B" or an index). Inputs are linear radiance; the channels are in RGB order (convert OpenCV's BGR
before calling).
"""

from __future__ import annotations

import numpy as np

from sim import EvsimInputError

#: the ITU-R BT.709 luminance weights of linear R, G, B
REC709_WEIGHTS = (0.2126, 0.7152, 0.0722)
#: negative values down to this fraction of the image's maximum are clipped to 0 (merging and filtering leave such
#: noise in EXR files); below it an image is refused: radiance is never negative
NEGATIVE_TOLERANCE = 0.01
_CHANNELS = {"R": 0, "G": 1, "B": 2}


def to_luminance(image: np.ndarray, channel: str | int | None = None) -> np.ndarray:
    """Reduce a linear image to luminance.

    Small negative values (EXR files may hold them from merging or filtering: at most NEGATIVE_TOLERANCE times the
    image's maximum) are clipped to 0; larger ones, NaN/inf and values that are not real numbers (bool, complex,
    object) raise EvsimInputError.

    Parameters
    ----------
    image : numpy.ndarray
        (H, W) or (H, W, C) linear image (radiance units), integer or float.
    channel : str or int, optional
        None (default) for Rec. 709 luminance of the first three channels (a fourth, alpha, is ignored; a 1-channel
        image is returned as is), or "R"/"G"/"B"/an integer index to select one channel.

    Returns
    -------
    numpy.ndarray
        float32 (H, W) luminance (the image's radiance units), >= 0.
    """
    img = np.asarray(image)
    if img.dtype.kind not in "iuf":
        raise EvsimInputError(f"an image must hold real numbers (integer or float), got dtype {img.dtype}")
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[..., 0]
    if img.ndim == 2:
        if channel not in (None, 0):
            raise EvsimInputError(f"channel {channel!r} selected but the image has a single channel")
        y = img.astype(np.float32)
    elif img.ndim == 3:
        if channel is None:
            if img.shape[2] < 3:
                raise EvsimInputError(f"cannot compute luminance of a {img.shape[2]}-channel image; select a channel")
            y = img[..., :3].astype(np.float32) @ np.asarray(REC709_WEIGHTS, np.float32)
        else:
            idx = _CHANNELS.get(str(channel).upper(), channel)
            if not isinstance(idx, (int, np.integer)) or not 0 <= idx < img.shape[2]:
                raise EvsimInputError(
                    f"channel {channel!r} is not one of 'R', 'G', 'B' or an index below {img.shape[2]}"
                )
            y = img[..., idx].astype(np.float32)
    else:
        raise EvsimInputError(f"an image must have shape (H, W) or (H, W, C), got {img.shape}")
    if not np.all(np.isfinite(y)):
        raise EvsimInputError("image holds NaN or infinite values")
    limit = NEGATIVE_TOLERANCE * max(float(y.max()), 0.0) if y.size else 0.0
    if y.size and y.min() < -limit:
        raise EvsimInputError(f"image holds negative radiance down to {y.min():.4g}: radiance is never negative "
                              f"(values down to {-limit or 0.0:.4g}, {NEGATIVE_TOLERANCE:g} x the image's maximum, "
                              "are taken as rounding noise and clipped to 0)")
    return np.maximum(y, 0.0, out=y)
