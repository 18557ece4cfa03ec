"""Scenes: which objects stand where, which one to retrieve, and how noisy perception is.

A scene is stored as JSON (format ``clutter-gym-scene/1``)::

    {
      "format": "clutter-gym-scene/1",
      "surface": "table",
      "objects": [
        {"name": "can", "kind": "soda_can", "pose": [0.85, -0.20, 0.0]},
        {"name": "box", "kind": "large_box", "pose": [0.65, -0.20, 1.5708]}
      ],
      "goal": {"object": "can", "region": {"x": [0.45, 1.19], "y": [-1.125, 0.725]},
               "success": "lift"},
      "noise": "sigma2"
    }

* ``surface``: ``"table"`` or ``"shelf"`` (see ``clutter_gym.model.world``).
* ``objects``: 1 to ``MAX_OBJECTS`` objects with unique names (printable, 1 to
  ``MAX_NAME_LENGTH`` characters); ``kind`` is a key of
  ``clutter_gym.model.objects.OBJECTS``; ``pose`` is ``[x, y, theta]`` of the object's base
  centre on the surface top, in the robot's base frame (metres, radians).
* ``goal.object``: the name of the (graspable) object to retrieve.  ``goal.region`` (optional,
  default: the surface's ``default_goal_region``) is where the object must end up: a rectangle
  of non-zero area that overlaps the surface top (``Surface.bounds``).  ``goal.success``
  (optional, default: the surface's) is ``"lift"`` (held above the surface inside the region)
  or ``"region"`` (brought into the region, e.g. the front of the shelf); for ``"region"`` the
  goal object must start outside the region, or the task would be solved at reset.
* ``noise`` (optional, default ``"sigma2"``): the pose uncertainty of perception, either a name
  of ``NOISE_LEVELS`` or ``{"xy": sigma_xy, "theta": sigma_theta}``, the standard deviations
  of Gaussian noise on the detected poses: sigma_xy in [0, 1] m and sigma_theta in [0, pi] rad
  (``MAX_SIGMA``), beyond which perception is meaningless and observations lose precision.
* ``description`` (optional): free text, e.g. which sentence of the paper a figure's placements
  follow.

Loading validates everything: every error is a ``ValueError`` whose message starts with the
JSON path of the offending field (e.g. ``objects[2].pose``) and says what was found and what
is allowed; values are shown abbreviated, so hostile input (huge numbers, deep nesting,
control characters) cannot flood or garble the message.  Beyond types, scenes whose objects
interpenetrate or whose footprints leave the surface are rejected, since the simulator would
resolve them by launching objects.

``generate_scene`` draws random scenes at the paper's three clutter levels (§3.1.2); the ten
fixed scenes per level of ``paper_suite`` are committed under ``scenes/paper`` and regenerated
by ``python -m clutter_gym.model.scene``.  The paper evaluates each scene at every noise level, e.g.
``dataclasses.replace(scene, noise="sigma3")``.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from clutter_gym.model.collision import penetration_depth
from clutter_gym.model.fields import allowed, invalid, mapping, numbers, shown, string
from clutter_gym.model.files import atomic_write_text
from clutter_gym.model.noise import DEFAULT_NOISE, NOISE_FORMS, resolve_noise
from clutter_gym.model.objects import OBJECTS, ObjectSpec, Pose, footprint_gap, get_object
from clutter_gym.model.transforms import rotation_2d
from clutter_gym.model.world import SURFACES, Region, Surface

SCENE_FORMAT = "clutter-gym-scene/1"
MAX_OBJECTS = 8
MAX_NAME_LENGTH = 64
Level = Literal["none", "medium", "high"]
LEVELS: tuple[Level, ...] = ("none", "medium", "high")
Success = Literal["lift", "region"]
SUCCESS_MODES: tuple[Success, ...] = ("lift", "region")

PENETRATION_TOLERANCE = 1e-4
"""Interpenetration (m) tolerated, since fcl reports touching shapes as colliding."""

MEDIUM_MIN_GAP = 0.10
"""Medium clutter: every pair of footprints is at least this far apart (m)."""
HIGH_GAP = (0.02, 0.05)
"""High clutter: each object is within this footprint-gap range (m) of a neighbour, and no
two footprints are closer than its lower end."""
SUPPORT_MARGIN = 0.02
"""Generated footprints stay this far inside the support's edges or walls (m)."""
POSE_DECIMALS = 4
"""Generated poses are rounded (0.1 mm, 0.1 mrad) so the committed JSON stays readable."""

