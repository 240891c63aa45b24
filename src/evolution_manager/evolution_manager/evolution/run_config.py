"""The configuration of one run: algorithm, objective, budget, seed; and the per-evaluation seeds.

Defaults follow ``docs/algorithms.md``: GP_o and QD_o produce 25,000 individuals on one objective,
GP_fnd 75,000 on all three at once (the budget counts individuals produced by the generations after the
initial population, as the paper's table 5: 1000 generations of 25, 500 batches of 50).

Scenarios: under ``fixed`` (the default, as the authors) every evaluation of a run uses the run's scenario
seed, so a tree has one exact fitness and a tree seen before need not be simulated again; under ``fresh``
evaluation ``i`` draws its own seed from the run seed and ``i`` (noisy fitness).

Profile: the model's profile every evaluation of the run uses (``docs/model.md``: ``paper``, the authors'
experiment, or ``clean``), recorded in ``config.json``. It also decides what a run does with clones, trees
that simplify to the same tree (``docs/algorithms.md``, "Clones"): under ``paper`` with fixed scenarios a
tree whose simplified form an earlier batch evaluated takes that evaluation's values unsimulated, as the
authors' code; under ``clean`` every grid refuses a tree whose simplified form is already in its bin.

Task: the world every evaluation runs in and the node set's conditions (``swarm_sim.tasks``: ``primitives``,
the 2023 20 s trials with the paper's 8 conditions, ``foraging``, the 2024 100 s trials with every condition,
``got_food`` too, or a task file), kept whole in ``config.json``. Objectives: GP_o and QD_o evolve one of
``OBJECTIVES``, GP_fnd any set of them (``fnd_objectives``; by default the task's: the paper's three, or
foraging alone). A run also keeps a passive grid per objective of ``grids``: the task's objectives and the
evolved ones. Library: a primitive library (``bt_controller.language.library``) whose names become terminals
of the node set; the run keeps a copy of it (``library.json`` in the run directory) and records the file and
its digest here.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING

from bt_controller.draws import (
    MAX_SEED,
    RUN_ALGORITHM,
    RUN_EVALUATION,
    RUN_HELDOUT,
    RUN_SCENARIO,
    derive_seed,
)
from bt_controller.language import ACTIONS, CONDITIONS, Library
from bt_controller.model_settings import PROFILES, Timeline
from bt_controller.validate import integer
from evolution_manager.errors import ConfigError
from evolution_manager.evolution.descriptor_sets import checked_space
from evolution_manager.evolution.parameters import (
    HIERARCHICAL_CONDITIONS,
    NODE_SETS,
    GPParameters,
    QDParameters,
)
from swarm_sim.model import OBJECTIVES, Config
from swarm_sim.tasks import DEFAULT_TASK, TaskSpec, resolve_task, task_from_record, task_named, task_to_record

if TYPE_CHECKING:  # see make_algorithm
    from evolution_manager.evolution.algorithms import AskTell
    from evolution_manager.evolution.archive import SimplifiedForms

DEFAULT_PROFILE: str = PROFILES[Timeline().profile]
"""The model's default profile (``bt_controller.robot.timeline``): runs that name none use it."""

ALGORITHMS: tuple[str, ...] = ("gp", "gp-fnd", "qd")
"""Command-line names: GP_o, GP_fnd, QD_o (MAP-Elites)."""

DEFAULT_EVALUATIONS = {"gp": 25_000, "gp-fnd": 75_000, "qd": 25_000}

LABELS = {"gp": "GP_o", "gp-fnd": "GP_fnd", "qd": "QD_o"}

SCENARIOS: tuple[str, ...] = ("fixed", "fresh")
"""``fixed``: every evaluation of a run on the run's scenario seed; ``fresh``: a new seed per evaluation."""

HELDOUT_EVALUATIONS = 5
"""Evaluations (of ``trials`` trials each, on fresh scenarios) behind every held-out score."""


def heldout_seed(scenario_seed: int, repeat: int) -> int:
    """The seed of held-out evaluation ``repeat`` of a run on ``scenario_seed``: a scenario it never used."""
    return derive_seed(scenario_seed, RUN_HELDOUT, repeat)


def default_scenario_seed(run_seed: int) -> int:
    """The scenario seed of a run when none is given: derived from the run seed."""
    return derive_seed(run_seed, RUN_SCENARIO)


