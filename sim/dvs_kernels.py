"""Numba kernels of the DVS emulator (see sim.dvs for the model they implement).

Rows are independent: the caller runs blocks of rows (and of frame intervals when gathering) on its own threads,
the kernels releasing the GIL (nogil). Serial kernels compile several times faster than numba's parallel ones and
a call costs no thread-pool wake-up, which matters when frames are fed one at a time. Every random number a pixel draws comes from a counter-based
generator (splitmix64 of the pixel's key and its own draw counter, kept in the state), so the output does not
depend on the number of threads nor on how the frames are split into calls.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .kernel_math import GOLDEN, expm1_row, log_row, mix64, stable_argsort

NO_EVENT_US = np.iinfo(np.int64).min  # last_event_us of a pixel that has not fired yet
LABEL_SIGNAL, LABEL_SHOT, LABEL_LEAK, LABEL_HOT = 0, 1, 2, 3

_PIXEL_MUL = np.uint64(0xD1B54A32D192ED03)
_S11 = np.uint64(11)
_ONE = np.uint64(1)
_TWO_M53 = 2.0**-53
LOG_GRID = 2.0**-32  # the log response is rounded to multiples of this (see log_response)
_LOG_ROUND = 1.5 * 2.0**20  # (x + _LOG_ROUND) - _LOG_ROUND rounds x to a multiple of LOG_GRID for |x| < 2**19


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
def frames_valid(frames):
    """True when every sample is finite and >= 0 (NaN fails both comparisons)."""
    n, h, w = frames.shape
    ok = np.empty(n * h, dtype=np.bool_)
    for i in range(n * h):
        k, y = i // h, i % h
        row_ok = True
        for x in range(w):
            v = frames[k, y, x]
            row_ok &= (v >= 0.0) & (v < np.inf)
        ok[i] = row_ok
    n_bad = 0
    for i in range(n * h):
        n_bad += not ok[i]
    return n_bad == 0


@njit(cache=True, nogil=True, error_model="numpy")
def emulate_rows(frames, times, t_prev, rows, cap, state, fixed, scal, out_t, out_x, out_p, out_lab, ends):
    """Advance the listed rows through frames (N, H, W) at times (N,) us, starting from time t_prev.

    state: (cur, logi, lf, ref, tref, e_shot, e_hot) float64 (H, W) arrays plus last_t int64 (H, W) and ctr
        uint64 (H, W), passed as a tuple. fixed: (c_on, c_off, drift, hot_rate) float64 (H, W).
    scal: (refractory_us, k_cut, dark, shot_rate, dark_shot_rate, key) (rates per us, k_cut per us per radiance).
    Events of row i go to out_*[i * cap : i * cap + cap], in (frame, x, time) order; ends[i, k] gets the row's
    event count after frame k. A row with more than cap events is rolled back to its state at entry (so it can be
    rerun with a larger buffer) and only its total ends[i, -1] is meaningful.
    """
    cur, logi, lf, ref, tref, e_shot, e_hot, last_t, ctr = state
    c_on, c_off, drift, hot_rate = fixed
    refractory, k_cut, dark, shot_rate, dark_shot_rate, key = scal
    w = cur.shape[1]
    for i in range(rows.size):
        y = rows[i]
        # the row's state at entry, for the rollback (element loops: a row assignment would compile numba's
        # shape-mismatch error path, seconds of compilation for nothing)
        saved_f, saved_i, saved_u = np.empty((7, w)), np.empty(w, dtype=np.int64), np.empty(w, dtype=np.uint64)
        for x in range(w):
            saved_f[0, x], saved_f[1, x], saved_f[2, x], saved_f[3, x] = cur[y, x], logi[y, x], lf[y, x], ref[y, x]
            saved_f[4, x], saved_f[5, x], saved_f[6, x] = tref[y, x], e_shot[y, x], e_hot[y, x]
            saved_i[x], saved_u[x] = last_t[y, x], ctr[y, x]
        cnt = _advance_row(frames, times, t_prev, y, i * cap, cap, cur[y], logi[y], lf[y], ref[y], tref[y],
                           e_shot[y], e_hot[y], last_t[y], ctr[y], c_on[y], c_off[y], drift[y], hot_rate[y],
                           refractory, k_cut, dark, shot_rate, dark_shot_rate, key, out_t, out_x, out_p, out_lab,
                           ends[i])
        if cnt > cap:
            for x in range(w):
                cur[y, x], logi[y, x], lf[y, x], ref[y, x] = saved_f[0, x], saved_f[1, x], saved_f[2, x], saved_f[3, x]
                tref[y, x], e_shot[y, x], e_hot[y, x] = saved_f[4, x], saved_f[5, x], saved_f[6, x]
                last_t[y, x], ctr[y, x] = saved_i[x], saved_u[x]


@njit(cache=True, error_model="numpy")
def _advance_row(frames, times, t_prev, y, base, cap, cur_y, logi_y, lf_y, ref_y, tref_y, es_y, eh_y, lt_y, ctr_y,
                 con_y, coff_y, dr_y, hot_y, refractory, k_cut, dark, shot_rate, dark_shot_rate, key, out_t, out_x,
                 out_p, out_lab, ends_y):
    """Advance row y (its state given as row views) through all frames; return its event count.

    ends_y[k] gets the row's event count after frame k.
    """
    w = cur_y.size
    n = frames.shape[0]
    c1_t, l1_t, q_t, em_t, j_t, f0_t, lam_t = (np.empty(w), np.empty(w), np.empty(w), np.empty(w), np.empty(w),
                                               np.empty(w), np.empty(w))
    bits = np.empty(w, dtype=np.int64)
    slow = np.empty(w, dtype=np.bool_)
    todo = np.empty(w, dtype=np.int64)
    sf = np.empty((4, w))
    G = np.empty((10, w))
    si = np.empty((2, w), dtype=np.int64)
    cnt = 0
    t0 = t_prev
    # Each step below is a short loop over the row touching few arrays, so that LLVM vectorises it.
    for k in range(n):
        t1 = times[k]
        hf = float(t1 - t0)
        for x in range(w):
            c1_t[x] = float(frames[k, y, x]) + dark
        log_response(c1_t, bits, l1_t)
        for x in range(w):
            j_t[x] = math.sqrt(cur_y[x] * c1_t[x])  # the interval's geometric-mean photocurrent
            cur_y[x] = c1_t[x]
        for x in range(w):
            f0_t[x] = lf_y[x]
        if k_cut > 0.0:
            # Photoreceptor: exact first-order response to the linear-in-time log input over the interval.
            for x in range(w):
                q_t[x] = -k_cut * hf * j_t[x]
            expm1_row(q_t, bits, em_t)  # distinct in/out arrays: aliasing would prevent vectorisation
            for x in range(w):
                l0 = logi_y[x]
                l1 = l1_t[x]
                em = em_t[x]
                lf_y[x] = l1 + (l1 - l0) * em / (k_cut * hf * j_t[x]) + (f0_t[x] - l0) * (1.0 + em)
        else:
            for x in range(w):
                lf_y[x] = l1_t[x]
        for x in range(w):
            logi_y[x] = l1_t[x]
            lam_t[x] = shot_rate + dark_shot_rate * dark / j_t[x]
        # Quiet pixels (no crossing, no noise arrival, not blind) only run their noise clocks. The
        # comparison is linear in time, so there is no crossing iff the end point is inside the band.
        for x in range(w):
            d1 = lf_y[x] - ref_y[x] + dr_y[x] * ((t0 - tref_y[x]) + hf)
            slow[x] = (d1 >= con_y[x]) | (d1 <= -coff_y[x])
        for x in range(w):
            es = es_y[x] - lam_t[x] * hf
            eh = eh_y[x] - hot_y[x] * hf
            busy = slow[x] | (es <= 0.0) | (eh <= 0.0)
            if refractory > 0:
                busy |= lt_y[x] + refractory >= t0
            slow[x] = busy
            es_y[x] = es_y[x] if busy else es
            eh_y[x] = eh_y[x] if busy else eh
        n_slow = 0
        for x in range(w):  # branch-free compaction of the busy columns
            todo[n_slow] = x
            n_slow += slow[x]
        cnt = _row_events(todo[:n_slow], t0, hf, f0_t, lf_y, lam_t, hot_y, y, refractory, key, ref_y, tref_y,
                          es_y, eh_y, lt_y, ctr_y, con_y, coff_y, dr_y, out_t, out_x, out_p, out_lab, base,
                          cap, cnt, sf, si, G)
        ends_y[k] = cnt
        t0 = t1
    return cnt


@njit(cache=True, inline="always")
def _row_events(todo, t0, hf, f0_t, f1_t, lam_t, hot_y, y, refractory, key, ref_y, tref_y, es_y, eh_y,
                lt_y, ctr_y, con_y, coff_y, dr_y, out_t, out_x, out_p, out_lab, base, cap, cnt, sf, si, G):
    """Events over (t0, t0 + hf] of the columns `todo` of row y (Lf goes linearly from f0_t to f1_t).

    The other arguments are that row's state; returns the row's updated event count. Almost every busy pixel has
    exactly one crossing and no noise arrival in the interval: that case is computed for all busy columns at once
    in branch-free loops (vectorised; the same arithmetic as _pixel_events for it), the others run _pixel_events.
    Inlined into the caller, since array arguments of a called function cost reference counting on every call.
    Scratch (float64 sf (4, W), G (10, W); int64 si (2, W)).
    """
    w = f0_t.size
    n = todo.size
    r2_j, tr2_j, es_j, eh_j = sf[0], sf[1], sf[2], sf[3]
    te_j, code_j = si[0], si[1]
    for j in range(n):  # gather the busy columns' state (LLVM does not emit vector gathers for this CPU)
        x = todo[j]
        G[0, j] = f0_t[x]
        G[1, j] = f1_t[x]
        G[2, j] = ref_y[x]
        G[3, j] = tref_y[x]
        G[4, j] = dr_y[x]
        G[5, j] = con_y[x]
        G[6, j] = coff_y[x]
        G[7, j] = es_y[x] - lam_t[x] * hf
        G[8, j] = eh_y[x] - hot_y[x] * hf
        G[9, j] = 1.0 if (refractory == 0) | (lt_y[x] + refractory < t0) else 0.0
    for j in range(n):  # the one-crossing case for all busy columns at once (vectorised)
        f0 = G[0, j]
        f1 = G[1, j]
        r = G[2, j]
        tr = G[3, j]
        dr = G[4, j]
        con = G[5, j]
        coff = G[6, j]
        es = G[7, j]
        eh = G[8, j]
        g = (f1 - f0) / hf
        m = g + dr
        target = con if m > 0.0 else -coff
        sc = (target - (f0 - r + dr * (t0 - tr))) * (1.0 / m if m != 0.0 else 0.0)
        sc = sc if sc > 0.0 else 0.0
        sc = sc if sc < 2.0 * hf else 2.0 * hf  # keeps the integer conversion defined; sc > hf fails the test
        d_hf = f1 - r + dr * ((t0 - tr) + hf)  # as the busy test computes it: a crossing reached at the end
        at_end = (d_hf >= con) if m > 0.0 else (d_hf <= -coff)  # is inside the interval, whatever sc's rounding
        sc = hf if at_end & (sc > hf) else sc
        te = t0 + np.int64(math.ceil(sc))
        te = te if te > t0 else t0 + 1
        sb = float(te + refractory - t0)
        blind_after = (refractory > 0) & (sb >= hf)
        r2 = f0 + g * sb if refractory > 0 else r - dr * ((t0 - tr) + sc) + target
        tr2 = float(t0) + (sb if refractory > 0 else sc)
        d_end = f1 - r2 + dr * ((t0 - tr2) + hf)
        ok = ((es > 0.0) & (eh > 0.0) & (m != 0.0) & (sc <= hf) & (G[9, j] != 0.0)
              & (blind_after | ((d_end < con) & (d_end > -coff))))
        leak = (m > 0.0) & (dr * ((t0 - tr) + sc) >= 0.5 * con)
        te_j[j] = te
        # code: 0 not this case; else 1 + 2 * polarity bit + 4 * leak label + 8 * reference unchanged
        code_j[j] = (1 + 2 * (m > 0.0) + 4 * leak + 8 * blind_after) if ok else 0
        r2_j[j] = r2
        tr2_j[j] = tr2
        es_j[j] = es
        eh_j[j] = eh
    for j in range(n):
        x = todo[j]
        code = code_j[j]
        if code != 0:
            if cnt < cap:
                out_t[base + cnt] = te_j[j]
                out_x[base + cnt] = x
                out_p[base + cnt] = 1 if code & 2 else -1
                out_lab[base + cnt] = LABEL_LEAK if code & 4 else LABEL_SIGNAL
            cnt += 1
            es_y[x] = es_j[j]
            eh_y[x] = eh_j[j]
            lt_y[x] = te_j[j]
            if not code & 8:
                ref_y[x] = r2_j[j]
                tref_y[x] = tr2_j[j]
        else:
            cnt = _pixel_events(t0, hf, f0_t[x], f1_t[x], lam_t[x], hot_y[x], y * w + x, x, refractory, key, ref_y,
                                tref_y, es_y, eh_y, lt_y, ctr_y, con_y, coff_y, dr_y, out_t, out_x, out_p, out_lab,
                                base, cap, cnt)
    return cnt


@njit(cache=True, inline="always")
def _pixel_events(t0, hf, f0, f1, lam_s, lam_h, pixel, x, refractory, key, ref_y, tref_y, es_y, eh_y, lt_y,
                  ctr_y, con_y, coff_y, dr_y, out_t, out_x, out_p, out_lab, base, cap, cnt):
    """Events of one pixel (flat index `pixel`, column x) over (t0, t0 + hf]; returns the row's event count."""
    es = es_y[x]
    eh = eh_y[x]
    r = ref_y[x]
    tr = tref_y[x]
    lt = lt_y[x]
    con = con_y[x]
    coff = coff_y[x]
    dr = dr_y[x]
    pkey = mix64(key + np.uint64(pixel) * _PIXEL_MUL)
    c = ctr_y[x]
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
            out_t[base + cnt] = te
            out_x[base + cnt] = x
            out_p[base + cnt] = pol
            out_lab[base + cnt] = label
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
    es_y[x] = es
    eh_y[x] = eh
    ref_y[x] = r
    tref_y[x] = tr
    lt_y[x] = lt
    ctr_y[x] = c
    return cnt


