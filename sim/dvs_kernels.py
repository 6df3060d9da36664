"""Numba kernels of the DVS emulator (see sim.dvs for the model they implement).

Rows are independent: the caller runs blocks of rows (and of frame intervals when gathering) on its own threads,
the kernels releasing the GIL (nogil). Serial kernels compile several times faster than numba's parallel ones and
a call costs no thread-pool wake-up, which matters when frames are fed one at a time. Every random number a pixel
draws comes from a counter-based generator (splitmix64 of the pixel's key and its own draw counter, kept in the
state), so the output does not depend on the number of threads nor on how the frames are split into calls.
"""

from __future__ import annotations

import math
import sys

import numpy as np
from numba import njit
from numba.core import types
from numba.extending import intrinsic

from .events import EVENT_DTYPE
from .kernel_math import GOLDEN, exp_minus_row_f32, expm1_row_f32, log_row, mix64, stable_argsort

NO_EVENT_US = np.iinfo(np.int64).min  # last_event_us of a pixel that has not fired yet
LABEL_SIGNAL, LABEL_SHOT, LABEL_LEAK, LABEL_HOT = 0, 1, 2, 3

# Slots of the emulator's kernel inputs, three tuples (numba takes these module-level ints as compile-time constants).
# Log values are natural logs of photocurrent in radiance units; times are microseconds (us).
#
# state: the evolving per-pixel state, (H, W) arrays.
#   ST_CURRENT      float64  photocurrent I + I_d of the last frame (radiance units)
#   ST_LOG          float64  log response L of the last frame (log units, a multiple of LOG_GRID)
#   ST_LF           float64  photoreceptor output Lf at the last frame time (log units)
#   ST_REF          float64  reference level R at time ST_REF_T (log units); at time t it is
#                            R - drift * (t - ST_REF_T), with drift the FX_DRIFT slot
#   ST_REF_T        float64  time of the reference's last reset, from which its leak drift runs (us, not always an
#                            integer; at the first frame a random fraction of a leak period before it)
#   ST_SHOT_BUDGET  float64  remaining unit-exponential budget of the shot-noise Poisson clock (an arrival at 0)
#   ST_HOT_BUDGET   float64  remaining unit-exponential budget of the hot-pixel Poisson clock (an arrival at 0)
#   ST_LAST_EVENT   int64    time of the last event (us; NO_EVENT_US before the first)
#   ST_DRAWS        uint64   number of random draws taken from the pixel's stream (its counter)
(ST_CURRENT, ST_LOG, ST_LF, ST_REF, ST_REF_T, ST_SHOT_BUDGET, ST_HOT_BUDGET, ST_LAST_EVENT,
 ST_DRAWS) = 0, 1, 2, 3, 4, 5, 6, 7, 8
N_STATE = 9
# fixed: the per-pixel fixed pattern, (H, W) arrays.
#   FX_C_ON   float32  ON contrast threshold C_on (log units, > 0, a multiple of LOG_GRID)
#   FX_C_OFF  float32  OFF contrast threshold C_off (log units, > 0, a multiple of LOG_GRID)
#   FX_DRIFT  float64  leak drift: the reference falls at this rate (log units per us, >= 0)
#   FX_HOT    uint8    1 at hot pixels, else 0
#   FX_DEAD   uint8    1 at dead pixels (they evolve as the others, their events are not output), else 0; or (0, 0)
#                      when there are none
FX_C_ON, FX_C_OFF, FX_DRIFT, FX_HOT, FX_DEAD = 0, 1, 2, 3, 4
N_FIXED = 5
# scal: scalars shared by all pixels.
#   SC_REFRACTORY      int64    refractory period (us)
#   SC_K_CUT           float64  photoreceptor bandwidth per unit photocurrent: 1 / tau = SC_K_CUT * J, J the
#                               interval's geometric-mean photocurrent (per us per radiance unit; 0: no filter, Lf = L);
#                               J / I_d (>= 1) and the decay factor expm1(-SC_K_CUT J h) are evaluated in float32
#                               (expm1_row_f32: within 1.2e-7 relative, a quarter of float64's cost;
#                               docs/models/dvs.md), the filter and the noise clocks in float64
#   SC_DARK            float64  dark current I_d (radiance units)
#   SC_SHOT_RATE       float64  shot-noise rate (per us)
#   SC_DARK_SHOT_RATE  float64  dark shot-noise rate at J = I_d (per us; the rate scales with I_d / J)
#   SC_KEY             uint64   key of the random streams (a pixel's key mixes it with the pixel's flat index)
#   SC_HOT_RATE        float64  hot-pixel noise rate (per us)
SC_REFRACTORY, SC_K_CUT, SC_DARK, SC_SHOT_RATE, SC_DARK_SHOT_RATE, SC_KEY, SC_HOT_RATE = 0, 1, 2, 3, 4, 5, 6
N_SCAL = 7

_PIXEL_MUL = np.uint64(0xD1B54A32D192ED03)
_S11 = np.uint64(11)
_ONE = np.uint64(1)
_TWO_M53 = 2.0**-53
# An event in the kernels' buffers is one int64 word: its time after the start of its frame interval (dt, 1 ..
# the interval's length, which MAX_TIME_GAP_US keeps below 2**32 us), its column, polarity and label.
EV_DT_MASK = np.int64(0xFFFFFFFF)  # bits 0-31: dt (us)
EV_X_SHIFT = 32  # bits 32-47: x
EV_ON_SHIFT = 48  # bit 48: 1 for ON, 0 for OFF
EV_LABEL_SHIFT = 49  # bits 49-50: the label (LABEL_*)
# Output records are written with two overlapping 8-byte stores, bytes 0-7 (t) and 5-12 (t's top bytes, x, y, p),
# where the machine and EVENT_DTYPE's layout allow it (field by field otherwise)
_EV_SIZE = EVENT_DTYPE.itemsize
_TWO_STORES = (sys.byteorder == "little" and _EV_SIZE == 13
               and [EVENT_DTYPE.fields[f][1] for f in "txyp"] == [0, 8, 10, 12])