SCENES_DIR = Path(__file__).parents[1] / "scenes"
"""The scenes shipped with the package: the demo, the paper's figures and suites."""
PAPER_SUITE_DIR = SCENES_DIR / "paper"
PAPER_SUITE_SIZE = 10
PAPER_SUITE_SEED = 0
"""The suites are the generator's first seeds (0-9): never chosen by any planner's outcome."""

_OBJECT_COUNTS: dict[str, tuple[int, int]] = {"none": (1, 1), "medium": (2, 3), "high": (3, 4)}
GOAL_KINDS = tuple(kind for kind, spec in OBJECTS.items() if spec.graspable and spec.liftable)
"""Kinds a generated scene's goal can be: graspable and liftable."""
_CLUTTER_WEIGHTS: dict[str, float] = {
    "soda_can": 3.0,
    "juice_bottle": 3.0,
    "poptart_box": 3.0,
    "large_box": 1.0,
    "dumbbell": 1.0,
}
"""Clutter kind frequencies: the large box and dumbbell are rarer, as in the paper's scenes."""
_SCENE_ATTEMPTS = 200
_PLACEMENT_ATTEMPTS = 100
_BISECTION_STEPS = 30


def _surface(name: object, path: str) -> Surface:
    if not isinstance(name, str) or name not in SURFACES:
        raise invalid(path, name, allowed(SURFACES))
    return SURFACES[name]


@dataclass(frozen=True)
class ObjectPlacement:
    """A named instance of an object kind at a planar pose on the scene's surface."""

    name: str
    kind: str
    pose: Pose

    @property
    def spec(self) -> ObjectSpec:
        return get_object(self.kind)


@dataclass(frozen=True)
class GoalSpec:
    """Which object to retrieve and where it must end up (``region`` as x and y ranges)."""

    object: str
    region: Region
    success: Success


@dataclass(frozen=True)
class Scene:
    """A validated scene: constructing one checks it, so every ``Scene`` is simulable."""

    surface: str
    objects: tuple[ObjectPlacement, ...]
    goal: GoalSpec
    noise: str | tuple[float, float] = DEFAULT_NOISE
    description: str = ""
    """Free text, e.g. which sentence of the paper each placement of a figure follows."""

    def __post_init__(self) -> None:
        _validate(self)
        if not isinstance(self.noise, str):  # e.g. a list or mapping: store the canonical pair
            object.__setattr__(self, "noise", resolve_noise(self.noise))

    @property
    def noise_sigma(self) -> tuple[float, float]:
        """Perception noise ``(sigma_xy, sigma_theta)`` in metres and radians."""
        return resolve_noise(self.noise)

    @property
    def goal_placement(self) -> ObjectPlacement:
        return next(o for o in self.objects if o.name == self.goal.object)


def _validate(scene: Scene) -> None:
    surface = _surface(scene.surface, "surface")
    _validate_objects(scene.objects)
    _validate_goal(scene, surface)
    resolve_noise(scene.noise)
    _validate_support(scene.objects, surface)
    _validate_interpenetration(scene.objects, surface)
    _validate_unsolved(scene)


def _validate_objects(objects: tuple[ObjectPlacement, ...]) -> None:
    if not isinstance(objects, tuple) or not all(isinstance(o, ObjectPlacement) for o in objects):
        raise invalid("objects", objects, "a tuple of ObjectPlacement")
    if not 1 <= len(objects) <= MAX_OBJECTS:
        raise ValueError(f"objects: got {len(objects)} objects; expected 1 to {MAX_OBJECTS}")
    first_index: dict[str, int] = {}
    for i, obj in enumerate(objects):
        name = _name(obj.name, f"objects[{i}].name")
        if name in first_index:
            raise invalid(
                f"objects[{i}].name",
                name,
                f"a unique name (already used by objects[{first_index[name]}])",
            )
        first_index[name] = i
        if not isinstance(obj.kind, str) or obj.kind not in OBJECTS:
            raise invalid(f"objects[{i}].kind", obj.kind, allowed(OBJECTS))
        numbers(obj.pose, f"objects[{i}].pose", 3, "[x, y, theta] of finite numbers")


