"""Input conditioning: the frames of a video or of a real camera, cleaned of what a real scene does not do
before they reach the DVS model.

A DVS pixel fires on a log-intensity change of a few tens of percent. In the frames that feed it, two things
change a static pixel that the scene did not: the camera's temporal read noise (real APS frames: 1.4-1.8 DN rms on
a DAVIS346) and the codec of a compressed video (quantisation error that wanders from frame to frame and jumps at
every key frame, when the whole picture is coded afresh). On dark pixels either is a large log change, so without
conditioning it becomes a stream of noise events, and key frames become whole-frame bursts.

InputConditioner is one per-pixel temporal filter for both, applied to each frame in order, in the input's code
values (DN: 0..255 for 8-bit video and images, 0..65535 for 16-bit), before any interpolation:

- a hold band (the "play" or backlash operator of hysteresis models; Krasnosel'skii and Pokrovskii 1989
  [Krasnoselskii1989]): the output stays put while the input is within +-tau of it, and follows with a lag of tau
  when the input leaves the band. A change larger than the band (a moving edge, a light switched on) passes at
  once, less tau; noise and codec wander inside the band never reach the DVS. Optionally (`track` > 0, default 0)
  the output also moves that fraction of the way to the input per frame inside the band (a first-order recursive
  filter, as in motion-adaptive temporal noise filters; Brailean et al. 1995 [Brailean1995]): slow changes
  smaller than tau then pass as ramps, and so does codec wander;
- motion passes whole: a pixel whose mean |change| over the 5 x 5 window around it exceeds 2 noise rms (noise
  alone gives 1.13 on average, and the window's mean varies by about 0.25) is moving and follows its input
  exactly (except at key frames), as in motion-adaptive temporal filters;
- tau = threshold_sigmas x sigma, where sigma is the temporal noise rms in DN: `noise_dn` when given (a calibrated
  camera), else estimated from the clip: per frame pair, from the lower quartile of |change around its median|
  (robust to motion on up to 3/4 of the picture; a uniform change, a light, is not noise) over 0.3186 (that of a
  normal variable) and sqrt(2) (one frame's share of a difference); sigma is the running median of that over the
  last 64 ordinary pairs, within [min_noise_dn, max_noise_dn];
- key frames (`key_frames`, compressed video): with s the rms of the change around its median over the pixels at or
  below its 90th percentile, a pair whose s exceeds key_frame_ratio x its running median (and half a code value), that
  looks like a re-encoding (s at most max_artefact_dn, a common shift no larger than s) and whose predecessor was not
  one is a key frame (the first pair never is). At a key frame, every still pixel (within tau of its recent mean, a
  time constant of 8 frames) is re-centred: its codec bias becomes input - output (clipped to +-max_artefact_dn), and
  the bias is subtracted from this and later frames, so that the fresh coding error never reaches the DVS and the band
  is centred for the next group of pictures. A pixel whose content then changes by more than max_artefact_dn drops its
  bias (the change passes whole). The price: a real change smaller than max_artefact_dn at a still pixel that
  coincides with a key frame is taken for codec error. Not handled: an encoder's refinement of its first picture over
  the next frames (on the synthetic clip of tests/test_video_input.py, most of the static events left come from the
  first 0.1 s).

The filter holds four frames of state (height x width float32) and is deterministic: reset() and the same frames give
the same output. describe() states the settings; stats() what was measured (noise estimate, key frames found,
the fraction of pixel updates held in the band).

References (docs/models/references.md): Krasnosel'skii and Pokrovskii 1989 [Krasnoselskii1989], the play operator;
Brailean et al. 1995 [Brailean1995], temporal noise filters.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import cv2
import numpy as np
from numba import njit

from sim import InvalidParameterError

__all__ = ["CONDITIONING_MODES", "ConditioningParams", "InputConditioner", "condition_linear"]

#: the values of ConditioningParams.mode: "temporal" (the filter of the module docstring), "off" (frames unchanged)
CONDITIONING_MODES = ("temporal", "off")
_HISTORY = 64  # pairs of noise estimates kept for the running median
_MEAN_GAIN = 0.125  # per frame: a pixel's recent mean follows with a time constant of 8 frames
_CODE_STEP_DN = 0.5  # a change spread narrower than half a code value is rounding, whatever the ratio
_QUARTILE_OF_ABS_NORMAL = 0.3186  # the 25th percentile of |N(0, 1)|
_WINDOW = 5  # pixels: the side of the window over which a change counts as motion
_MOVING_SIGMAS = 2.0  # a window whose mean |change| exceeds this many noise rms is moving (noise alone: 1.13)
_SAMPLE = 1 << 16  # pixels sampled (evenly) for the noise estimate
_DECILE = 90  # percentile of |frame difference| above which pixels count as moving in the noise estimate


@dataclass(frozen=True)
class ConditioningParams:
    """Settings of InputConditioner (module docstring).

    Attributes
    ----------
    mode : str
        "temporal" (the hold band with tracking; default) or "off" (frames pass unchanged).
    noise_dn : float or None
        Temporal noise rms of a static pixel in input code values (DN) at the sensor size, or None (default) to
        estimate it from the clip.
    threshold_sigmas : float
        Half-width of the hold band in units of the noise rms (default 3).
    track : float
        Fraction of the in-band difference followed per frame, in [0, 1] (default 0: held until the band is left).
    key_frame_ratio : float
        A frame pair whose noise estimate exceeds this multiple of the running median is a key frame (default 2).
    min_noise_dn, max_noise_dn : float
        Bounds of the estimated noise (DN; default 1 and 2; 8-bit quantisation alone gives 0.29; motion over most of
        the picture inflates the estimate, hence the ceiling).
    key_frames : bool
        Detect key frames (compressed video; default True); False for the frames of a camera (no codec).
    max_artefact_dn : float
        A frame pair whose change spreads wider than this (DN) is never taken for a key frame (default 16).
    """

    mode: str = "temporal"
    noise_dn: float | None = None
    threshold_sigmas: float = 3.0
    track: float = 0.0
    key_frame_ratio: float = 2.0
    min_noise_dn: float = 1.0
    max_noise_dn: float = 2.0
    key_frames: bool = True
    max_artefact_dn: float = 16.0

    def __post_init__(self):
        if self.mode not in CONDITIONING_MODES:
            raise InvalidParameterError(f"conditioning mode must be one of {', '.join(CONDITIONING_MODES)}, "
                                        f"got {self.mode!r}")
        if not isinstance(self.key_frames, bool):
            raise InvalidParameterError(f"conditioning key_frames must be true or false, got {self.key_frames!r}")
        given = ("noise_dn",) if self.noise_dn is not None else ()
        for name in ("threshold_sigmas", "key_frame_ratio", "min_noise_dn", "max_noise_dn", "max_artefact_dn") + given:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v <= 0:
                raise InvalidParameterError(f"conditioning {name} must be a finite number > 0, got {v!r}")
        if isinstance(self.track, bool) or not isinstance(self.track, (int, float)) or not 0 <= self.track <= 1:
            raise InvalidParameterError(f"conditioning track must be a number in [0, 1], got {self.track!r}")

    @classmethod
    def from_option(cls, option: ConditioningParams | dict | str | None) -> ConditioningParams:
        """From a scene option. Unknown keys raise InvalidParameterError listing the allowed ones.

        Parameters
        ----------
        option : ConditioningParams, dict, str or None
            None (the defaults), a mode name ("temporal", "off"), a table of fields (units as the Attributes) or an
            instance.

        Returns
        -------
        ConditioningParams
            The settings.
        """
        if option is None:
            return cls()
        if isinstance(option, cls):
            return option
        if isinstance(option, str):
            return cls(mode=option)
        if isinstance(option, dict):
            allowed = tuple(cls.__dataclass_fields__)
            unknown = sorted(set(option) - set(allowed))
            if unknown:
                raise InvalidParameterError(f"unknown conditioning key {unknown[0]!r}; allowed: {', '.join(allowed)}")
            return cls(**option)
        raise InvalidParameterError(f"conditioning must be a mode name ({', '.join(CONDITIONING_MODES)}) or a table "
                                    f"of {', '.join(cls.__dataclass_fields__)}, got {option!r}")


class InputConditioner:
    """The per-pixel temporal filter of the module docstring. Call it on each frame (float DN, (H, W)) in order;
    it returns the conditioned frame (float32, DN). reset() starts again from the next frame.

    Parameters
    ----------
    params : ConditioningParams, dict, str or None, optional
        The settings, as ConditioningParams.from_option takes them (default: the defaults).
    """

    def __init__(self, params: ConditioningParams | dict | str | None = None):
        self.params = ConditioningParams.from_option(params)
        self.reset()

    def reset(self) -> None:
        self._out: np.ndarray | None = None
        self._prev: np.ndarray | None = None
        self._spreads: list[float] = []
        self._noises: list[float] = []
        self.n_frames = 0
        self.key_frames: list[int] = []
        self._held = 0
        self._updates = 0
        self._sigmas: list[float] = []

    def __call__(self, frame_dn: np.ndarray) -> np.ndarray:
        c = np.asarray(frame_dn, dtype=np.float32)
        p = self.params
        k = self.n_frames
        self.n_frames += 1
        if p.mode == "off":
            return c
        if self._out is None:
            c = np.ascontiguousarray(c)
            self._out, self._prev, self._mean = c.copy(), c.copy(), c.copy()
            self._bias = np.zeros_like(c)
            return self._out.copy()
        c = np.ascontiguousarray(c)
        sigma, recoding = self._noise(c, k)
        tau = p.threshold_sigmas * sigma
        # moving pixels: the change around them, averaged over a window, stands out of the noise (not at key
        # frames, whose re-encoding changes whole regions)
        local = cv2.blur(np.abs(c - self._prev), (_WINDOW, _WINDOW), borderType=cv2.BORDER_REFLECT)
        moving = (local > np.float32(_MOVING_SIGMAS * sigma)) if not recoding else np.zeros(c.shape, np.bool_)
        held = _update(c.ravel(), self._prev.ravel(), self._mean.ravel(), self._bias.ravel(), self._out.ravel(),
                       moving.ravel(), tau, recoding, p.key_frames, p.max_artefact_dn, p.track, _MEAN_GAIN)
        self._held += held
        self._updates += c.size
        return self._out.copy()

    def _noise(self, c: np.ndarray, k: int) -> tuple[float, bool]:
        """(noise rms in DN for frame k: the given noise_dn or the running estimate; whether frame k is a key
        frame) (module docstring)."""
        p = self.params
        e = (c - self._prev).ravel()
        e = e[::max(1, e.size // _SAMPLE)]
        shift = float(np.median(e))
        e = np.abs(e - np.float32(shift))  # a uniform change (a light) is not noise
        cut = np.percentile(e, _DECILE)
        spread = float(np.sqrt(np.mean(np.square(e[e <= cut]))))  # rms change of the still pixels
        # a re-encoding changes the picture like noise, by a few DN, with no common shift larger than its spread
        recoded = p.key_frames and spread <= p.max_artefact_dn and abs(shift) <= spread
        # the noise of one frame from the lower quartile of |change| (robust to motion on up to 3/4 of the picture)
        noise = float(np.percentile(e, 25)) / _QUARTILE_OF_ABS_NORMAL / np.sqrt(2.0)
        first = not self._spreads
        if first:  # the first pair starts the history
            self._spreads.append(spread)
            self._noises.append(noise)
        typical = float(np.median(self._spreads))
        sigma = (float(p.noise_dn) if p.noise_dn is not None
                 else min(max(p.min_noise_dn, float(np.median(self._noises))), p.max_noise_dn))
        self._sigmas.append(sigma)
        isolated = not self.key_frames or self.key_frames[-1] != k - 1  # a key frame stands alone
        if not first and recoded and isolated and spread > p.key_frame_ratio * max(typical, _CODE_STEP_DN):
            self.key_frames.append(k)
            return sigma, True
        if not first:
            self._spreads.append(spread)
            self._noises.append(noise)
            del self._spreads[:-_HISTORY], self._noises[:-_HISTORY]
        return sigma, False

    def describe(self) -> dict:
        """The settings (the same before and after frames are processed).

        Returns
        -------
        dict
            JSON-serialisable: the ConditioningParams fields (DN where a noise level), the domain and the method;
            {"mode": "off"} when off.
        """
        p = self.params
        if p.mode == "off":
            return {"mode": "off"}
        return {**asdict(p), "domain": "input code values (DN), per pixel, before interpolation",
                "method": "hold band of +-threshold_sigmas x noise rms (play operator); key frames (noise-like "
                          "changes > key_frame_ratio x the running median) absorbed into a per-pixel codec bias"}

    def stats(self) -> dict:
        """What was measured over the frames so far.

        Returns
        -------
        dict
            "frames" (count), "noise_dn_median" (the median noise rms used, DN, or None before a pair),
            "key_frames" (count found), "first_key_frames" (the first 8 frame indices), "held_fraction" (of the
            pixel updates held in the band).
        """
        return {"frames": self.n_frames, "noise_dn_median": float(np.median(self._sigmas)) if self._sigmas else None,
                "key_frames": len(self.key_frames), "first_key_frames": self.key_frames[:8],
                "held_fraction": self._held / max(self._updates, 1)}


@njit(cache=True, nogil=True)
def _update(c, prev, mean, bias, out, moving, tau, recoding, key_frames, max_artefact, track,
            mean_gain):  # pragma: no cover
    """One frame of InputConditioner on flat float32 arrays (DN), in place: at a key frame (recoding) the bias of
    still pixels becomes input - output (clipped to +-max_artefact); the recent mean and previous frame follow the
    input; the output is target = input - bias at moving pixels and elsewhere follows it through the hold band of
    +-tau (after `track` of the in-band difference), dropping the bias where the content changed by more than
    max_artefact. Returns the number of pixels held in the band."""
    held = 0
    for i in range(c.size):
        ci = c[i]
        if recoding and abs(prev[i] - mean[i]) <= tau:
            bias[i] = min(max(ci - out[i], -max_artefact), max_artefact)
        mean[i] += mean_gain * (ci - mean[i])
        prev[i] = ci
        o = out[i]
        target = ci - bias[i]
        if track > 0:
            o += track * (target - o)
        if key_frames and abs(target - o) > max_artefact:  # the content changed: its codec bias is stale
            bias[i] = 0.0
            target = ci
        d = target - o
        if moving[i]:
            o = target
        elif d > tau:
            o = target - tau
        elif d < -tau:
            o = target + tau
        else:
            held += 1
        out[i] = o
    return held


@njit(cache=True, nogil=True)
def _to_codes(y, lut, guide, scale, out):  # pragma: no cover
    """out = the code value of each linear value of y, piecewise linear in the non-decreasing table lut (clamped at
    its ends); guide[j] is the last index i with lut[i] <= lut[0] + j / scale, where the search starts."""
    n = lut.size
    lo0, top = lut[0], lut[n - 1]
    for i in range(y.size):
        v = y[i]
        if v <= lo0:
            out[i] = 0.0
        elif v >= top:
            out[i] = n - 1.0
        else:
            k = guide[min(int((v - lo0) * scale), guide.size - 1)]
            while k < n - 2 and lut[k + 1] <= v:
                k += 1
            span = lut[k + 1] - lut[k]
            out[i] = k + ((v - lut[k]) / span if span > 0 else 0.0)
    return out


@njit(cache=True, nogil=True)
def _from_codes(dn, lut, out):  # pragma: no cover
    """out = lut interpolated linearly at the (fractional) code values dn, clamped to [0, lut.size - 1]."""
    n = lut.size
    for i in range(dn.size):
        v = min(max(dn[i], 0.0), n - 1.0)
        k = min(int(v), n - 2)
        out[i] = lut[k] + (lut[k + 1] - lut[k]) * (v - k)
    return out


_GUIDE_BINS = 4096


def condition_linear(conditioner: InputConditioner, y: np.ndarray, lut: np.ndarray) -> np.ndarray:
    """Condition a frame of linear values: to codes, through the conditioner, back to linear.

    Parameters
    ----------
    conditioner : InputConditioner
        The filter (its state advances by one frame).
    y : numpy.ndarray
        (H, W) linear values (the linearisation's units), as float32.
    lut : numpy.ndarray
        The linearisation table, non-decreasing: lut[code] is the linear value of input code value code (DN).

    Returns
    -------
    numpy.ndarray
        float32 (H, W) conditioned linear values.
    """
    lut = np.ascontiguousarray(lut, dtype=np.float32)
    flat = np.ascontiguousarray(y, dtype=np.float32).ravel()
    scale = _GUIDE_BINS / max(float(lut[-1] - lut[0]), 1e-30)
    grid = lut[0] + np.arange(_GUIDE_BINS, dtype=np.float64) / scale
    guide = np.clip(np.searchsorted(lut, grid, side="right") - 1, 0, lut.size - 2).astype(np.int64)
    dn = conditioner(_to_codes(flat, lut, guide, scale, np.empty_like(flat)).reshape(y.shape))
    return _from_codes(dn.ravel(), lut, np.empty_like(flat)).reshape(y.shape)
