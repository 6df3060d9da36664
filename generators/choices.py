"""Import-free names of what generators offers, so that the CLI builds its parser (and `evsim --help` answers)
without loading the readers, OpenCV or numba. The modules that implement each choice import its names from here.
"""

# dataset file formats (generators.formats)
FORMATS = ("native", "e2vid", "ijrr", "akf-mat", "exr", "e2vid-txt", "aedat4", "aedat2", "evt3", "evt2", "dat")
# the formats a dataset generator can write per sequence (exr holds only the reference frames)
EXPORT_FORMATS = tuple(f for f in FORMATS if f != "exr")

# the file of a dataset folder that lists its sequences (generators.dataset)
INDEX_FILE = "index.json"

# what a generated sequence holds (generators.ahdr.AHDRConfig.outputs): the events always, LDR frames and HDR
# reference frames when asked
OUTPUTS = ("events", "frames", "reference")

# video conversion (generators.scenes.video, generators.scenes.flow_interpolation)
UPSAMPLE_MODES = ("flow", "linear", "none")
FLOW_METHODS = ("dis", "farneback")
DIS_PRESET_NAMES = ("ultrafast", "fast", "medium")
