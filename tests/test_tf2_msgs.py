"""The workspace's tf2_msgs (src/tf2_msgs, built by ws/setup because tf2_msgs has no PyPI wheel) is ROS 2's:
the type hash of its TFMessage, as rosidl generated it here, equals the official one, which rosbags computes
from its own copy of ROS 2 Kilted's definitions. A different field, type or name would change the hash, and a
tf2 listener of a full ROS 2 install would then not match our /tf."""

from __future__ import annotations

import json
from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from rosbags.typesys import Stores, get_typestore

from tf2_msgs.msg import TFMessage


def generated_hash(package: str, kind: str, name: str) -> str:
    """The RIHS01 type hash rosidl wrote beside the installed interface
    (``share/<package>/<kind>/<name>.json``)."""
    path = Path(get_package_share_directory(package)) / kind / f"{name}.json"
    hashes = json.loads(path.read_text())["type_hashes"]
    (own,) = [h["hash_string"] for h in hashes if h["type_name"] == f"{package}/{kind}/{name}"]
    return own


def test_the_tf_message_type_hash_is_the_official_one() -> None:
    official = get_typestore(Stores.ROS2_KILTED).hash_rihs01("tf2_msgs/msg/TFMessage")
    assert official.startswith("RIHS01_")
    assert generated_hash("tf2_msgs", "msg", "TFMessage") == official


def test_the_check_tells_a_different_definition_apart() -> None:
    # the same comparison for a message whose definition is not TFMessage's: the hashes differ
    store = get_typestore(Stores.ROS2_KILTED)
    assert generated_hash("tf2_msgs", "msg", "TFMessage") != store.hash_rihs01(
        "geometry_msgs/msg/TransformStamped"
    )


def test_the_message_carries_transforms() -> None:
    assert TFMessage.get_fields_and_field_types() == {
        "transforms": "sequence<geometry_msgs/TransformStamped>"
    }
