"""The repository's licence and the packages' changelogs: one LICENSE at the root, Apache-2.0 (the ROS 2
norm), which every package.xml and setup.py declares; and a CHANGELOG.rst per package in the form
``catkin_generate_changelog`` and bloom read (the package named in its title, a section for its version)."""

import itertools
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = sorted(p.parent for p in (ROOT / "src").glob("*/package.xml"))


def test_the_license_file_is_apache_2():
    text = (ROOT / "LICENSE").read_text()
    assert "Apache License" in text and "Version 2.0, January 2004" in text
    assert "TERMS AND CONDITIONS FOR USE, REPRODUCTION, AND DISTRIBUTION" in text


@pytest.mark.parametrize("package", PACKAGES, ids=lambda p: p.name)
def test_each_package_declares_the_license_and_keeps_a_changelog(package):
    manifest = ET.parse(package / "package.xml").getroot()
    assert [e.text for e in manifest.findall("license")] == ["Apache-2.0"]
    setup = package / "setup.py"
    if setup.exists():
        assert 'license="Apache-2.0"' in setup.read_text()
    changelog = (package / "CHANGELOG.rst").read_text().splitlines()
    title = f"Changelog for package {package.name}"
    assert changelog[:3] == ["^" * len(title), title, "^" * len(title)]
    version = manifest.findtext("version")
    headings = [a for a, b in itertools.pairwise(changelog) if b and set(b) == {"-"} and len(b) == len(a)]
    assert headings, "no version section"
    assert headings[0] == "Forthcoming" or headings[0].split(" (")[0] == version, headings[0]
    assert version in [h.split(" (")[0] for h in headings], headings