LOG_GRID = 2.0**-32  # the log response is rounded to multiples of this (see log_response)
_LOG_ROUND = 1.5 * 2.0**20  # (x + _LOG_ROUND) - _LOG_ROUND rounds x to a multiple of LOG_GRID for |x| < 2**19


@njit(cache=True, inline="always")
def _crossing(s, f0, f1, g, r, tr, dr, m, target, con, coff, t0, hf):
    """The first crossing at or after s (us into the interval at t0) of a pixel without noise, Lf going linearly
    from f0 at slope g, the reference r reset at tr (us) and drifting at dr; m = g + dr, target its threshold (con or
    -coff). Returns its offset sc (hf when reached at the interval's end, whatever the rounding; above hf: none; at
    most 2 hf) and its event time te (us, after t0). Branch-free, inlined in emulate_rows' vectorised loops; the
    same arithmetic as _multi_events and _pixel_events."""
    d = f0 + g * s - r + dr * ((t0 - tr) + s)
    sc = s + (target - d) * (1.0 / m if m != 0.0 else 0.0)
    sc = sc if sc > s else s
    sc = sc if sc < 2.0 * hf else 2.0 * hf  # keeps the integer conversion defined; sc > hf fails the test
    d_hf = f1 - r + dr * ((t0 - tr) + hf)  # as the busy test computes it: a crossing reached at the end
    at_end = (d_hf >= con) if m > 0.0 else (d_hf <= -coff)  # is inside the interval, whatever sc's rounding
    sc = hf if at_end & (sc > hf) else sc
    te = t0 + np.int64(math.ceil(sc))
    return sc, (te if te > t0 else t0 + 1)


@njit(cache=True, inline="always")
def _event_word(dt, x, on, label):
    """The event word (EV_*) of an event dt us after its interval's start at column x; on: non-zero for ON; label:
    a LABEL_* value."""
    return (np.int64(dt) | (np.int64(x) << EV_X_SHIFT) | (np.int64(on != 0) << EV_ON_SHIFT)
            | (np.int64(label) << EV_LABEL_SHIFT))


@intrinsic
def _store_i64(typingctx, buf, i, v):
    """buf[i : i + 8] = the bytes of the int64 v in machine order, one unaligned store (buf: a uint8 array; no
    bounds check: the caller keeps i + 8 <= buf.size)."""

    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, args[0]).data
        ptr = builder.bitcast(builder.gep(data, [args[1]]), context.get_value_type(types.int64).as_pointer())
        builder.store(args[2], ptr).align = 1
        return context.get_dummy_value()

    return types.void(buf, types.uintp, types.int64), codegen


@njit(cache=True, error_model="numpy")
def log_response(a, bits, out):
    """out = log(a) rounded to a multiple of LOG_GRID (2**-32), for positive normal a.

    On this grid, as on v2e's rounded log, the reference arithmetic is exact: thresholds are multiples of it too, so
    a pixel that returns exactly to a level it left has Lf - reference exactly -C_off (or +C_on) and fires as the
    rule says, instead of missing the tie by a rounding error.
    """
    log_row(a, bits, out)
    for i in range(a.size):
        out[i] = (out[i] + _LOG_ROUND) - _LOG_ROUND


@njit(cache=True, error_model="numpy")
def log_input(v, dark, bits, e, c, out):
    """The photocurrent c (float64, >= dark) and log response out (log_response's grid) of log input v = float32
    log(radiance + dark), clamped to log(dark) from below: c is v's float32 exp (exp_minus_row_f32, one ulp).
    bits: int32 and e: float32 scratch of v's size."""
    log_dark = math.log(dark)
    exp_minus_row_f32(v, np.float32(0.0), bits, e)
    for i in range(v.size):
        lv = float(v[i])
        lv = lv if lv > log_dark else log_dark
        out[i] = (lv + _LOG_ROUND) - _LOG_ROUND
        ci = float(e[i])
        c[i] = ci if ci > dark else dark


@njit(cache=True)
def _uniform(pixel_key, counter):
    """Uniform draw in (0, 1] number `counter` of the pixel's stream."""
    z = mix64(pixel_key + counter * GOLDEN)
    return (float(z >> _S11) + 1.0) * _TWO_M53


@njit(cache=True)
def _drop_arrivals(budget, rate, duration, pixel_key, counter):
    """Run a Poisson clock (remaining unit-exponential budget) through a dead time; arrivals are lost.

    Returns the new budget and draw counter.
    """
    if rate <= 0.0:
        return budget, counter
    used = rate * duration
    while budget <= used:
        used -= budget
        budget = -math.log(_uniform(pixel_key, counter))
        counter += _ONE
    return budget - used, counter


@njit(cache=True, nogil=True)
def frames_valid(frames, lowest):
    """True when every sample is finite and >= lowest (NaN fails both comparisons)."""
    n, h, w = frames.shape
    ok = np.empty(n * h, dtype=np.bool_)
    for i in range(n * h):
        k, y = i // h, i % h
        row_ok = True
        for x in range(w):
            v = frames[k, y, x]
            row_ok &= (v >= lowest) & (v < np.inf)
        ok[i] = row_ok
    n_bad = 0
    for i in range(n * h):
        n_bad += not ok[i]
    return n_bad == 0


