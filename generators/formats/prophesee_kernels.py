"""Numba kernels of the Prophesee EVT 3.0 encoder and decoder (state machines over 16-bit words); the readers'
time rule, time_step_ok, is in time_wrap.py (also imported from here).

EVT 3.0 words (little-endian uint16, type in bits 15..12), as Prophesee documents them and Metavision decodes:
    0x0 ADDR_Y        bits 10..0 y (bit 11: system type, 0 = master camera)
    0x2 ADDR_X        bit 11 polarity (1 = ON), bits 10..0 x: one event at (x, last y, current time)
    0x3 VECT_BASE_X   bit 11 polarity, bits 10..0 x base for the vector words that follow
    0x4 VECT_12       bits 11..0: events at base + k for each set bit k; base += 12
    0x5 VECT_8        bits 7..0: the same for 8 pixels; base += 8
    0x6 TIME_LOW      bits 11..0 = time bits 11..0
    0x8 TIME_HIGH     bits 11..0 = time bits 23..12; a value below the previous one is a wrap of the 24-bit time
                      when time_step_ok says so (from the top of the range to its bottom), else a corrupt file
    0xA EXT_TRIGGER, 0xE OTHERS, 0x7 CONTINUED_4, 0xF CONTINUED_12: carry no CD event (skipped)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .time_wrap import WRAP_WINDOW, time_step_ok

__all__ = ["STATE_SIZE", "TIME_HIGH_MAX_STEP", "WRAP_WINDOW", "decode_evt3", "encode_evt3", "time_step_ok"]

_time_step_ok = njit(cache=True)(time_step_ok)

TIME_HIGH_MAX_STEP = 8  # TIME_HIGH steps (of 4096 us) in a silence: Metavision counts a wrap only when TIME_HIGH
# drops by at least 4085 steps (openeb evt3 decoder, LoopThreshold = 10 steps), so wraps must come in small steps


@njit(cache=True)
def encode_evt3(t, x, y, p, state, out):
    """Encode events into EVT 3.0 words.

    Parameters
    ----------
    t : numpy.ndarray
        int64 event times relative to the file's offset (us), non-decreasing.
    x, y : numpy.ndarray
        Pixel coordinates, < 2048.
    p : numpy.ndarray
        Polarities (> 0 = ON).
    state : numpy.ndarray
        int64 [time_high (unwrapped t >> 12), time, y] of the previous word written, -1 before the first; updated
        in place, carried between chunks.
    out : numpy.ndarray
        uint16 words, large enough: 4 words per event plus (t_gap >> 12) // TIME_HIGH_MAX_STEP at most.

    Returns
    -------
    int
        The number of words written to out.
    """
    k = 0
    th_prev, t_prev, y_prev = state[0], state[1], state[2]
    for i in range(t.size):
        ti = t[i]
        th = ti >> 12
        if th != th_prev:
            if th_prev >= 0:
                while th - th_prev > TIME_HIGH_MAX_STEP:  # long silence: keep every wrap visible
                    th_prev += TIME_HIGH_MAX_STEP
                    out[k] = 0x8000 | (th_prev & 0xFFF)
                    k += 1
            out[k] = 0x8000 | (th & 0xFFF)
            k += 1
            th_prev = th
            t_prev = -1
        if ti != t_prev:
            out[k] = 0x6000 | (ti & 0xFFF)
            k += 1
            t_prev = ti
        yi = np.int64(y[i])
        if yi != y_prev:
            out[k] = yi & 0x7FF
            k += 1
            y_prev = yi
        out[k] = 0x2000 | (0x800 if p[i] > 0 else 0) | (np.int64(x[i]) & 0x7FF)
        k += 1
    state[0], state[1], state[2] = th_prev, t_prev, y_prev
    return k


STATE_SIZE = 7  # decode_evt3's state: time_high, time_low, y, base_x, polarity, seen time_high, last event time


@njit(cache=True)
def decode_evt3(words, state, t, x, y, p):
    """Decode EVT 3.0 words into events.

    Parameters
    ----------
    words : numpy.ndarray
        uint16 EVT 3.0 words.
    state : numpy.ndarray
        np.int64 of STATE_SIZE: [time_high (unwrapped), time_low, y, base_x, polarity, seen time_high, time of the
        last event (-1 before the first)], carried between chunks; updated in place.
    t, x, y, p : numpy.ndarray
        Outputs, each as long as the words' events (ADDR_X words plus the set bits of vector words): t int64 us
        (from the unwrapped 24-bit time, relative to the file's offset), x, y uint16, p int8 -1/+1.

    Returns
    -------
    int
        The number of events decoded, or -1 - i when word i makes time go back (a TIME_HIGH step that time_step_ok
        refuses, or an event earlier than the one before it); state then holds the state before word i.
    """
    th, tl, yy, base, pol, seen, last = state[0], state[1], state[2], state[3], state[4], state[5], state[6]
    n = 0
    bad = -1
    for i in range(words.size):
        w = np.int64(words[i])
        typ = w >> 12
        if typ == 0x0:
            yy = w & 0x7FF
        elif typ == 0x2:
            ti = (th << 12) | tl
            if ti < last:
                bad = i
                break
            t[n] = ti
            x[n] = w & 0x7FF
            y[n] = yy
            p[n] = 1 if w & 0x800 else -1
            n += 1
            last = ti
        elif typ == 0x3:
            base = w & 0x7FF
            pol = 1 if w & 0x800 else -1
        elif typ == 0x4 or typ == 0x5:
            ti = (th << 12) | tl
            bits = w & (0xFFF if typ == 0x4 else 0xFF)
            if bits and ti < last:
                bad = i
                break
            width = 12 if typ == 0x4 else 8
            for b in range(width):
                if (w >> b) & 1:
                    t[n] = ti
                    x[n] = base + b
                    y[n] = yy
                    p[n] = pol
                    n += 1
                    last = ti
            base += width
        elif typ == 0x6:
            tl = w & 0xFFF
        elif typ == 0x8:
            v = w & 0xFFF
            low = th & 0xFFF
            if seen == 0:
                th = v
                seen = 1
            elif not _time_step_ok(low, v, 4096):
                bad = i
                break
            else:
                th += (v - low) & 0xFFF  # forward, across a wrap when v < low
    state[0], state[1], state[2], state[3], state[4], state[5], state[6] = th, tl, yy, base, pol, seen, last
    return n if bad < 0 else -1 - bad
