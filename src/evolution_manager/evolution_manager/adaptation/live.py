"""Live adaptation's core: a running swarm measured window by window, and Intelligent Trial and Error choosing
which tree the struck robots run after a fault.

The swarm runs one long trial through the node graph. Its performance is measured over windows of simulated
time with the task's own objective (``window_measure``: each robot's objective from its smoothed values at the
window's first and last steps, and the deliveries it made in between, averaged over the robots, as a trial
scores them from its initial and last steps). ``LiveAdaptation`` is told each window's measure and the faults
as they strike, and answers with the swaps to make:

1. *before the fault*: windows follow each other; the mean of the last ``reference`` of them is the
   performance to recover, and the target is ``stop_fraction`` times it;
2. *after the fault*: the first window from the fault's step measures the trees the fault struck. At the
   target or above, nothing changes. Below it, that measure is told to Intelligent Trial and Error
   (``search.IntelligentTrialAndError``, never stopping by its own rule) as the fitness of the tree the robots
   run, the repertoire's best. With ``watch``, a fault that left the swarm at the target is watched on: the
   first later window below the target starts the trials as this window would have (a fault's harm can
   show late: blind robots drifting off with the swarm's food);
3. *trials*: each asked tree is loaded into the faulty robots (or every robot: ``swap="all"``) from ``lead``
   steps after the last step of the window that decided it (the next step by default), and the next window
   from that step measures it. The adaptation ends at the first window at the target (the tree
   stays) or when the budget of trials is spent (the best tree tried comes back, unless it is the one
   running);
4. *kept*: windows go on being measured until the trial ends.

Nothing here imports ``rclpy``: ``evolution_manager.graph.nodes.adapt_live`` is the node around it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from evolution_manager.adaptation.search import (
    AdaptationError,
    Candidate,
    IntelligentTrialAndError,
    ITEParameters,
)
from swarm_sim.model import N_PROBES, OBJECTIVES, Config

MEASURABLE: tuple[str, ...] = (
    "density",
    "nest",
    "food",
    "idensity",
    "inest",
    "foraging",
    "foraging1",
    "foraging2",
    "foraging3",
    "foraging_biased",
    "foraging_balanced",
)
"""The objectives a window is measured with: those scored from the robots' smoothed values and deliveries,
which their controllers publish every step (``wheels``). ``ifood`` and ``aggregation`` read true distances
at a trial's first and last steps and are not measured live."""
SWAPS: tuple[str, ...] = ("faulty", "all")
"""Which robots a trial's tree is loaded into: the robots the fault struck, or every robot."""
PHASES: tuple[str, ...] = ("before-fault", "after-fault", "trial", "kept")


def window_measure(
    objective: str, initial: np.ndarray, final: np.ndarray, delivered: np.ndarray, config: Config
) -> float:
    """The swarm's ``objective`` over one window: each robot's objective (``swarm_sim.core.world``'s
    ``robot_objectives``, the one a trial is scored with) from its smoothed values at the window's first step
    (``initial``, robots x (nest, food, density, ...)) and last step (``final``) and its deliveries in the
    window (``delivered``, robots x food kinds; the swarm's, for ``foraging_balanced``), averaged over the
    robots."""
    if objective not in MEASURABLE:
        raise AdaptationError(
            f"objective {objective!r} cannot be measured live; expected one of {', '.join(MEASURABLE)}"
        )
    from swarm_sim.core import world  # compiled: only where a window is measured

    initial = np.asarray(initial, dtype=np.float64)
    final = np.asarray(final, dtype=np.float64)
    delivered = np.asarray(delivered, dtype=np.int64)
    if initial.shape != final.shape or initial.ndim != 2 or delivered.shape[0] != initial.shape[0]:
        raise AdaptationError(
            f"a window needs each robot's values at its start and end and its deliveries, got shapes "
            f"{initial.shape}, {final.shape} and {delivered.shape}"
        )
    p = config.params()
    k = OBJECTIVES.index(objective)
    probes = np.zeros(N_PROBES)
    swarm = world.swarm_deliveries(delivered)
    values = [
        world.robot_objectives(initial[i], final[i], probes, probes, delivered[i], swarm, 1.0, p)[k]
        for i in range(initial.shape[0])
    ]
    return float(np.mean(values))


