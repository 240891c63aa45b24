"""A primitive library shown in the explorer (``explorer RUN_DIR --library LIB.json``): two tiny real QD
runs of food, a library built from both by the ``library`` command, each run's page opened in headless
Chromium. The bins marked are exactly the library's source bins of that run, named; the block boundaries are
drawn; the other run's primitives are listed; a marked bin's detail names its primitive; a page without
--library is byte for byte the one the run wrote; files that are no library, or a library of no objective of
the run, are refused."""

from __future__ import annotations

import json
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest
from headless import dump_dom

from evolution_manager.graph.startup import executable
from evolution_manager.viewing.explorer_page import LIBRARY_SCRIPT, LIBRARY_STYLE

VOID = {"meta", "input", "br", "img", "hr", "link", "col", "area", "base", "wbr", "source", "track", "embed"}


class _Dom(HTMLParser):
    """Every element's tag, attributes and text (its descendants' included)."""

    def __init__(self) -> None:
        super().__init__()
        self.elements: list[tuple[str, dict[str, str], list[str]]] = []
        self._open: list[list[str]] = []

    def handle_starttag(self, tag: str, attrs: list) -> None:
        text: list[str] = []
        self.elements.append((tag, {k: v or "" for k, v in attrs}, text))
        if tag not in VOID:
            self._open.append(text)

    def handle_endtag(self, tag: str) -> None:
        if tag not in VOID and self._open:
            self._open.pop()

    def handle_data(self, data: str) -> None:
        for text in self._open:
            text.append(data)

    def find(self, tag: str | None = None, cls: str | None = None, **attrs: str) -> list[tuple[dict, str]]:
        """(attributes, text) of the elements with ``tag``, class ``cls`` and the attributes given
        (``data_bin`` for data-bin)."""
        wanted = {k.replace("_", "-"): v for k, v in attrs.items()}
        return [
            (a, "".join(text))
            for t, a, text in self.elements
            if (tag is None or t == tag)
            and (cls is None or cls in a.get("class", "").split())
            and all(a.get(k) == v for k, v in wanted.items())
        ]


def rendered(page: Path, fragment: str) -> _Dom:
    dom = _Dom()
    dom.feed(dump_dom(page, fragment))
    return dom


def command(name: str, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(executable("evolution_manager", name)), *args],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=cwd,
    )


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict:
    """Two 30-evaluation QD runs of food (seeds 1 and 2), each run's own explorer.html kept aside, and
    libraries of 8 and 64 blocks built from both, named by relative paths (from the runs' folder)."""
    top = tmp_path_factory.mktemp("explorer-library")
    for seed in (1, 2):
        done = command(
            "evolve", "--algorithm", "qd", "--objective", "food", "--evaluations", "30", "--trials", "1",
            "--seed", str(seed), "--out", str(top / f"run{seed}"), "--no-progress",
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-3000:]
        shutil.copyfile(top / f"run{seed}/explorer.html", top / f"run{seed}.written.html")
    for blocks in (8, 64):
        done = command(
            "library",
            "--from",
            "run1",
            "run2",
            "--blocks",
            str(blocks),
            "--out",
            f"lib{blocks}.json",
            cwd=top,
        )
        assert done.returncode == 0, done.stderr[-3000:]
    return {"top": top, "runs": [top / "run1", top / "run2"]}


def library_page(runs: dict, run: Path, blocks: int, fragment: str) -> _Dom:
    done = command("explorer", str(run), "--library", f"lib{blocks}.json", "--no-animations", cwd=runs["top"])
    assert done.returncode == 0, done.stderr[-3000:]
    return rendered(run / "explorer.html", fragment)


def primitives(runs: dict, blocks: int) -> list[dict]:
    return json.loads((runs["top"] / f"lib{blocks}.json").read_text())["primitives"]


def of_run(entries: list[dict], run: Path, top: Path) -> list[dict]:
    return [p for p in entries if (top / p["source"]["run"]).resolve() == run.resolve()]


def bin_text(entry: dict) -> str:
    return ",".join(map(str, entry["source"]["bin"]))