def _validate_goal(scene: Scene, surface: Surface) -> None:
    goal = scene.goal
    if not isinstance(goal, GoalSpec):
        raise invalid("goal", goal, "a GoalSpec")
    names = [o.name for o in scene.objects]
    if _name(goal.object, "goal.object") not in names:
        raise invalid("goal.object", goal.object, "the name of a scene object: " + allowed(names))
    spec = scene.goal_placement.spec
    if not spec.graspable:
        graspable = [k for k, s in OBJECTS.items() if s.graspable]
        raise invalid(
            "goal.object",
            goal.object,
            f"a graspable object, not a {spec.kind} (graspable kinds: {', '.join(graspable)})",
        )
    if not isinstance(goal.success, str) or goal.success not in SUCCESS_MODES:
        raise invalid("goal.success", goal.success, allowed(SUCCESS_MODES))
    if goal.success == "lift" and not spec.liftable:
        raise invalid(
            "goal.object",
            goal.object,
            f"a liftable object for success 'lift', not a {spec.kind} (use success 'region')",
        )
    _validate_region(goal.region, surface)


def _validate_region(region: object, surface: Surface) -> None:
    """A rectangle with area that overlaps the surface top: anywhere else the goal object
    could never be placed, so no episode could succeed."""
    if not isinstance(region, tuple | list) or len(region) != 2:
        raise invalid("goal.region", region, "(x range, y range)")
    x_min, x_max, y_min, y_max = surface.bounds
    tops = {"x": (x_min, x_max), "y": (y_min, y_max)}
    for axis, bounds in zip("xy", region, strict=True):
        path = f"goal.region.{axis}"
        low, high = numbers(bounds, path, 2, "[min, max] of finite numbers")
        if low >= high:
            raise invalid(path, bounds, "[min, max] with min < max (a region with area)")
        top_low, top_high = tops[axis]
        if high <= top_low or low >= top_high:
            raise invalid(
                path,
                bounds,
                f"a range overlapping the {surface.name} top's {axis} range "
                f"[{top_low}, {top_high}] (Surface.bounds)",
            )


def _validate_unsolved(scene: Scene) -> None:
    """A "region" goal whose object starts inside the region would succeed at reset (the
    task's test: the base centre inside the region, bounds included)."""
    (x_min, x_max), (y_min, y_max) = scene.goal.region
    x, y, _ = scene.goal_placement.pose
    if scene.goal.success == "region" and x_min <= x <= x_max and y_min <= y <= y_max:
        raise ValueError(
            f"goal.region: got x [{x_min}, {x_max}], y [{y_min}, {y_max}], but the goal object "
            f"{scene.goal.object!r} already stands inside it at ({x}, {y}), so success "
            "'region' would hold at reset; expected a region the goal object starts outside of"
        )


def _validate_support(objects: tuple[ObjectPlacement, ...], surface: Surface) -> None:
    x_min, x_max, y_min, y_max = surface.bounds
    where = "inside the shelf walls" if surface.name == "shelf" else "on the table top"
    for i, obj in enumerate(objects):
        ox_min, ox_max, oy_min, oy_max = obj.spec.footprint.aabb(obj.pose)
        if ox_min < x_min or ox_max > x_max or oy_min < y_min or oy_max > y_max:
            raise ValueError(
                f"objects[{i}].pose: {obj.name!r} ({obj.kind}) at {list(obj.pose)} has its "
                f"footprint over x [{ox_min:.3f}, {ox_max:.3f}], y [{oy_min:.3f}, {oy_max:.3f}],"
                f" which leaves the {surface.name}; footprints must stay {where}: "
                f"x [{x_min}, {x_max}], y [{y_min}, {y_max}]"
            )


