"""Motion-compensated interpolation between two frames, with OpenCV optical flow (no network, no download).

For a pair of frames 0 and 1 (log radiance L0, L1):
1. bidirectional dense optical flow F01 (pixel p of frame 0 is at p + F01(p) in frame 1) and F10, with OpenCV's
   DIS (default) or Farneback, computed on the log radiance mapped to 8 bits over a fixed range (so that a change
   of exposure or illumination by a constant factor is an offset, not a change of contrast), by default on the
   frames area-resized to half size and resized back (FlowEstimator's scale);
2. occlusion by forward-backward consistency (Sundaram et al., ECCV 2010): p is occluded in the other frame when
   |F01(p) + F10(p + F01(p))|^2 > 0.01 (|F01|^2 + |F10|^2) + 0.5 px^2, or when p + F01(p) leaves the image;
3. at a fraction a in (0, 1) of the interval (the key fractions chosen from the motion: FlowPair), the flows from
   time a back to both frames are approximated from the two flows as in Super SloMo (Jiang et al., CVPR 2018),
   exact for any motion constant over the interval:
   F_a0 = -(1 - a) a F01 + a^2 F10,   F_a1 = (1 - a)^2 F01 - a (1 - a) F10;
   both frames are warped to time a (bicubic interpolation, Keys a = -0.5, in floating point: bilinear
   interpolation blurs texture at half-pixel shifts, which loses events, and OpenCV's remap quantises coordinates
   to 1/32 pixel, which would make neighbouring keys jitter) and blended in log radiance with weights
   w0 = (1 - a) (1 - O1 + d), w1 = a (1 - O0 + d): content about to be hidden comes from frame 0 (O0 warped from
   frame 0: it is not in frame 1), newly revealed content from frame 1; d = 1e-3 keeps both weights positive.
The result is L0 at a = 0, L1 at a = 1 and continuous in a; between key frames the log radiance is linear in time.
"""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit

from sim import InvalidParameterError
from sim.parallel import in_parallel  # row blocks on numba's thread count (the kernels are nogil)

from ..choices import DIS_PRESET_NAMES, FLOW_METHODS

DIS_PRESETS = dict(zip(DIS_PRESET_NAMES, (cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST, cv2.DISOPTICAL_FLOW_PRESET_FAST,
                                           cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)))
# Farneback: pyramid scale, levels, window size, iterations, polynomial size and sigma (OpenCV's suggested values)
_FARNEBACK = (0.5, 4, 15, 3, 5, 1.2, 0)
_FB_ALPHA, _FB_BETA = 0.01, 0.5  # forward-backward consistency: relative (1) and absolute (px^2) tolerance
_WEIGHT_FLOOR = 1e-3
_MIN_ROWS = 32  # rows per thread, at least
FLOW_SCALE = 0.5  # default scale: at 346x260 as accurate as full size (README, "Converting videos"), 1/4 the cost