@njit(cache=True, nogil=True)
def gather_sorted(row_ids, bufs_a, bufs_b, src_b, offsets, starts, first_out, k0, k1, t_prev, times, events, labels):
    """Merge the per-row event buffers of frame intervals k0 .. k1 - 1 into `events` (EVENT_DTYPE) and `labels`,
    sorted by (t, y, x).

    Row i of row_ids (ascending y) has its events at offsets[i] in bufs_b if src_b[i] else bufs_a (each a tuple
    (t, x, p, label)); starts, first_out come from interval_plan. Frame intervals are independent (callers may
    run ranges of them on several threads), and in each the events are stably sorted by t: rows arrive in y order
    and a row's events of one interval in x order, so the result is in (t, y, x) order.
    """
    for k in range(k0, k1):
        _gather_interval(row_ids, bufs_a, bufs_b, src_b, offsets, starts, first_out, k, t_prev, times, events,
                         labels)


@njit(cache=True)
def interval_plan(ends):
    """starts[i, k]: row i's first buffered event of interval k; first_out[k]: interval k's first output index."""
    n_rows, n = ends.shape
    starts = np.zeros((n_rows, n + 1), dtype=np.int64)
    first_out = np.zeros(n + 1, dtype=np.int64)
    for i in range(n_rows):  # element loops: array expressions would compile numba's shape-error path
        for k in range(n):
            starts[i, k + 1] = ends[i, k]
            first_out[k + 1] += ends[i, k] - (ends[i, k - 1] if k > 0 else 0)
    for k in range(n):
        first_out[k + 1] += first_out[k]
    return starts, first_out


