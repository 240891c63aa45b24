"""The simulator's side of free timing: each robot's latest answer, whatever step it answered.

In lockstep (``swarm_sim.roads.lockstep``) the world advances a step only once every robot has answered that
step. With ``timing:=free`` the simulator node steps on its own clock and, at each step, advances the world
with what ``FreeAnswers`` holds then:

- each robot's **latest** answer (its motors, broadcast and smoothed values, carrying flag and deliveries),
  whatever sensing step it answered; a robot that has not answered since the chain started is stopped and
  broadcasts the estimate cap, as the world starts (``RobotAnswer`` defaults);
- the tree statuses received since the last tick step, credited at the next tick step: their condition ticks
  summed, the newest action started counted (a tick step without a status counts none);
- deliveries counted from the trial's first step (``begin_trial``): a free-running controller does not know
  where a chain's trials end, so it keeps counting across them.

No ROS here, so that the policy is tested without a graph; ``swarm_sim.nodes.simulator`` feeds it from its
subscriptions.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from bt_controller.language import STOP
from swarm_sim.roads.lockstep import RobotAnswer


@dataclass
class _Pending:
    condition_ticks: int = 0
    started: int = -1
    statuses: int = 0


@dataclass
class FreeAnswers:
    """The answers a free-stepping simulator uses: one latest answer per robot (see the module)."""

    robots: int
    estimate_cap: float
    regions: int = 2
    """The nest and the world's food kinds."""
    latest: list[RobotAnswer | None] = field(default_factory=list)
    pending: list[_Pending] = field(default_factory=list)
    baseline: list[tuple[int, ...]] = field(default_factory=list)
    answers_taken: int = 0
    """Answers received since the chain started (for diagnostics)."""

    def __post_init__(self) -> None:
        if self.robots < 1:
            raise ValueError(f"expected at least one robot, got {self.robots}")
        self.start_chain()

    def start_chain(self) -> None:
        """Forget every answer: a new chain starts (its controllers were just reset)."""
        self.latest = [None] * self.robots
        self.pending = [_Pending() for _ in range(self.robots)]
        self.baseline = [(0,) * (self.regions - 1)] * self.robots
        self.answers_taken = 0

    def answer(self, robot: int, answer: RobotAnswer) -> None:
        """Robot ``robot``'s newest answer (its ``condition_ticks`` and ``started`` are ignored: a status
        carries them)."""
        self.latest[robot] = answer
        self.answers_taken += 1

    def status(self, robot: int, condition_ticks: int, started: int) -> None:
        """A tick's status from robot ``robot``: ``condition_ticks`` condition nodes ticked, action
        ``started`` started (-1: none)."""
        pending = self.pending[robot]
        pending.condition_ticks += int(condition_ticks)
        pending.statuses += 1
        if started >= 0:
            pending.started = int(started)

    def begin_trial(self) -> None:
        """A trial starts: its deliveries count from each robot's deliveries now."""
        self.baseline = [
            tuple(a.deliveries) if a is not None else (0,) * (self.regions - 1) for a in self.latest
        ]

    def answers(self, ticks: bool) -> list[RobotAnswer]:
        """Every robot's answer for the step under way; ``ticks``: whether it is a tick step (the statuses
        received since the last one are then credited and cleared)."""
        out = []
        for robot, latest in enumerate(self.latest):
            kinds = self.regions - 1
            answer = latest or RobotAnswer(
                action=STOP,
                broadcast=(self.estimate_cap,) * self.regions,
                smoothed=(0.0,) * (self.regions + 1),
                carrying=(False,) * kinds,
                deliveries=(0,) * kinds,
            )
            deliveries = tuple(
                max(0, now - before)
                for now, before in zip(answer.deliveries, self.baseline[robot], strict=True)
            )
            pending = self.pending[robot]
            if ticks:
                answer = replace(
                    answer,
                    condition_ticks=pending.condition_ticks,
                    started=pending.started,
                    deliveries=deliveries,
                )
                self.pending[robot] = _Pending()
            else:
                answer = replace(answer, condition_ticks=0, started=-1, deliveries=deliveries)
            out.append(answer)
        return out
