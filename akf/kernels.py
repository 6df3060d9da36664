"""Numba kernels: the AKF's exact between-event propagation, per-event updates and publishing; the EDI exposure
integral; the baselines' per-event loops.

Per-pixel state lives in rows indexed by y * width + x (see the S and C column constants); the frame window and the
event noise parameters are float64 arrays with named slots (W_* and NZ_*). Times are microseconds;
differences are converted to seconds inside the equations. The filter runs window by window: frame window k spans
[s_k, s_{k+1}) (s_k: exposure start of frame k). Inside it the augmented measurement of a pixel is
    L^A(t) = Mprev + w(t) * (Mcur - Mprev),  w(t) = clip((t - s_k) / (e_k - s_k), 0, 1)          (eq. 13)
where Mprev / Mcur are the current values of the interval curves that end / start at frame k (piecewise constant
between the pixel's events), and the log-space frame variance R(t) is piecewise linear with knots at the
mid-exposure times tau_{k-1}, tau_k, tau_{k+1} (eq. 7 applied to R of eq. 9). Between a pixel's updates both are
linear in time on the sub-segments split at tau_k and e_k, where `propagate` (`propagate_one_sided` for clipped
frames, which switches the one-sided rule at the exact crossing time) is the exact solution. Publishing is a
pure read (akf_publish stores nothing), so outputs never depend on which other times were requested.

Threads: the per-event and per-pixel kernels release the GIL and take a range of pixel rows (or pixels); the
callers run disjoint ranges on numba's thread count with sim.parallel.in_parallel (plain threads: numba's
parallel=True loops cost seconds of compilation each). Events are read in place from the sim.EVENT_DTYPE array.

References (docs/models/references.md): Wang et al. 2021 [Wang2021], the AKF; Kalman and Bucy 1961 [Kalman1961]; Pan et
al. 2019 [Pan2019], EDI; Scheerlinck et al. 2018 [Scheerlinck2018], the complementary filter; Mehra 1972 [Mehra1972]
(covariance matching of the frame update's prior); Kalman 1960 [Kalman1960], the discrete update; Allik et al. 2016
[Allik2016] (related; evsim's one-sided rule is simpler).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from llvmlite import ir
from numba import njit
from numba.core import cgutils, types
from numba.extending import intrinsic

if TYPE_CHECKING:
    import numpy.typing as npt

US = 1e-6  # seconds per microsecond
# fast math without reassociation (the series branches of the closed forms keep their precision); every value is
# finite by construction (R >= sigma_im2 / (I + I0)^2 > 0, P > 0).
FAST = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}


@intrinsic
def _prefetch(typingctx, arr, idx):
    """Hint the CPU to fetch arr.flat[idx] into cache for writing (LLVM prefetch; no effect on results)."""

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]),
                                            "llvm.prefetch.p0i8")
        ptr = builder.bitcast(builder.gep(ary.data, [args[1]]), i8p)
        builder.call(fn, [ptr, ir.Constant(i32, 1), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return types.void(arr, idx), codegen


PREFETCH_AHEAD = 16  # events: random pixel access is memory-latency bound, so fetch the state of later events


@njit(cache=True, inline="always", fastmath=FAST)
def _log1p_over_x(x):
    """log(1 + x) / x; its Taylor series (error < 3e-9) where |x| < 0.05, which also spares the log."""
    if abs(x) < 0.05:
        return 1.0 + x * (-1 / 2 + x * (1 / 3 + x * (-1 / 4 + x * (1 / 5 + x * (-1 / 6)))))
    return math.log1p(x) / x


@njit(cache=True, inline="always", fastmath=FAST)
def _h_coef(x):
    """((1 + x) log(1 + x) - x) / x^2; its Taylor series (error < 3e-10) where |x| < 0.05 (no cancellation)."""
    if abs(x) < 0.05:
        return 1 / 2 + x * (-1 / 6 + x * (1 / 12 + x * (-1 / 20 + x * (1 / 30 + x * (-1 / 42)))))
    return ((1.0 + x) * math.log1p(x) - x) / (x * x)


@njit(cache=True, fastmath=FAST)
def propagate(L, P, dt, R0, R1, A0, A1):
    """Exact solution over dt seconds of the between-event ODEs (16), (19):
        dP/dt = -P^2 / R(t),   dL/dt = -(P / R(t)) (L - A(t)),
    with R and the measurement A linear in time from (R0, A0) to (R1, A1). Returns (L, P) at the end.

    1/P grows by the integral of 1/R (eq. 20; for constant R exactly the paper's dt / R). Since
    d/dt[(L - A) / P] = -A' / P, the error (L - A) decays like P (eq. 17) minus the lag of a moving A.
    """
    return _propagate(L, P, dt, R0, R1, A0, A1)


@njit(cache=True, inline="always", fastmath=FAST)
def _propagate(L, P, dt, R0, R1, A0, A1):
    """propagate, inlined into the per-pixel kernels (a call per segment cost about 10% of their time)."""
    if dt <= 0.0:
        return L, P
    x = (R1 - R0) / R0
    P1 = 1.0 / (1.0 / P + dt / R0 * _log1p_over_x(x))
    e0 = L - A0
    dA = A1 - A0
    if dA == 0.0:
        return A1 + e0 * (P1 / P), P1
    # integral of 1/P(u) du over the segment is dt / P + H, H = integral of (1/P(u) - 1/P)
    H = dt * dt / R0 * _h_coef(x)
    return A1 + P1 * ((e0 - dA) / P - dA / dt * H), P1


@njit(cache=True, inline="always", fastmath=FAST)
def _lerp_time(t, ta, tb, va, vb):
    if tb <= ta:
        return vb
    u = (t - ta) / (tb - ta)
    return va + u * (vb - va)


@njit(cache=True, inline="always", fastmath=FAST)
def r_at(t, Ra, Rb, Rc, tau_a, tau_b, tau_c):
    """Log-space frame variance at time t (eq. 7): piecewise linear through (tau_a, Ra), (tau_b, Rb), (tau_c, Rc)."""
    if t < tau_b:
        return _lerp_time(t, tau_a, tau_b, Ra, Rb)
    return _lerp_time(t, tau_b, tau_c, Rb, Rc)


@njit(cache=True, inline="always", fastmath=FAST)
def blend_weight(t, s, e):
    """Weight of the new interval's curve during the exposure [s, e] of a frame (eq. 13)."""
    if t >= e:
        return 1.0
    if t <= s:
        return 0.0
    return (t - s) / (e - s)


@njit(cache=True, fastmath=FAST)
def _crossing(target, P, dt, R0, x):
    """Time u in [0, dt] (s) solving u + P * H(u) = target (s), H(u) = integral over [0, u] of (1/P(v) - 1/P) dv
    with R linear from R0 by the fraction x over dt (see propagate); dt when the left side stays below target.
    The left side is increasing and convex, so Newton's method from dt descends monotonically onto the root."""
    g = dt + P * dt * dt / R0 * _h_coef(x)
    if g <= target:
        return dt
    u = dt
    for _ in range(60):
        xu = x * u / dt
        step = (u + P * u * u / R0 * _h_coef(xu) - target) / (1.0 + P * u / R0 * _log1p_over_x(xu))
        u = max(u - step, 0.0)
        if abs(step) <= 1e-14 * dt:
            break
    return u


@njit(cache=True, fastmath=FAST)
def propagate_one_sided(L, P, dt, R0, R1, A0, A1, side, strong):
    """propagate against a censored measurement A (side +1: the truth is at or above A, -1: at or below, 0: an
    ordinary measurement). A censored measurement says nothing on its possible side (side * (L - A) > 0): there
    the state and its variance are kept as they are (the likelihood of a clipped response is flat beyond the clip
    level; Allik et al. 2016). On the impossible side (side * (L - A) < 0) it is pulled with R * strong.
    Exact, with the side switched at the crossing time rather than decided once per segment:
    (L - A) / P = e0 / P - A' * integral of 1/P (see propagate), so L - A changes sign only where A moves toward L
    (e0 * A' > 0): on the possible side at u = dt * e0 / (A1 - A0) (L stays), on the impossible side at the u
    solving u + P * H(u) = e0 / A' (_crossing). It cannot cross back within the segment: at L = A,
    d(L - A)/dt = -A', whose sign is fixed. Where L = A at the start, the side is that of the motion -A'.
    """
    if side == 0 or dt <= 0.0:
        return propagate(L, P, dt, R0, R1, A0, A1)
    e0 = L - A0
    dA = A1 - A0
    d = e0 if e0 != 0.0 else -dA
    possible = side * d >= 0.0
    if e0 * dA > 0.0:
        x = (R1 - R0) / R0
        u = e0 * dt / dA if possible else _crossing(e0 * dt / dA, P, dt, R0 * strong, x)
        if u < dt:
            v = u / dt
            Ac = A0 + v * dA
            if not possible:
                return Ac, 1.0 / (1.0 / P + u / (R0 * strong) * _log1p_over_x(x * v))
            return propagate(Ac, P, dt - u, (R0 + v * (R1 - R0)) * strong, R1 * strong, Ac, A1)
    if possible:
        return L, P
    return propagate(L, P, dt, R0 * strong, R1 * strong, A0, A1)


@njit(cache=True, inline="always", fastmath=FAST)
def advance(a, t, L, P, mp, dm, Ra, Rb, Rc, side_p, side_c, strong, s, e, tau_a, tau_b, tau_c):
    """(L, P) of a pixel last updated at a (us) brought to t (us) with no events, exact on each sub-segment
    split at tau_b and e. mp, dm: Mprev and Mcur - Mprev; Ra, Rb, Rc: its frame variances at the three taus.

    Clipped frames are one-sided (censored) measurements: where both frames of the interval curve in force are
    clipped (side_p / side_c = +1 high, -1 low, 0 otherwise; the curve with the larger blend weight counts, which
    changes at tau_b = mid-exposure, a sub-segment boundary), a state on the consistent side of the measurement
    (above it for +1) is kept (the measurement says nothing there), while a state on the impossible side is pulled with
    R * strong (strong = sigma_im2 / max_variance: the variance of a well-exposed pixel at the clip level). The side
    switches exactly where the estimate crosses the measurement (propagate_one_sided), so the result does not
    depend (beyond rounding) on where [a, t] is split: it solves the ODE, not a discretisation of it.

    Scalars only: numba helpers taking arrays pay reference counting per call, which dominated the per-event cost.
    """
    ra = r_at(a, Ra, Rb, Rc, tau_a, tau_b, tau_c)
    wa = blend_weight(a, s, e)
    for k in range(3):
        b = tau_b if k == 0 else (e if k == 1 else t)
        if b > t:
            b = t
        if b <= a:
            continue
        rb = r_at(b, Ra, Rb, Rc, tau_a, tau_b, tau_c)
        wb = blend_weight(b, s, e)
        side = side_c if wa >= 0.5 else side_p
        if side == 0:
            L, P = _propagate(L, P, (b - a) * US, ra, rb, mp + wa * dm, mp + wb * dm)
        else:
            L, P = propagate_one_sided(L, P, (b - a) * US, ra, rb, mp + wa * dm, mp + wb * dm, side, strong)
        a, ra, wa = b, rb, wb
    return L, P


@njit(cache=True, inline="always")
def leaked_before_first_event(drift, c_on):
    """Expected leak part of a pixel's first crossing (log): the drift since the start (drift, log) plus the
    pre-start drift u ~ uniform[0, c_on) of a pixel that has been leaking, capped at c_on (where the leak alone would
    have fired): E[min(u + drift, c_on)] = c_on / 2 + drift - drift^2 / (2 c_on) for drift < c_on."""
    if drift >= c_on:
        return c_on
    return 0.5 * c_on + drift - drift * drift / (2.0 * c_on)


# Columns of the per-pixel state S (float64; rows of N_STATE values start on 64-byte boundaries, so an event
# touches one cache line). Log quantities are in units of log(I + I0).
SL = 0  # L: log estimate (log)
SP = 1  # P: variance of the estimate (log^2)
ST = 2  # time of the last update (us; integers, exact in float64)
SMP = 3  # Mprev: value of the previous interval's curve, the one ending at the window's frame (log)
SMC = 4  # Mcur: value of the current interval's curve, the one starting at the window's frame (log)
SRA = 5  # R at tau_a: log-space frame variance of the frame at W_TAU_A (log^2)
SRB = 6  # R at tau_b: log-space frame variance of the frame at W_TAU_B (log^2)
SRC = 7  # R at tau_c: log-space frame variance of the frame at W_TAU_C (log^2)
N_STATE = 8

# Columns of the per-pixel contrasts C (float64, rows as in S).
CP_ON = 0  # calibrated ON contrast of the previous interval (log, > 0)
CP_OFF = 1  # calibrated OFF contrast of the previous interval (log, a magnitude > 0)
CC_ON = 2  # calibrated ON contrast of the current interval (log, > 0)
CC_OFF = 3  # calibrated OFF contrast of the current interval (log, a magnitude > 0)
CP_SIDE = 4  # clip side of the previous interval's curve: +1 / -1 where both its frames are clipped high / low, else 0
CC_SIDE = 5  # clip side of the current interval's curve (as CP_SIDE)
C_FIRST = 6  # 1 while the pixel's first event (which carries the unknown leak drift from before the start) is to
#              come, else 0
N_C = 8  # the last column is padding: a row fills one 64-byte cache line

# Slots of the frame window w (float64, us) of akf_events / akf_publish; window k spans [s_k, s_{k+1}).
W_S = 0  # s: exposure start of frame k (us)
W_E = 1  # e: exposure end of frame k (us)
W_TAU_A = 2  # tau_a: mid-exposure time of frame k - 1 (us; of frame 0 in the first window)
W_TAU_B = 3  # tau_b: mid-exposure time of frame k (us)
W_TAU_C = 4  # tau_c: mid-exposure time of frame k + 1 (us; of the last frame in the last window)
N_W = 5

# Slots of the event noise parameters `noise` (float64) of akf_events (see akf.AKFParams).
NZ_PROC = 0  # sigma_proc2: process noise density (log^2 / s)
NZ_ISO = 1  # sigma_iso2: isolated-pixel noise density (log^2 / s)
NZ_REF = 2  # sigma_ref2: refractory noise (log^2)
NZ_RHO = 3  # rho_bar: upper bound of the refractory period (us)
NZ_STRONG = 4  # strong = sigma_im2 / max_variance: R factor on the impossible side of a clipped frame (see advance)
NZ_LEAK = 5  # leak rate (1/us: ON events per us of a static pixel; 0: no leak correction)
N_NOISE = 6


def window(s: float, e: float, tau_a: float, tau_b: float, tau_c: float) -> npt.NDArray[np.float64]:
    """The frame window array w of akf_events / akf_publish (slots W_*; times in us)."""
    w = np.empty(N_W)
    w[W_S], w[W_E], w[W_TAU_A], w[W_TAU_B], w[W_TAU_C] = s, e, tau_a, tau_b, tau_c
    return w


def noise_params(sigma_proc2: float, sigma_iso2: float, sigma_ref2: float, rho_bar_us: float, strong: float,
                 leak_per_us: float) -> npt.NDArray[np.float64]:
    """The event noise array `noise` of akf_events (slots NZ_*, units there)."""
    q = np.empty(N_NOISE)
    q[NZ_PROC], q[NZ_ISO], q[NZ_REF], q[NZ_RHO], q[NZ_STRONG], q[NZ_LEAK] = (sigma_proc2, sigma_iso2, sigma_ref2,
                                                                             rho_bar_us, strong, leak_per_us)
    return q


@njit(cache=True, nogil=True, fastmath=FAST, error_model="numpy")
def akf_events(ev, width, S, C, te, w, noise, y0, y1):
    """Process the events of pixel rows [y0, y1) among time-sorted events inside one frame window (O(1) each).

    Row blocks are independent within a window (a pixel's update reads only its own state and its neighbours'
    last event times), so disjoint blocks can run on parallel threads, each with its own te.
    ev: contiguous sim.EVENT_DTYPE array, read in place (one layout whatever its length: one compiled version).
    S, C: per-pixel state and contrasts (columns above). te: the block's last event time per pixel (for Q_iso), flat
    (y1 - y0 + 2) * (width + 2): rows y0 - 1 .. y1 with a one-pixel border; the rows outside [y0, y1) mirror the
    neighbouring blocks' (very old times beyond the image) and are updated here from their events.
    w: the frame window (slots W_*, see window). noise: the event noise parameters (slots NZ_*, see noise_params).
    """
    s, e, tau_a, tau_b, tau_c = w[W_S], w[W_E], w[W_TAU_A], w[W_TAU_B], w[W_TAU_C]
    sp2, si2, sr2, rho = noise[NZ_PROC], noise[NZ_ISO], noise[NZ_REF], noise[NZ_RHO]
    strong, leak = noise[NZ_STRONG], noise[NZ_LEAK]
    wp = width + 2
    m = ev.shape[0]
    for n in range(m):
        if n + PREFETCH_AHEAD < m:
            xa = np.int64(ev[n + PREFETCH_AHEAD].x)
            ya = np.int64(ev[n + PREFETCH_AHEAD].y)
            if ya < y0 or ya >= y1:  # not this block's: fetch its own first row (the other's would bounce)
                xa, ya = 0, y0
            ia = ya * width + xa
            ja = (ya - y0 + 1) * wp + xa + 1
            _prefetch(S, ia * N_STATE)
            _prefetch(C, ia * N_C)
            _prefetch(te, ja - wp)
            _prefetch(te, ja)
            _prefetch(te, ja + wp)
        evn = ev[n]
        y = np.int64(evn.y)
        if y < y0 - 1 or y > y1:
            continue
        t = evn.t
        x = np.int64(evn.x)
        j = (y - y0 + 1) * wp + x + 1
        if y < y0 or y >= y1:  # a neighbouring block's row: only its event times matter here
            te[j] = t
            continue
        i = y * width + x
        mp = S[i, SMP]
        mc = S[i, SMC]
        Li, Pi = advance(S[i, ST], float(t), S[i, SL], S[i, SP], mp, mc - mp, S[i, SRA], S[i, SRB], S[i, SRC],
                         C[i, CP_SIDE], C[i, CC_SIDE], strong, s, e, tau_a, tau_b, tau_c)
        S[i, ST] = t
        t_self = te[j]
        t_nbr = max(
            max(max(te[j - wp - 1], te[j - wp]), max(te[j - wp + 1], te[j - 1])),
            max(max(te[j + 1], te[j + wp - 1]), max(te[j + wp], te[j + wp + 1])),
        )
        te[j] = t
        dts = t - t_self
        q_noise = sp2 * dts * US + si2 * (t - t_nbr) * US  # eq. 2: process + isolated-pixel noise
        if dts <= rho:
            q_noise += sr2  # refractory noise
        wt = blend_weight(t, s, e)
        if evn.p > 0:
            dp, dc = C[i, CP_ON], C[i, CC_ON]
        else:
            dp, dc = -C[i, CP_OFF], -C[i, CC_OFF]
        leaked = 0.0
        if leak > 0.0:
            c_on = C[i, CP_ON] + wt * (C[i, CC_ON] - C[i, CP_ON])
            drift = leak * c_on * dts  # the reference's leak since the pixel's last event, part of this crossing
            if C[i, C_FIRST] != 0.0:
                leaked = leaked_before_first_event(drift, c_on)
                q_noise += c_on * c_on / 12.0  # the unknown pre-start drift, uniform on [0, c_on)
                C[i, C_FIRST] = 0.0
            else:
                leaked = min(drift, c_on)
        S[i, SL] = Li + dp + wt * (dc - dp) - leaked  # eq. 15 with the (blended) calibrated contrast
        S[i, SMP] = mp + dp - leaked
        S[i, SMC] = mc + dc - leaked
        S[i, SP] = Pi + q_noise  # eq. 21


@njit(cache=True, nogil=True, fastmath=FAST)
def akf_publish(t, S, C, w, strong, i0, out_i, out_p, out_k, a, b):
    """Write I = exp(L) - I0, P and K = P / R at t (us) of pixels [a, b) (out_p / out_k when non-empty; R without
    the one-sided factor of advance). A pure read: each pixel is brought to t from its last update without storing
    the result, so the outputs at t and the later trajectory do not depend on which other times are published.
    With out_i empty, commit instead: store each pixel's state brought to t (the frame switch, before akf_rotate).
    One kernel for both: each copy of the inlined advance costs seconds of compilation."""
    commit = out_i.shape[0] == 0
    for i in range(a, b):
        L, P = S[i, SL], S[i, SP]
        if t > S[i, ST]:
            mp = S[i, SMP]
            L, P = advance(S[i, ST], t, L, P, mp, S[i, SMC] - mp, S[i, SRA], S[i, SRB], S[i, SRC],
                           C[i, CP_SIDE], C[i, CC_SIDE], strong, w[W_S], w[W_E], w[W_TAU_A], w[W_TAU_B], w[W_TAU_C])
            if commit:
                S[i, SL], S[i, SP], S[i, ST] = L, P, t
        if commit:
            continue
        out_i[i] = math.exp(L) - i0
        if out_p.shape[0]:
            out_p[i] = P
        if out_k.shape[0]:
            out_k[i] = P / r_at(t, S[i, SRA], S[i, SRB], S[i, SRC], w[W_TAU_A], w[W_TAU_B], w[W_TAU_C])


@njit(cache=True, nogil=True, fastmath=FAST)
def akf_frame_update(S, z, r, a, b):
    """Discrete Kalman update (Kalman 1960) of pixels [a, b), once akf_publish committed them to a frame's
    mid-exposure time, with the frame's log z and variance r (log^2; r <= 0 where the frame is clipped: no update).
    The prior variance is matched to the innovation nu = z - L (covariance matching, Mehra 1972): P_prior =
    max(P, nu^2 - r), since a P smaller than nu^2 - r is inconsistent with the frame (the filter's P shrinks under
    the continuous measurement between frames as if its errors were white). Then K = P_prior / (P_prior + r),
    L <- L + K nu, P <- P_prior r / (P_prior + r): where nu^2 > r the residual |(1 - K) nu| = r / |nu| is below
    sqrt(r), so the state ends within the frame's noise of the frame."""
    for i in range(a, b):
        ri = r[i]
        if ri > 0.0:
            nu = z[i] - S[i, SL]
            P = max(S[i, SP], nu * nu - ri)
            k = P / (P + ri)
            S[i, SL] += k * nu
            S[i, SP] = P * ri / (P + ri)


@njit(cache=True, nogil=True)
def akf_rotate(S, C, m_new, on_new, off_new, side_new, r_next, a, b):
    """Frame-window switch of pixels [a, b), once akf_publish committed them to the switch time s_k: rotate the
    intervals (current becomes previous; m_new, on_new, off_new, side_new: the new interval's curve value at s_k,
    calibrated contrasts and clip side) and the frame variances (r_next at tau_c)."""
    for i in range(a, b):
        S[i, SMP] = S[i, SMC]
        S[i, SMC] = m_new[i]
        S[i, SRA] = S[i, SRB]
        S[i, SRB] = S[i, SRC]
        S[i, SRC] = r_next[i]
        C[i, CP_ON], C[i, CP_OFF], C[i, CP_SIDE] = C[i, CC_ON], C[i, CC_OFF], C[i, CC_SIDE]
        C[i, CC_ON], C[i, CC_OFF], C[i, CC_SIDE] = on_new[i], off_new[i], side_new[i]


@njit(cache=True, nogil=True)
def event_change(ev, width, c_on, c_off, change, net, y0, y1):
    """Per-pixel nominal event log change (sum of +c_on / -c_off) and net signed event count of the events ev
    (sim.EVENT_DTYPE) of pixel rows [y0, y1), added to change and net (flat float64 / int64)."""
    m = ev.shape[0]
    for n in range(m):
        evn = ev[n]
        y = np.int64(evn.y)
        if y < y0 or y >= y1:
            continue
        i = y * width + np.int64(evn.x)
        if evn.p > 0:
            change[i] += c_on[i]
            net[i] += 1
        else:
            change[i] -= c_off[i]
            net[i] -= 1


@njit(cache=True, nogil=True, fastmath=FAST)
def exposure_integral(ev, width, c_on, c_off, t_start, t_end, acc, lvl, y0, y1):
    """EDI integral over the exposure [t_start, t_end) of pixel rows [y0, y1) (ev: sim.EVENT_DTYPE, inside the
    exposure): per pixel acc = (1/T) * integral of exp(c E(t)) dt, where E(t) is the signed event log change since
    t_start, and lvl = the total change c E(t_end) (acc, lvl: flat float64, zero on entry). Exact for
    piecewise-constant E."""
    a, b = y0 * width, y1 * width
    last = np.full(b - a, t_start)
    m = ev.shape[0]
    for n in range(m):
        evn = ev[n]
        y = np.int64(evn.y)
        if y < y0 or y >= y1:
            continue
        i = y * width + np.int64(evn.x)
        acc[i] += math.exp(lvl[i]) * (evn.t - last[i - a])
        last[i - a] = evn.t
        lvl[i] += c_on[i] if evn.p > 0 else -c_off[i]
    T = t_end - t_start
    for i in range(a, b):
        acc[i] = (acc[i] + math.exp(lvl[i]) * (t_end - last[i - a])) / T


@njit(cache=True, fastmath=FAST)
def _decay(x, lf, alpha, a, t):
    """Complementary-filter state x brought from a to t (us) without events: exponential decay toward lf."""
    if t > a:
        return lf + (x - lf) * math.exp(-alpha * (t - a) * US)
    return x


@njit(cache=True, nogil=True, fastmath=FAST)
def cf_events(ev, width, c_on, c_off, X, tl, LF, alpha, lo, hi, y0, y1):
    """Complementary filter (Scheerlinck et al. 2018) on the events ev (sim.EVENT_DTYPE) of pixel rows [y0, y1):
    decay toward the frame log LF at rate alpha (rad/s), then add the event's contrast; the state is kept in
    [lo, hi] (log units; -inf, inf: unbounded). With LF = 0 this is the events-only high-pass filter."""
    for n in range(ev.shape[0]):
        evn = ev[n]
        y = np.int64(evn.y)
        if y < y0 or y >= y1:
            continue
        i = y * width + np.int64(evn.x)
        t = evn.t
        X[i] = min(max(_decay(X[i], LF[i], alpha[i], tl[i], t) + (c_on[i] if evn.p > 0 else -c_off[i]), lo), hi)
        tl[i] = t


@njit(cache=True, nogil=True, fastmath=FAST)
def cf_publish(t, X, tl, LF, alpha, i0, out_i, a, b):
    """For pixels [a, b): with out_i empty (a frame switch), bring each to t (us), committing the state; otherwise
    write I = exp(X) - I0 at t as a pure read (the state is not stored, so outputs do not depend on the other
    times)."""
    commit = out_i.shape[0] == 0
    for i in range(a, b):
        x = _decay(X[i], LF[i], alpha[i], tl[i], t)
        if commit:
            if t > tl[i]:
                X[i] = x
                tl[i] = t
        else:
            out_i[i] = math.exp(x) - i0


@njit(cache=True, fastmath=FAST)
def integrate_events(ev, width, c_on, c_off, X):
    """Direct integration: add each event's (ev: sim.EVENT_DTYPE) contrast to the log image X."""
    for n in range(ev.shape[0]):
        evn = ev[n]
        i = np.int64(evn.y) * width + np.int64(evn.x)
        X[i] += c_on[i] if evn.p > 0 else -c_off[i]
