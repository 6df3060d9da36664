"""Figures and animations (optional: needs matplotlib, `pip install 'evsim[plot]'`; this package imports without it).

plot_pixel: one pixel over time (the figure that explains the AKF); plot_events: event frames, time surfaces and the
event rate; plot_compare: methods side by side with error and gain maps; plot_hdr_recovery: the
README's HDR figure (reference and methods tone-mapped alike, log errors); plot_sweep: error (or a denoiser's AUC)
against swept noise parameters; plot_roc: ROC curves of event denoisers against the per-event labels; plot_realism:
a real recording's events beside a simulation's (the realism score's statistics); plot_crfs: the CRF family;
animate: events against the reconstruction as GIF/MP4. All use the Agg backend, one tone-mapping operator
(common.ToneMap) and write their files atomically.
"""

from sim.lazy import lazy_exports

# name -> submodule; imported on first use, so that `evsim --help` does not load every plotting module
_EXPORTS = {
    "animate": "animate",
    **dict.fromkeys(("PlotDependencyError", "Prepared", "ToneMap", "load_recording", "prepare"), "common"),
    **dict.fromkeys(("compare_images", "plot_compare", "plot_hdr_recovery"), "compare"),
    "plot_crfs": "crf",
    **dict.fromkeys(("event_frame", "event_rate", "plot_events", "time_surface"), "events"),
    **dict.fromkeys(("PixelSeries", "pixel_series", "plot_pixel"), "pixel"),
    **dict.fromkeys(("load_roc_result", "plot_roc"), "roc"),
    "plot_realism": "realism",
    **dict.fromkeys(("plot_sweep", "sweep_metrics"), "sweep"),
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
