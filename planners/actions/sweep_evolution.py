"""A sweep's simulated evolution nu_o, chunk by chunk, kept for every goal that asks for it.

Sweeping a box under every (mu_c, c) is the planner's most expensive computation, and the
evolution depends on the object's samples, the sweep's frame and the pushing parameters, not on
G: only where the sweep stops does. So the chunks are kept in the plan's context
(`PlanningContext.sweeps`) and each goal runs only its own stop test.

An evolution starts from the samples in the sweep's frame, (N, 3), each simulated under every
parameter set, or continues one, (P, N, 3): the rows where an earlier sweep left each sample
under each set (a sweep in two strokes, `planners.actions.sweep`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.transforms import Frame2D
from planners.actions.context import PlanningContext
from planners.actions.goals import AwayFrom, Goal
from planners.actions.grasp_geometry import START_CLEARANCE, translated
from planners.actions.hand_in import NU_SPACING
from planners.capture import SweepRegion, extreme_parameters

NU_STEP = 0.005  # m: simulation step of nu_o (regions are built at 1 mm; nu_o is a volume)
PILOT_STEP = 0.01  # m: simulation step of the one-sample pilot of a sweep
SWEEP_CHUNK = 0.06  # m of sweep simulated before checking whether the object has reached G
PILOT_INTO_AVOID = "the detected pose sweeps into avoidVol"
EXACT_STRIDE = 4
"""Steps of nu_o between the first exact goal tests of a sweep's first guess."""


def not_far_enough(ctx: PlanningContext, goal: Goal) -> str:
    """Why no sweep in a direction will do."""
    return f"no sweep up to {ctx.settings.sweep_max} m ends {goal.describe()}"


