"""A thin pybullet wrapper: one physics client per env, bodies addressed by name.

Why a wrapper: pybullet's API is global-state flavoured and integer-addressed. Every env owns one
`BulletClient` (never the module-level client), so several envs can live in one process, and the
rest of the code speaks about bodies by name ("herb", "table", "soda_can_0").

The world is rebuilt with `resetSimulation` on every episode: it frees collision shapes (unlike
`removeBody`, which leaks them) and makes an episode independent of the episodes before it, which
is what bit-identical rollouts need.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from clutter_gym.model.objects import ObjectSpec
from clutter_gym.model.world import Box
from clutter_gym.sim.bullet import BulletClient, native_stdout_muted, pybullet

TIMESTEP = 1.0 / 240.0
Transform = tuple[tuple[float, ...], tuple[float, ...]]
"""A pybullet (position, quaternion) pair."""
GRAVITY = -9.81


@dataclass(frozen=True)
class Camera:
    """A pinhole camera at `eye` looking at `target`; the default looks over HERB's right
    shoulder at the workspace, so the hand is never hidden behind clutter."""

    eye: tuple[float, float, float] = (0.3, -1.45, 1.6)
    target: tuple[float, float, float] = (0.95, -0.2, 0.85)
    width: int = 480
    height: int = 360
    fov: float = 50.0


class _Client(BulletClient):
    """A `BulletClient` that binds each pybullet function to its client once: the stock one
    builds a new `functools.partial` on every call (~1.5 us, about 20 calls per env step)."""

    def __getattr__(self, name: str) -> Any:
        attribute = super().__getattr__(name)
        if name != "disconnect":  # the stock client marks itself closed on this lookup
            setattr(self, name, attribute)
        return attribute


class Simulator:
    """One pybullet world: builds bodies by name, steps, renders, answers contact queries."""

    def __init__(self, timestep: float = TIMESTEP, solver_iterations: int = 20) -> None:
        with native_stdout_muted():
            self._client: BulletClient | None = _Client(connection_mode=pybullet.DIRECT)
        self.timestep = timestep
        self.solver_iterations = solver_iterations
        self._bodies: dict[str, int] = {}
        self._inertial: dict[str, Transform] = {}
        self._to_base: dict[str, Transform] = {}
        self.clear()

    @property
    def client(self) -> BulletClient:
        if self._client is None:
            raise RuntimeError("the simulator is closed")
        return self._client

    def clear(self) -> None:
        """Empty the world and reset every physics parameter."""
        c = self.client
        c.resetSimulation()
        c.setPhysicsEngineParameter(
            fixedTimeStep=self.timestep,
            numSolverIterations=self.solver_iterations,
            deterministicOverlappingPairs=1,
        )
        c.setGravity(0.0, 0.0, GRAVITY)
        self._bodies = {}
        self._inertial = {}
        self._to_base = {}

    def close(self) -> None:
        if self._client is not None:
            self._client.disconnect()
            self._client = None

    # --- bodies -----------------------------------------------------------------------------
    def body(self, name: str) -> int:
        try:
            return self._bodies[name]
        except KeyError:
            raise KeyError(f"no body named {name!r}; bodies: {sorted(self._bodies)}") from None

    def load_urdf(
        self, name: str, path: Path, fixed_base: bool = True, merge_fixed_links: bool = False
    ) -> int:
        """A URDF body; with `merge_fixed_links`, links on fixed joints fold into their parents
        (the same rigid bodies in fewer links; pybullet then prints its merges on stdout)."""
        flags = pybullet.URDF_USE_INERTIA_FROM_FILE
        if merge_fixed_links:
            flags |= pybullet.URDF_MERGE_FIXED_LINKS
        with native_stdout_muted():
            body_id = self.client.loadURDF(str(path), useFixedBase=fixed_base, flags=flags)
        self._register(name, body_id)
        return body_id

    def add_static_boxes(self, name: str, boxes: Sequence[Box]) -> int:
        """One static multi-body made of axis-aligned boxes (a table, a shelf)."""
        c = self.client
        half = [list(b.half_extents) for b in boxes]
        centres = [list(b.centre) for b in boxes]
        col = c.createCollisionShapeArray(
            shapeTypes=[pybullet.GEOM_BOX] * len(boxes),
            halfExtents=half,
            collisionFramePositions=centres,
        )
        vis = c.createVisualShapeArray(
            shapeTypes=[pybullet.GEOM_BOX] * len(boxes),
            halfExtents=half,
            visualFramePositions=centres,
            rgbaColors=[list(b.rgba) for b in boxes],
        )
        body_id = c.createMultiBody(0.0, col, vis, [0.0, 0.0, 0.0])
        self._register(name, body_id)
        return body_id

    def add_object(
        self, name: str, spec: ObjectSpec, pose: Sequence[float], surface_z: float
    ) -> int:
        """A movable object standing upright at planar pose (x, y, theta) on a surface."""
        c = self.client
        prims = spec.primitives
        frames = [list(p.xyz) for p in prims]
        shapes = {
            "shapeTypes": [_shape_type(p.kind) for p in prims],
            "halfExtents": [_half_extents(p.kind, p.dims) for p in prims],
            "radii": [p.dims[0] if p.kind == "cylinder" else 0.0 for p in prims],
            "lengths": [p.dims[1] if p.kind == "cylinder" else 0.0 for p in prims],
        }
        col = c.createCollisionShapeArray(**shapes, collisionFramePositions=frames)
        vis = c.createVisualShapeArray(
            **shapes, visualFramePositions=frames, rgbaColors=[list(spec.rgba)] * len(prims)
        )
        x, y, theta = (float(v) for v in pose)
        body_id = c.createMultiBody(
            baseMass=spec.mass,
            baseCollisionShapeIndex=col,
            baseVisualShapeIndex=vis,
            basePosition=[x, y, surface_z],
            baseOrientation=c.getQuaternionFromEuler([0.0, 0.0, theta]),
            baseInertialFramePosition=[0.0, 0.0, spec.com_height],
        )
        c.changeDynamics(
            body_id,
            -1,
            lateralFriction=spec.lateral_friction,
            spinningFriction=spec.spinning_friction,
            rollingFriction=spec.rolling_friction,
            # A resting object sleeps (leaves the solver) until something touches it: resting
            # clutter otherwise costs ~40 us per physics step (measured, high clutter).
            activationState=pybullet.ACTIVATION_STATE_ENABLE_SLEEPING,
        )
        self._register(name, body_id)
        return body_id

    def _register(self, name: str, body_id: int) -> None:
        self._bodies[name] = body_id
        info = self.client.getDynamicsInfo(body_id, -1)
        self._inertial[name] = (info[3], info[4])
        self._to_base[name] = self.client.invertTransform(info[3], info[4])

    def sleep(self, name: str) -> None:
        """Put a resting body to sleep now rather than after Bullet's 2 s of rest; contact with
        a moving body wakes it."""
        self.client.changeDynamics(
            self.body(name), -1, activationState=pybullet.ACTIVATION_STATE_SLEEP
        )

    # --- state ------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        step = self.client.stepSimulation
        for _ in range(n):
            step()

    def base_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (3,) and quaternion (x, y, z, w) of a body's base frame.

        pybullet reports the base's centre of mass; this converts to the body's own frame
        (for objects: the centre of the base, on the surface).
        """
        pos, quat = self._base_pose(name)
        return np.array(pos), np.array(quat)

    def base_poses(self, names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """`base_pose` of several bodies: positions (N, 3) and quaternions (N, 4)."""
        poses = [self._base_pose(name) for name in names]
        return np.array([p for p, _ in poses]), np.array([q for _, q in poses])

    def _base_pose(self, name: str) -> Transform:
        c = self.client
        com_pos, com_quat = c.getBasePositionAndOrientation(self.body(name))
        return c.multiplyTransforms(com_pos, com_quat, *self._to_base[name])

    def set_base_pose(self, name: str, position: Sequence[float], quat: Sequence[float]) -> None:
        """Teleport a body's base frame (tests and resets only, never during an episode)."""
        c = self.client
        com_pos, com_quat = c.multiplyTransforms(position, quat, *self._inertial[name])
        c.resetBasePositionAndOrientation(self.body(name), com_pos, com_quat)

    def contacts(self, a: str, b: str, link_a: int | None = None) -> list[tuple]:
        """pybullet contact points between two named bodies (optionally one link of `a`)."""
        if link_a is None:
            return list(self.client.getContactPoints(self.body(a), self.body(b)))
        return list(self.client.getContactPoints(self.body(a), self.body(b), linkIndexA=link_a))

    def render(self, camera: Camera) -> np.ndarray:
        """An RGB frame (H, W, 3) uint8 from the CPU renderer: works headless."""
        c = self.client
        view = c.computeViewMatrix(list(camera.eye), list(camera.target), [0.0, 0.0, 1.0])
        proj = c.computeProjectionMatrixFOV(
            fov=camera.fov, aspect=camera.width / camera.height, nearVal=0.05, farVal=10.0
        )
        _, _, rgba, _, _ = c.getCameraImage(
            camera.width,
            camera.height,
            viewMatrix=view,
            projectionMatrix=proj,
            renderer=pybullet.ER_TINY_RENDERER,
        )
        frame = np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)
        return frame[:, :, :3].copy()


def _shape_type(shape: str) -> int:
    return pybullet.GEOM_CYLINDER if shape == "cylinder" else pybullet.GEOM_BOX


def _half_extents(shape: str, size: tuple[float, ...]) -> list[float]:
    if shape == "box":
        return [s / 2.0 for s in size]
    return [0.0, 0.0, 0.0]