def _validate_interpenetration(objects: tuple[ObjectPlacement, ...], surface: Surface) -> None:
    for j, b in enumerate(objects):
        for i, a in enumerate(objects[:j]):
            reach = a.spec.footprint.bounding_radius + b.spec.footprint.bounding_radius
            if math.dist(a.pose[:2], b.pose[:2]) > reach:
                continue
            depth = penetration_depth(a.spec, a.pose, b.spec, b.pose, surface.top_z)
            if depth > PENETRATION_TOLERANCE:
                raise ValueError(
                    f"objects[{j}].pose: {b.name!r} ({b.kind}) interpenetrates {a.name!r} "
                    f"(objects[{i}], {a.kind}) by {depth * 1000:.1f} mm; objects may touch "
                    f"but not overlap (tolerance {PENETRATION_TOLERANCE * 1000:.1f} mm)"
                )


# --- JSON ---------------------------------------------------------------------------------


def _name(value: object, path: str) -> str:
    """Names end up in messages, logs and observations: no control characters."""
    if not (isinstance(value, str) and 1 <= len(value) <= MAX_NAME_LENGTH and value.isprintable()):
        raise invalid(path, value, f"a printable string of 1 to {MAX_NAME_LENGTH} characters")
    return value


def _range(value: object, path: str) -> tuple[float, float]:
    low, high = numbers(value, path, 2, "[min, max]")
    return low, high


def scene_from_dict(d: Mapping[str, Any]) -> Scene:
    """Parse and validate a scene from its JSON form (see the module docstring)."""
    top = mapping(d, "", ("format", "surface", "objects", "goal"), ("noise", "description"))
    if not isinstance(top["format"], str) or top["format"] != SCENE_FORMAT:
        raise invalid("format", top["format"], repr(SCENE_FORMAT))
    surface = _surface(top["surface"], "surface")
    raw_objects = top["objects"]
    if not isinstance(raw_objects, list):
        raise invalid("objects", raw_objects, "a list of objects")
    objects = []
    for i, raw in enumerate(raw_objects):
        path = f"objects[{i}]"
        entry = mapping(raw, path, ("name", "kind", "pose"))
        x, y, theta = numbers(entry["pose"], f"{path}.pose", 3, "[x, y, theta]")
        objects.append(
            ObjectPlacement(
                name=_name(entry["name"], f"{path}.name"),
                kind=string(entry["kind"], f"{path}.kind"),
                pose=(x, y, theta),
            )
        )
    goal = mapping(top["goal"], "goal", ("object",), ("region", "success"))
    region = surface.default_goal_region
    if "region" in goal:
        raw_region = mapping(goal["region"], "goal.region", ("x", "y"))
        region = (
            _range(raw_region["x"], "goal.region.x"),
            _range(raw_region["y"], "goal.region.y"),
        )
    success = string(goal.get("success", surface.success), "goal.success")
    if success not in SUCCESS_MODES:
        raise invalid("goal.success", success, allowed(SUCCESS_MODES))
    raw_noise = top.get("noise", DEFAULT_NOISE)
    if not isinstance(raw_noise, str | Mapping):
        raise invalid("noise", raw_noise, NOISE_FORMS)
    sigma = resolve_noise(raw_noise, "noise")
    return Scene(
        surface=surface.name,
        objects=tuple(objects),
        goal=GoalSpec(object=_name(goal["object"], "goal.object"), region=region, success=success),
        noise=raw_noise if isinstance(raw_noise, str) else sigma,
        description=string(top.get("description", ""), "description"),
    )


def scene_to_dict(scene: Scene) -> dict[str, Any]:
    """The JSON form of a scene, with every optional field written out."""
    (x_range, y_range) = scene.goal.region
    return {
        "format": SCENE_FORMAT,
        "surface": scene.surface,
        "objects": [{"name": o.name, "kind": o.kind, "pose": list(o.pose)} for o in scene.objects],
        "goal": {
            "object": scene.goal.object,
            "region": {"x": list(x_range), "y": list(y_range)},
            "success": scene.goal.success,
        },
        "noise": (
            scene.noise
            if isinstance(scene.noise, str)
            else {"xy": scene.noise[0], "theta": scene.noise[1]}
        ),
        **({"description": scene.description} if scene.description else {}),
    }