def test_each_run_marks_exactly_its_primitives_and_lists_the_others(runs):
    entries, top = primitives(runs, 8), runs["top"]
    assert all(p["source"]["objective"] == "food" for p in entries)
    mine = [of_run(entries, run, top) for run in runs["runs"]]
    assert mine[0] and mine[1], "both runs should give the library primitives (seeds 1 and 2 did)"
    assert len(mine[0]) + len(mine[1]) == len(entries)
    for k, run in enumerate(runs["runs"]):
        dom = library_page(runs, run, 8, "objective=food")
        marked = {a["data-bin"]: a for a, _ in dom.find("rect", cls="primitive")}
        assert marked.keys() == {bin_text(p) for p in mine[k]}
        for p in mine[k]:
            cell = marked[bin_text(p)]
            assert cell["data-primitive"] == p["name"]
            assert "filled" in cell["class"].split()
            (outline,) = dom.find("rect", cls="primitive-outline", data_primitive=p["name"])
            assert (float(outline[0]["x"]) - 1.5, float(outline[0]["y"]) - 1.5) == (
                float(cell["x"]),
                float(cell["y"]),
            )
            (badge,) = dom.find("text", cls="primitive-badge", data_primitive=p["name"])
            assert badge[1] == p["name"].removeprefix("gotoFood")  # the block number
            (title,) = [t for a, t in dom.find("title") if p["name"] in t]
            assert title == f"library primitive {p['name']} (block {p['name'][8:]} of 8)"
        (here,) = dom.find("p", id="library-here")
        assert all(f"{p['name']} (bin {bin_text(p)})" in here[1] for p in mine[k])
        others = mine[1 - k]
        rows = dom.find("tr", cls="library-other")
        assert {a["data-primitive"] for a, _ in rows} == {p["name"] for p in others}
        for p in others:
            (row,) = [t for a, t in rows if a["data-primitive"] == p["name"]]
            assert p["source"]["run"] in row and bin_text(p) in row
            assert f"{p['source']['fitness']:.4f}" in row and f"{p['source']['derated_fitness']:.4f}" in row


