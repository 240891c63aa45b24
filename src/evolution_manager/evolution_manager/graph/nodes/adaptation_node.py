"""The adaptation node: watches a running swarm window by window and swaps trees into its robots after a
fault (live adaptation), and the run of one live adaptation through the trial graph.

``AdaptationNode`` (node ``adaptation``) subscribes to each robot's ``wheels`` (the smoothed values and
deliveries a window's measure is computed from) and to the simulator's ``faults``; it tells the core
(``evolution_manager.adaptation.live.LiveAdaptation``, the decisions, ROS-free) each window's measure and each
fault, calls the robots' ``load_tree`` with ``from_step`` for every swap the core answers with (a swap that
reached a robot too late is made again later), and publishes every window, fault and swap on ``adaptation``
(``swarm_msgs/AdaptationEvent``). ``run_live_graph`` starts a trial graph, records it with the node's events
and runs one long trial with faults injected through the simulator's ``inject_faults`` service; the command is
``adapt-live`` (``evolution_manager.adaptation.adapt_live``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Protocol

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from rclpy.node import Node
from rclpy.task import Future
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray

from bt_controller.robot import timeline
from evolution_manager.errors import TrialFailedError
from evolution_manager.graph.nodes.recorder import GraphRecorder
from evolution_manager.graph.nodes.trial import TrialGraph, write_result
from evolution_manager.recording.bags import BagRecorder, check_new_bag
from swarm_msgs.msg import (
    AdaptationEvent,
    GroundSensor,
    RangeAndBearingReadings,
    RobotFaults,
    SwarmState,
    TreeStatus,
    TrialStart,
    WheelCommand,
)
from swarm_msgs.srv import HoldStep, InjectFaults, LoadTree
from swarm_ros.names import robot_namespaces
from swarm_ros.qos import RELIABLE
from swarm_sim.core import TrialRecord
from swarm_sim.model import Config, SwarmLayout
from swarm_sim.tasks import TaskSpec

BUFFER_STEPS = 400
"""Steps of the robots' answers the node keeps (a window's first step may lie that far behind)."""


class LiveSwap(Protocol):
    """Trees to load: ``tree`` into ``robots`` from step ``step`` on (``adaptation.live.Swap``)."""

    @property
    def step(self) -> int: ...
    @property
    def robots(self) -> tuple[int, ...]: ...
    @property
    def tree(self) -> str: ...
    @property
    def bin(self) -> tuple[int, ...]: ...
    @property
    def trial(self) -> int: ...


class LiveCore(Protocol):
    """What the node asks of a live adaptation core (``adaptation.live.LiveAdaptation``)."""

    robots: int
    trees: list[str]
    phase: str
    start: int
    trial: int
    stop_reason: str

    @property
    def end(self) -> int: ...
    @property
    def target(self) -> float: ...
    def fault(self, step: int, faulty: Sequence[int]) -> None: ...
    def close_window(self, measure: float) -> LiveSwap | None: ...
    def swap_refused(self, step: int) -> LiveSwap: ...


WindowMeasure = Callable[[str, np.ndarray, np.ndarray, np.ndarray, Config], float]
"""A window's measure: (objective, smoothed values at its first step, at its last, deliveries in it, world)
(``adaptation.live.window_measure``)."""


def live_topics(robots: int) -> list[tuple[str, type]]:
    """What a live adaptation records: the simulator's trial start, arena, swarm state and faults, the
    adaptation's events, and each robot's readings, answers and tick statuses (no frames, poses or markers
    per step: a long trial's bag stays small)."""
    topics: list[tuple[str, type]] = [
        ("/trial_start", TrialStart),
        ("/markers", MarkerArray),
        ("/swarm_state", SwarmState),
        ("/faults", RobotFaults),
        ("/adaptation", AdaptationEvent),
    ]
    for robot in robot_namespaces(robots):
        topics += [
            (f"/{robot}/ground", GroundSensor),
            (f"/{robot}/range_and_bearing", RangeAndBearingReadings),
            (f"/{robot}/wheels", WheelCommand),
            (f"/{robot}/tree_status", TreeStatus),
        ]
    return topics


class AdaptationNode:
    """The adaptation node (``adaptation``): a thin ROS shell over a live adaptation core
    (``evolution_manager.adaptation.live.LiveAdaptation``). It subscribes to each robot's
    ``wheels`` (the values a window is measured with) and the simulator's ``faults``, calls the robots'
    ``load_tree`` with ``from_step`` for every swap, and publishes each window, fault and swap on
    ``adaptation``. ``last_step``: the trial's last step (the node is done once it is answered)."""

    def __init__(
        self,
        context: rclpy.Context,
        core: LiveCore,
        measure: WindowMeasure,
        objective: str,
        config: Config,
        last_step: int,
    ) -> None:
        self.core = core
        self.window_measure = measure
        self.objective = objective
        self.config = config
        self.last_step = last_step
        self.step_ns = round(config.step_dt * 1e9)
        self.node = Node("adaptation", context=context)
        self.robots = core.robots
        self.answers: dict[int, dict[int, WheelCommand]] = {}  # step -> robot -> its answer
        self.newest = [0] * self.robots
        self.known_faults: list[str] | None = None
        self.done = False
        self.note = ""
        self.events: list[dict[str, object]] = []
        self.refused = 0
        self._last_swap: LiveSwap | None = None
        self.held = 0
        """The step the simulator is held before (``hold_step``), as last asked; 0: none."""
        self._swapping = False
        self.hold_client: rclpy.client.Client = self.node.create_client(HoldStep, "simulator/hold_step")
        self._events = self.node.create_publisher(AdaptationEvent, "adaptation", RELIABLE)
        self._load: list[rclpy.client.Client] = [
            self.node.create_client(LoadTree, f"{robot}/load_tree") for robot in robot_namespaces(self.robots)
        ]
        for i, robot in enumerate(robot_namespaces(self.robots)):
            self.node.create_subscription(
                WheelCommand, f"{robot}/wheels", partial(self._on_wheels, i), RELIABLE
            )
        self.node.create_subscription(RobotFaults, "faults", self._on_faults, RELIABLE)

    # --- what comes in
    def _on_faults(self, msg: RobotFaults) -> None:
        kinds = list(msg.kinds)
        if self.known_faults is None or self.done:  # the trial's start: the faults it began with
            self.known_faults = kinds
            return
        if kinds == self.known_faults:
            return
        self.known_faults = kinds
        faulty = [i for i, kind in enumerate(kinds) if kind]
        step = int(msg.step)
        try:
            self.core.fault(step, faulty)
        except ValueError as error:  # a fault the core cannot adapt to (AdaptationError is a ValueError)
            self._finish(str(error), step)
            return
        note = ", ".join(f"{i}:{kinds[i]}" for i in faulty) or "no robot faulty"
        self._publish("fault", step, step, robots=faulty, note=note)
        if not self._swapping:
            self._renew_hold()

    def _on_wheels(self, robot: int, msg: WheelCommand) -> None:
        step = int(msg.step)
        self.answers.setdefault(step, {})[robot] = msg
        self.newest[robot] = max(self.newest[robot], step)
        for old in [s for s in self.answers if s < step - BUFFER_STEPS]:
            del self.answers[old]
        self._close_windows()

    def _complete(self, step: int) -> bool:
        return len(self.answers.get(step, {})) == self.robots

    def _close_windows(self) -> None:
        while not self.done:
            core = self.core
            if core.end > self.last_step:
                if self._complete(self.last_step):
                    self._finish(core.stop_reason or "the trial ended", self.last_step)
                return
            if not self._complete(core.end):
                return
            if not self._complete(core.start):
                self._finish(
                    f"the answers of step {core.start} were lost: the window cannot be measured", core.end
                )
                return
            start, end, phase, trial = core.start, core.end, core.phase, core.trial
            measure = self.measure(start, end)
            swap = core.close_window(measure)
            self._publish("window", end, start, phase=phase, trial=trial, measure=measure)
            if swap is not None:
                self._swap(swap)  # the hold moves on once every robot has the tree
            else:
                self._renew_hold()

    def measure(self, start: int, end: int) -> float:
        """The objective over the window from step ``start`` to ``end`` (``window_measure``)."""

        def values(step: int) -> tuple[np.ndarray, np.ndarray]:
            answers = [self.answers[step][i] for i in range(self.robots)]
            smoothed = np.array(
                [
                    (a.smoothed_nest, a.smoothed_food, a.smoothed_density, *a.smoothed_other_food)
                    for a in answers
                ]
            )
            delivered = np.array([(a.deliveries, *a.other_food_deliveries) for a in answers], dtype=np.int64)
            return smoothed, delivered

        first, delivered_before = values(start)
        last, delivered_after = values(end)
        return self.window_measure(
            self.objective, first, last, delivered_after - delivered_before, self.config
        )

    # --- what goes out
    def hold_step(self) -> int:
        """The step to hold the simulator before: the one after the window under way (0 past the trial)."""
        step = self.core.end + 1
        return step if step <= self.last_step and not self.done else 0

    def _renew_hold(self) -> None:
        """Move the simulator's hold to the end of the window under way, releasing the one before."""
        step = self.hold_step()
        if step != self.held:
            self.held = step
            self.hold_client.call_async(HoldStep.Request(step=step))

    def _swap(self, swap: LiveSwap) -> None:
        self._publish(
            "swap",
            swap.step,
            swap.step,
            phase=self.core.phase,
            trial=swap.trial,
            robots=list(swap.robots),
            bin_=list(swap.bin),
            note=f"trial {swap.trial}" if swap.trial else "the best tree tried",
        )
        pending = {
            robot: self._load[robot].call_async(LoadTree.Request(tree=swap.tree, from_step=swap.step))
            for robot in swap.robots
        }

        self._last_swap = swap
        self._swapping = True
        handled = [False]

        def answered(_future: Future) -> None:
            if handled[0] or not all(f.done() for f in pending.values()):
                return
            handled[0] = True
            answers = [f.result() for f in pending.values()]
            late = any(a is None or not a.success for a in answers)
            # too late for some robot, and no later swap since: the same swap again, later
            if late and not self.done and self._last_swap is swap:
                self.refused += 1
                self._swap(self.core.swap_refused(max(self.newest)))
                return
            if self._last_swap is swap:
                self._swapping = False
                self._renew_hold()

        for future in pending.values():
            future.add_done_callback(answered)

    def _finish(self, note: str, step: int) -> None:
        self.done = True
        self.note = note
        self._renew_hold()  # released
        self._publish("done", step, step, phase=self.core.phase, note=note)

    def _stamp(self, step: int) -> Time:
        """The simulated time of ``step``: its answers' stamp, or counted on from the newest one."""
        known = [s for s in self.answers if s <= step and self.answers[s]]
        base = max(known) if known else step
        stamp = next(iter(self.answers[base].values())).header.stamp if known else Time()
        ns = stamp.sec * 1_000_000_000 + stamp.nanosec + (step - base) * self.step_ns
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def _publish(
        self,
        kind: str,
        step: int,
        start: int,
        *,
        phase: str = "",
        trial: int = 0,
        measure: float = math.nan,
        robots: Sequence[int] = (),
        bin_: Sequence[int] = (),
        note: str = "",
    ) -> None:
        target = self.core.target
        event = AdaptationEvent(
            header=Header(stamp=self._stamp(step), frame_id="arena"),
            kind=kind,
            step=step,
            start_step=start,
            phase=phase or self.core.phase,
            trial=trial,
            measure=measure,
            objective=self.objective,
            target=target,
            robots=[int(r) for r in robots],
            trees=list(self.core.trees),
            bin=[int(b) for b in bin_],
            note=note,
        )
        self._events.publish(event)
        self.events.append(
            {
                "kind": kind,
                "step": step,
                "start_step": start,
                "phase": event.phase,
                "trial": trial,
                "measure": None if math.isnan(measure) else measure,
                "target": None if math.isnan(target) else target,
                "robots": list(event.robots),
                "bin": list(event.bin),
                "note": note,
                **({"tree": self.core.trees[robots[0]]} if kind == "swap" and robots else {}),
            }
        )

    def destroy(self) -> None:
        self.node.destroy_node()


@dataclass(frozen=True)
class LiveRun:
    """What ``run_live_graph`` ran: the trial's record, the node's events and note, and the swaps made again
    because they reached a robot too late."""

    record: TrialRecord
    events: list[dict[str, object]]
    note: str
    retimed: int


def run_live_graph(
    core: LiveCore,
    measure: WindowMeasure,
    *,
    objective: str,
    task: TaskSpec,
    profile: str,
    robots: int,
    seed: int,
    faults: str,
    fault_step: int,
    bag_path: Path,
    log_dir: Path,
    timeout: float = 60.0,
) -> LiveRun:
    """Run trial 0 of ``seed`` of ``task`` (one long trial) through a fresh trial graph of ``robots``
    controllers, every robot starting on ``core.trees``, the ``faults`` (``ROBOT:KIND`` pairs) injected from
    step ``fault_step``, and the adaptation node driving ``core``; record it to ``bag_path``."""
    config = replace(task.config(profile), n_robots=robots)
    last_step = timeline.trial_steps(config.timeline)
    check_new_bag(bag_path)
    with TrialGraph(robots=robots, task=task, profile=profile, timeout=timeout, log_dir=log_dir) as graph:
        runner = graph.runner
        assert runner is not None
        runner.load_trees(list(core.trees))
        adaptation = AdaptationNode(runner.node.context, core, measure, objective, config, last_step)
        recorder_node = Node("live_recorder", context=runner.node.context)
        runner.executor.add_node(adaptation.node)
        runner.executor.add_node(recorder_node)
        try:
            with BagRecorder(bag_path) as bag:
                recorder = GraphRecorder(recorder_node, bag, live_topics(robots))
                runner.spin_until(recorder.all_publishers_matched, "the graph's publishers")
                runner.spin_for(1.0)  # the publishers' side of the matching (trial.PUBLISHERS_MATCH_SETTLE)
                inject: rclpy.client.Client = runner.node.create_client(
                    InjectFaults, "simulator/inject_faults"
                )
                request = InjectFaults.Request(faults=faults, at_step=fault_step)
                response = runner.call(inject, request, "the simulator's inject_faults")
                if not response.success:
                    raise TrialFailedError(f"the simulator refused the faults: {response.message}")
                # the swarm waits at each window's end while the node decides: the same swaps on any machine
                adaptation.held = adaptation.hold_step()
                runner.call(adaptation.hold_client, HoldStep.Request(step=adaptation.held), "hold_step")
                record = runner.run_trial(seed, 0)
                runner.spin_while_progressing(
                    lambda: (
                        adaptation.done
                        and recorder.counts["/swarm_state"] >= last_step
                        and recorder.counts["/adaptation"] >= len(adaptation.events)
                    ),
                    lambda: sum(recorder.counts.values()),
                    lambda: "the last messages of the trial and of the adaptation",
                )
                trees = tuple(core.trees)
                label = trees[0] if len(set(trees)) == 1 else SwarmLayout(trees).label
                write_result(bag, label, seed, record, recorder.last_stamp + 1, "", profile)
        finally:
            runner.executor.remove_node(adaptation.node)
            runner.executor.remove_node(recorder_node)
            adaptation.destroy()
            recorder_node.destroy_node()
    return LiveRun(record, adaptation.events, adaptation.note, adaptation.refused)