def scene_to_json(scene: Scene) -> str:
    """Indented JSON with one line per object, so scene files diff well."""
    d = scene_to_dict(scene)
    objects = ",\n".join(f"    {json.dumps(o)}" for o in d["objects"])
    fields = [
        f'  "objects": [\n{objects}\n  ]'
        if key == "objects"
        else f"  {json.dumps(key)}: {json.dumps(value)}"
        for key, value in d.items()
    ]
    return "{\n" + ",\n".join(fields) + "\n}\n"


def load_scene(source: str | os.PathLike[str] | Mapping[str, Any]) -> Scene:
    """Load a scene from a JSON file or from its already-parsed dict.

    Every failure, including an unreadable file, is a ``ValueError`` naming the file.
    """
    if isinstance(source, Mapping):
        return scene_from_dict(source)
    name = os.fspath(source) if isinstance(source, str | os.PathLike) else None
    if not isinstance(name, str):
        raise invalid("scene", source, "the path of a JSON scene file or a scene dict")
    if not name:
        raise ValueError("scene: the file path is empty; expected the path of a JSON scene file")
    path = Path(name)
    data = _read_json(path)
    try:
        return scene_from_dict(data)
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from err


def _read_json(path: Path) -> Any:
    """The JSON value of a scene file; every failure a ValueError naming the file."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ValueError(f"{path}: is a directory, not a scene file") from None
    except UnicodeDecodeError as err:
        raise ValueError(
            f"{path}: not UTF-8 text (byte {err.start}: {err.reason}); scene files are UTF-8 JSON"
        ) from None
    except (OSError, ValueError) as err:  # ValueError: e.g. a NUL byte in the path
        raise ValueError(f"{path}: cannot be read: {err}") from err
    try:
        return json.loads(text)
    except RecursionError:
        raise ValueError(
            f"{path}: not valid JSON: nested too deeply (beyond Python's recursion limit)"
        ) from None
    except ValueError as err:  # a syntax error, or an integer too long to convert
        raise ValueError(f"{path}: not valid JSON: {err}") from err


def save_scene(scene: Scene, path: str | os.PathLike[str]) -> None:
    """Write a scene as JSON atomically, so readers never see a half-written file."""
    atomic_write_text(Path(path), scene_to_json(scene))


# --- generation ---------------------------------------------------------------------------


def _round_pose(x: float, y: float, theta: float) -> Pose:
    wrapped = (theta + math.pi) % (2 * math.pi) - math.pi
    return round(x, POSE_DECIMALS), round(y, POSE_DECIMALS), round(wrapped, POSE_DECIMALS)


def _inside(aabb: tuple[float, float, float, float], region: Region) -> bool:
    (x_min, x_max), (y_min, y_max) = region
    return x_min <= aabb[0] and aabb[1] <= x_max and y_min <= aabb[2] and aabb[3] <= y_max


def _shrunk(bounds: tuple[float, float, float, float], margin: float) -> Region:
    x_min, x_max, y_min, y_max = bounds
    return (x_min + margin, x_max - margin), (y_min + margin, y_max - margin)


def _overlaps(aabb: tuple[float, float, float, float], region: Region) -> bool:
    (x_min, x_max), (y_min, y_max) = region
    return aabb[0] < x_max and x_min < aabb[1] and aabb[2] < y_max and y_min < aabb[3]


def _uniform_pose(workspace: Region, rng: np.random.Generator) -> Pose:
    """A pose with its centre uniform in the workspace and a uniform yaw."""
    (x_min, x_max), (y_min, y_max) = workspace
    theta = rng.uniform(-math.pi, math.pi)
    return _round_pose(rng.uniform(x_min, x_max), rng.uniform(y_min, y_max), theta)


def _pose_at_gap(
    spec: ObjectSpec, anchor: ObjectPlacement, gap: float, rng: np.random.Generator
) -> Pose:
    """A pose of ``spec`` whose footprint is ``gap`` away from ``anchor``'s in a random
    direction.  The gap grows monotonically along a ray out of the anchor (it is the
    distance to a convex set), so bisection on the ray finds it."""
    direction = rng.uniform(-math.pi, math.pi)
    theta = rng.uniform(-math.pi, math.pi)
    ux, uy = math.cos(direction), math.sin(direction)
    ax, ay, _ = anchor.pose
    anchor_fp, fp = anchor.spec.footprint, spec.footprint
    low, high = 0.0, anchor_fp.bounding_radius + fp.bounding_radius + gap
    for _ in range(_BISECTION_STEPS):
        mid = (low + high) / 2
        if footprint_gap(anchor_fp, anchor.pose, fp, (ax + mid * ux, ay + mid * uy, theta)) < gap:
            low = mid
        else:
            high = mid
    return _round_pose(ax + high * ux, ay + high * uy, theta)


def _place(
    level: str,
    spec: ObjectSpec,
    placed: list[ObjectPlacement],
    world: Surface,
    avoid: Region | None,
    rng: np.random.Generator,
) -> Pose | None:
    """Sample a pose for the next object that keeps the level's clutter properties, its
    centre in the surface's workspace, its footprint on the surface and out of ``avoid``; None
    after a bounded number of attempts."""
    workspace = world.workspace
    (x0, x1), (y0, y1) = workspace
    for _ in range(_PLACEMENT_ATTEMPTS):
        if level == "high" and placed:
            anchor = placed[int(rng.integers(len(placed)))]
            pose = _pose_at_gap(spec, anchor, rng.uniform(*HIGH_GAP), rng)
        else:
            pose = _uniform_pose(workspace, rng)
        if not (x0 <= pose[0] <= x1 and y0 <= pose[1] <= y1):
            continue
        if not _inside(spec.footprint.aabb(pose), _shrunk(world.bounds, SUPPORT_MARGIN)):
            continue
        if avoid is not None and _overlaps(spec.footprint.aabb(pose), avoid):
            continue
        gaps = [footprint_gap(spec.footprint, pose, o.spec.footprint, o.pose) for o in placed]
        if not gaps:
            return pose
        if level == "medium" and min(gaps) >= MEDIUM_MIN_GAP:
            return pose
        if level == "high" and min(gaps) >= HIGH_GAP[0] and min(gaps) <= HIGH_GAP[1]:
            return pose
    return None


def generate_scene(
    level: Level,
    seed: int,
    surface: str = "table",
    noise: str | tuple[float, float] = DEFAULT_NOISE,
    goal_kind: str | None = None,
) -> Scene:
    """A random scene at one of the paper's clutter levels, reproducible from ``seed``;
    ``goal_kind`` fixes the goal object's kind (a curriculum), else it is drawn.

    The paper's levels (§3.1.2) in measurable terms: none, the goal object alone; medium,
    2-3 objects "placed apart", every footprint gap >= `MEDIUM_MIN_GAP` (0.10 m: the open
    hand fits between any two); high, 3-4 objects "placed close to each other", each within
    `HIGH_GAP` (0.02-0.05 m: a few centimetres, more than a fingertip's 1.9 cm thickness) of
    another, the goal first among them, and no two closer. The goal is a graspable, liftable
    kind; every object's centre lies in the surface's workspace (where the arm is dexterous,
    `clutter_gym.model.reachability`) and its footprint on the surface.
    """
    if level not in LEVELS:
        raise invalid("level", level, allowed(LEVELS))
    if goal_kind is not None and goal_kind not in GOAL_KINDS:
        raise invalid("goal_kind", goal_kind, allowed(GOAL_KINDS))
    world = _surface(surface, "surface")
    rng = np.random.default_rng(seed)
    kinds = list(_CLUTTER_WEIGHTS)
    weights = np.array([_CLUTTER_WEIGHTS[k] for k in kinds])
    low, high = _OBJECT_COUNTS[level]
    for _ in range(_SCENE_ATTEMPTS):
        count = int(rng.integers(low, high + 1))
        drawn = str(rng.choice(GOAL_KINDS))  # drawn even when fixed: the same stream after it
        chosen = [goal_kind or drawn]
        chosen += [str(k) for k in rng.choice(kinds, size=count - 1, p=weights / weights.sum())]
        placed: list[ObjectPlacement] = []
        counters: dict[str, int] = {}
        for kind in chosen:
            # The goal must start outside a "region" goal, or the task is solved at reset.
            avoid = world.default_goal_region if not placed and world.success == "region" else None
            pose = _place(level, get_object(kind), placed, world, avoid, rng)
            if pose is None:
                break
            name = f"{kind}_{counters.get(kind, 0)}"
            counters[kind] = counters.get(kind, 0) + 1
            placed.append(ObjectPlacement(name=name, kind=kind, pose=pose))
        else:
            goal = GoalSpec(placed[0].name, world.default_goal_region, world.success)
            return Scene(surface=world.name, objects=tuple(placed), goal=goal, noise=noise)
    raise RuntimeError(
        f"could not generate a {level!r} clutter scene on the {surface} with seed {seed} "
        f"in {_SCENE_ATTEMPTS} attempts; the workspace is too small for these objects"
    )


# --- perturbed layouts ---------------------------------------------------------------------

PERTURB_SHIFT = 0.08
"""m: a perturbed layout moves by up to this along x and y."""
PERTURB_TURN = math.radians(30.0)
"""rad: a perturbed layout turns by up to this about its centroid."""
_PERTURB_ATTEMPTS = 200


def perturbed(scene: Scene, seed: int) -> Scene:
    """The scene's layout moved rigidly (every object together) by a seeded random shift of up
    to `PERTURB_SHIFT` and turn of up to `PERTURB_TURN` about its centroid, redrawn until
    every footprint stays on the support: a variant that keeps what the layout means (which
    object stands in front of which) but none of its exact numbers."""
    rng = np.random.default_rng(seed)
    poses = np.array([o.pose for o in scene.objects], dtype=float)
    centroid = poses[:, :2].mean(axis=0)
    for _ in range(_PERTURB_ATTEMPTS):
        shift = rng.uniform(-PERTURB_SHIFT, PERTURB_SHIFT, 2)
        turn = float(rng.uniform(-PERTURB_TURN, PERTURB_TURN))
        xy = (poses[:, :2] - centroid) @ rotation_2d(turn).T + centroid + shift
        objects = tuple(
            replace(o, pose=_round_pose(float(p[0]), float(p[1]), float(p[2]) + turn))
            for o, p in zip(scene.objects, np.column_stack([xy, poses[:, 2]]), strict=True)
        )
        try:
            return replace(scene, objects=objects)
        except ValueError:  # off the support, or a region goal already met: draw again
            continue
    raise RuntimeError(
        f"no perturbed layout stays on the {scene.surface} in {_PERTURB_ATTEMPTS} draws"
    )


# --- shipped scenes ---------------------------------------------------------------------


def shipped_scene(name: str) -> Path:
    """The path of a scene shipped with the package, by its name under ``scenes/`` without
    ``.json`` (e.g. ``"demo"``, ``"figures/fig3_can_box_dumbbell"``, ``"paper/high_03"``):
    usable from any working directory, unlike a path relative to the source tree."""
    path = SCENES_DIR / f"{name}.json"
    if not path.is_file():
        raise ValueError(f"scene: {shown(name)} is not a shipped scene (see {SCENES_DIR})")
    return path


# --- paper suite --------------------------------------------------------------------------


def _suite_path(directory: Path, surface: str, level: str, index: int) -> Path:
    """Table scenes sit directly in the suite directory, shelf scenes in ``shelf/``."""
    folder = directory if surface == "table" else directory / surface
    return folder / f"{level}_{index:02d}.json"


def paper_suite(level: Level, surface: str = "table") -> list[Scene]:
    """The ten fixed scenes of a clutter level, as in the paper's Table 1."""
    if level not in LEVELS:
        raise invalid("level", level, allowed(LEVELS))
    _surface(surface, "surface")
    return [
        load_scene(_suite_path(PAPER_SUITE_DIR, surface, level, i)) for i in range(PAPER_SUITE_SIZE)
    ]


def write_paper_suite(directory: str | os.PathLike[str]) -> list[Path]:
    """Generate the suite for every surface and level into ``directory``: the generator's
    first seeds, from `PAPER_SUITE_SEED` on."""
    written = []
    for surface in SURFACES:
        for level in LEVELS:
            for i in range(PAPER_SUITE_SIZE):
                path = _suite_path(Path(directory), surface, level, i)
                save_scene(generate_scene(level, PAPER_SUITE_SEED + i, surface=surface), path)
                written.append(path)
    return written


if __name__ == "__main__":
    paths = write_paper_suite(PAPER_SUITE_DIR)
    print(f"wrote {len(paths)} scenes under {PAPER_SUITE_DIR}")
