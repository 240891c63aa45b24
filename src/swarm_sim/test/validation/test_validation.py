"""Validation report: statistics, the tolerance rule, reading reference TSVs and the validate command."""

import math

import pytest

from swarm_sim.validation import AGREES, INDISTINGUISHABLE, OUTSIDE, Comparison, Estimate
from swarm_sim.validation import reference as validation
from swarm_sim.validation.cli import main as validate_main

SIX = ("density", "nest", "food", "movement", "rotation", "conditionality")
"""The quantities of the 2023 reference files (the paper's three objectives and the descriptors)."""
HEADER = "tree\t" + "\t".join(f"{q}_mean\t{q}_sem" for q in SIX) + "\tn_seeds\n"


def _row(tree, values):
    return tree + "\t" + "\t".join(f"{v}" for pair in values for v in pair) + "\t20\n"


def test_estimate_is_mean_and_sample_standard_error():
    e = validation.estimate([1.0, 2.0, 3.0, 4.0])
    assert e.mean == 2.5
    assert e.sem == pytest.approx(math.sqrt((1.5**2 + 0.5**2) * 2 / 3) / 2)  # sd (ddof 1) / sqrt(4)
    assert e.n == 4
    with pytest.raises(ValueError, match="at least 2"):
        validation.estimate([1.0])


def test_tolerance_and_verdicts_worked_by_hand():
    theirs = Estimate(0.5, 0.01, 20)  # tolerance 3 sqrt(2) 0.01 + 0.03 = 0.0724
    near = Comparison("t", "nest", Estimate(0.56, 0.01, 20), theirs)  # diff 0.06, z 0.06 / 0.01414 = 4.24
    assert near.tolerance == pytest.approx(0.0724264, abs=1e-6)
    assert near.agrees and near.z == pytest.approx(4.2426, abs=1e-4) and near.verdict == AGREES
    close = Comparison("t", "nest", Estimate(0.55, 0.01, 20), theirs)  # z 3.54
    assert close.verdict == INDISTINGUISHABLE
    far = Comparison("t", "nest", Estimate(0.58, 0.05, 20), theirs)  # diff 0.08 > 0.0724, z 1.57
    assert abs(far.z) < 4 and far.verdict == OUTSIDE
    exact = Comparison("t", "movement", Estimate(1.0, 0.0, 20), Estimate(1.0, 0.0, 20))
    assert exact.z == 0.0 and exact.verdict == INDISTINGUISHABLE
    rounded = Comparison("t", "movement", Estimate(0.1675 + 1e-12, 0.0, 20), Estimate(0.1675, 0.0, 20))
    assert rounded.diff != 0.0 and rounded.z == 0.0 and rounded.verdict == INDISTINGUISHABLE
    off = Comparison("t", "movement", Estimate(0.99, 0.0, 20), Estimate(1.0, 0.0, 20))
    assert off.z == -math.inf and off.verdict == AGREES  # within 0.03, but both exact and different


def test_reference_descriptors_are_mapped_from_raw_units(tmp_path):
    values = [(0.5, 0.001), (0.6, 0.01), (0.4, 0.02), (20.0, 0.8), (-40.0, 0.0), (0.25, 0.005)]
    path = tmp_path / "ref.tsv"
    path.write_text(HEADER + _row("seq(forward, reverse)", values))
    ref = validation.read_reference(path)["seq(forward, reverse)"]
    assert ref["movement"] == Estimate(0.75, 0.01, 20)  # (20 + 40) / 80, 0.8 / 80
    assert ref["rotation"] == Estimate(0.0, 0.0, 20)
    assert ref["nest"] == Estimate(0.6, 0.01, 20)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("tree\tdensity_mean\n", "missing column"),
        (HEADER, "no trees"),
        (HEADER + _row("stop", [(0.5, 0.1)] * 6) + _row("stop", [(0.5, 0.1)] * 6), "given twice"),
        (HEADER + _row("stop", [(0.5, 0.1)] * 5 + [("x", 0.1)]), "must be a number"),
        (HEADER + _row("stop", [(0.5, -0.1)] * 6), "standard error must be >= 0"),
    ],
)
def test_bad_reference_files_are_refused_naming_the_problem(tmp_path, text, message):
    path = tmp_path / "ref.tsv"
    path.write_text(text)
    with pytest.raises(validation.ReferenceFileError, match=message):
        validation.read_reference(path)


