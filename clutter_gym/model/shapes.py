"""Solid primitives: the one description of geometry that the URDF, pybullet, python-fcl,
trimesh and the planar pushing model all derive from (robot links and objects alike)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import trimesh

from clutter_gym.model.transforms import Vec3, transform

ShapeKind = Literal["box", "cylinder", "sphere"]
_DIMS = {"box": 3, "cylinder": 2, "sphere": 1}
CYLINDER_SECTIONS = 64
"""Facets of a cylinder's mesh: fine enough that its volume is within 0.2% of analytic."""


@dataclass(frozen=True)
class Shape:
    """A box (``dims`` = full sizes), a cylinder (radius, length along its z) or a sphere
    (radius,), with its pose ``xyz``/``rpy`` in its parent's frame (a link's or an object's)."""

    kind: ShapeKind
    dims: tuple[float, ...]
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.kind not in _DIMS:
            raise ValueError(f"Shape.kind: got {self.kind!r}; expected one of {list(_DIMS)}")
        expected = _DIMS[self.kind]
        if len(self.dims) != expected or not all(d > 0 for d in self.dims):
            raise ValueError(
                f"Shape.dims: got {self.dims!r}; a {self.kind} needs {expected} positive values"
            )

    @property
    def local(self) -> np.ndarray:
        """4x4 pose in the parent's frame."""
        return transform(self.xyz, self.rpy)

    @property
    def height(self) -> float:
        """Extent along the parent's z for an upright shape (no roll or pitch)."""
        if self.kind == "box":
            return self.dims[2]
        return self.dims[1] if self.kind == "cylinder" else 2.0 * self.dims[0]

    @property
    def half_xy(self) -> tuple[float, float]:
        """Half extents of an upright shape's planar outline, along the parent's x and y."""
        if self.kind == "box":
            return self.dims[0] / 2, self.dims[1] / 2
        return self.dims[0], self.dims[0]

    @property
    def volume(self) -> float:
        if self.kind == "box":
            return self.dims[0] * self.dims[1] * self.dims[2]
        if self.kind == "cylinder":
            return math.pi * self.dims[0] ** 2 * self.dims[1]
        return 4.0 / 3.0 * math.pi * self.dims[0] ** 3

    def principal_inertia(self, mass: float) -> Vec3:
        """Solid-body principal moments about the shape's own centre and axes."""
        if self.kind == "box":
            x, y, z = self.dims
            return (
                mass * (y * y + z * z) / 12,
                mass * (x * x + z * z) / 12,
                mass * (x * x + y * y) / 12,
            )
        if self.kind == "cylinder":
            r, h = self.dims
            side = mass * (3 * r * r + h * h) / 12
            return (side, side, mass * r * r / 2)
        i = 0.4 * mass * self.dims[0] ** 2
        return (i, i, i)

    def mesh(self) -> trimesh.Trimesh:
        """Watertight mesh in the parent's frame."""
        if self.kind == "box":
            mesh = trimesh.creation.box(extents=self.dims)
        elif self.kind == "cylinder":
            mesh = trimesh.creation.cylinder(
                radius=self.dims[0], height=self.dims[1], sections=CYLINDER_SECTIONS
            )
        else:
            mesh = trimesh.creation.icosphere(radius=self.dims[0])
        mesh.apply_transform(self.local)
        return mesh