class FlowEstimator:
    """Bidirectional dense optical flow between frames given as log radiance (float32 (H, W)).

    method: "dis" (OpenCV's DISOpticalFlow with `preset` ultrafast | fast | medium) or "farneback".
    log_range: (low, high) log radiance mapped to 0..255 for the flow computation (values outside are clipped).
    scale: the flow is computed on the frames area-resized by this factor (0 < scale <= 1) and resized back
        (bilinear, vectors divided by the factor); 0.5 (default) costs about a quarter of the full-size flow.
    """

    def __init__(self, log_range: tuple[float, float], method: str = "dis", preset: str = "medium",
                 scale: float = FLOW_SCALE):
        if method not in FLOW_METHODS:
            raise InvalidParameterError(f"flow method must be one of {', '.join(FLOW_METHODS)}, got {method!r}")
        if method == "dis" and preset not in DIS_PRESETS:
            raise InvalidParameterError(f"DIS preset must be one of {', '.join(DIS_PRESETS)}, got {preset!r}")
        low, high = (float(v) for v in log_range)
        if not (np.isfinite(low) and np.isfinite(high) and high > low):
            raise InvalidParameterError(f"log_range must be finite with high > low, got {log_range!r}")
        if not (0 < scale <= 1):
            raise InvalidParameterError(f"flow scale must be in (0, 1], got {scale!r}")
        self.method, self.preset, self.log_range, self.scale = method, preset, (low, high), float(scale)
        self._dis = cv2.DISOpticalFlow_create(DIS_PRESETS[preset]) if method == "dis" else None

    def describe(self) -> dict:
        return {"method": self.method, **({"preset": self.preset} if self.method == "dis" else {}),
                "log_range": list(self.log_range), "scale": self.scale}

    def to_u8(self, log_img: np.ndarray) -> np.ndarray:
        low, high = self.log_range
        u8 = cv2.convertScaleAbs(log_img, alpha=255.0 / (high - low), beta=-255.0 * low / (high - low))
        if self.scale == 1:
            return u8
        h, w = u8.shape
        size = (max(1, round(w * self.scale)), max(1, round(h * self.scale)))
        return cv2.resize(u8, size, interpolation=cv2.INTER_AREA)

    def flow(self, u8_from: np.ndarray, u8_to: np.ndarray) -> np.ndarray:
        """float32 (H, W, 2) flow (dx, dy) in pixels: pixel p of `from` is at p + flow(p) in `to`."""
        if self._dis is not None:
            return self._dis.calc(u8_from, u8_to, None)
        return cv2.calcOpticalFlowFarneback(u8_from, u8_to, None, *_FARNEBACK)

    def pair(self, log0: np.ndarray, log1: np.ndarray, **kwargs) -> FlowPair:
        """The FlowPair of two log-radiance frames (kwargs: key_step_px, max_keys)."""
        u8_0, u8_1 = self.to_u8(log0), self.to_u8(log1)
        f01, f10 = self.flow(u8_0, u8_1), self.flow(u8_1, u8_0)
        if self.scale != 1:
            f01, f10 = (self._full_size(f, log0.shape) for f in (f01, f10))
        return FlowPair(log0, log1, f01, f10, **kwargs)

    @staticmethod
    def _full_size(flow: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """A flow computed on resized frames, resized back to shape (H, W) with its vectors in full-size pixels."""
        h, w = shape
        sy, sx = h / flow.shape[0], w / flow.shape[1]
        out = cv2.resize(flow, (w, h), interpolation=cv2.INTER_LINEAR)
        out[..., 0] *= np.float32(sx)
        out[..., 1] *= np.float32(sy)
        return out


def occlusion(flow_ab: np.ndarray, flow_ba: np.ndarray) -> tuple[np.ndarray, float]:
    """float32 (H, W) mask, 1 where the pixel of frame a is not visible in frame b (forward-backward check, or
    its flow leaves the image), else 0; and the largest |flow_ab| among the visible pixels (pixels)."""
    out = np.empty(flow_ab.shape[:2], dtype=np.float32)
    largest = []
    in_parallel(lambda y0, y1: largest.append(_occlusion(flow_ab, flow_ba, out, y0, y1)), out.shape[0], _MIN_ROWS)
    return out, float(max(largest))


class FlowPair:
    """Two frames (log radiance, float32 (H, W)) with their flows F01, F10 (float32 (H, W, 2), pixels) and
    occlusion masks. log_at(a) gives the log radiance at fraction a of the interval.

    Motion-compensated key frames are synthesised (module docstring) at n_keys - 1 equally spaced fractions
    inside the interval, n_keys = ceil(largest motion / key_step_px) (1 for a still pair, at most max_keys), so
    that the image moves by at most key_step_px between keys; between keys the log radiance is linear in time,
    which is also how the DVS emulator interpolates between its samples. Keys are made when first needed and
    kept for the pair's lifetime (at most max_keys images).
    """

    def __init__(self, log0: np.ndarray, log1: np.ndarray, flow01: np.ndarray, flow10: np.ndarray, *,
                 key_step_px: float = 0.5, max_keys: int = 64):
        self.log0, self.log1 = log0, log1
        self.flow01, self.flow10 = flow01, flow10
        self.occlusion0, m0 = occlusion(flow01, flow10)  # pixels of frame 0 hidden in frame 1
        self.occlusion1, m1 = occlusion(flow10, flow01)  # pixels of frame 1 hidden in frame 0
        self.max_motion_px = max(m0, m1)  # largest displacement over the interval among the visible pixels
        self.n_keys = int(min(max(np.ceil(self.max_motion_px / key_step_px), 1), max_keys))
        self._keys = {0: log0, self.n_keys: log1}

    def key(self, j: int) -> np.ndarray:
        """Key frame j (0..n_keys): the synthesised log radiance at fraction j / n_keys."""
        if j not in self._keys:
            out = np.empty(self.log0.shape, dtype=np.float32)
            in_parallel(lambda y0, y1: _synthesise(self.log0, self.occlusion0, self.flow01, self.log1,
                                                   self.occlusion1, self.flow10, j / self.n_keys, out, y0, y1),
                        out.shape[0], _MIN_ROWS)
            self._keys[j] = out
        return self._keys[j]

    def log_at(self, a: float) -> np.ndarray:
        """float32 (H, W) log radiance at fraction a (0..1) of the interval."""
        u = min(max(float(a), 0.0), 1.0) * self.n_keys
        j = min(int(u), self.n_keys - 1)
        f = np.float32(u - j)
        if f == 0:
            return self.key(j)
        return (1 - f) * self.key(j) + f * self.key(j + 1)


@njit(cache=True, nogil=True)
def _occlusion(fab, fba, out, y0, y1):
    """out[y0:y1] = 1 where the forward-backward check fails or the flow leaves the image, else 0; returns the
    largest |fab| among the other pixels of those rows (0 when there are none)."""
    h, w = out.shape
    largest = 0.0
    for y in range(y0, y1):
        for x in range(w):
            ux, uy = fab[y, x, 0], fab[y, x, 1]
            tx, ty = x + ux, y + uy
            if tx < -0.5 or tx > w - 0.5 or ty < -0.5 or ty > h - 0.5:
                out[y, x] = 1.0
                continue
            tx, ty = min(max(tx, 0.0), w - 1.0), min(max(ty, 0.0), h - 1.0)
            xi, yi = min(int(tx), w - 1), min(int(ty), h - 1)
            x1, y1 = min(xi + 1, w - 1), min(yi + 1, h - 1)
            fx, fy = tx - xi, ty - yi
            bx = ((1 - fy) * ((1 - fx) * fba[yi, xi, 0] + fx * fba[yi, x1, 0])
                  + fy * ((1 - fx) * fba[y1, xi, 0] + fx * fba[y1, x1, 0]))
            by = ((1 - fy) * ((1 - fx) * fba[yi, xi, 1] + fx * fba[yi, x1, 1])
                  + fy * ((1 - fx) * fba[y1, xi, 1] + fx * fba[y1, x1, 1]))
            m2 = ux * ux + uy * uy
            err = (ux + bx) ** 2 + (uy + by) ** 2
            if err > _FB_ALPHA * (m2 + bx * bx + by * by) + _FB_BETA:
                out[y, x] = 1.0
            else:
                out[y, x] = 0.0
                largest = max(largest, m2)
    return np.sqrt(largest)


@njit(cache=True, inline="always")
def _keys(t):
    """Weights of the 4 taps at offsets -1, 0, 1, 2 for a fraction t in [0, 1): Keys' cubic convolution, a = -0.5
    (Catmull-Rom: C1-continuous, exact for quadratics)."""
    t2, t3 = t * t, t * t * t
    return (-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2)


@njit(cache=True, inline="always")
def _sample(img, occ, x, y):
    """img (bicubic) and occ (bilinear) at (x, y) in pixel coordinates, with a replicated border."""
    h, w = img.shape
    x = min(max(x, 0.0), w - 1.0)
    y = min(max(y, 0.0), h - 1.0)
    xi, yi = int(x), int(y)
    fx, fy = x - xi, y - yi
    ax0, ax1, ax2, ax3 = _keys(fx)
    ay0, ay1, ay2, ay3 = _keys(fy)
    c0, c1, c2, c3 = max(xi - 1, 0), xi, min(xi + 1, w - 1), min(xi + 2, w - 1)
    r0, r1, r2, r3 = max(yi - 1, 0), yi, min(yi + 1, h - 1), min(yi + 2, h - 1)
    v = (ay0 * (ax0 * img[r0, c0] + ax1 * img[r0, c1] + ax2 * img[r0, c2] + ax3 * img[r0, c3])
         + ay1 * (ax0 * img[r1, c0] + ax1 * img[r1, c1] + ax2 * img[r1, c2] + ax3 * img[r1, c3])
         + ay2 * (ax0 * img[r2, c0] + ax1 * img[r2, c1] + ax2 * img[r2, c2] + ax3 * img[r2, c3])
         + ay3 * (ax0 * img[r3, c0] + ax1 * img[r3, c1] + ax2 * img[r3, c2] + ax3 * img[r3, c3]))
    o = (1 - fy) * ((1 - fx) * occ[r1, c1] + fx * occ[r1, c2]) + fy * ((1 - fx) * occ[r2, c1] + fx * occ[r2, c2])
    return v, o


@njit(cache=True, nogil=True)
def _synthesise(log0, occ0, f01, log1, occ1, f10, a, out, y0, y1):
    """out[y0:y1] = the occlusion-weighted blend of both frames' log radiance warped to fraction a."""
    h, w = log0.shape
    b = 1.0 - a
    c00, c01 = -b * a, a * a  # F_a0 = c00 F01 + c01 F10
    c10, c11 = b * b, -a * b  # F_a1 = c10 F01 + c11 F10
    for y in range(y0, y1):
        for x in range(w):
            ux, uy, vx, vy = f01[y, x, 0], f01[y, x, 1], f10[y, x, 0], f10[y, x, 1]
            l0, o0 = _sample(log0, occ0, x + c00 * ux + c01 * vx, y + c00 * uy + c01 * vy)
            l1, o1 = _sample(log1, occ1, x + c10 * ux + c11 * vx, y + c10 * uy + c11 * vy)
            w0 = b * (1.0 + _WEIGHT_FLOOR - o1)
            w1 = a * (1.0 + _WEIGHT_FLOOR - o0)
            out[y, x] = (w0 * l0 + w1 * l1) / (w0 + w1)
