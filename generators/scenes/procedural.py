"""Procedural scenes with analytic ground truth.

Pixel (row i, column j) covers the unit square centred on (x=j, y=i). The moving edge and the checkerboard render
the exact mean radiance over that square (closed form). Curved or rotated shapes are anti-aliased with a
one-pixel linear ramp of their signed distance d from the pixel centre to the boundary, coverage =
clip(0.5 + d, 0, 1) (d > 0 inside), which is close to the area fraction and, unlike supersampling, continuous in
time: a sub-pixel motion gives a proportionally small change, which the adaptive DVS sampling relies on.
Each scene exposes its analytic state (edge position, offset, angle, centre, lamp intensity) at any time so that
tests and users can compare measurements with the truth. Speeds are in pixels per second, angular
speeds in degrees per second, times in microseconds, radiance in arbitrary linear units.
"""

from __future__ import annotations

import math

import numpy as np

from sim import InvalidParameterError
from sim.errors import check_int

from .base import Scene, level, number, numbers, positive


def _levels(owner: str, low: float, high: float) -> tuple[float, float]:
    low, high = level("low", low, owner), level("high", high, owner)
    if high <= low:
        raise InvalidParameterError(f"{owner}: high={high} must exceed low={low}")
    return low, high


def _pixel_grid(height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """x, y coordinates (float64, shape (H, W)) of the pixel centres."""
    return np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))


def _ramp(signed_distance: np.ndarray) -> np.ndarray:
    """Coverage of a pixel whose centre lies signed_distance inside a boundary (one-pixel linear ramp)."""
    return np.clip(0.5 + signed_distance, 0.0, 1.0)


def _disk_coverage(height: int, width: int, centre, radius: float) -> np.ndarray:
    x, y = _pixel_grid(height, width)
    return _ramp(radius - np.hypot(x - centre[0], y - centre[1]))


