"""``report DIR``: rebuild the report of an experiment, or the results of a single run, from its files.

For an experiment folder (``experiment.json``, ``runs/``) it writes ``report.md`` and ``runs.csv`` (one row
per run and objective) with, beside them in ``figures/``: box plots of best fitness, coverage and QD score
(figs. 4-6) and of the held-out scores, the histograms of the best fitness per bin of one run of each
algorithm (fig. 8), the MAP-Elites grids of one run per objective (fig. 7) and progress curves with the
held-out scores; the paper's table 6 row by row (its p-value and test beside ours, effect sizes, Holm's
correction, the held-out comparison and a verdict per row) and fig. 8's repertoire sizes beside the
paper's; with ARGoS's rows, the transfer section (``argos_transfer``); last ``notes.md`` when the folder
has one (a person's reading of the results, kept when the report is rebuilt). Algorithms are compared per
objective: GP_o and QD_o on their objective, GP_fnd on each of the
three. For a run directory (``config.json``) it rewrites the run's repertoires, summary, best trees and
figures from its last checkpoint.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from evolution_manager.arguments import EXIT_USAGE, Parser, positive_int
from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_folder import refuse_planted_links
from evolution_manager.evolution.run_results import run_results
from evolution_manager.files import read_json
from evolution_manager.studies import (
    ablation_study,
    argos_transfer,
    foraging_study,
    heterogeneity_study,
    networks_study,
    replication_study,
    scenarios,
    schedule_study,
)
from evolution_manager.studies.report import build_report
from evolution_manager.viewing.results import write_results


def rebuild_run(root: Path) -> list[Path]:
    """Rewrite a run directory's results from its last checkpoint (its logs are left as they are)."""
    refuse_planted_links(root)  # before the first result is rewritten
    run = Run.resume(root, None, cut=False)
    return write_results(run, run_results(run))


def _study(root: Path) -> str | None:
    """The study of the experiment folder ``root`` (``paper`` when its plan names none), or None."""
    plan = Path(root) / "experiment.json"
    if not plan.exists():
        return None
    document = read_json(plan)
    return str(document.get("study", "paper")) if isinstance(document, dict) else None


def report(argv: Sequence[str] | None = None) -> int:
    """Run ``report``; return the exit status."""
    parser = Parser(prog="report", description=__doc__.split("\n")[0])
    parser.add_argument(
        "dir",
        type=Path,
        help="an experiment folder, a run directory, or a folder of scenario experiments (seed-K/; "
        "table 6 across scenarios)",
    )
    parser.add_argument(
        "--beside",
        type=Path,
        help="another experiment's runs.csv: its table 6 is shown after this one's (a robustness check)",
    )
    parser.add_argument("--beside-title", default="", help="what the --beside runs are (for the report)")
    parser.add_argument(
        "--argos-eval",
        metavar="DRIVER",
        help="the ARGoS harness's argos_eval.py ($ARGOS_EVAL): score each run's best tree (a foraging "
        "study: each arm's best forager; a replication study: every run's; a bt-vs-nn study: each "
        "objective's best tree and best network) in the authors' ARGoS (rows kept in argos_raw*.tsv, run "
        "only when missing); the report's transfer section",
    )
    parser.add_argument(
        "--argos-seeds", default=argos_transfer.DEFAULT_SEEDS, help="ARGoS's seeds: N, A-B or a list (1-20)"
    )
    parser.add_argument("--argos-jobs", type=positive_int, default=1, help="ARGoS evaluations at once (1)")
    try:
        args = parser.parse_args(argv)
        seeds = argos_transfer.parse_seeds(args.argos_seeds)
    except UsageError as error:
        print(f"report: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    try:
        if scenarios.is_scenarios_folder(args.dir):
            if args.beside is not None or args.argos_eval is not None:
                raise UsageError("--beside and --argos-eval apply to an experiment folder, not to scenarios")
            print(scenarios.build_scenarios_report(args.dir))
        elif _study(args.dir) in ("ablation", "heterogeneity", "qd-schedule"):
            if args.beside is not None or args.argos_eval is not None:
                raise UsageError(
                    "--beside and --argos-eval apply to the paper's, the foraging, the replication and the "
                    "bt-vs-nn study"
                )
            study = {
                "ablation": ablation_study,
                "heterogeneity": heterogeneity_study,
                "qd-schedule": schedule_study,
            }[str(_study(args.dir))]
            print(study.build_report(args.dir))
        elif _study(args.dir) == "bt-vs-nn":
            if args.beside is not None:
                raise UsageError("--beside applies to the paper's experiment, not to a bt-vs-nn study")
            print(networks_study.build_report(args.dir, args.argos_eval, seeds, args.argos_jobs))
        elif _study(args.dir) == "replication":
            if args.beside is not None:
                raise UsageError("--beside applies to the paper's experiment, not to a replication study")
            print(replication_study.build_report(args.dir, args.argos_eval, seeds, args.argos_jobs))
        elif _study(args.dir) == "foraging":
            if args.beside is not None:
                raise UsageError("--beside applies to the paper's experiment, not to a foraging study")
            print(foraging_study.build_report(args.dir, args.argos_eval, seeds, args.argos_jobs))
        elif (args.dir / "experiment.json").exists() or (args.dir / "runs").is_dir():
            print(
                build_report(
                    args.dir, args.beside, args.beside_title, args.argos_eval, seeds, args.argos_jobs
                )
            )
        elif (args.dir / "config.json").exists():
            if args.beside is not None or args.argos_eval is not None:
                raise UsageError("--beside and --argos-eval apply to an experiment folder, not to a run")
            for path in rebuild_run(args.dir):
                print(path)
        else:
            raise UsageError(
                f"{args.dir} is neither an experiment folder, a run directory nor a folder of scenario "
                "experiments (seed-K/experiment.json)"
            )
    except (UsageError, EvolutionError, OSError, KeyError, ValueError) as error:
        print(f"report: error: {error!s} (is {args.dir} a finished run or experiment?)", file=sys.stderr)
        return EXIT_USAGE
    return 0


def main() -> None:
    """Console entry point of ``report``."""
    sys.exit(report())


__all__ = ["rebuild_run", "report"]
