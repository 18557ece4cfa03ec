"""Noisy object detection: what the agent sees instead of true poses.

The paper models its detector's error as independent Gaussian noise in x, y and theta (§2.1.2,
§3). A detection is the true planar pose plus that noise, drawn from the env's own generator so
that a seed fixes every detection of an episode.
"""

from __future__ import annotations

import numpy as np


def wrap_angle(theta: np.ndarray) -> np.ndarray:
    """Angles mapped to [-pi, pi)."""
    return (np.asarray(theta) + np.pi) % (2.0 * np.pi) - np.pi


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