class MovingEdge(Scene):
    """A vertical step edge moving horizontally: radiance `high` left of x_e(t), `low` right of it.

    x_e(t) = x0 + speed * t (pixels; x0 defaults to a quarter of the width). Rendering is exact: a pixel's value is
    low + (high - low) * coverage, so sum over a row of (I - low) / (high - low) equals x_e + 0.5 while the edge is in
    the image.

    Parameters
    ----------
    height, width : int
        Image size (pixels), >= 1.
    duration_us : int
        Duration (us), >= 1.
    speed_px_per_s : float, optional
        Edge speed (pixels per second, either sign; default 100).
    x0 : float, optional
        Edge position at t = 0 (pixel x coordinate; default width / 4).
    low, high : float, optional
        Radiance of the dark and the bright parts (radiance units, high > low > 0; default 0.05 and 1).
    """

    def __init__(self, height: int, width: int, duration_us: int, *, speed_px_per_s: float = 100.0,
                 x0: float | None = None, low: float = 0.05, high: float = 1.0):
        self._init_size(height, width, duration_us)
        self.speed = number("speed_px_per_s", speed_px_per_s, "MovingEdge")
        self.x0 = self.width / 4 if x0 is None else number("x0", x0, "MovingEdge")
        self.low, self.high = _levels("MovingEdge", low, high)

    def edge_x(self, t_us: float) -> float:
        """Analytic edge position at a time.

        Parameters
        ----------
        t_us : float
            Scene time (us).

        Returns
        -------
        float
            x_e(t_us), the edge's pixel x coordinate.
        """
        return self.x0 + self.speed * t_us * 1e-6

    def _render(self, t_us):
        cov = np.clip(self.edge_x(t_us) - (np.arange(self.width) - 0.5), 0.0, 1.0)
        row = self.low + (self.high - self.low) * cov
        return np.broadcast_to(row.astype(np.float32), (self.height, self.width))

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion, for the adaptive DVS sampling.

        Returns
        -------
        float
            The edge's speed abs(speed_px_per_s) (pixels per second).
        """
        return abs(self.speed)

    def _params(self):
        return {"speed_px_per_s": self.speed, "x0": self.x0, "low": self.low, "high": self.high}


def _square_wave_mean(u: np.ndarray, size: float) -> np.ndarray:
    """Mean over [u - 1/2, u + 1/2] of the +-1 square wave that is +1 on [0, size) (period 2 size)."""

    def integral(v):  # a triangle wave: the exact antiderivative of the square wave
        return size - np.abs(np.mod(v, 2 * size) - size)

    return integral(u + 0.5) - integral(u - 0.5)


class Checkerboard(Scene):
    """A translating checkerboard of `low` and `high` squares (contrast high/low, default 2e4:1).

    The board's origin moves as (x0 + vx t, y0 + vy t). Exact rendering: the checkerboard is (1 + a(x) a(y)) / 2 for
    a square wave a, and the pixel-box mean of a separable product is the product of the 1-D means (closed form).

    Parameters
    ----------
    height, width : int
        Image size (pixels), >= 1.
    duration_us : int
        Duration (us), >= 1.
    square_px : float, optional
        Side of a square (pixels, > 0; default 8).
    velocity_px_per_s : tuple of float, optional
        (vx, vy) of the board (pixels per second; default (40, 0)).
    low, high : float, optional
        Radiance of the dark and the bright squares (radiance units, high > low > 0; default 0.05 and 1000).
    origin : tuple of float, optional
        (x0, y0), the board's origin corner at t = 0 (pixels; default (0, 0)).
    """

    def __init__(self, height: int, width: int, duration_us: int, *, square_px: float = 8.0,
                 velocity_px_per_s: tuple[float, float] = (40.0, 0.0), low: float = 0.05, high: float = 1000.0,
                 origin: tuple[float, float] = (0.0, 0.0)):
        self._init_size(height, width, duration_us)
        self.square = positive("square_px", square_px, "Checkerboard")
        self.vx, self.vy = numbers("velocity_px_per_s", velocity_px_per_s, "Checkerboard")
        self.origin = numbers("origin", origin, "Checkerboard")
        self.low, self.high = _levels("Checkerboard", low, high)

    @property
    def contrast(self) -> float:
        return self.high / self.low

    def offset(self, t_us: float) -> tuple[float, float]:
        """Analytic position of the board's origin corner at a time.

        Parameters
        ----------
        t_us : float
            Scene time (us).

        Returns
        -------
        tuple of float
            (x, y) of the corner (pixels).
        """
        s = t_us * 1e-6
        return self.origin[0] + self.vx * s, self.origin[1] + self.vy * s

    def _render(self, t_us):
        ox, oy = self.offset(t_us)
        ax = _square_wave_mean(np.arange(self.width) - ox, self.square)
        ay = _square_wave_mean(np.arange(self.height) - oy, self.square)
        frac = 0.5 * (1.0 + ay[:, None] * ax[None, :])
        return self.low + (self.high - self.low) * frac

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion, for the adaptive DVS sampling.

        Returns
        -------
        float
            The board's speed, the norm of velocity_px_per_s (pixels per second).
        """
        return math.hypot(self.vx, self.vy)

    def _params(self):
        return {"square_px": self.square, "velocity_px_per_s": [self.vx, self.vy], "origin": list(self.origin),
                "low": self.low, "high": self.high}


