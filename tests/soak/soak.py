"""Soak: a manager run with evaluator processes while evaluators and the manager itself are killed (SIGKILL)
at random moments; the manager is resumed after each of its deaths. Not a CI test (it takes minutes): run it
by hand and report its figures.

The moments: each kill waits a random time (``--min-gap`` to ``--max-gap`` seconds, seeded) after the manager
has started evaluating, or, for a share ``--startup-share`` of the kills, after the manager process started
(so kills also land in its start-up: before the run directory exists, before the evaluators are found).

    source ws/env.sh && nice -n 10 python tests/soak/soak.py --evaluations 5000 --evaluators 3 --kills 20 \\
        --seed 1 --out /tmp/soak

It checks, and prints as one JSON object at the end:
- the final result files are byte for byte those of an undisturbed run (``evolve`` with the in-process
  evaluator and the same options);
- the run's bags, read in order, hold every evaluation of ``evaluations.csv`` exactly once (lost 0, duplicated
  0), in order, those answered from the run's cache (fixed scenarios, the default) marked ``cached``;
- no process started for the run is left (every PID seen, and every process of the run's ROS domain, by
  ``ps``), and no temporary file is left in the run directory or beside it.
Exit status 0 when every check passes, 1 otherwise.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

from evolution_manager.evolution.run import SIMULATED, Run
from evolution_manager.evolution.run_config import evaluation_seed
from evolution_manager.graph.startup import executable
from evolution_manager.recording.bags import read_bag
from evolution_manager.studies.evolve import evolve
from swarm_ros.isolation import domain_environment, reserved_domain

RESULT_FILES = [
    "config.json",
    "evaluations.csv",
    "progress.csv",
    "summary.json",
    "archive.json",
    "repertoire_density.json",
    "repertoire_nest.json",
    "repertoire_food.json",
]
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def children(pid: int) -> list[int]:
    """The PIDs whose parent is ``pid``."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            fields = stat.rsplit(")", 1)[1].split()
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(entry.name))
    return sorted(found)


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of a live process (None once it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def in_domain(domain: int) -> list[str]:
    """``ps`` lines of this user's processes whose environment has ROS_DOMAIN_ID=domain."""
    lines = []
    command = ["ps", "-u", str(os.getuid()), "-o", "pid=,args="]
    listing = subprocess.run(command, capture_output=True, text=True, check=True)
    for line in listing.stdout.splitlines():
        pid = int(line.split()[0])
        try:
            environ = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if f"ROS_DOMAIN_ID={domain}".encode() in environ and pid != os.getpid():
            lines.append(line.strip())
    return lines


class Soak:
    def __init__(self, args: argparse.Namespace, domain: int) -> None:
        self.args = args
        self.domain = domain
        self.out: Path = args.out / "disturbed"
        self.rng = random.Random(args.seed)
        self.cpu: dict[int, float] = {}  # the last CPU reading of every process seen
        self.seen: set[int] = set()
        self.kills = {"manager": 0, "evaluator": 0}
        self.starts = 0
        self.log = (args.out / "managers.log").open("a")
        self.log_offset = 0

    def watch(self, manager: subprocess.Popen) -> list[int]:
        """Read the CPU time of the manager and its evaluators; return the evaluators' PIDs."""
        evaluators = children(manager.pid)
        for pid in [manager.pid, *evaluators]:
            self.seen.add(pid)
            seconds = cpu_seconds(pid)
            if seconds is not None:
                self.cpu[pid] = seconds
        return evaluators

    def start_manager(self) -> subprocess.Popen:
        options = ["--out", str(self.out), "--evaluators", str(self.args.evaluators), "--no-figures"]
        options += ["--no-progress", "--checkpoint-every", str(self.args.checkpoint_every)]
        if (self.out / "config.json").exists():
            options.append("--resume")
        else:
            options += ["--algorithm", "qd", "--objective", "food", "--scenarios", self.args.scenarios]
            options += ["--evaluations", str(self.args.evaluations), "--seed", str(self.args.seed)]
        self.starts += 1
        self.log.write(f"--- start {self.starts}: {' '.join(options)}\n")
        self.log.flush()
        self.log_offset = self.log.tell()
        return subprocess.Popen(
            [str(executable("evolution_manager", "manager")), *options],
            env=domain_environment(self.domain),
            stdout=self.log,
            stderr=subprocess.STDOUT,
        )

    def evaluating(self) -> bool:
        """Whether the manager started last has found its evaluators and started evaluating."""
        with (self.args.out / "managers.log").open() as handle:
            handle.seek(self.log_offset)
            return "evaluator(s):" in handle.read()

    def run(self) -> int:
        manager = self.start_manager()
        while True:
            delay = self.rng.uniform(self.args.min_gap, self.args.max_gap)
            in_startup = self.rng.random() < self.args.startup_share
            target = "manager" if self.rng.random() < self.args.manager_share else "evaluator"
            pick = self.rng.random()
            while not in_startup and not self.evaluating() and manager.poll() is None:
                self.watch(manager)
                time.sleep(0.1)
            due = time.monotonic() + delay
            while time.monotonic() < due and manager.poll() is None:
                self.watch(manager)
                time.sleep(0.1)
            if manager.poll() is not None:
                if manager.returncode != 0:
                    raise SystemExit(f"soak: the manager failed (exit {manager.returncode})")
                return manager.returncode
            if sum(self.kills.values()) >= self.args.kills:
                continue  # every kill done: let the run finish
            evaluators = self.watch(manager)
            if target == "evaluator" and evaluators:
                victim = evaluators[int(pick * len(evaluators))]
                os.kill(victim, signal.SIGKILL)
                self.kills["evaluator"] += 1
                self.log.write(f"--- soak: SIGKILL evaluator {victim}\n")
            else:
                manager.kill()
                manager.wait()
                self.kills["manager"] += 1
                self.log.write(f"--- soak: SIGKILL manager {manager.pid}\n")
                self.log.flush()
                deadline = time.monotonic() + 10
                while any(alive(p) for p in evaluators) and time.monotonic() < deadline:
                    time.sleep(0.05)
                orphans = [p for p in evaluators if alive(p)]
                if orphans:
                    raise SystemExit(f"soak: evaluators {orphans} outlived their killed manager")
                manager = self.start_manager()
            self.log.flush()


def check(args: argparse.Namespace, soak: Soak, reference: Path) -> dict:
    out = soak.out
    different = [n for n in RESULT_FILES if (out / n).read_bytes() != (reference / n).read_bytes()]
    with open(out / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    segments = sorted(out.glob("run*.bag"), key=lambda p: (p.name != "run.bag", len(p.name), p.name))
    evaluations, progress = [], []
    for segment in segments:
        for message in read_bag(segment):
            if message.topic == "/evaluations":
                evaluations.append(message.message)
            elif message.topic == "/progress":
                progress.append(message.message.evaluations)
    # every row of the run (the budget counts individuals produced; an offspring no operator changed is not
    # evaluated again), in order; under fixed scenarios a tree seen before is answered from the cache, marked
    expected = [(r["tree"], int(r["seed"])) for r in rows]
    got = [(m.tree, m.seed) for m in evaluations]
    cached = [a != SIMULATED for a in Run.resume(out, None, cut=False).answers]  # the run's rule, replayed
    lost = max(0, len(expected) - len(got))
    duplicated = max(0, len(got) - len(expected))
    agree = got == expected and [bool(m.cached) for m in evaluations] == cached
    if args.scenarios == "fresh":  # each evaluation on its own seed
        agree = agree and [seed for _, seed in got] == [
            evaluation_seed(args.seed, i) for i in range(len(rows))
        ]
    leftovers = [
        str(p)
        for p in [*out.rglob(".*"), *out.parent.glob(f".{out.name}.*")]
        if p.name != ".lock" and not p.name.startswith(".lock")
    ]
    time.sleep(1.0)
    left = [p for p in soak.seen if alive(p)]
    return {
        "individuals_produced": args.evaluations,
        "evaluations": len(rows),
        "evaluators": args.evaluators,
        "kills": soak.kills,
        "kills_survived": sum(soak.kills.values()),
        "manager_starts": soak.starts,
        "bag_segments": len(segments),
        "evaluations_in_bags": len(got),
        "cached_evaluations_in_bags": sum(bool(m.cached) for m in evaluations),
        "evaluations_lost": lost,
        "evaluations_duplicated": duplicated,
        "bags_in_order_and_agree_with_csv": agree,
        "progress_messages_in_order_once": all(a <= b for a, b in itertools.pairwise(progress))
        and len(progress) == 3 * len(set(progress)),
        "result_files_differing_from_undisturbed_run": different,
        "processes_seen": len(soak.seen),
        "processes_left": left,
        "processes_left_in_domain_ps": in_domain(soak.domain),
        "temporary_files_left": leftovers,
        "cpu_seconds_manager_and_evaluators": round(sum(soak.cpu.values()), 1),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--evaluations", type=int, default=5000)
    parser.add_argument("--evaluators", type=int, default=3)
    parser.add_argument("--kills", type=int, default=20)
    parser.add_argument("--seed", type=int, default=1, help="seed of the run and of the kill schedule")
    parser.add_argument("--min-gap", type=float, default=0.5, help="shortest wait before a kill (s)")
    parser.add_argument("--max-gap", type=float, default=8.0, help="longest wait before a kill (s)")
    parser.add_argument("--manager-share", type=float, default=0.5, help="share of kills of the manager")
    parser.add_argument("--startup-share", type=float, default=0.2, help="share of kills timed from start-up")
    parser.add_argument("--checkpoint-every", type=float, default=2.0)
    parser.add_argument(
        "--scenarios", choices=("fixed", "fresh"), default="fixed", help="the run's scenarios"
    )
    parser.add_argument("--out", type=Path, required=True, help="a new directory for both runs")
    args = parser.parse_args()
    args.out.mkdir(parents=True)
    started, cpu_start = time.monotonic(), os.times()
    with reserved_domain() as domain:
        soak = Soak(args, domain)
        soak.run()
    disturbed_wall = time.monotonic() - started
    reference = args.out / "undisturbed"
    t = time.monotonic()
    options = ["--algorithm", "qd", "--objective", "food", "--evaluations", str(args.evaluations)]
    options += ["--seed", str(args.seed), "--out", str(reference), "--no-figures", "--no-progress"]
    options += ["--scenarios", args.scenarios]
    if evolve(options) != 0:
        raise SystemExit("soak: the undisturbed run failed")
    undisturbed_wall = time.monotonic() - t
    figures = check(args, soak, reference)
    cpu_end = os.times()
    figures["wall_seconds_disturbed_run"] = round(disturbed_wall, 1)
    figures["wall_seconds_undisturbed_in_process_run"] = round(undisturbed_wall, 1)
    figures["cpu_seconds_soak_process_and_reaped_children"] = round(sum(cpu_end[:4]) - sum(cpu_start[:4]), 1)
    print(json.dumps(figures, indent=1))
    ok = (
        figures["kills_survived"] == args.kills  # a run that ended before every kill landed is not a soak
        and figures["evaluations_lost"] == 0
        and figures["evaluations_duplicated"] == 0
        and figures["bags_in_order_and_agree_with_csv"]
        and not figures["result_files_differing_from_undisturbed_run"]
        and not figures["processes_left"]
        and not figures["processes_left_in_domain_ps"]
        and not figures["temporary_files_left"]
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
