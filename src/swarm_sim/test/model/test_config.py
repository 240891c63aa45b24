"""The configuration: defaults from docs/model.md, bad values refused by name."""

import dataclasses

import pytest

from swarm_sim.errors import ConfigError
from swarm_sim.model import DEFAULT, FAULT_FIELDS, Config, Piece, config_from_dict


def test_defaults_follow_the_model():
    c = DEFAULT
    assert c.profile == "paper"
    assert (c.arena_half, c.nest_radius, c.gaps) == (2450.0, 500.0, (500.0, 700.0))
    assert (c.n_robots, c.robot_radius, c.start_half, c.max_start_attempts) == (9, 85.036758, 1000.0, 10)
    assert (c.wheel_separation, c.wheel_speed) == (140.0, 50.0)
    assert (c.gain_low, c.gain_step, c.gain_levels) == (0.9, 0.01, 20)
    assert (c.step_dt, c.steps_per_tick, c.ticks, c.initial_step, c.chain_trials) == (0.125, 4, 40, 16, 5)
    assert (c.trial_steps, c.chain_length) == (160, 5)
    assert (c.message_range, c.delivery_probability, c.estimate_cap, c.occlusion) == (
        1000.0,
        0.95,
        5000.0,
        True,
    )
    assert (c.density_range, c.density_divisor, c.window, c.friction) == (10000.0, 6642.0, 7, 0.49)
    # Trials come in blocks of 5 per gap (one chain each under paper), under both profiles.
    assert [c.gap(k) for k in range(11)] == [500.0] * 5 + [700.0] * 5 + [500.0]
    clean = Config(profile="clean")
    assert (clean.trial_steps, clean.chain_length) == (176, 1)
    assert [clean.gap(k) for k in (0, 4, 5, 9)] == [500.0, 500.0, 700.0, 700.0]


def test_params_carry_every_value_with_its_type():
    p = DEFAULT.params()
    for name in p._fields:
        if name not in ("profile", "formation", "carry_groups", "carry_masks"):
            assert getattr(p, name) == getattr(DEFAULT, name)
    assert (p.carry_groups, p.carry_masks) == (0, 0)  # no groups: every robot carries every kind
    assert p.profile == 0 and Config(profile="clean").params().profile == 1
    assert p.formation == 0 and Config(formation="lattice", n_robots=4).params().formation == 1
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
        ({"initial_step": 0}, "initial_step"),
        ({"initial_step": 18}, "initial_step"),
        ({"profile": "argos"}, "profile"),
        ({"friction": 2.0}, "friction"),
        ({"delivery_probability": 1.5}, "delivery_probability"),
        ({"gain_low": -1.0}, "gain_low"),
        ({"gaps": ()}, "gaps"),
        ({"gaps": (500.0, -1.0)}, "gaps"),
        ({"start_half": 2450.0}, "start_half"),
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
    # every field; a layout only when there is one (the papers' arena is nest_radius and gaps), faults only
    # when some are given, robot types only when there are two, groups' food kinds only when there are
    # groups (files as before each)
    quiet = {*FAULT_FIELDS, "robot_types", "carries"}
    assert set(d) == {f.name for f in dataclasses.fields(Config)} - {"layout", *quiet}
    nest = Piece("nest", "disc", 0.0, 0.0, 400.0)
    laid_out = Config(
        layout=(((nest, Piece("food", "disc", 1000.0, 0.0, 300.0)),),), robot_types=2, carries=(("food",), ())
    )
    assert set(laid_out.as_dict()) == {f.name for f in dataclasses.fields(Config)} - set(FAULT_FIELDS)
    assert config_from_dict(laid_out.as_dict()) == laid_out
    faulty = Config(fault_robots=((0, "wheel-dead"), (3, "disruptive")))
    assert faulty.as_dict()["fault_robots"] == [[0, "wheel-dead"], [3, "disruptive"]]
    assert config_from_dict(faulty.as_dict()) == faulty
    drawn = Config(fault_rate=0.25, fault_kinds=("rab-deaf",))
    assert config_from_dict(drawn.as_dict()) == drawn
