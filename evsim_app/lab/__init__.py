"""`evsim lab`: the teaching lab, four interactive panels over evsim's own models, in the browser or in Jupyter.

Models (numpy, no Panel): pixel_model (one pixel: DVS, LDR camera, AKF), scene_model (the sensor over a scene at
346x260), reconstruction_model (AKF, CF and frames only on a generated sequence), real_model (a shared real
recording beside its simulation, with realism scores); signals holds the pixel's radiance signals and metrics the
one import of akf's scores. Views (Panel, the `lab` extra): pixel_panel, scene_panel, reconstruction_panel,
real_panel, and app, which puts them in tabs and serves them. In Jupyter::

    import panel as pn
    from evsim_app.lab.app import lab
    pn.extension()
    lab()          # or one panel: evsim_app.lab.pixel_panel.PixelPanel().view
"""

from sim import EvsimInputError

INSTALL_HINT = 'the lab needs Panel: pip install "evsim[lab]" (from a clone: pip install ".[lab]")'


class LabDependencyError(EvsimInputError):
    """The `lab` extra (Panel and Bokeh) is not installed."""


def require_panel() -> None:
    """LabDependencyError with the install command unless Panel can be imported."""
    try:
        import panel  # noqa: F401
    except ImportError as exc:
        raise LabDependencyError(INSTALL_HINT) from exc
