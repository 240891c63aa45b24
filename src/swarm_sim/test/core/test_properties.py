"""Property tests (hypothesis): estimates against brute force, physics invariants from arbitrary states."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from swarm_sim.core import world
from swarm_sim.model import DEFAULT

P = DEFAULT.params()

readings = st.integers(0, 8).flatmap(
    lambda n: st.tuples(
        st.booleans(),
        st.booleans(),
        st.lists(st.floats(170.0, 1000.0), min_size=n, max_size=n),
        st.lists(st.floats(0.0, 5000.0), min_size=n, max_size=n),
        st.lists(st.floats(0.0, 5000.0), min_size=n, max_size=n),
    )
)


@settings(max_examples=300, derandomize=True, deadline=None)
@given(readings)
def test_estimate_equals_brute_force(case):
    in_nest, on_food, ranges, nest, food = case
    n = len(ranges)
    r, values = np.array([*ranges, 0.0]), np.array([*zip(nest, food, strict=True), (0.0, 0.0)])
    raw, sources = np.zeros(2), np.zeros(2, np.int64)
    density, nearest = world.estimate(np.array([in_nest, on_food]), n, r, values, P, raw, sources)
    got = (raw[0], raw[1], density, sources[0], sources[1], nearest)

    def best(values, inside):
        if inside:
            return 0.0, -1
        options = [(values[k] + ranges[k], k) for k in range(n) if values[k] + ranges[k] < 5000.0]
        return min(options) if options else (5000.0, -1)  # min on (value, index): first on ties

    assert (got[0], got[3]) == best(nest, in_nest)
    assert (got[1], got[4]) == best(food, on_food)
    expected = sum(1.0 / (math.pi * (x / 10000.0) ** 2) for x in ranges) / 6642.0
    assert math.isclose(got[2], expected, rel_tol=1e-12, abs_tol=0.0)
    assert got[5] == (min(range(n), key=lambda k: (ranges[k], k)) if n else -1)
    assert 0.0 <= got[0] <= 5000.0 and 0.0 <= got[1] <= 5000.0


@st.composite
def swarms(draw):
    """A valid, crowded swarm (a jittered grid of touching-distance spacing, maybe against a wall or in a
    corner), headings, actions and wheel gains."""
    n = draw(st.integers(2, 9))
    limit = P.arena_half - P.robot_radius
    cx = draw(st.sampled_from([0.0, limit - 344.0, -limit]))
    cy = draw(st.sampled_from([0.0, limit - 344.0]))
    spacing = 2 * P.robot_radius + 2.0
    jitter = st.floats(-0.9, 0.9)
    xs = np.array([cx + spacing * (k % 3) + draw(jitter) for k in range(n)])
    ys = np.array([cy + spacing * (k // 3) + draw(jitter) for k in range(n)])
    xs, ys = np.clip(xs, -limit, limit), np.clip(ys, -limit, limit)
    headings = draw(st.lists(st.floats(-math.pi, math.pi, exclude_max=True), min_size=n, max_size=n))
    actions = draw(st.lists(st.integers(0, 6), min_size=n, max_size=n))
    gains = draw(st.lists(st.floats(0.9, 1.1), min_size=2 * n, max_size=2 * n))
    return xs, ys, np.array(headings), np.array(actions), np.array(gains).reshape(n, 2)


@settings(max_examples=150, derandomize=True, deadline=None)
@given(swarms(), st.integers(1, 40))
def test_physics_keeps_robots_apart_and_inside(swarm, steps):
    x, y, h, actions, gains = swarm
    n = len(x)
    state = world.new_dynamics(n)
    drive = world.drive(gains, P)
    limit = P.arena_half - P.robot_radius + 2.0  # a contact lets a body in by what one substep brings
    for _ in range(steps):
        world.physics_step(x, y, h, actions.astype(np.int64), drive, P, *state)
        assert (np.abs(x) <= limit).all() and (np.abs(y) <= limit).all()
        assert ((-math.pi <= h) & (h < math.pi)).all()
        for i in range(n):
            for j in range(i + 1, n):
                dx, dy = x[j] - x[i], y[j] - y[i]
                assert dx * dx + dy * dy >= (2 * P.robot_radius - 2.0) ** 2
