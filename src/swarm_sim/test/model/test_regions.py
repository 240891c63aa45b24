"""Regions as pieces of ground (swarm_sim.model.regions): the papers' arena as a layout, what the compiled
ground sensor and distances read of each shape, layouts through configurations and JSON, and the markers the
simulator draws of them."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from visualization_msgs.msg import Marker

from swarm_sim.core import world
from swarm_sim.errors import ConfigError
from swarm_sim.model import DEFAULT, Config, Piece, concentric, config_from_dict
from swarm_sim.model.regions import distance, layout_table
from swarm_sim.nodes.visualisation import arena_markers

NEST = Piece("nest", "disc", 0.0, 600.0, 400.0)
LAYOUT = (
    ((NEST, Piece("food", "disc", 0.0, -700.0, 450.0), Piece("food", "below", 0.0, 0.0, 1500.0)),),
    ((NEST, Piece("food", "beyond", 300.0, 0.0, 1800.0)), (NEST, Piece("food", "above", 0.0, 0.0, 1200.0))),
)
"""Two configurations: one entry (a food disc and a strip along the wall), then two entries in turn."""


def test_the_papers_arena_is_the_default_layout_and_the_same_bits_as_its_radii():
    assert DEFAULT.arena_layout == concentric(500.0, (500.0, 700.0))
    entry, scale = DEFAULT.arena_arrays(5)  # the second block: the 700 mm gap
    assert entry[1, 4] == 500.0 + 700.0 and scale == 1200.0
    assert "layout" not in DEFAULT.as_dict()  # a run's config.json in the papers' arena is what it was


@pytest.mark.parametrize(
    ("x", "y", "expected"),
    [
        (0.0, 600.0, (True, False)),  # the nest's centre
        (0.0, 1000.0, (False, False)),  # on the nest's rim: outside (strictly closer than the radius)
        (0.0, -700.0, (False, True)),  # the food disc
        (2000.0, -1600.0, (False, True)),  # the strip along the lower wall
        (2000.0, 0.0, (False, False)),
    ],
)
def test_the_ground_sensor_reads_every_piece_of_a_kind(x, y, expected):
    table, _ = layout_table(LAYOUT)
    inside = np.zeros(2, np.bool_)
    world.ground(x, y, table[0, 0], inside)
    assert tuple(inside) == expected


@pytest.mark.parametrize("entry", [0, 1])
def test_compiled_distances_are_the_pieces_distances(entry):
    table, scale = layout_table(LAYOUT)
    rng = np.random.default_rng(entry)
    pieces = LAYOUT[1][entry]
    for x, y in rng.uniform(-2400.0, 2400.0, (50, 2)):
        assert world.region_distance(x, y, table[1, entry], 1) == pytest.approx(
            distance(pieces, "food", x, y)
        )
        assert world.region_distance(x, y, table[1, entry], 0) == pytest.approx(
            distance(pieces, "nest", x, y)
        )
    assert scale[1, entry] == distance(pieces, "food", 0.0, 600.0)  # from the nest's centre


def test_trials_go_through_configurations_by_block_and_entries_by_trial():
    config = Config(layout=LAYOUT)
    assert [config.arena_of_trial(k) for k in (0, 4, 5, 9, 10)] == [0, 0, 1, 1, 0]
    assert config.arena_entry(0) == config.arena_entry(3) == LAYOUT[0][0]
    assert [config.arena_entry(k)[1].shape for k in (5, 6, 7)] == ["beyond", "above", "beyond"]
    assert math.isnan(config.gap(0))
    assert config_from_dict(config.as_dict()) == config  # through a run's config.json


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"gaps": (600.0,)}, "nest_radius and gaps describe the 2023 arena only"),
        ({"layout": ((),)}, "at least one arena entry per configuration"),
        ({"layout": (((NEST,),),)}, "arena entry 0 has no food piece"),
        ({"layout": (((NEST, Piece("food", "disc", 0.0, 600.0, 100.0)),),)}, "lies on food"),
        ({"layout": (((NEST, Piece("food", "ring", 0.0, 0.0, 100.0)),),)}, "shape must be one of disc"),
        ({"layout": (((NEST, Piece("food", "disc", 0.0, 2600.0, 100.0)),),)}, "lies outside the arena"),
        ({"layout": (((NEST, Piece("food", "disc", 0.0, -900.0, math.nan)),),)}, "radius must be a finite"),
    ],
)
def test_a_bad_layout_is_refused_in_one_line(change, expected):
    with pytest.raises(ConfigError, match=expected) as caught:
        replace(Config(layout=LAYOUT), **change)
    assert "\n" not in str(caught.value)


def test_the_markers_draw_every_piece_of_the_trial_and_follow_its_entry():
    config = Config(layout=LAYOUT)
    stamp = Time(sec=1)
    first = [m for m in arena_markers(config, 0, stamp).markers if m.ns in ("nest", "food")]
    assert [(m.ns, m.type) for m in first] == [
        ("nest", Marker.CYLINDER),
        ("food", Marker.CYLINDER),
        ("food", Marker.TRIANGLE_LIST),
    ]
    assert (first[0].pose.position.y, first[0].scale.x) == (0.6, 0.8)
    strip = first[2].points
    assert max(p.y for p in strip) == pytest.approx(-1.5) and min(p.y for p in strip) == pytest.approx(-2.45)
    ring = next(m for m in arena_markers(config, 5, stamp).markers if m.ns == "food")
    inner = min(math.hypot(p.x - 0.3, p.y) for p in ring.points)
    assert inner == pytest.approx(1.8)
    above = next(m for m in arena_markers(config, 6, stamp).markers if m.ns == "food")
    assert min(p.y for p in above.points) == pytest.approx(1.2)


# -- start formations (world.place_robots, Config.formation) ---------------------------------------------


def _placed(config: Config, trial: int = 0, seed: int = 4) -> np.ndarray:
    from swarm_sim.core import setup_chain

    chain = setup_chain(seed, 0, config)
    n = config.n_robots
    x, y, h = np.zeros(n), np.zeros(n), np.zeros(n)
    entry, _ = config.arena_arrays(trial)
    world.place_robots(x, y, h, chain.position_keys, chain.heading_keys, trial, config.params(), entry)
    return np.stack([x, y, h], axis=1)


HALF_PLANES = (((Piece("nest", "above", 0.0, 0.0, 300.0), Piece("food", "below", 0.0, 0.0, 300.0)),),)
"""The authors' arena 4: nest and food are half-planes, with no disc to start around."""


