"""Generation: scenes and HDR sources, AHDR sequences, datasets, sweeps, video conversion, configurations and the
runner that runs one task per sequence anywhere; file formats and the Recording in `generators.formats`."""

from . import moved

__all__ = ["load"]

moved.install()


def __getattr__(name: str):
    # generators.load is imported on first use: the formats (h5py, the readers) are not needed by `evsim --help`
    if name == "load":
        from .formats import load

        return load
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
