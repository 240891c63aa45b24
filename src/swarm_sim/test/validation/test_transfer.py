"""Transfer check: picking trees from repertoire grids, ARGoS's raw rows, the table, and the command."""

import json
import math
from pathlib import Path

import pytest

from swarm_sim.errors import UsageError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import PAPER_OBJECTIVES
from swarm_sim.validation import GridItem, transfer
from swarm_sim.validation import reference as validation
from swarm_sim.validation.cli import main as validate_main

SHAPE = (8, 8, 8)


def _item(bin_, fitness, tree=None):
    return GridItem(bin_, tree or f"t{bin_}", fitness, tuple((b + 0.5) / 8 for b in bin_))


def test_farthest_points_worked_by_hand():
    a = _item((0, 0, 0), 0.9)
    b = _item((7, 7, 7), 0.1)
    c = _item((7, 0, 0), 0.2)
    d = _item((0, 7, 7), 0.3)
    e = _item((1, 0, 0), 0.5)
    items = [a, e, d, c, b]
    picked = transfer.farthest_points(items, SHAPE, 4)
    # best a; b is the far corner; c and d are both 7/8 from {a, b}: the lower bin, d, first; then c, then e
    assert [(role, item.bin) for role, item in picked] == [
        ("best", (0, 0, 0)),
        ("spread 1", (7, 7, 7)),
        ("spread 2", (0, 7, 7)),
        ("spread 3", (7, 0, 0)),
        ("spread 4", (1, 0, 0)),
    ]
    assert [item for _, item in transfer.farthest_points(items, SHAPE, 2)] == [a, b, d]
    assert transfer.farthest_points(list(reversed(items)), SHAPE, 4) == picked  # order-free
    tie = _item((3, 3, 3), 0.9)
    assert transfer.farthest_points([tie, a], SHAPE, 0) == [("best", a)]  # equal fitness: the lower bin
    assert len(transfer.farthest_points([a, b], SHAPE, 5)) == 2  # no more than the grid holds
    assert transfer.farthest_points([], SHAPE, 3) == []


def _repertoire(path, objective, items):
    document = {
        "objective": objective,
        "shape": list(SHAPE),
        "items": [
            {"bin": list(b), "tree": t, "fitness": f, "descriptors": [(x + 0.5) / 8 for x in b]}
            for b, t, f in items
        ],
    }
    path.write_text(json.dumps(document))


def _run_dir(root, name, evolved, items_by_objective, scenario_seed=None):
    run = root / name
    run.mkdir()
    summary = {"objectives": {o: {"evolved": o in evolved} for o in ("density", "nest", "food")}}
    (run / "summary.json").write_text(json.dumps(summary))
    if scenario_seed is not None:
        (run / "config.json").write_text(json.dumps({"scenario_seed": scenario_seed}))
    for objective, items in items_by_objective.items():
        _repertoire(run / f"repertoire_{objective}.json", objective, items)
    return run


def test_pick_trees_reads_elites_of_evolved_grids_and_skips_repeats(tmp_path):
    density = [
        ((0, 0, 0), "forward", 0.4),
        ((0, 0, 0), "stop", 0.6),  # the bin's elite
        ((7, 7, 7), "reverse", 0.5),
        ((0, 7, 7), "forward_left", 0.45),
    ]
    food = [((7, 7, 7), "forward_right", 0.9)]  # a passive grid of this run: not picked
    run1 = _run_dir(tmp_path, "run1", ["density"], {"density": density, "food": food})
    run2 = _run_dir(
        tmp_path, "run2", ["nest"], {"nest": [((1, 1, 1), "stop", 0.9), ((5, 5, 5), "reverse", 0.2)]}
    )
    picks = transfer.pick_trees([run1, run2], 1)
    assert [(p.run, p.objective, p.bin, p.role, p.tree) for p in picks] == [
        ("run1", "density", (0, 0, 0), "best", "stop"),
        ("run1", "density", (7, 7, 7), "spread 1", "reverse"),
        # run2's best, stop, and its other tree, reverse, were picked already: nothing left
    ]
    assert picks[0].fitness == 0.6
    (run2 / "summary.json").unlink()  # without a summary: every repertoire file present
    assert [p.tree for p in transfer.pick_trees([run2], 1)] == ["stop", "reverse"]


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("not json", "not JSON"),
        (
            json.dumps({"objective": "density", "shape": [8, 8, 8], "items": [{"bin": [9, 0, 0]}]}),
            "not a repertoire",
        ),
        (json.dumps({"objective": "speed", "shape": [8, 8, 8], "items": []}), "objective must be one of"),
    ],
)
def test_bad_repertoires_are_refused_naming_the_file(tmp_path, content, message):
    run = _run_dir(tmp_path, "run", ["density"], {})
    (run / "repertoire_density.json").write_text(content)
    with pytest.raises(UsageError, match=message):
        transfer.pick_trees([run], 2)


