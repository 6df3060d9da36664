"""Pieces every panel of the lab uses: the explanation card, an image figure and a counter the browser tests read."""

from __future__ import annotations

import panel as pn
from bokeh.models import ColumnDataSource
from bokeh.plotting import figure


def explanation(title: str, text: str, equation: str) -> pn.pane.HTML:
    """The panel's paragraph and the equation it animates (HTML, no math renderer: nothing loaded from outside)."""
    return pn.pane.HTML(f"<h3>{title}</h3><p>{text}</p><p class='lab-equation'><code>{equation}</code></p>",
                        sizing_mode="stretch_width")


def image_figure(title: str, width: int, height: int, scale: float = 1.0) -> tuple[figure, ColumnDataSource]:
    """A figure showing one RGBA image (width x height pixels, drawn `scale` times larger) and its data source
    (column "image": a list of one uint32 array)."""
    fig = figure(title=title, width=int(width * scale), height=int(height * scale) + 30, x_range=(0, width),
                 y_range=(0, height), toolbar_location=None, tools="")
    fig.axis.visible = False
    fig.grid.visible = False
    source = ColumnDataSource({"image": []})
    fig.image_rgba(image="image", x=0, y=0, dw=width, dh=height, source=source)
    return fig, source


def count_html(element_id: str, label: str, value: int, extra: str = "") -> str:
    """The counter's HTML: label, the number in <b id=element_id>, and any extra text."""
    return f"<p style='font-size:1.1em'>{label}: <b id='{element_id}'>{value}</b>{extra}</p>"
