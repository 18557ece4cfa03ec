"""The clutter-gym command line: each command's output, and clear errors on bad input."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from agents.cli import main
from agents.experiments.speed.ik_speed import ANALYTIC, PREVIOUS
from agents.experiments.speed.plan_speed import bench_plan
from agents.runner import jobs
from clutter_gym.model.scene import generate_scene, load_scene
from tests.helpers import OUT_OF_REACH, TAB_GREEN, TABLE_BROWN, WHITE, assert_picture, lone_can


def test_scene_command_writes_the_generated_scene(tmp_path: Path) -> None:
    out = tmp_path / "scene.json"
    assert main(["scene", "--level", "high", "--seed", "3", "--out", str(out)]) == 0
    assert load_scene(out) == generate_scene("high", seed=3)


def test_render_command_writes_a_png(tmp_path: Path) -> None:
    scene = tmp_path / "scene.json"
    png = tmp_path / "scene.png"
    main(["scene", "--level", "medium", "--seed", "1", "--out", str(scene)])
    assert main(["render", "--scene", str(scene), "--out", str(png)]) == 0
    assert_picture(png, size=(480, 360), colours=(TABLE_BROWN,))


def test_bad_scene_file_is_one_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = tmp_path / "scene.json"
    main(["scene", "--level", "none", "--seed", "0", "--out", str(scene)])
    data = json.loads(scene.read_text())
    data["objects"][0]["pose"] = [0.9, "left", 0.0]
    scene.write_text(json.dumps(data))
    assert main(["render", "--scene", str(scene), "--out", str(tmp_path / "x.png")]) == 2
    assert "objects[0].pose[1]" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_unknown_level_lists_the_choices(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scene", "--level", "extreme", "--seed", "0", "--out", "x.json"]) == 2
    assert "none" in capsys.readouterr().err


@pytest.mark.slow
def test_demo_plans_the_papers_three_steps_and_retrieves_the_can(tmp_path: Path) -> None:
    """Figs. 3-5: the dumbbell moves first, then the box into its space, then the can."""
    assert main(["demo", "--out-dir", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "demo.json").read_text())
    assert summary["success"] and summary["goal_held"] and summary["goal_lift_m"] >= 0.10
    plan = summary["plan"]
    assert plan["success"] and plan["objects_moved"] == ["dumbbell", "big_box"]
    assert [(s["action"], s["object"]) for s in plan["steps"]] == [
        ("sweep", "dumbbell"),
        ("sweep", "big_box"),
        ("pickup", "red_can"),
    ]
    with Image.open(tmp_path / "demo.gif") as gif:
        # PIL merges identical consecutive frames (the arm at rest), so at most as many.
        assert 50 < gif.n_frames == summary["frames"]
    assert_picture(tmp_path / "demo.gif", size=(480, 360), colours=(TABLE_BROWN,))


def test_bench_train_times_env_and_update_apart(tmp_path: Path) -> None:
    config = tmp_path / "quick.yml"
    shipped = Path(__file__).resolve().parents[1] / "agents" / "hyperparams" / "sac_lone_can.yml"
    config.write_text(
        f"ClutterRetrieveEE-v0:\n  base: {shipped}\n  learning_starts: 12\n"
        "  buffer_size: 500\n  batch_size: 16\n  env_kwargs: {max_episode_steps: 10}\n"
    )
    out = tmp_path / "train.json"
    argv = ["bench", "train", "--config", str(config), "--train-steps", "20", "--json", str(out)]
    assert main(argv) == 0
    result = json.loads(out.read_text())
    assert result["replay_buffer"] == "HerReplayBuffer" and result["net_arch"] == [256, 256]
    assert result["timed_steps"] == 20 and result["warmup_steps"] == 12
    assert 0 < result["ms_per_env_step"] < result["ms_per_training_step"]
    assert result["ms_per_update"] == pytest.approx(
        result["ms_per_training_step"] - result["ms_per_env_step"], abs=0.02
    )


def test_bench_env_writes_json(tmp_path: Path) -> None:
    out = tmp_path / "bench.json"
    argv = ["bench", "env", "--steps", "30", "--trajectory-steps", "1", "--resets", "5"]
    assert main([*argv, "--primitive-steps", "4", "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    for key in ("low_level_steps_per_s", "trajectory_steps_per_s", "reset_ms", "rss_growth_mb"):
        assert result[key] > 0 or key == "rss_growth_mb"
    assert result["resets"] == 5
    assert result["primitive_steps"] == 4 and result["primitive_step_s"] > 0


@pytest.mark.slow
def test_bench_plan_compares_the_ik_solvers_on_the_same_detections() -> None:
    result = bench_plan(1, ("sigma2",), ("figures/fig2_high_uncertainty",))
    fig2 = result["fig2_high_uncertainty/sigma2"]
    assert set(fig2) == {ANALYTIC, PREVIOUS} and set(result["all"]) == {ANALYTIC, PREVIOUS}
    for summary in fig2.values():
        assert summary["planned"] == 1 and summary["objects_moved"] == [[]]
        assert 0 < summary["median_planning_time_s"] < 60
        assert 0 < summary["ik_share"] < 1 and 0 < summary["accounted_share"] <= 1
        shares = summary["shares"]
        assert shares["ik"] == pytest.approx(summary["ik_share"], abs=0.002)
        assert sum(shares.values()) == pytest.approx(summary["accounted_share"], abs=0.02)


def test_console_script_is_installed() -> None:
    exe = shutil.which("clutter-gym")
    assert exe is not None
    help_text = subprocess.run([exe, "--help"], capture_output=True, text=True, check=True).stdout
    for command in ("demo", "scene", "render", "bench"):
        assert command in help_text


def test_validate_capture_small_run_and_resume(tmp_path: Path) -> None:
    out = tmp_path / "val.json"
    argv = ["validate-capture", "--object", "can", "--trials", "4", "--json", str(out)]
    assert main([*argv, "--rotations", "0", "--workers", "1"]) == 0
    report = json.loads(out.read_text())
    summary = report["rotation_0deg"]
    assert summary["trials"] + summary["skipped"] == report["grid_points"] == 4
    assert summary["failures_inside"] == 0
    log = tmp_path / "val.json.trials.jsonl"
    lines = log.read_text().count("\n")
    assert main([*argv, "--rotations", "0", "--workers", "1"]) == 0  # resumes: nothing to rerun
    assert log.read_text().count("\n") == lines


def test_validate_capture_every_aperture_writes_one_table(tmp_path: Path) -> None:
    from clutter_gym.model.objects import get_object
    from planners.capture import push_grasp_apertures

    apertures = push_grasp_apertures(get_object("soda_can").footprint)
    out, table = tmp_path / "can.json", tmp_path / "can.md"
    argv = ["validate-capture", "--object", "can", "--aperture", "all", "--trials", "2"]
    argv += ["--rotations", "0", "--workers", "1", "--json", str(out), "--md", str(table)]
    assert main(argv) == 0
    for aperture in apertures:
        report = json.loads((tmp_path / f"can_{aperture:.3f}.json").read_text())
        assert report["aperture_m"] == aperture
    rows = table.read_text().splitlines()[2:]
    assert [row.split(" | ")[2] for row in rows] == [f"{a:.3f}" for a in apertures]
    assert all(row.startswith("| soda_can | push-grasp |") for row in rows)


def test_gif_frames_puts_evenly_spaced_frames_on_one_sheet(tmp_path: Path) -> None:
    from clutter_gym.media import gif_writer

    gif, png = tmp_path / "roll.gif", tmp_path / "sheet.png"
    colours = [(200, 30, 30), (30, 200, 30), (30, 30, 200)]
    rng = np.random.default_rng(0)
    with gif_writer(gif) as frames:
        for k in range(9):  # frames 0, 4 and 8 are kept: red, green, blue
            frame = rng.integers(0, 255, (20, 30, 3), dtype=np.uint8)
            frame[:, :15] = colours[k // 4] if k % 4 == 0 else (90, 90, 90)
            frames.add(frame)
    assert main(["gif-frames", "--gif", str(gif), "--out", str(png), "--frames", "3"]) == 0
    assert_picture(png, size=(90, 20), colours=colours, tolerance=12)


def test_capture_region_figure(tmp_path: Path) -> None:
    png = tmp_path / "fig.png"
    assert main(["capture-region", "--object", "bottle", "--out", str(png)]) == 0
    assert_picture(png, min_width=800, colours=(WHITE, (207, 232, 207)))  # the region's fill


def test_bench_capture_writes_json(tmp_path: Path) -> None:
    out = tmp_path / "capture.json"
    assert main(["bench", "capture", "--objects", "soda_can", "--json", str(out)]) == 0
    entry = json.loads(out.read_text())["push_grasp/soda_can"]
    assert entry["build_s"] > entry["cached_load_s"] and entry["query_50_ms"] > 0


def test_written_files_get_normal_permissions(tmp_path: Path) -> None:
    out = tmp_path / "scene.json"
    main(["scene", "--level", "none", "--seed", "0", "--out", str(out)])
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask  # as open() would, not mkstemp's 0600


def test_plan_executes_on_true_worlds_and_resumes(
    tmp_path: Path, lone_can_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = lone_can_file
    out = tmp_path / "plan.json"
    args = ["plan", "--scene", str(scene), "--execute", "--trials", "2", "--workers", "1"]
    assert main([*args, "--json", str(out), "--figure", str(tmp_path / "t.png")]) == 0
    report = json.loads(out.read_text())
    assert report["success"] and report["actions"] == 1 and report["samples"] == 30
    assert report["trials"] == 2 and report["execution_success_rate"] == 1.0
    assert_picture(tmp_path / "t.png", min_width=300, colours=(WHITE, TAB_GREEN))
    log = tmp_path / "plan.json.trials.jsonl"
    assert len(log.read_text().splitlines()) == 2
    capsys.readouterr()
    # A rerun finds both trials done, executes nothing new and says so.
    assert main([*args, "--json", str(out)]) == 0
    assert len(log.read_text().splitlines()) == 2
    assert json.loads(out.read_text())["resumed_trials"] == 2
    assert "resumed 2 of 2" in capsys.readouterr().err


def test_plan_trials_made_by_other_code_are_not_resumed(
    tmp_path: Path, lone_can_file: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    scene = lone_can_file
    args = ["plan", "--scene", str(scene), "--execute", "--trials", "1", "--workers", "1"]
    assert main(args) == 0  # no --json: the trials log is out/plan.json.trials.jsonl
    monkeypatch.chdir(tmp_path)
    assert main(args) == 0
    log = tmp_path / "out" / "plan.json.trials.jsonl"
    monkeypatch.setattr(jobs, "code_digest", lambda: "other code")
    assert main([*args, "--json", str(tmp_path / "p.json")]) == 0
    assert json.loads((tmp_path / "p.json").read_text())["resumed_trials"] == 0
    assert len(log.read_text().splitlines()) == 1


def test_plan_reports_why_there_is_no_plan(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    far = lone_can("sigma2", OUT_OF_REACH)
    scene = tmp_path / "far.json"
    scene.write_text(json.dumps(far))
    assert main(["plan", "--scene", str(scene), "--budget", "3"]) == 1
    captured = capsys.readouterr()
    assert json.loads(captured.out.splitlines()[-1])["success"] is False
    assert "blocked by: pickup red_can" in captured.err


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--planner", "teleport"], "allowed: pushing"),
        (["--noise", "sigma9"], "noise"),
        (["--samples", "0"], "samples"),
    ],
)
def test_plan_bad_arguments_are_one_clear_error(
    tmp_path: Path,
    lone_can_file: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    message: str,
) -> None:
    scene = lone_can_file
    assert main(["plan", "--scene", str(scene), *extra]) == 2
    assert message in capsys.readouterr().err
