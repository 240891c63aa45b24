"""Fuzzing the parser and the XML importer: any input gives a tree or a documented TreeError.

How quickly is a benchmark, not a test: ``ws/run bt_controller bench --parser`` times the pathological inputs.
"""

from __future__ import annotations

from bt_strategies import trees
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bt_controller.bench.tick_bench import PATHOLOGICAL
from bt_controller.errors import TreeError, TreeLimitError, TreeSyntaxError
from bt_controller.language.formats import from_xml, to_xml
from bt_controller.language.tree import Node, parse, to_indented, to_text

FUZZ = settings(
    max_examples=400, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
TOKENS = [
    "seq",
    "sel",
    "prob",
    "seq3",
    "sel9",
    "on_food",
    "stop",
    "forward",
    "(",
    ")",
    ",",
    " ",
    "\n",
    "x",
    "\t",
]
XML_PIECES = ["<", ">", "/", "<root>", "</root>", "<BehaviorTree>", "</BehaviorTree>", "<Sequence>",
              "</Sequence>", "<stop/>", '"', "=", "&", "&amp;", "<!--", "-->", "<!DOCTYPE x>", "\x00",
              '<?xml version="1.0" encoding="UTF-8"?>', "<Control ID='Probabilistic'>"]  # fmt: skip


def _either_tree_or_documented_error(function, text: str) -> None:
    try:
        result = function(text)
    except (TreeSyntaxError, TreeLimitError) as error:
        assert isinstance(error, TreeError) and isinstance(error, ValueError)
        assert "\n" not in str(error)
    else:
        assert isinstance(result, Node)
        assert parse(to_text(result)) == result


def _mutate(data: st.DataObject, text: str, pieces: list[str]) -> str:
    for _ in range(data.draw(st.integers(1, 4))):
        position = data.draw(st.integers(0, len(text)))
        action = data.draw(st.sampled_from(["insert", "delete", "replace", "duplicate"]))
        piece = data.draw(st.sampled_from(pieces))
        end = min(len(text), position + data.draw(st.integers(1, 8)))
        if action == "insert":
            text = text[:position] + piece + text[position:]
        elif action == "delete":
            text = text[:position] + text[end:]
        elif action == "replace":
            text = text[:position] + piece + text[end:]
        else:
            text = text[:position] + text[position:end] * 50 + text[end:]
    return text


@FUZZ
@given(text=st.text(max_size=300))
def test_parser_on_random_text(text):
    _either_tree_or_documented_error(parse, text)


@FUZZ
@given(text=st.lists(st.sampled_from(TOKENS), max_size=80).map("".join))
def test_parser_on_random_token_soup(text):
    _either_tree_or_documented_error(parse, text)


@FUZZ
@given(tree=trees, data=st.data())
def test_parser_on_mutated_trees(tree, data):
    text = data.draw(st.sampled_from([to_text(tree), to_indented(tree)]))
    _either_tree_or_documented_error(parse, _mutate(data, text, TOKENS))


@FUZZ
@given(text=st.one_of(st.text(max_size=300), st.lists(st.sampled_from(XML_PIECES), max_size=40).map("".join)))
def test_xml_importer_on_random_text(text):
    _either_tree_or_documented_error(from_xml, text)


@FUZZ
@given(tree=trees, data=st.data())
def test_xml_importer_on_mutated_documents(tree, data):
    _either_tree_or_documented_error(from_xml, _mutate(data, to_xml(tree), XML_PIECES + TOKENS))


def test_pathological_inputs_give_a_tree_or_a_documented_error():
    for _, function, text in PATHOLOGICAL:
        _either_tree_or_documented_error(function, text)
