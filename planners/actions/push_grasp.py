"""Push-grasp (§2.2) and PickUp of the goal object.

A push-grasp is a straight push of the horizontal hand at grasp height that the capture region
guarantees ends with every uncertainty sample between the fingers. It is searched over the
direction v (ordered by §2.2.6's heuristic), the aperture and the lateral offset. For the goal
object it is PickUp: close and lift (table) or close and pull into the goal strip (shelf). For an
obstacle the hand opens flat and backs away: the object stays where the capture region put it,
inside the hand's pocket.
"""

from __future__ import annotations

import math
from collections.abc import Generator, Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import Footprint
from clutter_gym.model.reachability import PUSH_HEIGHT
from clutter_gym.model.transforms import Frame2D, wrap_angle
from planners.actions.arm import Arm
from planners.actions.clearance import lines_overlapping
from planners.actions.context import PlanningContext
from planners.actions.goals import Goal, Retrieve
from planners.actions.grasp_geometry import START_CLEARANCE
from planners.actions.hand_in import NU_SPACING, HandIn, hand_in, pick_up_or_release
from planners.actions.heuristics import push_headings
from planners.actions.pick_and_place import place
from planners.actions.results import ActionResult, Failure, Outcome, unfit
from planners.actions.static_grasp import static_grasp
from planners.capture import CaptureRegion, extreme_parameters, push_grasp_apertures
from planners.hand2d import default_aperture, outline_reach, push_grasp_profile

HEADING_REFINE = 3
"""The push-grasp's headings are searched again at this fraction of the settings' step."""
OFFSET_STEP = 0.01  # m between the lateral offsets tried (the paper's "user defined step")
NU_STEP = 0.005  # m: simulation step of nu_o (regions are built at 1 mm; nu_o is a volume)
MISSES_SAMPLES = "the capture region misses some uncertainty samples"
PushedOrFailure = tuple[HandIn, dict[str, float]] | Failure
"""A push-grasp's hand motion with its parameters, or why one lateral offset has none."""


def push_grasp(
    ctx: PlanningContext, arm: Arm, name: str, goal: Goal, avoid: Volume
) -> Iterator[Outcome]:
    """Push-grasps of ``name``, best heading first: those that hold at least the settings'
    `preferred_mass` of the belief at every heading, then the others. For the goal (G is
    `Retrieve`) they are PickUps, and the static grasps of its TSR come first (push-grasps
    with no push, d = 0, §3.1.2: the shortest motion when the uncertainty allows one). An
    obstacle is either left where the push put it or carried out of the NGR (PickUp of an
    obstacle, §2.1.6)."""
    spec = ctx.beliefs[name].spec
    action = "pickup" if isinstance(goal, Retrieve) else "push-grasp"
    why = unfit(spec, pushed=True, lifted=action == "pickup")
    if why:
        yield Failure(name, action, why)
        return
    if action == "pickup":
        yield from static_grasp(ctx, arm, name, goal, avoid)
    apertures = aperture_order(spec.footprint, spec.liftable)
    reach = push_grasp_profile(max(apertures)).pusher.bounds[3]
    headings: list[float] = []
    finished: set[float] = set()
    for likely in (True, False):
        source = _headings(ctx, arm, name, reach, avoid) if likely else iter(headings)
        for heading in source:
            if likely:
                headings.append(heading)
            if heading in finished:
                continue
            for aperture in apertures:
                args = (ctx, arm, name, goal, avoid, action, heading, aperture, likely)
                if (yield from _first_finished(*args)):
                    finished.add(heading)
                    break  # the next candidate pushes from another direction


def _first_finished(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: Goal,
    avoid: Volume,
    action: str,
    heading: float,
    aperture: float,
    likely: bool,
) -> Generator[Outcome, None, bool]:
    """The finishes of the first lateral offset whose push and finish both pass (and the
    failures on the way); whether there was one. ``likely``: among the pushes that hold at
    least the settings' `preferred_mass` of the belief, else among the others (second pass)."""
    for pushed in _hand_ins(ctx, arm, name, avoid, action, heading, aperture, likely):
        if isinstance(pushed, Failure):
            yield pushed
            continue
        found = False
        for outcome in _finishes(ctx, arm, name, goal, avoid, action, *pushed):
            yield outcome
            found |= isinstance(outcome, ActionResult)
        if found:
            return True
    return False


