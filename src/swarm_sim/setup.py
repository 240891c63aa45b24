"""Install swarm_sim as an ament_python package (see ws/setup for the workspace build)."""

from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "swarm_sim"

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
            # "EXECUTABLE = swarm_sim.MODULE:main": run with `ws/run swarm_sim EXECUTABLE`.
            "evaluate = swarm_sim.evaluation.cli:evaluate_main",
            "bench = swarm_sim.bench.batch:main",
            "record-bench = swarm_sim.bench.recording:main",
            "division-bench = swarm_sim.bench.division:main",
            "validate = swarm_sim.validation.cli:main",
            "task = swarm_sim.tasks.cli:main",
            "simulator = swarm_sim.nodes.simulator:main",
            "evaluator = swarm_sim.nodes.evaluator:main",
            "sensor_bridge = swarm_sim.nodes.sensor_bridge:main",
        ],
    },
)
