"""Dataset file formats: the native HDF5 layout and export profiles, with readers.

- the registry (generators.formats.registry): one record per format; FORMATS (the names export() accepts),
  EXPORT_FORMATS (those a dataset generator writes per sequence), HOLDS (what each can hold);
- load(path) reads any readable layout (detected from the content, detect): native HDF5, E2VID HDF5, IJRR text
  folder (or its events.txt), E2VID text (.txt / .zip with a "width height" first line), AKF .mat, Prophesee EVT
  3.0 / EVT 2.0 .raw and .dat, AEDAT 2.0 (jAER, DAVIS layout: .aedat2 or .aedat), an EXR folder (reference frames
  only), and AEDAT4 when the optional `aedat` package is installed. Bad files raise DatasetFormatError;
- export(source, out, fmt) writes any of them (ExportDropWarning names what the format cannot hold);
- NativeWriter (streamed native files), ReaderNoteWarning (a file read with a remark), from_tonic / to_tonic.
Every name is imported on first use.
"""

from sim.lazy import lazy_exports

_EXPORTS = {
    "EXPORT_FORMATS": "registry", "FORMATS": "registry", "HOLDS": "registry",
    "DatasetFormatError": "common", "ReaderNoteWarning": "common",
    "ExportDropWarning": "dispatch", "detect": "dispatch", "export": "dispatch", "load": "dispatch",
    "NativeWriter": "native",
    "from_tonic": "interop", "to_tonic": "interop",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
