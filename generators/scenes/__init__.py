"""HDR radiance sources (scenes). Each implements sim.source.RadianceSource: height, width, duration_us,
radiance(t_us) -> float32 (H, W) linear radiance >= 0, max_speed_px_per_s()."""

from .base import Scene
from .builtin_images import BUILTIN_IMAGES, builtin_hdr_image, builtin_image_scene
from .frame_sequence import FrameSequenceScene
from .image_motion import ImageMotionScene, Trajectory, linearise_ldr, load_image
from .lighting import LIGHTING_KEYS, FlickerLighting, checked_lighting, flicker_gain
from .luminance import REC709_WEIGHTS, to_luminance
from .procedural import Checkerboard, FlickeringLight, MovingEdge, RotatingBar, RotatingDisk, SunPatch
from .video import UPSAMPLE_MODES, VideoScene, input_size, open_frames

__all__ = [
    "Scene", "BUILTIN_IMAGES", "builtin_hdr_image", "builtin_image_scene", "FrameSequenceScene", "ImageMotionScene",
    "Trajectory", "linearise_ldr", "load_image", "FlickerLighting", "LIGHTING_KEYS", "checked_lighting", "flicker_gain",
    "REC709_WEIGHTS", "to_luminance", "Checkerboard", "FlickeringLight", "MovingEdge", "RotatingBar",
    "RotatingDisk", "SunPatch", "UPSAMPLE_MODES", "VideoScene", "input_size", "open_frames",
]
