"""The evaluate command: one JSON object on stdout, byte-identical for a seed; clean errors."""

import json
import subprocess
import sys

import pytest

from swarm_sim.evaluation.cli import evaluate_main

TREE = "sel2(seq2(in_nest, stop), forward)"


def _run(*args):
    return subprocess.run(
        [sys.executable, "-m", "swarm_sim.evaluation.cli", *args],
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    )


def test_stdout_is_one_json_object_and_byte_identical_for_a_seed():
    first = _run("--tree", TREE, "--seed", "5", "--trials", "4")
    second = _run("--tree", TREE, "--seed", "5", "--trials", "4")
    assert first.returncode == 0, first.stderr
    assert first.stdout == second.stdout
    document = json.loads(first.stdout)
    assert list(document) == [
        "tree", "seed", "trials", "profile", "task", "conditions", "fitness", "descriptors"
    ]  # fmt: skip
    assert document["task"] == "primitives"
    assert document["conditions"] == {}
    assert document["tree"] == "sel(seq(in_nest, stop), forward)"
    assert (document["seed"], document["trials"]) == (5, 4)
    names = ["density", "nest", "food", "idensity", "inest", "ifood", "foraging", "aggregation"]
    names += ["foraging1", "foraging2", "foraging3", "foraging_biased", "foraging_balanced"]
    assert list(document["fitness"]) == names
    assert list(document["descriptors"]) == ["movement", "rotation", "conditionality"]


def test_different_seeds_differ(capsys):
    outputs = []
    for seed in ("1", "2"):
        assert evaluate_main(["--tree", TREE, "--seed", seed, "--trials", "2"]) == 0
        outputs.append(json.loads(capsys.readouterr().out))
    assert outputs[0]["fitness"] != outputs[1]["fitness"]


def test_engines_print_the_same_document(capsys):
    documents = []
    for engine in ("compiled", "reference"):
        args = ["--tree", TREE, "--seed", "9", "--trials", "2", "--engine", engine, "--per-trial"]
        assert evaluate_main(args) == 0
        documents.append(capsys.readouterr().out)
    assert documents[0] == documents[1]
    per_trial = json.loads(documents[0])["per_trial"]
    assert [t["trial"] for t in per_trial] == [0, 1] and [t["gap"] for t in per_trial] == [500.0, 500.0]
    assert len(per_trial[0]["start_poses"]) == 9 and len(per_trial[0]["end_poses"][0]) == 3


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--tree", "sel(in_nest"], "bad tree"),
        (["--tree", "dance"], "dance"),
        (["--tree", "stop", "--trials", "0"], "--trials"),
        (["--tree", "stop", "--seed", "-3"], "--seed"),
        (["--tree", "stop", "--engine", "fast"], "--engine"),
        (["--tree", "stop", "--profile", "argos"], "--profile"),
        (["--tree", "stop", "--trials", "many"], "--trials"),
        ([], "--tree"),
    ],
)
def test_bad_input_exits_2_with_one_line(capsys, args, words):
    assert evaluate_main(args) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and words in captured.err and "Traceback" not in captured.err


def test_bad_input_from_the_shell():
    done = _run("--tree", "seq(stop)")
    assert done.returncode == 2 and done.stdout == "" and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


def test_the_profile_is_chosen_and_recorded(capsys):
    documents = {}
    for profile in ("paper", "clean"):
        assert evaluate_main(["--tree", "seq(forward, reverse)", "--trials", "5", "--profile", profile]) == 0
        documents[profile] = json.loads(capsys.readouterr().out)
    assert documents["paper"]["profile"] == "paper" and documents["clean"]["profile"] == "clean"
    # (13.4 - 26.6 + 40) / 80 over a paper chain; (14 - 26 + 40) / 80 in clean trials.
    assert abs(documents["paper"]["descriptors"]["movement"] - (13.4 - 26.6 + 40) / 80) < 1e-12
    assert abs(documents["clean"]["descriptors"]["movement"] - (14 - 26 + 40) / 80) < 1e-12


NEST = "sel(in_nest, seq(nest_left, forward_left), seq(nest_right, forward_right), prob(forward, reverse))"