def _headings(
    ctx: PlanningContext, arm: Arm, name: str, reach: float, avoid: Volume
) -> Iterator[float]:
    """`push_headings` at the settings' step, then, only if the search goes on, the ones
    between them at a `HEADING_REFINE`-th of the step: in clutter a hand turned by 5 degrees
    may fit where the 15-degree grid has none (Table 1 high_03), and the coarse grid first
    keeps the cost of the scenes it solves."""
    coarse = push_headings(ctx, arm.heading_origin, name, reach, avoid)
    yield from coarse
    step = ctx.settings.heading_step_deg / HEADING_REFINE
    for heading in push_headings(ctx, arm.heading_origin, name, reach, avoid, step):
        if all(abs(math.remainder(heading - h, 2 * math.pi)) > 1e-6 for h in coarse):
            yield heading


def aperture_order(footprint: Footprint, liftable: bool = True) -> list[float]:
    """The push-grasp apertures in the order they are tried (§2.2.6 searches them all): the
    one that fits the object at any orientation first (the validated everyday preshape), then
    wider ones up to the V preshapes (wide uncertainty), then narrower ones (clutter)."""
    usual = default_aperture(footprint)
    apertures = push_grasp_apertures(footprint, liftable)
    return sorted(apertures, key=lambda a: (a < usual - 1e-3, abs(a - usual)))


def lateral_offsets(
    samples: np.ndarray, heading: float, half_width: float, step: float
) -> np.ndarray:
    """Lateral hand offsets (m, to the hand's left of the detection) that can capture every
    sample: from the middle of the samples' spread across the push out to the two extremes at
    which the capture region, ``half_width`` either side of the hand's axis, still spans them
    (§2.2.6: "o is changed between the two extreme positions"), middle first, ``step`` apart
    (`_over_offsets` then tries those that hold every sample most belief mass first)."""
    normal = np.array([-math.sin(heading), math.cos(heading)])
    lateral = (samples[:, :2] - samples[0, :2]) @ normal
    low, high = float(lateral.max()) - half_width, float(lateral.min()) + half_width
    if low > high:
        return np.empty(0)
    middle = 0.5 * (low + high)
    k = np.arange(int((high - low) / (2 * step) + 1e-9) + 1)
    return middle + step * np.column_stack([k, -k]).ravel()[1:]


def _finishes(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: Goal,
    avoid: Volume,
    action: str,
    moved: HandIn,
    details: dict[str, float],
) -> Iterator[Outcome]:
    """What a push-grasp does once the hand holds the object: PickUp of the goal; for an
    obstacle, release it where it is, else carry it to a placement out of the NGR."""
    yield pick_up_or_release(ctx, arm, name, goal, avoid, action, moved, details)
    if action != "pickup":
        yield place(ctx, arm, name, goal, avoid, moved, details)


class HandInSearch:
    """`_over_offsets` for one (object, action, heading, aperture, avoidVol), searched once per
    plan and only as far as asked: its checks (capture, the hand's overlap, IK, the arm's
    motion, nu_o against avoidVol) never depend on G, so every parent candidate that asks to
    move the object with the same avoidVol (`PlanningContext.objects_volume`, one object per
    set of names) reads what an earlier one found, failures too (for blocked_by), and goes on
    where it stopped. avoidVol is kept with the search: its id stays its own while it lives.
    The search yields its likely pushes, then None, then the rest (`tier`)."""

    def __init__(self, avoid: Volume, search: Iterator[PushedOrFailure | None]) -> None:
        self.avoid = avoid
        self._search: Iterator[PushedOrFailure | None] | None = search
        self._found: list[PushedOrFailure | None] = []

    def _items(self) -> Iterator[PushedOrFailure | None]:
        k = 0
        while True:
            if k == len(self._found):
                if self._search is None:
                    return
                try:
                    self._found.append(next(self._search))
                except StopIteration:
                    self._search = None
                    return
            yield self._found[k]
            k += 1

    def tier(self, likely: bool) -> Iterator[PushedOrFailure]:
        """The likely pushes (up to the None), else what follows the None."""
        items = self._items()
        if not likely:
            for item in items:
                if item is None:
                    break
        for item in items:
            if item is None:
                return
            yield item