def test_runs_the_argos_driver_cannot_measure_are_refused_in_one_line(tmp_path):
    # The driver measures the 2023 build's six quantities in 20 s trials: a foraging run, a run with a
    # primitive library, or a run evolving an inverse primitive has nothing there to compare with.
    items = {"density": [((0, 0, 0), "stop", 0.5)]}
    foraging = _run_dir(tmp_path, "foraging", ["density"], items)
    (foraging / "config.json").write_text(json.dumps({"task": "foraging"}))
    with pytest.raises(UsageError, match="foraging task: the ARGoS driver measures the primitives"):
        transfer.pick_trees([foraging], 1)
    library = _run_dir(tmp_path, "library", ["density"], items)
    (library / "config.json").write_text(json.dumps({"task": "primitives", "library": "p.json"}))
    with pytest.raises(UsageError, match=r"with the library p\.json"):
        transfer.pick_trees([library], 1)
    inverse = tmp_path / "inverse"
    inverse.mkdir()
    (inverse / "summary.json").write_text(json.dumps({"objectives": {"idensity": {"evolved": True}}}))
    with pytest.raises(UsageError, match="evolved idensity; the ARGoS driver measures density, nest, food"):
        transfer.pick_trees([inverse], 1)


def test_seeds_text_names_a_run_of_seeds_as_parse_seeds_reads_it():
    assert transfer.seeds_text(range(1, 21)) == "1-20"
    assert transfer.parse_seeds(transfer.seeds_text((4, 5, 6))) == [4, 5, 6]
    assert transfer.seeds_text([2, 5, 6]) == "[2, 5, 6]"


def test_parse_seeds():
    assert transfer.parse_seeds("3") == [1, 2, 3]
    assert transfer.parse_seeds("1-4") == [1, 2, 3, 4]
    assert transfer.parse_seeds("2,5-6") == [2, 5, 6]
    for bad in ("a-b", "0-3", "1,1", ""):
        with pytest.raises(UsageError, match="--seeds"):
            transfer.parse_seeds(bad)


RAW_HEADER = "tree\tseed\tchromosome\targos_wall_s\tdensity\tnest\tfood\tmovement\trotation\tconditionality\n"


def _raw_row(tree, seed, values):
    return f"{tree}\t{seed}\tx\t0.5\t" + "\t".join(f"{v:.9g}" for v in values) + "\n"


def test_argos_raw_rows_map_descriptors_and_report_what_is_missing(tmp_path):
    raw = tmp_path / "raw.tsv"
    raw.write_text(
        RAW_HEADER
        + _raw_row("forward", 1, [0.5, 0.4, 0.7, 40.0, 0.0, 0.0])
        + _raw_row("forward", 2, [0.5, 0.6, 0.7, 40.0, -8.0, 0.0])
        + _raw_row("stop", 1, [0.5, 0.6, 0.5, 0.0, 0.0, 0.0])
    )
    rows = transfer.read_argos_raw(raw)
    assert rows[("forward", 2)] == (0.5, 0.6, 0.7, 1.0, 0.4, 0.0)  # (40 + 40) / 80, (-8 + 40) / 80
    estimates, missing = transfer.argos_estimates(rows, ["forward", "stop"], [1, 2])
    assert missing == [("stop", 2)] and list(estimates) == ["forward"]
    assert estimates["forward"]["nest"].mean == pytest.approx(0.5)
    assert estimates["forward"]["nest"].sem == pytest.approx(0.1)  # sd 0.1414 / sqrt(2)
    assert estimates["forward"]["movement"] == validation.Estimate(1.0, 0.0, 2)
    assert transfer.read_argos_raw(tmp_path / "absent.tsv") == {}
    raw.write_text("tree\tseed\n")
    with pytest.raises(UsageError, match="missing column"):
        transfer.read_argos_raw(raw)


