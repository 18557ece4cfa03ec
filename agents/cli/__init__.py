"""The `clutter-gym` command line: a dispatch table of commands, each imported when run."""

from agents.cli.main import main

__all__ = ["main"]
