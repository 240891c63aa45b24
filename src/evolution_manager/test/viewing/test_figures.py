"""Box-plot figures stay readable at page width: many objectives wrap into rows of at most three panels, as
the paper's figs. 4-6 are laid out, and every objective keeps its panel."""

from __future__ import annotations

import numpy as np
from matplotlib.image import imread

from evolution_manager.viewing import figures

OBJECTIVES = ("density", "nest", "food", "idensity", "inest", "ifood", "foraging")
ARMS = ("gp", "qd", "nn-cmaes", "nn-ga", "nn-qd")


def samples(objectives, seed=5):
    rng = np.random.default_rng(seed)
    return {o: {arm: list(rng.uniform(0.5, 0.9, size=4)) for arm in ARMS} for o in objectives}


def size(path):
    height, width = imread(path).shape[:2]
    return width, height


def test_seven_objectives_wrap_into_rows_no_wider_than_three_panels(tmp_path):
    three = size(figures.boxes(samples(OBJECTIVES[:3]), "best fitness", tmp_path / "three.png"))
    seven = size(figures.boxes(samples(OBJECTIVES), "best fitness", tmp_path / "seven.png"))
    assert seven[0] <= three[0] + 20, f"seven panels {seven[0]} px wide against three's {three[0]}"
    assert seven[1] >= 2.8 * three[1], f"seven panels {seven[1]} px high: not three rows of {three[1]}"
    assert three[0] <= 1400, f"three panels are {three[0]} px wide"


def test_one_objective_is_one_panel_as_before(tmp_path):
    one = size(figures.boxes(samples(OBJECTIVES[-1:]), "held-out best fitness", tmp_path / "one.png"))
    three = size(figures.boxes(samples(OBJECTIVES[:3]), "held-out best fitness", tmp_path / "three.png"))
    assert one[0] < three[0] / 2 and abs(one[1] - three[1]) <= 20
