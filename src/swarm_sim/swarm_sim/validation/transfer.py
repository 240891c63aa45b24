"""Transfer check: do trees evolved here behave in the authors' ARGoS simulation as they do here?

``ws/run swarm_sim validate --transfer RUN_DIR ...`` (``swarm_sim.validation.cli``) takes evolution run
directories (as ``ws/run evolution_manager evolve`` writes them), picks trees from their repertoires, scores
each here on fresh scenarios and in ARGoS through the project's ARGoS harness, and sets the six quantities
side by side with the tolerance rule of ``swarm_sim.validation.reference``.

**Which trees.** From each run, the grid of every objective the run evolved (``summary.json``:
``objectives.<o>.evolved``; without a summary, every ``repertoire_<objective>.json`` present). A grid's
candidates are its bins' elites (the fittest item of each filled bin, the first on ties). The first pick is
the grid's best tree (highest fitness, lowest bin on ties); then ``per_run`` more, each time the candidate
whose bin centre is farthest (Euclidean, in the unit cube of the descriptors, bin centres at (b + 0.5) /
size) from every tree picked so far in that grid, the lowest bin on ties: farthest-point sampling, a pure
function of the grid. A tree text picked before (from another grid) is passed over.

**ARGoS.** The harness's driver ``argos_eval.py batch`` runs the evaluations and appends one row per (tree,
seed) to a raw TSV, which doubles as a cache: rows already there are not run again, and when every row is
there the driver is not needed at all. Everything here but ``run_driver`` is pure or reads files.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
import subprocess
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from bt_controller.validate import strict_json
from swarm_ros.safe_paths import open_no_follow, refuse_links
from swarm_sim.errors import UsageError
from swarm_sim.model import DESCRIPTORS, OBJECTIVES, PAPER_OBJECTIVES
from swarm_sim.validation import reference as validation
from swarm_sim.validation.reference import INDISTINGUISHABLE, MAX_Z, OUTSIDE, Comparison, Estimate, tsv_rows

__all__ = [
    "ArgosHarness",
    "GridItem",
    "Pick",
    "TransferRow",
    "argos_estimates",
    "farthest_points",
    "grid_elites",
    "network_means",
    "parse_seeds",
    "pick_trees",
    "read_foraging_raw",
    "read_network_raw",
    "read_raw_column",
    "read_transfer_tsv",
    "render_markdown",
    "render_summary",
    "seeds_text",
    "subs_text",
    "transfer_tsv",
]

RAW_HALF_RANGE = validation.RAW_DESCRIPTOR_HALF_RANGE
QUANTITIES: tuple[str, ...] = (*PAPER_OBJECTIVES, *DESCRIPTORS)
"""The six quantities the ARGoS driver measures in the primitives' 20 s trials (the 2023 build): the paper's
three objectives and the three descriptors. Runs of the foraging task, or with a primitive library, are not
transferred (the driver knows neither)."""


@dataclass(frozen=True)
class GridItem:
    """A bin's elite of a repertoire grid."""

    bin: tuple[int, ...]
    tree: str
    fitness: float
    descriptors: tuple[float, ...]


@dataclass(frozen=True)
class Pick:
    """A tree picked for the check and where it came from."""

    run: str
    """The run directory's name (or ``hand`` for a tree given on the command line)."""
    objective: str
    """The grid's objective: the fitness of this tree that the run evolved."""
    bin: tuple[int, ...]
    role: str
    """``best``, ``spread N`` (the N-th farthest-point pick) or ``hand``."""
    tree: str
    fitness: float | None
    """The fitness recorded in the repertoire (the evolution's own scenario)."""


@dataclass(frozen=True)
class TransferRow:
    """One picked tree's six comparisons (``QUANTITIES`` order)."""

    pick: Pick
    comparisons: tuple[Comparison, ...]

    @property
    def own_fitness(self) -> Comparison | None:
        """The comparison of the fitness its grid evolved (None for a hand-made tree)."""
        for c in self.comparisons:
            if c.quantity == self.pick.objective:
                return c
        return None


