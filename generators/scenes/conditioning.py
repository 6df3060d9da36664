"""Input conditioning: the frames of a video or of a real camera, cleaned of what a real scene does not do
before they reach the DVS model.

A DVS pixel fires on a log-intensity change of a few tens of percent. In the frames that feed it, two things
change a static pixel that the scene did not: the camera's temporal read noise (real APS frames: 1.4-1.8 DN rms on
a DAVIS346) and the codec of a compressed video (quantisation error that wanders from frame to frame and jumps at
every key frame, when the whole picture is coded afresh). On dark pixels either is a large log change, so without
conditioning it becomes a stream of noise events, and key frames become whole-frame bursts.

InputConditioner is one per-pixel temporal filter for both, applied to each frame in order, in the input's code
values (DN: 0..255 for 8-bit video and images, 0..65535 for 16-bit), before any interpolation:

- a hold band (the "play" or backlash operator of hysteresis models; Krasnosel'skii & Pokrovskii, "Systems with
  Hysteresis", 1989): the output stays put while the input is within +-tau of it, and follows with a lag of tau
  when the input leaves the band. A change larger than the band (a moving edge, a light switched on) passes at
  once, less tau; noise and codec wander inside the band never reach the DVS;
- within the band the output moves a fraction `track` of the way to the input per frame (a first-order recursive
  filter, as in motion-adaptive temporal noise filters; Brailean, Kleihorst, Efstratiadis, Katsaggelos & Lagendijk,
  "Noise reduction filters for dynamic image sequences: a review", Proc. IEEE 1995), so that the lag of tau decays
  and slow true changes smaller than tau per frame are followed;
- tau = threshold_sigmas x sigma_k, where sigma_k is the temporal noise rms in DN: `noise_dn` when given (a
  calibrated camera), else estimated from the clip: per frame pair k, s_k is the rms of the frame difference over
  the pixels whose |difference| is at or below its 90th percentile (moving pixels are the top decile and left
  out), and sigma_k is the running median of s over the pairs so far over sqrt(2) (the noise of one frame), at
  least min_noise_dn. A pair whose s_k exceeds key_frame_ratio x that median (and min_noise_dn) is a key frame (a
  whole-frame re-encoding: one step, not the difference of two noises) when it also looks like one: a spread of at
  most max_artefact_dn and a common shift (median change) no larger than the spread. Its changes within
  +-threshold_sigmas x s_k join a per-pixel codec bias that is subtracted from this and later frames, so that the
  re-encoding never reaches the DVS while larger, real changes pass. The estimates use the change around its
  median, so a uniform change (a light switched on) is not taken for noise.

The filter holds one frame of state (height x width float32) and is deterministic: reset() and the same frames give
the same output. describe() states the settings; stats() what was measured (noise estimate, key frames found,
the fraction of pixel updates held in the band).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from sim import InvalidParameterError

CONDITIONING_MODES = ("temporal", "off")
_HISTORY = 64  # pairs of noise estimates kept for the running median
_SAMPLE = 1 << 16  # pixels sampled (evenly) for the noise estimate
_DECILE = 90  # percentile of |frame difference| above which pixels count as moving in the noise estimate


@dataclass(frozen=True)
class ConditioningParams:
    """Settings of InputConditioner (module docstring).

    mode: "temporal" (the hold band with tracking) or "off" (frames pass unchanged).
    noise_dn: temporal noise rms of a static pixel in input code values (DN) at the sensor size, or None to estimate
        it from the clip.
    threshold_sigmas: half-width of the hold band in units of the noise rms.
    track: fraction of the in-band difference followed per frame (0..1; 0 holds until the band is left).
    key_frame_ratio: a frame pair whose noise estimate exceeds this multiple of the running median is a key frame.
    min_noise_dn: floor of the estimated noise (DN; 8-bit quantisation alone gives 0.29).
    key_frames: detect key frames (compressed video); False for the frames of a camera (no codec).
    max_artefact_dn: a frame pair whose change spreads wider than this (DN) is never taken for a key frame.
    """

    mode: str = "temporal"
    noise_dn: float | None = None
    threshold_sigmas: float = 3.0
    track: float = 0.0
    key_frame_ratio: float = 2.0
    min_noise_dn: float = 0.5
    key_frames: bool = True
    max_artefact_dn: float = 16.0

    def __post_init__(self):
        if self.mode not in CONDITIONING_MODES:
            raise InvalidParameterError(f"conditioning mode must be one of {', '.join(CONDITIONING_MODES)}, "
                                        f"got {self.mode!r}")
        if not isinstance(self.key_frames, bool):
            raise InvalidParameterError(f"conditioning key_frames must be true or false, got {self.key_frames!r}")
        given = ("noise_dn",) if self.noise_dn is not None else ()
        for name in ("threshold_sigmas", "key_frame_ratio", "min_noise_dn", "max_artefact_dn") + given:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v <= 0:
                raise InvalidParameterError(f"conditioning {name} must be a finite number > 0, got {v!r}")
        if isinstance(self.track, bool) or not isinstance(self.track, (int, float)) or not 0 <= self.track <= 1:
            raise InvalidParameterError(f"conditioning track must be a number in [0, 1], got {self.track!r}")

    @classmethod
    def from_option(cls, option: ConditioningParams | dict | str | None) -> ConditioningParams:
        """From a scene option: None (the defaults), a mode name ("temporal", "off"), a table of fields or an
        instance. Unknown keys raise InvalidParameterError listing the allowed ones."""
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
    it returns the conditioned frame (float32, DN). reset() starts again from the next frame."""

    def __init__(self, params: ConditioningParams | dict | str | None = None):
        self.params = ConditioningParams.from_option(params)
        self.reset()

    def reset(self) -> None:
        self._out: np.ndarray | None = None
        self._prev: np.ndarray | None = None
        self._spreads: list[float] = []
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
            self._out, self._prev, self._bias = c.copy(), c, np.zeros_like(c)
            return self._out.copy()
        sigma, key_sigma = self._noise(c, k)
        if key_sigma is not None:  # a re-encoding: its in-band steps join the per-pixel codec bias
            step = c - self._prev
            self._bias += np.where(np.abs(step) <= np.float32(p.threshold_sigmas * key_sigma), step, 0)
        self._prev = c
        target = c - self._bias
        tau = np.float32(p.threshold_sigmas * sigma)
        out = self._out
        if p.track:
            out += np.float32(p.track) * (target - out)  # follow within the band
        d = target - out
        leave = np.abs(d) > tau
        out[leave] = target[leave] - np.sign(d[leave]) * tau  # follow with a lag of tau outside it
        self._held += int(leave.size - np.count_nonzero(leave))
        self._updates += leave.size
        return out.copy()

    def _noise(self, c: np.ndarray, k: int) -> tuple[float, float | None]:
        """(noise rms in DN for frame k: the given noise_dn or the running estimate; the spread of the frame's
        own change if it is a key frame, else None) (module docstring)."""
        p = self.params
        e = (c - self._prev).ravel()
        e = e[::max(1, e.size // _SAMPLE)]
        shift = float(np.median(e))
        e = np.abs(e - np.float32(shift))  # a uniform change (a light) is not noise
        cut = np.percentile(e, _DECILE)
        spread = float(np.sqrt(np.mean(np.square(e[e <= cut]))))  # rms change of the still pixels
        # a re-encoding changes the picture like noise, by a few DN, with no common shift larger than its spread
        recoded = p.key_frames and spread <= p.max_artefact_dn and abs(shift) <= spread
        first = not self._spreads
        if first:  # the first pair starts the history; it is a key frame if it stands out of min_noise_dn alone
            self._spreads.append(spread)
        typical = float(np.median(self._spreads))
        sigma = float(p.noise_dn) if p.noise_dn is not None else max(p.min_noise_dn, typical / np.sqrt(2.0))
        self._sigmas.append(sigma)
        if recoded and spread > p.key_frame_ratio * (p.min_noise_dn if first else max(typical, p.min_noise_dn)):
            self.key_frames.append(k)
            return sigma, spread
        if first:
            return sigma, None
        self._spreads.append(spread)
        del self._spreads[:-_HISTORY]
        return sigma, None

    def describe(self) -> dict:
        """The settings (JSON-serialisable; the same before and after frames are processed)."""
        p = self.params
        if p.mode == "off":
            return {"mode": "off"}
        return {**asdict(p), "domain": "input code values (DN), per pixel, before interpolation",
                "method": "hold band of +-threshold_sigmas x noise rms (play operator); key frames (noise-like "
                          "changes > key_frame_ratio x the running median) absorbed into a per-pixel codec bias"}

    def stats(self) -> dict:
        """What was measured over the frames so far: frames, median noise rms used (DN), key frames found (count
        and the first 8 frame indices), the fraction of pixel updates held in the band."""
        return {"frames": self.n_frames, "noise_dn_median": float(np.median(self._sigmas)) if self._sigmas else None,
                "key_frames": len(self.key_frames), "first_key_frames": self.key_frames[:8],
                "held_fraction": self._held / max(self._updates, 1)}
