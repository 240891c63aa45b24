"""Install bt_controller as an ament_python package (see ws/setup for the workspace build)."""

from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "bt_controller"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
        ("share/" + PACKAGE + "/config", glob("config/*.yaml")),
        ("share/" + PACKAGE + "/launch", glob("launch/*.py")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Swarm BT-QD maintainers",
    maintainer_email="maintainers@swarm-bt-qd.org",
    description=Path("package.xml").read_text().split("<description>")[1].split("</description>")[0],
    license="Apache-2.0",
    # colcon runs pytest only when pytest is declared as the test extra.
    extras_require={"test": ["pytest"]},
    entry_points={
        "console_scripts": [
            # "EXECUTABLE = bt_controller.MODULE:main": run with `ws/run bt_controller EXECUTABLE`.
            "bt = bt_controller.tools.cli:main",
            "bench = bt_controller.bench.tick_bench:main",
            "footbot_controller = bt_controller.nodes.footbot_controller:main",
            "footbot_controllers = bt_controller.nodes.footbot_controller:main_many",
        ],
    },
)
