"""Scenes and HDR sources, dataset generators, file formats and the evsim command line."""

__all__ = ["load"]


def __getattr__(name: str):
    # generators.load is imported on first use: the formats (h5py, the readers) are not needed by `evsim --help`
    if name == "load":
        from .formats import load

        return load
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