class RotatingBar(Scene):
    """A bright bar (length x thickness pixels) rotating about the image centre on a dark background.

    angle(t) = angle0 + angular_speed * t, in degrees, measured from the +x axis towards +y (image rows).

    Parameters
    ----------
    height, width : int
        Image size (pixels), >= 1.
    duration_us : int
        Duration (us), >= 1.
    angular_speed_deg_s : float, optional
        Angular speed (degrees per second, either sign; default 90).
    length_px, thickness_px : float, optional
        The bar's size (pixels, > 0; default 0.8 min(height, width) and 4).
    angle0_deg : float, optional
        Angle at t = 0 (degrees; default 0).
    low, high : float, optional
        Radiance of the background and of the bar (radiance units, high > low > 0; default 0.05 and 1).
    """

    def __init__(self, height: int, width: int, duration_us: int, *, angular_speed_deg_s: float = 90.0,
                 length_px: float | None = None, thickness_px: float = 4.0, angle0_deg: float = 0.0,
                 low: float = 0.05, high: float = 1.0):
        self._init_size(height, width, duration_us)
        self.omega = number("angular_speed_deg_s", angular_speed_deg_s, "RotatingBar")
        self.length = 0.8 * min(height, width) if length_px is None else positive("length_px", length_px, "RotatingBar")
        self.thickness = positive("thickness_px", thickness_px, "RotatingBar")
        self.angle0 = number("angle0_deg", angle0_deg, "RotatingBar")
        self.low, self.high = _levels("RotatingBar", low, high)
        self.centre = ((width - 1) / 2, (height - 1) / 2)

    def angle_deg(self, t_us: float) -> float:
        """Analytic bar angle at a time.

        Parameters
        ----------
        t_us : float
            Scene time (us).

        Returns
        -------
        float
            angle(t_us) (degrees, not wrapped).
        """
        return self.angle0 + self.omega * t_us * 1e-6

    def _render(self, t_us):
        a = math.radians(self.angle_deg(t_us))
        x, y = _pixel_grid(self.height, self.width)
        dx, dy = x - self.centre[0], y - self.centre[1]
        along = dx * math.cos(a) + dy * math.sin(a)
        across = -dx * math.sin(a) + dy * math.cos(a)
        cov = _ramp(self.length / 2 - np.abs(along)) * _ramp(self.thickness / 2 - np.abs(across))
        return self.low + (self.high - self.low) * cov

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion, for the adaptive DVS sampling.

        Returns
        -------
        float
            The speed of the bar's ends, abs(angular speed) (rad/s) x length / 2 (pixels per second).
        """
        return math.radians(abs(self.omega)) * self.length / 2

    def _params(self):
        return {"angular_speed_deg_s": self.omega, "length_px": self.length, "thickness_px": self.thickness,
                "angle0_deg": self.angle0, "low": self.low, "high": self.high}


class RotatingDisk(Scene):
    """A disk of `sectors` bright sectors alternating with as many dark ones, spinning about the image centre.

    Bright sector k spans angles [angle(t) + 2k pi / sectors, angle(t) + (2k+1) pi / sectors) (radians, from +x
    towards +y); angle(t) = angle0 + angular_speed * t in degrees. Outside the disk the radiance is `background`.
    With sectors=1 the bright half-disk's centroid lies at angle(t) + 90 degrees, 4 R / (3 pi) from the centre.

    Parameters
    ----------
    height, width : int
        Image size (pixels), >= 1.
    duration_us : int
        Duration (us), >= 1.
    angular_speed_deg_s : float, optional
        Angular speed (degrees per second, either sign; default 180).
    radius_px : float, optional
        The disk's radius R (pixels, > 0; default 0.45 min(height, width)).
    sectors : int, optional
        Number of bright sectors (>= 1; default 4).
    angle0_deg : float, optional
        Angle at t = 0 (degrees; default 0).
    low, high : float, optional
        Radiance of the dark and the bright sectors (radiance units, high > low > 0; default 0.05 and 1).
    background : float, optional
        Radiance outside the disk (radiance units, > 0; default 0.2).
    """

    def __init__(self, height: int, width: int, duration_us: int, *, angular_speed_deg_s: float = 180.0,
                 radius_px: float | None = None, sectors: int = 4, angle0_deg: float = 0.0, low: float = 0.05,
                 high: float = 1.0, background: float = 0.2):
        self._init_size(height, width, duration_us)
        self.omega = number("angular_speed_deg_s", angular_speed_deg_s, "RotatingDisk")
        self.radius = (0.45 * min(height, width) if radius_px is None
                       else positive("radius_px", radius_px, "RotatingDisk"))
        self.sectors = check_int("RotatingDisk: sectors", sectors, minimum=1)
        self.angle0 = number("angle0_deg", angle0_deg, "RotatingDisk")
        self.low, self.high = _levels("RotatingDisk", low, high)
        self.background = level("background", background, "RotatingDisk")
        self.centre = ((width - 1) / 2, (height - 1) / 2)

    def angle_deg(self, t_us: float) -> float:
        """Analytic disk angle at a time.

        Parameters
        ----------
        t_us : float
            Scene time (us).

        Returns
        -------
        float
            angle(t_us) (degrees, not wrapped).
        """
        return self.angle0 + self.omega * t_us * 1e-6

    def _render(self, t_us):
        x, y = _pixel_grid(self.height, self.width)
        dx, dy = x - self.centre[0], y - self.centre[1]
        r = np.hypot(dx, dy)
        width = np.pi / self.sectors  # angular width of one sector
        u = np.mod(np.arctan2(dy, dx) - math.radians(self.angle_deg(t_us)), 2 * np.pi) / width
        # distance from the pixel centre to the nearest sector boundary ray, signed positive in a bright sector
        to_edge = np.minimum(u - np.floor(u), np.ceil(u) - u) * width
        sign = np.where(np.mod(np.floor(u), 2) == 0, 1.0, -1.0)
        bright = _ramp(sign * r * np.sin(np.minimum(to_edge, np.pi / 2)))
        disk = _ramp(self.radius - r)
        return self.background + disk * (self.low + (self.high - self.low) * bright - self.background)

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion, for the adaptive DVS sampling.

        Returns
        -------
        float
            The rim's speed, abs(angular speed) (rad/s) x radius (pixels per second).
        """
        return math.radians(abs(self.omega)) * self.radius

    def _params(self):
        return {"angular_speed_deg_s": self.omega, "radius_px": self.radius, "sectors": self.sectors,
                "angle0_deg": self.angle0, "low": self.low, "high": self.high, "background": self.background}