def _hand_ins(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    avoid: Volume,
    action: str,
    heading: float,
    aperture: float,
    likely: bool,
) -> Iterator[PushedOrFailure]:
    """`_over_offsets` through the plan's `HandInSearch` for these parameters: its likely
    pushes, or the rest."""
    key = (name, action, heading, aperture, id(avoid))
    search = ctx.hand_ins.get(key)
    if search is None:
        offsets = _over_offsets(ctx, arm, name, avoid, action, heading, aperture)
        search = HandInSearch(avoid, offsets)
        ctx.hand_ins[key] = search
    return search.tier(likely)


def _over_offsets(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    avoid: Volume,
    action: str,
    heading: float,
    aperture: float,
) -> Iterator[PushedOrFailure | None]:
    """The pushes at this heading and aperture, one per lateral offset (`lateral_offsets`),
    that pass every check, with the failures on the way: first the pushes whose capture holds
    at least the settings' `preferred_mass` of the belief (`_belief_masses`), most first; then
    None; then the offsets that fail before any IK, and the other pushes, most mass first. A
    failure at one offset does not end the search: a hand shifted by a centimetre may clear a
    neighbour or find IK; nor does a push that passes, since what the action does next (lift,
    release, place) may fail there and not at the next offset. The capture and the hand's
    overlap where it stops, which rule out most offsets, are decided for all offsets at once
    before any offset pays for the mass, and the mass before any offset pays for IK."""
    pushes = ctx.push_plans.get((name, heading, aperture))
    if pushes is None:  # the samples and the region alone decide them: once per plan
        with ctx.stats.timed("capture"):
            belief = ctx.beliefs[name]
            region = ctx.push_region(belief.spec.footprint, aperture)
            offsets = lateral_offsets(belief.samples, heading, region.lateral_reach, OFFSET_STEP)
            pushes = _plan_pushes(ctx, name, heading, aperture, offsets) if len(offsets) else []
        ctx.push_plans[(name, heading, aperture)] = pushes
    if pushes:  # one per lateral offset; none where no offset can capture every sample
        with ctx.stats.timed("clearance"):  # the planar test and what earlier ones found
            early, clear = _before_ik(ctx, name, avoid, action, heading, aperture, pushes)
    else:
        early, clear = [Failure(name, action, MISSES_SAMPLES)], []
    masses = _belief_masses(ctx, name, clear)
    ranked = sorted(zip(clear, masses, strict=True), key=lambda pm: -pm[1])  # stable
    bar = ctx.settings.preferred_mass

    def tried(push: PlannedPush, mass: float) -> PushedOrFailure:
        """`_push_at`, counted."""
        ctx.check_budget()
        ctx.stats.actions_tried += 1
        return _push_at(ctx, arm, name, avoid, action, push, mass)

    for push, mass in (pm for pm in ranked if pm[1] >= bar):
        yield tried(push, mass)
    yield None
    for failure in early:
        ctx.check_budget()
        ctx.stats.actions_tried += 1
        yield failure
    for push, mass in (pm for pm in ranked if pm[1] < bar):
        yield tried(push, mass)


