"""The colours every view draws a trial in: the GIF animation (``animate``) and the explorer page
(``explorer``) take them from here, so a food kind, a carried kind and a robot look the same in both."""

from __future__ import annotations

from bt_controller.language import food_kind_name

RGB = tuple[int, int, int]

ROBOT_COLOURS: tuple[RGB, ...] = (
    (31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (140, 86, 75),
    (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207),
)  # fmt: skip
"""Robot i's colour is ``ROBOT_COLOURS[i % 9]``."""
NEST_COLOUR: RGB = (246, 214, 160)
FOOD_COLOUR: RGB = (196, 230, 180)
GAP_COLOUR: RGB = (250, 250, 250)
CARRY_COLOUR: RGB = (30, 130, 30)
"""The ring of a robot carrying food of kind 1."""
FAULT_COLOUR: RGB = (200, 0, 0)
"""The cross over a faulty robot (a live adaptation's bag)."""
SWAP_COLOUR: RGB = (20, 60, 200)
"""The ring of a robot running a tree a live adaptation swapped in, and the adaptation's heading."""
REGION_COLOURS: dict[str, tuple[RGB, RGB]] = {
    "food": (FOOD_COLOUR, (40, 100, 40)),
    "food2": ((184, 208, 240), (40, 70, 150)),
    "food3": ((240, 196, 214), (150, 40, 90)),
    "nest": (NEST_COLOUR, (120, 80, 20)),
}
"""Each region kind's fill and ink (its label; the ring of a robot carrying it), drawn in this order."""


def carry_colour(kind: int) -> RGB:
    """The ring of a robot carrying food of kind ``kind`` (0-based: 0 is kind 1)."""
    return CARRY_COLOUR if kind == 0 else REGION_COLOURS[food_kind_name(kind + 1)][1]


def hex_colour(rgb: RGB) -> str:
    """``rgb`` as a CSS colour, ``#rrggbb``."""
    return "#" + "".join(f"{c:02x}" for c in rgb)
