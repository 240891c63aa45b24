"""Hand-worked cases of the model (``docs/model.md``), each number derived by hand in its comment.

They run on the reference road (the plain definition); ``test_roads`` checks that the batch evaluator and the
node graph's lockstep agree with it.
"""

from __future__ import annotations

import numpy as np
import pytest

from bt_controller.draws import DROPS, stream_key
from bt_controller.language import ACTION_INDEX, CONDITION_INDEX, N_CONDITIONS, parse
from bt_controller.model_settings import CLEAN, CODE_2024, CODE_2026, PAPER, PerceptionParams, Timeline
from bt_controller.robot import FootbotController, Readings, blackboard
from swarm_sim.core import world
from swarm_sim.model import Config
from swarm_sim.roads import reference_road

PAPER_CONFIG = Config(profile="paper")
CLEAN_CONFIG = Config(profile="clean")


def _movement(values: tuple[float, ...]) -> float:
    return values[world.VALUE_NAMES.index("movement")]


def _rotation(values: tuple[float, ...]) -> float:
    return values[world.VALUE_NAMES.index("rotation")]


@pytest.mark.parametrize("config", [PAPER_CONFIG, CLEAN_CONFIG], ids=["paper", "clean"])
def test_forward_has_movement_one(config):
    # Every tick ticks forward (starting it, or finishing it), so the motors are forward after all 40 ticks.
    values, records = reference_road.evaluate(parse("forward"), seed=3, trials=5, config=config)
    assert _movement(values) == 1.0
    assert _rotation(values) == 0.5
    assert all(_movement(r.values) == 1.0 for r in records)


def test_forward_then_reverse_over_a_paper_chain():
    # Ticks cycle +1 (forward starts), -1 (forward succeeds, reverse starts: the last action wins),
    # -1 (reverse succeeds) over the chain's 200 ticks; the trials hold ticks 0-39, 40-79, ... and the ticks
    # t with t % 3 == 0 among them number 14, 13, 13, 14, 13: a mean of 13.4 forward and 26.6 reverse.
    values, records = reference_road.evaluate(
        parse("seq(forward, reverse)"), seed=5, trials=5, config=PAPER_CONFIG
    )
    assert [round(_movement(r.values) * 80 - 40) for r in records] == [-12, -14, -14, -12, -14]
    assert _movement(values) == pytest.approx((13.4 - 26.6 + 40) / 80, abs=1e-12)


def test_forward_then_reverse_in_clean_trials():
    # Every clean trial starts afresh: 14 cycles begin in 40 ticks, 14 forward and 26 reverse ticks.
    values, records = reference_road.evaluate(
        parse("seq(forward, reverse)"), seed=5, trials=3, config=CLEAN_CONFIG
    )
    assert [round(_movement(r.values) * 80 - 40) for r in records] == [-12, -12, -12]
    assert _movement(values) == pytest.approx((14 - 26 + 40) / 80, abs=1e-12)


@pytest.mark.parametrize("config", [PAPER_CONFIG, CLEAN_CONFIG], ids=["paper", "clean"])
def test_forward_left_twice_has_rotation_one(config):
    values, _ = reference_road.evaluate(
        parse("seq(forward_left, forward_left)"), seed=2, trials=2, config=config
    )
    assert _rotation(values) == 1.0
    assert _movement(values) == 0.5


def _line_world(occlusion: bool):
    config = Config(delivery_probability=1.0, occlusion=occlusion)
    p = config.params()
    n = 3
    x = np.array([0.0, 300.0, 600.0])
    y = np.zeros(n)
    broadcast = np.array([[0.0, 4000.0], [1000.0, 3000.0], [2000.0, 2000.0]])  # (nest, food) per robot
    keys = np.array([stream_key(1, 0, i, DROPS) for i in range(n)], dtype=np.uint64)
    counts = np.zeros(n, np.int64)
    senders = np.zeros((n, n), np.int64)
    ranges, values = np.zeros((n, n)), np.zeros((n, n, 2))
    world.sense_step(x, y, broadcast, keys, 5, p, counts, senders, ranges, values)
    return p, counts, senders, ranges, values


def _estimate(p, count, ranges, values):
    """(nest, food, density) of a robot in neither region."""
    raw, sources = np.zeros(2), np.zeros(2, np.int64)
    density, _ = world.estimate(np.zeros(2, np.bool_), count, ranges, values, p, raw, sources)
    return raw[0], raw[1], density


