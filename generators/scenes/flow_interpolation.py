"""Motion-compensated interpolation between two frames, with OpenCV optical flow (no network, no download).

For a pair of frames 0 and 1 (log radiance L0, L1):
1. bidirectional dense optical flow F01 (pixel p of frame 0 is at p + F01(p) in frame 1) and F10, with OpenCV's
   DIS (default) or Farneback, computed on the log radiance mapped to 8 bits over a fixed range (so that a change
   of exposure or illumination by a constant factor is an offset, not a change of contrast), by default on the
   frames area-resized to half size and resized back (FlowEstimator's scale); vectors on still surroundings are
   dropped (still_where_unmoved: a pixel whose frames agree and over which no changing content moves keeps its
   value, where DIS leaves vectors on still content near edges, borders and moving content);
2. occlusion by forward-backward consistency (Sundaram et al., ECCV 2010): p is occluded in the other frame when
   |F01(p) + F10(p + F01(p))|^2 > 0.01 (|F01|^2 + |F10|^2) + 0.5 px^2, or when p + F01(p) leaves the image; checked
   at the flow's own size (half size by default) and the mask resized with the flow (bilinear, so soft at its
   edges);
3. at a fraction a in (0, 1) of the interval (the key fractions chosen from the motion: FlowPair), the flows from
   time a back to both frames are approximated from the two flows as in Super SloMo (Jiang et al., CVPR 2018),
   exact for any motion constant over the interval:
   F_a0 = -(1 - a) a F01 + a^2 F10,   F_a1 = (1 - a)^2 F01 - a (1 - a) F10;
   both frames are warped to time a and blended in log radiance, in one pass over the pixels for several key
   fractions at once (one numba kernel on blocks of rows, on every core): each frame is sampled bilinearly on its
   copy upsampled 4x (cv2.resize, bicubic: OpenCV's Keys kernel with parameter -0.75; made once per frame), which is
   close to a bicubic warp at a fraction of its cost (bilinear interpolation on the frames themselves blurs texture
   at half-pixel shifts and loses events, README "Converting videos"; on 2x copies 1.3 % of the events of
   tests/test_convert_pinned.py's clip, against 0.15 % of seed noise); weights
   w0 = (1 - a) (1 - O1 + d), w1 = a (1 - O0 + d): content about to be hidden comes from frame 0 (O0 warped from
   frame 0, nearest neighbour: it is not in frame 1), newly revealed content from frame 1; d = 1e-3 keeps both
   weights positive. Outside the image the frames are extended by their edge values.
The result is L0 at a = 0, L1 at a = 1 and continuous in a; between key frames the log radiance is linear in time.

References (docs/models/references.md): Kroeger et al. 2016 [Kroeger2016], Farneback 2003 [Farneback2003],
Sundaram et al. 2010 [Sundaram2010], Jiang et al. 2018 [Jiang2018], Keys 1981 [Keys1981], Moshier 1989
[Moshier1989].
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numba import njit

from sim import InvalidParameterError
from sim.errors import check_number
from sim.kernel_math import exp_minus_row_f32, load_pair_f32
from sim.parallel import in_parallel  # row blocks on numba's thread count (the kernels are nogil)

from ..choices import DIS_PRESET_NAMES, FLOW_METHODS

DIS_PRESETS = dict(zip(DIS_PRESET_NAMES, (cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST, cv2.DISOPTICAL_FLOW_PRESET_FAST,
                                           cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)))
# Farneback: pyramid scale, levels, window size, iterations, polynomial size and sigma (OpenCV's suggested values)
_FARNEBACK = (0.5, 4, 15, 3, 5, 1.2, 0)
_FB_ALPHA, _FB_BETA = 0.01, 0.5  # forward-backward consistency: relative (1) and absolute (px^2) tolerance
_WEIGHT_FLOOR = 1e-3
_MIN_ROWS = 32  # rows per thread, at least
_UP_SHIFT = 2
_UP = 1 << _UP_SHIFT  # frames are warped bilinearly on copies upsampled by this factor (bicubic)
FLOW_SCALE = 0.5  # default scale: at 346x260 as accurate as full size (README, "Converting videos"), 1/4 the cost
DIS_MIN_SIDE = 12  # OpenCV's DIS refuses (or fails on) frames with a side below this (pixels)
STILL_LOG = 0.05  # still_where_unmoved: frames that agree to this (log radiance, mean over 3x3 pixels) are unchanged
MAX_KEYS = 32  # default cap on key intervals per frame pair (README, "Converting videos": fast motion)
KEY_GROUP = 8  # key frames synthesised in one pass (the pass reads the upsampled frames once for all of them)
STEP_CLASSES = 4  # a pixel is warped at every 1st, 2nd, 4th or 8th key (KEY_GROUP: its anchors stay in one group)


class FlowEstimator:
    """Bidirectional dense optical flow between frames given as log radiance (float32 (H, W)).

    method: "dis" (OpenCV's DISOpticalFlow with `preset` ultrafast | fast | medium) or "farneback".
    log_range: (low, high) log radiance mapped to 0..255 for the flow computation (values outside are clipped).
    scale: the flow is computed on the frames area-resized by this factor (0 < scale <= 1) and resized back
        (bilinear, vectors divided by the factor); 0.5 (default) costs about a quarter of the full-size flow.
    DIS needs frames of at least DIS_MIN_SIDE pixels per side: with DIS the scale is raised where the scaled frames
    would be smaller (up to full size), and frames smaller than that at full size are padded by edge replication
    (the flow is cropped back); flow_note(shape) says so for a frame size. Farneback takes any size.
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
        if not check_number("flow scale", scale, positive=True) <= 1:
            raise InvalidParameterError(f"flow scale must be in (0, 1], got {scale!r}")
        self.method, self.preset, self.log_range, self.scale = method, preset, (low, high), float(scale)
        self._dis = cv2.DISOpticalFlow_create(DIS_PRESETS[preset]) if method == "dis" else None

    def describe(self) -> dict:
        return {"method": self.method, **({"preset": self.preset} if self.method == "dis" else {}),
                "log_range": list(self.log_range), "scale": self.scale}

    def flow_size(self, shape: tuple[int, int]) -> tuple[int, int]:
        """(height, width) of the frames the flow is computed on, for frames of `shape` (see the class docstring)."""
        h, w = shape
        scale = self.scale
        if self._dis is not None and min(round(h * scale), round(w * scale)) < DIS_MIN_SIDE:
            scale = min(1.0, DIS_MIN_SIDE / min(h, w))
        return (h, w) if scale == 1 else (max(1, round(h * scale)), max(1, round(w * scale)))

    def flow_note(self, shape: tuple[int, int]) -> str | None:
        """What differs from the configured scale for frames of `shape` (None: nothing)."""
        if self._dis is None:
            return None
        fh, fw = self.flow_size(shape)
        if min(fh, fw) < DIS_MIN_SIDE:
            return (f"frames of {shape[1]}x{shape[0]} px are below DIS's minimum of {DIS_MIN_SIDE} px per side: the "
                    f"flow is computed at full size on frames padded by edge replication")
        if (fh, fw) != (max(1, round(shape[0] * self.scale)), max(1, round(shape[1] * self.scale))):
            return (f"the flow is computed at {fw}x{fh} px, not at scale {self.scale:g}: DIS needs at least "
                    f"{DIS_MIN_SIDE} px per side")
        return None

    def to_u8(self, log_img: np.ndarray) -> np.ndarray:
        low, high = self.log_range
        u8 = cv2.convertScaleAbs(log_img, alpha=255.0 / (high - low), beta=-255.0 * low / (high - low))
        fh, fw = self.flow_size(u8.shape)
        if (fh, fw) == u8.shape:
            return u8
        return cv2.resize(u8, (fw, fh), interpolation=cv2.INTER_AREA)

    def flow(self, u8_from: np.ndarray, u8_to: np.ndarray) -> np.ndarray:
        """float32 (H, W, 2) flow (dx, dy) in pixels: pixel p of `from` is at p + flow(p) in `to`."""
        if self._dis is not None:
            h, w = u8_from.shape
            if min(h, w) >= DIS_MIN_SIDE:
                return self._dis.calc(u8_from, u8_to, None)
            pad = dict(top=0, bottom=max(0, DIS_MIN_SIDE - h), left=0, right=max(0, DIS_MIN_SIDE - w),
                       borderType=cv2.BORDER_REPLICATE)
            padded = self._dis.calc(cv2.copyMakeBorder(u8_from, **pad), cv2.copyMakeBorder(u8_to, **pad), None)
            return np.ascontiguousarray(padded[:h, :w])
        return cv2.calcOpticalFlowFarneback(u8_from, u8_to, None, *_FARNEBACK)

    def pair(self, log0: np.ndarray, log1: np.ndarray, **kwargs: Any) -> FlowPair:
        """The FlowPair of two log-radiance frames (kwargs: key_step_px, max_keys, upsampled0)."""
        u8_0, u8_1 = self.to_u8(log0), self.to_u8(log1)
        f01, f10 = self.flow(u8_0, u8_1), self.flow(u8_1, u8_0)
        small0, small1 = (self._at_flow_size(img, f01.shape[:2]) for img in (log0, log1))
        changing = changing_pixels(small0, small1)  # (the same for both directions)
        still_where_unmoved(f01, small0, small1, changing)
        still_where_unmoved(f10, small1, small0, changing)
        h, w = log0.shape
        px = max(h / f01.shape[0], w / f01.shape[1])  # one flow pixel in sensor pixels
        occ0, m0 = occlusion(f01, f10, px)  # pixels of frame 0 hidden in frame 1
        occ1, m1 = occlusion(f10, f01, px)  # pixels of frame 1 hidden in frame 0
        if f01.shape[:2] != (h, w):
            f01, f10 = (self._full_size(f, log0.shape) for f in (f01, f10))
            occ0, occ1 = (cv2.resize(o, (w, h), interpolation=cv2.INTER_LINEAR) for o in (occ0, occ1))
        return FlowPair(log0, log1, f01, f10, occ0, occ1, max(m0, m1), **kwargs)

    @staticmethod
    def _at_flow_size(img: np.ndarray, size: tuple[int, int]) -> np.ndarray:
        """img area-resized to size (H, W) of the flow (itself when it is that size already)."""
        return img if img.shape == size else cv2.resize(img, (size[1], size[0]), interpolation=cv2.INTER_AREA)

    @staticmethod
    def _full_size(flow: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """A flow computed on resized frames, resized back to shape (H, W) with its vectors in full-size pixels."""
        h, w = shape
        sy, sx = h / flow.shape[0], w / flow.shape[1]
        out = cv2.resize(flow, (w, h), interpolation=cv2.INTER_LINEAR)
        out[..., 0] *= np.float32(sx)
        out[..., 1] *= np.float32(sy)
        return out


def still_where_unmoved(flow_ab: np.ndarray, log_a: np.ndarray, log_b: np.ndarray,
                        changing: np.ndarray | None = None) -> np.ndarray:
    """Zero flow_ab (in place) where the frames agree and no changing content passes, and return the mask of those
    pixels. A pixel changes when the mean |log_a - log_b| over its 3x3 neighbourhood exceeds STILL_LOG; the content
    of each changing pixel q passes the pixels on the segment from q to q + flow_ab(q) (and their 8 neighbours: the
    warp's interpolation reaches that far). Every other pixel keeps its value between the frames. DIS returns
    vectors on still content near moving content, at image borders and on flat areas; warped by them, a pixel whose
    frames agree dips between them into a neighbour's value, which the DVS turns into events no camera fires (the
    DAVIS346 road recording: 0.39 of log radiance, OFF then ON events, at 116 DN pixels unchanged in all 59 frames,
    13-18 px from anything that changes, next to a 115/61 DN edge). The zero-vector candidate of motion-compensated
    frame rate conversion (de Haan et al. 1993 [deHaan1993]), chosen where nothing moves.

    Parameters
    ----------
    flow_ab : numpy.ndarray
        float32 (h, w, 2) flow from frame a to frame b, pixels (changed in place).
    log_a, log_b : numpy.ndarray
        float32 (h, w) the frames' log radiance at the flow's size.
    changing : numpy.ndarray, optional
        changing_pixels(log_a, log_b) when already made (for the flow of the other direction).

    Returns
    -------
    numpy.ndarray
        (h, w) bool: the pixels whose flow was set to zero.
    """
    if changing is None:
        changing = changing_pixels(log_a, log_b)
    swept = np.zeros(changing.shape, np.uint8)
    _sweep(changing, flow_ab, swept)
    still = cv2.dilate(swept, np.ones((3, 3), np.uint8)) == 0
    flow_ab[still] = 0.0
    return still


def changing_pixels(log_a: np.ndarray, log_b: np.ndarray) -> np.ndarray:
    """The pixels that change between two frames for still_where_unmoved: mean |log_a - log_b| over 3x3 pixels above
    STILL_LOG.

    Parameters
    ----------
    log_a, log_b : numpy.ndarray
        float32 (h, w) the frames' log radiance.

    Returns
    -------
    numpy.ndarray
        (h, w) bool.
    """
    return cv2.blur(cv2.absdiff(log_a, log_b), (3, 3), borderType=cv2.BORDER_REPLICATE) > STILL_LOG


@njit(cache=True, nogil=True)
def _sweep(changing, flow, out):
    """out = 1 on the pixels of the segments from each changing pixel q to q + flow(q) (rounded, inside the
    image), steps of at most one pixel."""
    h, w = changing.shape
    for y in range(h):
        for x in range(w):
            if not changing[y, x]:
                continue
            fx, fy = flow[y, x, 0], flow[y, x, 1]
            n = int(max(abs(fx), abs(fy))) + 1
            for i in range(n + 1):
                px = int(np.floor(x + fx * i / n + 0.5))
                py = int(np.floor(y + fy * i / n + 0.5))
                if 0 <= px < w and 0 <= py < h:
                    out[py, px] = 1


def occlusion(flow_ab: np.ndarray, flow_ba: np.ndarray, px: float = 1.0) -> tuple[np.ndarray, float]:
    """float32 (h, w) mask, 1 where the pixel of frame a is not visible in frame b (forward-backward check, or
    its flow leaves the image), else 0; and the largest |flow_ab| among the visible pixels, in sensor pixels.
    The flows are (h, w, 2) in the pixels of frames resized so that one of their pixels is px sensor pixels (the
    check's absolute tolerance is in sensor pixels)."""
    out = np.empty(flow_ab.shape[:2], dtype=np.float32)
    largest = []
    beta = _FB_BETA / px ** 2
    in_parallel(lambda y0, y1: largest.append(_occlusion(flow_ab, flow_ba, out, y0, y1, beta)), out.shape[0],
                _MIN_ROWS)
    return out, float(max(largest)) * px


class FlowPair:
    """Two frames (log radiance, float32 (H, W)) with their flows F01, F10 (float32 (H, W, 2), pixels) and
    occlusion masks. log_at(a) gives the log radiance at fraction a of the interval.

    Motion-compensated key frames are synthesised (module docstring) at n_keys - 1 equally spaced fractions
    inside the interval, n_keys = ceil(largest motion / key_step_px) (1 for a still pair, at most max_keys), so
    that the image moves by at most key_step_px between keys (largest motion / max_keys when that is more: fast
    motion, for which the flow itself is not that precise); between keys the log radiance is linear in time,
    which is also how the DVS emulator interpolates between its samples. The same rule holds per pixel: a pixel
    whose own samples move by less than key_step_px over 2, 4 or 8 key intervals is warped at every 2nd, 4th or 8th
    key only and linear in log radiance between those (its step, _still_parts), which leaves its events as they
    were within seed noise (tests/test_flow_keys.py) at a fraction of the warps where the motion is uneven. Keys are
    made when first needed in groups of KEY_GROUP (keys 8q + 1 .. 8q + 8, after key 8q: every pixel's anchors are
    then in the group, key 8q or frame 1), and kept for the pair's lifetime (at most max_keys images). lowest: the
    log of radiance 0 (log(log_eps) of a scene), below which no key goes (the bicubic copies overshoot below the
    frames' darkest values; -inf: no bound).
    """

    def __init__(self, log0: np.ndarray, log1: np.ndarray, flow01: np.ndarray, flow10: np.ndarray,
                 occlusion0: np.ndarray, occlusion1: np.ndarray, max_motion_px: float, *,
                 key_step_px: float = 0.5, max_keys: int = MAX_KEYS, upsampled0: np.ndarray | None = None,
                 lowest: float = -np.inf):
        self.log0, self.log1 = log0, log1
        self.lowest = np.float32(lowest)
        self.flow01, self.flow10 = flow01, flow10
        self.occlusion0, self.occlusion1 = occlusion0, occlusion1  # of frame 0 hidden in frame 1, and back
        self.max_motion_px = max_motion_px  # largest displacement over the interval among the visible pixels
        self.n_keys = int(min(max(np.ceil(self.max_motion_px / key_step_px), 1), max_keys))
        self.step_limit_px = key_step_px * self.n_keys  # a pixel's step s: s x its motion within this (_still_parts)
        self._keys = {0: log0, self.n_keys: log1}
        self._up = [upsampled0, None]  # both frames upsampled (made when the first key is synthesised)
        self._planar = None  # the flows as (4, H, W): F01 x, F01 y, F10 x, F10 y
        self._centre = self._moving = self._row_start = self._class_end = None  # _still_parts

    @property
    def upsampled1(self) -> np.ndarray:
        """float32 (_UP H, _UP W): frame 1's log radiance upsampled (bicubic; the next pair's frame 0 reuses it)."""
        if self._up[1] is None:
            self._up[1] = upsample(self.log1)
        return self._up[1]

    def key(self, j: int) -> np.ndarray:
        """Key frame j (0..n_keys): the synthesised log radiance at fraction j / n_keys. A missing key is made
        with its group (KEY_GROUP keys) in one pass (_synthesise), after the missing groups before it (the last
        key of the one before starts its anchors)."""
        if j not in self._keys:
            last = (j - 1) // KEY_GROUP
            first = last
            while first * KEY_GROUP not in self._keys:  # the groups before it whose keys start its anchors
                first -= 1
            for group in range(first, last + 1):
                for i, img in enumerate(self._synthesise(group), start=group * KEY_GROUP + 1):
                    self._keys[i] = img
        return self._keys[j]

    def prepare(self) -> None:
        """Make what key synthesis needs (the upsampled frames, the flows by component): at the first key, or
        ahead of it."""
        if self._planar is None:
            if self._up[0] is None:
                self._up[0] = upsample(self.log0)
            self.upsampled1  # noqa: B018 (made here)
            h, w = self.log0.shape
            self._planar = np.empty((4, h, w), np.float32)  # (plane by plane: a transposing copy costs 6x as much)
            self._planar[0], self._planar[1] = self.flow01[..., 0], self.flow01[..., 1]
            self._planar[2], self._planar[3] = self.flow10[..., 0], self.flow10[..., 1]
            self._centre = np.empty((2, h, w), np.float32)  # both copies sampled where a pixel without motion is
            self._moving = np.empty(h * w, np.int32)  # per row, the columns it warps, by step (_still_parts)
            self._row_start = np.empty(h + 1, np.int64)
            self._class_end = np.empty((h, STEP_CLASSES), np.int64)
            _still_parts(self._up[0], self._up[1], self._planar, self.step_limit_px, self._centre, self._moving,
                         self._row_start, self._class_end)

    def _synthesise(self, group: int) -> np.ndarray:
        """float32 (n, H, W): keys group * KEY_GROUP + 1 .. + n (the group's, up to key n_keys - 1), both frames
        warped and blended (module docstring), in one pass over the rows on every core; key group * KEY_GROUP is
        made."""
        self.prepare()
        first = group * KEY_GROUP + 1
        out = np.empty((min(KEY_GROUP, self.n_keys - first), *self.log0.shape), dtype=np.float32)
        args = (self._up[0], self._up[1], self.occlusion0, self.occlusion1, self._planar, first, self.n_keys,
                self.lowest, self._centre, self._moving, self._row_start, self._class_end,
                np.ascontiguousarray(self._keys[first - 1]), np.ascontiguousarray(self.log1))
        in_parallel(lambda y0, y1: _warp_blend(*args, y0, y1, out), out.shape[1], _MIN_ROWS, per_thread=2)
        return out

    def log_at(self, a: float) -> np.ndarray:
        """float32 (H, W) log radiance at fraction a (0..1) of the interval."""
        j, f = self._between_keys(a)
        if f == 0:  # at a key (j = n_keys at a = 1)
            return self.key(j)
        return blend_logs(self.key(j), self.key(j + 1), f)

    def radiance_at(self, a: float, eps: float) -> np.ndarray:
        """float32 (H, W) radiance at fraction a (0..1) of the interval: radiance_of_log of log_at(a) with offset eps,
        the blend between keys made in the same pass as the exp."""
        j, f = self._between_keys(a)
        if f == 0:
            return radiance_of_log(self.key(j), eps)
        return radiance_of_log(self.key(j), eps, self.key(j + 1), f)

    def _between_keys(self, a: float) -> tuple[int, np.float32]:
        """The key before fraction a and a's place between it and the next, (j, f) with 0 <= f < 1."""
        u = min(max(float(a), 0.0), 1.0) * self.n_keys
        j = int(u)
        return j, np.float32(u - j)


@njit(cache=True, nogil=True)
def _occlusion(fab, fba, out, y0, y1, beta):
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
            if err > _FB_ALPHA * (m2 + bx * bx + by * by) + beta:
                out[y, x] = 1.0
            else:
                out[y, x] = 0.0
                largest = max(largest, m2)
    return np.sqrt(largest)


def upsample(img: np.ndarray) -> np.ndarray:
    """float32 (_UP H, _UP W): img upsampled _UP times with cv2.resize (bicubic); its pixel u lies at img's
    x = (u - (_UP - 1) / 2) / _UP."""
    h, w = img.shape
    return cv2.resize(img, (_UP * w, _UP * h), interpolation=cv2.INTER_CUBIC)


@njit(cache=True, nogil=True, fastmath=True)
def _still_parts(up0, up1, flows, step_limit, centre, moving, row_start, class_end):
    """What _warp_blend needs, per row: centre[i] = up_i sampled bilinearly where a pixel without motion (both flows
    zero: still_where_unmoved) samples it at every fraction (at its centre: half-way between four samples of the
    4x copy), for every pixel; moving[row_start[y]:row_start[y + 1]] = the columns of row y with motion in either
    flow, by step class c (step 2**c keys) from 0 up, class_end[y, c] the number of those of class c or below. A
    pixel's class is the largest c < STEP_CLASSES with 2**c x its motion < step_limit (px), its motion the largest
    speed of its two sample positions over the pair (F_a0, F_a1 of the module docstring: |F01|, |F01 + 2 F10|,
    |2 F01 + F10|, |F10|)."""
    h, w = centre.shape[1], centre.shape[2]
    w2 = np.int32(_UP * w)
    half = np.float32(0.5)
    u0f, u1f = up0.ravel(), up1.ravel()
    lim2, two = np.float32(step_limit) * np.float32(step_limit), np.float32(2.0)
    cls = np.empty(w, np.int32)
    n = 0
    for y in range(h):
        row_start[y] = n
        k = (_UP * y + (_UP - 1) // 2) * w2 + (_UP - 1) // 2
        counts = np.zeros(STEP_CLASSES, np.int64)
        for x in range(w):
            centre[0, y, x] = _bilinear(u0f, k + _UP * x, w2, half, half)
            centre[1, y, x] = _bilinear(u1f, k + _UP * x, w2, half, half)
            ax, ay, bx, by = flows[0, y, x], flows[1, y, x], flows[2, y, x], flows[3, y, x]
            m2 = max(ax * ax + ay * ay, bx * bx + by * by, (ax + two * bx) ** 2 + (ay + two * by) ** 2,
                     (two * ax + bx) ** 2 + (two * ay + by) ** 2)
            c = 0
            while c + 1 < STEP_CLASSES and np.float32(4 ** (c + 1)) * m2 < lim2:
                c += 1
            moves = ax != 0 or ay != 0 or bx != 0 or by != 0
            cls[x] = c if moves else -1
            if moves:
                counts[c] += 1
        acc = n
        for c in range(STEP_CLASSES):  # counts -> where each class starts
            acc, counts[c] = acc + counts[c], acc
            class_end[y, c] = acc - n
        for x in range(w):
            if cls[x] >= 0:
                moving[counts[cls[x]]] = x
                counts[cls[x]] += 1
        n = acc
    row_start[h] = n


@njit(cache=True, inline="always")
def _position(xf, yf, cu, cv, ux, uy, vx, vy, umax, vmax, w):
    """Where a pixel at (xf, yf) of the 4x copy samples it at one fraction: (xf, yf) + cu (ux, uy) + cv (vx, vy)
    kept inside [0, umax] x [0, vmax] (edge values beyond the image); returns its bilinear weights fx, fy, the flat
    index of its upper left neighbour in the copy (w pixels wide at 1x) and that of the nearest 1x pixel."""
    zero, half = np.float32(0.0), np.float32(0.5)
    p = xf + cu * ux + cv * vx
    q = yf + cu * uy + cv * vy
    p = p if p > zero else zero  # (conditionals, not min/max: they vectorise)
    p = p if p < umax else umax
    q = q if q > zero else zero
    q = q if q < vmax else vmax
    ip, iq = np.int32(p), np.int32(q)
    nearest = (np.int32(q + half) >> _UP_SHIFT) * np.int32(w) + (np.int32(p + half) >> _UP_SHIFT)
    return p - np.float32(ip), q - np.float32(iq), iq * np.int32(_UP * w) + ip, nearest


@njit(cache=True, inline="always")
def _bilinear(u, k, w2, fx, fy):
    """The flat 4x copy u (w2 wide) interpolated at weights fx, fy from its sample k and its right, lower and lower
    right neighbours."""
    k = np.uintp(k)
    a00, a01 = load_pair_f32(u, k)  # (a row's two neighbours in one load: 15 % off a dense row's warp at 720p)
    a10, a11 = load_pair_f32(u, k + np.uintp(w2))
    t0, t1 = a00 + fx * (a01 - a00), a10 + fx * (a11 - a10)
    return t0 + fy * (t1 - t0)


@njit(cache=True, inline="always")
def _blend(w0, v0, w1, v1, lowest):
    """The weighted mean of v0 and v1 (weights w0, w1 > 0), at least lowest."""
    v = (w0 * v0 + w1 * v1) / (w0 + w1)
    return v if v > lowest else lowest


@njit(cache=True, nogil=True, fastmath=True, error_model="numpy")  # (no zero check: vectorised divisions)
def _warp_blend(up0, up1, occ0, occ1, flows, first, n_keys, lowest, centre, moving, row_start, class_end, before,
                log1, y0, y1, out):
    """out[g, y0:y1] = key first + g (at fraction (first + g) / n_keys), for g < len(out): the occlusion-weighted
    blend of both frames warped to its fraction (module docstring), frame i's log radiance sampled bilinearly on up_i
    (upsampled _UP times, float32 (_UP H, _UP W)) at p + F_ai(p), its occlusion mask occ_i (float32 (H, W)) at the
    nearest pixel; flows (4, H, W): F01 x, y, F10 x, y (pixels); no value below lowest (float32). Row by row, every
    key of a row before the next row: the rows of the upsampled frames one row reads at nearby fractions are then
    still in the core's cache (one read of them per row and not per key; half the cost of one key at a time at
    720p). The pixels with motion (the columns moving lists from row_start, by step class with class_end;
    _still_parts) are warped at the keys their step divides and linear between those (their anchors: key first - 1
    is `before`, key n_keys log1; first - 1 a multiple of KEY_GROUP); the pixels without motion blend their samples
    at the pixel (centre) for every key in loops that vectorise."""
    h, w = out.shape[1], out.shape[2]
    w2 = np.int32(_UP * w)
    floor, off = np.float32(1.0 + _WEIGHT_FLOOR), np.float32((_UP - 1) / 2)
    umax, vmax = np.float32(_UP * w - 1) - np.float32(1e-3), np.float32(_UP * h - 1) - np.float32(1e-3)
    k0, k1 = np.empty(w, np.int32), np.empty(w, np.int32)  # flat index of the upper left bilinear neighbour
    n0, n1 = np.empty(w, np.int32), np.empty(w, np.int32)  # flat index of the nearest pixel (occlusion)
    fx0, fy0, fx1, fy1 = (np.empty(w, np.float32), np.empty(w, np.float32), np.empty(w, np.float32),
                          np.empty(w, np.float32))
    v0, v1 = np.empty(w, np.float32), np.empty(w, np.float32)
    # the warped pixels of a row: their columns, x in the upsampled copy and flows
    cols, xs = np.empty(w, np.int32), np.empty(w, np.float32)
    ux, uy, vx, vy = np.empty(w, np.float32), np.empty(w, np.float32), np.empty(w, np.float32), np.empty(w, np.float32)
    u0f, u1f, o0f, o1f = up0.ravel(), up1.ravel(), occ0.ravel(), occ1.ravel()
    n = out.shape[0]
    # per key: the coefficients of F_a0 and F_a1 (in upsampled pixels), the blend's time weights and how many of a
    # row's columns it warps (those of step class <= the number of trailing zero bits of the key's index)
    c00, c01, c10, c11 = (np.empty(n, np.float32), np.empty(n, np.float32), np.empty(n, np.float32),
                          np.empty(n, np.float32))
    wa_g, wb_g, top = np.empty(n, np.float32), np.empty(n, np.float32), np.empty(n, np.int64)
    for g in range(n):
        a = (first + g) / n_keys
        b = 1.0 - a
        c00[g], c01[g], c10[g], c11[g] = -_UP * b * a, _UP * a * a, _UP * b * b, -_UP * a * b
        wa_g[g], wb_g[g] = a, b
        c = 0
        while c + 1 < STEP_CLASSES and (first + g) % (2 << c) == 0:
            c += 1
        top[g] = c
    for y in range(y0, y1):
        first_col, m = row_start[y], row_start[y + 1] - row_start[y]
        if m < w:
            c0, c1, oc0, oc1 = centre[0, y], centre[1, y], occ0[y], occ1[y]
            for g in range(n):
                row, ga, gb = out[g, y], wa_g[g], wb_g[g]
                for x in range(w):
                    row[x] = _blend(gb * (floor - oc1[x]), c0[x], ga * (floor - oc0[x]), c1[x], lowest)
        for j in range(m):
            x = moving[first_col + j]
            cols[j] = x
            ux[j], uy[j], vx[j], vy[j] = flows[0, y, x], flows[1, y, x], flows[2, y, x], flows[3, y, x]
            xs[j] = np.float32(_UP * x) + off
        yf = np.float32(_UP * y) + off
        for g in range(n):
            # F_a0 = -(1 - a) a F01 + a^2 F10, F_a1 = (1 - a)^2 F01 - a (1 - a) F10, in upsampled pixels
            d00, d01, d10, d11, wa, wb = c00[g], c01[g], c10[g], c11[g], wa_g[g], wb_g[g]
            mg = class_end[y, top[g]]
            for j in range(mg):  # sample positions (edge values beyond the image)
                fx0[j], fy0[j], k0[j], n0[j] = _position(xs[j], yf, d00, d01, ux[j], uy[j], vx[j], vy[j], umax, vmax, w)
                fx1[j], fy1[j], k1[j], n1[j] = _position(xs[j], yf, d10, d11, ux[j], uy[j], vx[j], vy[j], umax, vmax, w)
            for j in range(mg):  # the gathers; fx0, fy0 then hold the blend weights
                v0[j] = _bilinear(u0f, k0[j], w2, fx0[j], fy0[j])
                v1[j] = _bilinear(u1f, k1[j], w2, fx1[j], fy1[j])
                fx0[j] = wb * (floor - o1f[np.uintp(n1[j])])
                fy0[j] = wa * (floor - o0f[np.uintp(n0[j])])
            row = out[g, y]
            if class_end[y, 0] == w:  # every column, in order (contiguous stores: they vectorise)
                for x in range(w):
                    row[x] = _blend(fx0[x], v0[x], fy0[x], v1[x], lowest)
            else:
                for j in range(mg):
                    row[np.uintp(cols[j])] = _blend(fx0[j], v0[j], fy0[j], v1[j], lowest)
        for g in range(n):  # the other columns: linear between their anchors
            kj = first + g
            for c in range(top[g] + 1, STEP_CLASSES):
                step = 1 << c
                j0 = kj - kj % step
                j1 = min(j0 + step, n_keys)
                f = np.float32((kj - j0) / (j1 - j0))
                r0 = before[y] if j0 < first else out[j0 - first, y]
                r1 = log1[y] if j1 == n_keys else out[j1 - first, y]
                row = out[g, y]
                for j in range(class_end[y, c - 1], class_end[y, c]):
                    x = np.uintp(cols[j])
                    row[x] = r0[x] + f * (r1[x] - r0[x])


def blend_logs(log0: np.ndarray, log1: np.ndarray, f: np.float32) -> np.ndarray:
    """log0 + f (log1 - log0): the log radiance linear in time between two images, at fraction f of the way.

    Parameters
    ----------
    log0, log1 : numpy.ndarray
        float32 (H, W) log images.
    f : numpy.float32
        The fraction, 0..1.

    Returns
    -------
    numpy.ndarray
        float32 (H, W), a new array.
    """
    out = np.subtract(log1, log0)
    out *= f
    out += log0
    return out


def radiance_of_log(log: np.ndarray, eps: float, log_to: np.ndarray | None = None,
                    fraction: float = 0.0) -> np.ndarray:
    """Radiance of a log image, max(exp(log) - eps, 0), on every core (one pass over the pixels; exp within one
    unit in the last place of float32: _radiance_rows); with log_to, of the blend log + fraction (log_to - log),
    made in the same pass.

    Parameters
    ----------
    log : ndarray
        float32 (H, W) log(radiance + eps).
    eps : float
        The offset of the log (radiance units).
    log_to : ndarray, optional
        float32 (H, W) the log image the blend goes to (default: none, no blend).
    fraction : float
        Its weight in the blend, 0..1.

    Returns
    -------
    ndarray
        float32 (H, W) radiance, >= 0.
    """
    log = np.ascontiguousarray(log, dtype=np.float32)
    log_to = log if log_to is None else np.ascontiguousarray(log_to, dtype=np.float32)
    if log_to.shape != log.shape:
        raise ValueError(f"log images of shapes {log.shape} and {log_to.shape} cannot be blended")
    out = np.empty_like(log)
    f = np.float32(fraction if log_to is not log else 0.0)
    in_parallel(lambda y0, y1: _radiance_rows(log, log_to, f, np.float32(eps), y0, y1, out), log.shape[0], _MIN_ROWS)
    return out


@njit(cache=True, nogil=True, fastmath={"nnan", "ninf", "nsz", "contract"})  # no reassociation: it undoes ln2_lo
def _radiance_rows(log, log_to, f, eps, y0, y1, out):
    """out[y0:y1] = max(exp(v) - eps, 0) (float32) of v = log + f (log_to - log) (kernel_math.exp_minus_row_f32:
    exp within one unit in the last place of float32)."""
    w = log.shape[1]
    bits = np.empty(w, np.int32)
    for y in range(y0, y1):
        if f == 0:
            exp_minus_row_f32(log[y], eps, bits, out[y])
        else:
            row, to, o = log[y], log_to[y], out[y]
            for x in range(w):
                o[x] = row[x] + f * (to[x] - row[x])
            exp_minus_row_f32(o, eps, bits, o)
