"""Replay: a trial bag is republished in order for ROS tools; --verify accepts a faithful recording and names
the first step where a tampered one differs."""

import re
import shutil
import subprocess
import time

import pytest
import rclpy
from mcap.reader import make_reader
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from bt_controller.language import parse
from evolution_manager.graph.nodes.trial import write_result
from evolution_manager.graph.startup import executable
from evolution_manager.recording.bags import BagRecorder
from evolution_manager.recording.reproduce import verify_trial_bag
from swarm_msgs.msg import SwarmState
from swarm_ros.isolation import domain_environment, reserved_domain
from swarm_sim.model import DEFAULT
from swarm_sim.roads import run_with_controllers

TREE = "sel(seq(robot_left, forward_left), prob(forward, reverse_right))"
SEED, TRIAL = 21, 2
STEP_NS = 125_000_000


def write_trial_bag(path, tamper_step=None, tamper_carrying=None, reading_frames=None):
    """The /trial_start, /swarm_state and /trial_result messages `trial --bag` would record for (TREE, SEED,
    TRIAL), built by the simulator's own code from the in-process twin of the graph; optionally with one
    pose moved by 1 mm, or one robot's carrying flag flipped; with ``reading_frames`` (each robot's), its
    ground readings too, in those frames."""
    from builtin_interfaces.msg import Time
    from rclpy.serialization import serialize_message

    from swarm_ros.names import robot_frames, robot_namespaces
    from swarm_sim.nodes.simulator import step_messages, trial_start_message

    names = robot_namespaces(DEFAULT.n_robots)
    frames = [base for _, base in robot_frames("", names)]
    written = []

    def keep(world):
        at = sum(1 for w in written if w[0] == "/swarm_state") * STEP_NS
        stamp = Time(sec=at // 1_000_000_000, nanosec=at % 1_000_000_000)
        if not written:
            start = trial_start_message(world, stamp, SEED, TRIAL, DEFAULT.n_robots, DEFAULT)
            written.append(("/trial_start", "swarm_msgs/msg/TrialStart", 0, serialize_message(start)))
        state = step_messages(world, stamp, SEED, names, ["stop"] * DEFAULT.n_robots, DEFAULT, frames).state
        if world.step == tamper_step:
            state.poses[4].x += 1.0
        if world.step == tamper_carrying:
            state.carrying[4] = not state.carrying[4]
        written.append(("/swarm_state", "swarm_msgs/msg/SwarmState", at, serialize_message(state)))
        if reading_frames is not None:
            grounds = step_messages(world, stamp, SEED, names, ["stop"] * 9, DEFAULT, reading_frames).ground
            for name, ground in zip(names, grounds, strict=True):
                written.append(
                    (f"/{name}/ground", "swarm_msgs/msg/GroundSensor", at, serialize_message(ground))
                )

    record = run_with_controllers(parse(TREE), SEED, TRIAL, on_step=keep)
    with BagRecorder(path) as bag:
        for topic, msgtype, at, data in written:
            bag.write_cdr(topic, msgtype, at, data)
        write_result(bag, TREE, SEED, record, written[-1][2] + 1)
    return sum(1 for w in written if w[0] == "/swarm_state")


def test_verify_accepts_a_faithful_recording(tmp_path):
    steps = write_trial_bag(tmp_path / "faithful")
    verification = verify_trial_bag(tmp_path / "faithful")
    assert verification.reproduced, verification.summary()
    assert verification.steps_compared == steps == (TRIAL + 1) * 160  # trial 2 runs after trials 0 and 1


def test_verify_names_the_first_step_that_differs(tmp_path):
    write_trial_bag(tmp_path / "tampered", tamper_step=100)
    verification = verify_trial_bag(tmp_path / "tampered")
    assert not verification.reproduced
    assert "step 100" in verification.first_divergence
    done = subprocess.run(
        [str(executable("evolution_manager", "replay")), str(tmp_path / "tampered"), "--verify"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 1 and "NOT reproduced" in done.stdout
    write_trial_bag(tmp_path / "carrying", tamper_carrying=200)
    verification = verify_trial_bag(tmp_path / "carrying")
    assert verification.first_divergence == "the carrying flags or deliveries differ at step 200"


def test_verify_takes_readings_in_each_robots_base_link_or_bare_as_older_bags_name_them(tmp_path):
    """Issue 40: the readings name a robot by its frame (``footbot_3/base_link``, as on /tf); bags recorded
    before named it ``footbot_3``, and still reproduce. Any other frame is a divergence."""
    from swarm_ros.names import robot_frames, robot_namespaces

    names = robot_namespaces(DEFAULT.n_robots)
    for label, frames in (("namespaced", [base for _, base in robot_frames("", names)]), ("bare", names)):
        write_trial_bag(tmp_path / label, reading_frames=frames)
        verification = verify_trial_bag(tmp_path / label)
        assert verification.reproduced, verification.summary()
        assert "/footbot_8/ground" in verification.topics_compared
    write_trial_bag(tmp_path / "odom", reading_frames=[odom for odom, _ in robot_frames("", names)])
    verification = verify_trial_bag(tmp_path / "odom")
    assert (
        verification.first_divergence == "/footbot_0/ground differs from the re-run at its message 1 of 480"
    )


def test_replay_republishes_the_bag_in_order(tmp_path):
    """Every /swarm_state message reaches a listener, in order. ``--wait-for`` holds the first message until
    the listener has matched: a fixed delay alone lost the first 59 on a loaded CI machine."""
    write_trial_bag(tmp_path / "bag")
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        try:
            node = Node("replay_listener", context=context)
            received = []
            qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
            node.create_subscription(SwarmState, "/swarm_state", lambda m: received.append(m.step), qos)
            executor = rclpy.executors.SingleThreadedExecutor(context=context)
            executor.add_node(node)
            command = [str(executable("evolution_manager", "replay")), str(tmp_path / "bag"), "--rate", "20"]
            replay = subprocess.Popen(
                [*command, "--wait-for", "/swarm_state", "--delay", "1"],
                env=domain_environment(domain),
                stdout=subprocess.PIPE,
                text=True,
            )
            deadline = time.monotonic() + 120
            while replay.poll() is None and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            for _ in range(20):
                executor.spin_once(timeout_sec=0.05)
            assert replay.wait(timeout=10) == 0
            steps = (TRIAL + 1) * 160  # the chain's steps up to and including trial TRIAL
            assert f"replayed {steps + 2} messages" in replay.stdout.read()
            assert received == list(range(1, steps + 1))
        finally:
            executor.shutdown()
            rclpy.shutdown(context=context)


def test_replay_waiting_for_a_topic_nobody_hears_publishes_nothing_and_says_so(tmp_path):
    write_trial_bag(tmp_path / "bag")
    replay = str(executable("evolution_manager", "replay"))
    with reserved_domain() as domain:  # a domain of our own: nothing else subscribes there
        done = subprocess.run(
            [replay, str(tmp_path / "bag"), "--wait-for", "/swarm_state", "--wait-timeout", "1"],
            capture_output=True,
            text=True,
            env=domain_environment(domain),
            timeout=120,
        )
    assert done.returncode == 1, done.stdout + done.stderr
    ready, refusal = done.stderr.splitlines()  # rclpy's log line, then ours
    assert ready.endswith("; publishing once /swarm_state has a subscriber, then in 1.0 s")
    assert refusal == "replay: no subscriber of /swarm_state appeared in 1 s; nothing published"
    assert "replayed" not in done.stdout
    missing = subprocess.run(
        [replay, str(tmp_path / "bag"), "--wait-for", "/cmd_vel"], capture_output=True, text=True, timeout=120
    )
    assert missing.returncode == 2
    assert missing.stderr.startswith(
        f"replay: {tmp_path / 'bag'} has no topic /cmd_vel to wait for: its topics"
    )


def test_replay_refuses_a_bad_rate(tmp_path):
    done = subprocess.run(
        [str(executable("evolution_manager", "replay")), str(tmp_path), "--rate", "-1"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2 and "--rate" in done.stderr


@pytest.mark.parametrize("extra", [[], ["--verify"]])
def test_replay_of_a_missing_bag_is_a_clear_error(tmp_path, extra):
    replay = str(executable("evolution_manager", "replay"))
    done = subprocess.run([replay, str(tmp_path / "nothing"), *extra], capture_output=True, text=True)
    assert done.returncode == 2
    assert done.stderr.strip() == f"replay: no bag at {tmp_path / 'nothing'}"


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.mark.parametrize("named", ["planted/msg/Payload", "os/msg/system", "swarm_msgs/msg/../../planted"])
def test_replay_loads_message_types_of_the_allowed_packages_only(tmp_path, named):
    """Issue 41, item 9: replay imported whatever module a bag's metadata named as a message type. A bag
    naming a type outside the allowed packages (here a module planted on the path, which would leave a mark
    if imported) is refused in one line, status 2, before anything is imported or published."""
    import os

    planted = tmp_path / "lib" / "planted" / "msg"
    planted.mkdir(parents=True)
    (planted.parent / "__init__.py").write_text("")
    mark = tmp_path / "imported"
    (planted / "__init__.py").write_text(f"open({str(mark)!r}, 'w').close()\nPayload = object\n")
    bag = tmp_path / "bag"
    with BagRecorder(bag) as recorder:
        recorder.write("/chatter", recorder.message("std_msgs/msg/String", data="hi"), 1000)
    metadata = bag / "metadata.yaml"
    metadata.write_text(metadata.read_text().replace("type: std_msgs/msg/String", f"type: {named}"))
    env = {**os.environ, "PYTHONPATH": f"{tmp_path / 'lib'}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    replay = str(executable("evolution_manager", "replay"))
    done = subprocess.run(
        [replay, str(bag), "--rate", "0", "--delay", "0"],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, done.stderr
    assert f"topic /chatter has message type '{named}', which replay does not load" in done.stderr
    assert not mark.exists(), "the planted module was imported"


def _copy_with(source, target, change):
    """A copy of the bag ``source`` at ``target``, each message's CDR bytes passed through
    ``change(topic, index_on_topic, data)``."""
    from evolution_manager.recording.bags import read_bag

    seen: dict[str, int] = {}
    with BagRecorder(target) as bag:
        for m in read_bag(source):
            k = seen[m.topic] = seen.get(m.topic, 0) + 1
            bag.write_cdr(m.topic, m.msgtype, m.timestamp_ns, change(m.topic, k, m.data))


def test_verify_compares_every_topic_of_a_real_recording_checks_its_crcs_and_recover_counts(tmp_path):
    """Issue 41, item 11: --verify compared only /swarm_state and /trial_result, so altered wheels or poses
    "reproduced", and a flipped bit went unnoticed (no CRCs). Now every topic the re-run produces is
    compared and named, the MCAP CRCs are written and checked, and recover says how many messages of the
    metadata's count it got back."""
    from evolution_manager.recording.bags import swarm_typestore

    bag = tmp_path / "trial.bag"
    with reserved_domain() as domain:
        done = subprocess.run(
            [str(executable("evolution_manager", "trial")), "--tree", TREE, "--seed", str(SEED),
             "--trial", "0", "--bag", str(bag), "--domain", str(domain)],
            capture_output=True,
            text=True,
            timeout=600,
        )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    replay = str(executable("evolution_manager", "replay"))

    def verify(path):
        return subprocess.run([replay, str(path), "--verify"], capture_output=True, text=True, timeout=300)

    faithful = verify(bag)
    assert faithful.returncode == 0, faithful.stdout + faithful.stderr
    assert (
        faithful.stdout.startswith("reproduced: ")
        and "63 topics compared (/clock, /footbot_0/ground" in faithful.stdout
    )
    for topic in ("/footbot_8/wheels", "/footbot_8/tree_status", "/poses", "/robot_markers", "/markers"):
        assert topic in faithful.stdout
    assert "MCAP CRCs checked" in faithful.stdout and "no MCAP CRCs" not in faithful.stdout

    store = swarm_typestore()

    def faster(topic, k, data):  # one wheel command of robot 3 a nanometre per second faster
        if topic != "/footbot_3/wheels" or k != 10:
            return data
        # (rosbags' serializer: rclpy's serialize_message pads a message that ends in empty sequences of
        # float64 with the alignment it reserved for them, which a strict CDR reader refuses)
        message = store.deserialize_cdr(data, "swarm_msgs/msg/WheelCommand")
        message.left += 1e-9
        return bytes(store.serialize_cdr(message, "swarm_msgs/msg/WheelCommand"))

    _copy_with(bag, tmp_path / "wheels.bag", faster)
    altered = verify(tmp_path / "wheels.bag")
    assert altered.returncode == 1 and altered.stdout.startswith("NOT reproduced: "), altered.stdout
    assert "/footbot_3/wheels differs from the re-run at its message 10 of 160" in altered.stdout

    flipped = tmp_path / "flipped.bag"
    shutil.copytree(bag, flipped)
    mcap = next(flipped.glob("*.mcap"))
    with mcap.open("rb") as stream:  # one bit in the middle of a chunk past the first: inside the messages
        chunks = make_reader(stream).get_summary().chunk_indexes
    chunk = chunks[len(chunks) * 3 // 5]
    data = bytearray(mcap.read_bytes())
    data[chunk.chunk_start_offset + chunk.chunk_length // 2] ^= 0x10
    mcap.write_bytes(data)
    damaged = verify(flipped)
    assert damaged.returncode == 2 and "Traceback" not in damaged.stderr, damaged.stderr
    assert damaged.stderr.count("\n") == 1 and f"{mcap} is damaged" in damaged.stderr

    recover = str(executable("evolution_manager", "recover"))
    out = subprocess.run(
        [recover, str(flipped), str(tmp_path / "recovered.bag")], capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert re.fullmatch(
        rf"recovered \d+ of the \d+ messages its metadata.yaml counts into {tmp_path / 'recovered.bag'}: \d+ "
        r"lost \(a damaged or truncated MCAP file\)\n",
        out.stdout,
    ), out.stdout