def test_occlusion_three_robots_in_a_line():
    # Robots at x = 0, 300, 600 mm: the middle one's body (radius 85) cuts the segment between the outer
    # ones, which are 600 mm apart (in range) yet do not hear each other; both hear the middle one.
    p, counts, senders, ranges, values = _line_world(occlusion=True)
    assert counts.tolist() == [1, 2, 1]
    assert (
        senders[0, :1].tolist() == [1]
        and senders[1, :2].tolist() == [0, 2]
        and senders[2, :1].tolist() == [1]
    )
    assert ranges[0, 0] == 300.0 and ranges[2, 0] == 300.0
    # Robot 0 (not in the nest) hears only robot 1: nest 1000 + 300 = 1300, food 3000 + 300 = 3300.
    nest, food, density = _estimate(p, counts[0], ranges[0], values[0])
    assert (nest, food) == (1300.0, 3300.0)
    # Density: 1 / (pi (300 / 10000)^2) / (1107 x 6).
    assert density == pytest.approx(1.0 / (np.pi * 0.03**2) / 6642.0, rel=1e-12)
    # Without occlusion the outer robots hear each other too; robot 0's food estimate then comes from
    # robot 2: 2000 + 600 = 2600.
    p, counts, senders, ranges, values = _line_world(occlusion=False)
    assert counts.tolist() == [2, 2, 2]
    _, food, _ = _estimate(p, counts[0], ranges[0], values[0])
    assert food == 2600.0


def test_a_robot_beside_the_line_does_not_occlude():
    config = Config(delivery_probability=1.0)
    x = np.array([0.0, 300.0, 600.0])
    y = np.array([0.0, 86.0, 0.0])  # the middle body's edge is 1 mm beside the segment
    assert not world.occluded(x, y, 0, 2, config.params())
    y[1] = 84.0
    assert world.occluded(x, y, 0, 2, config.params())


def _readings(in_nest: bool, messages: list[tuple[float, float, float, float]]) -> Readings:
    """Readings with messages (range, bearing, nest value, food value) from senders 1, 2, ..."""
    m = np.array(messages, dtype=np.float64).reshape(len(messages), 4)
    senders = np.arange(1, len(messages) + 1, dtype=np.int64)
    return Readings(np.array([in_nest, False]), senders, m[:, 0], m[:, 1], m[:, 2:4])


def _controller(profile: int = PAPER, code: int = CODE_2024) -> FootbotController:
    controller = FootbotController()
    controller.load(parse("stop"))
    controller.start_chain(
        0,
        Timeline(profile=profile, authors_code=code),
        PerceptionParams(profile=profile, authors_code=code),
        trials=2 if profile == PAPER else 1,
    )
    return controller


def test_the_smoothed_broadcast():
    c = _controller()
    # Step 1: no sensing; the region values: not in the nest (the cap), not on food (the cap).
    assert c.on_step(1, _readings(False, [])).broadcast == (5000.0, 5000.0)
    # Step 2: raw nest 2000 + 345.6 = 2345.6, refreshed at step 2; broadcast in whole centimetres: 2340.
    assert c.on_step(2, _readings(False, [(345.6, 0.5, 2000.0, 5000.0)])).broadcast == (2340.0, 5000.0)
    # Step 3: raw nest 3000 enters the window but is not broadcast before the refresh at step 4.
    assert c.on_step(3, _readings(False, [(1000.0, 0.5, 2000.0, 5000.0)])).broadcast == (2340.0, 5000.0)
    # Step 4: mean of 2345.6, 3000, 3000 = 2781.87: 2780.
    outcome = c.on_step(4, _readings(False, [(1000.0, 0.5, 2000.0, 5000.0)]))
    assert outcome.smoothed[0] == pytest.approx((2345.6 + 6000.0) / 3)
    assert outcome.broadcast == (2780.0, 5000.0)
    assert outcome.tick is not None and outcome.tick.tick == 0  # the first tick is at step 4 under paper


def test_an_estimate_carried_over_a_teleport():
    c = _controller()
    heard = [(1000.0, 0.5, 2000.0, 5000.0)]  # raw nest 3000 at every sensing step
    for k in range(1, 161):
        outcome = c.on_step(k, _readings(False, heard))
    assert outcome.smoothed[0] == 3000.0 and outcome.broadcast[0] == 3000.0
    # Step 161: the robot was teleported into the nest; it does not sense at a trial's first step, and
    # broadcasts the stale smoothed values.
    outcome = c.on_step(161, _readings(True, []))
    assert outcome.broadcast == (3000.0, 5000.0)
    # Steps 162-164 sense 0 in the nest; the window still holds 4 samples of 3000 from the last trial:
    # 12000 / 7 = 1714.29 at the refresh of step 164, broadcast as 1710.
    c.on_step(162, _readings(True, []))
    c.on_step(163, _readings(True, []))
    outcome = c.on_step(164, _readings(True, []))
    assert outcome.smoothed[0] == pytest.approx(12000.0 / 7.0)
    assert outcome.broadcast[0] == 1710.0
    assert outcome.tick is not None and outcome.tick.tick == 40  # the chain's 41st tick