def _before_ik(
    ctx: PlanningContext,
    name: str,
    avoid: Volume,
    action: str,
    heading: float,
    aperture: float,
    pushes: list[PlannedPush | None],
) -> tuple[list[Failure], list[PlannedPush]]:
    """The offsets that fail before any IK (the capture misses a sample, or the planar test
    finds the hand on a neighbour where it stops or on its way in, now or under an earlier
    avoidVol that held it), and the pushes past them, each list in offset order: the planar
    test found every one of those clear (`hand_in` does not test them again)."""
    # Hand motions a named object blocked under an earlier avoidVol that holds it still: the
    # planar tests behind such failures see that object alone.
    known = [None if p is None else _blocked_before(ctx, name, p, avoid.labels) for p in pushes]
    open_ = [p for p, k in zip(pushes, known, strict=True) if p is not None and k is None]
    starts, ends = np.array([p.start for p in open_]), np.array([p.end for p in open_])
    z = ctx.surface.top_z + PUSH_HEIGHT  # the lowest: the most objects reach the hand there
    pusher = push_grasp_profile(aperture).pusher
    found = iter(lines_overlapping(ctx, pusher, starts, ends, heading, avoid, z))
    early: list[Failure] = []
    clear: list[PlannedPush] = []
    for push, blocked in zip(pushes, known, strict=True):
        if push is None:
            early.append(Failure(name, action, MISSES_SAMPLES))
        elif blocked is not None:
            early.append(Failure(name, action, blocked.reason, blocked.blocker))
        elif (why_blocker := next(found))[1]:
            why, blocker = why_blocker
            early.append(Failure(name, action, why, blocker))
            ctx.blocked_hands[_hand_key(name, push)] = BlockedHand(why, blocker)
        else:
            clear.append(push)
    return early, clear


def _hand_key(name: str, push: PlannedPush) -> tuple[str, float, float, float]:
    return (name, push.heading, push.aperture, push.offset)


@dataclass(frozen=True)
class BlockedHand:
    """Why the planar test found a push-grasp's hand motion on one object (`_before_ik`)."""

    reason: str
    blocker: str


def _blocked_before(
    ctx: PlanningContext, name: str, push: PlannedPush, avoid: frozenset[str]
) -> BlockedHand | None:
    """An earlier failure of this hand motion that named an object of avoidVol (its labels,
    ``avoid``): the hand's cross-section overlapped that object's samples where it stops or
    on its way (`clearance`), which no other object can undo."""
    blocked = ctx.blocked_hands.get(_hand_key(name, push))
    return blocked if blocked is not None and blocked.blocker in avoid else None


@dataclass(frozen=True)
class PlannedPush:
    """A push-grasp's geometry once the capture region holds every sample: hand_base from
    ``start`` to ``end`` along ``heading``, the samples in the hand's frame at the start."""

    heading: float
    aperture: float
    offset: float
    start: np.ndarray
    end: np.ndarray
    distance: float
    in_hand: np.ndarray


def _plan_pushes(
    ctx: PlanningContext, name: str, heading: float, aperture: float, offsets: np.ndarray
) -> list[PlannedPush | None]:
    """For each lateral offset, the hand pushing in along ``heading``, shifted sideways, until
    the capture region says every sample is in the hand; None where it misses some. All
    offsets at once: the samples' orientations in the hand and the outline's nearest edge
    ahead of the hand do not depend on the offset, one region query answers them all."""
    belief = ctx.beliefs[name]
    spec = belief.spec
    region = ctx.push_region(spec.footprint, aperture)
    profile = push_grasp_profile(aperture)
    v = np.array([math.cos(heading), math.sin(heading)])
    normal = np.array([-v[1], v[0]])
    samples = belief.samples
    centres = samples[0, :2] + np.asarray(offsets, dtype=float)[:, None] * normal  # (K, 2)
    theta = wrap_angle(samples[:, 2] - heading)
    d = samples[None, :, :2] - centres[:, None, :]  # (K, N, 2)
    local_x = d @ v
    outline = outline_reach(spec.footprint, theta)
    back_off = (local_x - outline).min(1) - profile.pusher.bounds[1] - START_CLEARANCE
    starts = centres + back_off[:, None] * v
    in_hand = _in_hands(samples, starts, heading)
    inside, need = region.query(in_hand.reshape(-1, 3))
    captured = np.all(inside.reshape(len(centres), -1), axis=1)
    distances = np.minimum(need.reshape(len(centres), -1).max(1) + region.push_margin, region.d_max)
    ends = starts + distances[:, None] * v
    return [
        PlannedPush(
            heading, aperture, float(offset), starts[k], ends[k], float(distances[k]), in_hand[k]
        )
        if captured[k]
        else None
        for k, offset in enumerate(offsets)
    ]


