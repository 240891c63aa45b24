"""Tasks as data: the registry, task files and their errors, and an edited task's world on both roads."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bt_controller.interpreters import pack
from bt_controller.language import (
    CONDITION_TABLE,
    CONDITIONS_2023,
    CONDITIONS_2024,
    SIDES,
    parse,
    random_trees,
)
from swarm_sim.core import kernel
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.evaluation.cli import run as evaluate_run
from swarm_sim.model import DEFAULT, Config, arena_entries
from swarm_sim.roads import reference_road
from swarm_sim.tasks import (
    FORAGING,
    PRIMITIVES,
    Arena,
    Region,
    Robots,
    TaskError,
    TaskSpec,
    Trials,
    arena_task,
    resolve_task,
    task_from_record,
    task_from_yaml,
    task_named,
    task_names,
    task_to_mapping,
    task_to_record,
    task_to_yaml,
    world_parameters,
)

EDITED = replace(
    FORAGING,
    name="small-foraging",
    arena=Arena(half_size=1800.0),
    regions=(Region("nest", "disc", (400.0,)), Region("food", "beyond", (900.0,))),
    trials=Trials(ticks=14, chain_trials=2),
    robots=Robots(count=5, start_half_size=800.0),
)
"""The foraging task with its trial length, arena size, robot count and regions edited."""

DISCS = replace(
    EDITED,
    name="two-discs",
    arena=Arena(half_size=1800.0, trial_entries=2),
    regions=(
        Region("nest", "disc", (400.0,), ((0.0, 600.0),)),
        Region("food", "disc", (450.0, 350.0, 450.0, 350.0), ((0.0, -700.0), (700.0, -300.0)) * 2),
        Region("food", "below", (1500.0,)),
    ),
)
"""Regions unlike the papers': a nest disc off the centre, food as a disc that moves from trial to trial of
a block (two entries per configuration, two configurations of radii) and a strip along a wall."""


def test_the_registered_tasks_are_the_two_papers_worlds_unchanged():
    assert task_names()[:2] == ("primitives", "foraging")
    for profile in ("paper", "clean"):
        assert PRIMITIVES.config(profile) == replace(DEFAULT, profile=profile)
        assert FORAGING.config(profile) == replace(DEFAULT, profile=profile, ticks=200)
    assert PRIMITIVES.nodes.conditions == CONDITIONS_2023 and FORAGING.nodes.conditions == CONDITIONS_2024
    assert PRIMITIVES.objectives == ("density", "nest", "food") and FORAGING.objectives == ("foraging",)
    assert world_parameters(PRIMITIVES.config()) == {}
    assert world_parameters(EDITED.config())["n_robots"] == 5


@pytest.mark.parametrize("task", [PRIMITIVES, FORAGING, EDITED, DISCS], ids=lambda t: t.name)
def test_a_task_file_reproduces_its_task(task, tmp_path):
    text = task_to_yaml(task)
    assert task_from_yaml(text) == task
    (tmp_path / "t.yaml").write_text(text)
    assert resolve_task(str(tmp_path / "t.yaml")) == task
    assert task_from_record(json.loads(json.dumps(task_to_record(task)))) == task
    assert task_to_record(task) == (task.name if task in (PRIMITIVES, FORAGING) else task_to_mapping(task))


def test_a_file_may_leave_out_every_key_but_the_name():
    task = task_from_yaml("name: mine\n")
    assert task.config() == DEFAULT and task.objectives == ()


BAD_FILES = [
    ("robots: {cout: 3}", "unknown key robots.cout (did you mean robots.count?)"),
    ("trials: {tick: 3}", "unknown key trials.tick (did you mean trials.ticks?)"),
    ("robots: {count: nine}", "robots.count must be an integer, got 'nine'"),
    ("communication: {occlusion: 1}", "communication.occlusion must be true or false, got 1"),
    ("arena: {half_size: .nan}", "arena.half_size must be a finite number, got nan"),
    ("arena: 3", "arena must be a mapping of keys, got 3"),
    ("regions: {kind: nest}", "regions must be a list"),
    ("trials: {ticks: 0}", "trials.ticks must be a positive integer, got 0"),
    (
        "regions: [{kind: nest, shape: disc, radius: [500]}, {kind: food, shape: beyond, radius: [3000]}]",
        "regions[1].radius 3000.0 puts the region's edge outside the arena",
    ),
    (
        "regions: [{kind: nest, shape: disc, radius: [500]}, {kind: food, shape: disc, radius: [300], "
        "centre: [0, 2600]}]",
        "regions[1].centre [0, 2600] lies outside the arena",
    ),
    (
        "regions: [{kind: nest, shape: disc, radius: [500]}, {kind: food, shape: below, radius: [300], "
        "centre: [5, 0]}]",
        "regions[1].centre must be [0, 0] for a half-plane (below)",
    ),
    (
        "regions: [{kind: nest, shape: disc, radius: [500]}, {kind: food, shape: disc, radius: [300], "
        "centre: [100, 0]}]",
        "arena entry 0: the nest's reference point (0, 0) lies on food",
    ),
    (
        "arena: {trial_entries: 2}\nregions: [{kind: nest, shape: disc, radius: [500]}, "
        "{kind: food, shape: beyond, radius: [900, 1000, 1100]}]",
        "3 arena entries do not make whole configurations of arena.trial_entries = 2",
    ),
    (
        "regions: [{kind: nest, shape: disc, radius: [500]}, {kind: lava, shape: beyond, radius: [900]}]",
        "regions[1].kind must be one of nest, food, food2, food3, got 'lava'",
    ),
    ("regions: [{kind: nest, shape: disc, radius: [500]}]", "the task has no food region"),
    (
        "regions: [{kind: nest, shape: disc, radius: [500]}, {kind: food3, shape: disc, radius: [300], "
        "centre: [1000, 0]}]",
        "the task has no food region; expected at least one (a nest, and food of every kind up to its "
        "highest, food3)",
    ),
    (
        "nodes: {conditions: [on_food2]}",
        "nodes.conditions: on_food2 reads the food2 region, which the task does not",
    ),
    (
        "scoring: {preferred_food: 2}",
        "scoring.preferred_food must be 0 (none) or a food kind of the task, 1 to 1",
    ),
    ("robots: {count: 90}", "robots.count = 90 robots of radius 85.036758 do not fit"),
    ("robots: {start_half_size: 2400}", "robots.start_half_size 2400.0 lets robots of radius"),
    ("objectives: [fooding]", "objectives: unknown objective 'fooding' (did you mean food?)"),
    ("nodes: {conditions: [in_nes]}", "nodes.conditions: unknown condition 'in_nes' (did you mean in_nest?)"),
    ("nodes: {actions: []}", "nodes.actions must name at least one action"),
    ("name: other", "the key 'name' appears twice"),
    ("robots: [", "not YAML at line"),
]


@pytest.mark.parametrize(("body", "expected"), BAD_FILES, ids=[e for _, e in BAD_FILES])
def test_a_bad_task_file_is_refused_in_one_line_naming_the_key(body, expected):
    with pytest.raises(TaskError) as caught:
        task_from_yaml(f"name: x\n{body}\n", "f.yaml")
    message = str(caught.value)
    assert message.startswith("f.yaml: ") and expected in message and "\n" not in message


def test_an_unknown_task_name_says_the_names_and_the_nearest():
    with pytest.raises(
        TaskError, match=r"one of primitives, foraging.*got 'foragin' \(did you mean foraging\?\)"
    ):
        task_named("foragin")


@settings(max_examples=200, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_any_edit_of_a_task_file_gives_a_task_or_one_line(data):
    mapping = task_to_mapping(FORAGING)
    values = st.one_of(
        st.none(), st.booleans(), st.integers(-5, 10**6), st.floats(allow_nan=True), st.text(max_size=5),
        st.lists(st.floats(-100, 5000), max_size=3),
        st.dictionaries(st.text(max_size=4), st.integers(), max_size=2),
    )  # fmt: skip
    for _ in range(data.draw(st.integers(1, 3))):
        section = data.draw(st.sampled_from(sorted(mapping)))
        if isinstance(mapping[section], dict) and mapping[section]:
            key = data.draw(st.sampled_from(sorted(mapping[section])))
            mapping[section][key] = data.draw(values)
        else:
            mapping[section] = data.draw(values)
    try:
        task = task_from_yaml(yaml.safe_dump(mapping))
    except TaskError as error:
        assert "\n" not in str(error)
    else:
        assert task_from_yaml(task_to_yaml(task)) == task


def test_the_kernels_bearing_skip_follows_the_conditions_table():
    for row in CONDITION_TABLE:
        packed = pack([parse(f"seq({row.name}, stop)")])
        tree = packed.op, packed.arg
        read = kernel._sides_read(*tree)
        expected = [side == row.side for side in SIDES]
        assert list(read) == expected, row.name


def test_an_edited_task_changes_the_world_and_both_roads_agree():
    config = EDITED.config("paper")
    assert (config.n_robots, config.ticks, config.arena_half, config.nest_radius, config.gaps) == (
        5, 14, 1800.0, 400.0, (500.0,),
    )  # fmt: skip
    texts = random_trees(7, 4)
    requests = [EvaluationRequest(t, 50 + k, 3) for k, t in enumerate(texts)]
    batch = BatchEvaluator(config).evaluate_trials(requests)
    unedited = BatchEvaluator(FORAGING.config("paper")).evaluate(requests)
    for request, (result, records), other in zip(requests, batch, unedited, strict=True):
        values, reference = reference_road.evaluate(parse(request.tree), request.seed, request.trials, config)
        assert result.fitness + result.descriptors == values, request.tree
        assert all((a.end_poses == b.end_poses).all() for a, b in zip(records, reference, strict=True))
        assert records[0].start_poses.shape[0] == 5
        assert result != other


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_regions_of_a_task_s_own_travel_as_a_layout_and_both_roads_agree_on_them(profile):
    config = DISCS.config(profile)
    assert config.layout and config.gaps == DEFAULT.gaps and np.isnan(config.gap(0))
    entries = [config.arena_entry(k) for k in range(4)]  # trial k of a block takes entry k % 2
    assert [e[1].x for e in entries] == [0.0, 700.0, 0.0, 700.0]
    assert [config.arena_entry(k)[1].radius for k in (0, 1, 2, 3)] == [450.0, 350.0, 450.0, 350.0]
    assert [config.arena_entry(k)[1].radius for k in (2, 3)] == [450.0, 350.0]
    texts = ["sel(seq(got_food, nest_left, forward_left), seq(food_right, forward_right), forward)"]
    texts += random_trees(4, 4)
    requests = [EvaluationRequest(t, 60 + k, 4) for k, t in enumerate(texts)]
    batch = BatchEvaluator(config).evaluate_trials(requests)
    edited = BatchEvaluator(EDITED.config("paper")).evaluate(requests)
    for request, (result, records), other in zip(requests, batch, edited, strict=True):
        values, reference = reference_road.evaluate(parse(request.tree), request.seed, request.trials, config)
        assert result.fitness + result.descriptors == values, request.tree
        assert all((a.end_poses == b.end_poses).all() for a, b in zip(records, reference, strict=True))
        assert result != other


def test_evaluate_takes_a_task_file_and_a_shown_foraging_file_gives_the_names_result(tmp_path):
    shown = subprocess.run(
        [sys.executable, "-m", "swarm_sim.tasks.cli", "show", "foraging"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    (tmp_path / "f.yaml").write_text(shown)
    common = ["--tree", "sel(seq(got_food, forward_left), forward)", "--trials", "2", "--seed", "3"]
    by_name = evaluate_run([*common, "--task", "foraging"])
    assert evaluate_run([*common, "--task", str(tmp_path / "f.yaml")]) == by_name
    (tmp_path / "small.yaml").write_text(task_to_yaml(EDITED))
    small = json.loads(evaluate_run([*common, "--task", str(tmp_path / "small.yaml")]))
    assert small["task"]["robots"]["count"] == 5 and small["fitness"] != json.loads(by_name)["fitness"]


def test_the_task_command_lists_shows_and_checks(tmp_path):
    def task(*argv: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "swarm_sim.tasks.cli", *argv], capture_output=True, text=True
        )

    listed = task("list")
    assert listed.returncode == 0 and listed.stdout.splitlines()[1].startswith(
        "foraging: 100 s trials, 9 robots"
    )
    (tmp_path / "good.yaml").write_text(task("show", "primitives").stdout)
    (tmp_path / "bad.yaml").write_text("name: x\nrobots: {cout: 3}\n")
    checked = task("check", str(tmp_path / "good.yaml"), str(tmp_path / "bad.yaml"))
    assert checked.returncode == 2
    assert checked.stdout == f"{tmp_path / 'good.yaml'}: task 'primitives', ok\n"
    assert checked.stderr.count("\n") == 1 and "unknown key robots.cout" in checked.stderr
    missing = task("show", "nowhere")
    assert missing.returncode == 2 and missing.stderr.count("\n") == 1


def test_a_config_built_by_hand_is_no_task_but_a_task_with_the_same_world_gives_the_same_config():
    assert replace(PRIMITIVES, name="copy").config() == Config()
    assert TaskSpec("copy").config("clean") == Config(profile="clean")
    assert np.isclose(EDITED.config().gap(0), 500.0)


@pytest.mark.parametrize("layout", [1, 2, 3, 4, 7, 8])
def test_the_authors_single_food_arenas_are_tasks_whose_files_reproduce_them(layout, tmp_path):
    task = arena_task(FORAGING, layout)
    assert task.name == f"foraging-arena{layout}" and task.robots.start_half_size == 1500.0
    assert task_from_yaml(task_to_yaml(task)) == task
    config = task.config("paper")
    for trial in range(10):  # every trial's regions are the layout's entry for its gap and place in the block
        gap = (500.0, 700.0)[trial // 5]
        row = arena_entries(layout, gap=gap)
        assert config.arena_entry(trial) == row[(trial % 5) % len(row)]
    assert config.layout == () if layout == 1 else config.layout  # arena 1 is the papers' arena


def test_an_arena_task_runs_alike_on_both_roads_and_the_command_shows_it(tmp_path):
    task = replace(arena_task(FORAGING, 8), trials=Trials(ticks=12, chain_trials=5))
    config = task.config("paper")
    tree = "sel(seq(got_food, nest_left, forward_left), seq(food_right, forward_right), forward)"
    ((result, records),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(tree, 5, 3)])
    values, reference = reference_road.evaluate(parse(tree), 5, 3, config)
    assert result.fitness + result.descriptors == values
    assert all((a.end_poses == b.end_poses).all() for a, b in zip(records, reference, strict=True))
    command = [sys.executable, "-m", "swarm_sim.tasks.cli", "arena"]
    shown = subprocess.run([*command, "3"], capture_output=True, text=True, check=True)
    assert task_from_yaml(shown.stdout) == arena_task(FORAGING, 3)
    refused = subprocess.run([*command, "9"], capture_output=True, text=True)
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1
    assert "arena layout 9 needs a bias" in refused.stderr


def test_docs_tasks_md_gives_every_key_of_a_task():
    """The schema table of ``docs/tasks.md`` names every key a task file holds."""
    docs = (Path(__file__).resolve().parents[4] / "docs" / "tasks.md").read_text()
    mapping = task_to_mapping(FORAGING)
    keys = [
        f"{section}.{key}" for section, value in mapping.items() if isinstance(value, dict) for key in value
    ]
    keys += [f"regions[k].{key}" for key in mapping["regions"][0]]
    keys += [key for key, value in mapping.items() if not isinstance(value, dict) and key != "regions"]
    # a key in backticks, or (in a row that gives several of a section) its last part
    missing = [key for key in keys if f"`{key}`" not in docs and f"`{key.rsplit('.', 1)[-1]}`" not in docs]
    assert not missing, f"docs/tasks.md does not give {', '.join(missing)}"
