"""The CRF family: response curves y = CRF(x) and their weighting functions f^w(y) (eq. 5), from crf_models."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .common import pyplot, save_figure

if TYPE_CHECKING:
    from pathlib import Path


def default_curves() -> dict:
    """{name: CRF} of every crf_models curve that builds without parameters (tabulated curves need a table)."""
    import crf_models

    curves = {}
    for name in crf_models.available():
        try:
            curves[name] = crf_models.get(name)
        except crf_models.CRFError:
            continue
    return curves


def plot_crfs(out: str | Path, curves: dict | None = None, n: int = 512) -> dict:
    """Left: y against x on a log x axis (1e-4..1); right: the weighting f^w(y).

    Parameters
    ----------
    out : str or pathlib.Path
        The image file.
    curves : dict, optional
        {name: CRF} (default: every registered curve with its default parameters, default_curves).
    n : int, optional
        Samples per curve (default 512).

    Returns
    -------
    dict
        {name: (x, y, w)} the plotted samples.
    """
    curves = default_curves() if curves is None else curves
    x = np.logspace(-4, 0, n)
    yy = np.linspace(0, 1, n)
    data = {name: (x, np.asarray(c.forward(x)), np.asarray(c.weight(yy))) for name, c in curves.items()}
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, (xs, ys, ws) in data.items():
        line, = a.semilogx(xs, ys, label=name, lw=1.3)
        b.plot(yy, ws, color=line.get_color(), lw=1.3, label=name)
    a.set_xlabel("normalised scaled irradiance x")
    a.set_ylabel("response y = CRF(x)")
    a.set_title("camera response functions")
    b.set_xlabel("response y")
    b.set_ylabel("weighting f^w(y) (eq. 5)")
    b.set_title("certainty as a function of the response")
    for ax in (a, b):
        ax.grid(alpha=0.3)
    a.legend(fontsize=7, ncol=2)
    save_figure(fig, out)
    return data
