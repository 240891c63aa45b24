"""Trial animations from a tree: one frame per sensing step, the batch evaluator's start and end poses and
trial values, robots drawn where the frames put them, a GIF that Pillow opens; clear errors."""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import replace

import numpy as np
import pytest
from PIL import Image

from bt_controller.language import load_library
from bt_controller.robot import timeline
from evolution_manager.errors import AnimationError
from evolution_manager.viewing.animate import (
    ARENA_PX,
    main,
    render_frame,
    text_font,
    to_pixels,
    write_animation,
)
from evolution_manager.viewing.frames import frames_from_tree
from evolution_manager.viewing.palette import ROBOT_COLOURS
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import DEFAULT, OBJECTIVES, load_layout

TREE = "sel(seq(on_food, stop), prob(forward, forward_left), reverse_right)"
SEED, TRIAL = 5, 1


@pytest.fixture(scope="module")
def frames():
    return frames_from_tree(TREE, SEED, TRIAL)


def test_one_frame_per_sensing_step(frames):
    p = DEFAULT.params()
    steps = timeline.trial_steps(DEFAULT.timeline)
    first = TRIAL * steps  # trial 1 is the chain's second: its steps follow trial 0's
    assert len(frames.steps) == steps and list(frames.steps) == list(range(first + 1, first + steps + 1))
    assert frames.poses.shape == (steps, p.n_robots, 3)
    # tick numbers count along the chain; the first frame still shows trial 0's last tick
    assert sorted(set(frames.ticks.tolist())) == list(range(TRIAL * p.ticks - 1, (TRIAL + 1) * p.ticks))


def test_frames_agree_with_the_batch_evaluator(frames):
    ((_, records),) = BatchEvaluator().evaluate_trials([EvaluationRequest(TREE, SEED, trials=TRIAL + 1)])
    record = records[TRIAL]
    # (the first frame is after the first step's move, which under paper the last tick's motors drive)
    np.testing.assert_allclose(frames.poses[-1], record.end_poses, rtol=0, atol=1e-9)
    # the fitness so far at the last step is the trial's fitness (every objective, foraging included)
    np.testing.assert_allclose(frames.fitness[-1], record.values[: len(OBJECTIVES)], rtol=0, atol=1e-12)
    assert np.isnan(frames.fitness[0]).all() and not np.isnan(frames.fitness[DEFAULT.initial_step]).any()


def test_robots_are_drawn_at_the_frame_poses(frames):
    hits = total = 0
    for k in (0, 60, 120, len(frames.steps) - 1):
        image = render_frame(frames, k).convert("RGB")
        for i, (x, y, heading) in enumerate(frames.poses[k]):
            px, py = to_pixels(frames, x, y)
            # a point inside the body, behind the centre (the heading line is drawn in front)
            r = 0.5 * frames.robot_radius * image.width / (2 * frames.arena_half) * 0.7
            sample = image.getpixel((round(px - r * math.cos(heading)), round(py + r * math.sin(heading))))
            total += 1
            hits += sum(abs(a - b) for a, b in zip(sample, ROBOT_COLOURS[i], strict=True)) < 30
    assert hits >= 0.9 * total  # a neighbour's id label may cover a sample


def test_gif_opens_with_pillow_with_every_frame(frames, tmp_path):
    path = write_animation(frames, tmp_path / "trial.gif")
    with Image.open(path) as gif:
        assert gif.format == "GIF" and gif.n_frames == len(frames.steps)


def test_every_kth_frame_is_kept_in_order_from_the_first(frames, tmp_path):
    full = write_animation(frames, tmp_path / "full.gif")
    sparse = write_animation(frames, tmp_path / "sparse.gif", every=4)
    kept = range(0, len(frames.steps), 4)
    with Image.open(full) as a, Image.open(sparse) as b:
        assert b.n_frames == len(kept) < a.n_frames
        for index, k in enumerate(kept[:5]):
            a.seek(k)
            b.seek(index)
            assert np.array_equal(np.asarray(a.convert("RGB")), np.asarray(b.convert("RGB")))
    assert sparse.stat().st_size < full.stat().st_size


