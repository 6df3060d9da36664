"""Numba building blocks shared by the sensor kernels: a counter-based hash and vectorisable log / exp / expm1.

Counter-based randomness (a SplitMix64 hash of a stream key and a draw counter) lets parallel kernels give the same
numbers whatever the thread count or the order in which pixels are processed.

References (docs/models/references.md): Steele et al. 2014 [Steele2014], Salmon et al. 2011 [Salmon2011], Moshier
1989 [Moshier1989].
"""

from __future__ import annotations

import math

import llvmlite.ir as llvm_ir
import numpy as np
from numba import njit
from numba.core import types
from numba.extending import intrinsic

GOLDEN = np.uint64(0x9E3779B97F4A7C15)  # SplitMix64 stream increment
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31 = np.uint64(30), np.uint64(27), np.uint64(31)
_LN2 = math.log(2.0)
_SQRT_HALF_BITS = np.int64(0x3FE6A09E667F3BCD)  # bit pattern of sqrt(1/2)
# expm1_row_f32's constants (float32: numba keeps float32 arithmetic only between float32 values)
_F32_M40, _F32_ONE, _F32_ROUND = np.float32(-40.0), np.float32(1.0), np.float32(1.5 * 2**23)
_F32_INV_LN2, _F32_LN2_HI, _F32_LN2_LO = np.float32(1.0 / _LN2), np.float32(0.693359375), np.float32(-2.12194440e-4)
_F32_C2, _F32_C3, _F32_C4 = np.float32(1.0 / 2), np.float32(1.0 / 6), np.float32(1.0 / 24)
_F32_C5, _F32_C6, _F32_C7 = np.float32(1.0 / 120), np.float32(1.0 / 720), np.float32(1.0 / 5040)


@intrinsic
def _as_int64(typingctx, x):
    """The bits of a float64 as an int64 (no conversion; a bit cast, cheaper to compile than an array view)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.int64))

    return types.int64(types.float64), codegen


@intrinsic
def _as_float64(typingctx, x):
    """The float64 whose bits are the int64 x (a bit cast)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float64))

    return types.float64(types.int64), codegen


@intrinsic
def load_pair_f32(typingctx, u, k):
    """(u[k], u[k + 1]) of a float32 array u by one 8-byte load (two loads of a bilinear interpolation's four; no
    bounds check: the caller keeps k + 1 < u.size)."""

    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, args[0]).data
        pair = builder.load(builder.bitcast(builder.gep(data, [args[1]]), llvm_ir.VectorType(llvm_ir.FloatType(), 2)
                                            .as_pointer()))
        pair.align = 4
        first, second = (builder.extract_element(pair, llvm_ir.Constant(llvm_ir.IntType(32), i)) for i in (0, 1))
        return context.make_tuple(builder, signature.return_type, (first, second))

    return types.UniTuple(types.float32, 2)(u, types.uintp), codegen


