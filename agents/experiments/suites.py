"""The benchmark's suites: Table 1, pushing vs pick-and-place on the figure scenes, and their
perturbed variants, as (scene, noise level) cases, with the paper's Table 1 beside them. Scenes
and names only (no simulator, no planner), so that the command line checks its arguments
before `agents.experiments.benchmark` loads either."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from clutter_gym.model.scene import (
    PERTURB_SHIFT,
    PERTURB_TURN,
    Scene,
    load_scene,
    perturbed,
    shipped_scene,
)
from planners.kinds import planner_kind

TABLE1_NOISES = ("sigma1", "sigma2", "sigma3", "sigma4")
CLUTTER_LEVELS = ("none", "medium", "high")
PERTURBED_VARIANTS = 10
"""Variants of each figure layout in the perturbed suite: ten, so that a cell measures the
layout rather than the luck of one pose."""
FIGURE_SCENES = (
    "figures/fig3_can_box_dumbbell",
    "figures/fig15_can_box_two_graspables",
    "figures/fig16_shelf_can_behind_box",
    "figures/fig2_high_uncertainty",
    "can_behind_poptarts",
)

PAPER_TABLE1: dict[tuple[str, str], tuple[tuple[int, float], ...]] = {
    ("tsr", "none"): ((10, 0.01), (9, 0.52), (0, 0.86), (0, 0.86)),
    ("tsr", "medium"): ((10, 0.01), (9, 1.02), (0, 1.61), (0, 1.63)),
    ("tsr", "high"): ((5, 0.54), (0, 1.97), (0, 3.22), (0, 3.08)),
    ("pg", "none"): ((10, 0.02), (10, 0.58), (10, 1.00), (5, 1.44)),
    ("pg", "medium"): ((10, 0.04), (10, 1.17), (10, 5.17), (0, 3.91)),
    ("pg", "high"): ((8, 1.98), (5, 12.93), (3, 28.16), (0, 7.46)),
}
"""Table 1 of the paper (Dogar & Srinivasa): (scenes solved of 10, mean planning
time [s]) per (planner, clutter level), at sigma1-sigma4. Reference data for the report."""


@dataclass(frozen=True)
class Case:
    """One scene at one noise level; ``group`` is the clutter level or the figure."""

    scene: Scene
    label: str  # e.g. "high_03"
    group: str
    noise: str


@dataclass(frozen=True)
class Suite:
    name: str
    description: str
    cases: tuple[Case, ...]
    planners: tuple[str, ...]  # the default planners


def table1_suite() -> Suite:
    cases = tuple(
        Case(load_scene(shipped_scene(f"paper/{level}_{k:02d}")), f"{level}_{k:02d}", level, noise)
        for level in CLUTTER_LEVELS
        for k in range(10)
        for noise in TABLE1_NOISES
    )
    return Suite(
        "table1",
        "Table 1: 10 scenes x 3 clutter levels x 4 noise levels",
        cases,
        ("tsr", "pg"),
    )


def _figure_cases(variants: int) -> tuple[Case, ...]:
    """The figure scenes at their own noise: as drawn (``variants`` 0), or that many seeded
    perturbed variants of each (`clutter_gym.model.scene.perturbed`)."""
    cases = []
    for name in FIGURE_SCENES:
        path = shipped_scene(name)
        scene = load_scene(path)
        if not isinstance(scene.noise, str):
            raise ValueError(f"{path}: noise must be a level name for the suite")
        figure = name.split("/")[-1]
        if not variants:
            cases.append(Case(scene, figure, figure, scene.noise))
        for k in range(variants):
            cases.append(Case(perturbed(scene, k), f"{figure}~{k:02d}", figure, scene.noise))
    return tuple(cases)


def fig15_suite() -> Suite:
    return Suite(
        "fig15",
        "Pushing vs pick-and-place (§3.2.1) on the figure scenes: "
        + ", ".join(n.split("/")[-1] for n in FIGURE_SCENES),
        _figure_cases(0),
        ("pushing", "pick-and-place"),
    )


def perturbed_suite() -> Suite:
    return Suite(
        "perturbed",
        f"The figure layouts moved by up to {PERTURB_SHIFT:g} m and turned by up to "
        f"{math.degrees(PERTURB_TURN):g} deg, {PERTURBED_VARIANTS} seeded variants each",
        _figure_cases(PERTURBED_VARIANTS),
        ("pushing", "pick-and-place"),
    )


SUITES: dict[str, Callable[[], Suite]] = {
    "table1": table1_suite,
    "fig15": fig15_suite,
    "perturbed": perturbed_suite,
}


def get_suite(name: str) -> Suite:
    try:
        return SUITES[name]()
    except KeyError:
        raise ValueError(f"suite: {name!r} is unknown; allowed: {', '.join(SUITES)}") from None


def check_planners(names: Sequence[str] | None, suite: Suite) -> tuple[str, ...]:
    """The planners to run (default: the suite's); an unknown name lists the valid ones."""
    if names is None:
        return suite.planners
    if not names:
        raise ValueError("planners: none given; name at least one")
    for name in names:
        planner_kind(name)
    return tuple(dict.fromkeys(names))


def select_cases(suite: Suite, noises: Sequence[str] | None, per_group: int | None) -> list[Case]:
    """The suite's cases, only the first ``per_group`` scenes of each group and only the
    ``noises`` levels when given; an unknown level lists the suite's."""
    cases = _first_scenes(suite.cases, per_group)
    if noises is not None:
        known = sorted({c.noise for c in suite.cases})
        unknown = [n for n in noises if n not in known]
        if unknown or not noises:
            raise ValueError(f"noises: {list(noises)!r}; the suite has {', '.join(known)}")
        cases = [c for c in cases if c.noise in noises]
    return cases


def _first_scenes(cases: Iterable[Case], per_group: int | None) -> list[Case]:
    if per_group is None:
        return list(cases)
    if per_group < 1:
        raise ValueError(f"scenes_per_group: {per_group}; must be >= 1")
    labels: dict[str, list[str]] = {}
    for c in cases:
        group = labels.setdefault(c.group, [])
        if c.label not in group:
            group.append(c.label)
    keep = {label for group in labels.values() for label in group[:per_group]}
    return [c for c in cases if c.label in keep]
