"""The configuration: defaults from model.md, bad values refused by name."""

import dataclasses

import pytest

from swarm_sim.config import DEFAULT, Config, ConfigError


def test_defaults_follow_the_model():
    c = DEFAULT
    assert (c.arena_half, c.nest_radius, c.gaps) == (2500.0, 500.0, (500.0, 700.0))
    assert (c.n_robots, c.robot_radius, c.start_radius) == (9, 85.0, 1000.0)
    assert (c.wheel_separation, c.wheel_speed, c.gain_low, c.gain_high) == (140.0, 50.0, 0.9, 1.1)
    assert (c.step_dt, c.steps_per_tick, c.ticks, c.settle_steps) == (0.125, 4, 40, 16)
    assert c.steps == 160
    assert (c.message_range, c.delivery_probability, c.estimate_cap) == (1000.0, 0.95, 5000.0)
    assert (c.density_range, c.density_divisor, c.window) == (170.0, 6.0, 7)
    assert [c.gap(k) for k in range(4)] == [500.0, 700.0, 500.0, 700.0]


def test_params_carry_every_value_with_its_type():
    p = DEFAULT.params()
    for name in p._fields:
        assert getattr(p, name) == getattr(DEFAULT, name)
    assert isinstance(p.n_robots, int) and isinstance(p.arena_half, float)
    assert isinstance(Config(arena_half=3000).params().arena_half, float)


def test_config_is_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        DEFAULT.n_robots = 3  # type: ignore[misc]  # the point: assigning to a frozen config must fail


@pytest.mark.parametrize(
    ("change", "name"),
    [
        ({"arena_half": -1.0}, "arena_half"),
        ({"robot_radius": float("nan")}, "robot_radius"),
        ({"n_robots": 0}, "n_robots"),
        ({"n_robots": 2.5}, "n_robots"),
        ({"ticks": True}, "ticks"),
        ({"settle_steps": 0}, "settle_steps"),
        ({"delivery_probability": 1.5}, "delivery_probability"),
        ({"gain_low": 1.2}, "gain_low"),
        ({"gaps": ()}, "gaps"),
        ({"gaps": (500.0, -1.0)}, "gaps"),
        ({"start_radius": 2450.0}, "start_radius"),
        ({"n_robots": 200}, "n_robots"),
        ({"wheel_speed": "fast"}, "wheel_speed"),
    ],
)
def test_bad_values_are_refused_by_name(change, name):
    with pytest.raises(ConfigError, match=name):
        Config(**change)


def test_as_dict_names_every_field():
    d = DEFAULT.as_dict()
    assert d["gaps"] == [500.0, 700.0]
    assert set(d) == {f.name for f in dataclasses.fields(Config)}
