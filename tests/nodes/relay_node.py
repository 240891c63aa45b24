"""A small real node for the workspace's own tests: it answers range-and-bearing readings with wheel commands
and serves load_tree, over swarm_msgs and Fast DDS. Started as a separate process by test_ros_messaging.py.

It computes the robot's raw nest estimate the way a footbot does (minimum of sender estimate plus range), so
the test can check that the message content crossed the process boundary intact.
"""

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from swarm_msgs.msg import RangeAndBearingReadings, WheelCommand
from swarm_msgs.srv import LoadTree


class RelayNode(Node):
    def __init__(self) -> None:
        super().__init__("relay", namespace="footbot_0")
        self.publisher = self.create_publisher(WheelCommand, "wheels", 10)
        self.create_subscription(RangeAndBearingReadings, "range_and_bearing", self.on_readings, 10)
        self.create_service(LoadTree, "load_tree", self.on_load_tree)

    def on_readings(self, msg: RangeAndBearingReadings) -> None:
        estimates = [r.nest_estimate + r.range for r in msg.readings]
        reply = WheelCommand(robot=0, step=msg.step, left=1.0, right=-1.0)
        reply.nest_estimate = min(estimates, default=5000.0)
        self.publisher.publish(reply)

    def on_load_tree(self, request: LoadTree.Request, response: LoadTree.Response) -> LoadTree.Response:
        words = request.tree.split()
        response.success = bool(words)
        response.message = "" if words else "the tree is empty"
        response.canonical_tree = " ".join(words)
        return response


def main() -> None:
    rclpy.init()
    node = RelayNode()
    print("relay ready", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