class FlickeringLight(Scene):
    """A static lamp (a disk) whose radiance flickers sinusoidally over a static background.

    lamp(t) = mean * (1 + depth * sin(2 pi frequency t + phase)); pixel = background + coverage * lamp(t).
    depth < 1 keeps the lamp positive. Nothing moves: max_speed_px_per_s() is 0.

    Parameters
    ----------
    height, width : int
        Image size (pixels), >= 1.
    duration_us : int
        Duration (us), >= 1.
    frequency_hz : float, optional
        Flicker frequency (Hz, > 0; default 100).
    mean : float, optional
        The lamp's mean radiance (radiance units, > 0; default 10).
    depth : float, optional
        Modulation depth, in [0, 1) (dimensionless; default 0.8).
    phase_rad : float, optional
        Phase at t = 0 (radians; default 0).
    background : float, optional
        Radiance around the lamp (radiance units, > 0; default 0.1).
    radius_px : float, optional
        The lamp's radius (pixels, > 0; default 0.25 min(height, width)).
    """

    def __init__(self, height: int, width: int, duration_us: int, *, frequency_hz: float = 100.0,
                 mean: float = 10.0, depth: float = 0.8, phase_rad: float = 0.0, background: float = 0.1,
                 radius_px: float | None = None):
        self._init_size(height, width, duration_us)
        self.frequency = positive("frequency_hz", frequency_hz, "FlickeringLight")
        self.mean = level("mean", mean, "FlickeringLight")
        self.depth = number("depth", depth, "FlickeringLight")
        if not 0 <= self.depth < 1:
            raise InvalidParameterError(f"FlickeringLight: depth must be in [0, 1), got {depth!r}")
        self.phase = number("phase_rad", phase_rad, "FlickeringLight")
        self.background = level("background", background, "FlickeringLight")
        self.radius = (0.25 * min(height, width) if radius_px is None
                       else positive("radius_px", radius_px, "FlickeringLight"))
        centre = ((width - 1) / 2, (height - 1) / 2)
        self._coverage = _disk_coverage(height, width, centre, self.radius).astype(np.float32)

    @property
    def period_us(self) -> float:
        return 1e6 / self.frequency

    def max_frequency_hz(self) -> float:
        """The highest temporal frequency of the radiance, for the adaptive DVS sampling.

        Returns
        -------
        float
            The lamp's flicker frequency (Hz); 0 at depth 0.
        """
        return self.frequency if self.depth > 0 else 0.0

    def lamp_intensity(self, t_us: float) -> float:
        """Analytic lamp radiance at a time.

        Parameters
        ----------
        t_us : float
            Scene time (us).

        Returns
        -------
        float
            lamp(t_us) (radiance units).
        """
        return self.mean * (1 + self.depth * math.sin(2 * math.pi * self.frequency * t_us * 1e-6 + self.phase))

    def _render(self, t_us):
        return self.background + self._coverage * np.float32(self.lamp_intensity(t_us))

    def _params(self):
        return {"frequency_hz": self.frequency, "mean": self.mean, "depth": self.depth, "phase_rad": self.phase,
                "background": self.background, "radius_px": self.radius}


