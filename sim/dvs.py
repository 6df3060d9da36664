"""The DVS (event camera) emulator: linear-radiance frames in, time-sorted events out.

Pixel model (every pixel independent; log is the natural logarithm; times in microseconds):

- Log response. The photocurrent is I + I_d, with I the input radiance and I_d = dark_fraction *
  full_illumination the dark current expressed as radiance; the pixel responds to L = log(I + I_d), which is
  logarithmic above I_d and linear below it (black stays finite). L is rounded to a multiple of 2^-32 (as v2e
  rounds its log) and so are the thresholds: the reference arithmetic is then exact, and a pixel that returns
  exactly to a level it left fires the event of that tie as the rule says.
- Input between samples. L is interpolated linearly in time between two consecutive frames of a pixel. The first
  frame only initialises the pixels: photoreceptor settled, reference = L, no event.
- Photoreceptor. A first-order low-pass on L with time constant tau = 1 / (2 pi f_c),
  f_c = cutoff_hz * J / full_illumination, where J = sqrt((I0 + I_d)(I1 + I_d)) is the interval's geometric-mean
  photocurrent (constant over the interval; dim pixels are slow). For the linear input the ODE is solved exactly
  over the interval, however long: with x = h / tau and s = L1 - L0,
  Lf1 = L1 - s (1 - e^-x) / x + (Lf0 - L0) e^-x (J and e^-x - 1 evaluated in float32: within 1.2e-7 relative, far
  below a threshold's effect; the rest in float64). cutoff_hz = 0 makes Lf = L. Between samples the filtered level
  Lf is again interpolated linearly, which gives the crossing times.
- Events. A pixel compares Lf with its reference level R and fires ON when Lf - R reaches +C_on and OFF when it
  reaches -C_off (per-pixel thresholds, see DVSParams). Every crossing gets its own time, so an interval with several
  crossings gives several events spread over it (not clumped at frame times); an event is stamped at the first
  integer microsecond at or after its crossing (ceil), so stamps are never early and lie within 1 us of the exact
  crossing (a crossing reached at a frame's end is stamped at that frame's time). Without
  refractory the reference moves by exactly +C_on / -C_off per event.
- Refractory (IEBCS-style physical reset). After an event stamped t_e the pixel is blind until t_e + refractory_us;
  crossings in that time are lost (not deferred as in v2e), and at t_e + refractory_us the reference is reset to
  the (interpolated) Lf of that moment, as the pixel's reset switch opens then. A fast ramp therefore gives events
  about every refractory_us + C / slope, and no two events of a pixel are closer than refractory_us. This is what
  the circuit does; deferring blocked crossings (v2e) fires bursts when the pixel wakes, and advancing the
  reference by C per blocked crossing (ESIM) reports contrast the pixel never saw.
- Leak. The reference drifts down at drift = leak_rate * C_on log units per second, so a static pixel fires ON leak
  events at its leak_rate (log-normal over pixels with mean leak_hz; with refractory the period is
  1 / leak_rate + refractory_us); the initial drift phase is uniform random.
  An ON crossing is labelled leak when the drift since the last reset supplied at least half of C_on. Every
  event resets the drift, so with shot noise a static pixel shows fewer leak events than leak_rate
  (DVSParams.observed_leak_hz; DVSParams.with_observed_leak sets leak_hz from a measured rate).
- Shot noise: a Poisson process per pixel of rate shot_noise_hz + dark_shot_noise_hz * I_d / J (J as above),
  polarity +-1 with equal odds. Hot pixels (a fixed random set) add a Poisson process of rate hot_pixel_hz, also
  with random polarity. Both have continuous arrival times (stamped by ceil like crossings). Dead pixels (a fixed
  random set, dead_pixel_fraction) never fire: their events are dropped from the output.
- Noise events act on the pixel like real ones: an arrival while the pixel is blind is lost; otherwise the pixel
  fires, goes blind for refractory_us and its reference is reset to the current Lf (at the end of the refractory
  time, or at once when refractory_us = 0), which also restarts its leak drift.

Determinism: fixed patterns (thresholds, leak rates, hot and dead pixels, initial phases) come from the seed's
SeedSequence; every later draw comes from a per-pixel counter-based stream kept in the state. The events are
bit-identical for the same seed, whatever the chunking of the frames into calls and the numba thread count.

Speed: blocks of rows run in parallel on numba.get_num_threads() threads (serial kernels that release the GIL, run
from a thread pool); feed stacks of frames where possible, since every call has a fixed cost.

References (docs/models/references.md): Lichtsteiner et al. 2008 [Lichtsteiner2008], Rebecq et al. 2018
[Rebecq2018], Gehrig et al. 2020 [Gehrig2020], Hu et al. 2021 [Hu2021], Joubert et al. 2021 [Joubert2021], Nozaki
and Delbruck 2017 [Nozaki2017], Steele et al. 2014 [Steele2014], Salmon et al. 2011 [Salmon2011].
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
import numpy.typing as npt

from . import dvs_kernels as K
from .dvs_params import DVSParams
from .errors import EvsimInputError, InvalidParameterError, TimeOrderError, check_int
from .events import EVENT_DTYPE, check_times_us, empty_events
from .parallel import in_parallel, split
from .seeding import as_seed_sequence, child_seed
from .source import RadianceSource

EVENT_LABELS = ("signal", "shot", "leak", "hot")  # per-event label code -> name (labels are uint8 indices)
LABEL_SIGNAL, LABEL_SHOT, LABEL_LEAK, LABEL_HOT = K.LABEL_SIGNAL, K.LABEL_SHOT, K.LABEL_LEAK, K.LABEL_HOT
NO_EVENT_US = K.NO_EVENT_US

MAX_TIME_GAP_US = 3_600_000_000  # one hour: consecutive input times further apart are refused (noise is simulated
# over every gap, so a gap of days would mean billions of noise events; split such a recording instead)
_PARTS_PER_THREAD = 4  # parts of the rows (and of the frame intervals) per thread, taken by whichever thread is free:
# on a loaded machine a descheduled thread then holds up a smaller part (2 -> 4, alternating runs on 2 cores shared
# with other jobs: 5-11 % less wall time at 29k events per frame, within noise at 16k and 53k)
_BLOCK_PIXEL_FRAMES = 1 << 23  # frames per kernel call are limited so event buffers stay bounded


class DVSEmulator:
    """A streaming DVS emulator of height x width pixels (see the module docstring for the model and its
    references, and docs/models/dvs.md).

    params: DVSParams (default: the "davis346" preset). seed: int or numpy SeedSequence; its entropy is in
    seed_entropy. return_labels: feed() then returns (events, labels) with labels a uint8 array of indices into
    EVENT_LABELS (0 signal, 1 shot, 2 leak, 3 hot).
    """

    def __init__(self, height: int, width: int, params: DVSParams | None = None,
                 seed: int | np.random.SeedSequence = 0, *, return_labels: bool = False):
        for name, n in (("height", height), ("width", width)):
            check_int(name, n, minimum=1, maximum=65535, unit="pixels")
        if params is None:
            params = DVSParams.preset("davis346")
        if not isinstance(params, DVSParams):
            raise InvalidParameterError(f"params must be a sim.DVSParams, got {type(params).__name__}")
        self.height, self.width, self.params = int(height), int(width), params
        self.return_labels = bool(return_labels)
        ss = as_seed_sequence(seed)
        self.seed_sequence = ss
        self.seed_entropy = ss.entropy
        fixed_ss, stream_ss = child_seed(ss, 0), child_seed(ss, 1)
        rng = np.random.default_rng(fixed_ss)
        shape = (self.height, self.width)
        p = params

        def threshold(mean):
            c = np.maximum(mean + p.threshold_sigma * rng.standard_normal(shape), p.min_threshold)
            c = c.astype(np.float32).astype(np.float64)  # exactly what threshold_map reports
            # on the log response's grid (a no-op above 2**-9, where float32 values are multiples of it)
            return np.maximum(np.round(c / K.LOG_GRID), 1.0) * K.LOG_GRID

        c_on, c_off = threshold(p.pos_threshold), threshold(p.neg_threshold)
        s = p.leak_spread
        leak_hz = p.leak_hz * np.exp(s * rng.standard_normal(shape) - 0.5 * s * s)
        hot = np.zeros(self.height * self.width, dtype=bool)
        hot[rng.choice(hot.size, int(round(p.hot_pixel_fraction * hot.size)), replace=False)] = True
        hot = hot.reshape(shape)
        self._leak_phase = rng.random(shape)
        self._init_shot_budget, self._init_hot_budget = rng.standard_exponential((2, *shape))
        # Thresholds are stored as float32, exactly (multiples of 2**-32 with at most 24 significant bits), and hot
        # pixels as a mask: fewer bytes per pixel to stream through memory on every feed.
        self._dead = None  # drawn from a seed of its own, so that the other fixed patterns do not depend on it
        if p.dead_pixel_fraction > 0:
            dead = np.zeros(self.height * self.width, dtype=bool)
            n_dead = int(round(p.dead_pixel_fraction * dead.size))
            dead[np.random.default_rng(child_seed(ss, 2)).choice(dead.size, n_dead, replace=False)] = True
            self._dead = dead.reshape(shape)
        self._fixed = _slot_tuple(K.N_FIXED, {
            K.FX_C_ON: c_on.astype(np.float32),
            K.FX_C_OFF: c_off.astype(np.float32),
            K.FX_DRIFT: leak_hz * 1e-6 * c_on,
            K.FX_HOT: hot.astype(np.uint8),
            K.FX_DEAD: (self._dead if self._dead is not None else np.zeros((0, 0), dtype=bool)).astype(np.uint8),
        })
        self._leak_hz, self._hot = leak_hz, hot
        self._scal = _slot_tuple(K.N_SCAL, {
            K.SC_REFRACTORY: np.int64(p.refractory_us),
            K.SC_K_CUT: 2 * np.pi * p.cutoff_hz * 1e-6 / p.full_illumination,
            K.SC_DARK: p.dark_fraction * p.full_illumination,
            K.SC_SHOT_RATE: p.shot_noise_hz * 1e-6,
            K.SC_DARK_SHOT_RATE: p.dark_shot_noise_hz * 1e-6,
            K.SC_KEY: stream_ss.generate_state(1, dtype=np.uint64)[0],
            K.SC_HOT_RATE: p.hot_pixel_hz * 1e-6,
        })
        self._state = None
        self._t: int | None = None
        self._row_rate: float | None = None  # events per frame of the busiest row in the last block
        self._bufs = None
        self._rows = np.arange(self.height, dtype=np.int64)

    # ----- inspectable state -----
    @property
    def time_us(self) -> int | None:
        """Time of the last frame fed (None before the first)."""
        return self._t

    @property
    def dark_level(self) -> float:
        """The dark level added to radiance before the log response: dark_fraction x full_illumination (radiance
        units); feed_log takes log(radiance + dark_level)."""
        return float(self._scal[K.SC_DARK])

    @property
    def threshold_map(self) -> np.ndarray:
        """(2, H, W) float32 per-pixel contrast thresholds [C_on, C_off] (positive, log units)."""
        return np.stack((self._fixed[K.FX_C_ON], self._fixed[K.FX_C_OFF])).astype(np.float32)

    @property
    def leak_rate_map(self) -> np.ndarray:
        """(H, W) float64 per-pixel leak rate in Hz (static-pixel leak event rate without refractory)."""
        return self._leak_hz.copy()

    @property
    def hot_pixel_mask(self) -> np.ndarray:
        """(H, W) bool, True at hot pixels."""
        return self._hot.copy()

    @property
    def dead_pixel_mask(self) -> np.ndarray:
        """(H, W) bool, True at dead pixels (which never fire)."""
        return self._dead.copy() if self._dead is not None else np.zeros((self.height, self.width), dtype=bool)

    @property
    def log_intensity(self) -> np.ndarray:
        """(H, W) float64 photoreceptor output Lf (filtered log of radiance + dark level) at time_us."""
        return self._require_state()[K.ST_LF].copy()

    @property
    def reference_log(self) -> np.ndarray:
        """(H, W) float64 reference level at time_us, leak drift included (stale while a pixel is blind)."""
        st = self._require_state()
        return st[K.ST_REF] - self._fixed[K.FX_DRIFT] * (self._t - st[K.ST_REF_T])

    @property
    def last_event_us(self) -> np.ndarray:
        """(H, W) int64 time of each pixel's last event (NO_EVENT_US when it has not fired)."""
        return self._require_state()[K.ST_LAST_EVENT].copy()

    def _require_state(self):
        if self._state is None:
            raise EvsimInputError("the emulator has no state yet: feed() a first frame")
        return self._state

    # ----- input -----
    def feed(self, radiance: npt.ArrayLike, t_us: int | npt.ArrayLike) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Feed one frame (H, W) at integer time t_us, or a stack (N, H, W) at times (N,); return the new events.

        The very first frame only initialises the pixels.

        Parameters
        ----------
        radiance : array_like
            (H, W) or (N, H, W) linear radiance, >= 0 and finite (float; integer arrays are converted).
        t_us : int or array_like of int
            Its time, or the (N,) times: integer microseconds, strictly increasing across calls.

        Returns
        -------
        events : numpy.ndarray
            The EVENT_DTYPE events in (t_prev, t_last], sorted by (t, y, x).
        labels : numpy.ndarray
            With return_labels: their uint8 labels (EVENT_LABELS: signal, shot, leak, hot), as (events, labels).
        """
        frames, times = self._check_input(radiance, t_us)
        return self._feed(frames, times, log_in=False)

    def feed_log(self, log_radiance: npt.ArrayLike, t_us: int | npt.ArrayLike, *,
                 check_finite: bool = True) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """feed() for input that is already the log response: log(radiance + dark_level), as a scene that
        interpolates in log space holds it (the video conversion's key frames). It saves the emulator's log (a
        fifth of its per-pixel cost) and the scene's exp; the photocurrent is its float32 exp. Calls of feed and
        feed_log may alternate.

        Parameters
        ----------
        log_radiance : array_like
            (H, W) or (N, H, W) float32 natural log of (radiance + dark_level), finite, at least log(dark_level)
            (values up to 1e-5 below it, float32 rounding, are taken as radiance 0).
        t_us : int or array_like of int
            As for feed().
        check_finite : bool
            Check every value first (default; a pass over the input, as scipy.linalg's check_finite). False
            skips that for input known to hold these bounds (the video conversion's key frames, clamped at its
            floor): a NaN or infinite value then gives undefined events, a value below the floor is taken as it.

        Returns
        -------
        events : numpy.ndarray
            As for feed().
        labels : numpy.ndarray
            As for feed().
        """
        if not isinstance(check_finite, (bool, np.bool_)):
            raise InvalidParameterError(f"check_finite must be True or False, got {check_finite!r}")
        frames, times = self._check_input(log_radiance, t_us, log_in=True, check_values=bool(check_finite))
        return self._feed(frames, times, log_in=True)

    def _feed(self, frames: np.ndarray, times: np.ndarray, log_in: bool):
        if self._t is None:
            self._initialise(frames[0], int(times[0]), log_in)
            frames, times = frames[1:], times[1:]
        per_block = max(1, _BLOCK_PIXEL_FRAMES // (self.height * self.width))
        plans, i = [], 0
        while i < len(times):
            # until the event rate is known, a short block measures it (it sizes the event buffers)
            m = per_block if self._row_rate is not None else min(per_block, 4)
            plans.append(self._run(frames[i:i + m], times[i:i + m], log_in, fresh=bool(plans)))
            i += m
        # every block's events gathered into one array (no copy to join them)
        total = sum(int(plan[5][-1]) for plan in plans)
        events = np.empty(total, dtype=EVENT_DTYPE)  # all fields written
        labels = np.empty(total if self.return_labels else 0, dtype=np.uint8)
        done = 0
        for plan in plans:
            n_out = int(plan[5][-1])
            self._gather(plan, events[done:done + n_out], labels[done:done + n_out])
            done += n_out
        return (events, labels) if self.return_labels else events

    def _check_input(self, radiance, t_us, log_in: bool = False, check_values: bool = True):
        frames = np.asarray(radiance)
        what = "log_radiance" if log_in else "radiance"
        if frames.dtype.kind not in "fiu":
            raise EvsimInputError(f"{what} must be a real float (or integer) array, got dtype {frames.dtype}")
        if log_in:  # (float32: the kernels' exp of it is float32)
            frames = frames.astype(np.float32, copy=False)
        elif frames.dtype not in (np.float32, np.float64):  # integers, float16, other byte orders
            frames = frames.astype(np.float32 if frames.dtype.itemsize <= 2 else np.float64)
        times = np.asarray(t_us)
        if times.dtype.kind not in "iu":
            raise EvsimInputError(f"t_us must be integer microseconds, got dtype {times.dtype}")
        hw = (self.height, self.width)
        if frames.ndim == 2 and times.ndim == 0:
            frames, times = frames[None], times[None]
        elif not (frames.ndim == 3 and times.ndim == 1 and len(times) == len(frames)):
            raise EvsimInputError(
                f"expected a frame {hw} with a scalar time or a stack (N, *{hw}) with times (N,), got {what} "
                f"shape {frames.shape} and t_us shape {times.shape}"
            )
        if len(frames) == 0:
            raise EvsimInputError("no frames given")
        if frames.shape[1:] != hw:
            raise EvsimInputError(f"{what} frames must be {hw}, got {frames.shape[1:]}")
        times = check_times_us(times)
        if len(times) > 1:
            steps = np.diff(times)
            if steps.min() <= 0:
                i = int(np.flatnonzero(steps <= 0)[0]) + 1
                raise TimeOrderError(f"t_us must be strictly increasing: t[{i}]={times[i]} after {times[i - 1]} us")
            gap = int(steps.max())
        else:
            gap = 0
        if self._t is not None:
            if times[0] <= self._t:
                raise TimeOrderError(f"t_us={times[0]} is not after the previous frame time {self._t} us")
            gap = max(gap, int(times[0]) - self._t)
        if gap > MAX_TIME_GAP_US:
            raise InvalidParameterError(f"input times {gap} us apart: at most MAX_TIME_GAP_US = "
                                        f"{MAX_TIME_GAP_US} us (one hour) between consecutive frames")
        frames = np.ascontiguousarray(frames)
        if not check_values:
            return frames, times
        valid = [True]
        lowest = np.log(self.dark_level) - 1e-5 if log_in else 0.0  # (float32 rounding of log(0 + dark))

        def check(a, b):
            valid.append(K.frames_valid(frames[a:b], lowest))

        if len(frames) * frames[0].size <= 1 << 18:
            check(0, len(frames))
        else:
            in_parallel(check, len(frames), max(1, (1 << 18) // frames[0].size))
        if not all(valid):
            below = f"below log(dark_level) = {lowest + 1e-5:.6g} (negative radiance)" if log_in else "negative"
            for kind, bad in (("NaN", np.isnan), ("infinite", np.isinf), (below, lambda a: a < lowest)):
                idx = np.argwhere(bad(frames))
                if idx.size:
                    k, y, x = idx[0]
                    raise EvsimInputError(f"{what} has {kind} values, first in frame {k} at (y={y}, x={x})")
        return frames, times

    def _initialise(self, frame: np.ndarray, t: int, log_in: bool) -> None:
        shape = (self.height, self.width)
        logi = np.empty(shape)  # the kernels' log response, so that a pixel back at its first level is at it
        if log_in:
            cur = np.empty(shape)
            K.log_input(np.ascontiguousarray(frame).ravel(), self.dark_level, np.empty(frame.size, np.int32),
                        np.empty(frame.size, np.float32), cur.reshape(-1), logi.reshape(-1))
        else:
            cur = frame.astype(np.float64) + self._scal[K.SC_DARK]
            K.log_response(cur.ravel(), np.empty(cur.size, dtype=np.int64), logi.reshape(-1))
        # random leak phase: as if the reference had been reset a uniform fraction of a leak period ago
        drift = self._fixed[K.FX_DRIFT]
        since = np.divide(self._leak_phase * self._fixed[K.FX_C_ON], drift, out=np.zeros(shape), where=drift > 0)
        self._state = _slot_tuple(K.N_STATE, {
            K.ST_CURRENT: cur,
            K.ST_LOG: logi,
            K.ST_LF: logi.copy(),
            K.ST_REF: logi.copy(),
            K.ST_REF_T: t - since,
            K.ST_SHOT_BUDGET: self._init_shot_budget.copy(),
            K.ST_HOT_BUDGET: self._init_hot_budget.copy(),
            K.ST_LAST_EVENT: np.full(shape, NO_EVENT_US, dtype=np.int64),
            K.ST_DRAWS: np.zeros(shape, dtype=np.uint64),
        })
        self._t = t

    def _run(self, frames: np.ndarray, times: np.ndarray, log_in: bool, fresh: bool = False) -> tuple:
        """Advance all rows through a block of frames (radiance, or its log response with log_in); return the plan
        of its gather (see _gather): buffers, spill, row offsets, interval plan, times, row parts and counts. fresh:
        in an event buffer of its own (the reused one holds an earlier block's events, not gathered yet)."""
        h, n = self.height, len(times)
        cap = int((self._row_rate or 0.02 * self.width) * n * 1.5) + 16
        buf = np.empty(h * cap, dtype=np.int64) if fresh else self._buffers(h * cap)
        ends = np.empty((h, n), dtype=np.int64)
        t_prev = np.int64(self._t)
        # For one frame, the emulating threads count their events per microsecond of the interval (the counting
        # sort's first pass, while the events are in cache; the gather of one interval then runs on one thread) when
        # the counts take less memory than about twice the buffer. For several, the gathering threads count faster.
        bins = np.diff(times, prepend=t_prev) + 1
        t_base = np.cumsum(bins) - bins
        parts = np.array(split(h, max(1, 4096 // (self.width * n)), per_thread=_PARTS_PER_THREAD), dtype=np.int64)
        shape = (parts.size - 1, int(bins[0]))
        counted = n == 1 and shape[0] * shape[1] <= 2 * h * cap + 1024
        counts = np.zeros(shape if counted else (0, 0), dtype=np.int64)
        spills = self._emulate(frames, times, t_prev, cap, buf, ends, parts, counts, t_base, log_in)
        offsets, src_b, buf_b = self._rows * cap, np.zeros(h, dtype=np.bool_), buf
        over = np.flatnonzero(ends[:, -1] > cap)
        if over.size:  # rows that outgrew their buffer have all their events in the parts' spills
            buf_b = np.concatenate([spills[a][0] for a in parts[:-1]])
            done = 0
            for a in parts[:-1]:
                spill, spill_start = spills[a]
                mine = spill_start >= 0
                offsets[a:a + spill_start.size][mine] = done + spill_start[mine]
                done += spill.size
            src_b[over] = True
        starts, first_out = np.empty((h, n + 1), dtype=np.int64), np.empty(n + 1, dtype=np.int64)
        K.interval_plan(ends, starts, first_out)
        self._t = int(times[-1])
        self._row_rate = float(ends[:, -1].max()) / n
        return buf, buf_b, src_b, offsets, starts, first_out, t_prev, times, parts, counts, t_base

    def _gather(self, plan: tuple, events: np.ndarray, labels: np.ndarray) -> None:
        """Write a block's events (plan: from _run) sorted by (t, y, x) into events (and labels, unless empty), on
        the numba threads by ranges of frame intervals."""
        buf, buf_b, src_b, offsets, starts, first_out, t_prev, times, parts, counts, t_base = plan
        ev_bytes = events.view(np.uint8)

        def gather(k0, k1):
            K.gather_sorted(self._rows, buf, buf_b, src_b, offsets, starts, first_out, k0, k1, t_prev, times, parts,
                            counts, t_base, events, ev_bytes, labels)

        in_parallel(gather, len(times), 1 if len(times) < 8 else 4, per_thread=_PARTS_PER_THREAD)

    def _emulate(self, frames, times, t_prev, cap, buf, ends, parts, counts, t_base, log_in) -> dict:
        """K.emulate_rows over the parts of the rows (bounds `parts`) on the numba threads (row y's events at
        buf[y * cap:]), part p counting its events in counts[p] (when counts has rows).

        Returns first row of each part -> its spill (see K.emulate_rows)."""
        rows, spills, index = self._rows, {}, {int(a): p for p, a in enumerate(parts[:-1])}
        empty = np.empty(0, dtype=np.int64)

        def block(a, b):
            c = counts[index[a]] if counts.shape[0] else empty
            spills[a] = _returning_arrays(K.emulate_rows, frames, times, t_prev, rows[a:b], cap, self._state,
                                          self._fixed, self._scal, buf[a * cap:b * cap], ends[a:b], c, t_base,
                                          log_in)

        in_parallel(block, rows.size, 1, bounds=parts.tolist())
        return spills

    def _buffers(self, n: int) -> np.ndarray:
        """An event-word buffer for n events, reused across calls (fresh memory is slow to touch the first time)."""
        if self._bufs is None or self._bufs.size < n:
            self._bufs = np.empty(n, dtype=np.int64)
        return self._bufs


def _slot_tuple(n: int, slots: dict) -> tuple:
    """The kernel-input tuple of n slots holding slots[i] at index i (i: the slot constants of sim.dvs_kernels)."""
    if sorted(slots) != list(range(n)):
        raise ValueError(f"slots {sorted(slots)} are not 0 .. {n - 1}")
    return tuple(slots[i] for i in range(n))


def _returning_arrays(kernel, *args):
    """kernel(*args) for a numba kernel that returns arrays. Numba runs Python code to box them (it unpickles their
    dtype), where a signal's handler may raise (Ctrl-C's KeyboardInterrupt, the CLI's SIGTERM exception); numba then
    raises SystemError around it: raise the handler's exception instead, as anywhere else in Python code."""
    try:
        return kernel(*args)
    except SystemError as e:
        cause = e
        while isinstance(cause, SystemError) and cause.__cause__ is not None:
            cause = cause.__cause__
        if cause is e:
            raise
        raise cause from None


def _join(outs: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate (events, labels) pairs; events are joined as raw bytes (numpy copies packed records slowly)."""
    if len(outs) == 1:
        return outs[0]
    if not outs:
        return empty_events(), np.empty(0, dtype=np.uint8)
    events = np.concatenate([o[0].view(np.uint8) for o in outs]).view(EVENT_DTYPE)
    return events, np.concatenate([o[1] for o in outs])


def _blocks(pairs: Iterable) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Stack an iterable of (frame, t_us) pairs into blocks of about _BLOCK_PIXEL_FRAMES pixel-frames."""
    block_f, block_t = [], []
    for item in pairs:
        try:
            frame, t = item
        except (TypeError, ValueError):
            raise EvsimInputError("without times_us, frames must yield (frame, t_us) pairs") from None
        frame = np.asarray(frame)
        if block_f and frame.shape != block_f[0].shape:
            raise EvsimInputError(f"frame shape changed from {block_f[0].shape} to {frame.shape}")
        block_f.append(frame)
        block_t.append(t)
        if len(block_f) * frame.size >= _BLOCK_PIXEL_FRAMES:
            yield np.stack(block_f), np.asarray(block_t)
            block_f, block_t = [], []
    if block_f:
        yield np.stack(block_f), np.asarray(block_t)


def _emulate_pairs(pairs: Iterable, params, seed, return_labels: bool):
    emu, out = None, []
    for frames, times in _blocks(pairs):
        if emu is None:
            if frames.ndim != 3:
                raise EvsimInputError(f"each frame must be (H, W), got shape {frames.shape[1:]}")
            emu = DVSEmulator(frames.shape[1], frames.shape[2], params, seed, return_labels=return_labels)
        got = emu.feed(frames, times)  # (labels are only gathered when asked for)
        out.append(got if return_labels else (got, np.empty(0, dtype=np.uint8)))
    if emu is None:
        raise EvsimInputError("no frames to emulate")
    events, labels = _join(out)
    return (events, labels) if return_labels else events


def emulate(frames: np.ndarray | Iterable, times_us: npt.ArrayLike | None = None, params: DVSParams | None = None,
            seed: int | np.random.SeedSequence = 0, *,
            return_labels: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Emulate a whole sequence; return its events (and labels with return_labels), sorted by (t, y, x).

    Parameters
    ----------
    frames : numpy.ndarray or iterable
        An (N, H, W) array of linear radiance with times_us, or an iterable of (H, W) frames with times_us, or an
        iterable of (frame, t_us) pairs with times_us=None (consumed in bounded blocks).
    times_us : array_like of int, optional
        The (N,) frame times, integer microseconds, strictly increasing.
    params : DVSParams, optional
        The sensor (default the "davis346" preset).
    seed : int or numpy.random.SeedSequence
        The seed of mismatch and noise.
    return_labels : bool
        Also return the per-event labels.

    Returns
    -------
    events : numpy.ndarray
        EVENT_DTYPE events sorted by (t, y, x).
    labels : numpy.ndarray
        With return_labels: their uint8 labels, as (events, labels).
    """
    if isinstance(frames, np.ndarray):
        if times_us is None:
            raise EvsimInputError("an array of frames needs times_us")
        if frames.ndim != 3:
            raise EvsimInputError(f"frames must be (N, H, W), got shape {frames.shape}")
        return DVSEmulator(frames.shape[1], frames.shape[2], params, seed, return_labels=return_labels).feed(frames,
                                                                                                       times_us)
    return _emulate_pairs(frames if times_us is None else _with_times(frames, times_us), params, seed, return_labels)


def _with_times(frames: Iterable, times_us) -> Iterator[tuple]:
    times = np.asarray(times_us)
    k = 0
    for k, frame in enumerate(frames):
        if k >= len(times):
            raise EvsimInputError(f"more frames than times_us ({len(times)})")
        yield frame, times[k]
    if len(times) > k + 1:
        raise EvsimInputError(f"fewer frames than times_us ({len(times)})")


def emulate_source(source: RadianceSource, times_us: npt.ArrayLike, params: DVSParams | None = None,
                   seed: int | np.random.SeedSequence = 0, *,
                   return_labels: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Emulate a RadianceSource sampled at the given times.

    Parameters
    ----------
    source : RadianceSource
        The scene (radiance(t_us) -> (H, W) linear radiance).
    times_us : array_like of int
        The sample times, integer microseconds within [0, source.duration_us], increasing.
    params : DVSParams, optional
        The sensor (default the "davis346" preset).
    seed : int or numpy.random.SeedSequence
        The seed of mismatch and noise.
    return_labels : bool
        Also return the per-event labels.

    Returns
    -------
    events : numpy.ndarray
        EVENT_DTYPE events sorted by (t, y, x).
    labels : numpy.ndarray
        With return_labels: their uint8 labels, as (events, labels).
    """
    times = np.asarray(times_us)
    if times.ndim != 1 or times.dtype.kind not in "iu":
        raise EvsimInputError(f"times_us must be a 1-D integer array, got {times.dtype} shape {times.shape}")
    if times.size and (times.min() < 0 or times.max() > source.duration_us):
        raise EvsimInputError(f"times_us must lie in [0, {source.duration_us}] us")
    return _emulate_pairs(((source.radiance(int(t)), t) for t in times), params, seed, return_labels)


__all__ = ["DVSEmulator", "DVSParams", "EVENT_LABELS", "EVENT_DTYPE", "NO_EVENT_US", "emulate", "emulate_source"]