def test_the_2026_code_starts_every_trial_afresh():
    c = _controller(code=CODE_2026)
    heard = [(1000.0, 0.5, 2000.0, 5000.0)]  # raw nest 3000 at every sensing step
    for k in range(1, 161):
        outcome = c.on_step(k, _readings(False, heard))
    assert outcome.smoothed[0] == 3000.0
    # Step 161: teleported into the nest, the robot senses nothing and broadcasts its region values from
    # where it stands (footbot_bt.cpp:855-859 at 1cd2358), not the stale smoothed ones.
    assert c.on_step(161, _readings(True, [])).broadcast == (0.0, 5000.0)
    # Step 162: the trial's end emptied the window, and step 2 of every trial refreshes: one sample, 0.
    outcome = c.on_step(162, _readings(True, []))
    assert outcome.smoothed[0] == 0.0 and outcome.broadcast[0] == 0.0
    # The density's window was kept: its mean still holds the last trial's neighbour (range 1000 mm).
    assert outcome.smoothed[2] == pytest.approx(6 / 7 * 1.0 / (np.pi * 0.01) / 6642.0)


_NOWHERE = np.zeros(2, np.bool_)
"""In neither the nest nor food."""
_EMPTY = np.zeros(1, np.bool_)
"""Carrying nothing."""


def _bearings(nest: float, food: float, robot: float) -> np.ndarray:
    """The side pairs' bearings (``vocabulary.SIDES``: nest, food, robot, food2, food3)."""
    return np.array([nest, food, robot, np.nan, np.nan])


def test_robot_left_with_nobody_heard_depends_on_the_profile():
    out = np.zeros(N_CONDITIONS, np.bool_)
    cases = ((PAPER, CODE_2024, True), (CLEAN, CODE_2024, False), (PAPER, CODE_2026, False))
    for profile, code, expected in cases:
        blackboard(
            _NOWHERE,
            np.full(2, 5000.0),
            np.full(5, np.nan),
            False,
            _EMPTY,
            PerceptionParams(profile=profile, authors_code=code),
            out,
        )
        assert out[CONDITION_INDEX["robot_left"]] == expected
        assert not out[CONDITION_INDEX["robot_right"]]


def test_nest_side_needs_an_estimate_strictly_inside_the_cap():
    out = np.zeros(N_CONDITIONS, np.bool_)
    p = PerceptionParams()
    blackboard(_NOWHERE, np.array([4999.0, 5000.0]), _bearings(0.3, 0.3, -0.1), True, _EMPTY, p, out)
    assert out[CONDITION_INDEX["nest_left"]] and not out[CONDITION_INDEX["food_left"]]
    assert out[CONDITION_INDEX["robot_right"]]
    blackboard(
        _NOWHERE, np.array([2000.0, 2000.0]), _bearings(0.0, -0.2, 0.0), True, np.array([True]), p, out
    )
    assert not out[CONDITION_INDEX["nest_left"]] and not out[CONDITION_INDEX["nest_right"]]  # bearing 0
    assert out[CONDITION_INDEX["food_right"]] and out[CONDITION_INDEX["robot_left"]]
    assert out[CONDITION_INDEX["got_food"]]  # the carrying flag, as given


def test_nest_objective_is_one_when_the_final_smoothed_nest_value_is_zero():
    p = PAPER_CONFIG.params()
    density, nest, food, *_ = world.robot_objectives(
        np.array([3000.0, 2000.0, 0.1]),
        np.array([0.0, 4000.0, 0.3]),
        np.zeros(2),
        np.zeros(2),
        np.zeros(1, np.int64),
        np.zeros(1),
        1000.0,
        p,
    )
    assert nest == 1.0
    assert food == pytest.approx(0.5 * ((2000.0 - 4000.0) / 5000.0 + 1.0))
    assert density == pytest.approx(0.5 * (0.3 - 0.1 + 1.0))


def test_clean_trials_stand_still_until_the_initial_step_and_tick_40_times():
    c = _controller(CLEAN)
    ticks = [k for k in range(1, 177) if c.on_step(k, _readings(False, [])).tick is not None]
    assert ticks[0] == 20 and ticks[-1] == 176 and len(ticks) == 40