def _our_rows(tree, seeds, trials):
    results = BatchEvaluator().evaluate([EvaluationRequest(tree, s, trials) for s in seeds])
    out = []
    for result in results:
        values = list(result.fitness[: len(PAPER_OBJECTIVES)] + result.descriptors)  # the driver's six
        values[3] = values[3] * 80 - 40  # back to the driver's raw units
        values[4] = values[4] * 80 - 40
        out.append(values)
    return out


def test_command_against_rows_of_our_own_model_finds_every_quantity_indistinguishable(tmp_path, capsys):
    # The ARGoS rows are our own evaluations of the same seeds: every difference is 0 (up to the driver's
    # printed resolution), so the whole path (picking, our batch, the rows, the table) must say so.
    density = [((0, 0, 0), "stop", 0.5), ((7, 7, 7), "sel(seq(robot_left, reverse), forward)", 0.52)]
    run = _run_dir(tmp_path, "run", ["density"], {"density": density}, scenario_seed=2)
    trees = ["sel(seq(robot_left, reverse), forward)", "stop", "seq(reverse_left, forward)"]
    ours_seeds = [1, 3, 4]  # seed 2 is the run's own scenario: not fresh
    raw = tmp_path / "raw.tsv"
    text = RAW_HEADER
    for tree in trees:
        for seed, values in zip([1, 2, 3], _our_rows(tree, ours_seeds, 2), strict=True):
            text += _raw_row(tree, seed, values)
    raw.write_text(text)
    out = tmp_path / "transfer.md"
    args = ["--transfer", str(run), "--per-run", "3", "--evaluations", "3", "--trials", "2", "--seeds", "1-3"]
    args += ["--tree", "seq(reverse_left, forward)", "--argos-raw", str(raw), "--out", str(out)]
    assert validate_main(args) == 0, capsys.readouterr().err
    report = out.read_text()
    assert "**18 of 18** quantities over 3 trees agree" in report
    assert "**18 of 18** are also statistically indistinguishable" in report
    assert "seeds 1, 3, 4, 2 trials each; fresh" in report
    assert "| 1 | run | density | 7,7,7 | best | `sel(seq(robot_left, reverse), forward)` |" in report
    assert "| 3 | hand |  |  | hand | `seq(reverse_left, forward)` |" in report
    table = transfer.read_transfer_tsv(tmp_path / "transfer.tsv")
    assert [row.pick.tree for row in table] == [trees[0], "stop", trees[2]]
    for row in table:
        for c in row.comparisons:
            assert abs(c.diff) <= 5e-7 and c.verdict == validation.INDISTINGUISHABLE
    assert table[0].own_fitness is not None and table[0].own_fitness.quantity == "density"
    assert validate_main(args) == 2  # the report and the table exist: refused without --force
    assert "already exists: add --force" in capsys.readouterr().err
    assert validate_main([*args, "--force"]) == 0 and out.read_text() == report  # seeded: the same report


