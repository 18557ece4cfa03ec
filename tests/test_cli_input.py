"""Bad input on the command line: one line on stderr naming the flag, the value and what is
allowed, exit status 2, no traceback, nothing written, and no work started."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.helpers import TABLE_BROWN, assert_picture
from tests.helpers import run_cli as run


@pytest.fixture
def files(tmp_path: Path, lone_can_file: Path) -> dict[str, Path]:
    """A scene, a directory, a regular file, a file of invalid JSON and a JSON that is not a
    report, all under tmp_path."""
    scene = lone_can_file
    (tmp_path / "dir").mkdir()
    (tmp_path / "file.txt").write_text("a regular file")
    (tmp_path / "bad.json").write_text('{"suite": "table1", ')
    (tmp_path / "other.json").write_text('{"hello": "world"}')
    return {
        "scene": scene,
        "dir": tmp_path / "dir",
        "file": tmp_path / "file.txt",
        "bad": tmp_path / "bad.json",
        "other": tmp_path / "other.json",
    }


CASES: list[tuple[str, list[str], tuple[str, ...]]] = [
    # (id, argv with {placeholders}, texts the one line must hold)
    ("scene missing", ["demo", "--scene", "{tmp}/nope.json"], ("--scene", "no such file")),
    (
        "scene is a directory",
        ["render", "--scene", "{dir}", "--out", "{tmp}/x.png"],
        ("--scene", "is a directory"),
    ),
    ("scene empty", ["plan", "--scene", ""], ("--scene", "empty")),
    (
        "out is a directory",
        ["render", "--scene", "{scene}", "--out", "{dir}"],
        ("--out", "is a directory"),
    ),
    ("out empty", ["render", "--scene", "{scene}", "--out", ""], ("--out", "empty")),
    (
        "out under a file",
        ["render", "--scene", "{scene}", "--out", "{file}/x.png"],
        ("--out", "is a file, not a directory"),
    ),
    (
        "out not writable",
        ["render", "--scene", "{scene}", "--out", "/proc/clutter/x.png"],
        ("--out", "cannot be written"),
    ),
    (
        "json is a directory",
        ["plan", "--scene", "{scene}", "--json", "{dir}"],
        ("--json", "is a directory"),
    ),
    (
        "json not writable",
        ["plan", "--scene", "{scene}", "--json", "/proc/x.json"],
        ("--json", "cannot be written"),
    ),
    (
        "md under a file",
        ["benchmark", "--suite", "fig15", "--json", "{tmp}/b.json", "--md", "{file}/b.md"],
        ("--md", "is a file"),
    ),
    (
        "figure is a directory",
        ["plan", "--scene", "{scene}", "--figure", "{dir}"],
        ("--figure", "is a directory"),
    ),
    ("gif empty", ["plan", "--scene", "{scene}", "--gif", ""], ("--gif", "empty")),
    (
        "plots is a file",
        ["benchmark", "--suite", "fig15", "--json", "{tmp}/b.json", "--plots", "{file}"],
        ("--plots", "is a file"),
    ),
    ("out-dir is a file", ["demo", "--out-dir", "{file}"], ("--out-dir", "is a file")),
    (
        "noises empty",
        ["benchmark", "--suite", "table1", "--json", "{tmp}/b.json", "--noises", ""],
        ("--noises", "names nothing"),
    ),
    (
        "planners empty",
        ["benchmark", "--suite", "table1", "--json", "{tmp}/b.json", "--planners", ","],
        ("--planners", "names nothing"),
    ),
    (
        "unknown noise level",
        ["benchmark", "--suite", "table1", "--json", "{tmp}/b.json", "--noises", "sigma9"],
        ("noises", "sigma9", "sigma1"),
    ),
    (
        "unknown suite",
        ["benchmark", "--suite", "table2", "--json", "{tmp}/b.json"],
        ("--suite", "table2", "table1", "fig15"),
    ),
    (
        "unknown backend",
        ["benchmark", "--suite", "table1", "--json", "{tmp}/b.json", "--backend", "dask"],
        ("--backend", "dask", "local", "ray"),
    ),
    (
        "unknown planner",
        ["benchmark", "--suite", "table1", "--json", "{tmp}/b.json", "--planners", "tsr,rrt"],
        ("planner", "rrt", "pushing"),
    ),
    (
        "workers 0",
        ["plan", "--scene", "{scene}", "--execute", "--workers", "0"],
        ("--workers", "0", "integer >= 1"),
    ),
    (
        "workers -1",
        ["plan", "--scene", "{scene}", "--execute", "--workers", "-1"],
        ("--workers", "-1", "integer >= 1"),
    ),
    (
        "trials negative",
        ["plan", "--scene", "{scene}", "--trials", "-3"],
        ("--trials", "-3", "integer >= 0"),
    ),
    (
        "benchmark trials negative",
        ["benchmark", "--suite", "fig15", "--json", "{tmp}/b.json", "--trials", "-1"],
        ("--trials", "-1"),
    ),
    ("budget zero", ["plan", "--scene", "{scene}", "--budget", "0"], ("--budget", "0", "> 0")),
    ("budget nan", ["plan", "--scene", "{scene}", "--budget", "nan"], ("--budget", "nan")),
    ("seed negative", ["plan", "--scene", "{scene}", "--seed", "-1"], ("--seed", "-1")),
    ("samples zero", ["plan", "--scene", "{scene}", "--samples", "0"], ("--samples", "0")),
    ("plan noise", ["plan", "--scene", "{scene}", "--noise", "sigma9"], ("--noise", "sigma9")),
    (
        "scene noise",
        ["scene", "--level", "none", "--seed", "0", "--noise", "loud", "--out", "{tmp}/s.json"],
        ("--noise", "loud"),
    ),
    ("bench steps 0", ["bench", "env", "--steps", "0"], ("--steps", "0")),
    ("bench resets 0", ["bench", "env", "--resets", "0"], ("--resets", "0")),
    (
        "bench trajectory steps 0",
        ["bench", "env", "--trajectory-steps", "0"],
        ("--trajectory-steps",),
    ),
    ("bench seeds 0", ["bench", "plan", "--seeds", "0"], ("--seeds", "0")),
    ("bench objects empty", ["bench", "capture", "--objects", ""], ("--objects",)),
    (
        "scenes per group 0",
        ["benchmark", "--suite", "table1", "--json", "{tmp}/b.json", "--scenes-per-group", "0"],
        ("--scenes-per-group",),
    ),
    (
        "rotations abc",
        ["validate-capture", "--object", "can", "--json", "{tmp}/v.json", "--rotations", "abc"],
        ("--rotations", "abc"),
    ),
    (
        "rotations inf",
        ["validate-capture", "--object", "can", "--json", "{tmp}/v.json", "--rotations", "0,inf"],
        ("--rotations",),
    ),
    (
        "validation trials 0",
        ["validate-capture", "--object", "can", "--json", "{tmp}/v.json", "--trials", "0"],
        ("--trials",),
    ),
    (
        "plots of invalid JSON",
        ["benchmark-plots", "--json", "{bad}", "--out", "{tmp}/p"],
        ("--json", "bad.json", "not valid JSON"),
    ),
    (
        "plots of a non-report",
        ["benchmark-plots", "--json", "{other}", "--out", "{tmp}/p"],
        ("--json", "other.json", "not a clutter-gym benchmark report"),
    ),
    (
        "figure of invalid JSON",
        ["capture-region", "--object", "can", "--out", "{tmp}/c.png", "--validation", "{bad}"],
        ("--validation", "bad.json", "JSON"),
    ),
    (
        "figure of a non-report",
        ["capture-region", "--object", "can", "--out", "{tmp}/c.png", "--validation", "{other}"],
        ("--validation", "other.json"),
    ),
    (
        "unknown object",
        ["capture-region", "--object", "piano", "--out", "{tmp}/c.png"],
        ("--object", "piano", "can"),
    ),
]


@pytest.mark.parametrize(("argv", "texts"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_and_exit_2(
    argv: list[str],
    texts: tuple[str, ...],
    files: dict[str, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    places = {key: str(path) for key, path in files.items()} | {"tmp": str(tmp_path)}
    before = sorted(tmp_path.rglob("*"))
    began = time.perf_counter()
    code, out, err = run([a.format(**places) for a in argv], capsys)
    assert code == 2, err
    assert time.perf_counter() - began < 10.0  # rejected before any work
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    for text in texts:
        assert text in lines[0], (text, lines[0])
    assert sorted(tmp_path.rglob("*")) == before  # nothing written, not even half


def test_version_and_defaults_in_help(capsys: pytest.CaptureFixture[str]) -> None:
    from clutter_gym import __version__

    code, out, _ = run(["--version"], capsys)
    assert code == 0 and out.strip() == f"clutter-gym {__version__}"
    for command in ("demo", "plan", "benchmark", "bench", "validate-capture", "scene"):
        code, out, _ = run([command, "--help"], capsys)
        assert code == 0 and "(default:" in out, command


def _clutter_gym(*args: str, **env: str) -> subprocess.CompletedProcess[str]:
    script = Path(sys.executable).with_name("clutter-gym")
    return subprocess.run(
        [str(script), *args], capture_output=True, text=True, env={**os.environ, **env}
    )


def test_bench_env_stdout_is_pure_json(tmp_path: Path) -> None:
    pytest.importorskip("panda_gym")  # its pybullet client printed argv[0]=... on stdout
    done = _clutter_gym(
        "bench",
        "env",
        "--steps",
        "20",
        "--trajectory-steps",
        "1",
        "--resets",
        "2",
        "--primitive-steps",
        "2",
    )
    assert done.returncode == 0, done.stderr
    (line,) = done.stdout.splitlines()
    assert json.loads(line)["panda_push_v3_steps_per_s"] > 0


def test_an_unwritable_cache_directory_is_a_warning_not_a_crash(
    files: dict[str, Path], tmp_path: Path
) -> None:
    png = tmp_path / "scene.png"
    done = _clutter_gym(
        "render",
        "--scene",
        str(files["scene"]),
        "--out",
        str(png),
        XDG_CACHE_HOME=str(files["file"] / "cache"),
    )
    assert done.returncode == 0, done.stderr
    assert "is not writable" in done.stderr and "XDG_CACHE_HOME" in done.stderr
    assert_picture(png, size=(480, 360), colours=(TABLE_BROWN,))


ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("pybullet", "pybullet_utils", "torch", "stable_baselines3", "sb3_contrib")
"""What `--help` and an argument error never load (nor the planners)."""
LOADED = (
    "import json, sys\n"
    "from agents.cli import main\n"
    "for argv in {argvs!r}:\n"
    "    main(argv)\n"
    "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {heavy!r})))\n"
)


def _loaded(*argvs: list[str]) -> list[str]:
    """The heavy modules and the planner modules loaded by running `main` on ``argvs``."""
    code = LOADED.format(argvs=list(argvs), heavy=(*HEAVY, "planners"))
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    return json.loads(done.stdout.splitlines()[-1])


def test_help_loads_no_simulator_torch_or_planner() -> None:
    assert _loaded(["--help"], ["--version"]) == []


def test_argument_errors_load_no_simulator_torch_or_planner(
    files: dict[str, Path], tmp_path: Path
) -> None:
    places = {key: str(path) for key, path in files.items()} | {"tmp": str(tmp_path)}
    argvs = [[a.format(**places) for a in argv] for _, argv, _ in CASES]
    argvs += [
        ["plan", "--scene", places["scene"], "--planner", "rrt"],
        ["validate-capture", "--object", "piano", "--json", f"{tmp_path}/v.json"],
        ["evaluate", "--agent", "nonsense", "--env", "ClutterRetrieve-v0", "--json", "e.json"],
        ["train", "--algo", "dqn", "--env", "ClutterRetrieve-v0", "--out", f"{tmp_path}/t"],
        ["frobnicate"],
    ]
    # The planners' names (planners.kinds, data only) are all an argument check may read.
    assert set(_loaded(*argvs)) <= {"planners", "planners.kinds"}


def test_no_pybullet_banner_in_a_commands_output(files: dict[str, Path], tmp_path: Path) -> None:
    png = tmp_path / "scene.png"
    done = _clutter_gym("render", "--scene", str(files["scene"]), "--out", str(png))
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"wrote {png}\n" and "pybullet" not in done.stderr
    code = "import clutter_gym.env; print('only this')"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert (done.stdout, done.stderr) == ("only this\n", "")
