"""Tools for people: ``cli`` the ``bt`` command (check, show and draw, export and simplify trees; imported by
its own name) and ``render`` SVG and PNG drawings of a tree with matplotlib (loaded only when drawing)."""

from bt_controller.tools.render import RENDER_FORMATS, layout, render

__all__ = ["RENDER_FORMATS", "layout", "render"]