def _in_hands(poses: np.ndarray, starts: np.ndarray, heading: float) -> np.ndarray:
    """World poses (N, 3) in the frame of a hand at each of ``starts`` (K, 2) pointing along
    ``heading``: (K, N, 3), the capture region's coordinates."""
    v = np.array([math.cos(heading), math.sin(heading)])
    across = Frame2D((0.0, 0.0), heading).y_axis  # the hand frame's y, as `Frame2D` has it
    d = poses[None, :, :2] - starts[:, None, :]
    theta = np.broadcast_to(wrap_angle(poses[:, 2] - heading), d.shape[:2])
    return np.stack([d @ v, d @ across, theta], axis=-1)


def extreme_samples(in_hand: np.ndarray) -> np.ndarray:
    """Indices of the samples (N, 3; the hand's frame) at the ends of their spread along the
    push, across it and in orientation: where a push's nu_o sweeps into avoidVol and its
    detected pose does not, one of these does (Table 1 high_04 at sigma2: 60 of 60 such
    pushes). Sorted, at most six."""
    ends = [f(in_hand[:, k]) for k in range(3) for f in (np.argmin, np.argmax)]
    return np.unique(np.array(ends, dtype=int))


def _belief_masses(ctx: PlanningContext, name: str, pushes: list[PlannedPush]) -> list[float]:
    """For each push, the share of the belief's draws (`ObjectBelief.mass_draws`) its capture
    region holds within its distance: the chance that the push-grasp captures the true pose.
    The paper takes any push that holds the n samples, yet the true pose falls beyond them in
    some executions (Fig. 2's variant 08: 20 samples at sigma 2 cm, and the push at the middle
    of their spread held 0.905 of the draws where another offset held 0.995). Once per push
    and plan, all new pushes of a heading and aperture in one region query."""
    new = [p for p in pushes if _hand_key(name, p) not in ctx.push_masses]
    if new:
        with ctx.stats.timed("capture"):
            region = ctx.push_region(ctx.beliefs[name].spec.footprint, new[0].aperture)
            starts = np.array([p.start for p in new])
            in_hand = _in_hands(ctx.beliefs[name].mass_draws, starts, new[0].heading)
            _, need = region.query(in_hand.reshape(-1, 3))
            held = need.reshape(len(new), -1) <= np.array([p.distance for p in new])[:, None]
            for push, share in zip(new, held.mean(1), strict=True):
                ctx.push_masses[_hand_key(name, push)] = float(share)
    return [ctx.push_masses[_hand_key(name, p)] for p in pushes]


