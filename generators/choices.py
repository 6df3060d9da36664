"""Import-free names of what generators offers, so that the CLI builds its parser (and `evsim --help` answers)
without loading the readers, OpenCV or numba. The modules that implement each choice import its names from here.
"""

# dataset file formats: the registry's names (generators.formats.registry, itself import-free); EXPORT_FORMATS, the
# formats a dataset generator can write per sequence (exr holds only the reference frames)
from .formats.registry import EXPORT_FORMATS, FORMATS, READ_SUFFIXES  # noqa: F401 (names for the CLI)

# the file of a dataset folder that lists its sequences (generators.dataset)
INDEX_FILE = "index.json"
# the file of an `evsim export` folder that says what it holds (generators.exports: format, source, sequences)
EXPORT_FILE = "export.json"
# the suffix of a complete sequence's manifest in a dataset folder ("<name>.manifest.json"; generators.dataset)
MANIFEST_SUFFIX = ".manifest.json"

# what a generated sequence holds (generators.ahdr.AHDRConfig.outputs): the events always, LDR frames and HDR
# reference frames when asked
OUTPUTS = ("events", "frames", "reference")

# the suffixes of video files (convert's inputs; what OpenCV decodes)
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg", ".wmv", ".flv")

# video conversion (generators.scenes.video, generators.scenes.flow_interpolation)
UPSAMPLE_MODES = ("flow", "linear", "none")
FLOW_METHODS = ("dis", "farneback")
DIS_PRESET_NAMES = ("ultrafast", "fast", "medium")
