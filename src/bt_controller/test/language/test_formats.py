"""BehaviorTree.CPP XML export and import, DOT, the text views and rendering."""

from __future__ import annotations

from xml.etree.ElementTree import Comment, Element, SubElement, indent, tostring

import numpy as np
import pytest
from bt_strategies import trees
from hypothesis import given, settings

from bt_controller.errors import TreeLimitError, TreeSyntaxError
from bt_controller.language.formats import (
    BTCPP_CONTROL,
    PROBABILISTIC_DESCRIPTION,
    composite_label,
    from_xml,
    to_ascii,
    to_dot,
    to_xml,
)
from bt_controller.language.library import LIBRARY_FORMAT, library_from_json
from bt_controller.language.random_trees import random_tree
from bt_controller.language.tree import Composite, Node, leaf_name, parse
from bt_controller.language.vocabulary import ACTIONS, CONDITIONS
from bt_controller.tools.render import layout, render

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


def _elementtree_xml(tree: Node, tree_id: str = "MainTree") -> str:
    """The document as ElementTree's ``indent`` and ``tostring`` wrote it before ``to_xml`` wrote it line by
    line (recursive: shallow trees only); the new writer must give the same bytes for trees without keys."""
    root = Element("root", {"BTCPP_format": "4", "main_tree_to_execute": tree_id})
    stack: list[tuple[Node, Element]] = [(tree, SubElement(root, "BehaviorTree", {"ID": tree_id}))]
    while stack:
        node, parent = stack.pop()
        if isinstance(node, Composite):
            element = SubElement(parent, BTCPP_CONTROL[node.kind])
            stack.extend((child, element) for child in reversed(node.children))
        else:
            SubElement(parent, leaf_name(node))
    model = SubElement(root, "TreeNodesModel")
    model.append(Comment(f" {PROBABILISTIC_DESCRIPTION} "))
    SubElement(model, "Control", {"ID": "Probabilistic"})
    for name in CONDITIONS:
        SubElement(model, "Condition", {"ID": name})
    for name in ACTIONS:
        SubElement(model, "Action", {"ID": name})
    indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root, encoding="unicode") + "\n"


def test_xml_of_trees_without_keys_is_as_before():
    rng = np.random.default_rng(4)
    for tree in [EXAMPLE, parse("stop")] + [random_tree(rng, int(rng.integers(3, 80))) for _ in range(300)]:
        assert to_xml(tree) == _elementtree_xml(tree)
    assert to_xml(EXAMPLE, 'a "tree" & <more>\n') == _elementtree_xml(EXAMPLE, 'a "tree" & <more>\n')


def test_xml_draw_keys_are_attributes_declared_as_a_port():
    tree = parse("sel(prob@7(forward, stop), prob(stop, forward))")
    xml = to_xml(tree)
    assert '<Probabilistic draw_key="7">' in xml and "<Probabilistic>" in xml
    assert '<input_port name="draw_key" type="int">' in xml
    assert '<Control ID="Probabilistic" />' not in xml
    assert from_xml(xml) == tree
    explicit = """<root BTCPP_format="4"><BehaviorTree>
      <Control ID="Probabilistic" draw_key=" 12 ">
        <stop/><Fallback draw_key=""><stop/><stop/></Fallback>
      </Control>
    </BehaviorTree></root>"""
    assert from_xml(explicit) == parse("prob@12(stop, sel(stop, stop))")


@pytest.mark.parametrize(
    ("element", "fragment"),
    [
        ('<Sequence draw_key="3"><stop/><stop/></Sequence>', "draw_key at Sequence: only Probabilistic"),
        (
            '<Fallback><stop draw_key="3"/><stop/></Fallback>',
            "draw_key at Fallback/stop[0]: only Probabilistic",
        ),
        (
            '<Probabilistic draw_key="-1"><stop/><stop/></Probabilistic>',
            "draw_key='-1' at Probabilistic: expected",
        ),
        (
            '<Probabilistic draw_key="2147483648"><stop/><stop/></Probabilistic>',
            "expected an integer in [0, 2147",
        ),
        ('<Probabilistic draw_key="１"><stop/><stop/></Probabilistic>', "expected an integer"),
        ('<Probabilistic draw_key="7.0"><stop/><stop/></Probabilistic>', "draw_key='7.0'"),
    ],
)
def test_xml_bad_draw_keys_are_refused(element, fragment):
    with pytest.raises(TreeSyntaxError) as info:
        from_xml(f"<root><BehaviorTree>{element}</BehaviorTree></root>")
    assert fragment in str(info.value)


def test_drawings_show_draw_keys():
    tree = parse("sel(prob@7(forward, stop), prob(stop, forward))")
    dot = to_dot(tree)
    assert 'label="prob % @7"' in dot and 'label="prob %"' in dot
    assert to_ascii(tree).splitlines()[1] == "├── prob@7"
    assert composite_label(tree.children[0]) == "prob % @7"  # render draws this label too


