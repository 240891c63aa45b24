"""The 9-5-1 network: its arithmetic against a plain numpy forward pass, the action ranges, the inputs read
from the blackboard, the text and file forms and their refusals."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bt_controller.errors import TreeSyntaxError
from bt_controller.interpreters.network import (
    INPUT_NAMES,
    N_WEIGHTS,
    Network,
    NetworkError,
    NetworkRobot,
    act,
    action_of_output,
    load_network,
    output,
    parse_controller,
    parse_network,
    to_text,
)
from bt_controller.language.tree import parse
from bt_controller.language.vocabulary import ACTIONS, CONDITION_INDEX, N_CONDITIONS, RUNNING


def _plain_output(weights: np.ndarray, inputs: np.ndarray) -> float:
    """The authors' forward pass written with numpy matrices (inputs in the authors' order)."""
    w_in = weights[:45].reshape(5, 9)
    b_hidden = weights[45:50]
    w_out = weights[50:55]
    hidden = 1.0 / (1.0 + np.exp(-(w_in @ inputs + b_hidden)))
    return 7.0 / (1.0 + math.exp(-(w_out @ hidden + weights[55])))


def _board(active: set[str]) -> np.ndarray:
    board = np.zeros(N_CONDITIONS, dtype=np.bool_)
    for name in active:
        board[CONDITION_INDEX[name]] = True
    return board


def test_output_matches_a_plain_forward_pass_on_every_input_pattern() -> None:
    rng = np.random.default_rng(3)
    for _ in range(5):
        weights = rng.uniform(-5, 5, N_WEIGHTS)
        for pattern in range(2**9):
            inputs = np.array([(pattern >> k) & 1 for k in range(9)], dtype=np.float64)
            board = _board({name for name, bit in zip(INPUT_NAMES, inputs, strict=True) if bit})
            assert output(weights, board) == pytest.approx(_plain_output(weights, inputs), abs=1e-12)


def test_zero_weights_give_forward_right_as_in_the_authors_code() -> None:
    # every hidden unit 0.5, output sigmoid(0) * 7 = 3.5: forward_right (up to 4)
    weights = np.zeros(N_WEIGHTS)
    assert output(weights, _board(set())) == 3.5
    assert ACTIONS[act(weights, _board({"in_nest", "robot_left"}))] == "forward_right"


def test_each_input_reaches_its_own_weight() -> None:
    # only hidden unit 0 matters (output weight 1 on it): input k shows through weight k
    for k, name in enumerate(INPUT_NAMES):
        weights = np.zeros(N_WEIGHTS)
        weights[k] = 10.0
        weights[50] = 1.0
        on, off = output(weights, _board({name})), output(weights, _board(set()))
        assert on > off
        others = {n for n in INPUT_NAMES if n != name}
        assert output(weights, _board(others)) == off


def test_output_ranges_pick_the_seven_actions() -> None:
    cases = [(0.01, "stop"), (1.0, "stop"), (1.0000001, "forward"), (2.0, "forward"), (3.0, "forward_left"),
             (4.0, "forward_right"), (5.0, "reverse"), (6.0, "reverse_left"), (6.0001, "reverse_right"),
             (6.99, "reverse_right")]  # fmt: skip
    for o, name in cases:
        assert ACTIONS[action_of_output(o)] == name


def test_network_robot_ticks_running_with_its_action_started() -> None:
    robot = NetworkRobot(Network((0.0,) * N_WEIGHTS))
    status, started = robot.step(_board(set()))
    assert (status, ACTIONS[started]) == (RUNNING, "forward_right")
    assert robot.counts[0] == 0 and robot.counts[1 + started] == 1 and robot.tick_index == 1


def test_text_form_round_trips_exactly() -> None:
    rng = np.random.default_rng(5)
    network = Network(tuple(float(w) for w in rng.normal(0, 3, N_WEIGHTS)))
    text = to_text(network)
    assert text.startswith("nn(") and parse_network(text) == network
    assert parse_controller(text) == network
    assert parse_controller("sel(in_nest, stop)") == parse("sel(in_nest, stop)")


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("nn(1, 2)", "a network has 56 weights, got 2"),
        ("nn(" + ", ".join(["1"] * 55) + ", x)", "weight 56 is not a number: 'x'"),
        ("nn(" + ", ".join(["1"] * 55) + ", nan)", "weight 56 must be finite"),
        ("nn(1", "a network's text is nn(w1, ..., w56)"),
    ],
)
def test_bad_network_text_is_refused_in_one_line(text: str, expected: str) -> None:
    with pytest.raises(TreeSyntaxError, match=r"^[^\n]*$") as caught:
        parse_controller(text)
    assert expected in str(caught.value)


def test_network_file_and_its_refusals(tmp_path) -> None:  # type: ignore[no-untyped-def]  # tmp_path: pytest's
    good = tmp_path / "net.json"
    good.write_text(json.dumps({"weights": [0.5] * N_WEIGHTS}))
    assert load_network(good) == Network((0.5,) * N_WEIGHTS)
    cases = {
        '{"weights": [1, 2, 3]}': "a network has 56 weights, got 3",
        '{"weights": [' + ", ".join(["1"] * 55) + ', "a"]}': "weight 56 must be a number",
        '{"weights": [' + ", ".join(["1"] * 55) + ", NaN]}": "NaN is not a JSON number",
        '{"weights": [' + ", ".join(["1"] * 55) + ", true]}": "weight 56 must be a number",
        '{"w": []}': 'expected an object with one key, {"weights"',
        "[1, 2": "not JSON",
    }
    for content, expected in cases.items():
        bad = tmp_path / "bad.json"
        bad.write_text(content)
        with pytest.raises(NetworkError) as caught:
            load_network(bad)
        message = str(caught.value)
        assert "\n" not in message and message.startswith(str(bad)) and expected in message, message
    with pytest.raises(NetworkError, match="cannot read"):
        load_network(tmp_path / "missing.json")