def test_a_named_primitive_evaluates_as_its_tree_written_out_under_success(tmp_path, capsys):
    library = tmp_path / "primitives.json"
    library.write_text(json.dumps({"format": 1, "primitives": [{"name": "gotoNest3", "tree": NEST}]}))
    documents = []
    for engine in ("compiled", "reference"):
        for tree, extra in (
            ("sel(seq(got_food, gotoNest3), prob(forward, gotoNest3))", ["--library", str(library)]),
            (f"sel(seq(got_food, success({NEST})), prob(forward, success({NEST})))", []),
        ):
            args = ["--tree", tree, "--seed", "4", "--trials", "2", "--engine", engine, *extra]
            assert evaluate_main(args) == 0
            documents.append(json.loads(capsys.readouterr().out))
    named = documents[0]
    assert named["tree"] == "sel(seq(got_food, gotoNest3), prob(forward, gotoNest3))"
    assert named["library"]["file"] == str(library) and len(named["library"]["digest"]) == 64
    for other in documents[1:]:
        assert (other["fitness"], other["descriptors"]) == (named["fitness"], named["descriptors"])
    assert evaluate_main(["--tree", "seq(got_food, gotoNest4)", "--library", str(library)]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "unknown node 'gotoNest4'" in error and str(library) in error
    assert evaluate_main(["--tree", "gotoNest3", "--library", str(tmp_path / "none.json")]) == 2
    assert "--library: library" in capsys.readouterr().err


MIXED = [NEST, "sel2(seq(food_left, forward_left), forward)", "stop"] * 3


def test_a_swarm_layout_evaluates_with_each_robots_tree(tmp_path, capsys):
    swarm = tmp_path / "swarm.json"
    swarm.write_text(json.dumps({"trees": MIXED}))
    documents = []
    for engine in ("compiled", "reference"):
        args = ["--swarm", str(swarm), "--seed", "6", "--trials", "2", "--engine", engine, "--per-trial"]
        assert evaluate_main(args) == 0
        documents.append(capsys.readouterr().out)
    assert documents[0] == documents[1]
    document = json.loads(documents[0])
    assert list(document)[:2] == ["trees", "seed"] and "tree" not in document
    assert document["trees"][1::3] == ["sel(seq(food_left, forward_left), forward)"] * 3  # canonical
    assert document["trees"][0] == NEST and document["trees"][2] == "stop"
    # one tree for all, either way, is the homogeneous evaluation's numbers
    swarm.write_text(json.dumps({"tree": TREE}))
    assert evaluate_main(["--swarm", str(swarm), "--seed", "6", "--trials", "2"]) == 0
    uniform = json.loads(capsys.readouterr().out)
    assert evaluate_main(["--tree", TREE, "--seed", "6", "--trials", "2"]) == 0
    alone = json.loads(capsys.readouterr().out)
    assert uniform["trees"] == [alone["tree"]] * 9
    assert (uniform["fitness"], uniform["descriptors"]) == (alone["fitness"], alone["descriptors"])
    assert (document["fitness"], document["descriptors"]) != (alone["fitness"], alone["descriptors"])


@pytest.mark.parametrize(
    ("content", "extra", "words"),
    [
        (None, ["--tree", "stop"], "argument --tree: not allowed with argument --swarm"),
        ({"trees": MIXED[:7]}, [], "expected 9 trees (one per robot), got 7"),
        ({"trees": MIXED}, ["--condition", "robots=5"], "expected 5 trees (one per robot), got 9"),
        ({"trees": [*MIXED[:6], "seq(dance)", *MIXED[7:]]}, [], "the tree of robot 6 does not parse"),
        ({"robots": MIXED}, [], 'expected {"trees": ["tree text", ...]'),
        ("not json", [], "not JSON"),
    ],
)
def test_bad_swarm_input_exits_2_with_one_line(tmp_path, capsys, content, extra, words):
    swarm = tmp_path / "swarm.json"
    text = (
        content if isinstance(content, str) else json.dumps({"trees": MIXED} if content is None else content)
    )
    swarm.write_text(text)
    assert evaluate_main(["--swarm", str(swarm), "--trials", "1", *extra]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and "Traceback" not in captured.err
    assert words in captured.err and (content is None or f"--swarm: swarm layout {swarm}: " in captured.err)


def test_tree_or_swarm_is_required(capsys):
    assert evaluate_main(["--seed", "1"]) == 2
    assert "one of the arguments --tree --network --swarm is required" in capsys.readouterr().err


NETWORK = [round(0.37 * ((k * 7) % 11) - 1.8, 2) for k in range(56)]


def test_a_network_file_evaluates_on_both_engines_and_prints_its_weights(tmp_path, capsys):
    path = tmp_path / "net.json"
    path.write_text(json.dumps({"weights": NETWORK}))
    documents = []
    for engine in ("compiled", "reference"):
        args = [
            "--network",
            str(path),
            "--seed",
            "3",
            "--trials",
            "2",
            "--task",
            "foraging",
            "--engine",
            engine,
        ]
        assert evaluate_main(args) == 0
        documents.append(capsys.readouterr().out)
    assert documents[0] == documents[1]
    document = json.loads(documents[0])
    assert document["network"] == NETWORK and "tree" not in document and document["task"] == "foraging"
    assert document["descriptors"]["conditionality"] == 0.0  # a network ticks no condition node


@pytest.mark.parametrize(
    ("content", "words"),
    [
        ({"weights": NETWORK[:55]}, "a network has 56 weights, got 55"),
        ({"weights": [*NETWORK[:55], "x"]}, "weight 56 must be a number, got 'x'"),
        ({"weights": NETWORK, "bias": 1}, 'expected an object with one key, {"weights"'),
        ("[1,", "not JSON"),
    ],
)
def test_bad_network_files_exit_2_with_one_line(tmp_path, capsys, content, words):
    path = tmp_path / "net.json"
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    assert evaluate_main(["--network", str(path), "--trials", "1"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and "Traceback" not in captured.err
    assert f"--network: {path}: " in captured.err and words in captured.err
