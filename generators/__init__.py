"""Generation: HDR scenes and sources, AHDR sequences, datasets, sweeps and video conversion.

- sequences: `AHDRConfig`, `generate_ahdr` (one AHDR sequence from a scene), `generate_ahdr_suite` (the built-in
  suite);
- datasets: `load_config`, `parse_config` (TOML configurations), `generate_dataset`, `generate_sweep`, run one task
  per sequence by `run_tasks` (serially, on local workers or a cluster); `generators.convert.convert` (your own
  video or frames); `export_path` (`evsim export`: any file or folder evsim reads to another layout);
- files (`generators.formats`, the layer below): `load`, `export`, `detect`, `Recording`, `validate_recording`.
Scenes are in `generators.scenes`. Every name is imported on first use.
"""

from sim.lazy import lazy_exports

_EXPORTS = {
    "AHDRConfig": "ahdr", "generate_ahdr": "ahdr",
    "generate_ahdr_suite": "builtin",
    "load_config": "config", "parse_config": "config",
    "generate_dataset": "dataset",
    "generate_sweep": "sweep",
    "run_tasks": "runner",
    "export_path": "exports",
    "load": "formats", "export": "formats", "detect": "formats",
    "Recording": "formats.recording", "validate_recording": "formats.recording",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
