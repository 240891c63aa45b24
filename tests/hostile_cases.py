"""The hostile-files probe's cases (``hostile_probe``, ``ws/probe-hostile``): every command of ``ws/run``
against hostile and careless inputs: outputs that are symbolic links (to a saved file, dangling, to a
folder), that exist, that are folders or lie under a file; inputs that are not UTF-8, truncated, hold a key
twice or NaN, are folders, missing, or the user's own unrelated file; numbers that are NaN, infinite,
negative or zero; links planted inside a run folder. Each case says whether the command must refuse it or
succeed (with tiny budgets: nothing here runs a long evolution, and nothing starts a ROS graph)."""

from __future__ import annotations

import json
import re
from collections.abc import Callable

from hostile_probe import EITHER, SUCCEED, Case, Copy, Edit, Folder, Link, Remove, Write

NOT_UTF8 = "\udcff\udcfe"  # the bytes ff fe in a command line, as Python holds them (surrogateescape)

# --- damage to a file's bytes


def truncate(data: bytes) -> bytes:
    return data[: len(data) // 2]


def truncate_inside_a_word(data: bytes) -> bytes:
    """``truncate``, the cut moved on to inside the next word: a YAML file cut where a line ends is a whole
    shorter file (the task schema lets any key but the name default), so only a cut inside a word tests
    that a torn file is refused."""
    cut = len(data) // 2
    while cut < len(data) and not data[cut : cut + 1].isalnum():
        cut += 1
    return data[: cut + 1]


def not_utf8(data: bytes) -> bytes:
    """Two bytes that are not UTF-8, inside the first string of the file."""
    quote = data.find(b'"') if b'"' in data else data.find(b":") + 1
    return data[: quote + 1] + b"\xff\xfe" + data[quote + 1 :]


def json_key_twice(data: bytes) -> bytes:
    """The first key of the top-level object given again, first."""
    document = json.loads(data)
    key = next(iter(document))
    return (
        b"{"
        + json.dumps(key).encode()
        + b": "
        + json.dumps(document[key]).encode()
        + b", "
        + data.lstrip()[1:]
    )


def json_nan(key: str) -> Callable[[bytes], bytes]:
    """The first number given for ``key`` replaced by NaN."""
    return lambda data: re.sub(rb'("' + key.encode() + rb'": *)-?[0-9][0-9.eE+-]*', rb"\1NaN", data, count=1)


def yaml_key_twice(data: bytes) -> bytes:
    """The first line (a top-level key) given again at the end."""
    return data + data.split(b"\n", 1)[0] + b"\n"


def yaml_nan(key: str) -> Callable[[bytes], bytes]:
    return lambda data: re.sub(rb"(" + key.encode() + rb": *)-?[0-9][0-9.eE+-]*", rb"\1.nan", data, count=1)


# --- the cases, command by command

EVOLVE = ("evolution_manager evolve",)
QUICK = ["--algorithm", "qd", "--objective", "food", "--evaluations", "2", "--seed", "1", "--no-progress"]
NEW_RUN = [*QUICK, "--out", "{case}/new"]
RESUME = [
    "--out",
    "{case}/unfinished",
    "--resume",
    "--no-progress",
    "--no-figures",
    "--checkpoint-every",
    "0",
]


def _case(name: str, command: str, *args: str, **options: object) -> Case:
    return Case(name, command, tuple(args), **options)


def _output_cases(command: str, before: list[str], option: str, suffix: str, force: bool) -> list[Case]:
    """An output (``option``) that is a link to a saved file (with --force too), a dangling link, a link to a
    folder, a folder, a place under a file, and one that exists (without --force)."""
    out = "{case}/out" + suffix
    forced = ["--force"] if force else []
    return [
        _case(f"{option} a link to a saved file", command, *before, option, out,
              plant=(Link("out" + suffix, "{saved}"),)),
        _case(f"{option} a link to a saved file, --force", command, *before, option, out, *forced,
              plant=(Link("out" + suffix, "{saved}"),)),
        _case(f"{option} a dangling link", command, *before, option, out,
              plant=(Link("out" + suffix, "{outside}/made"),)),
        _case(f"{option} a link to a folder", command, *before, option, out,
              plant=(Link("out" + suffix, "{outside}"),)),
        _case(f"{option} a folder", command, *before, option, out, *forced, plant=(Folder("out" + suffix),)),
        _case(f"{option} under a file", command, *before, option, "{case}/file/out" + suffix,
              plant=(Write("file", b"a file\n"),)),
        _case(f"{option} exists", command, *before, option, out, plant=(Write("out" + suffix, b"saved\n"),)),
    ]  # fmt: skip


JSON_VALUE = {"--library": b"0.5", "--swarm": b'"forward"'}
"""For each JSON input, a value its fixture holds, replaced by NaN or 1e400 in a case."""


def _json_input_cases(command: str, before: list[str], option: str, after: list[str]) -> list[Case]:
    """A JSON input (``option``, a copy of the fixture at ``{case}/input.json``): damaged (not UTF-8,
    truncated, a key twice, NaN or 1e400 for one of its values, empty), a folder, missing, a dangling link,
    the user's own file."""
    file = "{case}/input.json"
    value = JSON_VALUE[option]

    def damaged(label: str, how: Callable[[bytes], bytes]) -> Case:
        return _case(f"{option} {label}", command, *before, option, file, *after,
                     plant=(Copy(FIXTURE_OF[option], "input.json"), Edit("input.json", how)))  # fmt: skip

    return [
        damaged("not UTF-8", not_utf8),
        damaged("truncated", truncate),
        damaged("a key twice", json_key_twice),
        damaged(f"NaN for {value.decode()}", lambda data: data.replace(value, b"NaN", 1)),
        damaged(f"1e400 for {value.decode()}", lambda data: data.replace(value, b"1e400", 1)),
        damaged("empty", lambda _: b""),
        _case(f"{option} a folder", command, *before, option, file, *after, plant=(Folder("input.json"),)),
        _case(f"{option} missing", command, *before, option, file, *after),
        _case(f"{option} a dangling link", command, *before, option, file, *after,
              plant=(Link("input.json", "{outside}/nowhere"),)),
        _case(f"{option} the user's own text file", command, *before, option, "{saved}", *after),
    ]  # fmt: skip


def _yaml_input_cases(
    command: str, before: list[str], option: str, after: list[str], nan_key: str
) -> list[Case]:
    file = "{case}/input.yaml"

    def damaged(label: str, how: Callable[[bytes], bytes]) -> Case:
        return _case(f"{option} {label}", command, *before, option, file, *after,
                     plant=(Copy(FIXTURE_OF[option], "input.yaml"), Edit("input.yaml", how)))  # fmt: skip

    return [
        damaged("not UTF-8", lambda data: data.replace(b"\n", b" \xff\xfe\n", 1)),
        damaged("truncated", truncate_inside_a_word),
        damaged("a key twice", yaml_key_twice),
        damaged(f".nan for {nan_key}", yaml_nan(nan_key)),
        damaged("a list, not a mapping", lambda _: b"- 1\n- 2\n"),
        _case(f"{option} a folder", command, *before, option, file, *after, plant=(Folder("input.yaml"),)),
        _case(f"{option} missing", command, *before, option, file, *after),
        _case(f"{option} the user's own text file", command, *before, option, "{saved}", *after),
    ]  # fmt: skip


FIXTURE_OF = {
    "--library": "library",
    "--swarm": "swarm",
    "--params-file": "params",
    "--task": "task",
    "--cluster-config": "cluster",
    "--reference": "reference",
}


def _numbers(command: str, before: list[str], option: str, values: list[str], after: list[str]) -> list[Case]:
    return [_case(f"{option} {value!r}", command, *before, option, value, *after) for value in values]


def _evolve() -> list[Case]:
    c = "evolution_manager evolve"
    run = [*QUICK, "--no-figures"]
    cases = [
        _case("a tiny run", c, *NEW_RUN, "--no-figures", expect=SUCCEED, writes=("new",),
              makes=("new/summary.json",),
              timeout=120),
        _case("a tiny run into a folder whose name is not UTF-8", c, *QUICK, "--no-figures", "--out",
              "{case}/run-" + NOT_UTF8, expect=SUCCEED, timeout=120),
        _case("--out a link to a saved file", c, *run, "--out", "{case}/out",
              plant=(Link("out", "{saved}"),)),
        _case("--out a dangling link", c, *run, "--out", "{case}/out",
              plant=(Link("out", "{outside}/made"),)),
        _case("--out a file", c, *run, "--out", "{saved}"),
        _case("--out under a file", c, *run, "--out", "{case}/file/run", plant=(Write("file", b"a file\n"),)),
        _case("--out a finished run, no --resume", c, *run, "--out", "{run}"),
        _case("--resume: .lock a link to a saved file", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Remove("unfinished/.lock"), Link("unfinished/.lock",
                    "{saved}"))),
        _case("--resume: evaluations.csv a link to a saved file", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Remove("unfinished/evaluations.csv"),
                     Link("unfinished/evaluations.csv", "{saved}"))),
        _case("--resume: best/ a link to a folder outside", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Link("unfinished/best", "{outside}"))),
        _case("--resume: config.json with a key twice", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Edit("unfinished/config.json", json_key_twice))),
        _case("--resume: config.json with NaN", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Edit("unfinished/config.json", json_nan("seed")))),
        _case("--resume: config.json not UTF-8", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Edit("unfinished/config.json", not_utf8))),
        _case("--resume: checkpoint.json truncated", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Edit("unfinished/checkpoint.json", truncate))),
        _case("--resume: checkpoint.json a folder", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Remove("unfinished/checkpoint.json"),
                     Folder("unfinished/checkpoint.json"))),
        _case("--resume: heldout.json damaged", c, *RESUME,
              plant=(Copy("unfinished", "unfinished"), Write("unfinished/heldout.json", b'{"format": [1'))),
        _case("--resume: a folder that holds no run", c, "--out", "{case}/empty", "--resume",
              plant=(Folder("empty"),)),
        *_numbers(c, ["--algorithm", "qd", "--objective", "food", "--out", "{case}/new"], "--evaluations",
                  ["nan", "-1", "0", "inf", "1e400"], []),
        *_numbers(c, run[:-1], "--seed", ["-1", "nan", str(2**64)], ["--out", "{case}/new"]),
        *_numbers(c, run, "--scenario-seed", ["-1", "nan"], ["--out", "{case}/new"]),
        *_numbers(c, run, "--trials", ["0", "-2", "nan"], ["--out", "{case}/new"]),
        *_numbers(c, run, "--checkpoint-every", ["nan", "-1", "inf"], ["--out", "{case}/new"]),
        *_json_input_cases(c, run, "--library", ["--out", "{case}/new"]),
        *_yaml_input_cases(c, run, "--task", ["--out", "{case}/new"], "ticks"),
        _case("--cluster-config not UTF-8 (slurm)", c, *run, "--out", "{case}/new", "--cluster", "slurm",
              "--cluster-config", "{case}/c.yaml",
                    plant=(Write("c.yaml", b"cores: 1\npartition: \xff\xfe\n"),)),
        _case("--cluster-config a key twice (slurm)", c, *run, "--out", "{case}/new", "--cluster", "slurm",
              "--cluster-config", "{case}/c.yaml", plant=(Write("c.yaml", b"cores: 1\ncores: 2\n"),)),
        _case("--cluster-config NaN cores (slurm)", c, *run, "--out", "{case}/new", "--cluster", "slurm",
              "--cluster-config", "{case}/c.yaml", plant=(Write("c.yaml", b"cores: .nan\n"),)),
        _case("--cluster dask:// of nothing", c, *run, "--out", "{case}/new", "--cluster",
              "dask://host:port"),
        _case("--swarm-from the same run twice", c, "--task", "foraging", "--swarm-from", "{run}", "{run}",
              "--algorithm", "ga", "--evaluations", "10", "--trials", "1", "--out", "{case}/new"),
        _case("--swarm-from a file", c, "--task", "foraging", "--swarm-from", "{saved}", "--algorithm", "ga",
              "--evaluations", "10", "--out", "{case}/new"),
        _case("--homogeneous larger than the cells", c, "--task", "foraging", "--swarm-from", "{run}",
              "--algorithm", "ga", "--evaluations", "10", "--homogeneous", "100000", "--out", "{case}/new"),
        _case("--worker-wait NaN", c, *run, "--out", "{case}/new", "--cluster", "dask://127.0.0.1:1",
              "--worker-wait", "nan"),
        _case("an unknown option", c, *run, "--out", "{case}/new", "--no-such-option"),
        _case("an option without its value", c, *run, "--out"),
        _case("an option not UTF-8", c, *run, "--out", "{case}/new", "--" + NOT_UTF8),
    ]  # fmt: skip
    return cases


