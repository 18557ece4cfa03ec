"""The `clutter-gym` command line.

clutter-gym demo [--scene scene.json] [--out-dir out/demo]
clutter-gym plan --scene scene.json [--planner pushing] [--execute --trials 100] [--json out.json]
    [--gif out.gif] [--figure timeline.png]
clutter-gym scene --level high --seed 3 [--surface table] [--noise sigma2] --out scene.json
clutter-gym render --scene scene.json --out scene.png
clutter-gym bench env|capture|plan|ik|train --json out.json [--samples 500] [--train-steps 2000]
clutter-gym benchmark --suite table1|fig15|perturbed [--planners tsr,pg,pushing,pick-and-place]
    --json out.json [--md out.md] [--plots dir] [--trials 10] [--workers 2] [--backend local|ray]
clutter-gym benchmark-plots --json out.json --out dir
clutter-gym train --algo ppo|sac|tqc[,...] --env ID [--config agents/hyperparams/ppo.yml]
    [--steps N] [--n-envs K] [--seed S | --seeds 0,1,2] --out DIR [--backend local|ray]
    [--workers 1] [--eval-freq F] [--eval-episodes E] [--save-freq C]
clutter-gym evaluate --agent DIR|planner:pushing|planner:pg|planner:tsr|scripted [--agent ...]
    --env ID --episodes N --seed S --json out.json [--md out.md]
    [--level none] [--goal-kind soda_can] [--noise sigma1] [--scenes a.json ...]
    [--grasped-start 0]
clutter-gym demos --planner pushing --env ClutterRetrieveEE-v0 --episodes N --out DIR
    [--level none] [--goal-kind soda_can] [--noise sigma1] [--seed S] [--grasped-start 0.5]
clutter-gym plot-training DIR... --out fig.png
clutter-gym gif-frames --gif out/demo/demo.gif --out frames.png [--frames 8] [--columns 4]

Bad input is one line naming the flag, the value and what is allowed, exit status 2; every
argument is checked before any work starts. A job log (the .jsonl beside --json) has one writer:
a second run given the same --json says in one line which process uses it, exit status 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import Any, NamedTuple, NoReturn


class Command(NamedTuple):
    """A subcommand: its name, its one-line help and the module of its `add_arguments`/`run`
    (``COMMANDS[name]`` there), imported only when the command is the one given."""

    name: str
    help: str
    module: str


COMMANDS = (
    Command(
        "demo",
        "retrieve the goal object of a scene; write a GIF and JSON",
        "agents.cli.experiments",
    ),
    Command(
        "plan",
        "plan a retrieval with Rearrange; optionally execute it on noisy worlds",
        "agents.cli.experiments",
    ),
    Command(
        "benchmark",
        "the paper's experiments (Table 1, pushing vs pick-and-place)",
        "agents.cli.experiments",
    ),
    Command("benchmark-plots", "PNG plots from a benchmark JSON", "agents.cli.figures"),
    Command("scene", "generate a scene at one of the paper's clutter levels", "agents.cli.scenes"),
    Command("render", "render a scene file to a PNG", "agents.cli.scenes"),
    Command(
        "validate-capture",
        "capture region vs pybullet physics (paper Fig. 11)",
        "agents.cli.experiments",
    ),
    Command("capture-region", "plot a push-grasp or sweep capture region", "agents.cli.figures"),
    Command(
        "reachability",
        "build the arm's reachability map of a support and plot it",
        "agents.cli.experiments",
    ),
    Command(
        "train", "train a stable-baselines3 / sb3-contrib agent on a variant", "agents.cli.learning"
    ),
    Command(
        "evaluate",
        "trained agents, planners and the scripted grasp on the same episodes",
        "agents.cli.learning",
    ),
    Command(
        "demos",
        "the planner's plans as end-effector actions (demonstrations for learning)",
        "agents.cli.learning",
    ),
    Command("plot-training", "success rate against env steps, over seeds", "agents.cli.figures"),
    Command("gif-frames", "a GIF's frames side by side in one PNG", "agents.cli.figures"),
    Command("bench", "speed and memory benchmarks, written as JSON", "agents.cli.experiments"),
)
"""The dispatch table, in the order `--help` lists the commands."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line (and exit status 2), defaults shown."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _CommandParser(_Parser):
    """A subcommand's parser that adds its arguments when it first parses: `--help` and the
    other commands never import a command's module (nor the simulator or torch behind it)."""

    def __init__(self, *args: object, command: Command, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        self._pending: Command | None = command

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        if self._pending is not None:
            command, self._pending = self._pending, None
            add_arguments, run = importlib.import_module(command.module).COMMANDS[command.name]
            add_arguments(self)
            self.set_defaults(func=run)
        return super().parse_known_args(args, namespace)


class _Version(argparse._VersionAction):
    """--version, reading the version only when asked (importing clutter_gym loads gymnasium)."""

    def __call__(self, parser: argparse.ArgumentParser, *args: Any, **kwargs: Any) -> None:
        from clutter_gym import __version__

        self.version = f"clutter-gym {__version__}"
        super().__call__(parser, *args, **kwargs)


class _HelpFormatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """The module docstring as written, and every option's default in --help (once: a help
    text that already says its default, "(None: ...)" or "(default: ...)", keeps its own)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if "(default:" in text or "(None:" in text:
            return text
        return super()._get_help_string(action)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="clutter-gym", description=__doc__)
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_CommandParser)
    for command in COMMANDS:
        sub.add_parser(command.name, help=command.help, command=command)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; the exit status (2 for bad input) rather than raising SystemExit."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exit_:  # --help, --version, or a usage error already printed
        return exit_.code if isinstance(exit_.code, int) else 2
    try:
        return int(args.func(args))
    except ValueError as error:  # bad input found past parsing: one clear line, no traceback
        print(f"clutter-gym {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"clutter-gym {args.command}: interrupted; finished work is kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