def test_mp4_needs_ffmpeg(frames, tmp_path):
    if shutil.which("ffmpeg") is None:
        with pytest.raises(AnimationError, match="needs ffmpeg"):
            write_animation(frames, tmp_path / "trial.mp4")
    else:
        assert write_animation(frames, tmp_path / "trial.mp4").stat().st_size > 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--tree", "forward", "--out", "x.gif"], "needs --seed"),
        (["--tree", "seq(forward", "--seed", "1", "--out", "x.gif"], "--tree"),
        (["--tree", "forward", "--seed", "1", "--out", "x.png"], ".gif or .mp4"),
        (["--bag", "no_such_bag", "--out", "x.gif"], "no bag at"),
        (["--bag", "b", "--seed", "3", "--out", "x.gif"], "go with --tree"),
        (["--bag", "b", "--task", "foraging", "--out", "x.gif"], "go with --tree"),
        (
            ["--tree", "forward", "--seed", "1", "--task", "mowing", "--out", "x.gif"],
            "--task: task must be one of",
        ),
        (["--tree", "wander1", "--seed", "1", "--out", "x.gif"], "unknown node 'wander1'"),
        (["--tree", "forward", "--seed", "1", "--library", "none.json", "--out", "x.gif"], "--library"),
        (
            ["--tree", "forward", "--seed", "1", "--every", "0", "--out", "x.gif"],
            "--every: expected a positive",
        ),
        (["--tree", "forward", "--seed", "1", "--fps", "0", "--out", "x.gif"], "--fps: expected a number of"),
        (["--tree", "forward", "--seed", "-1", "--out", "x.gif"], "--seed: expected an integer seed in [0, "),
        (["--tree", "forward", "--seed", "1", "--trial", "-1", "--out", "x.gif"], "--trial: expected an"),
    ],
)
def test_bad_input_is_one_line(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "x.gif").exists()


def test_the_pictures_text_is_dejavu_and_keeps_its_spaces(frames):
    font = text_font()
    assert font.getname()[0] == "DejaVu Sans"
    assert font.getlength("fitness so far:") > font.getlength("fitnesssofar:") + font.getlength(" ")
    image = np.asarray(render_frame(frames, 0).convert("L"))
    row = image[10 + 3 * 15 : 10 + 4 * 15, ARENA_PX + 10 :]  # the panel's fourth line: "fitness so far:"
    inked = np.flatnonzero((row < 128).any(axis=0))
    left, _, right, _ = font.getbbox("fitness so far:")
    assert abs((inked[-1] - inked[0] + 1) - (right - left)) <= 2  # drawn as wide as the text with its spaces


NEST = "sel(seq(in_nest, stop), seq(nest_left, forward_left), seq(nest_right, forward_right), forward)"
FLOCK = "sel(seq(robot_left, forward_left), seq(robot_right, forward_right), prob(forward, reverse_right))"
MIXED = (NEST, TREE, FLOCK, TREE, NEST, NEST, FLOCK, TREE, NEST)


def test_a_heterogeneous_swarm_is_animated_with_each_robots_tree_named(frames, tmp_path):
    from evolution_manager.viewing.animate import tree_legend, tree_letters
    from swarm_sim.evaluation import SwarmRequest
    from swarm_sim.model import of_trees

    layout = of_trees(MIXED, 9)
    mixed = frames_from_tree(layout, SEED, TRIAL)
    ((_, records),) = BatchEvaluator().evaluate_trials([SwarmRequest(layout, SEED, trials=TRIAL + 1)])
    np.testing.assert_array_equal(mixed.poses[-1], records[TRIAL].end_poses)
    np.testing.assert_array_equal(mixed.fitness[-1], records[TRIAL].values[: len(OBJECTIVES)])
    assert mixed.trees == MIXED and mixed.heterogeneous and mixed.to_json()["trees"] == list(MIXED)
    assert tree_letters(mixed) == list("ABCBAACBA")
    legend = tree_legend(mixed)
    assert legend[0] == "trees:" and [line[:3] for line in legend if not line.startswith(" ")][1:] == [
        "A: ", "B: ", "C: "
    ]  # fmt: skip
    assert "".join(line[3:] for line in legend[1:]).replace(" ", "").startswith("sel(seq(in_nest,stop)")
    # one tree for all: no letters, no legend, the picture as before
    assert tree_letters(frames) == [] and "trees" not in frames.to_json() and frames.trees == (TREE,) * 9
    image = np.asarray(render_frame(mixed, 50).convert("L"))
    plain = np.asarray(render_frame(replace(mixed, trees=(TREE,) * 9), 50).convert("L"))
    assert (image[:, ARENA_PX:] != plain[:, ARENA_PX:]).any() and (
        image[:, :ARENA_PX] == plain[:, :ARENA_PX]
    ).all()
    swarm = tmp_path / "swarm.json"
    swarm.write_text(json.dumps({"trees": list(MIXED)}))
    assert (
        main(["--swarm", str(swarm), "--seed", str(SEED), "--trial", "1", "--out", str(tmp_path / "s.gif")])
        == 0
    )
    assert Image.open(tmp_path / "s.gif").n_frames == len(mixed.steps)
    swarm.write_text(json.dumps({"trees": list(MIXED[:3])}))
    assert main(["--swarm", str(swarm), "--seed", "1", "--out", str(tmp_path / "t.gif")]) == 2