def _evaluate() -> list[Case]:
    c = "swarm_sim evaluate"
    tree = ["--tree", "sel(seq(on_food, stop), forward)", "--trials", "1"]
    return [
        _case("one tree, one trial", c, *tree, "--seed", "1", expect=SUCCEED),
        _case("--tree that does not parse", c, "--tree", "sel(", "--trials", "1"),
        _case("--tree not UTF-8", c, "--tree", "sel(" + NOT_UTF8 + ")", "--trials", "1"),
        _case("--tree a file that is not UTF-8", c, "--tree", "{case}/tree.txt", "--trials", "1",
              plant=(Write("tree.txt", b"sel(forward, \xff)\n"),)),
        *_numbers(c, tree[:2], "--trials", ["0", "-1", "nan", "1e400"], []),
        *_numbers(c, tree, "--seed", ["-1", str(2**64), "nan"], []),
        *[_case(f"--condition {value}", c, *tree, "--condition", value)
          for value in ("weak-wheel=3:inf", "weak-wheel=3:nan", "dead-robots=-1", "message-loss=nan",
                "robots=0",
                        "gap=nan", "gap=-5", "speed=2", "robots=" + "9" * 30)],
        *_json_input_cases(c, ["--trials", "1"], "--swarm", []),
        _case("--swarm of 8 trees for 9 robots", c, "--swarm", "{case}/s.json", "--trials", "1",
              plant=(Write("s.json", json.dumps({"trees": ["forward"] * 8}).encode()),)),
        *_json_input_cases(c, tree, "--library", []),
        *_yaml_input_cases(c, tree, "--task", [], "ticks"),
        _case("--profile nope", c, *tree, "--profile", "nope"),
    ]  # fmt: skip