# ------------------------------------------------------------------------------------------ picking trees


def seeds_text(seeds: Sequence[int]) -> str:
    """Seeds as a report names them: ``A-B`` for consecutive seeds, else the list."""
    seeds = list(seeds)
    return f"{seeds[0]}-{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) else str(seeds)


def parse_seeds(text: str) -> list[int]:
    """Seeds from ``N`` (1..N), ``A-B`` (A..B) or a comma-separated list of these; UsageError when bad."""
    text = text.strip()
    if text.isdigit():
        return list(range(1, int(text) + 1))
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        lo, dash, hi = part.partition("-")
        try:
            if dash:
                seeds.extend(range(int(lo), int(hi) + 1))
            else:
                seeds.append(int(part))
        except ValueError:
            raise UsageError(
                f"--seeds: expected N, A-B or a comma-separated list of these, got {text!r}"
            ) from None
    if not seeds or min(seeds) < 1 or len(set(seeds)) != len(seeds):
        raise UsageError(f"--seeds: expected distinct seeds >= 1, got {text!r}")
    return seeds


def _read_json(path: Path) -> dict:
    try:  # strictly: NaN, infinities and a key given twice refused (bt_controller.validate.strict_json)
        document = strict_json(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise UsageError(f"{path}: cannot read ({error.strerror or error})") from None
    except json.JSONDecodeError as error:
        raise UsageError(f"{path}: not JSON ({error.msg} at line {error.lineno})") from None
    except UnicodeDecodeError as error:
        raise UsageError(f"{path}: not UTF-8 text (byte {error.start}: {error.reason})") from None
    except ValueError as error:  # strict_json's refusals
        raise UsageError(f"{path}: {error}") from None
    if not isinstance(document, dict):
        raise UsageError(f"{path}: expected a JSON object")
    return document


def grid_elites(path: Path) -> tuple[str, tuple[int, ...], list[GridItem]]:
    """(objective, grid shape, elites in bin order) of a ``repertoire_<objective>.json``."""
    document = _read_json(path)
    try:
        objective = str(document["objective"])
        shape = tuple(int(s) for s in document["shape"])
        best: dict[tuple[int, ...], GridItem] = {}
        for item in document["items"]:
            index = tuple(int(b) for b in item["bin"])
            fitness = float(item["fitness"])
            if len(index) != len(shape) or not all(0 <= b < s for b, s in zip(index, shape, strict=True)):
                raise ValueError(f"bin {list(index)} outside the grid {list(shape)}")
            if not math.isfinite(fitness):
                raise ValueError(f"fitness of bin {list(index)} is not finite")
            if index not in best or fitness > best[index].fitness:
                best[index] = GridItem(
                    index, str(item["tree"]), fitness, tuple(float(d) for d in item["descriptors"])
                )
    except (KeyError, TypeError, ValueError) as error:
        raise UsageError(f"{path}: not a repertoire file ({error})") from None
    if objective not in OBJECTIVES:
        raise UsageError(f"{path}: objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    return objective, shape, [best[index] for index in sorted(best)]


def farthest_points(
    items: Sequence[GridItem], shape: Sequence[int], extra: int
) -> list[tuple[str, GridItem]]:
    """The best item, then up to ``extra`` more by farthest-point sampling of bin centres (see the module's
    docstring), as (role, item)."""
    if not items:
        return []
    first = max(items, key=lambda item: (item.fitness, tuple(-b for b in item.bin)))

    def centre(item: GridItem) -> tuple[float, ...]:
        return tuple((b + 0.5) / s for b, s in zip(item.bin, shape, strict=True))

    chosen = [("best", first)]
    nearest = {item.bin: math.dist(centre(item), centre(first)) for item in items}
    for k in range(1, extra + 1):
        remaining = [item for item in items if nearest[item.bin] > 0.0]
        if not remaining:
            break
        far = max(remaining, key=lambda item: (nearest[item.bin], tuple(-b for b in item.bin)))
        chosen.append((f"spread {k}", far))
        for item in items:
            nearest[item.bin] = min(nearest[item.bin], math.dist(centre(item), centre(far)))
    return chosen


def evolved_objectives(run_dir: Path) -> list[str]:
    """The objectives a run evolved (its ``summary.json``), else every objective with a repertoire file."""
    summary = run_dir / "summary.json"
    if summary.is_file():
        objectives = _read_json(summary).get("objectives")
        if not isinstance(objectives, dict):
            raise UsageError(f"{summary}: no 'objectives' object (not a run's summary)")
        return [o for o in OBJECTIVES if isinstance(objectives.get(o), dict) and objectives[o].get("evolved")]
    return [o for o in OBJECTIVES if (run_dir / f"repertoire_{o}.json").is_file()]


def scenario_seed(run_dir: Path) -> int | None:
    """The run's fixed scenario seed (``config.json``), if it has one."""
    config = run_dir / "config.json"
    if not config.is_file():
        return None
    value = _read_json(config).get("scenario_seed")
    return int(value) if isinstance(value, int) else None


def pick_trees(run_dirs: Sequence[Path], per_run: int) -> list[Pick]:
    """The trees to check: per run directory and evolved objective, the grid's best and ``per_run`` more
    (``farthest_points``); a tree text picked before is passed over (the next farthest takes its place)."""
    picks: list[Pick] = []
    seen: set[str] = set()
    for run_dir in run_dirs:
        if not run_dir.is_dir():
            raise UsageError(f"--transfer {run_dir}: not a directory (expected an evolution run directory)")
        config = run_dir / "config.json"
        settings = _read_json(config) if config.is_file() else {}
        if settings.get("task", "primitives") != "primitives" or settings.get("library"):
            raise UsageError(
                f"--transfer {run_dir}: a run of the {settings.get('task')} task"
                + (f" with the library {settings['library']}" if settings.get("library") else "")
                + ": the ARGoS driver measures the primitives' trials without libraries only"
            )
        objectives = evolved_objectives(run_dir)
        beyond = [o for o in objectives if o not in PAPER_OBJECTIVES]
        if beyond:
            raise UsageError(
                f"--transfer {run_dir}: evolved {', '.join(beyond)}; the ARGoS driver measures "
                f"{', '.join(PAPER_OBJECTIVES)} only"
            )
        if not objectives:
            raise UsageError(
                f"--transfer {run_dir}: holds no repertoire_<objective>.json of an evolved objective"
            )
        for objective in objectives:
            path = run_dir / f"repertoire_{objective}.json"
            found, shape, items = grid_elites(path)
            if found != objective:
                raise UsageError(f"{path}: holds the objective {found!r}, not {objective!r}")
            fresh = [item for item in items if item.tree not in seen]
            for role, item in farthest_points(fresh, shape, per_run):
                seen.add(item.tree)
                picks.append(Pick(run_dir.name, objective, item.bin, role, item.tree, item.fitness))
    return picks


# ------------------------------------------------------------------------------------------------- ARGoS


@dataclass(frozen=True)
class ArgosHarness:
    """The project's ARGoS harness: its driver script and the build it drives (the driver's own environment
    variables and defaults, ``argos_eval.py``'s docstring)."""

    driver: Path

    @staticmethod
    def from_environment(driver: str | None) -> ArgosHarness:
        """The harness at ``driver`` (else ``$ARGOS_EVAL``); UsageError when none is named."""
        path = driver or os.environ.get("ARGOS_EVAL")
        if not path:
            raise UsageError(
                "no ARGoS harness: name its argos_eval.py with --argos-eval or $ARGOS_EVAL "
                "(docs/validation/README.md)"
            )
        return ArgosHarness(Path(path))

    def missing(self, build: str = "2023") -> list[Path]:
        """The files of the driver and of ``build`` (``BUILDS``) that are not there."""
        home = Path.home() / "argos-check"
        prefix = Path(os.environ.get("ARGOS_PREFIX", home / "install"))
        variable, folder = BUILDS[build]
        tree = Path(os.environ.get(variable, home / folder / "argos3"))
        shim = Path(os.environ.get("SRAND_SHIM", home / "build-shim" / "libsrand_shim.so"))
        controllers = (
            ("footbot_nn", "nn_loop_functions")
            if build == NETWORK_BUILD
            else ("footbot_bt", "bt_loop_functions")
        )
        needed = [
            self.driver,
            prefix / "bin" / "argos3",
            tree / "build" / "controllers" / controllers[0] / f"lib{controllers[0]}.so",
            tree / "build" / "loop_functions" / controllers[1] / f"lib{controllers[1]}.so",
            shim,
        ]
        return [path for path in needed if not path.is_file()]

    def _check(self, build: str) -> None:
        missing = self.missing(build)
        if missing:
            raise UsageError(
                f"ARGoS build not found: {', '.join(map(str, missing))} missing "
                f"(build it with the harness's {REBUILD[build]}; docs/validation/README.md)"
            )

    def run(
        self,
        trees: Sequence[str],
        seeds: Sequence[int],
        raw: Path,
        jobs: int,
        work: Path,
        build: str = "2023",
        subs: Path | None = None,
    ) -> None:
        """Evaluate every (tree, seed) missing from ``raw`` with the driver (``batch``, which appends to
        ``raw``) in ``build``, named primitives defined by the sub-behaviours file ``subs``; UsageError when
        the build is missing or the driver fails."""
        self._check(build)
        trees_file = work / "transfer_trees.txt"
        trees_file.write_text("".join(f"{tree}\n" for tree in trees))
        spec = ",".join(str(s) for s in seeds)
        command = ["python3", str(self.driver), "batch", "--trees", str(trees_file), "--seeds", spec]
        command += ["--raw", str(raw), "--jobs", str(jobs)]
        if build != "2023":
            command += ["--build", build]
        if subs is not None:
            command += ["--subs", str(subs)]
        _run_driver(command)

    def run_networks(
        self, networks: Sequence[str], seeds: Sequence[int], trial_s: int, raw: Path, work: Path
    ) -> None:
        """Evaluate every (network, seed) missing from ``raw`` at ``trial_s`` seconds a trial in the
        authors' footbot_nn (the driver's ``eval --build multifood --nn``, its work folder kept under
        ``work`` and read for all ten of the controller's per-trial values), appending one row each in
        ``NETWORK_RAW_COLUMNS``. ``networks``: ``nn: w1 ... w56`` lines. UsageError when the build is
        missing or the driver fails."""
        refuse_links(raw)
        have = read_network_raw(raw)
        todo = [(n, s) for n in networks for s in seeds if (n, s, trial_s) not in have]
        if not todo:
            return
        self._check(NETWORK_BUILD)
        keep = (work / "argos_network_run").absolute()  # the driver runs ARGoS from inside it
        refuse_links(keep)  # the driver empties and fills it
        if not raw.exists():
            _append(raw, "\t".join(NETWORK_RAW_COLUMNS) + "\n")
        for network, seed in todo:
            weights = network.removeprefix(validation.NETWORK_PREFIX).strip()
            command = ["python3", str(self.driver), "eval", "--build", NETWORK_BUILD, "--nn", weights]
            command += ["--seed", str(seed), "--trial-s", str(trial_s), "--keep", str(keep)]
            done = _run_driver(command)
            per_gap = [
                network_means((keep / "txt" / f"result_gap{gap:g}.txt").read_text()) for gap in NETWORK_GAPS
            ]
            values = [math.fsum(g[i] for g in per_gap) / len(per_gap) for i in range(len(NETWORK_SLOTS))]
            wall = float(json.loads(done.stdout)["argos_wall_s"])
            cells = [network, str(seed), str(trial_s), *(f"{v:.9g}" for v in values)]
            cells += [f"{v:.9g}" for g in per_gap for v in g] + [f"{wall:.3f}"]
            _append(raw, "\t".join(cells) + "\n")


def _run_driver(command: list[str]) -> subprocess.CompletedProcess[str]:
    """Run the ARGoS driver; UsageError with its last line of output when it fails."""
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        last = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no output"]
        raise UsageError(f"the ARGoS driver failed (exit {done.returncode}): {last[0]}")
    return done


def _append(path: Path, text: str) -> None:
    """Append ``text`` to ``path`` (made if missing), never through a symbolic link."""
    descriptor = open_no_follow(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT)
    with os.fdopen(descriptor, "a", encoding="utf-8") as out:
        out.write(text)


BUILDS: dict[str, tuple[str, str]] = {
    "2023": ("BT_ARGOS_DIR", "bmr"),
    "foraging": ("BT_ARGOS_DIR_FORAGING", "bmr-a73"),
    "primitives": ("BT_ARGOS_DIR_PRIMITIVES", "bmr-a73-prim"),
    "multifood": ("BT_ARGOS_DIR_MULTIFOOD", "bmr-2026"),
}
"""The harness's builds this module drives: the environment variable naming the build's ``argos3`` folder
and the folder under ``~/argos-check`` it defaults to (the driver's own defaults): the 2023 commit (the
primitives' 20 s trials), the 2024 commit's foraging setting (100 s trials, deliveries) and its six
primitives (20 s trials), and the 2026 commit, whose footbot_nn is the authors' neural controller."""

REBUILD: dict[str, str] = {
    "2023": "rebuild.sh",
    "foraging": "rebuild.sh and rebuild_2024.sh",
    "primitives": "rebuild.sh and rebuild_2024.sh",
    "multifood": "rebuild.sh and rebuild_2026.sh",
}
"""The harness's scripts that make each build."""

NETWORK_BUILD = "multifood"
"""The build whose footbot_nn evaluates networks."""

NETWORK_SLOTS: tuple[str, ...] = (
    "density", "nest", "food", "idensity", "inest", "ifood",
    "foraging", "movement", "rotation", "conditionality",
)  # fmt: skip
"""footbot_nn's ten per-trial values, in the order it prints them (movement and rotation in raw units,
[-ticks, ticks]; foraging: deliveries in the trial)."""

NETWORK_GAPS = (0.5, 0.7)
"""The gaps of the authors' two runs per evaluation, as the driver names its result files."""

NETWORK_TRIALS = 5
"""Trials per ARGoS run of footbot_nn (their fixed network environment)."""

NETWORK_ROBOTS = 9
"""Footbots per run; their per-trial values are summed over them and divided by this."""

NETWORK_RAW_COLUMNS: tuple[str, ...] = (
    "tree",
    "seed",
    "trial_s",
    *NETWORK_SLOTS,
    *(f"{q}_gap{gap:g}" for gap in NETWORK_GAPS for q in NETWORK_SLOTS),
    "argos_wall_s",
)
"""A network raw TSV's columns (``docs/validation/argos_raw_networks.tsv``): the network (``nn: ...``), the
seed, the trial length, each value's mean over both runs, then each run's."""


def network_means(result: str) -> list[float]:
    """One footbot_nn run's ten values, each the mean per robot per trial, from the ``result <robot> ...``
    lines ARGoS printed (per robot, slot-major: slot ``q`` of trial ``k`` at ``q * 5 + k``)."""
    robots = [line.split()[2:] for line in result.splitlines() if line.startswith("result ")]
    expected = len(NETWORK_SLOTS) * NETWORK_TRIALS
    if not robots or any(len(values) != expected for values in robots):
        raise UsageError(
            f"footbot_nn's result lines: expected {expected} values per robot, one line per robot"
        )
    return [
        math.fsum(float(v[q * NETWORK_TRIALS + k]) for v in robots for k in range(NETWORK_TRIALS))
        / (NETWORK_ROBOTS * NETWORK_TRIALS)
        for q in range(len(NETWORK_SLOTS))
    ]


def read_network_raw(raw: Path) -> dict[tuple[str, int, int], tuple[float, ...]]:
    """A network raw TSV: per (network, seed, trial length in seconds), the ten values (``NETWORK_SLOTS``)."""
    if not raw.is_file():
        return {}
    rows: dict[tuple[str, int, int], tuple[float, ...]] = {}
    with io.StringIO(_raw_text(raw), newline="") as f:
        reader = csv.DictReader(f, delimiter="\t")
        missing = [
            q for q in ("tree", "seed", "trial_s", *NETWORK_SLOTS) if q not in (reader.fieldnames or ())
        ]
        if missing:
            raise UsageError(
                f"{raw}: not a network raw TSV of footbot_nn: missing column(s) {', '.join(missing)}"
            )
        for line, row in enumerate(reader, start=2):
            try:
                key = (row["tree"], int(row["seed"]), int(row["trial_s"]))
                rows[key] = tuple(_finite(row[q]) for q in NETWORK_SLOTS)
            except (TypeError, ValueError):
                raise UsageError(
                    f"{raw}:{line}: expected numbers in the seed, trial_s and value columns (finite ones)"
                ) from None
    return rows


def subs_text(library: Iterable[tuple[str, str]]) -> str:
    """A library as the driver's sub-behaviours file: ``<name> <tree>`` per line. A probabilistic node's
    draw key (``prob@K``) is dropped: it names which of our random streams the node draws from, which ARGoS
    (one ``rand()``) has no counterpart of; the node is the same ``prob`` there."""
    return "".join(f"{name} {_without_keys(tree)}\n" for name, tree in library)


def _without_keys(tree: str) -> str:
    return re.sub(r"prob@\d+\(", "prob(", tree)


def _raw_text(raw: Path) -> str:
    """The text of the driver's raw TSV ``raw``; ``UsageError`` when it cannot be read or is not UTF-8."""
    try:
        return raw.read_text(encoding="utf-8")
    except OSError as error:
        raise UsageError(f"{raw}: cannot read the ARGoS rows ({error.strerror or error})") from None
    except UnicodeDecodeError as error:
        raise UsageError(f"{raw}: not UTF-8 text (byte {error.start}: {error.reason})") from None


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text!r} is not a finite number")
    return value


def read_foraging_raw(raw: Path) -> dict[tuple[str, int], float]:
    """The driver's raw TSV of the foraging build: per (tree, seed), the mean deliveries per robot per
    trial."""
    return read_raw_column(raw, "foraging", "foraging")


def read_raw_column(raw: Path, column: str, build: str) -> dict[tuple[str, int], float]:
    """The driver's raw TSV of ``build`` (named in the message only): per (tree, seed), its ``column``."""
    if not raw.is_file():
        return {}
    rows: dict[tuple[str, int], float] = {}
    with io.StringIO(_raw_text(raw), newline="") as f:
        reader = csv.DictReader(f, delimiter="\t")
        missing = [q for q in ("tree", "seed", column, "build") if q not in (reader.fieldnames or ())]
        if missing:
            raise UsageError(
                f"{raw}: not the ARGoS driver's raw TSV of the {build} build: missing column(s) "
                f"{', '.join(missing)}"
            )
        for line, row in enumerate(reader, start=2):
            try:
                rows[(row["tree"], int(row["seed"]))] = _finite(row[column])
            except (TypeError, ValueError):
                raise UsageError(
                    f"{raw}:{line}: expected numbers in the seed and {column} columns (finite ones)"
                ) from None
    return rows


def read_argos_raw(raw: Path) -> dict[tuple[str, int], tuple[float, ...]]:
    """The driver's raw TSV: per (tree, seed), the six quantities, movement and rotation mapped to [0, 1]."""
    if not raw.is_file():
        return {}
    rows: dict[tuple[str, int], tuple[float, ...]] = {}
    with io.StringIO(_raw_text(raw), newline="") as f:
        reader = csv.DictReader(f, delimiter="\t")
        missing = [q for q in ("tree", "seed", *QUANTITIES) if q not in (reader.fieldnames or ())]
        if missing:
            raise UsageError(f"{raw}: not the ARGoS driver's raw TSV: missing column(s) {', '.join(missing)}")
        for line, row in enumerate(reader, start=2):
            try:
                values = [_finite(row[q]) for q in QUANTITIES]
                seed = int(row["seed"])
            except (TypeError, ValueError):
                raise UsageError(
                    f"{raw}:{line}: expected numbers in the seed and value columns (finite ones)"
                ) from None
            for i, q in enumerate(QUANTITIES):
                if q in ("movement", "rotation"):
                    values[i] = (values[i] + RAW_HALF_RANGE) / (2 * RAW_HALF_RANGE)
            rows[(row["tree"], seed)] = tuple(values)
    return rows


def argos_estimates(
    raw: dict[tuple[str, int], tuple[float, ...]], trees: Iterable[str], seeds: Sequence[int]
) -> tuple[dict[str, dict[str, Estimate]], list[tuple[str, int]]]:
    """Per tree, ARGoS's estimates over ``seeds`` from raw rows; and the (tree, seed) pairs missing."""
    out: dict[str, dict[str, Estimate]] = {}
    missing: list[tuple[str, int]] = []
    for tree in trees:
        rows = []
        for seed in seeds:
            if (tree, seed) in raw:
                rows.append(raw[(tree, seed)])
            else:
                missing.append((tree, seed))
        if len(rows) == len(seeds):
            out[tree] = validation.estimates(rows, QUANTITIES)
    return out, missing


# --------------------------------------------------------------------------------------------- the table

TSV_COLUMNS = (
    "index",
    "run",
    "objective",
    "bin",
    "role",
    "tree",
    "quantity",
    "ours_mean",
    "ours_sem",
    "ours_n",
    "argos_mean",
    "argos_sem",
    "argos_n",
    "diff",
    "tolerance",
    "z",
    "verdict",
)


def _bin_text(index: tuple[int, ...]) -> str:
    return ",".join(str(b) for b in index)


def transfer_tsv(rows: Sequence[TransferRow]) -> str:
    """One line per (tree, quantity): the tree's origin, both estimates, diff, tolerance, z and verdict."""
    lines = ["\t".join(TSV_COLUMNS)]
    for number, row in enumerate(rows, start=1):
        p = row.pick
        for c in row.comparisons:
            cells = [str(number), p.run, p.objective, _bin_text(p.bin), p.role, p.tree, c.quantity]
            cells += [f"{c.ours.mean:.6f}", f"{c.ours.sem:.6f}", str(c.ours.n)]
            cells += [f"{c.theirs.mean:.6f}", f"{c.theirs.sem:.6f}", str(c.theirs.n)]
            z = c.z
            z_text = ("inf" if z > 0 else "-inf") if math.isinf(z) else f"{z:.3f}"
            cells += [f"{c.diff:+.6f}", f"{c.tolerance:.6f}", z_text, c.verdict]
            lines.append("\t".join(cells))
    return "\n".join(lines) + "\n"


def read_transfer_tsv(path: Path) -> list[TransferRow]:
    """The rows of a ``transfer_tsv`` file (UsageError naming the file and line when it is not one)."""
    reader = tsv_rows(path, "the transfer table", UsageError)
    if tuple(reader.fieldnames or ()) != TSV_COLUMNS:
        raise UsageError(f"{path}: not a transfer table (expected the columns {', '.join(TSV_COLUMNS)})")
    by_index: dict[int, tuple[Pick, list[Comparison]]] = {}
    for line, r in enumerate(reader, start=2):
        try:
            index = int(r["index"])
            bin_ = tuple(int(b) for b in r["bin"].split(",")) if r["bin"] else ()
            pick = Pick(r["run"], r["objective"], bin_, r["role"], r["tree"], None)
            ours = Estimate(float(r["ours_mean"]), float(r["ours_sem"]), int(r["ours_n"]))
            theirs = Estimate(float(r["argos_mean"]), float(r["argos_sem"]), int(r["argos_n"]))
        except (TypeError, ValueError):
            raise UsageError(
                f"{path}:{line}: expected numbers in the index, bin and estimate columns"
            ) from None
        entry = by_index.setdefault(index, (pick, []))
        entry[1].append(Comparison(r["tree"], r["quantity"], ours, theirs))
    rows = [TransferRow(pick, tuple(cs)) for _, (pick, cs) in sorted(by_index.items())]
    for row in rows:
        if [c.quantity for c in row.comparisons] != list(QUANTITIES):
            raise UsageError(f"{path}: tree {row.pick.tree!r} does not have the six quantities in order")
    if not rows:
        raise UsageError(f"{path}: an empty transfer table")
    return rows


_MARK = {INDISTINGUISHABLE: "✓", validation.AGREES: "≈", OUTSIDE: "✗"}


def _z_text(c: Comparison) -> str:
    if math.isinf(c.z):
        return "+inf" if c.z > 0 else "-inf"
    return f"{c.z:+.1f}"


def render_summary(rows: Sequence[TransferRow]) -> list[str]:
    """The summary lines: counts, fitness transfer, the verdict grid and what is not indistinguishable."""
    comparisons = [c for row in rows for c in row.comparisons]
    agreeing = sum(c.agrees for c in comparisons)
    same = sum(c.verdict == INDISTINGUISHABLE for c in comparisons)
    own = [c for c in (row.own_fitness for row in rows) if c is not None]
    lines = [
        f"**{agreeing} of {len(comparisons)}** quantities over {len(rows)} trees agree with ARGoS within "
        f"tolerance; **{same} of {len(comparisons)}** are also statistically indistinguishable "
        f"(|z| <= {MAX_Z:g}).",
        "",
    ]
    if own:
        mean_diff = math.fsum(c.diff for c in own) / len(own)
        worst = max(abs(c.z) for c in own)
        lines += [
            f"Fitness transfer (each evolved tree's own objective, {len(own)} trees): mean difference ours - "
            f"ARGoS {mean_diff:+.4f}, largest |z| {worst:.1f}.",
            "",
        ]
    lines += [
        f"Verdicts: {_MARK[INDISTINGUISHABLE]} indistinguishable, {_MARK[validation.AGREES]} agrees (within "
        f"tolerance, |z| > {MAX_Z:g}), {_MARK[OUTSIDE]} outside tolerance.",
        "",
        "| # | run | grid | bin | pick | tree | " + " | ".join(QUANTITIES) + " |",
        "|---|---|---|---|---|---|" + "---|" * len(QUANTITIES),
    ]
    for number, row in enumerate(rows, start=1):
        p = row.pick
        marks = " | ".join(_MARK[c.verdict] for c in row.comparisons)
        lines.append(
            f"| {number} | {p.run} | {p.objective} | {_bin_text(p.bin)} | {p.role} | `{p.tree}` | {marks} |"
        )
    lines += ["", "Not indistinguishable:", ""]
    odd = [(number, c) for number, row in enumerate(rows, start=1) for c in row.comparisons]
    odd = [(number, c) for number, c in odd if c.verdict != INDISTINGUISHABLE]
    if odd:
        lines += [
            f"- #{number} {c.quantity}: {c.verdict}, ours {c.ours.mean:.4f} ± {c.ours.sem:.4f}, ARGoS "
            f"{c.theirs.mean:.4f} ± {c.theirs.sem:.4f}, diff {c.diff:+.4f} (tolerance {c.tolerance:.4f}), "
            f"z {_z_text(c)}"
            for number, c in odd
        ]
    else:
        lines.append("None.")
    return lines


def render_markdown(rows: Sequence[TransferRow], header: Iterable[str]) -> str:
    """The full report: ``header``, the summary, then every quantity of every tree."""
    lines = [*header, "", *render_summary(rows), "", "## Every quantity", ""]
    lines += [
        "| # | quantity | ours (mean ± SE) | ARGoS (mean ± SE) | diff | tolerance | z | verdict |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for number, row in enumerate(rows, start=1):
        for c in row.comparisons:
            lines.append(
                f"| {number} | {c.quantity} | {c.ours.mean:.4f} ± {c.ours.sem:.4f} | {c.theirs.mean:.4f} ± "
                f"{c.theirs.sem:.4f} | {c.diff:+.4f} | {c.tolerance:.4f} | {_z_text(c)} | {c.verdict} |"
            )
    return "\n".join(lines) + "\n"
