"""Stream keys: one per (seed, trial, robot, purpose), trials replayable alone."""

import numpy as np

from bt_controller.draws import DROPS, PURPOSES, TREE, root_key, stream_key, trial_keys
from swarm_sim.config import DEFAULT
from swarm_sim.trial_data import setup_trial


def test_trial_keys_match_the_documented_derivation():
    keys = trial_keys(np.uint64(root_key(7)), 3, 9)
    assert keys.shape == (len(PURPOSES), 9) and keys.dtype == np.uint64
    for robot in range(9):
        for purpose in range(len(PURPOSES)):
            assert keys[purpose, robot] == stream_key(7, 3, robot, purpose)


def test_keys_are_all_distinct():
    seen = {int(stream_key(s, t, r, u)) for s in (0, 1) for t in range(4) for r in range(9) for u in range(5)}
    assert len(seen) == 2 * 4 * 9 * 5


def test_a_trial_replays_alone_and_depends_on_its_index():
    a = setup_trial(11, 5)
    b = setup_trial(11, 5)
    assert (a.poses == b.poses).all() and (a.gains == b.gains).all()
    assert (a.drop_keys == b.drop_keys).all() and (a.tree_keys == b.tree_keys).all()
    c = setup_trial(11, 4)
    assert not (a.poses == c.poses).any()
    assert a.drop_keys[0] == stream_key(11, 5, 0, DROPS) and a.tree_keys[8] == stream_key(11, 5, 8, TREE)


def test_arena_configuration_alternates():
    assert [setup_trial(0, k).gap for k in range(4)] == [500.0, 700.0, 500.0, 700.0]


def test_start_poses_gains_and_headings_follow_the_model():
    r = DEFAULT.robot_radius
    for trial in range(50):
        s = setup_trial(123, trial)
        x, y, h = s.poses.T
        assert (np.hypot(x, y) <= DEFAULT.start_radius).all()
        assert ((-np.pi <= h) & (h < np.pi)).all()
        assert ((s.gains >= 0.9) & (s.gains < 1.1)).all()
        d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
        assert (d[np.triu_indices(9, 1)] >= 2 * r).all()


def test_huge_seeds_work():
    s = setup_trial(2**63 - 1, 0)
    assert s.poses.shape == (9, 3)