def test_every_format_takes_a_tree_of_any_depth(tmp_path):
    # Issue 25, item 6: XML export used ElementTree's recursive serialiser; the layout recursed.
    text = "forward"
    for i in range(10_000):
        text = f"seq(in_nest, {text})" if i % 2 else f"prob@{i}(on_food, {text})"
    tree = parse(text, max_depth=100_000, max_nodes=100_000)
    # The XML is indented, 2 spaces a level: 1,500 levels (past Python's recursion limit) keep the document
    # within MAX_XML_CHARS for the round trip.
    part = tree
    while part.depth > 1_500:
        part = part.children[1]
    assert from_xml(to_xml(part), max_depth=100_000, max_nodes=100_000) == part
    closing_tags = sum(isinstance(node, Composite) for node in tree.preorder())
    # and the lines around the tree: 7 of the document, 1 comment, 3 for Probabilistic with its port, and
    # one per condition and action in the model.
    around = 11 + len(CONDITIONS) + len(ACTIONS)
    assert to_xml(tree).count("\n") == tree.size + closing_tags + around
    assert to_dot(tree).count(" -> ") == tree.size - 1
    placed = layout(tree)
    assert len(placed) == tree.size and placed[-1][2] == 10_000
    assert placed[0][1] == (placed[1][1] + placed[2][1]) / 2
    assert to_ascii(tree).count("\n") == tree.size
    with pytest.raises(TreeLimitError, match="a PNG drawing takes at most 404 leaves and depth 605"):
        render(tree, tmp_path / "deep.png")


def test_success_is_btcpp_force_success_both_ways():
    tree = parse("sel(seq(got_food, success(seq(nest_left, forward_left))), success(forward))")
    xml = to_xml(tree)
    assert xml.count("<ForceSuccess>") == 2 and '<Condition ID="got_food" />' in xml
    assert from_xml(xml) == tree
    explicit = """<root BTCPP_format="4"><BehaviorTree ID="T">
      <Decorator ID="ForceSuccess"><Condition ID="got_food"/></Decorator>
    </BehaviorTree></root>"""
    assert from_xml(explicit) == parse("success(got_food)")
    two = '<root BTCPP_format="4"><BehaviorTree><ForceSuccess><stop/><stop/></ForceSuccess></BehaviorTree>'
    two += "</root>"
    with pytest.raises(TreeSyntaxError, match="ForceSuccess takes exactly one"):
        from_xml(two)
    assert "success ✓" in to_dot(tree) and to_ascii(tree).splitlines()[3] == "│   └── success"


def test_a_drawing_shows_each_copy_of_a_primitive_as_one_box_named_even_when_moved(tmp_path):
    library = library_from_json(
        {"format": LIBRARY_FORMAT, "primitives": [{"name": "wander1", "tree": "prob(forward, stop)"}]}, "lib"
    )
    # the second copy was moved by the simplifier: its prob keeps its draws with a key
    tree = parse("sel(on_food, wander1, success(prob@9(forward, stop)))", library=library)
    placed = layout(tree, library.shown_name_of)
    assert [leaf_name(n) if not isinstance(n, Composite) else n.kind for n, *_ in placed] == [
        "sel",
        "on_food",
        "success",
        "success",
    ]
    assert [library.shown_name_of(n) for n, *_ in placed[2:]] == ["wander1", "wander1"]
    assert library.name_of(placed[3][0]) is None  # the text keeps the keyed copy whole (it folds exactly)
    svg = render(tree, tmp_path / "named.svg", name_of=library.shown_name_of).read_text()
    plain = render(tree, tmp_path / "plain.svg").read_bytes()
    assert len(svg.encode()) < len(plain)  # fewer boxes drawn


def test_drawings_are_the_same_bytes_every_time(tmp_path):
    for fmt in ("svg", "png"):
        first = render(EXAMPLE, tmp_path / f"a.{fmt}").read_bytes()
        assert render(EXAMPLE, tmp_path / f"b.{fmt}").read_bytes() == first


def _bushy(depth: int, leaf: str) -> str:
    """A tree of ``sel`` with four children at every level, ``4 ** depth`` leaves."""
    return leaf if depth == 0 else f"sel({', '.join([_bushy(depth - 1, leaf)] * 4)})"


def test_the_vertical_drawing_grows_down_with_the_nodes_and_across_only_with_the_depth(tmp_path):
    """An outline, a row per node: a tree with many leaves stays narrow enough for a page."""
    from PIL import Image

    wide = parse(_bushy(3, "forward_left"))  # 64 leaves, 85 nodes
    width, height = Image.open(render(wide, tmp_path / "wide.png", vertical=True)).size
    top_down = Image.open(render(wide, tmp_path / "top_down.png")).size
    assert width < 400 and top_down[0] > 8000 and height > 85 * 0.3 * 120 * 0.95  # a row per node
    deeper = Image.open(render(parse(_bushy(2, "forward_left")), tmp_path / "deep.png", vertical=True))
    shallow = Image.open(render(parse(_bushy(1, "forward_left")), tmp_path / "shallow.png", vertical=True))
    assert deeper.size[0] > shallow.size[0]
    library = library_from_json(
        {"format": LIBRARY_FORMAT, "primitives": [{"name": "wander1", "tree": "prob(forward, stop)"}]}, "lib"
    )
    named = parse("sel(on_food, wander1)", library=library)
    svg = render(named, tmp_path / "named.svg", name_of=library.shown_name_of, vertical=True).read_text()
    assert "wander1" in svg and "forward" not in svg  # the primitive as one named box
    first = render(EXAMPLE, tmp_path / "a.svg", vertical=True).read_bytes()
    assert render(EXAMPLE, tmp_path / "b.svg", vertical=True).read_bytes() == first
    with pytest.raises(TreeLimitError, match="a vertical PNG drawing takes at most 1820"):
        render(parse(_bushy(6, "stop"), max_nodes=10_000), tmp_path / "many.png", vertical=True)  # 5461 nodes
