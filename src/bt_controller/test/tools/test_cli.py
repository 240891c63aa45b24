"""The ``bt`` console script: outputs, and one line with exit status 2 for bad input."""

from __future__ import annotations

import pytest

from bt_controller.language.formats import XML_INDENT_LEVELS, from_xml
from bt_controller.language.tree import parse
from bt_controller.tools.cli import main

TREE = "sel3(seq(in_nest,stop), forward, reverse)"


def test_check(capsys):
    assert main(["check", TREE]) == 0
    assert capsys.readouterr().out == "ok: 6 nodes, depth 2: sel(seq(in_nest, stop), forward, reverse)\n"


def test_show_formats(capsys):
    assert main(["show", TREE]) == 0
    assert capsys.readouterr().out.startswith("sel\n├── seq\n")
    assert main(["show", TREE, "--format", "tree"]) == 0
    assert capsys.readouterr().out == "sel(seq(in_nest, stop), forward, reverse)\n"
    assert main(["show", TREE, "-f", "xml"]) == 0
    assert from_xml(capsys.readouterr().out) == parse(TREE)
    assert main(["show", TREE, "-f", "dot"]) == 0
    assert capsys.readouterr().out.startswith("digraph")


def test_export_by_suffix_and_read_back(tmp_path, capsys):
    for suffix in ("xml", "dot", "svg", "png", "txt"):
        out = tmp_path / f"tree.{suffix}"
        assert main(["export", TREE, "--output", str(out)]) == 0
        assert out.stat().st_size > 0
    assert main(["check", str(tmp_path / "tree.xml")]) == 0
    assert main(["check", str(tmp_path / "tree.txt")]) == 0
    assert capsys.readouterr().out.count("ok: 6 nodes") == 2


@pytest.mark.parametrize("fmt", ["xml", "png"])
def test_an_existing_output_is_refused_unless_forced_and_a_link_always(tmp_path, capsys, fmt):
    out = tmp_path / f"tree.{fmt}"
    out.write_text("mine")
    assert main(["export", TREE, "--output", str(out)]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "already exists: add --force" in error, error
    assert out.read_text() == "mine"
    assert main(["export", TREE, "--output", str(out), "--force"]) == 0
    assert out.read_bytes() != b"mine"
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    link = tmp_path / f"link.{fmt}"
    link.symlink_to(precious)
    dangling = tmp_path / f"dangling.{fmt}"
    dangling.symlink_to(tmp_path / "nowhere")
    for path in (link, dangling):
        for command in (["export", TREE], ["show", TREE, "--format", fmt]):
            assert main([*command, "--output", str(path), "--force"]) == 2
            error = capsys.readouterr().err
            assert error.count("\n") == 1 and "is a symbolic link" in error, error
    assert precious.read_text() == "keep me\n" and not (tmp_path / "nowhere").exists()
    assert main(["export", TREE, "--output", str(tmp_path), "--force"]) == 2
    assert "is a folder" in capsys.readouterr().err


def test_stdin(monkeypatch, capsys):
    monkeypatch.setattr("sys.stdin", __import__("io").StringIO("seq(\n on_food,\n stop)\n"))
    assert main(["check", "-"]) == 0
    assert "seq(on_food, stop)" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["check", "seq(stop, fly)"], "line 1, column 11: unknown node 'fly'"),
        (["check", "seq(stop"], "expected ',' or ')'"),
        (["check", "nosuch/file.xml"], "no such file"),
        (["check", "seq(" * 30 + "stop" + ", stop)" * 30], "max_depth=17"),
        (["check", "seq(stop, stop)", "--max-nodes", "2"], "max_nodes=2"),
        (["show", "stop", "--format", "png"], "give --output"),
        (["show", "stop", "--format", "pdf"], "invalid choice"),
        (["frobnicate", "stop"], "invalid choice"),
        ([], "required"),
        (["export", "stop"], "required"),
        (["export", "stop", "-o", "/nonexistent-dir/x.xml"], "No such file"),
        (["check", "<root><BehaviorTree>"], "malformed XML"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, fragment, capsys):
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and captured.err.startswith("bt: error: ")
    assert fragment in captured.err


def test_binary_file_is_a_clear_error(tmp_path, capsys):
    path = tmp_path / "tree.bin"
    path.write_bytes(b"\xff\xfe\x00seq")
    assert main(["check", str(path)]) == 2
    assert "UTF-8" in capsys.readouterr().err


def _deep(levels: int, composite: str, condition: str) -> str:
    text = "forward"
    for i in range(levels):
        text = f"seq({composite}, {text})" if i % 2 else f"sel({condition}, {text})"
    return text


def test_deep_trees(tmp_path, capsys):
    """Issue 25, item 6: with --max-depth 100000, `bt simplify` and `bt show --format xml` of a 10,000-level
    tree raised RecursionError. Every format now takes it; simplify takes up to 2,000 nodes at any depth and
    refuses more in one line."""
    limits = ["--max-depth", "100000", "--max-nodes", "100000"]
    path = tmp_path / "deep.txt"
    path.write_text(_deep(10_000, "in_nest", "on_food"))
    assert main(["show", str(path), "-f", "xml", *limits]) == 0
    xml = capsys.readouterr().out
    assert xml.count("<Sequence>") == 5_000 and xml.count("<Fallback>") == 5_000
    # Issue 41, item 18: the document grows with the tree's size, not size x depth (two spaces a level made
    # 300 MB of 10,000 levels); indentation stops at XML_INDENT_LEVELS, and the document reads back.
    indents = [len(line) - len(line.lstrip(" ")) for line in xml.splitlines()]
    assert max(indents) == 2 * XML_INDENT_LEVELS and len(xml) < 10_000_000
    assert from_xml(xml, max_depth=100_000, max_nodes=100_000) == parse(
        path.read_text(), max_depth=100_000, max_nodes=100_000
    )
    assert main(["simplify", str(path), *limits]) == 2
    assert (
        capsys.readouterr().err == f"bt: error: {path}: tree has 20001 nodes; simplify takes at most 2000\n"
    )
    # 900 levels: past the recursion the simplifier had (RecursionError), and nothing to simplify.
    irreducible = _deep(900, "forward", "on_food")
    assert main(["simplify", irreducible, *limits]) == 0
    assert capsys.readouterr().out == irreducible + "\n"
    # ... and one that collapses: after in_nest, on_food is false and in_nest true at every level.
    assert main(["simplify", _deep(300, "in_nest", "on_food"), *limits]) == 0
    assert capsys.readouterr().out == "seq(in_nest, forward)\n"
    assert main(["export", str(path), "-o", str(tmp_path / "deep.png"), *limits]) == 2
    assert "a PNG drawing takes at most 404 leaves" in capsys.readouterr().err