@dataclass
class SweepEvolution:
    """A sweep's simulated nu_o so far, chunk by chunk (module docstring)."""

    chunks: list[tuple[np.ndarray, np.ndarray]]  # (distances (k + 1,), world (k + 1, P*N, 3))
    current: np.ndarray  # hand-frame poses where the last chunk ends
    advanced: float  # m simulated

    def chunk(
        self,
        i: int,
        region: SweepRegion,
        frame: Frame2D,
        step: float,
        limit: float,
        chosen: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Chunk ``i`` of the sweep, simulated only the first time anyone asks for it."""
        while len(self.chunks) <= i:
            d = min(SWEEP_CHUNK, limit - self.advanced)
            k = max(1, math.ceil(d / NU_SPACING))
            nu_hand = region.evolve(self.current, d, k, step, chosen)
            distances = self.advanced + np.linspace(0.0, d, k + 1)
            self.chunks.append((distances, frame.moving_to_world(nu_hand, distances)))
            self.current = nu_hand[-1]
            self.advanced += d
        return self.chunks[i]


def _kept(
    ctx: PlanningContext, name: str, frame: Frame2D, in_frame: np.ndarray, step: float
) -> SweepEvolution:
    """The plan's evolution of this sweep, begun if nobody asked for it before."""
    key = (name, frame.origin, frame.angle, frame.handedness, step, in_frame.shape)
    evolution = ctx.sweeps.get(key)
    if evolution is None:
        evolution = ctx.sweeps[key] = SweepEvolution([], in_frame, 0.0)
    return evolution


def _start(frame: Frame2D, in_frame: np.ndarray, region: SweepRegion) -> np.ndarray:
    """nu_o's first stage, (1, P*N, 3) world poses: every sample under every parameter set."""
    sets = len(extreme_parameters(region.mus, region.cs))
    rows = in_frame if in_frame.ndim == 3 else np.tile(in_frame, (sets, 1, 1))
    return frame.moving_to_world(rows[None], np.zeros(1))


def _chunks(
    ctx: PlanningContext,
    name: str,
    region: SweepRegion,
    frame: Frame2D,
    in_frame: np.ndarray,
    limit: float,
    step: float,
) -> Iterator[tuple[np.ndarray, np.ndarray, int]]:
    """The evolution's chunks up to ``limit``, each simulated the first time anyone asks for
    it: its distances, world poses and the index of its last stage within the limit (a chunk
    kept from a longer sweep may run past this one's limit)."""
    chosen = extreme_parameters(region.mus, region.cs)
    evolution = _kept(ctx, name, frame, in_frame, step)
    i = 0
    while i < len(evolution.chunks) or evolution.advanced < limit - 1e-9:
        ctx.check_budget()
        distances, world = evolution.chunk(i, region, frame, step, limit, chosen)
        i += 1
        k = int(np.searchsorted(distances, limit + 1e-9)) - 1
        yield distances, world, k
        if k < len(distances) - 1:
            return


def evolved(
    ctx: PlanningContext,
    name: str,
    region: SweepRegion,
    frame: Frame2D,
    in_frame: np.ndarray,
    distance: float,
) -> np.ndarray:
    """nu_o of a sweep of ``distance`` (a multiple of NU_SPACING), stages (S, P*N, 3)."""
    stages = [_start(frame, in_frame, region)]
    for _, world, k in _chunks(ctx, name, region, frame, in_frame, distance, NU_STEP):
        stages.append(world[1 : k + 1])
    return np.concatenate(stages)


def first_guess(
    ctx: PlanningContext, name: str, goal: AwayFrom, samples: np.ndarray, direction: np.ndarray
) -> float | None:
    """How far to sweep the object's ``samples`` (world poses) along ``direction`` (a unit
    vector): a rigid translation along the sweep is a cheap first guess of how far to sweep (the
    simulated evolution decides); it does not depend on where along the hand. The top-view
    test of the axis-aligned bounds is tried first, for every distance at once; when no
    distance passes it (a turned box's
    bounds are pessimistic next to the NGR), the exact test decides, every `EXACT_STRIDE`
    steps first and then at the steps just short of the first distance that passes: a failing
    exact test costs milliseconds (a large NGR), and most distances fail."""
    gap = START_CLEARANCE
    shifts = np.arange(NU_SPACING, ctx.settings.sweep_max - gap + 1e-9, NU_SPACING)

    def accepts(d: float) -> bool:
        return goal.accepts(ctx, name, translated(samples, d * direction), False)

    moved = np.repeat(samples[None], len(shifts), axis=0)
    moved[:, :, :2] += (shifts[:, None] * direction)[:, None, :]
    clear = np.flatnonzero(goal.clearly_accepts_each(ctx, name, moved))
    if len(clear):
        return float(gap + shifts[clear[0]])
    coarse = list(range(EXACT_STRIDE - 1, len(shifts), EXACT_STRIDE))
    if coarse[-1] != len(shifts) - 1:
        coarse.append(len(shifts) - 1)
    previous = -1
    for k in coarse:
        if accepts(shifts[k]):
            shorter = (j for j in range(previous + 1, k) if accepts(shifts[j]))
            return float(gap + shifts[next(shorter, k)])
        previous = k
    return None


def reached(
    ctx: PlanningContext,
    name: str,
    goal: Goal,
    region: SweepRegion,
    in_frame: np.ndarray,
    distance: float,
    final: np.ndarray,
) -> bool:
    """A sweep of ``distance`` keeps every sample and leaves all of nu_o[1] in G."""
    inside = region.query(in_frame.reshape(-1, 3), distance)[0].all()
    return bool(inside) and goal.accepts(ctx, name, final, False)


def sweep_until(
    ctx: PlanningContext,
    name: str,
    goal: Goal,
    region: SweepRegion,
    frame: Frame2D,
    in_frame: np.ndarray,
    limit: float,
    step: float = NU_STEP,
    check_from: float = 0.0,
) -> tuple[float, np.ndarray] | None:
    """The shortest sweep (to NU_SPACING) whose every evolved sample ends in G, with nu_o.

    The evolution is simulated a chunk at a time and stops as soon as G is reached; its
    chunks are kept for the next goal that asks for the same sweep. G is tested from
    ``check_from`` on (a pilot run tells roughly where it is reached)."""
    stages = [_start(frame, in_frame, region)]
    hold = region.holds_until(in_frame.reshape(-1, 3))
    for distances, world, k in _chunks(ctx, name, region, frame, in_frame, limit, step):
        if k < 1:
            break
        if distances[k] >= check_from:

            def at(j: int, d: np.ndarray = distances, w: np.ndarray = world) -> bool:
                return reached(ctx, name, goal, region, in_frame, float(d[j]), w[j])

            held = bool(distances[k] < hold)
            if not held or at(k):
                # G is reached by the chunk's end, or the region lets go of a sample by then and
                # holds none longer: the sweep is the chunk's first stage that reaches G (the
                # last stage only while it is held, and then it is known to).
                last = k if held else k - 1
                j = next((j for j in range(1, last + 1) if j == k or at(j)), None)
                if j is None:
                    return None
                return float(distances[j]), np.concatenate([*stages, world[1 : j + 1]])
        if k < len(distances) - 1:
            break
        stages.append(world[1:])
    return None


def simulate(
    ctx: PlanningContext,
    name: str,
    goal: AwayFrom,
    region: SweepRegion,
    frame: Frame2D,
    in_frame: np.ndarray,
    avoid: Volume,
) -> tuple[float, np.ndarray] | str:
    """How far to sweep and nu_o, or why not: a pilot with the detected pose alone (a
    thirtieth of the work) says whether and roughly where the sweep reaches G, and whether the
    detected pose already sweeps into avoidVol (nu_o holds its path, so the sweep would fail
    there after simulating every sample); only then are all samples simulated, tested for G
    from a chunk before there on, as far as the sweep may go (the samples spread as they turn,
    and the last of them may need several chunks more). ``in_frame`` (P, N, 3) continues an
    evolution (a second stroke): its pilot is the first sample under every parameter set."""
    # No sweep longer than the region holds every sample can pass: simulate no further.
    limit = min(ctx.settings.sweep_max, region.holds_until(in_frame.reshape(-1, 3)))
    pilot_rows = in_frame[:, :1] if in_frame.ndim == 3 else in_frame[:1]
    pilot = sweep_until(ctx, name, goal, region, frame, pilot_rows, limit, PILOT_STEP)
    if pilot is None:
        return not_far_enough(ctx, goal)
    if ctx.sweeps_into(name, pilot[1], avoid):
        return PILOT_INTO_AVOID
    swept = sweep_until(
        ctx,
        name,
        goal,
        region,
        frame,
        in_frame,
        limit,
        check_from=pilot[0] - SWEEP_CHUNK,
    )
    return not_far_enough(ctx, goal) if swept is None else swept
