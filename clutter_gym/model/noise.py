"""Perception noise: the paper's noise levels and noisy detections.

The paper models its detector's error as independent Gaussian noise in x, y and theta (§2.1.2,
§3). A detection is the true planar pose plus that noise, drawn from the env's own generator so
that a seed fixes every detection of an episode. A noise level is a name of ``NOISE_LEVELS``, a
pair ``(sigma_xy, sigma_theta)`` or the scene file's ``{"xy": .., "theta": ..}``, bounded by
``MAX_SIGMA`` (beyond which perception is meaningless and observations lose precision).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from clutter_gym.model.fields import allowed, invalid, mapping, number
from clutter_gym.model.transforms import wrap_angle

NOISE_LEVELS: dict[str, tuple[float, float]] = {
    "sigma1": (0.0, 0.0),
    "sigma2": (0.005, 0.034),
    "sigma3": (0.02, 0.175),
    "sigma4": (0.06, 0.785),
    "detector": (0.007, 0.07),
    "fig2": (0.02, 0.05),
}
"""Perception noise ``(sigma_xy [m], sigma_theta [rad])``: the paper's σ1–σ4, its real
detector (§3.1) and the high-uncertainty example of its Fig. 2."""
DEFAULT_NOISE = "sigma2"
MAX_SIGMA: dict[str, float] = {"xy": 1.0, "theta": math.pi}
"""Upper bounds of the noise standard deviations (m, rad)."""
_SIGMA_RANGES = {"xy": "[0, 1] m", "theta": "[0, pi] rad"}
NOISE_FORMS = (
    ", ".join(repr(n) for n in NOISE_LEVELS) + ' or {"xy": sigma_xy, "theta": sigma_theta}'
)


def resolve_noise(
    noise: str | Sequence[float] | Mapping[str, float], path: str = "noise"
) -> tuple[float, float]:
    """``(sigma_xy, sigma_theta)`` of a level name, a pair or a ``{"xy", "theta"}`` mapping.

    Every other input is a ``ValueError`` naming ``path``, since the env passes user input
    straight through.  Sigmas are bounded (``MAX_SIGMA``) so observations stay finite in float32.
    """
    if isinstance(noise, str):
        if noise not in NOISE_LEVELS:
            raise invalid(path, noise, allowed(NOISE_LEVELS) + ' or {"xy": .., "theta": ..}')
        return NOISE_LEVELS[noise]
    if isinstance(noise, Mapping):
        entry = mapping(noise, path, tuple(MAX_SIGMA))
        values = tuple(entry[key] for key in MAX_SIGMA)
    elif isinstance(noise, list | tuple) and len(noise) == 2:
        values = tuple(noise)
    else:
        raise invalid(path, noise, f"a pair (sigma_xy, sigma_theta), {NOISE_FORMS}")
    sigmas = []
    for (key, limit), value in zip(MAX_SIGMA.items(), values, strict=True):
        sigma = number(value, f"{path}.{key}")
        if not 0 <= sigma <= limit:
            raise invalid(f"{path}.{key}", value, f"a standard deviation in {_SIGMA_RANGES[key]}")
        sigmas.append(sigma)
    return sigmas[0], sigmas[1]


def detect(
    true_poses: np.ndarray, sigma: tuple[float, float], rng: np.random.Generator
) -> np.ndarray:
    """Detected planar poses (N, 3): true (x, y, theta) plus independent Gaussian noise."""
    true_poses = np.asarray(true_poses, dtype=np.float64).reshape(-1, 3)
    sigma_xy, sigma_theta = sigma
    noise = rng.standard_normal(true_poses.shape) * np.array([sigma_xy, sigma_xy, sigma_theta])
    detected = true_poses + noise
    detected[:, 2] = wrap_angle(detected[:, 2])
    return detected
