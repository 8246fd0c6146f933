"""The shipped demonstrator component: tool surfaces, cavity thickness and trim line.

The paper's component (Figs. 13-16) is not published, so this is a generic part of our
own in its spirit: a dished panel, doubly curved, with a crushed flange and a crushed
pad, formed from a flat 720 x 590 mm blank. Everything is a smooth function of (x, y),
symmetric about x = 0 and y = 0 (the case models a quarter), and every dimension is a
field of :class:`Component`, checked when built.

- **Lower tool** (fixed; its working face at z = ``lower_z(x, y)``): flat at z = 0
  outside the dish rim (a rounded rectangle in plan); inside, a wall of plan width
  ``wall`` falls by ``depth`` (quintic smoothstep, concave at its foot, convex at its
  top), and the bottom sags by a further ``sag`` towards the centre (an elliptic
  paraboloid), so the bottom is doubly curved.
- **Cavity**: the core thickness the closed tools leave, ``core_thickness(x, y)``,
  measured along the lower face's normal: the full ``core`` in the dish, ramping to
  ``flange_core`` outside the rim and to ``pad_core`` in two round pads at
  (+-``pad_x``, 0) on the dish bottom. The skins (``skin`` in total per face) add to it.
- **Upper tool**: its working face is the lower one offset along the normal by the
  cavity; the case opens it by its stroke and closes it along -z.
- **Trim line**: the finished part's outline, a rounded rectangle of ``trim`` x
  ``trim``, corner radius ``trim_radius``, on the flange.

Units mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from forming.errors import InputError

COPIES = ((1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0))
"""Sign flips that mirror the modelled quarter (x >= 0, y >= 0) into the whole part."""


def rounded_rectangle_distance(x, y, half_x: float, half_y: float, radius: float):
    """Signed distance in plan to a rounded rectangle centred at the origin (negative inside)."""
    qx = np.abs(x) - (half_x - radius)
    qy = np.abs(y) - (half_y - radius)
    outside = np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0))
    return outside + np.minimum(np.maximum(qx, qy), 0.0) - radius


def smoothstep(s):
    """Quintic ramp 0 -> 1 over s in [0, 1] with zero first and second derivatives at both ends."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


