"""Install swarm_ros as an ament_python package (see ws/setup for the workspace build)."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "swarm_ros"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Swarm BT-QD maintainers",
    maintainer_email="maintainers@swarm-bt-qd.org",
    description=Path("package.xml").read_text().split("<description>")[1].split("</description>")[0],
    license="Apache-2.0",
    # colcon runs pytest only when pytest is declared as the test extra.
    extras_require={"test": ["pytest"]},
)
