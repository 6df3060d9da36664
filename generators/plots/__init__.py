"""Figures and animations (optional: needs matplotlib, `pip install 'evsim[plot]'`; this package imports without it).

plot_pixel: one pixel over time (the figure that explains the AKF); plot_events: event frames, time surfaces and the
event rate; plot_compare: methods side by side with error and gain maps; plot_sweep: error (or a denoiser's AUC)
against swept noise parameters; plot_roc: ROC curves of event denoisers against the per-event labels; plot_crfs:
the CRF family; animate: events against the reconstruction as GIF/MP4. All use the Agg backend, one tone-mapping
operator (common.ToneMap) and write their files atomically.
"""

from .animate import animate
from .common import PlotDependencyError, Prepared, ToneMap, load_recording, prepare
from .compare import compare_images, plot_compare
from .crf import plot_crfs
from .events import event_frame, event_rate, plot_events, time_surface
from .pixel import PixelSeries, pixel_series, plot_pixel
from .roc import load_roc_result, plot_roc
from .sweep import plot_sweep, sweep_metrics