@dataclass(frozen=True)
class Component:
    """Dimensions of the shipped component (all mm; see the module docstring).

    Attributes:
        blank: Flat blank, length along x and y.
        trim: Finished part's outline (trim line), length along x and y.
        trim_radius: Corner radius of the trim line in plan.
        rim: Dish rim in plan, length along x and y.
        rim_radius: Corner radius of the rim in plan (above ``wall``, so that the dish
            bottom keeps rounded corners: ``rim_radius - wall``).
        wall: Plan width of the dish wall.
        depth: Depth of the dish at its wall's foot.
        sag: Further depth at the centre (doubly curved bottom).
        core: Uncrushed core thickness.
        skin: Skin thickness per face (plies x ply thickness).
        flange_core: Core thickness the closed tools leave on the flange.
        flange_start: Distance outside the rim where the flange's crushing starts.
        flange_ramp: Plan width over which the flange's crushing ramps in.
        pad_core: Core thickness in the pads.
        pad_x: Pad centres at (+-pad_x, 0).
        pad_radius: Radius of the pads' fully crushed part.
        pad_ramp: Radial width over which a pad's crushing ramps in.
        margin: The tools reach this far beyond the blank's corners.
        tool_height: Thickness of each tool's solid below (above) its working face.
    """

    blank: tuple[float, float] = (720.0, 590.0)
    trim: tuple[float, float] = (600.0, 480.0)
    trim_radius: float = 60.0
    rim: tuple[float, float] = (460.0, 340.0)
    rim_radius: float = 100.0
    wall: float = 85.0
    depth: float = 30.0
    sag: float = 8.0
    core: float = 20.0
    skin: float = 0.4
    flange_core: float = 7.0
    flange_start: float = 5.0
    flange_ramp: float = 45.0
    pad_core: float = 8.0
    pad_x: float = 75.0
    pad_radius: float = 15.0
    pad_ramp: float = 40.0
    margin: float = 60.0
    tool_height: float = 60.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            for x in (v if isinstance(v, tuple) else (v,)):
                if not (isinstance(x, (int, float)) and math.isfinite(x)):
                    raise InputError(f"component.{f.name}", f"must be finite numbers, got {v!r}")
                if x <= 0 and f.name != "skin":
                    raise InputError(f"component.{f.name}", f"must be positive, got {v!r}")
        if self.skin < 0:
            raise InputError("component.skin", f"must be >= 0, got {self.skin!r}")
        for a, b, why in ((self.rim, self.trim, "the rim lies inside the trim line"),
                          (self.trim, self.blank, "the trim line lies inside the blank")):
            if a[0] >= b[0] or a[1] >= b[1]:
                raise InputError("component", f"{why}: {a} against {b}")
        if not self.wall < self.rim_radius <= min(self.rim) / 2:
            raise InputError("component.rim_radius", f"must exceed the wall ({self.wall:g}) "
                             f"and be at most half the rim's width, got {self.rim_radius!r}")
        if not self.trim_radius <= min(self.trim) / 2:
            raise InputError("component.trim_radius", f"at most half the trim's width, got "
                             f"{self.trim_radius!r}")
        if not (self.flange_core < self.core and self.pad_core < self.core):
            raise InputError("component", "flange_core and pad_core must be below core")
        inner = (self.rim[0] / 2 - self.wall, self.rim[1] / 2 - self.wall)
        if self.pad_x + self.pad_radius + self.pad_ramp > inner[0] or \
                self.pad_radius + self.pad_ramp > inner[1]:
            raise InputError("component.pad_x", "the pads must lie on the dish bottom "
                             f"(half {inner[0]:g} x {inner[1]:g} mm)")

    @property
    def sag_axes(self) -> tuple[float, float]:
        """Semi-axes of the bottom's paraboloid (1.3 x the rim's: positive over the dish)."""
        return 0.65 * self.rim[0], 0.65 * self.rim[1]

    def rim_distance(self, x, y):
        """Signed plan distance to the dish rim (negative inside the dish)."""
        return rounded_rectangle_distance(x, y, self.rim[0] / 2, self.rim[1] / 2,
                                          self.rim_radius)

    def trim_distance(self, x, y):
        """Signed plan distance to the trim line (negative inside the part)."""
        return rounded_rectangle_distance(x, y, self.trim[0] / 2, self.trim[1] / 2,
                                          self.trim_radius)

    def lower_z(self, x, y):
        """Z of the lower tool's working face [mm]."""
        a, b = self.sag_axes
        bowl = self.depth + self.sag * (1.0 - (x / a) ** 2 - (y / b) ** 2)
        return -smoothstep(-self.rim_distance(x, y) / self.wall) * bowl

    def lower_normal(self, x, y, h: float = 1e-3):
        """Upward unit normal of the lower working face at (x, y), shape (..., 3)."""
        zx = (self.lower_z(x + h, y) - self.lower_z(x - h, y)) / (2 * h)
        zy = (self.lower_z(x, y + h) - self.lower_z(x, y - h)) / (2 * h)
        n = np.stack([-zx, -zy, np.ones_like(zx)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def core_thickness(self, x, y):
        """Core thickness the closed tools leave, along the lower face's normal [mm]."""
        flange = smoothstep((self.rim_distance(x, y) - self.flange_start) / self.flange_ramp)
        rho = np.hypot(np.abs(x) - self.pad_x, y)
        pad = smoothstep((self.pad_radius + self.pad_ramp - rho) / self.pad_ramp)
        return (self.core - (self.core - self.flange_core) * flange
                - (self.core - self.pad_core) * pad)

    def upper_points(self, x, y) -> np.ndarray:
        """Points of the upper tool's working face (closed tools) over the (x, y) grid."""
        z = self.lower_z(x, y)
        gap = self.core_thickness(x, y) + 2 * self.skin
        return np.stack([x, y, z], axis=-1) + gap[..., None] * self.lower_normal(x, y)

    def upper_z(self, x, y, iterations: int = 50):
        """Z of the upper tool's working face (closed tools) above the plan point (x, y).

        The offset face as a height field: the lower-face point whose offset lands on
        (x, y) is found by fixed-point iteration (the offset moves points in plan by less
        than the cavity, well below the faces' radii of curvature).
        """
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        u, v = x.copy(), y.copy()
        for _ in range(iterations):
            p = self.upper_points(u, v)
            du, dv = x - p[..., 0], y - p[..., 1]
            u, v = u + du, v + dv
            if max(float(np.abs(du).max(initial=0)), float(np.abs(dv).max(initial=0))) < 1e-9:
                break
        return self.upper_points(u, v)[..., 2]

    def tool_extent(self) -> tuple[float, float]:
        """Half lengths of the tools in plan (the blank's plus the margin)."""
        return self.blank[0] / 2 + self.margin, self.blank[1] / 2 + self.margin

    def trim_points(self, n_corner: int = 16) -> np.ndarray:
        """The trim line as a closed polygon (counter-clockwise, not repeating its start)."""
        hx, hy, r = self.trim[0] / 2, self.trim[1] / 2, self.trim_radius
        pts = []
        for k, (cx, cy) in enumerate(((hx - r, hy - r), (-hx + r, hy - r),
                                      (-hx + r, -hy + r), (hx - r, -hy + r))):
            t = np.linspace(0.0, 0.5 * np.pi, n_corner + 1) + k * 0.5 * np.pi
            pts.append(np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], axis=1))
        return np.vstack(pts)

    def key(self) -> str:
        """A short name that changes with every dimension (generated files' folder)."""
        import hashlib

        text = repr(tuple(getattr(self, f.name) for f in fields(self)))
        return "demonstrator-" + hashlib.sha1(text.encode()).hexdigest()[:10]
