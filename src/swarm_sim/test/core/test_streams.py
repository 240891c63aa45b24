"""Stream keys: one per (seed, chain, robot, purpose), chains replayable alone; start poses by the placement
rule."""

import numpy as np

from bt_controller.draws import DROPS, PURPOSES, TREE, chain_keys, root_key, stream_key
from swarm_sim.core import chain_plan, setup_chain, world
from swarm_sim.model import DEFAULT


def test_chain_keys_match_the_documented_derivation():
    keys = chain_keys(np.uint64(root_key(7)), 3, 9)
    assert keys.shape == (len(PURPOSES), 9) and keys.dtype == np.uint64
    for robot in range(9):
        for purpose in range(len(PURPOSES)):
            assert keys[purpose, robot] == stream_key(7, 3, robot, purpose)


def test_keys_are_all_distinct():
    seen = {int(stream_key(s, t, r, u)) for s in (0, 1) for t in range(4) for r in range(9) for u in range(5)}
    assert len(seen) == 2 * 4 * 9 * 5


def test_a_chain_replays_alone_and_depends_on_its_index():
    a = setup_chain(11, 1)
    b = setup_chain(11, 1)
    assert (a.gains == b.gains).all() and (a.position_keys == b.position_keys).all()
    assert (a.drop_keys == b.drop_keys).all() and (a.tree_keys == b.tree_keys).all()
    c = setup_chain(11, 0)
    assert not (a.position_keys == c.position_keys).any()
    assert a.drop_keys[0] == stream_key(11, 1, 0, DROPS) and a.tree_keys[8] == stream_key(11, 1, 8, TREE)
    assert (a.first_trial, a.gap, c.gap) == (5, 700.0, 500.0)


def test_chain_plans_cover_the_trials():
    assert chain_plan(10) == [(0, 5), (1, 5)]
    assert chain_plan(7) == [(0, 5), (1, 2)]
    assert chain_plan(1) == [(0, 1)]


def _placed(seed: int, chain: int, position: int, x=None, y=None, heading=None):
    s = setup_chain(seed, chain)
    n = DEFAULT.n_robots
    x = np.zeros(n) if x is None else x
    y = np.zeros(n) if y is None else y
    heading = np.zeros(n) if heading is None else heading
    world.place_robots(
        x, y, heading, s.position_keys, s.heading_keys, position, DEFAULT.params(), DEFAULT.arena_arrays(0)[0]
    )
    return x, y, heading, s


def test_start_poses_gains_and_headings_follow_the_model():
    r = DEFAULT.robot_radius
    for chain in range(30):
        x, y, h, s = _placed(123, chain, 0)
        assert ((np.abs(x) <= 1000.0) & (np.abs(y) <= 1000.0)).all()
        assert ((-np.pi <= h) & (h < np.pi)).all()
        # (90 + U{0..19}) / 100: whole hundredths from 0.90 to 1.09.
        assert np.allclose(s.gains * 100, np.round(s.gains * 100))
        assert ((s.gains >= 0.9 - 1e-12) & (s.gains <= 1.09 + 1e-12)).all()
        d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
        assert (d[np.triu_indices(9, 1)] >= 2 * r).all()


def test_a_teleport_avoids_robots_where_they_stand():
    x, y, h, _ = _placed(5, 0, 0)
    x2, y2, _, _ = _placed(5, 0, 1, x.copy(), y.copy(), h.copy())
    assert not np.array_equal(x, x2)
    d = np.hypot(x2[:, None] - x2[None, :], y2[:, None] - y2[None, :])
    assert (d[np.triu_indices(9, 1)] >= 2 * DEFAULT.robot_radius).all()


def test_a_robot_with_no_room_keeps_its_pose_or_stays_where_it_was_created():
    # A 2 mm start square: once robot 0 stands in it, every try of every other robot overlaps robot 0.
    tight = DEFAULT.params()._replace(start_half=1.0)  # beyond what Config accepts, to force failures
    s = setup_chain(5, 0)
    x, y, h = np.arange(9.0) * 200.0 + 100.0, np.zeros(9), np.full(9, 0.5)
    x[0] = 0.0
    before_x, before_h = x.copy(), h.copy()
    world.place_robots(
        x, y, h, s.position_keys, s.heading_keys, 1, tight, DEFAULT.arena_arrays(0)[0]
    )  # a teleport
    assert abs(x[0]) <= 1.0 and h[0] != 0.5
    assert x[1:].tolist() == before_x[1:].tolist() and h[1:].tolist() == before_h[1:].tolist()
    world.place_robots(
        x, y, h, s.position_keys, s.heading_keys, 0, tight, DEFAULT.arena_arrays(0)[0]
    )  # a chain's start
    assert x[1:].tolist() == [0.0] * 8 and h[1:].tolist() == [0.0] * 8


def test_huge_seeds_work():
    x, _, _, _ = _placed(2**63 - 1, 0, 0)
    assert x.shape == (9,)