def _experiment() -> list[Case]:
    c = "evolution_manager experiment"
    base = ["--runs", "1", "--evaluations", "2", "--no-progress"]
    return [
        *_numbers(c, ["--evaluations", "2", "--out", "{case}/exp"], "--runs", ["0", "-1", "nan"], []),
        *_numbers(c, ["--runs", "1", "--out", "{case}/exp"], "--evaluations", ["nan", "0", "inf"], []),
        *_numbers(c, [*base, "--out", "{case}/exp"], "--processes", ["0", "nan"], []),
        *_numbers(c, [*base, "--out", "{case}/exp"], "--scenario-seed", ["-1"], []),
        _case("--out a link to a saved file", c, *base, "--out", "{case}/exp",
              plant=(Link("exp", "{saved}"),)),
        _case("--out a dangling link", c, *base, "--out", "{case}/exp",
              plant=(Link("exp", "{outside}/made"),)),
        _case("--out a file", c, *base, "--out", "{saved}"),
        _case("--out under a file", c, *base, "--out", "{case}/file/exp",
              plant=(Write("file", b"a file\n"),)),
        _case("--out a folder with a damaged experiment.json", c, *base, "--out", "{case}/exp",
              plant=(Write("exp/experiment.json", b'{"runs": 1, "runs": 2}'),)),
        _case("--out a folder with experiment.json not UTF-8", c, *base, "--out", "{case}/exp",
              plant=(Write("exp/experiment.json", b'{"runs": "\xff"}'),)),
        _case("--out a run folder, not an experiment's", c, *base, "--out", "{run}"),
        _case("--cluster-config not UTF-8 (slurm)", c, *base, "--out", "{case}/exp", "--cluster", "slurm",
              "--cluster-config", "{case}/c.yaml", plant=(Write("c.yaml", b"cores: \xff\n"),)),
        _case("--design nope", c, *base, "--out", "{case}/exp", "--design", "nope"),
        _case("--study nope", c, *base, "--out", "{case}/exp", "--study", "nope"),
    ]  # fmt: skip