class SunPatch(Scene):
    """A very bright "sun" disk moving in a straight line over a dark, gently textured background.

    background(x, y) = dark * (1 + 0.5 sin(2 pi x / 23) sin(2 pi y / 17)); pixel = background + coverage * sun.
    centre(t) = start + velocity * t (pixels). The dynamic range sun / dark is 1e4:1 by default.

    Parameters
    ----------
    height, width : int
        Image size (pixels), >= 1.
    duration_us : int
        Duration (us), >= 1.
    sun : float, optional
        The sun's radiance (radiance units, > 0; default 1000).
    dark : float, optional
        The background's mean radiance (radiance units, > 0; default 0.1).
    radius_px : float, optional
        The sun's radius (pixels, > 0; default 0.08 min(height, width)).
    start : tuple of float, optional
        (x, y) centre at t = 0 (pixels; default a third of the width and of the height).
    velocity_px_per_s : tuple of float, optional
        (vx, vy) (pixels per second; default (30, 10)).
    """

    def __init__(self, height: int, width: int, duration_us: int, *, sun: float = 1000.0, dark: float = 0.1,
                 radius_px: float | None = None, start: tuple[float, float] | None = None,
                 velocity_px_per_s: tuple[float, float] = (30.0, 10.0)):
        self._init_size(height, width, duration_us)
        self.sun = level("sun", sun, "SunPatch")
        self.dark = level("dark", dark, "SunPatch")
        self.radius = 0.08 * min(height, width) if radius_px is None else positive("radius_px", radius_px, "SunPatch")
        self.start = (self.width / 3, self.height / 3) if start is None else numbers("start", start, "SunPatch")
        self.vx, self.vy = numbers("velocity_px_per_s", velocity_px_per_s, "SunPatch")
        yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
        self._background = self.dark * (1 + 0.5 * np.sin(2 * np.pi * xx / 23) * np.sin(2 * np.pi * yy / 17))

    def centre(self, t_us: float) -> tuple[float, float]:
        """Analytic centre of the sun at a time.

        Parameters
        ----------
        t_us : float
            Scene time (us).

        Returns
        -------
        tuple of float
            (x, y) of the centre (pixels).
        """
        s = t_us * 1e-6
        return self.start[0] + self.vx * s, self.start[1] + self.vy * s

    def _render(self, t_us):
        cov = _disk_coverage(self.height, self.width, self.centre(t_us), self.radius)
        return self._background + self.sun * cov

    def max_speed_px_per_s(self) -> float:
        """The fastest image motion, for the adaptive DVS sampling.

        Returns
        -------
        float
            The sun's speed, the norm of velocity_px_per_s (pixels per second).
        """
        return math.hypot(self.vx, self.vy)

    def _params(self):
        return {"sun": self.sun, "dark": self.dark, "radius_px": self.radius, "start": list(self.start),
                "velocity_px_per_s": [self.vx, self.vy]}