FORWARD, REVERSE, STOP_ACTION = ACTION_INDEX["forward"], ACTION_INDEX["reverse"], ACTION_INDEX["stop"]


def _ground(in_nest: bool, on_food: bool) -> Readings:
    """Readings of the ground sensor only (nobody heard)."""
    none = np.zeros(0)
    return Readings(np.array([in_nest, on_food]), np.zeros(0, dtype=np.int64), none, none, np.zeros((0, 2)))


def _forager(profile: int = PAPER) -> FootbotController:
    controller = FootbotController()
    controller.load(parse("sel(seq(got_food, reverse), forward)"))
    controller.start_chain(0, Timeline(profile=profile), PerceptionParams(profile=profile), trials=1)
    return controller


def test_a_robot_started_on_food_delivers_on_its_first_sensed_step_in_the_nest():
    c = _forager()
    # Step 1, the trial's first: no sensing, but the start pose on food sets the carrying flag (a73e4af:
    # footbot_bt.cpp:134-137 -> CBlackBoard.cpp:140-143).
    first = c.on_step(1, _ground(False, True))
    assert first.carrying == (True,) and first.deliveries == (0,)
    # Steps 2-3 away from both regions: still carrying; step 4 ticks: got_food holds, reverse starts.
    c.on_step(2, _ground(False, False))
    c.on_step(3, _ground(False, False))
    tick = c.on_step(4, _ground(False, False))
    assert tick.carrying == (True,) and tick.tick is not None and tick.action == tick.tick.started == REVERSE
    # Step 5: the first sensed step in the nest delivers and clears the flag (footbot_bt.cpp:249-254).
    delivered = c.on_step(5, _ground(True, False))
    assert (delivered.carrying, delivered.deliveries) == ((False,), (1,))
    # In the nest there is nothing to deliver any more.
    assert c.on_step(6, _ground(True, False)).deliveries == (1,)
    assert c.on_step(7, _ground(True, False)).carrying == (False,)
    # Step 8 ticks: reverse, resumed, succeeds (the motors stay reverse); step 12's fresh tick finds got_food
    # false in the nest and goes forward.
    assert c.on_step(8, _ground(True, False)).action == REVERSE
    for k in range(9, 12):
        c.on_step(k, _ground(True, False))
    tick = c.on_step(12, _ground(True, False))
    assert tick.tick is not None and tick.action == FORWARD


def test_a_robot_started_in_the_nest_delivers_nothing_at_the_trial_start():
    c = _forager()
    assert (c.on_step(1, _ground(True, False)).carrying, c.on_step(2, _ground(True, False)).deliveries) == (
        (False,), (0,)
    )  # fmt: skip


def test_a_food_crossing_between_two_ticks_still_shows_as_got_food_at_the_next_tick():
    c = FootbotController()
    c.load(parse("seq(got_food, reverse)"))
    c.start_chain(0, Timeline(), PerceptionParams(), trials=1)
    for k in range(1, 4):
        c.on_step(k, _ground(False, False))
    tick = c.on_step(4, _ground(False, False))
    assert tick.tick is not None and tick.tick.status == 1 and tick.action == STOP_ACTION  # nothing carried
    # Steps 5-7: the robot crosses the food region's edge at step 6 only (sensing at 8 Hz, ticks at 2 Hz).
    c.on_step(5, _ground(False, False))
    crossing = c.on_step(6, _ground(False, True))
    assert crossing.carrying == (True,) and crossing.tick is None
    c.on_step(7, _ground(False, False))
    tick = c.on_step(8, _ground(False, False))  # on_food is false at the tick, got_food true
    assert tick.tick is not None and tick.action == REVERSE and tick.carrying == (True,)


def test_the_carrying_flag_and_deliveries_are_cleared_at_a_trials_last_step():
    c = FootbotController()
    c.load(parse("forward"))
    c.start_chain(0, Timeline(), PerceptionParams(), trials=2)
    for k in range(1, 161):
        on_food, in_nest = k % 20 == 10, k % 20 == 15  # a delivery every 20 steps from step 15
        outcome = c.on_step(k, _ground(in_nest, on_food))
    assert (outcome.carrying, outcome.deliveries) == ((False,), (8,))  # the trial's count, at its last step
    # Step 161, the second trial's first: counted from 0 again, carrying only if it starts on food.
    outcome = c.on_step(161, _ground(False, False))
    assert (outcome.carrying, outcome.deliveries) == ((False,), (0,))