def test_report_counts_and_lists_what_is_not_indistinguishable():
    theirs = {q: Estimate(0.5, 0.01, 20) for q in SIX}
    ours = dict(theirs, food=Estimate(0.7, 0.01, 20))
    text = validation.render(validation.compare("forward", ours, theirs), ["# title"], "## Notes\nwhy")
    assert "**5 of 6** quantities over 1 trees agree" in text
    assert "- `forward` food: OUTSIDE, diff +0.2000" in text
    assert text.rstrip().endswith("## Notes\nwhy")


def test_a_network_is_shown_by_its_first_weights_and_its_last():
    weights = " ".join(f"{0.01 * k:.2f}" for k in range(56))
    theirs = {q: Estimate(0.5, 0.01, 20) for q in SIX}
    comparisons = validation.compare(f"nn: {weights}", theirs, theirs, group="foraging")
    text = validation.render(comparisons, ["# title"])
    assert "| 1 | [foraging] `nn: 0.00 0.01 0.02 … 0.55` |" in text
    assert "### 1. [foraging] `nn: 0.00 0.01 0.02 … 0.55`" in text
    assert weights not in text


def test_validate_command_writes_the_report_and_our_statistics(tmp_path, capsys):
    # stop: movement and rotation exactly 0.5 (raw 0) and conditionality 0 in every model; the rest is
    # whatever the model gives
    values = [(0.5, 0.01), (0.5, 0.01), (0.5, 0.01), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0)]
    ref = tmp_path / "ref.tsv"
    ref.write_text(HEADER + _row("stop", values) + _row("seq(forward_left, forward_left)", values))
    out, tsv = tmp_path / "validation.md", tmp_path / "ours.tsv"
    args = ["--reference", str(ref), "--seeds", "3", "--trials", "2", "--out", str(out), "--tsv", str(tsv)]
    assert validate_main(args) == 0
    report = out.read_text()
    assert (
        "| movement | 0.5000 ± 0.0000 | 0.5000 ± 0.0000 | +0.0000 | 0.0300 | +0.0 | indistinguishable |"
        in report
    )
    assert "### 2. `seq(forward_left, forward_left)`" in report
    ours = validation.read_reference(tsv)
    assert ours["stop"]["movement"] == ours["stop"]["rotation"] == Estimate(0.5, 0.0, 3)
    assert ours["stop"]["conditionality"] == Estimate(0.0, 0.0, 3)  # an action only: no condition ticks
    capsys.readouterr()
    assert validate_main(args) == 2  # it exists: refused, as it was
    err = capsys.readouterr().err.strip()
    expected = f"--out {out} already exists: add --force to overwrite it, or name a new file"
    assert err == f"validate: error: {expected}"
    assert out.read_text() == report
    assert validate_main([*args, "--force"]) == 0 and out.read_text() == report  # seeded: the same report


