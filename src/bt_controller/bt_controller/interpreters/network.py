"""The neural controller: the authors' 9-5-1 perceptron (``footbot_nn``), beside the tree language.

A network is 56 weights in the authors' order (``docs/model.md``, "Neural controllers"): the input-to-hidden
weights hidden unit by hidden unit (``w[h * 9 + i]``), the 5 hidden biases, the 5 hidden-to-output weights and
the output bias. Hidden and output units are logistic; the output times 7, a number in (0, 7), picks one of
the seven actions: up to 1 stop, up to 2 forward, up to 3 forward_left, up to 4 forward_right, up to 5
reverse, up to 6 reverse_left, above 6 reverse_right (``vocabulary.ACTIONS`` is in that order).

Its 9 inputs, 0 or 1, are read from the robot's blackboard (``perception.blackboard``), the very entries a
tree's conditions read, in the authors' order: in_nest, on_food, carrying (``got_food``), nest_left,
nest_right, food_left, food_right, robot_left, robot_right (``INPUTS``).

A network runs where a tree would: at each tick of the timeline it reads the blackboard and drives the
wheels with its action until the next tick. In the interpreters' terms a network's tick returns running and
starts its action (``NetworkRobot.step``), so the motors, the movement and rotation counts and the action
starts follow as for a tree; it ticks no condition node.

Text form, so that a network travels wherever tree text does (requests, swarm layouts, the controller node,
bags): ``nn(w1, w2, ..., w56)``, the weights as Python writes floats (``to_text``, exact both ways). A file
form: JSON ``{"weights": [56 numbers]}`` (``load_network``). ``parse_controller`` reads either a tree or a
network from text.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

import bt_controller.lean_numba  # noqa: F401  (numba without scipy and cffi: see there)
from bt_controller.errors import TreeSyntaxError
from bt_controller.language.tree import MAX_DEPTH, MAX_NODES, Node, PrimitiveLibrary, parse
from bt_controller.language.vocabulary import ACTIONS, CONDITION_INDEX, RUNNING
from bt_controller.validate import number, strict_json

N_INPUTS = 9
N_HIDDEN = 5
N_WEIGHTS = N_INPUTS * N_HIDDEN + N_HIDDEN + N_HIDDEN + 1
"""56: input-to-hidden, hidden biases, hidden-to-output, output bias."""

INPUT_NAMES: tuple[str, ...] = (
    "in_nest",
    "on_food",
    "got_food",
    "nest_left",
    "nest_right",
    "food_left",
    "food_right",
    "robot_left",
    "robot_right",
)
"""The network's inputs in the authors' order (``got_food``: carrying), as blackboard names."""

INPUTS = np.array([CONDITION_INDEX[name] for name in INPUT_NAMES], dtype=np.int64)
"""For each input, its entry of the blackboard (``vocabulary.CONDITIONS`` order)."""

OUTPUT_SCALE = float(len(ACTIONS))
"""The output unit's value is multiplied by 7: one unit of the range per action."""

MAX_NETWORK_FILE_BYTES = 1_000_000
"""Largest network file read."""

_PREFIX = "nn("


@numba.njit(cache=True, error_model="numpy")
def _logistic(x: float) -> float:
    return 1.0 / (1.0 + math.exp(-x))


@numba.njit(cache=True, error_model="numpy")
def output(weights: np.ndarray, board: np.ndarray) -> float:
    """The network's output times 7, in (0, 7), for ``board`` (a blackboard, ``vocabulary.CONDITIONS``
    order): each hidden unit sums its weighted inputs in input order, then adds its bias."""
    hidden_start = N_INPUTS * N_HIDDEN
    out_start = hidden_start + N_HIDDEN
    total = 0.0
    for h in range(N_HIDDEN):
        acc = 0.0
        for i in range(N_INPUTS):
            acc += weights[h * N_INPUTS + i] * (1.0 if board[INPUTS[i]] else 0.0)
        acc += weights[hidden_start + h]
        total += weights[out_start + h] * _logistic(acc)
    total += weights[N_WEIGHTS - 1]
    return OUTPUT_SCALE * _logistic(total)


@numba.njit(cache=True, error_model="numpy")
def action_of_output(o: float) -> int:
    """The action (``vocabulary.ACTIONS`` index) an output in (0, 7) picks: the first ``a`` with
    ``o <= a + 1``, else the last action."""
    for a in range(len(ACTIONS) - 1):
        if o <= a + 1.0:
            return a
    return len(ACTIONS) - 1


@numba.njit(cache=True, error_model="numpy")
def act(weights: np.ndarray, board: np.ndarray) -> int:
    """The action the network with ``weights`` picks on ``board``."""
    return action_of_output(output(weights, board))


class NetworkError(ValueError):
    """Weights, text or a file that are not a network; one line saying what is wrong."""


@dataclass(frozen=True)
class Network:
    """A 9-5-1 network: its 56 weights in the authors' order (finite floats)."""

    weights: tuple[float, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "weights", check_weights(self.weights))

    def array(self) -> np.ndarray:
        """The weights as a float64 array (what the kernels take)."""
        return np.array(self.weights, dtype=np.float64)

    def __str__(self) -> str:
        return to_text(self)


