"""The Evaluator contract (``docs/interfaces.md``) and its in-process implementation, ``BatchEvaluator``.

An evaluation of a (tree, seed) is ``trials`` trials (trial ``k`` has the gap 500 mm when ``k div 5`` is even,
else 700 mm: ``docs/model.md``); its fitness is every objective (``world.OBJECTIVES``: the paper's three, the
inverse primitives' three and foraging) and its descriptors (movement, rotation, conditionality), each
averaged over robots and trials and each in [0, 1] but foraging (deliveries per robot per trial). A result
depends only on its request.

A ``SwarmRequest`` evaluates a heterogeneous swarm (``swarm_sim.model.swarm_layout``: a tree per robot) the
same way; a layout of one tree on every robot gives the very bits of the ``EvaluationRequest`` of that tree.
A request's tree text may be a network's (``nn(...)``, ``bt_controller.interpreters.network``): it runs in a
tree's place.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numba
import numpy as np

from bt_controller.draws import check_seed, root_key
from bt_controller.errors import TreeError
from bt_controller.interpreters import FlatTree, Network, flatten, pack, parse_controller
from bt_controller.language import MAX_DEPTH, MAX_NODES, Library, Node
from bt_controller.validate import integer
from swarm_sim.core import TrialRecord, combine, kernel, world
from swarm_sim.model import DEFAULT, Config, SwarmLayout

MAX_TRIALS = 10_000
"""Most trials one request may ask for."""


@dataclass(frozen=True)
class EvaluationRequest:
    """Evaluate ``tree`` (tree text) with ``seed`` over ``trials`` trials."""

    tree: str
    seed: int
    trials: int = 10


@dataclass(frozen=True)
class SwarmRequest:
    """Evaluate ``swarm`` (robot ``i`` running ``swarm.trees[i]``) with ``seed`` over ``trials`` trials."""

    swarm: SwarmLayout
    seed: int
    trials: int = 10


@dataclass(frozen=True)
class EvaluationResult:
    """Fitness (every objective, ``world.OBJECTIVES`` order) and descriptors (movement, rotation,
    conditionality), or an error."""

    fitness: tuple[float, ...] | None
    descriptors: tuple[float, ...] | None
    error: str | None

    @property
    def ok(self) -> bool:
        """True when the request was evaluated."""
        return self.error is None


@runtime_checkable
class Evaluator(Protocol):
    """Anything that turns requests into results, one result per request in the same order."""

    def evaluate(self, requests: Sequence[EvaluationRequest]) -> list[EvaluationResult]:
        """Evaluate every request; a bad request gives an error result, never an exception."""
        ...


def failed(reason: str) -> EvaluationResult:
    """An error result."""
    return EvaluationResult(fitness=None, descriptors=None, error=reason)


def from_values(values: Sequence[float] | np.ndarray) -> EvaluationResult:
    """A result from the values of an evaluation (``world.VALUE_NAMES`` order)."""
    v = tuple(float(x) for x in values)
    k = world.N_OBJECTIVES
    return EvaluationResult(fitness=v[:k], descriptors=v[k:], error=None)


def check_request(
    request: object,
    max_nodes: int = MAX_NODES,
    max_depth: int = MAX_DEPTH,
    library: Library | None = None,
) -> Node | Network:
    """The parsed tree (or network) of a valid request (its primitives' names expanded with ``library``);
    raise ValueError saying what is wrong otherwise."""
    return _parse(_check_fields(request).tree, max_nodes, max_depth, library)


def _check_fields(request: object) -> EvaluationRequest:
    if not isinstance(request, EvaluationRequest):
        raise ValueError(f"expected an EvaluationRequest, got {type(request).__name__}")
    if not isinstance(request.tree, str):
        raise ValueError(f"tree must be tree text (str), got {type(request.tree).__name__}")
    check_seed(request.seed)
    integer(request.trials, "trials", 1, MAX_TRIALS, numpy=True)
    return request


def _parse(text: str, max_nodes: int, max_depth: int, library: Library | None) -> Node | Network:
    try:
        return parse_controller(text, max_nodes=max_nodes, max_depth=max_depth, library=library)
    except TreeError as error:
        raise ValueError(f"bad tree: {error}") from None


def most_threads() -> int:
    """The most numba threads this process may use (``NUMBA_NUM_THREADS``, fixed when numba loads)."""
    most: int = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]  # set by numba at import
    return most


@functools.lru_cache(maxsize=4096)
def _flat_tree(text: str, max_nodes: int, max_depth: int, library: Library | None) -> FlatTree | Network:
    """The flat tree of a tree text (a network as it is: ``compiled.pack`` packs it), remembered: evolution
    offers the same tree again and again. (Errors are not cached; a FlatTree's arrays are only read; a library
    is one object per evaluator, compared by identity.)"""
    parsed = _parse(text, max_nodes, max_depth, library)
    return parsed if isinstance(parsed, Network) else flatten(parsed)


@dataclass(frozen=True)
class _Request:
    """A request checked and made ready for the kernels: its flat trees, each robot's index into them, seed
    key and trial count."""

    index: int
    flats: tuple[FlatTree | Network, ...]
    robot_tree: tuple[int, ...]
    seed_key: np.uint64
    trials: int


class BatchEvaluator:
    """The in-process evaluator: every trial of every request in compiled kernels.

    ``evaluate`` answers the contract; ``evaluate_trials`` also returns each trial's record (values and
    poses). Trees are refused beyond ``max_nodes`` nodes or ``max_depth`` depth (primitives expanded). A
    tree may name the primitives of ``library`` (``bt_controller.language.library``): each use is its own
    ``success`` copy. With ``threads`` > 1 the trials are spread over that many numba threads; results are the
    same bits either way.
    """

    def __init__(
        self,
        config: Config = DEFAULT,
        max_nodes: int = MAX_NODES,
        max_depth: int = MAX_DEPTH,
        threads: int = 1,
        library: Library | None = None,
    ) -> None:
        integer(threads, "threads", 1, most_threads())
        self.threads = threads
        self.config = config
        self.max_nodes = max_nodes
        self.max_depth = max_depth
        self.library = library
        self._params = config.params()

    def evaluate(self, requests: Sequence[EvaluationRequest | SwarmRequest]) -> list[EvaluationResult]:
        """Evaluate every request (see ``Evaluator``), a swarm layout's as well."""
        return [result for result, _ in self._evaluate(requests, keep_records=False)]

    def evaluate_trials(
        self, requests: Sequence[EvaluationRequest | SwarmRequest]
    ) -> list[tuple[EvaluationResult, list[TrialRecord]]]:
        """Evaluate every request, a swarm layout's as well; with each result, its trials' records (empty for
        an error)."""
        return self._evaluate(requests, keep_records=True)

    def _prepare(self, index: int, request: object) -> _Request:
        """Check, parse and flatten a request and derive its seed key: everything before the kernels, in one
        place; raise ValueError or TreeError saying what is wrong."""
        n_robots = self._params.n_robots
        if isinstance(request, SwarmRequest):
            swarm = request.swarm
            if not isinstance(swarm, SwarmLayout):
                raise ValueError(f"swarm must be a SwarmLayout, got {type(swarm).__name__}")
            if swarm.n_robots != n_robots:
                raise ValueError(f"the swarm layout has {swarm.n_robots} trees for {n_robots} robots")
            check_seed(request.seed)
            integer(request.trials, "trials", 1, MAX_TRIALS, numpy=True)
            flats = []
            for i, text in enumerate(swarm.distinct):
                try:
                    flats.append(_flat_tree(text, self.max_nodes, self.max_depth, self.library))
                except ValueError as error:  # (TreeError is one)
                    robot = swarm.robot_tree.index(i)
                    raise ValueError(f"robot {robot}: {error}") from None
            trees, robot_tree, seed, trials = tuple(flats), swarm.robot_tree, request.seed, request.trials
        else:
            checked = _check_fields(request)
            trees = (_flat_tree(checked.tree, self.max_nodes, self.max_depth, self.library),)
            robot_tree, seed, trials = (0,) * n_robots, checked.seed, checked.trials
        return _Request(index, trees, robot_tree, root_key(int(seed)), int(trials))

    def _evaluate(
        self, requests: Sequence[EvaluationRequest | SwarmRequest], keep_records: bool
    ) -> list[tuple[EvaluationResult, list[TrialRecord]]]:
        out: list[tuple[EvaluationResult, list[TrialRecord]] | None] = [None] * len(requests)
        ready: list[_Request] = []
        for index, request in enumerate(requests):
            try:
                ready.append(self._prepare(index, request))
            except (ValueError, TreeError) as error:
                out[index] = (failed(str(error)), [])
        if ready:
            self._run(ready, out, keep_records)
        return [item for item in out if item is not None]

    def _run(
        self,
        ready: list[_Request],
        out: list[tuple[EvaluationResult, list[TrialRecord]] | None],
        keep_records: bool,
    ) -> None:
        # One pack of every request's trees; each robot's index into its request's trees moved into the pack.
        offsets = np.cumsum([0] + [len(r.flats) for r in ready])
        trees = pack([flat for r in ready for flat in r.flats])
        robot_trees = [
            [int(offset) + t for t in r.robot_tree] for r, offset in zip(ready, offsets, strict=False)
        ]
        jobs = kernel.make_jobs(
            [r.seed_key for r in ready], [r.trials for r in ready], self.config, robot_trees
        )
        results = kernel.Outputs.zeros(jobs.n_rows, self._params.n_robots)
        if self.threads > 1:
            numba.set_num_threads(self.threads)
        run = kernel.run_jobs_parallel if self.threads > 1 else kernel.run_jobs
        run(trees, self._params, jobs, results)
        values, poses = results
        row = 0
        for r in ready:
            if not keep_records:
                out[r.index] = (from_values(world.mean_values(values[row : row + r.trials])), [])
                row += r.trials
                continue
            records = [
                TrialRecord(
                    trial=k,
                    gap=self.config.gap(k),
                    values=tuple(float(v) for v in values[row + k]),
                    start_poses=poses[row + k, 0].copy(),
                    end_poses=poses[row + k, 1].copy(),
                )
                for k in range(r.trials)
            ]
            out[r.index] = (from_values(combine(records)), records)
            row += r.trials