def test_a_foraging_trial_of_named_primitives_is_animated_at_its_length_with_the_names(tmp_path):
    library = tmp_path / "lib.json"
    library.write_text(
        json.dumps({"format": 1, "primitives": [{"name": "wander1", "tree": "prob(forward, stop)"}]})
    )
    swarm = tmp_path / "swarm.json"
    swarm.write_text(json.dumps({"trees": ["sel(got_food, wander1)"] * 8 + ["forward"]}))
    out = tmp_path / "f.gif"
    args = ["--swarm", str(swarm), "--library", str(library), "--seed", "3", "--out", str(out)]
    assert main([*args, "--task", "foraging"]) == 0
    with Image.open(out) as image:
        assert image.n_frames == 800  # 100 s of 8 Hz sensing steps
    frames = frames_from_tree(
        load_layout(swarm, 9, load_library(library)), 3, 0, replace(DEFAULT, ticks=200), load_library(library)
    )
    assert frames.trees[0] == "sel(got_food, wander1)" and len(frames.steps) == 800


def test_a_trial_on_regions_of_a_task_s_own_is_drawn_with_its_pieces():
    from evolution_manager.viewing.palette import FOOD_COLOUR, GAP_COLOUR, NEST_COLOUR
    from swarm_sim.model import Config, Piece

    nest = Piece("nest", "disc", 0.0, 900.0, 400.0)
    layout = (
        ((nest, Piece("food", "disc", -1200.0, -1000.0, 500.0), Piece("food", "below", 0.0, 0.0, 2000.0)),),
    )
    config = Config(layout=layout)
    drawn = frames_from_tree(TREE, SEED, 0, config)
    assert drawn.regions == layout[0][0] and math.isnan(drawn.gap)
    assert "regions" in drawn.to_json() and drawn.to_json()["gap"] is None  # valid JSON for the explorer
    image = render_frame(drawn, 0).convert("RGB")

    def colour_at(x: float, y: float) -> tuple[int, int, int]:
        return image.getpixel(tuple(round(v) for v in to_pixels(drawn, x, y)))

    assert colour_at(250.0, 900.0) == NEST_COLOUR  # inside the nest disc, beside its label
    assert colour_at(-1200.0, -1250.0) == FOOD_COLOUR  # inside the food disc
    assert colour_at(1500.0, -2300.0) == FOOD_COLOUR  # the strip along the lower wall
    assert colour_at(1800.0, 1800.0) == GAP_COLOUR


def test_the_explorer_packs_each_carried_food_kind_as_a_bit():
    """A multi-food trial's frames, packed for the explorer page: each robot's byte of carried kinds has bit k
    set while it carries food of kind k + 1, as the frames say."""
    import base64

    from evolution_manager.viewing.explorer import _pack
    from swarm_sim.tasks import Trials, task_named

    task = replace(task_named("multifood-arena6"), trials=Trials(ticks=60, chain_trials=5))
    tree = "sel(seq(got_food2, forward), seq(got_food3, forward), prob(forward, forward_left, forward_right))"
    frames = frames_from_tree(tree, 3, 0, task.config("paper"))
    packed = _pack(frames, 1, ["foraging"])
    n, record = frames.n_robots, frames.n_robots * 5 + 2 + 2 + 2 * frames.n_robots
    data = np.frombuffer(base64.b64decode(packed["data"]), dtype=np.uint8).reshape(-1, record)
    bits = data[:, -n:]
    expected = (np.asarray(frames.carrying, dtype=np.uint8) << np.arange(3, dtype=np.uint8)).sum(axis=2)
    np.testing.assert_array_equal(bits, expected)
    assert (bits & 0b110).any()  # kinds 2 or 3 are carried at some step, not only kind 1