def test_block_boundaries_cut_the_grid_and_the_conditionality_panels(runs):
    run = runs["runs"][0]
    for blocks, per in ((8, 2), (64, 4)):
        dom = library_page(runs, run, blocks, "objective=food")
        assert dom.find("div", id="heatmaps", data_library_blocks=str(blocks))
        lines = dom.find("line", cls="block-line")
        assert len(lines) == 8 * 2 * (per - 1)  # per panel, per - 1 lines across and as many up
        step = 8 // per * 22  # cells of 22 px, the grid 18 px from the panel's left edge
        assert {float(a["x1"]) for a, _ in lines if a["data-axis"] == "0"} == {
            18 + i * step for i in range(1, per)
        }
        assert {float(a["y1"]) for a, _ in lines if a["data-axis"] == "1"} == {
            i * step for i in range(1, per)
        }
        panels = [a for a, _ in dom.find("div", cls="panel")]
        assert [int(a["data-conditionality-block"]) for a in panels] == [k * per // 8 for k in range(8)]
        starts = [k for k, a in enumerate(panels) if "block-start" in a["class"].split()]
        assert starts == list(range(8 // per, 8, 8 // per))
        cells = [a for a, _ in dom.find("rect", cls="cell")]
        assert len(cells) == 512
        for a in cells:
            m, r, c = (int(v) * per // 8 for v in a["data-bin"].split(","))
            assert int(a["data-block"]) == m * per * per + r * per + c + 1
        marked = {a["data-primitive"]: a["data-block"] for a, _ in dom.find("rect", cls="primitive")}
        assert marked == {
            p["name"]: p["name"].removeprefix("gotoFood")
            for p in of_run(primitives(runs, blocks), run, runs["top"])
        }


def test_a_marked_bin_names_its_primitive_beside_its_trees(runs):
    run = runs["runs"][1]
    entry = of_run(primitives(runs, 8), run, runs["top"])[0]
    dom = library_page(runs, run, 8, f"objective=food&bin={bin_text(entry)}")
    assert dom.find("section", id="detail", data_bin=bin_text(entry))
    (note,) = dom.find("p", id="library-primitive")
    assert note[0]["data-primitive"] == entry["name"]
    assert note[1] == f"library primitive {entry['name']} (block {entry['name'][8:]} of 8)"
    assert dom.find("table", id="values") and dom.find("div", cls="tree")  # the bin's trees as before
    (cell,) = dom.find("rect", data_bin=bin_text(entry))
    assert "selected" in cell[0]["class"].split() and "primitive" in cell[0]["class"].split()
    # a bin that is no primitive's: its trees, no library note
    repertoire = json.loads((run / "repertoire_food.json").read_text())["items"]
    marked = {bin_text(p) for p in of_run(primitives(runs, 8), run, runs["top"])}
    other = next(
        ",".join(map(str, i["bin"])) for i in repertoire if ",".join(map(str, i["bin"])) not in marked
    )
    dom = library_page(runs, run, 8, f"objective=food&bin={other}")
    assert dom.find("table", id="values") and not dom.find("p", id="library-primitive")


def test_relative_source_runs_also_resolve_against_the_librarys_folder(runs):
    run, top = runs["runs"][0], runs["top"]
    done = command(
        "explorer", str(run), "--library", str(top / "lib8.json"), "--no-animations", cwd=run / "best"
    )
    assert done.returncode == 0, done.stderr[-3000:]
    dom = rendered(run / "explorer.html", "objective=food")
    marked = {a["data-bin"] for a, _ in dom.find("rect", cls="primitive")}
    assert marked == {bin_text(p) for p in of_run(primitives(runs, 8), run, top)}


def test_an_objective_without_primitives_shows_the_blocks_and_says_so(runs):
    dom = library_page(runs, runs["runs"][0], 8, "objective=nest")
    assert dom.find("div", id="heatmaps", data_objective="nest")
    assert not dom.find("rect", cls="primitive") and not dom.find("tr", cls="library-other")
    assert len(dom.find("line", cls="block-line")) == 16
    assert any("the library has no primitive of nest" in t for _, t in dom.find("p"))


def test_without_library_the_page_is_the_one_the_run_wrote_byte_for_byte(runs):
    run, top = runs["runs"][0], runs["top"]
    done = command("explorer", str(run))
    assert done.returncode == 0, done.stderr[-3000:]
    assert (run / "explorer.html").read_bytes() == (top / "run1.written.html").read_bytes()
    # and a library page is that page plus the library's style, script and data, nothing else changed
    done = command("explorer", str(run), "--no-animations")
    assert done.returncode == 0, done.stderr[-3000:]
    plain = (run / "explorer.html").read_text()
    assert "__LIBRARY" not in plain and "DATA.library" not in plain
    library_page(runs, run, 8, "objective=food")
    shown = (run / "explorer.html").read_text()
    head, payload, tail = _split_data(shown)
    data = json.loads(payload.replace("<\\/", "</"))
    assert data.pop("library")["blocks"] == 8
    stripped = (
        head.replace(LIBRARY_STYLE, "", 1)
        + json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
        + tail.replace(LIBRARY_SCRIPT, "", 1)
    )
    assert stripped == plain and shown != plain


def _split_data(page: str) -> tuple[str, str, str]:
    opening = '<script type="application/json" id="data">'
    head, rest = page.split(opening, 1)
    payload, tail = rest.split("</script>", 1)
    return head + opening, payload, "</script>" + tail


def test_what_is_no_library_or_of_no_objective_of_the_run_is_refused(runs):
    run, top = runs["runs"][0], runs["top"]
    before = (run / "explorer.html").read_bytes()
    done = command("explorer", str(run), "--library", str(run / "config.json"))
    assert done.returncode == 2
    assert (
        "config.json" in done.stderr
        and "expected a library file written by the library command" in done.stderr
    )

    document = json.loads((top / "lib8.json").read_text())
    bare = {
        "format": 1,
        "primitives": [{"name": p["name"], "tree": p["tree"]} for p in document["primitives"]],
    }
    (top / "bare.json").write_text(json.dumps(bare))
    done = command("explorer", str(run), "--library", str(top / "bare.json"))
    assert done.returncode == 2 and "has no source run, objective, blocks, block, bin, fitness" in done.stderr

    # the same primitives said to come from ifood runs: an objective this run has no grid of
    for p in document["primitives"]:
        p["name"] = p["name"].replace("gotoFood", "goAwayFromFood")
        p["source"]["objective"] = "ifood"
    (top / "ifood.json").write_text(json.dumps(document))
    done = command("explorer", str(run), "--library", str(top / "ifood.json"))
    assert done.returncode == 2
    assert (
        "holds primitives of ifood" in done.stderr
        and "shows density, nest, food: none in common" in done.stderr
    )
    assert (run / "explorer.html").read_bytes() == before  # nothing written
