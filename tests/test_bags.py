"""Bags: what the recorder writes reads back with rosbags and with the mcap reader, in order, none missing;
a recorder killed with SIGKILL leaves a file whose flushed messages recover_bag brings back."""

import signal
import subprocess
import sys

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from evolution_manager.recording.bags import (
    BagError,
    BagRecorder,
    read_bag,
    recover_bag,
    swarm_msgs_definitions,
    swarm_typestore,
)


@pytest.fixture(scope="module")
def typestore():
    return swarm_typestore()


def wheel_command(typestore, step):
    types = typestore.types
    stamp = types["builtin_interfaces/msg/Time"](sec=step // 8, nanosec=(step % 8) * 125_000_000)
    header = types["std_msgs/msg/Header"](stamp=stamp, frame_id="arena")
    return types["swarm_msgs/msg/WheelCommand"](
        header=header,
        robot=step % 9,
        step=step,
        action=3,
        action_name="forward_right",
        left=0.05,
        right=0.0,
        nest_estimate=0.5 * step,
        food_estimate=5000.0,
        smoothed_nest=0.25 * step,
        smoothed_food=5000.0,
        smoothed_density=0.5,
        carrying=step % 2 == 1,
        deliveries=step // 100,
        other_food_estimates=np.array([250.0 * (step % 3)]),  # a world of two food kinds
        smoothed_other_food=np.array([125.0]),
        carrying_other_food=np.array([step % 3 == 0]),
        other_food_deliveries=np.array([step // 200], dtype=np.uint32),
    )


def test_recorded_messages_read_back_in_order_with_rosbags_and_mcap(tmp_path, typestore):
    bag = tmp_path / "bag"
    with BagRecorder(bag, typestore) as recorder:
        for step in range(2000):
            recorder.write(f"/footbot_{step % 9}/wheels", wheel_command(typestore, step), step * 125_000_000)
    assert (bag / "metadata.yaml").exists()

    messages = list(read_bag(bag, typestore))
    assert [m.message.step for m in messages] == list(range(2000))
    assert all(m.topic == f"/footbot_{m.message.step % 9}/wheels" for m in messages)
    assert messages[1234].message.nest_estimate == 617.0
    assert messages[1234].message.other_food_estimates.tolist() == [250.0 * (1234 % 3)]

    (mcap_file,) = bag.glob("*.mcap")
    with mcap_file.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        decoded = [(channel.topic, msg.step) for _, channel, _, msg in reader.iter_decoded_messages()]
    assert decoded == [(f"/footbot_{s % 9}/wheels", s) for s in range(2000)]


def test_bags_carry_the_ros_distro_and_each_channel_its_type_hash_as_rosbag2_writes_them(
    tmp_path, typestore, monkeypatch
):
    monkeypatch.delenv("ROS_DISTRO", raising=False)
    bag = tmp_path / "bag"
    with BagRecorder(bag, typestore) as recorder:
        for step in range(20):
            recorder.write(f"/footbot_{step % 2}/wheels", wheel_command(typestore, step), step * 125_000_000)
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["ros_distro"] == "kilted"  # the wheels' distribution, not "rosbags"
    hashes = {
        t["topic_metadata"]["name"]: t["topic_metadata"]["type_description_hash"]
        for t in info["topics_with_message_count"]
    }
    assert set(hashes) == {"/footbot_0/wheels", "/footbot_1/wheels"}
    assert all(h.startswith("RIHS01_") and len(h) == 7 + 64 for h in hashes.values())

    (mcap_file,) = bag.glob("*.mcap")
    with mcap_file.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        header, summary = reader.get_header(), reader.get_summary()
        assert header.profile == "ros2"
        # the MCAP ros2 profile: cdr messages, ros2msg schemas named pkg/msg/Type, offered QoS per channel;
        # and, as rosbag2's MCAP storage writes it, the type hash per channel
        for channel in summary.channels.values():
            assert channel.message_encoding == "cdr"
            assert summary.schemas[channel.schema_id].encoding == "ros2msg"
            assert summary.schemas[channel.schema_id].name == "swarm_msgs/msg/WheelCommand"
            assert "offered_qos_profiles" in channel.metadata
            assert channel.metadata["topic_type_hash"] == hashes[channel.topic]
        (record,) = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
        assert record.metadata["ros_distro"] == "kilted"
        assert "ros_distro: kilted" in record.metadata["serialized_metadata"]
        assert [msg.step for _, _, _, msg in reader.iter_decoded_messages()] == list(range(20))
    assert [m.message.step for m in read_bag(bag, typestore)] == list(range(20))  # rosbags reads it too

    monkeypatch.setenv("ROS_DISTRO", "jazzy")  # a full ROS 2 install's
    with BagRecorder(tmp_path / "jazzy", typestore) as recorder:
        recorder.write("/footbot_0/wheels", wheel_command(typestore, 1), 0)
    assert "ros_distro: jazzy" in (tmp_path / "jazzy" / "metadata.yaml").read_text()


def test_recorder_refuses_to_overwrite(tmp_path, typestore):
    (tmp_path / "bag").mkdir()
    with pytest.raises(BagError, match="refusing to overwrite"):
        BagRecorder(tmp_path / "bag", typestore)


def test_killed_recorder_leaves_a_recoverable_bag(tmp_path):
    code = """
import sys
from evolution_manager.recording.bags import BagRecorder
with BagRecorder(sys.argv[1]) as recorder:
    step = 0
    while True:
        pose = recorder.message("swarm_msgs/msg/RobotPose", x=float(step), y=0.0, theta=0.0)
        recorder.write("/pose", pose, step)
        step += 1
        if step == 50_000:
            print("written", flush=True)
"""
    damaged = tmp_path / "killed"
    process = subprocess.Popen([sys.executable, "-c", code, str(damaged)], stdout=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == "written"
    process.send_signal(signal.SIGKILL)
    process.wait()

    with pytest.raises(BagError, match="recover"):
        list(read_bag(damaged))
    count = recover_bag(damaged, tmp_path / "recovered")
    assert count > 10_000  # every chunk flushed before the kill (the writer buffers about 1 MiB)
    xs = [m.message.x for m in read_bag(tmp_path / "recovered")]
    assert xs == [float(i) for i in range(count)]


def test_a_bag_written_before_the_food_kinds_reads_back_as_it_was_written(tmp_path):
    """A message type that has since gained fields is read with the bag's own definition of it."""
    older = get_typestore(Stores.ROS2_KILTED)
    types = {}
    for name, text in swarm_msgs_definitions().items():
        if name.endswith("/WheelCommand"):
            text = text[: text.index("# In a world of several food kinds")]  # the fields of before
        types.update(get_types_from_msg(text, name))
    older.register(types)
    stamp = older.types["builtin_interfaces/msg/Time"](sec=1, nanosec=0)
    header = older.types["std_msgs/msg/Header"](stamp=stamp, frame_id="arena")
    old = older.types["swarm_msgs/msg/WheelCommand"](
        header=header, robot=2, step=8, action=1, action_name="forward", left=0.05, right=0.05,
        nest_estimate=1200.0, food_estimate=300.0, smoothed_nest=1250.0, smoothed_food=310.0,
        smoothed_density=0.2, carrying=True, deliveries=3,
    )  # fmt: skip
    with BagRecorder(tmp_path / "bag", older) as recorder:
        recorder.write("/footbot_2/wheels", old, 1_000_000_000)
    (read,) = read_bag(tmp_path / "bag")  # with today's definitions as the default
    assert (read.message.food_estimate, read.message.carrying, read.message.deliveries) == (300.0, True, 3)
    assert not hasattr(read.message, "other_food_estimates")
