"""Objectives and descriptors on hand-worked trees, with the expected values worked out here."""

import math

import numpy as np
import pytest

from bt_controller.interpreters import N_COUNTS
from bt_controller.language import parse
from swarm_sim.core import world
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import DEFAULT, PROBES, Config, Piece
from swarm_sim.roads import reference_road
from swarm_sim.tasks import task_named

TRIALS = 4
MOVEMENT = world.VALUE_NAMES.index("movement")
DESCRIPTORS = slice(world.N_OBJECTIVES, None)
OBJECTIVE = {name: k for k, name in enumerate(world.OBJECTIVES)}


def both_roads(tree, seed, config, trials=TRIALS):
    """The reference road's values and records; the batch road must agree exactly."""
    values, records = reference_road.evaluate(parse(tree), seed, trials, config)
    result = BatchEvaluator(config).evaluate([EvaluationRequest(tree, seed, trials)])[0]
    assert result.fitness + result.descriptors == values
    return values, records


def objectives(
    initial, final, food=(0.0, 0.0), deliveries=0, radius=1000.0, spread=(0.0, 0.0), p=None, swarm=None
):
    """One robot's objectives; ``food`` and ``spread``: its food and neighbour distances (``PROBES``) at the
    trial's first and last steps; ``deliveries``: a count of kind 1, or one per food kind; ``swarm``: the
    swarm's deliveries per kind per robot (by default the robot's own, a swarm of one)."""
    p = p or DEFAULT.params()
    initial, final = np.array(initial, float), np.array(final, float)
    first, last = np.array([food[0], spread[0]]), np.array([food[1], spread[1]])
    kinds = np.array(deliveries if isinstance(deliveries, tuple) else (deliveries,), np.int64)
    swarm = kinds.astype(float) if swarm is None else np.array(swarm, float)
    return world.robot_objectives(initial, final, first, last, kinds, swarm, radius, p)


def test_objective_formulas():
    initial, final = [4000.0, 1000.0, 0.2], [1500.0, 3000.0, 0.5]
    # 300 mm from food at the start, on food at the end; food radius 1200 mm (gap 700); 3 deliveries.
    values = objectives(initial, final, (300.0, 0.0), 3, 1200.0, (1600.0, 400.0))
    density, nest, food, idensity, inest, ifood, foraging, aggregation, *kinds, biased, balanced = values
    assert density == pytest.approx((0.5 - 0.2 + 1) / 2)
    assert nest == pytest.approx(((4000 - 1500) / 5000 + 1) / 2)
    assert food == pytest.approx(((1000 - 3000) / 5000 + 1) / 2)
    # The inverse primitives (a73e4af: CBlackBoard.cpp:98-104, 247-261, 355-359).
    assert idensity == pytest.approx((0.2 - 0.5 + 1) / 2)
    assert inest == pytest.approx(((1500 - 4000) / 5000 + 1) / 2)
    assert ifood == pytest.approx((0.0 - 300.0 + 1200.0) / 2400.0)
    assert foraging == 3.0 and kinds == [3.0, 0.0, 0.0] and biased == 3.0
    assert balanced == 3.0  # one kind of food: the swarm's foraging, here a swarm of one
    # Aggregation: the mean distance from the others fell from 1600 to 400 mm.
    assert aggregation == pytest.approx(((1600 - 400) / 1600 + 1) / 2)
    assert objectives(initial, final, spread=(500.0, 1500.0))[7] == 0.0  # spread out threefold: clipped
    assert objectives(initial, final, spread=(0.0, 0.0))[7] == 0.5  # alone
    assert len(values) == len(world.OBJECTIVES)
    # A final smoothed value of 0 (7 samples in the region) scores 1; the inverse nest has no such rule.
    assert objectives(initial, [0.0, 0.0, 0.5])[1:3] == (1.0, 1.0)
    assert objectives(initial, [0.0, 0.0, 0.5])[4] == pytest.approx(((0 - 4000) / 5000 + 1) / 2)
    assert objectives([0, 0, 0.0], [1, 1, 1.2])[0] == 1.0 and objectives([0, 0, 0.0], [1, 1, 1.2])[3] == 0.0
    assert objectives([1, 1, 1.2], [1, 1, 0.0])[0] == 0.0 and objectives([1, 1, 1.2], [1, 1, 0.0])[3] == 1.0


def test_the_food_kinds_objectives_and_the_bias():
    initial, final = [4000.0, 1000.0, 0.2], [1500.0, 3000.0, 0.5]
    named = dict(zip(world.OBJECTIVES, objectives(initial, final, deliveries=(2, 5, 1)), strict=True))
    assert (named["foraging"], named["foraging1"], named["foraging2"], named["foraging3"]) == (
        8.0,
        2.0,
        5.0,
        1.0,
    )
    assert named["foraging_biased"] == 8.0  # no kind preferred: every delivery counts
    layout = ((
        (Piece("nest", "disc", 0.0, 0.0, 400.0), Piece("food", "disc", 1000.0, 0.0, 300.0),
         Piece("food2", "disc", -1000.0, 0.0, 300.0)),
    ),)  # fmt: skip
    biased = Config(layout=layout, preferred_food=2, other_food_weight=0.5).params()
    named = dict(zip(world.OBJECTIVES, objectives(initial, final, deliveries=(2, 5), p=biased), strict=True))
    assert named["foraging_biased"] == 5.0 + 0.5 * 2.0 and named["foraging3"] == 0.0
    penalised = Config(layout=layout, preferred_food=1, other_food_weight=-1.0).params()
    assert (
        objectives(initial, final, deliveries=(2, 5), p=penalised)[OBJECTIVE["foraging_biased"]] == 2.0 - 5.0
    )


