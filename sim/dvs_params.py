"""DVS pixel parameters (`DVSParams`) and named sensor presets.

Log units are natural logarithms of radiance; rates are per pixel; times are microseconds unless the name says Hz.

References (docs/models/references.md): Brandli et al. 2014 [Brandli2014a], the DAVIS; Hu et al. 2021 [Hu2021], v2e.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .errors import InvalidParameterError, check_int, check_number, check_override_names


@dataclass(frozen=True)
class DVSParams:
    """Configuration of the DVS emulator. Every field is validated on construction.

    Attributes
    ----------
    pos_threshold, neg_threshold : float
        Mean ON / OFF contrast thresholds C_on, C_off (natural-log units, > 0).
    threshold_sigma : float
        Standard deviation of the per-pixel Gaussian threshold mismatch (log units, >= 0); ON and OFF thresholds are
        drawn independently and fixed for the sensor (seeded).
    min_threshold : float
        Positive floor the per-pixel thresholds are clamped to (log units, > 0).
    refractory_us : int
        Dead time after each event (integer microseconds, >= 0). See sim.dvs for the reset semantics.
    cutoff_hz : float
        Photoreceptor bandwidth (first-order low-pass, Hz) when the photocurrent equals full_illumination; it scales in
        proportion to radiance + dark level. 0 disables the filter (ideal, infinitely fast pixel).
    full_illumination : float
        The radiance (in the caller's units) that counts as full illumination (> 0).
    dark_fraction : float
        The dark current expressed as radiance, relative to full_illumination (> 0). The pixel responds to log(radiance
        + dark_fraction * full_illumination): logarithmic above that level, linear below it.
    shot_noise_hz : float
        Rate of shot-noise events (ON and OFF together, Hz per pixel) at any illumination (>= 0).
    dark_shot_noise_hz : float
        Additional shot-noise rate in complete darkness (Hz per pixel, >= 0); it falls off as dark / (radiance + dark),
        so noise rises in the dark as in real sensors.
    leak_hz : float
        Mean reference drift, as the rate of the leak ON events it gives a static pixel without noise or refractory (Hz
        per pixel, >= 0; the reference drifts down leak_hz * C_on log units per second; the AKF's leak_rate_hz is this
        rate). Shot noise resets the reference and restarts the drift, so with noise a static pixel shows fewer leak
        events (0.058 Hz for 0.1 with 0.1 Hz shot noise): observed_leak_hz gives that rate, with_observed_leak the
        leak_hz that shows a measured one.
    leak_spread : float
        Standard deviation of the natural log of the per-pixel leak rate (log-normal spread, >= 0); the per-pixel rates
        average to leak_hz.
    hot_pixel_fraction : float
        Fraction of pixels that are hot, in [0, 1] (rounded to a whole number of pixels).
    hot_pixel_hz : float
        Poisson rate of the extra events of each hot pixel (ON and OFF together, Hz, >= 0).
    dead_pixel_fraction : float
        Fraction of pixels that never fire, signal or noise (stuck or masked pixels, as the Prophesee simulator models
        them), in [0, 1] (rounded to a whole number of pixels; a dead pixel drawn among the hot ones is dead).
    """

    pos_threshold: float = 0.2
    neg_threshold: float = 0.2
    threshold_sigma: float = 0.03
    min_threshold: float = 0.01
    refractory_us: int = 100
    cutoff_hz: float = 300.0
    full_illumination: float = 1.0
    dark_fraction: float = 1e-4
    shot_noise_hz: float = 0.1
    dark_shot_noise_hz: float = 1.0
    leak_hz: float = 0.1
    leak_spread: float = 0.5
    hot_pixel_fraction: float = 5e-4
    hot_pixel_hz: float = 50.0
    dead_pixel_fraction: float = 0.0

    def __post_init__(self) -> None:
        for name in ("pos_threshold", "neg_threshold", "min_threshold", "full_illumination", "dark_fraction"):
            check_number(name, getattr(self, name), positive=True)
        for name in ("threshold_sigma", "cutoff_hz", "shot_noise_hz", "dark_shot_noise_hz", "leak_hz",
                     "leak_spread", "hot_pixel_fraction", "hot_pixel_hz", "dead_pixel_fraction"):
            check_number(name, getattr(self, name), positive=False)
        for name in ("hot_pixel_fraction", "dead_pixel_fraction"):
            if getattr(self, name) > 1:
                raise InvalidParameterError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        # a numpy integer is stored as an int (the parameters go into JSON metadata)
        object.__setattr__(self, "refractory_us", check_int("refractory_us", self.refractory_us, minimum=0,
                                                            unit="microseconds"))

    @classmethod
    def preset(cls, name: str, **overrides: object) -> DVSParams:
        """The named preset (see PRESETS), with any field replaced by a keyword override.

        Parameters
        ----------
        name : str
            A PRESETS name ("ideal", "davis346", "davis346_road", "noisy").
        **overrides
            DVSParams fields to replace (units: FIELD_UNITS).

        Returns
        -------
        DVSParams
            The parameters.
        """
        try:
            base = PRESETS[name]
        except KeyError:
            raise InvalidParameterError(f"unknown DVS preset {name!r}; known: {sorted(PRESETS)}") from None
        check_override_names("DVSParams.preset", cls, overrides)
        return dataclasses.replace(base, **overrides)

    def observed_leak_hz(self, radiance: float = 1.0, leak_hz: float | None = None) -> float:
        """Leak event rate (Hz) of a static pixel at `radiance` with these params' shot noise and refractory.

        For one pixel of drift rate leak_hz (default self.leak_hz; the per-pixel spread aside): every event resets
        the reference, after a dead time r = refractory_us, so with shot-noise rate lam (at that radiance) and
        drift period T = 1 / leak_hz, a leak event ends a cycle r + min(Exp(lam), T) with probability
        u = e^(-lam T): the rate is u / (r + (1 - u) / lam) (1 / (r + T) without noise).

        Parameters
        ----------
        radiance : float, optional
            The pixel's radiance (radiance units, as full_illumination), >= 0 (default 1).
        leak_hz : float, optional
            Drift rate (Hz); default self.leak_hz.

        Returns
        -------
        float
            Observed leak events per second (Hz); 0 when the drift rate is 0.
        """
        rate = self.leak_hz if leak_hz is None else float(leak_hz)
        if rate <= 0:
            return 0.0
        lam, r, period = self._static_shot_hz(radiance), self.refractory_us * 1e-6, 1.0 / rate
        if lam <= 0:
            return 1.0 / (r + period)
        u = math.exp(-lam * period)
        return u / (r + -math.expm1(-lam * period) / lam)

    def with_observed_leak(self, observed_hz: float, radiance: float = 1.0) -> DVSParams:
        """A copy whose leak_hz makes a static pixel at `radiance` show `observed_hz` leak events (Hz).

        The inverse of observed_leak_hz: what to set when the leak rate was measured on a real, noisy sensor.

        Parameters
        ----------
        observed_hz : float
            The measured leak event rate (Hz), >= 0, below 1 / refractory period.
        radiance : float, optional
            The radiance it was measured at (radiance units), >= 0 (default 1).

        Returns
        -------
        DVSParams
            A copy with leak_hz set.
        """
        check_number("observed_hz", observed_hz, positive=False)
        o = float(observed_hz)
        if o == 0:
            return self.replace(leak_hz=0.0)
        lam, r = self._static_shot_hz(radiance), self.refractory_us * 1e-6
        if o * r >= 1:
            raise InvalidParameterError(f"observed_hz {o} is not reachable with refractory_us={self.refractory_us}")
        if lam <= 0:
            return self.replace(leak_hz=1.0 / (1.0 / o - r))
        u = o * (r * lam + 1.0) / (lam + o)  # solves o = u / (r + (1 - u) / lam)
        return self.replace(leak_hz=lam / -math.log(u))

    def _static_shot_hz(self, radiance: float) -> float:
        check_number("radiance", radiance, positive=False)
        i = float(radiance)
        dark = self.dark_fraction * self.full_illumination
        return self.shot_noise_hz + self.dark_shot_noise_hz * dark / (i + dark)

    def replace(self, **changes: object) -> DVSParams:
        """A copy with some fields changed (validated again).

        Parameters
        ----------
        **changes
            DVSParams fields to change (units: FIELD_UNITS).

        Returns
        -------
        DVSParams
            The copy.
        """
        return dataclasses.replace(self, **changes)


#: named DVS configurations (DVSParams.preset(name, **overrides)): "ideal", "davis346" (the defaults, a guess),
#: "davis346_road" (fitted to a real DAVIS346 recording) and "noisy"
PRESETS: dict[str, DVSParams] = {
    # A perfect log-contrast detector: no mismatch, no refractory, no bandwidth limit, no noise.
    "ideal": DVSParams(
        threshold_sigma=0.0, refractory_us=0, cutoff_hz=0.0, shot_noise_hz=0.0, dark_shot_noise_hz=0.0,
        leak_hz=0.0, hot_pixel_fraction=0.0, hot_pixel_hz=0.0,
    ),
    # A DAVIS346-like sensor under indoor light (the DVSParams defaults): 0.2 log thresholds with 0.03 mismatch,
    # 100 us refractory, 300 Hz photoreceptor at full illumination, 0.1 Hz background activity rising to 1.1 Hz in
    # darkness, 0.1 Hz leak, 0.05 % hot pixels at 50 Hz. A GUESS from typical published figures (v2e's defaults,
    # DAVIS papers), not fitted to any recording: on the real DAVIS346 road recording it gives 2x the events and
    # 75x the static noise (docs/guide/calibrate.md); "davis346_road" is the fitted one.
    "davis346": DVSParams(),
    # FITTED: the DAVIS346 of ../shared/data/events/davis346_road (iniVation DV, daylight road, 25 fps APS frames
    # with a 500 us exposure; MIT, from neuromorphicsystems/aedat) by `evsim calibrate davis346_road.aedat4
    # --window 0.4 2.32` (evsim_eval.calibrate: the recording's own frames simulated as convert does, with its
    # temporal input conditioning, and the realism statistics of the events matched; loss 0.32, 145 simulations).
    # dark_fraction is relative to the 99th percentile of the first frame (convert's auto illumination): a log
    # offset of 38 DN of the 8-bit frames. Fit table and scores: docs/guide/calibrate.md.
    "davis346_road": DVSParams(
        pos_threshold=0.1740, neg_threshold=0.2011, threshold_sigma=0.0472, refractory_us=108, cutoff_hz=334.0,
        dark_fraction=0.1504, shot_noise_hz=0.00223, dark_shot_noise_hz=0.0, leak_hz=0.0,
        hot_pixel_fraction=2.2e-5, hot_pixel_hz=5.99,
    ),
    # The same sensor with the noise of v2e's "noisy" setting (5 Hz shot noise) and more leak and hot pixels.
    "noisy": DVSParams(shot_noise_hz=5.0, dark_shot_noise_hz=10.0, leak_hz=0.5, hot_pixel_fraction=1e-3),
}

#: unit (or kind) of every DVSParams field, for messages, sensor files and `evsim ... --help` (tests check it covers
#: them all)
FIELD_UNITS: dict[str, str] = {
    "pos_threshold": "log units", "neg_threshold": "log units", "threshold_sigma": "log units",
    "min_threshold": "log units", "refractory_us": "us", "cutoff_hz": "Hz at full illumination, 0 = off",
    "full_illumination": "radiance units", "dark_fraction": "fraction of full_illumination",
    "shot_noise_hz": "Hz per pixel", "dark_shot_noise_hz": "Hz per pixel", "leak_hz": "Hz per pixel",
    "leak_spread": "std of log rate", "hot_pixel_fraction": "fraction of pixels", "hot_pixel_hz": "Hz",
    "dead_pixel_fraction": "fraction of pixels",
}