class _PushEvolution:
    """nu_o of one push-grasp (world poses, stages x samples), simulated only once the arm's
    motion is known feasible, and before it the pilots, a few of its own rows (`pilots`);
    both kept in the plan's context for every later candidate with this push."""

    def __init__(self, ctx: PlanningContext, name: str, push: PlannedPush) -> None:
        # Only what every candidate needs: most never reach nu_o (the hand's overlap, IK and
        # the arm's motion refuse them first), so the rest is computed when first asked for.
        self.ctx = ctx
        self.name = name
        self.push = push
        self.key = (name, push.heading, push.aperture, push.offset)

    @cached_property
    def _region(self) -> CaptureRegion:
        return self.ctx.push_region(self.ctx.beliefs[self.name].spec.footprint, self.push.aperture)

    @cached_property
    def _stages(self) -> int:
        return max(1, math.ceil(self.push.distance / NU_SPACING))

    @cached_property
    def _chosen(self) -> np.ndarray:
        return extreme_parameters(self._region.mus, self._region.cs)

    @cached_property
    def _extremes(self) -> np.ndarray:
        return extreme_samples(self.push.in_hand)

    def _simulate(self, samples: np.ndarray | slice, parameters: np.ndarray) -> np.ndarray:
        """Rows of nu_o in the hand's frame (stages, parameter sets, samples, 3): each sample
        is simulated on its own, so a subset gives nu_o's own rows, to the bit."""
        push = self.push
        with self.ctx.stats.timed("nu"):
            return self._region.evolve(
                push.in_hand[samples], push.distance, self._stages, NU_STEP, parameters
            )

    def _part(self, stage: int) -> np.ndarray:
        """The rows of pilot ``stage`` (0: the detected pose under the first parameter set,
        1: the `extreme_samples` under every set), simulated once per push and plan."""
        parts = self.ctx.push_pilots.setdefault(self.key, [])
        if len(parts) == 0:
            parts.append(self._simulate(slice(0, 1), self._chosen[:1]))
        if stage == 1 and len(parts) == 1:
            parts.append(self._simulate(self._extremes, self._chosen))
        return parts[stage]

    def _to_world(self, in_hand: np.ndarray) -> np.ndarray:
        """Hand-frame rows to the world, the hand advancing stage by stage along the push."""
        push = self.push
        with self.ctx.stats.timed("nu"):
            frame = Frame2D((float(push.start[0]), float(push.start[1])), push.heading)
            advances = np.linspace(0.0, push.distance, self._stages + 1)
            return frame.moving_to_world(in_hand, advances)

    def evolve(self) -> np.ndarray:
        """nu_o, on the pilots' rows where they were simulated."""
        ctx, key = self.ctx, self.key
        if key in ctx.pushes:
            return ctx.pushes[key]
        parts = ctx.push_pilots.pop(key, [])  # nu_o holds them
        samples = len(self.push.in_hand)
        if len(parts) < 2:
            nu_hand = self._simulate(slice(None), self._chosen)
        else:
            nu_hand = np.empty((self._stages + 1, len(self._chosen), samples, 3))
            nu_hand[:, :, self._extremes] = parts[1]
            rest = np.setdiff1d(np.arange(samples), self._extremes)
            if len(rest):
                nu_hand[:, :, rest] = self._simulate(rest, self._chosen)
        nu = self._to_world(nu_hand)
        nu.setflags(write=False)  # shared by every later candidate with this push
        ctx.pushes[key] = nu
        return nu

    def pilots(self) -> Iterator[np.ndarray]:
        """nu_o's rows of the detected pose under the first parameter set, then of the
        `extreme_samples` under every set (about a tenth and a fifth of nu_o's cost); none
        once nu_o itself is at hand. Most pushes whose nu_o sweeps into avoidVol carry the
        detection there too, and nearly all the others an extreme sample."""
        for stage in range(2):
            if self.key in self.ctx.pushes:
                return
            yield self._to_world(self._part(stage))


def _push_at(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    avoid: Volume,
    action: str,
    push: PlannedPush,
    mass: float,
) -> tuple[HandIn, dict[str, float]] | Failure:
    """The push's motion, nu_o and parameters, or why the arm cannot make it (the planar test
    of `_before_ik` found the hand's motion clear of avoidVol)."""
    nu_o = _PushEvolution(ctx, name, push)
    details = {
        "heading_deg": math.degrees(push.heading),
        "aperture_m": push.aperture,
        "offset_m": push.offset,
        "push_m": push.distance,
        "belief_mass": mass,
    }
    profile = push_grasp_profile(push.aperture)
    line = (push.start, push.end)
    moved = hand_in(
        ctx,
        arm,
        name,
        action,
        avoid,
        line,
        push.heading,
        profile,
        nu_o.evolve,
        nu_o.pilots,
        planar_clear=True,
    )
    if isinstance(moved, Failure):
        return moved
    return moved, details