def check_weights(weights: object) -> tuple[float, ...]:
    """``weights`` as a tuple of 56 finite floats; NetworkError (one line) otherwise."""
    if isinstance(weights, (str, bytes)) or not isinstance(weights, (Sequence, np.ndarray)):
        raise NetworkError(f"weights must be a list of {N_WEIGHTS} numbers, got {type(weights).__name__}")
    if len(weights) != N_WEIGHTS:
        raise NetworkError(f"a network has {N_WEIGHTS} weights, got {len(weights)}")
    checked = []
    for k, value in enumerate(weights):
        if isinstance(value, np.floating | np.integer) and not isinstance(value, np.bool_):
            value = value.item()
        checked.append(number(value, f"weight {k + 1}", error=NetworkError))
    return tuple(checked)


def to_text(network: Network) -> str:
    """The network's text form, ``nn(w1, ..., w56)`` (floats as ``repr`` writes them: exact both ways)."""
    return _PREFIX + ", ".join(repr(w) for w in network.weights) + ")"


def is_network_text(text: str) -> bool:
    """Whether ``text`` is meant as a network (it starts with ``nn(``, after blanks)."""
    return text.lstrip().startswith(_PREFIX)


def parse_network(text: str) -> Network:
    """The network of ``nn(w1, ..., w56)``; NetworkError (one line) for anything else."""
    body = text.strip()
    if not body.startswith(_PREFIX) or not body.endswith(")"):
        raise NetworkError(f"a network's text is nn(w1, ..., w{N_WEIGHTS}), got {_short(text)!r}")
    parts = [part.strip() for part in body[len(_PREFIX) : -1].split(",")]
    values = []
    for k, part in enumerate(parts):
        try:
            value = float(part)
        except ValueError:
            raise NetworkError(f"weight {k + 1} is not a number: {_short(part)!r}") from None
        values.append(value)
    return Network(tuple(values))


def parse_controller(
    text: str,
    *,
    max_nodes: int = MAX_NODES,
    max_depth: int = MAX_DEPTH,
    library: PrimitiveLibrary | None = None,
) -> Node | Network:
    """A robot's controller from text: a network (``nn(...)``) or a tree (``tree.parse``). A bad network is
    refused with a ``TreeSyntaxError`` (a ``TreeError``), as a bad tree is, so callers need one ``except``."""
    if is_network_text(text):
        try:
            return parse_network(text)
        except NetworkError as error:
            raise TreeSyntaxError(str(error)) from None
    return parse(text, max_nodes=max_nodes, max_depth=max_depth, library=library)


def controller_text(controller: Node | Network) -> str:
    """The text of a tree or a network (``tree.to_text`` or ``to_text``)."""
    return to_text(controller) if isinstance(controller, Network) else str(controller)


def load_network(path: str | Path) -> Network:
    """The network of a JSON file ``{"weights": [56 numbers]}``; NetworkError naming the file otherwise."""
    where = str(path)
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_NETWORK_FILE_BYTES + 1)
    except OSError as error:
        raise NetworkError(f"{where}: cannot read the network file ({error.strerror or error})") from None
    if len(raw) > MAX_NETWORK_FILE_BYTES:
        raise NetworkError(f"{where}: larger than {MAX_NETWORK_FILE_BYTES} bytes")
    try:
        document = strict_json(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise NetworkError(f"{where}: not UTF-8 text") from None
    except json.JSONDecodeError as error:
        raise NetworkError(f"{where}: not JSON ({error.msg}, line {error.lineno})") from None
    except ValueError as error:
        raise NetworkError(f"{where}: {error}") from None
    if not isinstance(document, dict) or set(document) != {"weights"}:
        raise NetworkError(f'{where}: expected an object with one key, {{"weights": [{N_WEIGHTS} numbers]}}')
    try:
        return Network(document["weights"])
    except NetworkError as error:
        raise NetworkError(f"{where}: {error}") from None


def network_document(network: Network) -> dict[str, list[float]]:
    """The JSON document of ``load_network``'s form."""
    return {"weights": list(network.weights)}


class NetworkRobot:
    """One robot running a network, with ``ReferenceRobot``'s interface: ``step`` ticks it once. A tick
    returns running with the action it picks started (counted in ``counts[1 + action]``); no condition node
    is ticked."""

    def __init__(self, network: Network) -> None:
        self.network = network
        self._weights = network.array()
        self.counts = [0] * (1 + len(ACTIONS))
        self.tick_index = 0

    def step(self, blackboard: Sequence[bool] | np.ndarray) -> tuple[int, int]:
        """Tick once with ``blackboard``; returns ``(RUNNING, action)``."""
        action = int(act(self._weights, np.asarray(blackboard, dtype=np.bool_)))
        self.counts[1 + action] += 1
        self.tick_index += 1
        return RUNNING, action


def _short(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[:limit] + "..."
