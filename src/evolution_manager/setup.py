"""Install evolution_manager as an ament_python package (see ws/setup for the workspace build)."""

from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "evolution_manager"

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
            # "EXECUTABLE = evolution_manager.MODULE:main": run with `ws/run evolution_manager EXECUTABLE`.
            "trial = evolution_manager.nodes.trial:main",
            "record = evolution_manager.nodes.recorder:main",
            "replay = evolution_manager.nodes.replay:main",
            "recover = evolution_manager.nodes.replay:recover_main",
            "manager = evolution_manager.nodes.manager:main",
            "measure-services = evolution_manager.nodes.measure_services:main",
            "main = evolution_manager.nodes.main_job:main",
            "measure-graph = evolution_manager.nodes.measure_graph:main",
            "evolve = evolution_manager.cli:main",
            "experiment = evolution_manager.experiment:main",
            "report = evolution_manager.report:main",
            "measure = evolution_manager.measure:main",
            "snapshot = evolution_manager.snapshot:main",
            "animate = evolution_manager.animation:main",
            "explorer = evolution_manager.explorer:main",
            "adapt = evolution_manager.adapt:main",
            "adapt-benchmark = evolution_manager.adapt_benchmark:main",
        ],
    },
)
