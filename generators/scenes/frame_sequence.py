"""A sequence of HDR frames with timestamps, interpolated between frames.

Frames come from an array (N, H, W) or from a folder of OpenEXR files (loaded lazily, two at a time, so memory
does not grow with the number of frames). Between two frames the radiance is interpolated either
- "log" (default): linearly in log(I + eps), i.e. I(t) = (I0 + eps)^(1-a) (I1 + eps)^a - eps, which is how a pixel
  whose brightness changes by a constant factor per unit time behaves and what the DVS sees as constant event rate;
- "linear": linearly in radiance, I(t) = (1 - a) I0 + a I1 (a cross-fade, which is what motion blur averages).
eps (log_eps, same units as the radiance) keeps black pixels finite. Times are shifted so the first frame is t=0.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sim import EvsimInputError, InvalidParameterError, TimeOrderError

from .base import Scene, positive
from .image_motion import load_image
from .luminance import to_luminance

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

TIMESTAMPS_FILE = "timestamps.txt"


class FrameSequenceScene(Scene):
    """Interpolated HDR frames.

    Parameters
    ----------
    frames : numpy.ndarray or sequence
        (N, H, W[, C]) linear radiance (radiance units), or a list of arrays or of paths to images readable by
        load_image.
    times_us : array_like
        (N,) strictly increasing integer times (us), N >= 2; shifted so that the first frame is t = 0.
    interpolation : {"log", "linear"}, optional
        Between frames: linear in log(I + log_eps) (default) or in radiance (see the module).
    log_eps : float, optional
        eps of the log interpolation (radiance units, > 0; default 1e-6).
    channel : str or int, optional
        As to_luminance's.
    max_speed_px_per_s : float, optional
        An upper bound of the motion (pixels per second) if known; by default the source reports one pixel per
        shortest frame interval, so that a consumer sampling at one pixel of motion samples at least once per input
        frame (the interpolation holds no finer information).
    name : str, optional
        The frames' name in describe() (e.g. their folder).
    """

    def __init__(self, frames: np.ndarray | Sequence[np.ndarray | str | Path], times_us: ArrayLike, *,
                 interpolation: str = "log", log_eps: float = 1e-6, channel: str | int | None = None,
                 max_speed_px_per_s: float | None = None, name: str | None = None):
        times = np.asarray(times_us)
        if times.ndim != 1 or times.size < 2 or not np.issubdtype(times.dtype, np.integer):
            raise EvsimInputError(f"times_us must be a 1-D integer array of at least 2 microsecond times, "
                                  f"got {times.dtype} shape {times.shape}")
        if np.any(np.diff(times) <= 0):
            i = int(np.flatnonzero(np.diff(times) <= 0)[0]) + 1
            raise TimeOrderError(f"frame times must be strictly increasing: times_us[{i}]={times[i]} <= "
                                 f"times_us[{i - 1}]={times[i - 1]}")
        if len(frames) != times.size:
            raise EvsimInputError(f"{len(frames)} frames but {times.size} timestamps")
        if interpolation not in ("log", "linear"):
            raise InvalidParameterError(f"interpolation must be 'log' or 'linear', got {interpolation!r}")
        self._frames, self._channel = frames, channel
        self.times = times.astype(np.int64) - int(times[0])
        self.interpolation = interpolation
        self.log_eps = positive("log_eps", log_eps, "FrameSequenceScene")
        self.name = name
        self._cache: dict[int, np.ndarray] = {}
        first = self._frame(0)
        self._init_size(first.shape[0], first.shape[1], int(self.times[-1]))
        self._speed = (1e6 / float(np.diff(self.times).min()) if max_speed_px_per_s is None
                       else positive("max_speed_px_per_s", max_speed_px_per_s, "FrameSequenceScene", allow_zero=True))

    @classmethod
    def from_folder(cls, folder: str | Path, *, fps: float | None = None, **kwargs: Any) -> FrameSequenceScene:
        """All *.exr files of a folder in name order.

        Parameters
        ----------
        folder : str or Path
            The folder; its times come from timestamps.txt in it (one integer microsecond time per line, in the
            same order) or, when it is absent, from fps.
        fps : float, optional
            Frames per second, when the folder has no timestamps.txt.
        **kwargs
            The constructor's other keywords (name defaults to the folder).

        Returns
        -------
        FrameSequenceScene
            The scene.
        """
        folder = Path(folder)
        paths = sorted(folder.glob("*.exr"))
        if len(paths) < 2:
            raise EvsimInputError(f"{folder}: need at least 2 .exr frames, found {len(paths)}")
        ts_file = folder / TIMESTAMPS_FILE
        if ts_file.is_file():
            try:
                times = np.loadtxt(ts_file, dtype=np.int64, ndmin=1)
            except ValueError as e:
                raise EvsimInputError(f"{ts_file}: expected one integer microsecond time per line ({e})") from None
        elif fps is not None:
            times = np.round(np.arange(len(paths)) * 1e6 / positive("fps", fps, "from_folder")).astype(np.int64)
        else:
            raise EvsimInputError(f"{folder}: no {TIMESTAMPS_FILE} and no fps given")
        return cls(paths, times, name=kwargs.pop("name", str(folder)), **kwargs)

    def _frame(self, i: int) -> np.ndarray:
        if i not in self._cache:
            f = self._frames[i]
            img = load_image(f, channel=self._channel) if isinstance(f, (str, Path)) else to_luminance(f, self._channel)
            if hasattr(self, "height") and img.shape != (self.height, self.width):
                raise EvsimInputError(f"frame {i} has shape {img.shape}, expected {(self.height, self.width)}")
            if len(self._cache) >= 2:  # keep only the current pair
                self._cache.pop(next(iter(self._cache)))
            self._cache[i] = img
        return self._cache[i]

    def _render(self, t_us):
        k = int(np.searchsorted(self.times, t_us, side="right")) - 1
        k = min(k, self.times.size - 2)
        a = (t_us - self.times[k]) / (self.times[k + 1] - self.times[k])
        i0, i1 = self._frame(k), self._frame(k + 1)
        if a == 0:
            return i0
        if self.interpolation == "linear":
            return (1 - a) * i0 + a * i1
        eps = np.float32(self.log_eps)
        out = np.exp((1 - a) * np.log(i0 + eps) + a * np.log(i1 + eps)) - eps
        return np.maximum(out, 0.0, out=out)

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion, for the adaptive DVS sampling.

        Returns
        -------
        float
            max_speed_px_per_s as given, else one pixel per shortest frame interval (pixels per second).
        """
        return self._speed

    def _params(self):
        return {"frames": self.name, "n_frames": int(self.times.size), "interpolation": self.interpolation,
                "log_eps": self.log_eps}
