"""What a person opens: a run's result files and its pictures.

``results`` writes a finished run's files (summary, repertoires, the best trees in every format, figures,
explorer); ``figures`` draws the paper's figures with matplotlib; ``frames`` gives one trial frame by frame
(from a tree or a bag) and ``animate`` draws it as a GIF; ``snapshot`` draws one step of a trial bag;
``explorer`` builds the repertoire explorer page (its HTML in ``explorer_page``); ``palette`` holds the
colours both draw in. They show what they are
given: held-out scores and simplified trees come from the ``evolution`` wing. Imports: the base modules,
the ``evolution`` and ``recording`` wings, bt_controller, swarm_sim, matplotlib and Pillow; no ROS.
"""

__all__ = ["animate", "explorer", "figures", "frames", "palette", "results", "snapshot"]