@njit(cache=True, nogil=True, error_model="numpy")
def emulate_rows(frames, times, t_prev, rows, cap, state, fixed, scal, out, ends, t_counts, t_base, log_in):
    """Advance the listed rows through frames (N, H, W) at times (N,) us, starting from time t_prev: radiance, or with
    log_in float32 log(radiance + SC_DARK) (clamped to log(SC_DARK) from below; its exp, within one float32 ulp, is
    the photocurrent).

    state, fixed, scal: tuples of the per-pixel state (updated in place), the per-pixel fixed pattern and the
        scalars, with the slots ST_*, FX_* and SC_* above.
    Events of row i go to out[i * cap : i * cap + cap] as event words (EV_*: dt from the interval's start, x,
    polarity, label; one int64 store per event), in (frame, x, time) order; ends[i, k] gets the row's event count
    after frame k. A row with more than cap events continues in a buffer of its own and all its events go to the
    spill instead: returns the spill (event words) and spill_start (rows.size,), the index of row i's first event
    in the spill or -1 (rare: the caller sizes cap from the recent event rate). Events of dead pixels (FX_DEAD) are
    dropped as each interval ends, their state evolving as the others'. No state is saved for a rerun,
    which would cost a pass over the state per call (as much as the rest when fed one frame).
    t_counts: empty, or int64 counts to which the number of events of interval k at dt (us after its start) is
    added at t_counts[t_base[k] + dt] (the first pass of the counting sort, while the rows' events are in cache).

    A row runs through all frames before the next (its state stays in cache). Almost every busy pixel has no noise
    arrival in the interval and either exactly one crossing, or two with a refractory period (fast motion), or,
    blind at its start, wakes (or stays blind) without one: those cases are computed for all busy columns of the
    row at once in branch-free loops (vectorised; the same arithmetic as _pixel_events for them), more crossings in
    _multi_events, the others (a hot pixel without a crossing too) in _pixel_events. One function body indexing the
    (H, W) arrays directly: row views, and array arguments of inlined or called functions, cost reference counting
    (atomic operations) each time.
    """
    cur, logi, lf, ref, tref = state[ST_CURRENT], state[ST_LOG], state[ST_LF], state[ST_REF], state[ST_REF_T]
    e_shot, e_hot, last_t, ctr = state[ST_SHOT_BUDGET], state[ST_HOT_BUDGET], state[ST_LAST_EVENT], state[ST_DRAWS]
    c_on, c_off, drift, hot, dead = fixed[FX_C_ON], fixed[FX_C_OFF], fixed[FX_DRIFT], fixed[FX_HOT], fixed[FX_DEAD]
    any_dead = dead.shape[0] > 0
    refractory, k_cut, dark, shot_rate = scal[SC_REFRACTORY], scal[SC_K_CUT], scal[SC_DARK], scal[SC_SHOT_RATE]
    dark_shot_rate, key, hot_rate = scal[SC_DARK_SHOT_RATE], scal[SC_KEY], scal[SC_HOT_RATE]
    w = cur.shape[1]
    n = frames.shape[0]
    # scratch for all rows, allocated once per call (per-row allocations cost more than a row of a frame)
    w8 = (w + 7) // 8 * 8  # (whole 8-byte words of `slow`; its padding stays False)
    sf, si, slow = np.empty((17, w)), np.empty((5, w8), dtype=np.int64), np.zeros(w8, dtype=np.bool_)
    slow_words = slow.view(np.uint64)
    f0_t, lam_t, r2_j, tr2_j, es_j, eh_j, G = sf[0], sf[1], sf[2], sf[3], sf[4], sf[5], sf[6:17]
    todo, te_j, code_j, te2_j, code2_j = si[0], si[1], si[2], si[3], si[4]
    sv_f, sv_i, sv_u = np.empty((4, w)), np.empty(w, dtype=np.int64), np.empty(w, dtype=np.uint64)  # slow pixels
    # pixels with several crossings (_multi_events): the candidates, their new state and events
    mc_f, mc_i = np.empty((3, w)), np.empty((3, w), dtype=np.int64)
    mc_t, mc_l = np.empty((_MULTI_MAX, w), dtype=np.int64), np.empty((_MULTI_MAX, w), dtype=np.uint8)
    # per-chunk inputs of F frames of a row (photocurrent, log response, I_d / J, the filter's exponent and decay
    # factor), each computed for the whole chunk in one call: fewer calls, longer vector loops (2048 samples: the
    # chunk's arrays stay in the L2 cache)
    F = max(1, min(n, 2048 // w))
    c_ch, l_ch = np.empty(F * w), np.empty(F * w)  # (the rest float32: see SC_K_CUT's note)
    ij_ch, q_ch, em_ch = (np.empty(F * w, dtype=np.float32), np.empty(F * w, dtype=np.float32),
                          np.empty(F * w, dtype=np.float32))
    inv_dark2 = 1.0 / (dark * dark)
    bits, bits32 = np.empty(F * w, dtype=np.int64), np.empty(F * w, dtype=np.int32)
    e_ch = np.empty(F * w if log_in else 0, dtype=np.float32)  # log input: its exp
    zero = np.int64(0)  # one integer type for every call of _grown (each type would compile it again)
    spill = _grown(out, zero, zero, zero)  # the spill, empty
    sp_n = zero
    spill_start = np.full(rows.size, -1, dtype=np.int64)
    for i in range(rows.size):
        y = np.uintp(rows[i])
        # where the row's events go: E from index base, room for lim (a buffer of its own once outgrown)
        E, base, lim = out, i * cap, np.int64(cap)
        cnt = np.int64(0)  # an int64 from the start: a literal 0 compiles _pixel_events twice
        t0 = t_prev
        # Each step below is a short loop over the row touching few arrays, so that LLVM vectorises it.
        for k in range(n):
            if k % F == 0:  # the next chunk of frames k .. k + nk - 1
                nk = min(F, n - k)
                tk = t0
                for kk in range(nk):
                    o = kk * w
                    hf = float(times[k + kk] - tk)
                    tk = times[k + kk]
                    q_dark = np.float32(-k_cut * hf * dark)
                    if log_in:
                        log_input(frames[k + kk, y], dark, bits32[o:o + w], e_ch[o:o + w], c_ch[o:o + w],
                                  l_ch[o:o + w])
                    else:
                        for x in range(w):
                            c_ch[o + x] = float(frames[k + kk, y, x]) + dark
                    for x in range(w):
                        c = c_ch[o + x]
                        # J / I_d (>= 1) for the interval's geometric-mean photocurrent J: float32 without underflow
                        jr = np.sqrt(np.float32(cur[y, x] * c * inv_dark2))
                        ij_ch[o + x] = np.float32(1.0) / jr  # (one division serves the filter and the noise rate)
                        q_ch[o + x] = q_dark * jr
                        cur[y, x] = c
                if not log_in:
                    log_response(c_ch[:nk * w], bits[:nk * w], l_ch[:nk * w])
                if k_cut > 0.0:  # distinct in/out arrays: aliasing would prevent vectorisation
                    expm1_row_f32(q_ch[:nk * w], bits32[:nk * w], em_ch[:nk * w])
            o = (k % F) * w
            t1 = times[k]
            hf = float(t1 - t0)
            if k_cut > 0.0:
                # Photoreceptor: exact first-order response to the linear-in-time log input over the interval.
                inv_x = 1.0 / (k_cut * hf * dark)  # x = h / tau = k_cut hf J, J = I_d / ij
                for x in range(w):
                    l0 = logi[y, x]
                    l1 = l_ch[o + x]
                    em = np.float64(em_ch[o + x])
                    f0 = lf[y, x]
                    f0_t[x] = f0
                    ij = np.float64(ij_ch[o + x])
                    lf[y, x] = l1 + (l1 - l0) * em * (inv_x * ij) + (f0 - l0) * (1.0 + em)
                    logi[y, x] = l1
                    lam_t[x] = shot_rate + dark_shot_rate * ij
            else:
                for x in range(w):
                    f0_t[x] = lf[y, x]
                    lf[y, x] = l_ch[o + x]
                    logi[y, x] = l_ch[o + x]
                    lam_t[x] = shot_rate + dark_shot_rate * np.float64(ij_ch[o + x])
            # Quiet pixels (no crossing, no shot-noise arrival, not blind, not hot) only run their shot-noise clock.
            # The comparison is linear in time, so there is no crossing iff the end point is inside the band. Hot
            # pixels (a few) always take the busy path, so this loop, which streams every pixel's state, leaves out
            # their noise clock. (One loop: a second loop reading back `slow` stalled on store forwarding from masked
            # vector stores.)
            blind_from = t0 - refractory if refractory > 0 else np.iinfo(np.int64).max  # blind iff last_t >= it
            for x in range(w):
                d1 = lf[y, x] - ref[y, x] + drift[y, x] * ((t0 - tref[y, x]) + hf)
                es = e_shot[y, x] - lam_t[x] * hf
                busy = ((d1 >= np.float64(c_on[y, x])) | (d1 <= -np.float64(c_off[y, x])) | (es <= 0.0)
                        | (hot[y, x] != 0) | (last_t[y, x] >= blind_from))
                slow[x] = busy
                e_shot[y, x] = e_shot[y, x] if busy else es
            n_busy = 0
            for q in range(w8 // 8):  # compaction of the busy columns, skipping 8 quiet ones at a time
                if slow_words[q] != 0:
                    for x in range(8 * q, 8 * q + 8):  # (branch-free)
                        todo[n_busy] = x
                        n_busy += slow[x]
            # Events over (t0, t0 + hf] of the busy columns (Lf goes linearly from f0_t to lf_y).
            for j in range(n_busy):  # gather the busy columns' state (LLVM does not emit vector gathers for this CPU)
                x = np.uintp(todo[j])  # unsigned: no negative-index wraparound code on each access
                G[0, j] = f0_t[x]
                G[1, j] = lf[y, x]
                G[2, j] = ref[y, x]
                G[3, j] = tref[y, x]
                G[4, j] = drift[y, x]
                G[5, j] = np.float64(c_on[y, x])
                G[6, j] = np.float64(c_off[y, x])
                G[7, j] = e_shot[y, x] - lam_t[x] * hf
                G[8, j] = e_hot[y, x] - (hot_rate if hot[y, x] else 0.0) * hf
                blind0 = last_t[y, x] >= blind_from  # blind at t0: wakes (and resets) s0 into the interval
                G[9, j] = 1.0 if blind0 else 0.0
                G[10, j] = float(last_t[y, x] + refractory - t0) if blind0 else 0.0
            # The common cases for all busy columns at once (vectorised), each with no noise arrival: exactly one
            # crossing, or (for a pixel blind at t0) none, the pixel waking in the interval or staying blind.
            n_other = 0  # busy columns left to _multi_events or _pixel_events
            n_two = 0  # of those, candidates for exactly two crossings (code2_j: their code for the first)
            for j in range(n_busy):
                f0 = G[0, j]
                f1 = G[1, j]
                r = G[2, j]
                tr = G[3, j]
                dr = G[4, j]
                con = G[5, j]
                coff = G[6, j]
                es = G[7, j]
                eh = G[8, j]
                blind0 = G[9, j] != 0.0
                s0 = G[10, j]
                g = (f1 - f0) / hf
                m = g + dr
                r = f0 + g * s0 if blind0 else r  # the reset at the wake-up (s0 = 0 when awake at t0)
                tr = float(t0) + s0 if blind0 else tr
                target = con if m > 0.0 else -coff
                sc, te = _crossing(s0, f0, f1, g, r, tr, dr, m, target, con, coff, t0, hf)
                fires = (s0 < hf) & (m != 0.0) & (sc <= hf)  # (s0 >= hf: blind over the whole interval)
                sb = float(te + refractory - t0)
                blind_after = (refractory > 0) & (sb >= hf)
                r2 = f0 + g * sb if refractory > 0 else r - dr * ((t0 - tr) + sc) + target
                tr2 = float(t0) + (sb if refractory > 0 else sc)
                d_end = f1 - r2 + dr * ((t0 - tr2) + hf)
                one = fires & (blind_after | ((d_end < con) & (d_end > -coff)))
                ok = (es > 0.0) & (eh > 0.0) & (one | (blind0 & (not fires)))  # (a blind pixel without an event)
                leak = (m > 0.0) & (dr * ((t0 - tr) + sc) >= 0.5 * con)
                te_j[j] = te
                # code: 0 not these cases; else 1 + 2 * polarity bit + 4 * leak label + 8 * blind throughout (the
                # reference unchanged) + 16 * an event
                reset = fires & ((refractory == 0) | (sb < hf))  # a reset after the event, in the interval
                code = 1 + 2 * (m > 0.0) + 4 * leak + 8 * (s0 >= hf) + 16 * fires
                code_j[j] = code if ok else 0
                n_other += not ok
                two = (refractory > 0) & fires & (not one) & (es > 0.0) & (eh > 0.0)  # (m != 0: it fired)
                code2_j[j] = code if two else 0
                n_two += two
                r2_j[j] = r2 if reset else r
                tr2_j[j] = tr2 if reset else tr
                es_j[j] = es
                eh_j[j] = eh
            if n_two > 0:  # exactly two crossings (a second after the reset at sb), as _multi_events finds them
                for j in range(n_busy):
                    f0, f1, dr, con, coff = G[0, j], G[1, j], G[4, j], G[5, j], G[6, j]
                    g = (f1 - f0) / hf
                    m = g + dr
                    target = con if m > 0.0 else -coff
                    r2, tr2 = r2_j[j], tr2_j[j]
                    sb = float(te_j[j] + refractory - t0)
                    sc2, te2 = _crossing(sb, f0, f1, g, r2, tr2, dr, m, target, con, coff, t0, hf)
                    sb2 = float(te2 + refractory - t0)
                    r3, tr3 = f0 + g * sb2, float(t0) + sb2
                    d_end2 = f1 - r3 + dr * ((t0 - tr3) + hf)
                    code = code2_j[j]
                    two = (code != 0) & (sc2 <= hf) & ((sb2 >= hf) | ((d_end2 < con) & (d_end2 > -coff)))
                    leak2 = (m > 0.0) & (dr * ((t0 - tr2) + sc2) >= 0.5 * con)
                    te2_j[j] = te2
                    code_j[j] = code + 64 + 128 * leak2 if two else code_j[j]
                    n_other -= two
                    r2_j[j] = (r3 if sb2 < hf else r2) if two else r2
                    tr2_j[j] = (tr3 if sb2 < hf else tr2) if two else tr2
            if refractory > 0 and n_other > 0:  # several crossings without noise (code 32)
                _multi_events(y, t0, hf, refractory, n_busy, todo, code_j, G, lam_t, e_shot, hot, mc_f, mc_i, mc_t,
                              mc_l)
            # The busy columns' events, in column order. The loop can run again from the start if the row outgrows
            # its buffer (rare): it reads the slow pixels' state from where it saved it on their first visit, so a rerun
            # gives the same events and state (the buffer is replaced here, not in the loop: array variables
            # reassigned inside a loop cost reference counting on every iteration).
            n_saved = 0  # slow pixels j < n_saved have their state at entry saved
            while True:
                n_ev, need = cnt, np.int64(0)
                for j in range(n_busy):
                    x = np.uintp(todo[j])
                    code = code_j[j]
                    if code & 32:  # several events (_multi_events)
                        q = mc_i[2, j]
                        k_ev = mc_i[1, q]
                        if n_ev + k_ev > lim:
                            need = n_ev + k_ev + n_busy
                            break
                        for e in range(k_ev):  # (code & 2: ON; mc_l 1: LABEL_LEAK)
                            E[base + n_ev] = _event_word(mc_t[e, q] - t0, x, code & 2, LABEL_LEAK * mc_l[e, q])
                            n_ev += 1
                        last_t[y, x] = mc_t[k_ev - 1, q]
                        ref[y, x] = mc_f[0, q]
                        tref[y, x] = mc_f[1, q]
                        e_shot[y, x] = mc_f[2, q]
                    elif code != 0:
                        if code & 16:
                            k_new = 1 + ((code >> 6) & 1)  # (code & 64: a second event)
                            if n_ev + k_new > lim:
                                need = n_ev + k_new + n_busy
                                break
                            # (code & 2: ON; code & 4, code & 128: LABEL_LEAK, its value 2)
                            E[base + n_ev] = _event_word(te_j[j] - t0, x, code & 2, (code & 4) >> 1)
                            n_ev += 1
                            last_t[y, x] = te_j[j]
                            if code & 64:
                                E[base + n_ev] = _event_word(te2_j[j] - t0, x, code & 2, (code & 128) >> 6)
                                n_ev += 1
                                last_t[y, x] = te2_j[j]
                        e_shot[y, x] = es_j[j]
                        e_hot[y, x] = eh_j[j]
                        if not code & 8:
                            ref[y, x] = r2_j[j]
                            tref[y, x] = tr2_j[j]
                    else:
                        if j >= n_saved:
                            sv_f[0, j], sv_f[1, j] = e_shot[y, x], e_hot[y, x]
                            sv_f[2, j], sv_f[3, j] = ref[y, x], tref[y, x]
                            sv_i[j], sv_u[j] = last_t[y, x], ctr[y, x]
                            n_saved = j + 1
                        es, eh, r, tr, lt, c, n_new = _pixel_events(
                            t0, hf, f0_t[x], lf[y, x], lam_t[x], hot_rate if hot[y, x] else 0.0,
                            rows[i] * w + todo[j], todo[j], refractory, key, sv_f[0, j], sv_f[1, j], sv_f[2, j],
                            sv_f[3, j], sv_i[j], sv_u[j], np.float64(c_on[y, x]), np.float64(c_off[y, x]),
                            drift[y, x], E, base, lim, n_ev)
                        if n_new > lim:
                            need = n_new + n_busy
                            break
                        e_shot[y, x], e_hot[y, x], ref[y, x], tref[y, x], last_t[y, x], ctr[y, x] = es, eh, r, tr, lt, c
                        n_ev = n_new
                if need == 0:
                    break
                E = _grown(E, base, cnt, 2 * need)  # the row's events before this interval
                base, lim = zero, np.int64(E.size)
            if any_dead:  # the interval's events of dead pixels are dropped (their state evolves as the others')
                kept = base + cnt
                for q in range(base + cnt, base + n_ev):
                    word = E[q]
                    E[kept] = word
                    kept += dead[y, np.uintp((word >> EV_X_SHIFT) & 0xFFFF)] == 0
                n_ev = kept - base
            if t_counts.size:  # while the interval's events are in cache
                tb = t_base[k]
                for q in range(base + cnt, base + n_ev):
                    t_counts[np.uintp(tb + (E[q] & EV_DT_MASK))] += 1
            cnt = n_ev
            ends[i, k] = cnt
            t0 = t1
        if cnt > cap:  # the row's events, all in its own buffer, go to the spill
            if sp_n + cnt > spill.size:
                spill = _grown(spill, zero, sp_n, 2 * (sp_n + cnt))
            for q in range(cnt):
                spill[sp_n + q] = E[q]
            spill_start[i] = sp_n
            sp_n += cnt
    return spill[:sp_n], spill_start


_MULTI_MAX = 16  # most events of a pixel in one interval on _multi_events' path (more: _pixel_events)


@njit(cache=True, nogil=True)
def _multi_events(y, t0, hf, refractory, n_busy, todo, code_j, G, lam_t, e_shot, hot, mc_f, mc_i, mc_t, mc_l):
    """The busy columns left to _pixel_events (code_j 0) that are not hot pixels, with refractory > 0, one at a
    time: each one's events in exactly _pixel_events' arithmetic for a pixel without noise arrivals. A column whose
    events are all found (no noise arrival in the interval, 1 to _MULTI_MAX events) gets code 32 + 2 * polarity
    bit, mc_i[2, j] = q its index here, mc_i[1, q] its event count, mc_t[:, q] their times, mc_l[:, q] 1 for a leak
    label, and mc_f[:, q] its new reference, reference time and shot budget; the others keep code 0
    (_pixel_events). G: emulate_rows' gathered busy-column state."""
    inf = np.inf
    n_c = 0
    for j in range(n_busy):  # branch-free compaction of the candidates
        mc_i[0, n_c] = j
        n_c += (code_j[j] == 0) & (hot[y, np.uintp(todo[j])] == 0)
    q = 0
    for c in range(n_c):
        j = mc_i[0, c]
        x = np.uintp(todo[j])
        lam = lam_t[x]
        f0, f1, dr, con, coff = G[0, j], G[1, j], G[4, j], G[5, j], G[6, j]
        g = (f1 - f0) / hf
        blind0 = G[9, j] != 0.0
        s0 = G[10, j]
        es = e_shot[y, x]
        used = lam * s0
        if blind0 and (s0 >= hf or (lam > 0.0 and es <= used)):
            continue
        if blind0 and lam > 0.0:
            es = es - used
        s = s0 if blind0 else 0.0
        r = f0 + g * s0 if blind0 else G[2, j]
        tr = float(t0) + s0 if blind0 else G[3, j]
        m = g + dr
        inv_m = 1.0 / m if m != 0.0 else 0.0
        target = con if m > 0.0 else -coff
        inv_lam = 1.0 / lam if lam > 0.0 else 0.0
        n_ev = 0
        while True:
            d = f0 + g * s - r + dr * ((t0 - tr) + s)
            sc = max(s, s + (target - d) * inv_m) if m != 0.0 else inf
            d_hf = f1 - r + dr * ((t0 - tr) + hf)
            if sc > hf and m != 0.0 and ((d_hf >= con) if m > 0.0 else (d_hf <= -coff)):
                sc = hf
            sn = s + es * inv_lam if lam > 0.0 else inf
            se = min(sc, sn)
            if se > hf:  # no more events
                es = es - lam * (hf - s)
                break
            if not sc <= sn or n_ev == _MULTI_MAX:  # a noise arrival, or too many events: _pixel_events
                n_ev = -1
                break
            es -= lam * (se - s)
            te = t0 + np.int64(math.ceil(se))
            if te <= t0:
                te = t0 + 1
            mc_t[n_ev, q] = te
            mc_l[n_ev, q] = (m > 0.0) and dr * ((t0 - tr) + se) >= 0.5 * con
            n_ev += 1
            sb = float(te + refractory - t0)
            used = lam * ((hf if sb >= hf else sb) - se)
            if lam > 0.0 and es <= used:  # an arrival while blind: _pixel_events
                n_ev = -1
                break
            if lam > 0.0:
                es = es - used
            if sb >= hf:  # blind to the end (the reference is reset after the interval)
                break
            s = sb
            r = f0 + g * sb
            tr = float(t0) + sb
        if n_ev > 0:
            mc_f[0, q], mc_f[1, q], mc_f[2, q] = r, tr, es
            mc_i[1, q] = n_ev
            mc_i[2, j] = q
            code_j[j] = 32 + 2 * (m > 0.0)
            q += 1


@njit(cache=True)
def _grown(words, base, n, size):
    """A new event-word array of `size` holding the n events at index base of the given one."""
    out = np.empty(size, dtype=np.int64)
    for q in range(n):
        out[q] = words[base + q]
    return out


@njit(cache=True)
def _pixel_events(t0, hf, f0, f1, lam_s, lam_h, pixel, x, refractory, key, es, eh, r, tr, lt, c, con, coff, dr,
                  out, base, cap, cnt):
    """Events of one pixel (flat index `pixel`, column x, state given as scalars) over (t0, t0 + hf].

    Returns its new state (es, eh, r, tr, lt, c) and the row's event count. A called function, not inlined: the
    array arguments of inlined code cost reference counting (atomic operations) on every busy pixel.
    """
    pkey = mix64(key + np.uint64(pixel) * _PIXEL_MUL)
    g = (f1 - f0) / hf
    s = 0.0
    done = False
    if refractory > 0 and lt + refractory >= t0:  # blind at the start of the interval
        sb = float(lt + refractory - t0)
        if sb >= hf:
            es, c = _drop_arrivals(es, lam_s, hf, pkey, c)
            eh, c = _drop_arrivals(eh, lam_h, hf, pkey, c)
            done = True
        else:
            es, c = _drop_arrivals(es, lam_s, sb, pkey, c)
            eh, c = _drop_arrivals(eh, lam_h, sb, pkey, c)
            s = sb
            r = f0 + g * s
            tr = float(t0) + s
    m = g + dr  # slope of Lf - reference: only one polarity can be reached in this interval
    inv_m = 1.0 / m if m != 0.0 else 0.0
    target = con if m > 0.0 else -coff
    inv_ls = 1.0 / lam_s if lam_s > 0.0 else 0.0
    inv_lh = 1.0 / lam_h if lam_h > 0.0 else 0.0
    while not done:
        d = f0 + g * s - r + dr * ((t0 - tr) + s)
        sc = max(s, s + (target - d) * inv_m) if m != 0.0 else np.inf
        d_hf = f1 - r + dr * ((t0 - tr) + hf)
        if sc > hf and m != 0.0 and ((d_hf >= con) if m > 0.0 else (d_hf <= -coff)):
            sc = hf  # a crossing reached at the interval's end is inside it, whatever the rounding of sc
        pol = 1 if m > 0.0 else -1
        sn = s + es * inv_ls if lam_s > 0.0 else np.inf
        sh = s + eh * inv_lh if lam_h > 0.0 else np.inf
        se = min(sc, sn, sh)
        if se > hf:
            es -= lam_s * (hf - s)
            eh -= lam_h * (hf - s)
            break
        crossing = sc <= sn and sc <= sh
        if crossing:
            es -= lam_s * (se - s)
            eh -= lam_h * (se - s)
            label = LABEL_LEAK if pol > 0 and dr * ((t0 - tr) + se) >= 0.5 * con else LABEL_SIGNAL
        else:
            pol = 1 if _uniform(pkey, c) < 0.5 else -1
            fresh = -math.log(_uniform(pkey, c + _ONE))
            c += np.uint64(2)
            if sn <= sh:
                label = LABEL_SHOT
                es = fresh
                eh -= lam_h * (se - s)
            else:
                label = LABEL_HOT
                eh = fresh
                es -= lam_s * (se - s)
        te = t0 + np.int64(math.ceil(se))
        if te <= t0:
            te = t0 + 1
        if cnt < cap:
            out[base + cnt] = _event_word(te - t0, x, pol > 0, label)
        cnt += 1
        lt = te
        if refractory > 0:
            # Physical reset: blind until te + refractory, then the reference takes the level of that moment.
            sb = float(te + refractory - t0)
            if sb >= hf:
                es, c = _drop_arrivals(es, lam_s, hf - se, pkey, c)
                eh, c = _drop_arrivals(eh, lam_h, hf - se, pkey, c)
                break
            es, c = _drop_arrivals(es, lam_s, sb - se, pkey, c)
            eh, c = _drop_arrivals(eh, lam_h, sb - se, pkey, c)
            s = sb
            r = f0 + g * s
            tr = float(t0) + s
        else:
            if crossing:
                r = r - dr * ((t0 - tr) + se) + (con if pol > 0 else -coff)
            else:
                r = f0 + g * se
            tr = float(t0) + se
            s = se
    return es, eh, r, tr, lt, c, cnt


@njit(cache=True, nogil=True)
def gather_sorted(row_ids, bufs_a, bufs_b, src_b, offsets, starts, first_out, k0, k1, t_prev, times, parts, counts,
                  t_base, events, ev_bytes, labels):
    """Merge the per-row event buffers of frame intervals k0 .. k1 - 1 into `events` (EVENT_DTYPE; ev_bytes is the
    same memory viewed as uint8) and `labels`, sorted by (t, y, x).

    Row i of row_ids (ascending y) has its event words at offsets[i] in bufs_b if src_b[i] else bufs_a; starts,
    first_out come from interval_plan. counts: (P, bins) event counts of the row parts parts[p] .. parts[p + 1] - 1
    per microsecond of each interval (interval k's at t_base[k] + dt, from emulate_rows), overwritten with output
    positions; or (0, 0): counted here. labels: empty when not wanted. Frame intervals are independent (callers may
    run ranges of them on several threads), and in each the events are stably sorted by t: rows arrive in y order
    and a row's events of one interval in x order, so the result is in (t, y, x) order.
    """
    for k in range(k0, k1):
        _gather_interval(row_ids, bufs_a, bufs_b, src_b, offsets, starts, first_out, k, t_prev, times, parts, counts,
                         t_base, events, ev_bytes, labels)


@njit(cache=True)
def interval_plan(ends, starts, first_out):
    """Fill starts (rows, n + 1), row i's first buffered event of interval k at [i, k], and first_out (n + 1,),
    interval k's first output index (arguments, not returned: see sim.dvs._returning_arrays)."""
    n_rows, n = ends.shape
    for k in range(n + 1):
        first_out[k] = 0
    for i in range(n_rows):  # element loops: array expressions would compile numba's shape-error path
        starts[i, 0] = 0
        for k in range(n):
            starts[i, k + 1] = ends[i, k]
            first_out[k + 1] += ends[i, k] - (ends[i, k - 1] if k > 0 else 0)
    for k in range(n):
        first_out[k + 1] += first_out[k]


@njit(cache=True)
def _gather_interval(row_ids, bufs_a, bufs_b, src_b, offsets, starts, first_out, k, t_prev, times, parts, counts,
                     t_base, events, ev_bytes, labels):
    """Write the events of frame interval k stably sorted by t (see gather_sorted)."""
    m = first_out[k + 1] - first_out[k]
    if m == 0:
        return
    out = first_out[k]
    t_lo = times[k - 1] if k > 0 else t_prev
    span = times[k] - t_lo
    if counts.shape[0]:  # counted by the emulating threads, per part of the rows
        tb = t_base[k]
        acc = out
        for b in range(tb, tb + span + 1):  # part p's events at t go after those of the earlier t, then parts
            for p in range(counts.shape[0]):
                c = counts[p, b]
                counts[p, b] = acc
                acc += c
        for p in range(counts.shape[0]):
            scatter_events(parts[p], parts[p + 1], row_ids, bufs_a, bufs_b, src_b, offsets, starts, k, t_lo,
                           counts[p, tb:], events, ev_bytes, labels)
        return
    if span <= 4 * m + 1024:  # counting sort over the interval's microseconds
        pos = np.zeros(span + 1, dtype=np.int64)
        for i in range(row_ids.size):
            bw = bufs_b if src_b[i] else bufs_a
            for j in range(offsets[i] + starts[i, k], offsets[i] + starts[i, k + 1]):
                pos[np.uintp(bw[j] & EV_DT_MASK)] += 1
        acc = out
        for b in range(span + 1):
            c = pos[b]
            pos[b] = acc
            acc += c
        scatter_events(0, row_ids.size, row_ids, bufs_a, bufs_b, src_b, offsets, starts, k, t_lo, pos, events,
                       ev_bytes, labels)
        return
    # a long interval with few events: comparison sort
    tt = np.empty(m, dtype=np.int64)
    src_i = np.empty(m, dtype=np.int64)
    src_j = np.empty(m, dtype=np.int64)
    q = 0
    for i in range(row_ids.size):
        bw = bufs_b if src_b[i] else bufs_a
        for j in range(offsets[i] + starts[i, k], offsets[i] + starts[i, k + 1]):
            tt[q] = bw[j] & EV_DT_MASK
            src_i[q] = i
            src_j[q] = j
            q += 1
    order = stable_argsort(tt)
    for q in range(m):
        i, j = src_i[order[q]], src_j[order[q]]
        _put(events, ev_bytes, labels, out + q, t_lo, (bufs_b if src_b[i] else bufs_a)[j], row_ids[i])


@njit(cache=True, nogil=True)
def scatter_events(i0, i1, row_ids, bufs_a, bufs_b, src_b, offsets, starts, k, t_lo, pos, events, ev_bytes,
                   labels):
    """Write the events of interval k (starting at t_lo) in rows i0 .. i1 - 1 at pos[dt] (advanced), the counting
    sort's second pass."""
    for i in range(i0, i1):
        bw = bufs_b if src_b[i] else bufs_a
        y = row_ids[i]
        for j in range(offsets[i] + starts[i, k], offsets[i] + starts[i, k + 1]):
            word = bw[j]
            b = np.uintp(word & EV_DT_MASK)
            q = np.uintp(pos[b])
            pos[b] = q + 1
            _put(events, ev_bytes, labels, q, t_lo, word, y)


@njit(cache=True, inline="always")
def _put(events, ev_bytes, labels, q, t_lo, word, y):
    """events[q] (also ev_bytes, the same memory as bytes) and labels[q] unless labels is empty, from an event word
    of the interval starting at t_lo."""
    t = t_lo + (word & EV_DT_MASK)
    p = ((word >> (EV_ON_SHIFT - 1)) & 2) - 1
    if _TWO_STORES:  # two stores instead of four: the record's bytes 0-7, then 5-12
        o = np.uintp(q) * np.uintp(_EV_SIZE)
        _store_i64(ev_bytes, o, t)
        _store_i64(ev_bytes, o + np.uintp(5), ((t >> 40) & 0xFFFFFF) | (((word >> EV_X_SHIFT) & 0xFFFF) << 24)
                  | (np.int64(y) << 40) | (p << 56))
    else:
        events[q]["t"] = t
        events[q]["x"] = np.uint16((word >> EV_X_SHIFT) & 0xFFFF)
        events[q]["y"] = y
        events[q]["p"] = np.int8(p)
    if labels.size:
        labels[q] = np.uint8((word >> EV_LABEL_SHIFT) & 3)