def test_the_random_formation_is_the_papers_start_square():
    poses = _placed(DEFAULT)
    assert (np.abs(poses[:, :2]) <= DEFAULT.start_half).all() and len(set(poses[:, 0])) == 9


def test_a_lattice_puts_robots_1_m_apart_with_drawn_headings():
    poses = _placed(Config(formation="lattice"))
    assert sorted(set(poses[:, 0])) == sorted(set(poses[:, 1])) == [-1000.0, 0.0, 1000.0]
    assert (poses[1, :2] == (-1000.0, 0.0)).all()  # robot i * 3 + j at (i - 1, j - 1) m
    assert len(set(poses[:, 2])) == 9
    four = _placed(Config(formation="lattice", n_robots=4))
    assert sorted(set(four[:, 0])) == [-500.0, 500.0]  # half a metre off for an even side


def test_nest_and_localised_starts_gather_around_their_discs():
    nest = _placed(Config(layout=LAYOUT, formation="nest"))
    assert (np.abs(nest[:, 0]) <= 500.0).all() and (np.abs(nest[:, 1] - 600.0) <= 500.0).all()
    localised = _placed(Config(layout=LAYOUT[:1], formation="localised"))
    even, odd = localised[0::2], localised[1::2]
    assert (np.abs(even[:, 1] + 700.0) <= 500.0).all()  # around the food disc at (0, -700)
    assert (np.abs(odd[:, 1] - 600.0) <= 500.0).all()  # around the nest at (0, 600)


def test_two_robots_face_each_other():
    poses = _placed(Config(formation="two_robots", n_robots=2, chain_trials=1))
    assert poses.tolist() == [[300.0, 250.0, -math.pi / 2], [-300.0, -250.0, math.pi / 2]]


@pytest.mark.parametrize(
    ("settings", "expected"),
    [
        ({"formation": "circle"}, "formation must be one of random, lattice"),
        ({"formation": "lattice", "n_robots": 8}, "a square number of robots, got n_robots = 8"),
        ({"formation": "lattice", "n_robots": 36}, "beyond arena_half"),
        ({"formation": "two_robots"}, "needs n_robots = 2 and chain_trials = 1"),
        ({"formation": "localised"}, "arena entry 0 has no food disc"),  # the papers' arena (their arena 1)
        ({"formation": "nest", "layout": HALF_PLANES}, "arena entry 0 has no nest disc"),  # their arena 4
    ],
)
def test_a_formation_the_arena_cannot_hold_is_refused_in_one_line(settings, expected):
    with pytest.raises(ConfigError, match=expected) as caught:
        Config(**settings)
    assert "\n" not in str(caught.value)


def test_a_formation_runs_alike_on_both_roads():
    from bt_controller.language import parse
    from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
    from swarm_sim.roads import reference_road

    config = Config(layout=LAYOUT[:1], formation="localised", ticks=10)
    tree = "sel(seq(got_food, nest_left, forward_left), seq(food_right, forward_right), forward)"
    ((result, records),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(tree, 2, 2)])
    values, reference = reference_road.evaluate(parse(tree), 2, 2, config)
    assert result.fitness + result.descriptors == values
    assert all((a.start_poses == b.start_poses).all() for a, b in zip(records, reference, strict=True))
    assert (np.abs(records[0].start_poses[0::2, 1] + 700.0) <= 500.0).all()