def _report() -> list[Case]:
    c = "evolution_manager report"
    return [
        _case("a run's results rebuilt", c, "{run}", expect=SUCCEED, writes=("run",), timeout=120),
        _case("a run in a folder whose name is not UTF-8", c, "{case}/run-" + NOT_UTF8,
              plant=(Copy("run", "run-" + NOT_UTF8),), expect=SUCCEED, writes=("run-*",), timeout=120),
        _case("a folder that is missing", c, "{case}/nothing"),
        _case("a file", c, "{saved}"),
        _case("an empty folder", c, "{case}/empty", plant=(Folder("empty"),)),
        # a run's results (summary, repertoires, figures, best/) are rebuilt from its checkpoint and config
        _case("summary.json damaged: rebuilt", c, "{run}", plant=(Edit("run/summary.json", truncate),),
              expect=EITHER, writes=("run",), timeout=120),
        _case("checkpoint.json with NaN", c, "{run}",
              plant=(Edit("run/checkpoint.json", json_nan("evaluations")),)),
        _case("checkpoint.json with a key twice", c, "{run}",
              plant=(Edit("run/checkpoint.json", json_key_twice),)),
        _case("checkpoint.json not UTF-8", c, "{run}", plant=(Edit("run/checkpoint.json", not_utf8),)),
        _case("checkpoint.json truncated", c, "{run}", plant=(Edit("run/checkpoint.json", truncate),)),
        _case("config.json with a key twice", c, "{run}", plant=(Edit("run/config.json", json_key_twice),)),
        _case("figures/ a link to a folder outside", c, "{run}", plant=(Link("run/figures", "{outside}"),)),
        _case("summary.json a link to a saved file", c, "{run}",
              plant=(Remove("run/summary.json"), Link("run/summary.json", "{saved}"))),
        _case("--argos-seeds nan", c, "{run}", "--argos-seeds", "nan", "--argos-eval",
              "{case}/argos_eval.py"),
        _case("--argos-jobs 0", c, "{run}", "--argos-jobs", "0"),
    ]  # fmt: skip


def _library() -> list[Case]:
    c = "evolution_manager library"
    return [
        *_output_cases(c, ["--from", "{run}"], "--out", ".json", force=True),
        _case("--from missing", c, "--from", "{case}/nothing", "--out", "{case}/lib.json"),
        _case("--from a file", c, "--from", "{saved}", "--out", "{case}/lib.json"),
        _case("--from a run with NaN in its repertoire", c, "--from", "{run}", "--out", "{case}/lib.json",
              plant=(Edit("run/repertoire_food.json", json_nan("fitness")),)),
        _case("--from a run whose repertoire has a key twice", c, "--from", "{run}", "--out",
              "{case}/lib.json",
              plant=(Edit("run/repertoire_food.json", json_key_twice),)),
        _case("--from a run whose repertoire is not UTF-8", c, "--from", "{run}", "--out", "{case}/lib.json",
              plant=(Edit("run/repertoire_food.json", not_utf8),)),
        _case("--from a run whose config.json is truncated", c, "--from", "{run}", "--out", "{case}/lib.json",
              plant=(Edit("run/config.json", truncate),)),
        _case("--blocks 3", c, "--from", "{run}", "--blocks", "3", "--out", "{case}/lib.json"),
        _case("--out a name that is not UTF-8", c, "--from", "{run}", "--out",
              "{case}/lib-" + NOT_UTF8 + ".json",
              expect=EITHER),
    ]  # fmt: skip