@njit(cache=True)
def mix64(z):
    """splitmix64 finaliser: a bijective 64-bit hash."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@njit(cache=True, error_model="numpy")
def log_row(a, bits, out):
    """out = log(a) for positive normal a (within 1e-15 absolute); written so that LLVM vectorises it."""
    for i in range(a.size):
        ab = _as_int64(a[i])
        e = (ab - _SQRT_HALF_BITS) >> 52  # exponent that puts the mantissa in [sqrt(1/2), sqrt(2))
        bits[i] = ab - (e << 52)
        out[i] = float(e)
    for i in range(a.size):
        x = _as_float64(bits[i])
        s = (x - 1.0) / (x + 1.0)  # log(x) = 2 atanh(s), |s| <= 0.172
        z = s * s
        p = 2.0 / 19.0
        p = p * z + 2.0 / 17.0
        p = p * z + 2.0 / 15.0
        p = p * z + 2.0 / 13.0
        p = p * z + 2.0 / 11.0
        p = p * z + 2.0 / 9.0
        p = p * z + 2.0 / 7.0
        p = p * z + 2.0 / 5.0
        p = p * z + 2.0 / 3.0
        p = p * z + 2.0
        out[i] = out[i] * _LN2 + s * p


@njit(cache=True, error_model="numpy")
def expm1_row_f32(a, bits, out):
    """out = expm1(a) in float32 for float32 a <= 0, within 1.2e-7 relative (about one float32 unit in the last
    place: at most 1.16e-7, near -0.35, over 30 M sampled inputs); written so that LLVM vectorises it (8 lanes, a
    degree-7 polynomial: a quarter of the float64 cost).

    Cody-Waite reduction by ln 2 in two parts, e^r - 1 by its Taylor polynomial for |r| <= ln(2) / 2 (truncation
    below 1.5e-8 relative), then 2^k e^r - 1 = 2^k (e^r - 1) + (2^k - 1). Below -40 the result is -1 (e^-40 <
    5e-18): this also keeps subnormal numbers (slow) out of later products. bits: int32 scratch of a's size.
    """
    for i in range(a.size):
        x = a[i]
        x = x if x > _F32_M40 else _F32_M40
        k = (x * _F32_INV_LN2 + _F32_ROUND) - _F32_ROUND  # nearest integer
        r = (x - k * _F32_LN2_HI) - k * _F32_LN2_LO  # |r| <= ln(2) / 2
        p = _F32_C7 * r + _F32_C6
        p = p * r + _F32_C5
        p = p * r + _F32_C4
        p = p * r + _F32_C3
        p = p * r + _F32_C2
        out[i] = (p * r + _F32_ONE) * r  # e^r - 1
        bits[i] = (np.int32(k) + np.int32(127)) << 23  # 2^k
    two_k = bits.view(np.float32)
    for i in range(a.size):
        out[i] = two_k[i] * out[i] + (two_k[i] - _F32_ONE)


@njit(cache=True, nogil=True, fastmath={"nnan", "ninf", "nsz", "contract"})  # no reassociation: it undoes ln2_lo
def exp_minus_row_f32(v_row, eps, bits, o):
    """o = max(exp(v_row) - eps, 0) (float32; o may be v_row), exp as in Cephes' expf (Moshier 1989 [Moshier1989]):
    exp(v) = 2^n e^r with n = round(v / ln 2) and |r| <= ln(2) / 2, e^r by a degree-7 polynomial, 2^n written as
    float32 bits (bits: int32 scratch of the row's length); within one unit in the last place of float32 for v in
    [-87, 88] (v is clamped there: e^-87 is below the smallest normal float32's ten times, e^88 near its largest).
    Every loop vectorises (libm's scalar exp costs 7x as much)."""
    lo, hi = np.float32(-87.0), np.float32(88.0)
    log2e, ln2_hi, ln2_lo = _F32_INV_LN2, _F32_LN2_HI, _F32_LN2_LO
    c0, c1, c2 = np.float32(1.9875691500e-4), np.float32(1.3981999507e-3), np.float32(8.3334519073e-3)
    c3, c4, c5 = np.float32(4.1665795894e-2), np.float32(1.6666665459e-1), np.float32(5.0000001201e-1)
    zero, half, one = np.float32(0.0), np.float32(0.5), np.float32(1.0)
    two_n = bits.view(np.float32)
    for x in range(o.size):
        v = v_row[x]
        v = v if v > lo else lo  # (conditionals, not min/max: they vectorise)
        v = v if v < hi else hi
        n = np.floor(v * log2e + half)
        r = v - n * ln2_hi - n * ln2_lo
        o[x] = (((((c0 * r + c1) * r + c2) * r + c3) * r + c4) * r + c5) * r * r + r + one
        bits[x] = (np.int32(n) + np.int32(127)) << 23
    for x in range(o.size):
        v = o[x] * two_n[x] - eps
        o[x] = v if v > zero else zero


@njit(cache=True)
def stable_argsort(keys):
    """Indices that sort the int64 keys stably (ties keep their order): an LSD radix sort on 11-bit digits of
    keys - min(keys), as many passes as the range needs. Compiles in a fraction of the time of numba's
    np.argsort(kind="mergesort") and is faster on the event times it sorts."""
    n = keys.size
    order = np.arange(n)
    if n < 2:
        return order
    lo, hi = keys[0], keys[0]
    for i in range(n):
        lo = min(lo, keys[i])
        hi = max(hi, keys[i])
    span = np.uint64(hi - lo)  # exact even when the difference overflows int64
    tmp = np.empty(n, dtype=np.int64)
    count = np.empty(2049, dtype=np.int64)
    shift = np.uint64(0)
    while shift < np.uint64(64) and (span >> shift) != np.uint64(0):
        for d in range(2049):
            count[d] = 0
        for i in range(n):
            count[np.int64((np.uint64(keys[order[i]] - lo) >> shift) & np.uint64(0x7FF)) + 1] += 1
        for d in range(2048):
            count[d + 1] += count[d]
        for i in range(n):
            d = np.int64((np.uint64(keys[order[i]] - lo) >> shift) & np.uint64(0x7FF))
            tmp[count[d]] = order[i]
            count[d] += 1
        order, tmp = tmp, order
        shift += np.uint64(11)
    return order