@dataclass(frozen=True)
class LiveSettings:
    """How the live adaptation runs (steps are the simulator's sensing steps, 8 a second)."""

    window: int = 80
    """Steps per measured window (80: 10 s)."""
    lead: int = 1
    """Steps from a window's last step to the swap it decided (1: the next step)."""
    budget: int = 10
    """Most trials (trees tried) after a fault."""
    stop_fraction: float = 0.9
    """Performance is back when a window reaches this fraction of the performance before the fault."""
    swap: str = "faulty"
    """Which robots get a trial's tree (``SWAPS``)."""
    reference: int = 2
    """How many of the last windows before the fault make the performance to recover (their mean)."""
    watch: bool = False
    """After a fault that left the swarm at the target, start the trials at the first later window below it
    (else nothing changes after such a fault)."""

    def __post_init__(self) -> None:
        for name in ("window", "lead", "budget", "reference"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise AdaptationError(f"{name} must be a positive whole number, got {value!r}")
        if not (isinstance(self.stop_fraction, int | float) and 0.0 < self.stop_fraction <= 1.0):
            raise AdaptationError(f"stop_fraction must be in (0, 1], got {self.stop_fraction!r}")
        if not isinstance(self.watch, bool):
            raise AdaptationError(f"watch must be True or False, got {self.watch!r}")
        if self.swap not in SWAPS:
            raise AdaptationError(f"swap must be one of {', '.join(SWAPS)}, got {self.swap!r}")


@dataclass(frozen=True)
class Window:
    """One measured window: its first and last steps, the phase, the adaptation trial it measured (0 for
    none) and the measure."""

    start: int
    end: int
    phase: str
    trial: int
    measure: float


@dataclass(frozen=True)
class Swap:
    """Trees to load: ``tree`` into ``robots`` from step ``step`` on; ``trial`` 0 for the final pick."""

    step: int
    robots: tuple[int, ...]
    tree: str
    bin: tuple[int, ...]
    trial: int


@dataclass
class LiveAdaptation:
    """The adaptation's state, told windows and faults, answering with swaps (module docstring)."""

    candidates: Sequence[Candidate]
    robots: int
    settings: LiveSettings = field(default_factory=LiveSettings)
    parameters: ITEParameters = field(default_factory=lambda: ITEParameters(stop_fraction=None))
    first_step: int = 1
    """The step the first window starts at."""

    def __post_init__(self) -> None:
        if not self.candidates:
            raise AdaptationError("no candidates: the repertoire is empty")
        if self.parameters.stop_fraction is not None:
            raise AdaptationError("live adaptation stops on its own target: give ITE stop_fraction=None")
        self.best = max(self.candidates, key=lambda c: c.prior)
        self.trees: list[str] = [self.best.tree] * self.robots
        self.phase = "before-fault"
        self.start = self.first_step
        self.windows: list[Window] = []
        self.swaps: list[Swap] = []
        self.faulty: tuple[int, ...] = ()
        self.fault_step = 0
        self.search: IntelligentTrialAndError | None = None
        self.trial = 0
        self.unchanged = math.nan
        """The measure of the trees the fault struck that decided: the first window after the fault (with
        ``watch``, the first later window below the target where the first was at it)."""
        self.stop_reason = ""
        self.watching = False
        """A fault left the swarm at the target and ``watch`` is on: a window below it starts the trials."""
        self._pending: tuple[int, tuple[int, ...]] | None = None

    @property
    def end(self) -> int:
        """The last step of the window under way."""
        return self.start + self.settings.window - 1

    @property
    def target(self) -> float:
        """``stop_fraction`` times the mean of the last ``reference`` windows before the fault (NaN before the
        first window)."""
        before = [w.measure for w in self.windows if w.phase == "before-fault"][-self.settings.reference :]
        return self.settings.stop_fraction * float(np.mean(before)) if before else math.nan

    def fault(self, step: int, faulty: Sequence[int]) -> None:
        """Faults struck ``faulty`` robots from ``step``: the window under way is dropped and the next
        measures the trees as they are; a fault after the window under way (announced before its last
        answers came) waits for that window to be measured. AdaptationError before any window was measured
        (nothing to recover to)."""
        if step > self.end:
            self._pending = (step, tuple(faulty))
            return
        self._strike(step, faulty)

    def _strike(self, step: int, faulty: Sequence[int]) -> None:
        self._pending = None
        # a window that ended at or after the fault's step (its announcement came late) measured it: dropped
        self.windows = [w for w in self.windows if w.end < step]
        if not [w for w in self.windows if w.phase == "before-fault"]:
            raise AdaptationError(
                f"a fault at step {step}, before the first window ended (step {self.end}): there is no "
                "performance to recover to; strike later or use shorter windows"
            )
        self.faulty = tuple(sorted(int(r) for r in faulty))
        self.fault_step = step
        self.phase, self.trial, self.search, self.stop_reason = "after-fault", 0, None, ""
        self.watching = False
        self.start = step

    def close_window(self, measure: float) -> Swap | None:
        """The window under way ended with ``measure``; the swap it decides, if any (the next window starts at
        the swap's step, else right after this one)."""
        if not math.isfinite(measure):
            raise AdaptationError(f"a window's measure must be a finite number, got {measure!r}")
        self.windows.append(Window(self.start, self.end, self.phase, self.trial, float(measure)))
        swap = None
        if self.phase == "after-fault":
            swap = self._begin(measure)
        elif self.phase == "kept" and self.watching and measure < self.target:
            self.watching, self.stop_reason = False, ""  # the fault's harm showed late: adapt now
            swap = self._begin(measure)
        elif self.phase == "trial":
            assert self.search is not None
            self.search.tell(measure)
            if measure >= self.target:
                self._stop(f"recovered at trial {self.trial}: {measure:.4f} >= target {self.target:.4f}")
            elif self.search.done:
                swap = self._final()
            else:
                swap = self._next_trial()
        self.start = swap.step if swap is not None else self.end + 1
        if self._pending is not None:  # a fault announced before this window's last answers
            self._strike(*self._pending)
        return swap

    def _begin(self, measure: float) -> Swap | None:
        """The unchanged trees measured ``measure`` under the fault: the first trial's swap, or none."""
        self.unchanged = measure
        if measure >= self.target:
            self.watching = self.settings.watch
            self._stop(
                "the fault left the swarm at the target: "
                + ("watching for a window below it" if self.watching else "nothing to adapt")
            )
            return None
        if not self._robots():
            self._stop("no robot to swap: the fault struck none")
            return None
        search = IntelligentTrialAndError(self.candidates, self.settings.budget + 1, self.parameters)
        first = search.ask()  # the repertoire's best, the tree the robots run: measured already
        if first.tree != self.best.tree:  # the same prior twice: the first in bin order
            raise AdaptationError("the search's first pick is not the tree the swarm runs")
        search.tell(measure)
        self.search = search
        return self._next_trial()

    def swap_refused(self, step: int) -> Swap:
        """The last swap reached a robot too late (it had answered ``step`` already): the same swap again,
        ``lead`` steps after ``step``, the window moving with it. AdaptationError when there was no swap."""
        if not self.swaps:
            raise AdaptationError("no swap was made: none can be refused")
        swap = self.swaps[-1]
        again = Swap(step + self.settings.lead, swap.robots, swap.tree, swap.bin, swap.trial)
        self.swaps[-1] = again
        self.start = again.step
        return again

    def _robots(self) -> tuple[int, ...]:
        return self.faulty if self.settings.swap == "faulty" else tuple(range(self.robots))

    def _swap(self, candidate_tree: str, bin_: tuple[int, ...], trial: int) -> Swap:
        swap = Swap(self.end + self.settings.lead, self._robots(), candidate_tree, bin_, trial)
        for robot in swap.robots:
            self.trees[robot] = candidate_tree
        self.swaps.append(swap)
        return swap

    def _next_trial(self) -> Swap:
        assert self.search is not None
        candidate = self.search.ask()
        self.trial += 1
        self.phase = "trial"
        return self._swap(candidate.tree, candidate.bin, self.trial)

    def _final(self) -> Swap | None:
        assert self.search is not None and self.search.best is not None
        best = self.search.best
        self._stop(f"budget of {self.settings.budget} trials spent; best window {best.fitness:.4f}")
        if all(self.trees[r] == best.tree for r in self._robots()):
            return None
        return self._swap(best.tree, best.bin, 0)

    def _stop(self, reason: str) -> None:
        self.phase = "kept"
        self.stop_reason = reason