def _adapt() -> list[Case]:
    c = "evolution_manager adapt"
    base = ["--repertoire", "{run}", "--objective", "food", "--condition", "dead-robots=3"]
    quick = [*base, "--budget", "2", "--trials", "1"]
    return [
        _case("two trials of a repertoire", c, *quick, "--out", "{case}/adapt", expect=SUCCEED,
              writes=("adapt",),
              timeout=120),
        _case("--out a name that is not UTF-8", c, *quick, "--out", "{case}/adapt-" + NOT_UTF8,
              expect=SUCCEED,
              timeout=120),
        _case("--repertoire missing", c, "--repertoire", "{case}/nothing", "--objective", "food", "--out",
              "{case}/adapt"),
        _case("--repertoire with NaN", c, *quick, "--out", "{case}/adapt",
              plant=(Edit("run/repertoire_food.json", json_nan("fitness")),)),
        _case("--repertoire with a key twice", c, *quick, "--out", "{case}/adapt",
              plant=(Edit("run/repertoire_food.json", json_key_twice),)),
        _case("--repertoire not UTF-8", c, *quick, "--out", "{case}/adapt",
              plant=(Edit("run/repertoire_food.json", not_utf8),)),
        _case("--repertoire whose trees do not parse", c, *quick, "--out", "{case}/adapt",
              plant=(Edit("run/repertoire_food.json", lambda data: data.replace(b"(", b"((")),)),
        *_numbers(c, [*base, "--trials", "1", "--out", "{case}/adapt"], "--budget", ["0", "nan", "-1"], []),
        *_numbers(c, [*quick, "--out", "{case}/adapt"], "--stop-fraction", ["nan", "2", "-1"], []),
        *_numbers(c, [*quick, "--out", "{case}/adapt"], "--kappa", ["nan", "inf", "-1"], []),
        *_numbers(c, [*quick, "--out", "{case}/adapt"], "--length-scale", ["0", "nan"], []),
        _case("--condition weak-wheel=3:inf", c, "--repertoire", "{run}", "--objective", "food",
              "--condition",
              "weak-wheel=3:inf", "--out", "{case}/adapt"),
        _case("--out a link to a saved file", c, *quick, "--out", "{case}/adapt",
              plant=(Link("adapt", "{saved}"),)),
        _case("--out a dangling link", c, *quick, "--out", "{case}/adapt",
              plant=(Link("adapt", "{outside}/made"),)),
        _case("--out under a file", c, *quick, "--out", "{case}/file/adapt",
              plant=(Write("file", b"a file\n"),)),
        _case("--out a file", c, *quick, "--out", "{saved}"),
        _case("--out/adaptation.json a dangling link", c, *quick, "--out", "{case}/adapt",
              plant=(Link("adapt/adaptation.json", "{outside}/made"),)),
        _case("--out/adaptation.png a link to a saved file", c, *quick, "--out", "{case}/adapt",
              plant=(Link("adapt/adaptation.png", "{saved}"),)),
    ]  # fmt: skip


def _adapt_benchmark() -> list[Case]:
    c = "evolution_manager adapt-benchmark"
    base = ["--repertoires", "{run}", "--condition-set", "dead-robots=3", "--no-progress"]
    return [
        *_numbers(c, [*base, "--out", "{case}/b"], "--seeds", ["0", "nan"], []),
        *_numbers(c, [*base, "--out", "{case}/b"], "--budget", ["0", "nan"], []),
        *_numbers(c, [*base, "--out", "{case}/b"], "--ceiling", ["-1", "nan"], []),
        _case("--condition-set nope=1", c, "--repertoires", "{run}", "--condition-set", "nope=1", "--out",
              "{case}/b"),
        _case("--repertoires missing", c, "--repertoires", "{case}/nothing", "--condition-set",
              "dead-robots=3",
              "--out", "{case}/b"),
        _case("--out a link to a saved file", c, *base, "--out", "{case}/b", plant=(Link("b", "{saved}"),)),
        _case("--out/report.md a link to a saved file", c, *base, "--seeds", "1", "--budget", "2",
              "--ceiling", "10",
              "--trials", "1", "--out", "{case}/b", plant=(Link("b/report.md", "{saved}"),), timeout=120),
    ]  # fmt: skip


def _bags(command: str, before: list[str], after: list[str], option: str = "") -> list[Case]:
    """A trial bag input damaged: truncated or not-UTF-8 metadata, a key twice, a type outside the allowed
    packages, a flipped byte, not a bag at all."""
    label = f"{option} " if option else "BAG "
    head = [*before, option] if option else list(before)

    def damaged(name: str, file: str, how: Callable[[bytes], bytes]) -> Case:
        return _case(label + name, command, *head, "{bag}", *after, plant=(Edit(file, how),))

    return [
        damaged("metadata.yaml truncated", "bag/metadata.yaml", truncate),
        damaged("metadata.yaml not UTF-8", "bag/metadata.yaml", lambda d: d.replace(b"\n", b" \xff\xfe\n",
              1)),
        damaged("metadata.yaml a key twice", "bag/metadata.yaml",
              lambda d: d + b"rosbag2_bagfile_information: {}\n"),
        damaged("a type of another package", "bag/metadata.yaml",
                lambda d: re.sub(rb"[a-z_]+/msg/[A-Za-z]+", b"os/msg/System", d)),
        _case(label + "without metadata.yaml", command, *head, "{case}/b", *after, plant=(Folder("b"),)),
        _case(label + "missing", command, *head, "{case}/nothing", *after),
        _case(label + "the user's own text file", command, *head, "{saved}", *after),
    ]  # fmt: skip


def _mcap_flipped(data: bytes) -> bytes:
    middle = len(data) // 2
    return data[:middle] + bytes([data[middle] ^ 0xFF]) + data[middle + 1 :]


