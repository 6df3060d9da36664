"""The names of the dataset file formats, import-free: the CLI builds its --format choices from them without
loading the readers and writers (generators.formats, which re-exports both tuples)."""

FORMATS = ("native", "e2vid", "ijrr", "akf-mat", "exr", "e2vid-txt", "aedat4", "evt3", "evt2", "dat")
# the formats a dataset generator can write per sequence (exr holds only the reference frames)
EXPORT_FORMATS = tuple(f for f in FORMATS if f != "exr")
