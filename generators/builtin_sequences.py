"""The built-in dataset's sequences (BUILTIN_SEQUENCES, re-exported by generators.builtin), in a module of their
own that imports nothing, so that the command line lists the scene names without loading the generators."""

# The default dataset (generators.builtin), in the configuration-file schema (see generators.config).
BUILTIN_SEQUENCES = [
    {"name": "astronaut_pan", "scene": {"type": "builtin_image", "image": "astronaut",
                                        "trajectory": {"pan_px_per_s": [30.0, 8.0], "shake_px": 1.0,
                                                       "shake_hz": 2.0}}},
    {"name": "camera_zoom_rotate", "scene": {"type": "builtin_image", "image": "camera",
                                             "trajectory": {"zoom_per_s": 0.2, "rotation_deg_per_s": 8.0}}},
    {"name": "checkerboard", "scene": {"type": "checkerboard", "square_px": 12.0,
                                       "velocity_px_per_s": [40.0, 10.0], "low": 0.02, "high": 400.0}},
    {"name": "sun", "scene": {"type": "sun", "velocity_px_per_s": [40.0, 10.0]}},
    {"name": "rotating_disk", "scene": {"type": "rotating_disk", "angular_speed_deg_s": 90.0}},
    {"name": "moving_edge", "scene": {"type": "moving_edge", "speed_px_per_s": 60.0}},
    {"name": "flicker", "scene": {"type": "flicker", "frequency_hz": 50.0}},
]
