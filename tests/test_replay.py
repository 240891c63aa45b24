"""Replay: a trial bag is republished in order for ROS tools; --verify accepts a faithful recording and names
the first step where a tampered one differs."""

import subprocess
import time

import numpy as np
import pytest
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from bt_controller.tree import parse
from evolution_manager.graph.nodes.trial import write_result
from evolution_manager.graph.startup import executable
from evolution_manager.recording.bags import BagRecorder
from evolution_manager.recording.reproduce import verify_trial_bag
from swarm_msgs.msg import SwarmState
from swarm_ros.isolation import domain_environment, reserved_domain
from swarm_sim.config import DEFAULT
from swarm_sim.lockstep import run_with_controllers

TREE = "sel(seq(robot_left, forward_left), prob(forward, reverse_right))"
SEED, TRIAL = 21, 2
STEP_NS = 125_000_000


def write_trial_bag(path, tamper_step=None, tamper_carrying=None):
    """The bag `trial --bag` would write for (TREE, SEED, TRIAL), from the in-process twin of the graph:
    /trial_start, one /swarm_state per step (poses, carrying flags, deliveries), /trial_result; optionally
    with one pose moved by 1 mm, or one robot's carrying flag flipped."""
    states = []

    def keep(world):
        cargo = ([bool(c) for c in world.carrying], [int(d) for d in world.deliveries])
        states.append((world.step, world.poses().tolist(), cargo))

    record = run_with_controllers(parse(TREE), SEED, TRIAL, on_step=keep)
    with BagRecorder(path) as bag:
        types = bag.typestore.types

        def header(step):
            stamp = types["builtin_interfaces/msg/Time"](sec=step // 8, nanosec=(step % 8) * STEP_NS)
            return types["std_msgs/msg/Header"](stamp=stamp, frame_id="arena")

        start = bag.message(
            "swarm_msgs/msg/TrialStart",
            header=header(0),
            seed=SEED,
            trial=TRIAL,
            arena_configuration=TRIAL % 2,
            robots=9,
            tree_keys=np.zeros(9, dtype=np.uint64),
            ticks=DEFAULT.ticks,
        )
        bag.write("/trial_start", start, 0)
        for step, poses, (carrying, deliveries) in states:
            if step == tamper_step:
                poses[4][0] += 1.0
            if step == tamper_carrying:
                carrying[4] = not carrying[4]
            robots = [bag.message("swarm_msgs/msg/RobotPose", x=x, y=y, theta=t) for x, y, t in poses]
            state = bag.message(
                "swarm_msgs/msg/SwarmState",
                header=header(step),
                seed=SEED,
                trial=TRIAL,
                step=step,
                poses=robots,
                carrying=np.array(carrying, dtype=bool),
                deliveries=np.array(deliveries, dtype=np.uint32),
            )
            bag.write("/swarm_state", state, step * STEP_NS)
        write_result(bag, TREE, SEED, record, len(states) * STEP_NS)
    return len(states)


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


def test_replay_republishes_the_bag_in_order(tmp_path):
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
                [*command, "--delay", "3"],
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
