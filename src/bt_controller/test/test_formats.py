"""BehaviorTree.CPP XML export and import, DOT, the text views and rendering."""

from __future__ import annotations

import pytest
from bt_strategies import trees
from hypothesis import given, settings

from bt_controller.errors import TreeLimitError, TreeSyntaxError
from bt_controller.formats import from_xml, to_ascii, to_dot, to_xml
from bt_controller.render import layout, render
from bt_controller.tree import parse
from bt_controller.vocabulary import ACTIONS, CONDITIONS

EXAMPLE = parse("sel(seq(in_nest, stop), prob(forward, reverse, seq(on_food, robot_left)))")


@settings(max_examples=300, derandomize=True, deadline=None)
@given(tree=trees)
def test_xml_round_trip(tree):
    assert from_xml(to_xml(tree)) == tree


def test_xml_uses_btcpp_v4_controls_and_declares_our_nodes():
    xml = to_xml(EXAMPLE)
    assert '<root BTCPP_format="4" main_tree_to_execute="MainTree">' in xml
    assert "<Fallback>" in xml and "<Sequence>" in xml and "<Probabilistic>" in xml
    model = xml[xml.index("<TreeNodesModel>") :]
    assert '<Control ID="Probabilistic" />' in model
    for name in CONDITIONS:
        assert f'<Condition ID="{name}" />' in model
    for name in ACTIONS:
        assert f'<Action ID="{name}" />' in model


def test_xml_import_accepts_explicit_ids_comments_and_the_named_main_tree():
    xml = """<?xml version="1.0"?>
    <root BTCPP_format="4" main_tree_to_execute="Second">
      <BehaviorTree ID="First"><stop/></BehaviorTree>
      <BehaviorTree ID="Second">
        <!-- a comment -->
        <Control ID="Probabilistic">
          <Condition ID="on_food"/>
          <Action ID="reverse_left" name="back off"/>
        </Control>
      </BehaviorTree>
    </root>"""
    assert from_xml(xml) == parse("prob(on_food, reverse_left)")


@pytest.mark.parametrize(
    ("xml", "fragment"),
    [
        ("<root><BehaviorTree><Sequence><stop/></Sequence></BehaviorTree></root>", "1 children"),
        ("<root><BehaviorTree><Jump/></BehaviorTree></root>", "unknown element <Jump>"),
        ("<root><BehaviorTree><stop><stop/></stop></BehaviorTree></root>", "leaf"),
        ("<root><BehaviorTree><stop/><stop/></BehaviorTree></root>", "one root node"),
        ("<root/>", "<BehaviorTree>"),
        ("<tree/>", "<root>"),
        ('<root BTCPP_format="3"><BehaviorTree><stop/></BehaviorTree></root>', "BTCPP_format"),
        ('<root main_tree_to_execute="X"><BehaviorTree ID="Y"><stop/></BehaviorTree></root>', "names no"),
        ("<root><BehaviorTree><Sequence><stop/>", "malformed XML"),
        ('<!DOCTYPE r [<!ENTITY e "x">]><root>&e;</root>', "refused XML"),
    ],
)
def test_xml_errors_are_tree_syntax_errors(xml, fragment):
    with pytest.raises(TreeSyntaxError, match=fragment.replace("(", r"\(")):
        from_xml(xml)


def test_malformed_xml_says_line_and_column():
    with pytest.raises(TreeSyntaxError) as info:
        from_xml("<root>\n  <BehaviorTree>\n  </root>")
    assert info.value.line == 3 and info.value.column is not None


def test_xml_limits():
    deep = "stop"
    for _ in range(20):
        deep = f"seq(on_food, {deep})"
    xml = to_xml(parse(deep, max_depth=20))
    with pytest.raises(TreeLimitError):
        from_xml(xml)
    assert from_xml(xml, max_depth=20) == parse(deep, max_depth=20)
    with pytest.raises(TreeLimitError):
        from_xml(to_xml(EXAMPLE), max_nodes=5)


def test_dot_lists_every_node_and_edge_in_order():
    dot = to_dot(EXAMPLE)
    assert dot.startswith("digraph behaviour_tree {") and dot.rstrip().endswith("}")
    assert dot.count(" -> ") == EXAMPLE.size - 1
    assert 'n2 [shape=ellipse, label="in_nest?"]' in dot
    assert "n0 -> n1;" in dot and "n0 -> n4;" in dot and "n7 -> n9;" in dot


def test_ascii_view():
    assert to_ascii(parse("sel(seq(in_nest, stop), forward)")) == (
        "sel\n├── seq\n│   ├── in_nest?\n│   └── stop\n└── forward\n"
    )
    assert to_ascii(parse("stop")) == "stop\n"


def test_layout_centres_parents_over_children():
    placed = layout(parse("seq(stop, sel(on_food, forward, reverse))"))
    xs = {i: x for i, (_, x, _, _) in enumerate(placed)}
    assert xs[0] == (xs[1] + xs[2]) / 2 and xs[2] == xs[4]


@pytest.mark.parametrize("fmt", ["svg", "png"])
def test_render(tmp_path, fmt):
    path = render(EXAMPLE, tmp_path / f"tree.{fmt}")
    data = path.read_bytes()
    assert data.startswith(b"\x89PNG") if fmt == "png" else b"<svg" in data[:2000]
    with pytest.raises(ValueError):
        render(EXAMPLE, tmp_path / "tree.pdf")
