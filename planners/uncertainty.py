"""Object pose uncertainty as samples (§2.1.2): U(o) drawn from N(q_hat, Q) at the detection.

The planner never sees true poses. Each object's detection q_hat and the detector's noise
(sigma_xy, sigma_theta), independent in x, y and theta as in the paper's §3, give a diagonal
covariance Q; U(o) is represented by n samples, the first of which is q_hat itself so that one
sample (sigma1) is the detection.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from clutter_gym.model.noise import NOISE_LEVELS
from clutter_gym.model.objects import ObjectSpec
from clutter_gym.model.transforms import wrap_angle

SAMPLE_COUNTS: dict[str, int] = {
    "sigma1": 1,
    "sigma2": 30,
    "sigma3": 50,
    "sigma4": 50,
    "detector": 30,
    "fig2": 20,
}
"""The paper's sample counts per noise level (§3.1.2, Table 1; the real detector n = 30;
Fig. 2's example n = 20)."""
CUSTOM_SAMPLES = 50
"""Samples for noise that is not one of the paper's levels (the paper's largest count)."""
MASS_DRAWS = 1000
"""Draws of N(q_hat, Q) that estimate how much of the belief an action's capture region holds
(the standard error at 0.97 is 0.005): enough to order an action's parameters by it."""
MASS_SEED = 0
"""The draws' seed: the same standard-normal draws for every object, so plans are deterministic."""


def sample_count(sigma: tuple[float, float]) -> int:
    """n for a noise level: the paper's count for its named levels, 1 without noise."""
    sigma_xy, sigma_theta = sigma
    if sigma_xy == 0.0 and sigma_theta == 0.0:
        return 1
    for name, level in NOISE_LEVELS.items():
        if np.allclose(level, sigma, rtol=1e-3, atol=1e-9):
            return SAMPLE_COUNTS[name]
    return CUSTOM_SAMPLES


def sample_poses(
    detected: tuple[float, float, float] | np.ndarray,
    sigma: tuple[float, float],
    n: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """(n, 3) samples of U(o): the detection, then n - 1 draws from N(q_hat, diag(Q))."""
    q = np.asarray(detected, dtype=float).reshape(3)
    if n < 1:
        raise ValueError(f"samples: {n}; must be >= 1")
    if not (np.all(np.isfinite(q)) and all(math.isfinite(s) and s >= 0 for s in sigma)):
        raise ValueError(f"detection {q.tolist()} and sigma {sigma} must be finite, sigma >= 0")
    scale = np.array([sigma[0], sigma[0], sigma[1]])
    draws = q + rng.standard_normal((n - 1, 3)) * scale
    samples = np.vstack([q, draws])
    samples[:, 2] = wrap_angle(samples[:, 2])
    return samples


@dataclass(frozen=True)
class ObjectBelief:
    """What the planner knows about one object: its kind and the samples of U(o)."""

    name: str
    spec: ObjectSpec
    detected: tuple[float, float, float]
    samples: np.ndarray  # (n, 3) planar poses
    sigma: tuple[float, float] = (0.0, 0.0)  # the noise the samples were drawn with

    @property
    def n(self) -> int:
        return len(self.samples)

    @cached_property
    def mass_draws(self) -> np.ndarray:
        """(`MASS_DRAWS`, 3) draws of N(q_hat, Q), the same on every call. A plan holds the n
        samples, yet the true pose falls beyond them in some of its executions (Fig. 2's n = 20
        at sigma 2 cm: about one in twenty); among the parameters that hold every sample, the
        ones that also hold most of these draws are tried first. Without noise: the detection."""
        if self.sigma == (0.0, 0.0):
            return self.samples[:1].copy()
        z = np.random.default_rng(MASS_SEED).standard_normal((MASS_DRAWS, 3))
        scale = np.array([self.sigma[0], self.sigma[0], self.sigma[1]])
        draws = np.asarray(self.detected, dtype=float) + z * scale
        draws[:, 2] = wrap_angle(draws[:, 2])
        return draws


def beliefs(
    detections: Sequence[tuple[str, ObjectSpec, tuple[float, float, float]]],
    sigma: tuple[float, float],
    n: int,
    rng: np.random.Generator,
) -> list[ObjectBelief]:
    """The belief of every detected object ``(name, spec, detected pose)``: n samples of U(o)
    each, drawn in the order given (the order fixes the samples of a seed)."""
    return [
        ObjectBelief(name, spec, detected, sample_poses(detected, sigma, n, rng), sigma)
        for name, spec, detected in detections
    ]
