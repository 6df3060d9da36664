"""AKFParams: the filter's tuning parameters, with the paper's names and units.

Times enter the API as int64 microseconds; inside the equations they are seconds, so the noise densities below
are per second. "log" means natural log of scaled irradiance plus the offset I0 (L = log(I + I0)); "x" is the
CRF's scaled-irradiance unit (the argument of crf.forward).

References (docs/models/references.md): Wang et al. 2021 [Wang2021].
"""

from __future__ import annotations

from dataclasses import dataclass

from sim.errors import InvalidParameterError, check_int, check_number


@dataclass(frozen=True)
class AKFParams:
    """Parameters of the frame augmentation and the Asynchronous Kalman Filter (Wang et al. 2021 [Wang2021]).

    Every variance, i0 and p0 must be > 0 (POSITIVE_FIELDS); rho_bar_us and calib_min_events are integers >= 0.

    The defaults suit x in about [0, 1] with 8-bit frames: sigma_im2 = 1e-6 is about one quantisation step of the
    AHDR window CRF squared, and max_variance = 1e4 sigma_im2 (the paper: clipped responses get a large variance
    "so the filter trusts events there"). Where the state is consistent with two clipped frames it is not pulled
    at all (a clipped response says only that the truth is beyond the clip level), so events carry the clipped
    regions; the drift of event noise there is held by the flat-fielded thresholds (flat_field) and the clip prior
    above, and by the strong one-sided pull at the clip level. max_variance is the best of 100, 3e3, 1e4 and
    1e5 times sigma_im2 on the built-in AHDR suite with the tuning protocol (evsim_eval; measured while the
    possible side was still pulled with the saturated variance).

    Attributes
    ----------
    sigma_proc2 : float
        Event noise (eq. 2), realised at each event, in log^2 units. Process noise density (log^2 / s); Q_proc =
        sigma_proc2 * (time since the pixel's last event).
    sigma_iso2 : float
        Isolated-pixel noise density (log^2 / s); Q_iso = sigma_iso2 * (time since the latest event of the 8
        neighbouring pixels; the pixel itself is excluded, its own history is Q_proc's job).
    sigma_ref2 : float
        Refractory noise (log^2), added when the pixel's previous event is at most rho_bar_us earlier.
    rho_bar_us : int
        Upper bound of the refractory period (microseconds). Default 5 ms: events closer than this come from a
        bandwidth-limited pixel (a DAVIS photoreceptor's time constant is ~0.5 ms at full illumination and grows as 1 /
        illumination, ~5 ms at 10 %), whose log change they under-report. A shorter bound lets the ON burst of a
        dark-to-bright edge ride on a stale dark state past the next well-exposed frame (the authors' code uses 10 ms;
        3-5 ms scores best on the AHDR suite).
    sigma_im2 : float
        Frame noise (eqs. 6-9). Base variance of a frame pixel (x^2); Rbar = sigma_im2 / f^w(response), saturated at
        max_variance (x^2) where f^w ~ 0 (clipped responses). Clipped frames are also treated as one-sided (censored)
        measurements, which the paper does not do: where both frames around an interval are clipped on the same side, a
        state on the impossible side of the measurement (below it for a pixel clipped high) is pulled with R * sigma_im2
        / max_variance, a state on the possible side not at all; the rule switches exactly when the state crosses the
        measurement (see akf.kernels.propagate_one_sided).
    max_variance : float
        The saturation value of Rbar (x^2), where f^w ~ 0 (clipped responses); see sigma_im2 and the defaults above.
    i0 : float
        Offset I0 (x units) in L = log(I + I0); keeps the log finite at I = 0.
    bias_max_variance : float
        The bias correction of eq. 8 subtracts R/2 (log^2 -> log), capped at bias_max_variance / 2; clipped pixels get
        none (a censored response: the expansion does not apply, and the truth lies beyond the clip level, so a shift
        toward the middle only adds bias).
    p0 : float
        Filter. Initial state variance P (log^2) at the start of the first exposure.
    frame_update : bool
        At each frame's mid-exposure time tau_k, a discrete Kalman update (Kalman 1960) of every pixel the frame
        measures (not clipped) with the frame's bias-corrected log z and its own variance F (the read noise below), its
        prior variance matched to the innovation (covariance matching, Mehra 1972: P_prior = max(P, (z - L)^2 - F)),
        which the paper does not do. The paper's continuous measurement alone (eqs. 16-20) integrates R(t), interpolated
        between a clipped frame's saturated variance and a well-exposed frame's small one (eq. 7), and its P shrinks
        between frames as if the augmented frame's errors were white, so a pixel that becomes well exposed (or whose
        event-interpolated curve is off) is barely corrected by the time of the frame. With the update the state ends
        each frame within sqrt(F) of the frame (see akf.kernels.akf_frame_update). False: the paper's filter.
    read_noise_dn : float or None
        The frames' temporal (read) noise, DN rms before quantisation, which sets the frame update's variance F: with
        the quantisation, through the CRF's slope at each pixel's response (akf.frame_noise.frame_log_variance). The
        continuous measurement (the augmented frame) keeps eq. 9's R. None (default): estimated from the frames
        themselves (akf.frame_noise.estimate_read_noise).
    smooth_range : float
        Output smoothing (not in the paper; akf.smoothing). Range sigma (log) of the bilateral filter of each published
        log image; 0 disables it. Each pixel the last frame did not measure (clipped) takes the filtered value with the
        weight max(0, 1 - smooth_variance / P), never past that frame's clip level, so the event speckle of pixels no
        frame measures is averaged while pixels the last frame measured keep their value bit for bit. Where the next
        frame measures the pixel (the edge of a clipped area) the range is at most akf.smoothing.EDGE_RANGE (1 log).
        Default 4: between two clipped frames a range of 4 instead of 1 lowered mse01 by 5-17 % and raised ssim01 by
        0.01-0.04 on AHDR pans of the shared HDR photos.
    smooth_variance : float
        The state variance P (log^2) up to which a pixel is not smoothed at all (half at twice it); 3e-5 is about the
        frame variance R of a well-exposed 8-bit pixel of the AHDR window CRF.
    clip_prior : bool
        Clip prior (not in the paper; akf.clip_prior; acts only with frame_update). A pixel no frame has measured yet
        (clipped since the first frame) whose interval's frames are both clipped on one side has only a bound (the clip
        level plus its events); each published image gives it the median of the levels beyond its bound of the pixels on
        the same side that a frame has measured (their events carried them beyond the clip level). False: such pixels
        stay at their bound.
    smoother_drift2 : float
        Smoother (akf.reconstruct_smoothed only). How fast (log^2 / s) the error of a level carried by events grows with
        the time since the frame that measured it, beyond the filter's P; where a frame measured the pixel on both sides
        of t, the two passes are weighted by P + smoother_drift2 * (time since / until that frame), so the nearer frame
        counts more. The filter's event noise (eq. 2) leaves out the photoreceptor's lag and threshold mismatch, which
        make events under- or over-report a change: on the AHDR pan of Desk with the davis346 sensor, a pixel's log
        error one frame interval after its last measuring frame is about 0.3, after 0.5 s about 1.
    clip_prior_variance : float
        The variance (log^2) of the clip prior's level (akf.clip_prior) where the smoother fuses it with the other
        pass's: a pass in which no frame has measured a pixel yet holds that level, weighed against the other pass's
        carried level. 16 (of 1, 4, 16 and none) gave the lowest log_rmse on the AHDR pans of the three shared HDR
        photos with the davis346 sensor (Desk 1.29, Grace Cathedral 0.58, MtTamWest 1.12; without it 1.29, 0.62, 1.25),
        and the demo's 0.65 (0.66 without).
    flat_field : bool
        Threshold flat field (not in the paper; akf.flat_field). Where the contrast is given as a scalar or an (ON, OFF)
        pair, the thresholds of each pixel that at least half the frames clip are scaled by its ON (OFF) event count
        relative to its 5 x 5 neighbourhood's over the whole input (threshold mismatch read from the events; scales
        within calib_scale_range; akf.flat_field). Pixels the frames measure more often keep the nominal thresholds: the
        eq. 12 calibration and the frame update correct them (flat-fielding them too cost 3 % of mse01 on the real
        DAVIS346 road recording). Without it, pixels no frame measures integrate every event with the nominal threshold
        and run off (to 2e9 x on the AHDR pan of the HDR photo Desk, whose truth peaks at 127 x). Per-pixel contrast
        maps given to the filter are taken as they are. False: the nominal thresholds, as in the paper.
    deblur : bool
        Frame augmentation (section 4.1). EDI-deblur each frame to the start and end of its exposure (else the blurred
        frame is used as is).
    calibrate : bool
        Per-pixel contrast calibration (eq. 12) over each interval between deblurred frames.
    calib_min_events : int
        Calibrate only where the net signed event count over the interval is at least this.
    calib_scale_range : tuple of float
        Accepted (min, max) of the calibrated/nominal contrast ratio; outside it, or where either deblurred frame is
        clipped (Rbar at max_variance), the interval is not calibrated by eq. 12 and takes the pixel's calibration
        carried from earlier intervals (akf.augmentation.ContrastCalibration).
    calib_prior : float
        Shrinkage (log units of measured change) of a pixel's carried calibration toward the pooled one: a pixel whose
        calibrated intervals changed by calib_prior in total is half its own, half pooled.
    gap_variance : float
        Gaps in the event stream (not in the paper; sim.gaps: dropped packets, exposure-gated exports). The variance
        (log^2) added to every pixel's P at the end of a gap: the log intensity changed by an unknown amount while no
        events were recorded. 1 (a change of a factor e, one sigma) dwarfs a well-exposed frame's R (about 1e-5), so
        the continuous measurement pulls the state onto the interval's curve within microseconds, a curve that
        carries the change the events missed (the next frame's deblurred level minus the events' change, shared among
        the interval's gaps by duration: akf.filter). Gaps also keep their intervals out of the eq. 12 calibration.
    """

    sigma_proc2: float = 5e-4
    sigma_iso2: float = 0.03
    sigma_ref2: float = 0.05
    rho_bar_us: int = 5000
    sigma_im2: float = 1e-6
    max_variance: float = 1e-2
    i0: float = 1e-3
    bias_max_variance: float = 0.1
    p0: float = 0.09
    frame_update: bool = True
    read_noise_dn: float | None = None
    smooth_range: float = 4.0
    smooth_variance: float = 3e-5
    clip_prior: bool = True
    flat_field: bool = True
    smoother_drift2: float = 1.0
    clip_prior_variance: float = 16.0
    deblur: bool = True
    calibrate: bool = True
    calib_min_events: int = 2
    calib_scale_range: tuple[float, float] = (0.5, 2.0)
    calib_prior: float = 1.0
    gap_variance: float = 1.0

    def __post_init__(self) -> None:
        """Check every field once, here (the boundary): each error names the field."""
        for name in ("deblur", "calibrate", "frame_update", "clip_prior", "flat_field"):
            if not isinstance(getattr(self, name), bool):
                raise InvalidParameterError(f"AKFParams.{name} must be a bool, got {getattr(self, name)!r}")
        for name in ("rho_bar_us", "calib_min_events"):
            check_int(f"AKFParams.{name}", getattr(self, name), minimum=0,
                      unit="microseconds" if name == "rho_bar_us" else "")
        for name in POSITIVE_FIELDS:
            check_number(f"AKFParams.{name}", getattr(self, name), positive=True)
        if self.read_noise_dn is not None:
            check_number("AKFParams.read_noise_dn", self.read_noise_dn, positive=False)
        for name in ("bias_max_variance", "calib_prior", "smooth_range", "smoother_drift2"):
            check_number(f"AKFParams.{name}", getattr(self, name), positive=False)
        pair = self.calib_scale_range
        if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
            raise InvalidParameterError(f"AKFParams.calib_scale_range must be a (min, max) pair, got {pair!r}")
        lo, hi = (check_number(f"AKFParams.calib_scale_range[{i}]", v, positive=True) for i, v in enumerate(pair))
        if not lo <= 1 <= hi:
            raise InvalidParameterError(f"AKFParams.calib_scale_range must satisfy 0 < min <= 1 <= max, got {pair}")
        object.__setattr__(self, "calib_scale_range", (lo, hi))
        if self.max_variance < self.sigma_im2:
            raise InvalidParameterError(
                f"AKFParams.max_variance={self.max_variance} must be >= sigma_im2={self.sigma_im2}"
            )


#: the AKFParams fields that must be > 0: every noise variance (a zero variance claims noise-free events or frames:
#: the state variance then never grows between frames, or a frame is taken as exact), i0 (log(I + i0) at I = 0)
POSITIVE_FIELDS = ("sigma_proc2", "sigma_iso2", "sigma_ref2", "sigma_im2", "max_variance", "i0", "p0",
                   "smooth_variance", "clip_prior_variance", "gap_variance")
