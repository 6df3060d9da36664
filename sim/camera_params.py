"""LDR camera parameters (`CameraParams`), their units (FIELD_UNITS) and named camera presets; the camera itself is
sim.camera. numpy is imported where it is used (schedule), so that reading the parameters (`evsim --help`) stays
light.

References (docs/models/references.md): EMVA 1288 [EMVA1288].
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from .errors import InvalidParameterError, TimeOrderError, check_int, check_number, check_override_names

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True)
class CameraParams:
    """Configuration of the LDR camera (frozen; use dataclasses.replace or CameraParams.preset to vary it).

    Every field is validated on construction; FIELD_UNITS gives each one's unit.

    Attributes
    ----------
    fps : float
        Timing: frame rate (frames per second, > 0) used when frame_times_us is None; frame k has mid-exposure
        first_frame_us + round(k 1e6 / fps) us (default 30).
    first_frame_us : int or None
        Mid-exposure time of frame 0 (us; default None: half the first exposure, so it starts at t = 0).
    frame_times_us : tuple of int or None
        Explicit mid-exposure times (us), strictly increasing (overrides fps).
    exposure_us : int or tuple of int
        One exposure time (us, > 0), or a sequence used cyclically over the frames (e.g. (1000, 8000) alternates a
        short and a long exposure); default 10000.
    rolling_shutter_line_us : float
        Row r is exposed rolling_shutter_line_us r later than row 0 (us per row; 0, the default: global shutter).
    reference_radiance : float
        Exposure scaling: radiance reference_radiance (radiance units, > 0) exposed for reference_exposure_us fills
        reference_fill of the full well (before PRNU); default 1.
    reference_fill : float
        Fraction of the full well, in (0, 1] (default 0.5).
    reference_exposure_us : int or None
        Exposure of the scaling (us; default None: the first exposure).
    full_well_e : float
        Sensor (EMVA 1288): full well (electrons, > 0; default 10000).
    read_noise_e : float
        Read noise (electrons rms, >= 0; default 3).
    dark_current_e_per_s : float
        Dark current (electrons per second, >= 0; default 0).
    prnu_sigma : float
        Relative standard deviation of the per-pixel gain (PRNU, >= 0; default 0).
    dsnu_e : float
        Standard deviation of the per-pixel dark offset (DSNU, electrons, >= 0; default 0).
    bit_depth : int
        Bits of the digital numbers, 8..16 (default 8).
    noise : bool
        False switches off the temporal noise (shot and read noise); fixed patterns follow prnu_sigma and dsnu_e
        (default True).
    n_subframes : int or None
        Sub-frames per exposure, or None (default) to choose from the source's max_speed_px_per_s so that the image
        moves at most max_px_per_subframe between sub-frames, within [1, max_subframes].
    max_px_per_subframe : float
        Pixels (> 0; default 1).
    max_subframes : int
        Sub-frames at most (>= 1; default 64).
    """

    fps: float = 30.0
    first_frame_us: int | None = None
    frame_times_us: tuple[int, ...] | None = None
    exposure_us: int | tuple[int, ...] = 10_000
    rolling_shutter_line_us: float = 0.0
    reference_radiance: float = 1.0
    reference_fill: float = 0.5
    reference_exposure_us: int | None = None
    full_well_e: float = 10_000.0
    read_noise_e: float = 3.0
    dark_current_e_per_s: float = 0.0
    prnu_sigma: float = 0.0
    dsnu_e: float = 0.0
    bit_depth: int = 8
    noise: bool = True
    n_subframes: int | None = None
    max_px_per_subframe: float = 1.0
    max_subframes: int = 64

    def __post_init__(self) -> None:
        # numpy's types, when numpy is loaded (a numpy value exists only then): reading the parameters stays light
        np = sys.modules.get("numpy")
        arrays, bools, ints = ((np.ndarray,), (bool, np.bool_), (int, np.integer)) if np else ((), (bool,), (int,))
        if self.exposure_us is None:
            raise InvalidParameterError("exposure_us must be integer microseconds (one value or a sequence), got None")
        if self.frame_times_us is not None and not isinstance(self.frame_times_us, (list, tuple, *arrays)):
            raise InvalidParameterError(f"frame_times_us must be a sequence of integer microseconds, got "
                                        f"{self.frame_times_us!r}")
        for name in ("exposure_us", "frame_times_us"):
            value = getattr(self, name)
            many = isinstance(value, (list, tuple, *arrays))
            for v in (value if many else () if value is None else (value,)):
                if isinstance(v, bools) or not isinstance(v, ints):
                    raise InvalidParameterError(f"{name} must be integer microseconds, got {v!r}")
            if many:
                object.__setattr__(self, name, tuple(int(v) for v in value))
        exposures = self.exposures
        if len(exposures) == 0 or min(exposures) <= 0:
            raise InvalidParameterError(
                f"exposure_us must be > 0 (one value or a non-empty sequence), got {self.exposure_us}")
        if self.frame_times_us is not None:
            t = self.frame_times_us
            if len(t) == 0:
                raise InvalidParameterError("frame_times_us is empty")
            back = next((i for i in range(1, len(t)) if t[i] <= t[i - 1]), None)
            if back is not None:
                raise TimeOrderError(f"frame_times_us must increase strictly: [{back}]={t[back]} after "
                                     f"{t[back - 1]} us")
        check_number("fps", self.fps, positive=True)
        for name in ("first_frame_us", "reference_exposure_us"):
            if getattr(self, name) is not None:
                check_int(name, getattr(self, name), minimum=0 if name == "first_frame_us" else 1,
                          unit="microseconds")
        for name in ("full_well_e", "reference_radiance", "max_px_per_subframe", "reference_fill"):
            check_number(name, getattr(self, name), positive=True)
        if self.reference_fill > 1:
            raise InvalidParameterError(f"reference_fill must lie in (0, 1], got {self.reference_fill}")
        for name in ("read_noise_e", "dark_current_e_per_s", "prnu_sigma", "dsnu_e", "rolling_shutter_line_us"):
            check_number(name, getattr(self, name), positive=False)
        check_int("bit_depth", self.bit_depth, minimum=8, maximum=16)
        if not isinstance(self.noise, bools):
            raise InvalidParameterError(f"noise must be a bool, got {self.noise!r}")
        if self.n_subframes is not None:
            check_int("n_subframes", self.n_subframes, minimum=1)
        check_int("max_subframes", self.max_subframes, minimum=1)

    @property
    def exposures(self) -> tuple[int, ...]:
        """The exposure times (us), used cyclically over the frames."""
        e = self.exposure_us
        return e if isinstance(e, tuple) else (int(e),)

    @property
    def max_dn(self) -> int:
        """Largest digital number, 2**bit_depth - 1."""
        return (1 << self.bit_depth) - 1

    @property
    def electrons_per_radiance_us(self) -> float:
        """Mean electrons collected per unit radiance per microsecond of exposure."""
        t_ref = self.reference_exposure_us or self.exposures[0]
        return self.reference_fill * self.full_well_e / (self.reference_radiance * t_ref)

    def schedule(self, height: int, duration_us: int | None = None) -> np.ndarray:
        """Frame timing as an int64 array of shape (F, 3): t_start_us, t_mid_us, t_end_us of row 0.

        With fps, frames continue while the last row's exposure ends by duration_us. Raises
        InvalidParameterError when a frame starts before t = 0 or two exposures of a row overlap.

        Parameters
        ----------
        height : int
            Image height (rows), for the rolling shutter's span.
        duration_us : int, optional
            Length of the source (us); needed with fps (None: only with frame_times_us).

        Returns
        -------
        numpy.ndarray
            int64 (F, 3) times in us.
        """
        import numpy as np

        line = self.rolling_shutter_line_us * (height - 1)
        exposures = self.exposures
        if self.frame_times_us is not None:
            mids = np.asarray(self.frame_times_us, dtype=np.int64)
        else:
            if duration_us is None:
                raise InvalidParameterError("a duration is needed to schedule frames from fps")
            first = exposures[0] // 2 if self.first_frame_us is None else int(self.first_frame_us)
            n = max(0, int((duration_us - first) * self.fps / 1e6) + 2)
            mids = first + np.rint(np.arange(n) * (1e6 / self.fps)).astype(np.int64)
        exp = np.asarray([exposures[k % len(exposures)] for k in range(mids.size)], dtype=np.int64)
        start = mids - exp // 2
        end = start + exp
        if self.frame_times_us is None:
            keep = end + line <= duration_us
            start, mids, end = start[keep], mids[keep], end[keep]
        if start.size and start[0] < 0:
            raise InvalidParameterError(f"frame 0 would start at {start[0]} us, before t = 0")
        overlap = np.flatnonzero(end[:-1] > start[1:])
        if overlap.size:
            k = int(overlap[0])
            raise InvalidParameterError(
                f"exposures overlap: frame {k} ends at {end[k]} us after frame {k + 1} starts at {start[k + 1]} us"
            )
        return np.stack([start, mids, end], axis=1)

    @classmethod
    def preset(cls, name: str, **overrides: Any) -> CameraParams:
        """A named configuration ("ideal", "davis346_aps", "machine_vision") with fields overridden.

        Parameters
        ----------
        name : str
            A PRESETS name.
        **overrides
            CameraParams fields to replace (units: FIELD_UNITS).

        Returns
        -------
        CameraParams
            The parameters.
        """
        if name not in PRESETS:
            raise InvalidParameterError(f"unknown camera preset {name!r}; available: {', '.join(PRESETS)}")
        check_override_names("CameraParams.preset", cls, overrides)
        return dataclasses.replace(PRESETS[name], **overrides)


# Typical values, not datasheet figures: DAVIS346 APS frames as distributed (8-bit, noticeable read noise and
# fixed pattern); a global-shutter machine-vision CMOS (IMX-class: ~10 ke- full well, ~2.5 e- read noise, 12-bit).
PRESETS = {
    "ideal": CameraParams(read_noise_e=0.0, noise=False),
    "davis346_aps": CameraParams(
        fps=25.0, exposure_us=10_000, full_well_e=20_000.0, read_noise_e=10.0, dark_current_e_per_s=50.0,
        prnu_sigma=0.01, dsnu_e=5.0, bit_depth=8, rolling_shutter_line_us=0.0,
    ),
    "machine_vision": CameraParams(
        fps=60.0, exposure_us=5_000, full_well_e=10_500.0, read_noise_e=2.5, dark_current_e_per_s=2.0,
        prnu_sigma=0.005, dsnu_e=1.0, bit_depth=12,
    ),
}


#: unit (or kind) of every CameraParams field, for messages and `evsim ... --help` (tests check it covers them all)
FIELD_UNITS: dict[str, str] = {
    "fps": "frames per second", "first_frame_us": "us, exposure midpoint of frame 0",
    "frame_times_us": "us, list of exposure midpoints", "exposure_us": "us, one value or a list used cyclically",
    "rolling_shutter_line_us": "us per row, 0 = global shutter", "reference_radiance": "radiance units",
    "reference_fill": "fraction of full well, (0, 1]", "reference_exposure_us": "us",
    "full_well_e": "electrons", "read_noise_e": "electrons rms", "dark_current_e_per_s": "electrons per second",
    "prnu_sigma": "relative gain std", "dsnu_e": "electrons std", "bit_depth": "bits, 8..16",
    "noise": "true/false: temporal noise", "n_subframes": "subframes per exposure",
    "max_px_per_subframe": "pixels", "max_subframes": "subframes",
}
