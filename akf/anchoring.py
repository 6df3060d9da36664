"""Levels for the pixels no frame ever measures, from their neighbours (not in the paper; the smoother's last step).

A pixel whose every frame is clipped has, from its own data, only a bound (the clip level) and its events: its log
intensity is L_p(t) = a_p + E_p(t) with E_p known from the events and the offset a_p unknown beyond the bound.
Its neighbours watch nearly the same scene (the same texture moving past, or the same sky), so over the sequence
their log intensities differ little on average, and a neighbour that a frame did measure at some time has a level
at every time (the smoother carries it there with its events). The offsets of the never-measured pixels are chosen
to make each pixel agree, on average over the published times, with its 4-neighbours: the harmonic extension of
the measured pixels' levels into the never-measured region (a discrete Poisson equation, as in gradient-domain
image editing: Perez, Gangnet and Blake 2003 [Perez2003]), with the time-mean differences of their own event curves as
the guidance field. A weak pull (ANCHOR_PRIOR_WEIGHT, relative to one neighbour) toward a prior offset keeps every
component solvable: where no measured pixel touches a region, the prior (the clip prior's level, akf.clip_prior)
stands. The offset never takes a pixel past its clip bound: a pixel clipped high stays at or above the clip level.

References (docs/models/references.md): Perez et al. 2003 [Perez2003].
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

if TYPE_CHECKING:
    import numpy.typing as npt

__all__ = ["ANCHOR_PRIOR_WEIGHT", "anchor_offsets"]

#: the prior offset's weight against one neighbour's: about 1 / 0.001**0.5 = 30 pixels from the nearest measured
#: pixel, the prior counts as much as the neighbours
ANCHOR_PRIOR_WEIGHT = 1e-3


def anchor_offsets(log: npt.NDArray[np.floating], unknown: npt.NDArray[np.bool_], prior: npt.NDArray[np.float64],
                   lowest: npt.NDArray[np.float64], highest: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The log offset (H, W) of every unknown pixel (0 elsewhere) that minimises the squared time-mean differences
    with its 4-neighbours plus ANCHOR_PRIOR_WEIGHT times the squared distance to its prior offset, then clipped to
    [lowest, highest] (the offsets that keep it on its side of the clip bound).

    Parameters
    ----------
    log : numpy.ndarray
        (T, H, W) log intensities at the published times (the unknown pixels' own curves, the others' levels).
    unknown : numpy.ndarray
        (H, W) bool, the pixels to solve for.
    prior, lowest, highest : numpy.ndarray
        (H, W) log offsets (read at unknown pixels): the prior and the bounds.

    Returns
    -------
    numpy.ndarray
        float64 (H, W) log offsets (log units), 0 outside unknown.
    """
    t, h, w = log.shape
    idx = np.full((h, w), -1, np.int64)
    ys, xs = np.nonzero(unknown)
    m = ys.size
    if m == 0:
        return np.zeros((h, w))
    idx[ys, xs] = np.arange(m)
    mean = log.mean(axis=0, dtype=np.float64)
    diag = np.full(m, ANCHOR_PRIOR_WEIGHT)
    rhs = ANCHOR_PRIOR_WEIGHT * prior[ys, xs]
    rows, cols = [], []
    for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        qy, qx = ys + dy, xs + dx
        inside = (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
        p, qy, qx = np.flatnonzero(inside), qy[inside], qx[inside]
        diag[p] += 1.0
        rhs[p] += mean[qy, qx] - mean[ys[p], xs[p]]  # the neighbour's level minus this pixel's own curve
        q = idx[qy, qx]
        both = q >= 0  # an unknown neighbour: its offset is solved jointly
        rows.append(p[both])
        cols.append(q[both])
    r, c = np.concatenate(rows), np.concatenate(cols)
    a = scipy.sparse.csr_matrix((np.concatenate([diag, -np.ones(r.size)]), (np.concatenate([np.arange(m), r]),
                                                                            np.concatenate([np.arange(m), c]))),
                                shape=(m, m))
    d = scipy.sparse.linalg.spsolve(a.tocsc(), rhs)
    out = np.zeros((h, w))
    out[ys, xs] = np.clip(d, lowest[ys, xs], highest[ys, xs])
    return out
