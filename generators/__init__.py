"""Scenes and HDR sources, dataset generators, file formats and the evsim command line."""

from .formats import load
