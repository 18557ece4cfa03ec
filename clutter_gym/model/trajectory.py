"""Robot trajectories, in the one form every planner, baseline, validation and policy uses.

A `Trajectory` is a sequence of `Segment`s, each a joint path of the right arm (N, 7) under one
hand command. The env's trajectory action is K = ``waypoints`` rows of 9 columns (7 joints,
spread, closure); `Trajectory.actions` cuts a trajectory into such actions, the last one padded
by repeating its final row (a zero-length segment costs the env nothing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from clutter_gym.model.herb import HandCommand

DEFAULT_WAYPOINTS = 16
"""K, the rows of one trajectory action (the env's default)."""
ACTION_COLUMNS = 9
"""7 joint angles, hand spread, hand closure."""


@dataclass(frozen=True)
class Segment:
    """Part of a trajectory under one hand command: joint rows (N, 7); the env moves through
    the rows in order and changes the hand at the first."""

    label: str
    path: np.ndarray
    hand: HandCommand

    def rows(self) -> np.ndarray:
        """(N, 9) rows in the env's trajectory action format."""
        hand = np.tile(np.array([self.hand.spread, self.hand.closure]), (len(self.path), 1))
        return np.hstack([self.path, hand])


@dataclass(frozen=True)
class Trajectory:
    """Segments executed in order (the paper's tau)."""

    segments: tuple[Segment, ...]

    @property
    def start(self) -> np.ndarray:
        return self.segments[0].path[0]

    @property
    def end(self) -> np.ndarray:
        return self.segments[-1].path[-1]

    def rows(self) -> np.ndarray:
        """(N, 9) rows of every segment."""
        return np.vstack([s.rows() for s in self.segments])

    def actions(self, waypoints: int = DEFAULT_WAYPOINTS) -> list[np.ndarray]:
        """Env trajectory actions of ``waypoints`` rows each (float32), in order."""
        return chunk_rows(self.rows(), waypoints)

    def __add__(self, other: Trajectory) -> Trajectory:
        return Trajectory(self.segments + other.segments)


def chunk_rows(rows: np.ndarray, waypoints: int) -> list[np.ndarray]:
    """(N, 9) rows as env actions of ``waypoints`` rows, the last padded by holding still."""
    chunks = []
    for k in range(math.ceil(len(rows) / waypoints)):
        part = rows[k * waypoints : (k + 1) * waypoints]
        pad = np.repeat(part[-1:], waypoints - len(part), axis=0)
        chunks.append(np.vstack([part, pad]).astype(np.float32))
    return chunks


def hold_action(
    arm: np.ndarray, hand: HandCommand, waypoints: int, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """The action that keeps the arm where it is (within the joint limits) and the hand as it
    is: what a policy sends when it has nothing to do."""
    row = np.r_[np.clip(arm, lower, upper), hand.spread, hand.closure]
    return np.tile(row, (waypoints, 1)).astype(np.float32)
