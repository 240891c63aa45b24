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
            "trial = evolution_manager.graph.nodes.trial:main",
            "record = evolution_manager.graph.nodes.recorder:main",
            "replay = evolution_manager.graph.nodes.replay:main",
            "recover = evolution_manager.graph.nodes.replay:recover_main",
            "manager = evolution_manager.graph.nodes.manager:main",
            "measure-services = evolution_manager.graph.nodes.measure_services:main",
            "main = evolution_manager.graph.nodes.main_job:main",
            "measure-graph = evolution_manager.graph.nodes.measure_graph:main",
            "evolve = evolution_manager.studies.evolve:main",
            "experiment = evolution_manager.studies.experiment:main",
            "report = evolution_manager.studies.report_command:main",
            "library = evolution_manager.evolution.libraries:main",
            "measure = evolution_manager.studies.measure:main",
            "timing-study = evolution_manager.studies.timing_study:main",
            "measure-cluster = evolution_manager.studies.measure_cluster:main",
            "snapshot = evolution_manager.viewing.snapshot:main",
            "animate = evolution_manager.viewing.animate:main",
            "explorer = evolution_manager.viewing.explorer:main",
            "adapt = evolution_manager.adaptation.adapt:main",
            "adapt-benchmark = evolution_manager.adaptation.adapt_benchmark:main",
            "adapt-live = evolution_manager.adaptation.adapt_live:main",
        ],
    },
)