@njit(cache=True)
def _gather_interval(row_ids, bufs_a, bufs_b, src_b, offsets, starts, first_out, k, t_prev, times, events, labels):
    """Write the events of frame interval k stably sorted by t (see gather_sorted)."""
    m = first_out[k + 1] - first_out[k]
    if m == 0:
        return
    out = first_out[k]
    t_lo = times[k - 1] if k > 0 else t_prev
    span = times[k] - t_lo
    j0, j1 = starts[:, k], starts[:, k + 1]
    if span <= 4 * m + 1024:  # counting sort over the interval's microseconds
        pos = np.zeros(span + 1, dtype=np.int64)
        for i in range(row_ids.size):
            bt = bufs_b[0] if src_b[i] else bufs_a[0]
            for j in range(offsets[i] + j0[i], offsets[i] + j1[i]):
                pos[bt[j] - t_lo] += 1
        acc = out
        for b in range(span + 1):
            c = pos[b]
            pos[b] = acc
            acc += c
        for i in range(row_ids.size):
            bt, bx, bp, bl = bufs_b if src_b[i] else bufs_a
            for j in range(offsets[i] + j0[i], offsets[i] + j1[i]):
                b = bt[j] - t_lo
                q = pos[b]
                pos[b] = q + 1
                _put(events, labels, q, bt[j], bx[j], row_ids[i], bp[j], bl[j])
        return
    # a long interval with few events: comparison sort
    tt = np.empty(m, dtype=np.int64)
    src_i = np.empty(m, dtype=np.int64)
    src_j = np.empty(m, dtype=np.int64)
    q = 0
    for i in range(row_ids.size):
        bt = bufs_b[0] if src_b[i] else bufs_a[0]
        for j in range(offsets[i] + j0[i], offsets[i] + j1[i]):
            tt[q] = bt[j]
            src_i[q] = i
            src_j[q] = j
            q += 1
    order = stable_argsort(tt)
    for q in range(m):
        i, j = src_i[order[q]], src_j[order[q]]
        bt, bx, bp, bl = bufs_b if src_b[i] else bufs_a
        _put(events, labels, out + q, bt[j], bx[j], row_ids[i], bp[j], bl[j])


@njit(cache=True, inline="always")
def _put(events, labels, q, t, x, y, p, label):
    events[q]["t"] = t
    events[q]["x"] = x
    events[q]["y"] = y
    events[q]["p"] = p
    labels[q] = label