def _trial(deliveries, p=None):
    """A hand-made trial's values (``world.trial_values``) by name: robots standing still, each with the given
    deliveries of each food kind (a row per robot)."""
    p = p or DEFAULT.params()
    delivered = np.array(deliveries, np.int64)
    n = delivered.shape[0]
    smoothed = np.full((n, p.regions + 1), 1000.0)
    counts, motion = np.zeros((n, N_COUNTS), np.int64), np.zeros((n, 2), np.int64)
    probes = np.full((n, 2, len(PROBES)), 500.0)
    values = world.trial_values(smoothed, smoothed, counts, motion, probes, delivered, 1000.0, p)
    return dict(zip(world.VALUE_NAMES, values, strict=True))


def test_balanced_foraging_is_the_swarms_least_kind_times_the_kinds():
    three = task_named("multifood-arena6").config().params()  # three kinds of food
    # Every kind delivered alike, 3 per kind over 3 robots, though no robot delivers every kind: 3 x 1.
    even = _trial([[2, 0, 1], [0, 3, 0], [1, 0, 2]], three)
    assert even["foraging_balanced"] == pytest.approx(3.0) and even["foraging"] == pytest.approx(3.0)
    # Kind 1 four times, the others once each: per robot (4/3, 1/3, 1/3), so 3 x 1/3, half of foraging.
    skewed = _trial([[4, 0, 0], [0, 1, 0], [0, 0, 1]], three)
    assert skewed["foraging_balanced"] == pytest.approx(1.0) and skewed["foraging"] == pytest.approx(2.0)
    # A kind nobody delivers: 0, however much of the others.
    assert _trial([[5, 5, 0], [5, 5, 0], [0, 0, 0]], three)["foraging_balanced"] == 0.0
    # Each robot is given the swarm's value, whatever it delivered itself (nothing, say).
    swarm = world.swarm_deliveries(np.array([[4, 0, 0], [0, 1, 0], [0, 0, 1]], np.int64))
    assert list(swarm) == pytest.approx([4 / 3, 1 / 3, 1 / 3])
    k = OBJECTIVE["foraging_balanced"]
    for robot in ((4, 0, 0), (0, 0, 0)):
        own = objectives([0, 0, 0.0], [0, 0, 0.0], deliveries=robot, p=three, swarm=swarm)
        assert own[k] == pytest.approx(1.0)
    # One kind of food: the swarm's foraging (the mean of the robots' deliveries).
    one = _trial([[3], [1], [2]])
    assert one["foraging_balanced"] == pytest.approx(one["foraging"]) == pytest.approx(2.0)


def _food_distance(x: float, y: float, gap: float) -> float:
    return world.region_distance(x, y, Config(gaps=(gap,)).arena_arrays(0)[0], 1)


def test_food_distance_is_the_true_distance_from_the_food_region():
    assert _food_distance(600.0, 800.0, 500.0) == 0.0  # r = 1000 = 500 + 500: on food
    assert _food_distance(300.0, 400.0, 700.0) == pytest.approx(1200.0 - 500.0)
    assert _food_distance(0.0, 0.0, 500.0) == 1000.0


def test_neighbour_distance_is_the_mean_true_distance_from_the_others():
    x, y = np.array([0.0, 300.0, 0.0]), np.array([0.0, 0.0, 400.0])
    assert world.neighbour_distance(x, y, 0) == pytest.approx((300 + 400) / 2)
    assert world.neighbour_distance(x, y, 1) == pytest.approx((300 + 500) / 2)
    assert world.neighbour_distance(x[:1], y[:1], 0) == 0.0


def test_take_probes_writes_every_probe_of_a_robot_at_the_step_asked():
    x, y = np.array([300.0, 0.0]), np.array([400.0, 0.0])
    probes = np.zeros((2, 2, len(PROBES)))
    config = Config(gaps=(700.0,))
    world.take_all_probes(x, y, config.arena_arrays(0)[0], probes, 1, config.params())
    assert probes[:, 0].tolist() == [[0.0, 0.0], [0.0, 0.0]]  # the first step's row untouched
    assert probes[0, 1].tolist() == [_food_distance(300.0, 400.0, 700.0), 500.0]
    assert probes[1, 1].tolist() == [_food_distance(0.0, 0.0, 700.0), 500.0]