def _graph_commands() -> list[Case]:
    replay, recover, record = (
        "evolution_manager replay",
        "evolution_manager recover",
        "evolution_manager record",
    )
    trial = "evolution_manager trial"
    tree = ["--tree", "sel(seq(in_nest, stop), forward)", "--seed", "1"]
    flip = Edit("bag/*.mcap", _mcap_flipped)
    return [
        # replay
        *_bags(replay, [], ["--rate", "0", "--delay", "0"]),
        _case("a flipped byte in the MCAP file", replay, "{bag}", "--rate", "0", "--delay", "0",
              plant=(flip,)),
        *_numbers(replay, ["{bag}"], "--rate", ["nan", "-1", "inf"], []),
        *_numbers(replay, ["{bag}", "--rate", "0"], "--delay", ["nan", "inf"], []),
        *_numbers(replay, ["{bag}", "--rate", "0"], "--wait-timeout", ["nan", "-1", "inf"], []),
        _case("--wait-for a topic the bag lacks", replay, "{bag}", "--wait-for", "/nothing"),
        _case("--verify of a bag that is no one trial", replay, "{bag}", "--verify"),
        _case("a good bag gets to the guard", replay, "{bag}", "--rate", "0", "--delay", "0", expect=SUCCEED,
              guard=True),
        _case("an argument not UTF-8", replay, "{bag}", NOT_UTF8),
        # recover
        _case("a whole bag into a new one", recover, "{bag}", "{case}/new.bag", expect=SUCCEED,
              writes=("new.bag",),
              makes=("new.bag/metadata.yaml",)),
        _case("NEW_BAG a name that is not UTF-8", recover, "{bag}", "{case}/new-" + NOT_UTF8, expect=SUCCEED),
        _case("a flipped byte: what can be", recover, "{bag}", "{case}/new.bag", plant=(flip,), expect=EITHER,
              writes=("new.bag",)),
        _case("NEW_BAG a link to a saved file", recover, "{bag}", "{case}/new.bag",
              plant=(Link("new.bag", "{saved}"),)),
        _case("NEW_BAG a dangling link", recover, "{bag}", "{case}/new.bag",
              plant=(Link("new.bag", "{outside}/made"),)),
        _case("NEW_BAG a folder", recover, "{bag}", "{case}/new.bag", plant=(Folder("new.bag"),)),
        _case("NEW_BAG under a file", recover, "{bag}", "{case}/f/new.bag", plant=(Write("f", b"a file\n"),)),
        _case("DAMAGED missing", recover, "{case}/nothing", "{case}/new.bag"),
        _case("DAMAGED the user's own text file", recover, "{saved}", "{case}/new.bag"),
        # record
        *[c for c in _output_cases(record, [], "--bag", ".bag", force=False) if "--force" not in c.name],
        *_numbers(record, ["--bag", "{case}/r.bag"], "--robots", ["0", "nan", "-3", "9" * 30], []),
        _case("--namespace 'bad name'", record, "--bag", "{case}/r.bag", "--namespace", "bad name"),
        _case("--clock ''", record, "--bag", "{case}/r.bag", "--clock", ""),
        _case("a good line gets to the guard", record, "--bag", "{case}/r.bag", expect=SUCCEED, guard=True),
        # trial
        _case("a good line gets to the guard", trial, *tree, "--bag", "{case}/t.bag",
              expect=SUCCEED, guard=True),
        *[c for c in _output_cases(trial, tree, "--bag", ".bag", force=False) if "--force" not in c.name],
        *_numbers(trial, [*tree, "--bag", "{case}/t.bag"], "--timeout", ["nan", "0", "inf", "-1"], []),
        *_numbers(trial, tree[:2], "--seed", ["-1", str(2**64)], ["--bag", "{case}/t.bag"]),
        *_numbers(trial, [*tree, "--bag", "{case}/t.bag"], "--trial", ["-1"], []),
        *_numbers(trial, [*tree, "--bag", "{case}/t.bag"], "--domain", ["300", "-1"], []),
        _case("--namespace '/a//b'", trial, *tree, "--bag", "{case}/t.bag", "--namespace", "/a//b"),
        _case("--clock 'a b'", trial, *tree, "--bag", "{case}/t.bag", "--clock", "a b"),
        _case("--logs a link to a saved file", trial, *tree, "--bag", "{case}/t.bag", "--logs", "{case}/logs",
              plant=(Link("logs", "{saved}"),)),
        _case("--logs a file", trial, *tree, "--bag", "{case}/t.bag", "--logs", "{saved}"),
        _case("the default logs folder a link", trial, *tree, "--bag", "{case}/t.bag",
              plant=(Link("t.bag.logs", "{outside}"),)),
        *_yaml_input_cases(trial, [*tree, "--bag", "{case}/t.bag"], "--params-file", [], "answer_timeout"),
        _case("--params-file a mistyped value", trial, *tree, "--bag", "{case}/t.bag", "--params-file",
              "{case}/p.yaml",
                    plant=(Write("p.yaml", b"/**:\n  ros__parameters:\n    answer_timeout: soon\n"),)),
        *_json_input_cases(trial, [*tree, "--bag", "{case}/t.bag"], "--library", [])[:4],
        *_json_input_cases(trial, ["--seed", "1", "--bag", "{case}/t.bag"], "--swarm", [])[:4],
        _case("--tree a file that is not UTF-8", trial, "--tree", "{case}/tree.txt", "--bag", "{case}/t.bag",
              plant=(Write("tree.txt", b"sel(forward, \xff)\n"),)),
    ]  # fmt: skip


