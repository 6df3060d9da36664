"""The LDR (frame) camera: exposure integral with motion blur and rolling shutter, EMVA 1288 sensor noise, CRF
(its parameters, CameraParams, are in sim.camera_params).

Image formation per frame (units in brackets):
1. irradiance E [radiance units] = mean linear radiance over the exposure window of each row, sampled as
   sub-frames (box integral of the sample-and-hold signal; exact midpoint rule for a global shutter);
2. mean electrons = E * electrons_per_radiance_us * exposure_us * PRNU + dark_current * exposure + DSNU [e-];
3. with noise: electrons = Poisson(mean) + Normal(0, read_noise_e^2), clipped to [0, full_well_e];
4. x = electrons / full_well_e (so x = 1 is full well), y = crf.forward(x), DN = round(y * (2**bit_depth - 1)).

References (docs/models/references.md): EMVA 1288 [EMVA1288], the sensor noise; Foi et al. 2008 [Foi2008],
Poissonian-Gaussian noise; Pan et al. 2019 [Pan2019], EDI (blurred frames).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .camera_kernels import accumulate_rows, sense
from .camera_params import CameraParams
from .errors import EvsimInputError, InvalidParameterError, check_int, check_real_array
from .seeding import as_seed_sequence, child_seed
from .source import RadianceSource

if TYPE_CHECKING:
    import numpy.typing as npt

    from crf_models import CRF

#: sub-frames per period of a source's flicker (max_frequency_hz): the midpoint rule then integrates a sinusoid
#: over whole periods exactly
SUBFRAMES_PER_PERIOD = 8


@dataclass
class LDRFrame:
    """One captured frame.

    Attributes
    ----------
    index : int
        The frame's index k.
    image : numpy.ndarray
        (H, W) uint8 (bit_depth 8) or uint16 digital numbers in [0, 2**bit_depth - 1].
    t_start_us, t_mid_us, t_end_us : numpy.int64
        Exposure window of row 0, int64 us (row r is shifted by r line_us).
    exposure_us : int
        Exposure time (us).
    line_us : float
        Rolling-shutter line delay (us per row; 0 for a global shutter).
    n_subframes : int
        Radiance samples per row window.
    clean_response : numpy.ndarray or None
        float32 (H, W) noise-free response crf(x) of the scene without sensor noise, fixed pattern, dark signal or
        quantisation (x = E electrons_per_radiance_us exposure_us / full_well_e), or None.
    irradiance : numpy.ndarray or None
        float32 (H, W) mean linear radiance over each row's exposure (the motion-blurred truth, radiance units), or
        None.
    """

    index: int
    image: np.ndarray
    t_start_us: np.int64
    t_mid_us: np.int64
    t_end_us: np.int64
    exposure_us: int
    line_us: float
    n_subframes: int
    clean_response: np.ndarray | None = None
    irradiance: np.ndarray | None = None


class LDRCamera:
    """A frame camera of size (height, width) with parameters `params` and response `crf` (a crf_models CRF).

    The fixed patterns come from child (0,) of the seed and the temporal noise of frame k from child (1, k), so any
    frame can be regenerated on its own. seed_entropy records the entropy.

    Parameters
    ----------
    height, width : int
        Image size (pixels), >= 1.
    params : CameraParams
        The camera's parameters.
    crf : CRF
        Its response curve (a crf_models CRF).
    seed : int or numpy.random.SeedSequence, optional
        The camera's seed (default 0).
    """

    def __init__(self, height: int, width: int, params: CameraParams, crf: CRF,
                 seed: int | np.random.SeedSequence = 0) -> None:
        height = check_int("height", height, minimum=1, unit="pixels")
        width = check_int("width", width, minimum=1, unit="pixels")
        if not isinstance(params, CameraParams):
            raise InvalidParameterError(f"params must be a CameraParams, got {type(params).__name__}")
        for attr in ("forward", "inverse", "weight", "variance", "name", "params"):
            if not hasattr(crf, attr):
                raise InvalidParameterError(f"crf must be a crf_models CRF (missing {attr!r})")
        self.height, self.width, self.params, self.crf = int(height), int(width), params, crf
        self._seed = as_seed_sequence(seed)
        self.seed_entropy = self._seed.entropy
        rng = np.random.default_rng(child_seed(self._seed, 0))
        # Fixed patterns: relative gain (PRNU) and dark offset in e- (DSNU); (1, 1) placeholders when unused.
        self._use_maps = bool(params.prnu_sigma or params.dsnu_e)
        shape = (self.height, self.width) if self._use_maps else (1, 1)
        self._prnu_map = 1.0 + params.prnu_sigma * rng.standard_normal(shape)
        self._dsnu_map = params.dsnu_e * rng.standard_normal(shape)
        self._quant = None

    # --- public API ---------------------------------------------------------------------------------------
    def capture(self, source: RadianceSource, *, irradiance: bool = True,
                clean_response: bool = True) -> Iterator[LDRFrame]:
        """A generator of the frames of `source`, one at a time (memory independent of the sequence length).

        The configuration is checked here, before the first frame. Frames follow params.schedule(height,
        source.duration_us); with explicit frame_times_us every exposure must lie within [0, duration_us].

        Parameters
        ----------
        source : RadianceSource
            The scene, of the camera's size.
        irradiance : bool, optional
            Keep each frame's irradiance (default True).
        clean_response : bool, optional
            Keep each frame's noise-free response (default True).

        Returns
        -------
        iterator of LDRFrame
            The frames, in order.
        """
        if not isinstance(source, RadianceSource):
            raise EvsimInputError(f"source must implement sim.source.RadianceSource, got {type(source).__name__}")
        if (source.height, source.width) != (self.height, self.width):
            raise EvsimInputError(
                f"source is {source.height} x {source.width}, camera is {self.height} x {self.width}"
            )
        p = self.params
        schedule = p.schedule(self.height, int(source.duration_us))
        line_span = p.rolling_shutter_line_us * (self.height - 1)
        if schedule.size and schedule[-1, 2] + line_span > source.duration_us:
            raise InvalidParameterError(f"the last exposure ends after the source's duration {source.duration_us} us")
        speed = float(source.max_speed_px_per_s())
        if not (math.isfinite(speed) and speed >= 0):
            raise EvsimInputError(f"source.max_speed_px_per_s() must be finite and >= 0, got {speed}")
        rate = getattr(source, "max_frequency_hz", None)
        frequency = float(rate()) if rate is not None else 0.0
        if not (math.isfinite(frequency) and frequency >= 0):
            raise EvsimInputError(f"source.max_frequency_hz() must be finite and >= 0, got {frequency}")
        return self._frames(source, schedule, speed, frequency, irradiance, clean_response)

    def _frames(self, source, schedule, speed, frequency, keep_irradiance, keep_clean) -> Iterator[LDRFrame]:
        for k, (t_start, t_mid, t_end) in enumerate(schedule):
            exposure = int(t_end - t_start)
            n_sub = self.subframes_for(exposure, speed, frequency)
            irr = self._integrate(source, int(t_start), exposure, n_sub)
            yield self._sense(irr, k, t_start, t_mid, t_end, n_sub, keep_irradiance, keep_clean)

    def expose(self, radiance: npt.ArrayLike, exposure_us: int, *, frame_index: int = 0,
               t_start_us: int = 0) -> LDRFrame:
        """Sensor model without a source: `radiance` is either the mean radiance over the exposure (H, W) or
        equally weighted sub-frames (S, H, W) (global shutter). The noise is that of frame `frame_index`.

        Parameters
        ----------
        radiance : array_like
            (H, W) mean linear radiance, or (S, H, W) sub-frames (radiance units), finite and >= 0.
        exposure_us : int
            Exposure time (us), >= 1.
        frame_index : int, optional
            Whose temporal noise (default 0).
        t_start_us : int, optional
            Exposure start, int64 us (default 0).

        Returns
        -------
        LDRFrame
            The frame.
        """
        check_int("exposure_us", exposure_us, minimum=1, unit="microseconds")
        rad = check_real_array("radiance", radiance)
        if rad.ndim == 3:
            subframes = rad.shape[0]
            rad = rad.mean(axis=0, dtype=np.float64) if subframes else rad
        elif rad.ndim == 2:
            subframes = 1
        else:
            raise EvsimInputError(f"radiance must be (H, W) or (S, H, W), got shape {rad.shape}")
        if rad.shape != (self.height, self.width) or subframes == 0:
            raise EvsimInputError(
                f"radiance frames must be {self.height} x {self.width}, got shape {np.shape(radiance)}")
        rad = rad.astype(np.float32, copy=False)
        if not np.all((rad >= 0) & (rad < np.inf)):
            raise EvsimInputError("radiance contains NaN, infinite or negative values")
        t_start = np.int64(t_start_us)
        return self._sense(rad, frame_index, t_start, t_start + exposure_us // 2, t_start + exposure_us, subframes)

    def subframes_for(self, exposure_us: int, speed_px_per_s: float, frequency_hz: float = 0.0) -> int:
        """Sub-frames per exposure: params.n_subframes, or enough that motion between them is at most
        max_px_per_subframe and a flicker of frequency_hz gets SUBFRAMES_PER_PERIOD per period, within
        [1, max_subframes] and at most one per microsecond.

        Parameters
        ----------
        exposure_us : int
            Exposure time (us).
        speed_px_per_s : float
            Bound of image-plane motion (pixels per second).
        frequency_hz : float, optional
            Highest flicker frequency (Hz; default 0).

        Returns
        -------
        int
            The number of sub-frames, >= 1.
        """
        p = self.params
        if p.n_subframes is not None:
            n = p.n_subframes
        else:
            n = max(math.ceil(speed_px_per_s * exposure_us * 1e-6 / p.max_px_per_subframe),
                    math.ceil(frequency_hz * exposure_us * 1e-6 * SUBFRAMES_PER_PERIOD))
            n = min(max(n, 1), p.max_subframes)
        return max(1, min(n, exposure_us))

    # --- internals ----------------------------------------------------------------------------------------
    def _integrate(self, source, t_start: int, exposure: int, n_sub: int) -> np.ndarray:
        """Mean radiance over each row's window [t_start + r line, + exposure), from samples of the source held
        over intervals of length exposure / n_sub (midpoint samples, times rounded to the microsecond)."""
        line = self.params.rolling_shutter_line_us
        dt = exposure / n_sub
        n_samples = n_sub if line == 0 else math.ceil((exposure + line * (self.height - 1)) / dt - 1e-9)
        row_start = t_start + line * np.arange(self.height)
        acc = np.zeros((self.height, self.width), dtype=np.float32)
        for j in range(n_samples):
            a, b = t_start + j * dt, t_start + (j + 1) * dt
            w = np.clip(np.minimum(b, row_start + exposure) - np.maximum(a, row_start), 0.0, None) / exposure
            t = int(round(t_start + (j + 0.5) * dt))
            rad = np.asarray(source.radiance(t))
            if rad.dtype.kind not in "iuf":  # a cast would drop an imaginary part, or read True as 1
                raise EvsimInputError(f"source.radiance({t}) must hold real numbers (integer or float), got dtype "
                                      f"{rad.dtype}")
            rad = rad.astype(np.float32, copy=False)
            if rad.shape != (self.height, self.width):
                raise EvsimInputError(
                    f"source.radiance({t}) has shape {rad.shape}, expected {(self.height, self.width)}")
            if not accumulate_rows(acc, rad, w):
                raise EvsimInputError(f"source.radiance({t}) contains NaN, infinite or negative values")
        return acc

    def _quantiser(self) -> tuple[np.ndarray, np.ndarray]:
        """Decision thresholds t_d (d = 1..max_dn): the x at which the digital number steps from d - 1 to d, so
        that DN(x) = #{t_d <= x} equals round(crf.forward(x) * max_dn) up to exact ties; t_d =
        crf.inverse((d - 0.5) / max_dn), 0 below the lowest response and +inf above the highest. Also the
        count of thresholds below each of 4 (max_dn + 1) equal bins of x in [0, 1], to start the search."""
        if self._quant is None:
            crf, m = self.crf, self.params.max_dn
            levels = (np.arange(1, m + 1) - 0.5) / m
            y0, y1 = float(crf.forward(0.0)), float(crf.forward(1.0))
            thr = crf.inverse(np.clip(levels, y0, y1))
            thr = np.where(levels <= y0, 0.0, np.where(levels > y1, np.inf, thr))
            n_bins = 4 * (m + 1)
            bin_start = np.searchsorted(thr, np.arange(n_bins + 1) / n_bins, side="left").astype(np.int64)
            self._quant = (thr, bin_start)
        return self._quant

    def _sense(self, irr, k, t_start, t_mid, t_end, n_sub, keep_irradiance=True, keep_clean=True) -> LDRFrame:
        """Electrons, noise, clipping, CRF and quantisation of the mean radiance irr ((H, W) float)."""
        p = self.params
        exposure = int(t_end - t_start)
        gain = p.electrons_per_radiance_us * exposure
        dark = p.dark_current_e_per_s * exposure * 1e-6
        key = child_seed(self._seed, 1, k).generate_state(1, np.uint64)[0]
        image = np.empty((self.height, self.width), dtype=np.uint8 if p.bit_depth == 8 else np.uint16)
        sense(irr, gain, dark, self._prnu_map, self._dsnu_map, self._use_maps, p.noise, float(p.read_noise_e),
              float(p.full_well_e), key, *self._quantiser(), image)
        clean = None
        if keep_clean:
            x_clean = np.clip(irr * (p.electrons_per_radiance_us * exposure / p.full_well_e), 0.0, 1.0)
            clean = self.crf.forward(x_clean).astype(np.float32)
        return LDRFrame(
            index=int(k), image=image, t_start_us=np.int64(t_start), t_mid_us=np.int64(t_mid), t_end_us=np.int64(t_end),
            exposure_us=exposure, line_us=float(p.rolling_shutter_line_us), n_subframes=int(n_sub),
            clean_response=clean, irradiance=irr.astype(np.float32, copy=False) if keep_irradiance else None,
        )