@pytest.mark.parametrize("planted", ["table", "raw rows"])
def test_the_transfer_table_and_raw_rows_are_never_written_through_a_link(tmp_path, capsys, planted):
    run = _run_dir(tmp_path, "run", ["food"], {"food": [((0, 0, 0), "stop", 0.5)]})
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    out = tmp_path / "transfer.md"
    link = tmp_path / ("transfer.tsv" if planted == "table" else "transfer_argos_raw.tsv")
    link.symlink_to(precious)
    assert validate_main(["--transfer", str(run), "--out", str(out), "--force"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{link} is a symbolic link" in err, err
    assert precious.read_text() == "keep me\n" and not out.exists()


def test_a_missing_argos_build_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    run = _run_dir(tmp_path, "run", ["food"], {"food": [((0, 0, 0), "stop", 0.5)]})
    out = tmp_path / "transfer.md"
    monkeypatch.delenv("ARGOS_EVAL", raising=False)
    assert validate_main(["--transfer", str(run), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("validate: error: no ARGoS harness") and not out.exists()
    monkeypatch.setenv("ARGOS_EVAL", str(tmp_path / "argos_eval.py"))
    monkeypatch.setenv("ARGOS_PREFIX", str(tmp_path / "install"))
    assert validate_main(["--transfer", str(run), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("validate: error: ARGoS build not found:") and "argos3" in err and not out.exists()
    assert validate_main(["--transfer", str(tmp_path / "nothing"), "--out", str(out)]) == 2
    assert "not a directory" in capsys.readouterr().err


def test_transfer_table_round_trip_and_summary(tmp_path):
    pick = transfer.Pick("r", "nest", (1, 2, 3), "best", "forward", 0.7)
    ours = {q: validation.Estimate(0.5, 0.01, 20) for q in transfer.QUANTITIES}
    theirs = dict(ours, nest=validation.Estimate(0.6, 0.01, 20))
    row = transfer.TransferRow(pick, tuple(validation.compare("forward", ours, theirs)))
    summary = "\n".join(transfer.render_summary([row]))
    assert "**5 of 6** quantities over 1 trees agree" in summary
    assert "mean difference ours - ARGoS -0.1000, largest |z| 7.1" in summary
    assert "- #1 nest: OUTSIDE, ours 0.5000 ± 0.0100, ARGoS 0.6000 ± 0.0100, diff -0.1000" in summary
    text = transfer.transfer_tsv([row])
    nest = ["nest", "0.500000", "0.010000", "20", "0.600000", "0.010000", "20", "-0.100000", "0.072426"]
    assert text.splitlines()[2].split("\t")[6:] == [*nest, "-7.071", "OUTSIDE"]
    assert math.isclose(row.own_fitness.z, -0.1 / math.hypot(0.01, 0.01))
    path = tmp_path / "t.tsv"
    path.write_text(text)
    (back,) = transfer.read_transfer_tsv(path)
    assert (back.pick.run, back.pick.objective, back.pick.bin, back.pick.role) == (
        "r",
        "nest",
        (1, 2, 3),
        "best",
    )
    assert back.comparisons == row.comparisons
    path.write_text(text.replace("\tnest\t", "\tspeed\t"))
    with pytest.raises(UsageError, match="six quantities"):
        transfer.read_transfer_tsv(path)


def test_the_reference_report_adds_a_transfer_tables_summary(tmp_path, capsys):
    pick = transfer.Pick("run7", "food", (0, 1, 2), "best", "forward", 0.7)
    same = {q: validation.Estimate(0.5, 0.01, 20) for q in transfer.QUANTITIES}
    table = tmp_path / "transfer.tsv"
    table.write_text(
        transfer.transfer_tsv([transfer.TransferRow(pick, tuple(validation.compare("f", same, same)))])
    )
    ref = tmp_path / "ref.tsv"
    header = "tree\t" + "\t".join(f"{q}_mean\t{q}_sem" for q in transfer.QUANTITIES) + "\n"
    ref.write_text(header + "stop\t" + "\t".join(["0.5\t0.01"] * 3 + ["0.0\t0.0"] * 3) + "\n")
    out = tmp_path / "validation.md"
    args = [
        "--reference",
        str(ref),
        "--seeds",
        "2",
        "--trials",
        "1",
        "--transfer-table",
        str(table),
        "--out",
        str(out),
    ]
    assert validate_main(args) == 0, capsys.readouterr().err
    report = out.read_text()
    assert "## Transfer: trees evolved here, in ARGoS" in report
    assert "**6 of 6** quantities over 1 trees agree" in report
    assert "| 1 | run7 | food | 0,1,2 | best | `forward` | ✓ | ✓ | ✓ | ✓ | ✓ | ✓ |" in report
    table.write_text("not\ta table\n")
    assert validate_main([*args, "--force"]) == 2
    assert "not a transfer table" in capsys.readouterr().err


@pytest.mark.parametrize(
    "text,message",
    [
        (RAW_HEADER + "stop\t1\tx\t0.5\tnan\t0\t0\t0\t0\t0\n", "finite"),
        (RAW_HEADER + "stop\t1\tx\t0.5\tinf\t0\t0\t0\t0\t0\n", "finite"),
        (RAW_HEADER.encode() + b"st\xffop\t1\tx\t0.5\t0\t0\t0\t0\t0\t0\n", "not UTF-8 text"),
    ],
)
def test_argos_raw_rows_that_are_not_finite_or_not_utf8_are_refused(tmp_path, text, message):
    """NaN rows were taken as measurements; bytes that are not UTF-8 were a traceback."""
    raw = tmp_path / "raw.tsv"
    raw.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(UsageError, match=message) as refused:
        transfer.read_argos_raw(raw)
    assert "\n" not in str(refused.value)


def test_a_runs_repertoire_is_read_strictly_by_the_transfer_check(tmp_path):
    run = _run_dir(tmp_path, "run", ["food"], {"food": [((0, 0, 0), "stop", 0.5)]})
    path = run / "repertoire_food.json"
    path.write_text(path.read_text()[:-1] + ', "objective": "food"}')
    with pytest.raises(UsageError, match="appears twice"):
        transfer.pick_trees([run], 1)


VALIDATION = Path(__file__).resolve().parents[4] / "docs" / "validation"


def _result_lines(values_of_robot) -> str:
    """footbot_nn's ``result`` lines: per robot, slot-major, its ten values in each of five trials."""
    lines = ["ARGoS says hello"]
    for robot in range(transfer.NETWORK_ROBOTS):
        cells = [values_of_robot(robot, q, k) for q in range(10) for k in range(transfer.NETWORK_TRIALS)]
        lines.append(f"result {robot} " + " ".join(repr(v) for v in cells))
    return "\n".join(lines) + "\n"


def test_footbot_nns_result_lines_give_each_value_per_robot_per_trial():
    text = _result_lines(lambda robot, q, k: 10.0 * q + k + (robot == 0))
    means = transfer.network_means(text)
    assert means == pytest.approx([10.0 * q + 2.0 + 1.0 / 9 for q in range(10)])
    with pytest.raises(UsageError, match="expected 50 values per robot"):
        transfer.network_means(text.replace("result 3 ", "result 3 1.0 "))
    with pytest.raises(UsageError, match="expected 50 values per robot"):
        transfer.network_means("no results\n")


def test_the_validations_network_rows_read_back_and_need_no_driver(tmp_path, monkeypatch):
    """The committed footbot_nn rows (7 networks, seeds 1-20, 20 s and 100 s trials) read back by network,
    seed and trial length; run_networks asks nothing of ARGoS when every row is there, names the build to
    make when one is missing, and never writes through a planted link."""
    committed = VALIDATION / "argos_raw_networks.tsv"
    rows = transfer.read_network_raw(committed)
    assert len(rows) == 7 * 20 * 2
    first = committed.read_text().splitlines()[1].split("\t")
    assert rows[(first[0], int(first[1]), int(first[2]))] == tuple(float(v) for v in first[3:13])
    raw = tmp_path / "raw.tsv"
    raw.write_bytes(committed.read_bytes())
    harness = transfer.ArgosHarness(tmp_path / "absent_argos_eval.py")
    harness.run_networks([first[0]], range(1, 21), int(first[2]), raw, tmp_path)  # all there: no driver
    assert raw.read_bytes() == committed.read_bytes()
    monkeypatch.setenv("ARGOS_PREFIX", str(tmp_path / "install"))
    with pytest.raises(UsageError, match=r"ARGoS build not found: .*rebuild_2026\.sh"):
        harness.run_networks([first[0]], [21], 20, raw, tmp_path)
    # a build's files where the harness looks (none of them run: the link is refused first)
    build = tmp_path / "bmr-2026" / "argos3" / "build"
    monkeypatch.setenv("BT_ARGOS_DIR_MULTIFOOD", str(build.parent))
    monkeypatch.setenv("SRAND_SHIM", str(tmp_path / "shim.so"))
    for made in (
        tmp_path / "install" / "bin" / "argos3",
        build / "controllers" / "footbot_nn" / "libfootbot_nn.so",
        build / "loop_functions" / "nn_loop_functions" / "libnn_loop_functions.so",
        tmp_path / "shim.so",
    ):
        made.parent.mkdir(parents=True, exist_ok=True)
        made.write_text("")
    harness = transfer.ArgosHarness(Path(__file__))
    assert harness.missing("multifood") == []
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    link = tmp_path / "linked.tsv"
    link.symlink_to(precious)
    with pytest.raises(OSError, match=r"linked\.tsv is a symbolic link"):
        harness.run_networks([first[0]], [1], 20, link, tmp_path)
    (tmp_path / "argos_network_run").symlink_to(precious)
    with pytest.raises(OSError, match="argos_network_run is a symbolic link"):
        harness.run_networks([first[0]], [1], 20, tmp_path / "new.tsv", tmp_path)
    assert precious.read_text() == "keep me\n" and not (tmp_path / "new.tsv").exists()
    bad = tmp_path / "bad.tsv"
    bad.write_text("tree\tseed\n")
    with pytest.raises(UsageError, match="not a network raw TSV of footbot_nn: missing column"):
        transfer.read_network_raw(bad)