def _viewing() -> list[Case]:
    snapshot, explorer = "evolution_manager snapshot", "evolution_manager explorer"
    animate = "evolution_manager animate"
    tree = ["--tree", "forward", "--seed", "1", "--every", "50"]
    return [
        # snapshot
        _case("a step drawn", snapshot, "{bag}", "--out", "{case}/s.png", expect=SUCCEED, makes=("s.png",)),
        _case("--out a name that is not UTF-8", snapshot, "{bag}", "--out", "{case}/s-" + NOT_UTF8 + ".png",
              expect=SUCCEED),
        *_output_cases(snapshot, ["{bag}"], "--out", ".png", force=True),
        _case("--out with a suffix no picture has", snapshot, "{bag}", "--out", "{case}/new/s.xyz"),
        *_numbers(snapshot, ["{bag}", "--out", "{case}/s.png"], "--step", ["99", "nan"], []),
        *_bags(snapshot, [], ["--out", "{case}/s.png"])[:4],
        # explorer
        _case("a run's page rebuilt", explorer, "{run}", "--no-animations", expect=SUCCEED, writes=("run",),
              makes=("run/explorer.html",)),
        _case("a run in a folder whose name is not UTF-8", explorer, "{case}/run-" + NOT_UTF8,
              "--no-animations",
              plant=(Copy("run", "run-" + NOT_UTF8),), expect=SUCCEED, writes=("run-*",)),
        _case("a folder that is missing", explorer, "{case}/nothing"),
        _case("a file", explorer, "{saved}"),
        _case("an empty folder", explorer, "{case}/empty", plant=(Folder("empty"),)),
        _case("repertoire with NaN", explorer, "{run}", "--no-animations",
              plant=(Edit("run/repertoire_food.json", json_nan("fitness")),)),
        _case("repertoire with a key twice", explorer, "{run}", "--no-animations",
              plant=(Edit("run/repertoire_food.json", json_key_twice),)),
        _case("repertoire not UTF-8", explorer, "{run}", "--no-animations",
              plant=(Edit("run/repertoire_food.json", not_utf8),)),
        _case("repertoire whose trees do not parse", explorer, "{run}", "--no-animations",
              plant=(Edit("run/repertoire_food.json", lambda data: data.replace(b"(", b"((")),)),
        _case("explorer.html a link to a saved file", explorer, "{run}", "--no-animations",
              plant=(Link("run/explorer.html", "{saved}"),)),
        *_json_input_cases(explorer, ["{run}", "--no-animations"], "--library", []),
        # animate
        _case("a trial animated", animate, *tree, "--out", "{case}/a.gif", expect=SUCCEED, makes=("a.gif",),
              timeout=120),
        _case("--out a name that is not UTF-8", animate, *tree, "--out", "{case}/a-" + NOT_UTF8 + ".gif",
              expect=SUCCEED, timeout=120),
        *_output_cases(animate, tree, "--out", ".gif", force=True),
        _case("--out .xyz", animate, *tree, "--out", "{case}/a.xyz"),
        *_numbers(animate, [*tree, "--out", "{case}/a.gif"], "--fps", ["0", "-1", "nan", "9" * 30], []),
        *_numbers(animate, ["--tree", "forward", "--seed", "1", "--out", "{case}/a.gif"], "--every", ["0",
              "nan"], []),
        *_numbers(animate, ["--tree", "forward", "--out", "{case}/a.gif"], "--seed", ["-1", "nan"], []),
        *_numbers(animate, [*tree, "--out", "{case}/a.gif"], "--trial", ["-1"], []),
        _case("--tree that does not parse", animate, "--tree", "sel(", "--seed", "1", "--out",
              "{case}/a.gif"),
        *_json_input_cases(animate, ["--seed", "1", "--out", "{case}/a.gif"], "--swarm", [])[:4],
        *_json_input_cases(animate, [*tree, "--out", "{case}/a.gif"], "--library", [])[:4],
        *_bags(animate, [], ["--out", "{case}/a.gif"], option="--bag")[:4],
    ]  # fmt: skip


def _validate() -> list[Case]:
    c = "swarm_sim validate"
    ref = ["--reference", "{reference}", "--seeds", "2", "--trials", "1"]
    return [
        _case("a report of one tree", c, *ref, "--out", "{case}/v.md", expect=SUCCEED, makes=("v.md",)),
        _case("--out a name that is not UTF-8", c, *ref, "--out", "{case}/v-" + NOT_UTF8 + ".md",
              expect=SUCCEED),
        *_output_cases(c, ref, "--out", ".md", force=True),
        _case("--tsv a link to a saved file", c, *ref, "--out", "{case}/v.md", "--tsv", "{case}/t.tsv",
              plant=(Link("t.tsv", "{saved}"),)),
        _case("--reference not UTF-8", c, "--reference", "{case}/r.tsv", "--out", "{case}/v.md",
              plant=(Write("r.tsv", b"tree\tdensity_mean\n\xff\t0.5\n"),)),
        _case("--reference with NaN", c, "--reference", "{reference}", "--out", "{case}/v.md",
              plant=(Edit("reference", lambda d: d.replace(b"0.5", b"nan", 1)),)),
        _case("--reference missing", c, "--reference", "{case}/r.tsv", "--out", "{case}/v.md"),
        _case("--reference a folder", c, "--reference", "{case}/r", "--out", "{case}/v.md",
              plant=(Folder("r"),)),
        *_numbers(c, ["--reference", "{reference}", "--out", "{case}/v.md"], "--seeds", ["1", "nan", "0"],
              []),
        *_numbers(c, ["--reference", "{reference}", "--out", "{case}/v.md"], "--trials", ["0", "nan"], []),
        _case("--transfer missing", c, "--transfer", "{case}/nothing", "--out", "{case}/t.md"),
        _case("--notes not UTF-8", c, *ref, "--notes", "{case}/n.md", "--out", "{case}/v.md",
              plant=(Write("n.md", b"notes \xff\n"),)),
        *_json_input_cases(c, ref, "--library", ["--out", "{case}/v.md"])[:4],
    ]  # fmt: skip