def test_validate_command_refuses_bad_input_in_one_line_and_writes_nothing(tmp_path, capsys):
    ref = tmp_path / "ref.tsv"
    ref.write_text(HEADER + _row("seq(forward, flying)", [(0.5, 0.1)] * 6))
    out = tmp_path / "validation.md"
    assert validate_main(["--reference", str(ref), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("validate: error:") and "flying" in err and "\n" not in err
    assert not out.exists()
    assert validate_main(["--reference", str(tmp_path / "none.tsv"), "--out", str(out)]) == 2
    assert "cannot read" in capsys.readouterr().err
    assert validate_main(["--reference", str(ref), "--seeds", "1", "--out", str(out)]) == 2


def test_validate_refuses_a_link_as_its_report_before_evaluating(tmp_path, capsys):
    """A report regenerated in place (docs/validation.md in a clone, which stores links) is never written
    through a planted link."""
    ref = tmp_path / "ref.tsv"
    ref.write_text(HEADER + _row("stop", [(0.5, 0.01)] * 3 + [(0.0, 0.0)] * 3))
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    for option in ("--out", "--tsv"):
        link = tmp_path / f"link{option}"
        link.symlink_to(precious)
        other = tmp_path / "other.md"
        args = ["--reference", str(ref), "--seeds", "2", "--trials", "1", "--out", str(other)]
        args += [option, str(link)]
        assert validate_main(args) == 2
        err = capsys.readouterr().err.strip()
        assert f"validate: error: {option} {link} is a symbolic link" in err and "\n" not in err, err
        assert not other.exists()
    assert precious.read_text() == "keep me\n"


def _reference(tmp_path):
    ref = tmp_path / "ref.tsv"
    ref.write_text(HEADER + _row("stop", [(0.5, 0.01)] * 3 + [(0.0, 0.0)] * 3))
    return ref


@pytest.mark.parametrize("option", ["--out", "--tsv"])
def test_validate_refuses_an_output_that_exists_unless_forced_before_evaluating(tmp_path, capsys, option):
    """The workspace's rule for outputs (README, docs/security.md): never overwrite without --force."""
    out, tsv = tmp_path / "validation.md", tmp_path / "ours.tsv"
    args = ["--reference", str(_reference(tmp_path)), "--seeds", "2", "--trials", "1"]
    args += ["--out", str(out), "--tsv", str(tsv)]
    {"--out": out, "--tsv": tsv}[option].write_text("mine\n")
    assert validate_main(args) == 2
    err = capsys.readouterr().err  # one line: nothing evaluated (that says "validate: 1 trees x ...")
    assert err.count("\n") == 1 and f"{option} " in err and "already exists: add --force" in err, err
    assert {"--out": out, "--tsv": tsv}[option].read_text() == "mine\n"
    assert not {"--out": tsv, "--tsv": out}[option].exists()  # nothing written
    assert validate_main([*args, "--force"]) == 0
    report = out.read_text()
    assert "--force" not in report and "--out" in report  # the maker's command: the same report either way
    assert tsv.read_text().startswith("tree\t")


@pytest.mark.parametrize("place", ["folder", "under a file"])
def test_validate_refuses_a_folder_or_a_place_under_a_file_even_with_force(tmp_path, capsys, place):
    (tmp_path / "place").mkdir() if place == "folder" else (tmp_path / "place").write_text("mine\n")
    out = tmp_path / "place" if place == "folder" else tmp_path / "place" / "validation.md"
    args = ["--reference", str(_reference(tmp_path)), "--seeds", "2", "--out", str(out), "--force"]
    assert validate_main(args) == 2
    err = capsys.readouterr().err
    expected = "is a folder" if place == "folder" else "place is a file, not a folder"
    assert err.count("\n") == 1 and expected in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["place", "ref.tsv"]


def test_foraging_references_run_100_s_trials_with_the_library_and_the_authors_syntax(tmp_path, capsys):
    # A foraging reference file: only the quantities it measured (foraging and the descriptors, raw in
    # [-200, 200] for 200 ticks); a tree naming a primitive of --library and one in the authors' syntax.
    import json

    library = tmp_path / "primitives.json"
    library.write_text(json.dumps({"format": 1, "primitives": [{"name": "ahead", "tree": "forward"}]}))
    columns = ("foraging", "movement", "rotation", "conditionality")
    header = "tree\t" + "\t".join(f"{q}_mean\t{q}_sem" for q in columns) + "\tn_seeds\n"
    # forward: movement +200 raw (1.0), rotation 0 (0.5); seqm2(f, f) is the same in their syntax
    values = "0.04\t0.01\t200.0\t0.0\t0.0\t0.0\t0.0\t0.0\t20\n"
    ref = tmp_path / "foraging.tsv"
    ref.write_text(header + "sel(seq(got_food, ahead), ahead)\t" + values + "seqm2(f, f)\t" + values)
    primitives = tmp_path / "ref.tsv"
    primitives.write_text(HEADER + _row("stop", [(0.5, 0.01)] * 3 + [(0.0, 0.0)] * 3))
    out, tsv = tmp_path / "validation.md", tmp_path / "ours.tsv"
    args = ["--reference", str(primitives), "--foraging-reference", str(ref), "--library", str(library)]
    args += ["--seeds", "2", "--trials", "2", "--out", str(out), "--tsv", str(tsv)]
    assert validate_main(args) == 0, capsys.readouterr().err
    report = out.read_text()
    assert "| 2 | [foraging] `sel(seq(got_food, ahead), ahead)` | - | - | - | " in report  # no 2023 objective
    assert "### 3. [foraging] `seqm2(f, f)`" in report
    assert (
        "| movement | 1.0000 ± 0.0000 | 1.0000 ± 0.0000 | +0.0000 | 0.0300 | +0.0 | indistinguishable |"
        in report
    )
    ours = validation.read_reference(tsv, ticks=200)
    assert ours["[foraging] seqm2(f, f)"]["movement"] == Estimate(1.0, 0.0, 2)
    assert 0.0 <= ours["[foraging] sel(seq(got_food, ahead), ahead)"]["foraging"].mean < 1.0
    # a primitive the library lacks: one line naming the library, nothing written
    out.unlink()
    capsys.readouterr()
    ref.write_text(header + "sel(seq(got_food, behind), ahead)\t" + values)
    assert validate_main([*args, "--force"]) == 2  # ours.tsv is there
    err = capsys.readouterr().err.strip()
    assert "behind" in err and str(library) in err and "\n" not in err and not out.exists()


@pytest.mark.parametrize("option", ["--reference", "--notes"])
def test_a_file_that_is_not_utf8_is_one_line(tmp_path, capsys, option):
    """It was a UnicodeDecodeError traceback (found by ws/probe-hostile)."""
    bad = tmp_path / "bad"
    bad.write_bytes(b"tree\tdensity_mean\n\xff\xfe\t0.5\n")
    args = ["--reference", str(bad if option == "--reference" else _reference(tmp_path)), "--seeds", "2"]
    args += ["--notes", str(bad)] if option == "--notes" else []
    assert validate_main([*args, "--out", str(tmp_path / "v.md")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not UTF-8 text" in err and str(bad) in err, err
    assert not (tmp_path / "v.md").exists()


def test_a_report_whose_name_is_not_utf8_is_written(tmp_path, monkeypatch):
    """The report quotes its command line: writing the name's surrogates was a UnicodeEncodeError."""
    import io
    import sys

    # standard error as Python opens it: what cannot be encoded is written with backslashes
    monkeypatch.setattr(sys, "stderr", io.TextIOWrapper(io.BytesIO(), "utf-8", errors="backslashreplace"))
    out = tmp_path / "v-\udcff\udcfe.md"
    assert validate_main(["--reference", str(_reference(tmp_path)), "--seeds", "2", "--out", str(out)]) == 0
    assert "v-\\xff\\xfe.md" in out.read_text()


MULTIFOOD = ("foraging", "food1", "food2", "food3", "fitness")
"""The quantities of the harness's multi-food statistics (its 2026 build)."""


def _multifood_reference(tmp_path, setting):
    header = "tree\tsetting\t" + "\t".join(f"{q}_mean\t{q}_sem" for q in MULTIFOOD) + "\tn_seeds\n"
    values = "\t".join("0.1\t0.05" for _ in MULTIFOOD) + "\t20\n"
    ref = tmp_path / "multifood.tsv"
    # even robots ahead, odd ones forward only when carrying kind 2, in the authors' syntax
    swarm = "swarm: " + " ; ".join(("seqm2(ifGotFood2, f)" if k % 2 else "forward") for k in range(9))
    tree = "sel(seq(got_food2, forward), reverse)"
    ref.write_text(f"{header}{tree}\t{setting}\t{values}{swarm}\t{setting}\t{values}")
    return ref


def test_multifood_references_run_their_settings_task_trees_and_swarms(tmp_path, capsys):
    # Arena 9 with kind 2 preferred (their bias 1) and a penalty of 0.5, in 5 s trials to be quick.
    setting = "project=heterogeneous_genetic_algorithm;arena=9;formation=random;trial_s=5;iterations=5;"
    ref = _multifood_reference(tmp_path, setting + "robots=9;bias=1;penalty=0.5")
    out, tsv = tmp_path / "validation.md", tmp_path / "ours.tsv"
    args = ["--multifood-reference", str(ref), "--seeds", "2", "--trials", "10", "--out", str(out)]
    assert validate_main(["--reference", str(_reference(tmp_path)), *args, "--tsv", str(tsv)]) == 0
    report = out.read_text()
    assert "### 2. [multifood-arena9-kind2] `sel(seq(got_food2, forward), reverse)`" in report
    assert "[multifood-arena9-kind2] `swarm: forward ; seqm2(ifGotFood2, f) ; forward" in report
    for ours in ("foraging1", "foraging2", "foraging3", "foraging_biased"):
        assert f"| {ours} | " in report
    rows = validation.read_reference(tsv, ticks=10)
    assert rows["[multifood-arena9-kind2] sel(seq(got_food2, forward), reverse)"]["foraging"].n == 2
    # A setting this project cannot read is one line naming the file and the item, and nothing is written.
    out.unlink()
    capsys.readouterr()
    _multifood_reference(tmp_path, setting + "robots=9;bias=1;velocity=7")
    assert validate_main(["--reference", str(_reference(tmp_path)), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert "velocity=7" in err and str(ref) in err and "\n" not in err and not out.exists()


def test_a_multifood_setting_is_the_registered_task_of_its_arena():
    from swarm_sim.tasks import task_named
    from swarm_sim.validation.cli import multifood_task

    base = "project=straight_to_foraging;formation=random;trial_s=100;iterations=5;robots=9"
    assert multifood_task(base + ";arena=6") == task_named("multifood-arena6")
    assert multifood_task(base + ";arena=9;bias=1;penalty=0.5") == task_named("multifood-arena9-kind2")
    assert multifood_task(base + ";arena=1;build=multifood-a73start") == task_named("foraging-2026")
    with pytest.raises(ValueError, match="project must be one of"):
        multifood_task("project=objectives_cast_to_grid;arena=6")