def test_descriptor_formulas():
    p = DEFAULT.params()
    counts = np.array([30, 0, 5, 0, 3, 0, 2, 0], np.int64)  # 30 conditions; 10 starts
    movement, rotation, conditionality = world.robot_descriptors(counts, -12, 7, p)
    assert (movement, rotation) == ((-12 + 40) / 80, (7 + 40) / 80)
    assert conditionality == 30 / 40
    assert world.robot_descriptors(np.zeros(8, np.int64), 0, 0, p)[2] == 1.0


LONE = {
    profile: Config(profile=profile, n_robots=1, gain_step=0.0, delivery_probability=1.0)
    for profile in ("paper", "clean")
}
"""One robot with perfect wheels (gain 0.9 on both: no turning)."""
STEP = 0.9 * 50.0 * 0.125
"""mm per step at full speed."""
LAG = 1 / LONE["paper"].physics_substeps
"""The share of a step still moved at the last step's velocity (its first substep)."""


def _motor_signs(profile, tree, trials):
    """Per trial, the sign (+1 forward, -1 reverse, 0 stop) of the motors driving each of its steps.

    paper: one chain; the tick at chain step 4 (t + 1) drives the next 4 steps. clean: a chain per trial,
    ticks at steps 20 + 4 t. forward: always +1; seq(forward, reverse): F, R, R over the ticks t."""
    line = LONE[profile]
    steps = line.trial_steps

    def motor(t):
        return 1 if tree == "forward" or t % 3 == 0 else -1

    if profile == "paper":
        chain = [0 if k <= 4 else motor((k - 1) // 4 - 1) for k in range(1, trials * steps + 1)]
        return [chain[i * steps : (i + 1) * steps] for i in range(trials)]
    first = line.initial_step + line.steps_per_tick
    return [[0 if k <= first else motor((k - first - 1) // 4) for k in range(1, steps + 1)]] * trials


@pytest.mark.parametrize(
    ("profile", "tree", "movement"),
    [
        ("paper", "forward", 1.0),
        ("clean", "forward", 1.0),
        # seq(forward, reverse): movement counts ticks 0-39 (14 F, 26 R), 40-79 (13 F), 80-119 (13 F)
        ("paper", "seq(forward, reverse)", None),
        ("clean", "seq(forward, reverse)", (14 - 26 + 40) / 80),
    ],
)
def test_lone_robot_drives_as_worked_out(profile, tree, movement):
    # Each step moves STEP along the heading times the motors' sign, except that its first substep still
    # moves at the velocity of the step before, which carries over a teleport (its direction too).
    _, records = both_roads(tree, 8, LONE[profile], trials=3)
    last = np.zeros(2)  # the velocity (in steps) of the step before, as a vector
    for record, signs in zip(records, _motor_signs(profile, tree, 3), strict=True):
        (x0, y0, h0), (x1, y1, h1) = record.start_poses[0], record.end_poses[0]
        assert h1 == h0
        if profile == "clean":
            last = np.zeros(2)  # every trial is a chain of its own, from rest
        moved = np.zeros(2)
        for sign in signs:
            now = sign * np.array([math.cos(h0), math.sin(h0)])
            moved += LAG * last + (1 - LAG) * now
            last = now
        assert (x1 - x0, y1 - y0) == (
            pytest.approx(STEP * moved[0], abs=1e-9),
            pytest.approx(STEP * moved[1], abs=1e-9),
        )
        if movement is not None:
            assert record.values[MOVEMENT] == movement
    if movement is None:
        assert [round(r.values[MOVEMENT] * 80 - 40) for r in records] == [14 - 26, 13 - 27, 13 - 27]


FAR_FOOD = {profile: Config(profile=profile, gaps=(1900.0,)) for profile in ("paper", "clean")}
"""Food beyond 2400 mm: out of reach from the start square for robots that stay put or turn on the spot."""


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_condition_that_never_holds(profile):
    # seq(on_food, stop): every tick ticks the condition, which fails, and starts nothing.
    values, _ = both_roads("seq(on_food, stop)", 4, FAR_FOOD[profile])
    assert values[DESCRIPTORS] == (0.5, 0.5, 1.0)


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_selector_with_a_turn(profile):
    # sel(on_food, forward_left): one tick the condition fails and forward_left starts (running); the next
    # forward_left succeeds, and so does the selector; both ticks set the motors to forward_left: rotation 40.
    # 20 conditions and 20 starts per trial.
    values, _ = both_roads("sel(on_food, forward_left)", 4, FAR_FOOD[profile])
    assert values[DESCRIPTORS] == (0.5, 1.0, 20 / (20 + 20))


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_values_stay_in_the_unit_interval(profile):
    for tree in ["forward", "prob(forward_left, reverse, sel(robot_left, forward_right))", "reverse_left"]:
        values, records = both_roads(tree, 2, Config(profile=profile))
        for v in [values, *(r.values for r in records)]:
            named = dict(zip(world.VALUE_NAMES, v, strict=True))
            assert all(0.0 <= x <= 1.0 for name, x in named.items() if name != "foraging")
            assert named["foraging"] >= 0.0  # deliveries per robot