def _bt() -> list[Case]:
    c = "bt_controller bt"
    return [
        _case("check a tree", c, "check", "sel(seq(in_nest, stop), forward)", expect=SUCCEED),
        _case("export a tree as SVG", c, "export", "sel(in_nest, forward)", "--output", "{case}/t.svg",
              expect=SUCCEED, makes=("t.svg",)),
        _case("export to a name that is not UTF-8", c, "export", "forward", "--output",
              "{case}/t-" + NOT_UTF8 + ".svg", expect=SUCCEED),
        *_output_cases(c, ["export", "sel(in_nest, forward)"], "--output", ".svg", force=True),
        _case("check a tree that does not parse", c, "check", "sel("),
        _case("check a file that is not UTF-8", c, "check", "{case}/t.txt",
              plant=(Write("t.txt", b"sel(\xff)\n"),)),
        _case("check XML with a key... an attribute twice", c, "check", "{case}/t.xml",
              plant=(Write("t.xml", b'<root BTCPP_format="4" BTCPP_format="4"><BehaviorTree/></root>'),)),
        _case("check an XML entity bomb", c, "check", "{case}/t.xml",
              plant=(Write("t.xml",
                    b'<!DOCTYPE r [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;">]><root>&b;</root>'),)),
        _case("show a tree 5000 deep", c, "show", "seq(" * 5000 + "forward" + ")" * 5000, "--format", "xml"),
        _case("simplify --max-nodes nan", c, "simplify", "forward", "--max-nodes", "nan"),
        _case("check a tree not UTF-8", c, "check", "sel(" + NOT_UTF8 + ")"),
    ]  # fmt: skip


def _task() -> list[Case]:
    c = "swarm_sim task"
    return [
        _case("list", c, "list", expect=SUCCEED),
        _case("show foraging", c, "show", "foraging", expect=SUCCEED),
        _case("check a task file", c, "check", "{task}", expect=SUCCEED),
        _case("show nope", c, "show", "nope"),
        *[_case(case.name, c, "check", *case.args[1:], plant=case.plant)
          for case in _yaml_input_cases(c, [], "--task", [], "ticks")],
    ]  # fmt: skip


def _main_job() -> list[Case]:
    c = "evolution_manager main"
    return [
        _case("a good line gets to the guard", c, "--evaluations", "150", "--out", "{case}/m", expect=SUCCEED,
              guard=True, writes=("m",)),
        *_numbers(c, ["--out", "{case}/m"], "--evaluations", ["nan", "0", "-5"], []),
        *_numbers(c, ["--evaluations", "150", "--out", "{case}/m"], "--evaluators", ["0", "nan"], []),
        *_numbers(c, ["--evaluations", "150", "--out", "{case}/m"], "--seed", ["-1"], []),
        *_numbers(c, ["--evaluations", "150", "--out", "{case}/m"], "--scenario-seed", ["-1", "nan"], []),
        _case("--out a link to a saved file", c, "--evaluations", "150", "--out", "{case}/m",
              plant=(Link("m", "{saved}"),)),
        _case("--out a file", c, "--evaluations", "150", "--out", "{saved}"),
        _case("--out under a file", c, "--evaluations", "150", "--out", "{case}/f/m",
              plant=(Write("f", b"a file\n"),)),
        _case("--resume of a folder that is missing", c, "--out", "{case}/nothing", "--resume"),
        _case("--resume of a file", c, "--out", "{saved}", "--resume"),
        _case("--cluster-config not UTF-8 (slurm)", c, "--evaluations", "150", "--out", "{case}/m",
              "--cluster",
              "slurm", "--cluster-config", "{case}/c.yaml", plant=(Write("c.yaml", b"cores: \xff\n"),)),
    ]  # fmt: skip


def _measure() -> list[Case]:
    c = "evolution_manager measure"
    return [
        _case("--json a link to a saved file", c, "--evaluations", "2", "--json", "{case}/m.json", "--force",
              plant=(Link("m.json", "{saved}"),)),
        _case("--json exists", c, "--evaluations", "2", "--json", "{case}/m.json",
              plant=(Write("m.json", b"{}"),)),
        *_numbers(c, [], "--evaluations", ["0", "nan"], []),
    ]  # fmt: skip


CASES: list[Case] = [
    *_evolve(),
    *_evaluate(),
    *_experiment(),
    *_report(),
    *_library(),
    *_adapt(),
    *_adapt_benchmark(),
    *_graph_commands(),
    *_viewing(),
    *_validate(),
    *_bt(),
    *_task(),
    *_main_job(),
    *_measure(),
]
"""Every case, in the order the probe runs and prints them."""

SMOKE = (
    "evolution_manager snapshot|--out a link to a saved file, --force",
    "evolution_manager explorer|a folder that is missing",
    "swarm_sim validate|--out exists",
    "evolution_manager trial|--timeout 'nan'",
    "evolution_manager record|--robots '0'",
    "evolution_manager replay|--rate 'nan'",
    "bt_controller bt|check a file that is not UTF-8",
    "swarm_sim task|--task a key twice",
)
"""A few fast cases (no simulation, no fixture run) for the probe's own test: ``command|name``."""