@dataclass(frozen=True)
class RunConfig:
    """One run. ``objective`` is None for ``gp-fnd``, which evolves all three objectives."""

    algorithm: str
    objective: str | None
    evaluations: int
    seed: int
    trials: int = 10
    gp: GPParameters = field(default_factory=GPParameters)
    qd: QDParameters = field(default_factory=QDParameters)
    scenarios: str = "fixed"
    scenario_seed: int = -1
    """-1: derived from ``seed`` (see :func:`default_scenario_seed`); replaced by the value at creation."""
    profile: str = DEFAULT_PROFILE
    """The model's profile (``docs/model.md``), the same for every evaluation of the run."""
    task: TaskSpec = field(default_factory=lambda: task_named(DEFAULT_TASK))
    """The task: the world and the node set's conditions (``swarm_sim.tasks``); a name is taken for the
    registered task."""
    fnd_objectives: tuple[str, ...] = ()
    """GP_fnd: the objectives it evolves at once (empty: the task's, ``TASK_OBJECTIVES``); empty otherwise."""
    library: str = ""
    """The primitive library file the run was started with ("" for none); the run uses its copy."""
    library_digest: str = ""
    """The digest of that library (``bt_controller.language.library.Library.digest``)."""
    nodes: str = "flat"
    """The node set (``parameters.NODE_SETS``): ``flat`` or ``hierarchical`` (needs a library)."""
    descriptors: str = "behaviour"
    """The behaviour space the grids bin trees by (``descriptor_sets.DESCRIPTOR_SETS``): ``behaviour`` (the
    paper's) or ``deliveries`` (the deliveries of each food kind: a task with several)."""

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise ConfigError(f"algorithm must be one of {', '.join(ALGORITHMS)}, got {self.algorithm!r}")
        if isinstance(self.task, str):  # a registered name, for convenience
            object.__setattr__(self, "task", resolve_task(self.task))
        if set(self.task.nodes.actions) != set(ACTIONS):
            raise ConfigError(
                f"task {self.task.name}: nodes.actions must be every action ({', '.join(ACTIONS)}): "
                "evolution draws trees over all of them"
            )
        object.__setattr__(self, "fnd_objectives", tuple(self.fnd_objectives))
        if self.algorithm == "gp-fnd":
            if self.objective is not None:
                raise ConfigError("gp-fnd evolves a set of objectives at once: leave out the objective")
            for name in self.fnd_objectives:
                if name not in OBJECTIVES:
                    raise ConfigError(f"objectives must be among {', '.join(OBJECTIVES)}; got {name!r}")
            if len(set(self.fnd_objectives)) != len(self.fnd_objectives):
                raise ConfigError(f"objectives must be distinct, got {', '.join(self.fnd_objectives)}")
        else:
            if self.fnd_objectives:
                raise ConfigError(f"{self.algorithm} evolves one objective; a set of them is for gp-fnd")
            if self.objective not in OBJECTIVES:
                raise ConfigError(
                    f"{self.algorithm} needs an objective, one of {', '.join(OBJECTIVES)}; "
                    f"got {self.objective!r}"
                )
        if bool(self.library) != bool(self.library_digest):
            raise ConfigError("a library needs its digest (and a digest its library)")
        try:
            checked_space(self.descriptors, self.task, "trees", "multifood-arena6")
        except ValueError as error:
            raise ConfigError(str(error)) from None
        if self.nodes not in NODE_SETS:
            raise ConfigError(f"nodes must be one of {', '.join(NODE_SETS)}, got {self.nodes!r}")
        if self.nodes == "hierarchical" and not self.library:
            raise ConfigError(
                "the hierarchical node set has a library's primitives as leaves: give --library"
            )
        integer(self.evaluations, "evaluations", 1, error=ConfigError)
        integer(self.seed, "seed", 0, MAX_SEED, error=ConfigError)
        integer(self.trials, "trials", 1, error=ConfigError)
        if self.scenarios not in SCENARIOS:
            raise ConfigError(f"scenarios must be one of {', '.join(SCENARIOS)}, got {self.scenarios!r}")
        if self.scenario_seed == -1:  # frozen: set once, at creation
            object.__setattr__(self, "scenario_seed", default_scenario_seed(self.seed))
        integer(self.scenario_seed, "the scenario seed", 0, MAX_SEED, error=ConfigError)
        if self.profile not in PROFILES:
            raise ConfigError(f"profile must be one of {', '.join(PROFILES)}, got {self.profile!r}")

    @classmethod
    def make(
        cls,
        algorithm: str,
        objective: str | None,
        evaluations: int | None,
        seed: int,
        trials: int = 10,
        scenarios: str = "fixed",
        scenario_seed: int | None = None,
        profile: str | None = None,
        task: TaskSpec | str = DEFAULT_TASK,
        fnd_objectives: tuple[str, ...] = (),
        library: str = "",
        library_digest: str = "",
        nodes: str | None = None,
        descriptors: str = "behaviour",
    ) -> RunConfig:
        """A configuration with the paper's parameters for ``algorithm`` (population 75 and tournament 5
        for gp-fnd), its default budget when ``evaluations`` is None and the scenario seed derived from
        ``seed`` when ``scenario_seed`` is None; the model's default profile when ``profile`` is None.
        ``nodes`` None: ``hierarchical`` with a library, else ``flat``. GP over the flat node set of the
        foraging task without a library (the 2024 flat baseline) derates as the authors' baseline
        (``parameters.DERATINGS``, ``baseline``); every other GP run as the 2023 GP."""
        if algorithm not in ALGORITHMS:
            raise ConfigError(f"algorithm must be one of {', '.join(ALGORITHMS)}, got {algorithm!r}")
        if nodes is None:
            nodes = "hierarchical" if library else "flat"
        task = resolve_task(task)
        baseline = "foraging" in task.objectives and nodes == "flat" and not library
        derating = "baseline" if baseline else "standard"
        gp = (
            GPParameters(population=75, tournament=5, derating=derating)
            if algorithm == "gp-fnd"
            else GPParameters(derating=derating)
        )
        budget = DEFAULT_EVALUATIONS[algorithm] if evaluations is None else evaluations
        return cls(
            algorithm,
            objective,
            budget,
            seed,
            trials,
            gp=gp,
            scenarios=scenarios,
            scenario_seed=-1 if scenario_seed is None else scenario_seed,
            profile=DEFAULT_PROFILE if profile is None else profile,
            task=task,
            fnd_objectives=fnd_objectives,
            library=library,
            library_digest=library_digest,
            nodes=nodes,
            descriptors=descriptors,
        )

    def request_seed(self, index: int) -> int:
        """The simulator seed of evaluation ``index`` (0-based) of this run (``scenario_of_evaluation``)."""
        return scenario_of_evaluation(self.scenarios, self.scenario_seed, self.seed, index)

    def heldout_seed(self, repeat: int) -> int:
        """The seed of held-out evaluation ``repeat`` (0 to ``HELDOUT_EVALUATIONS`` - 1), the same for every
        tree re-scored at the end of the run: scenarios the run never used."""
        return heldout_seed(self.scenario_seed, repeat)

    @property
    def objectives(self) -> tuple[str, ...]:
        """The objectives this run evolves, in ``OBJECTIVES`` order."""
        if self.objective is not None:
            return (self.objective,)
        chosen = self.fnd_objectives or self.task.objectives
        return tuple(o for o in OBJECTIVES if o in chosen)

    @property
    def grids(self) -> tuple[str, ...]:
        """The objectives the run keeps a passive grid of and shows (summary, repertoires, figures): the
        task's and the evolved ones, in ``OBJECTIVES`` order."""
        shown = set(self.task.objectives) | set(self.objectives)
        return tuple(o for o in OBJECTIVES if o in shown)

    @property
    def label(self) -> str:
        """``GP_o``-style label: GP_food, GP_fnd, QD_nest."""
        if self.algorithm == "gp-fnd":
            return "GP_fnd"
        return f"{LABELS[self.algorithm][:-2]}_{self.objective}"

    def to_json(self) -> dict:
        """The configuration as ``config.json`` holds it. The node set and the GP derating are left out at
        their values of before they existed (``flat``, ``standard``), so that the files of earlier runs and
        experiments (``config.json``, ``heldout.json``, ``experiment.json``) still compare equal."""
        data = asdict(self)
        data["task"] = task_to_record(self.task)
        data["fnd_objectives"] = list(self.fnd_objectives)
        data["gp"]["mutations"] = [list(m) for m in self.gp.mutations]
        data["qd"]["mutations"] = [list(m) for m in self.qd.mutations]
        if self.nodes == "flat":
            del data["nodes"]
        if self.gp.derating == "standard":
            del data["gp"]["derating"]
        if self.descriptors == "behaviour":
            del data["descriptors"]
        return data

    @classmethod
    def from_json(cls, data: dict) -> RunConfig:
        try:
            gp = dict(data["gp"])
            qd = dict(data["qd"])
            gp["mutations"] = tuple((str(n), float(p)) for n, p in gp["mutations"])
            qd["mutations"] = tuple((str(n), float(p)) for n, p in qd["mutations"])
            return cls(
                str(data["algorithm"]),
                None if data["objective"] is None else str(data["objective"]),
                integer(data["evaluations"], "evaluations"),
                integer(data["seed"], "seed"),
                integer(data["trials"], "trials"),
                gp=GPParameters(**gp),
                qd=QDParameters(**qd),
                # run directories written before scenarios existed drew a fresh seed per evaluation
                scenarios=str(data.get("scenarios", "fresh")),
                scenario_seed=integer(data.get("scenario_seed", -1), "scenario_seed"),
                # run directories written before profiles existed ran the model's default
                profile=str(data.get("profile", DEFAULT_PROFILE)),
                # ... and before tasks and libraries, the primitives' trials without a library
                task=task_from_record(data.get("task"), "config.json: task"),
                fnd_objectives=tuple(str(o) for o in data.get("fnd_objectives", ())),
                library=str(data.get("library", "")),
                library_digest=str(data.get("library_digest", "")),
                # ... and before node sets, the flat one
                nodes=str(data.get("nodes", "flat")),
                # ... and before descriptor sets, the paper's
                descriptors=str(data.get("descriptors", "behaviour")),
            )
        except (KeyError, TypeError, ValueError, OverflowError) as error:
            if isinstance(error, ConfigError):
                raise
            raise ConfigError(f"not a run configuration: {error}") from error

    def world(self) -> Config:
        """The model every evaluation of the run uses: its task's world under its profile."""
        return self.task.config(self.profile)

    @property
    def conditions(self) -> tuple[str, ...]:
        """The conditions of the run's node set: the task's, in blackboard order (``primitives``: the paper's
        eight; ``foraging``: all, with ``got_food``: the 2024 baseline's node set, params.py:168-189 at
        a73e4af)."""
        if self.nodes == "hierarchical":
            return HIERARCHICAL_CONDITIONS
        return tuple(c for c in CONDITIONS if c in self.task.nodes.conditions)

    @property
    def refuses_clones(self) -> bool:
        """Whether the run's grids refuse a tree whose simplified form is already in its bin (``clean``)."""
        return self.profile == "clean"

    @property
    def inherits_by_form(self) -> bool:
        """Whether a tree whose simplified form an earlier batch of the run evaluated takes that evaluation's
        fitness and descriptors without being simulated (``paper`` with ``fixed`` scenarios: the authors'
        qdpy/ea.py:447-478 and gp/ea.py:506-555)."""
        return self.profile == "paper" and self.scenarios == "fixed"

    def make_algorithm(self, library: Library | None = None, forms: SimplifiedForms | None = None) -> AskTell:
        """A fresh algorithm for this configuration, with its own generator seeded from the run seed;
        ``library``: the run's primitive library (its names become terminals; the run's copy of
        ``self.library``); ``forms``: the run's simplified forms, shared with MAP-Elites' archive when it
        refuses clones."""
        # late: DEAP and qdpy (about 0.1 s) load when a run starts, not when a command's options are read
        from evolution_manager.evolution.algorithms import GeneticProgramming, MapElites
        from evolution_manager.evolution.archive import SimplifiedForms

        if (library.digest if library is not None else "") != self.library_digest:
            raise ConfigError(
                f"the primitive library given ({library.label if library else 'none'}) is not the run's "
                f"({self.library or 'none'})"
            )
        algorithm_seed = derive_seed(self.seed, RUN_ALGORITHM)
        if self.algorithm == "qd":
            grid_forms = (forms or SimplifiedForms(library)) if self.refuses_clones else None
            objective = OBJECTIVES.index(self.objective)
            return MapElites(
                objective,
                self.evaluations,
                algorithm_seed,
                self.qd,
                self.conditions,
                library,
                grid_forms,
                self.nodes,
            )
        objectives = [OBJECTIVES.index(o) for o in self.objectives]
        return GeneticProgramming(
            objectives, self.evaluations, algorithm_seed, self.gp, self.conditions, library, self.nodes
        )


def scenario_of_evaluation(scenarios: str, scenario_seed: int, run_seed: int, index: int) -> int:
    """The simulator seed of evaluation ``index`` (0-based) of a run of any kind: the scenario seed under
    ``fixed`` scenarios; under ``fresh`` a seed of its own (:func:`evaluation_seed`)."""
    return scenario_seed if scenarios == "fixed" else evaluation_seed(run_seed, index)


def evaluation_seed(run_seed: int, index: int) -> int:
    """The simulator seed of evaluation number ``index`` (0-based) of a run: a pure function of the run
    seed and the index, so that a resumed or distributed run draws exactly the same trials."""
    return derive_seed(run_seed, RUN_EVALUATION, index)
