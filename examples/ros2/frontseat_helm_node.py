#!/usr/bin/env python3
"""A ROS 2 helm node (rclpy, Jazzy style) for a frontseat vehicle: the Goby3 course homework path,
the same decisions as the Zenoh helm (examples/python/helm.py) and as cyclone_helm.py beside it
(both import homework.py).

NOT RUN HERE: ROS 2 cannot be installed on the machine this project is built on, so this file was
only byte-compiled. What was run is the same logic over plain Cyclone DDS (cyclone_helm.py, in
tests/ros2_python.rs). On a ROS 2 machine, with frontseat_msgs built in your workspace
(examples/ros2/README.md):

    source /opt/ros/jazzy/setup.bash && source ~/ws/install/setup.bash
    python3 examples/ros2/frontseat_helm_node.py --ros-args -p platform:=auv1 -p warp:=1.0

Subscribes /<platform>/frontseat/node_status (sensor-data QoS) and /<platform>/frontseat/status;
publishes /<platform>/frontseat/helm_state (HELM_DRIVE, 1 Hz) and desired_course (QoS depth 10,
reliable). Once the interface reports COMMAND: 1.5 m/s east for t1 s, south for t2 s, then
northwest until the vehicle stops closing on its start; exits 0 when done, 1 on timeout, 130 on
Ctrl-C.
Parameters: platform, t1, t2, speed, warp (the interface's sim_warp_factor), timeout (wall s).
"""

import sys
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data

from frontseat_msgs.msg import DesiredCourse, HelmStateReport, InterfaceStatus, NodeStatus
from homework import CourseThrottle, HomeworkPath


class FrontseatHelm(Node):
    def __init__(self):
        super().__init__("frontseat_helm")
        platform = self.declare_parameter("platform", "auv1").value
        t1 = self.declare_parameter("t1", 60.0).value
        t2 = self.declare_parameter("t2", 60.0).value
        speed = self.declare_parameter("speed", 1.5).value
        self.warp = self.declare_parameter("warp", 1.0).value
        self.timeout = self.declare_parameter("timeout", 600.0).value
        prefix = "/{}/frontseat/".format(platform)
        self.course_pub = self.create_publisher(DesiredCourse, prefix + "desired_course", 10)
        self.helm_pub = self.create_publisher(HelmStateReport, prefix + "helm_state", 10)
        self.create_subscription(NodeStatus, prefix + "node_status", self.on_nav, qos_profile_sensor_data)
        self.create_subscription(InterfaceStatus, prefix + "status", self.on_status, 10)
        self.create_timer(1.0, self.beat)
        self.path = HomeworkPath(t1, t2, speed, log=self.get_logger().info)
        self.throttle = CourseThrottle()
        self.t_start = time.monotonic()
        self.beat()

    def beat(self):
        self.helm_pub.publish(HelmStateReport(state=HelmStateReport.HELM_DRIVE))

    def on_status(self, msg):
        if msg.has_state:
            self.path.on_status(msg.state)

    def on_nav(self, msg):
        if not msg.has_local_fix:
            return
        t = (time.monotonic() - self.t_start) * self.warp
        c = self.path.on_position(msg.local_fix.x, msg.local_fix.y, t)
        if self.throttle.due(c, time.monotonic()):
            # time: seconds since the UNIX epoch, as Goby3's DesiredCourse.time
            self.course_pub.publish(DesiredCourse(
                time=time.time(), has_heading=True, heading=c[0], has_speed=True, speed=c[1],
                has_depth=True, depth=0.0))


def main():
    rclpy.init(args=sys.argv)
    node = FrontseatHelm()
    deadline = time.monotonic() + node.timeout
    interrupted = False
    try:
        while rclpy.ok() and not node.path.done and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.5)
        # rclpy's own SIGINT handler shuts the context down: the loop ends with ok() false.
        interrupted = not rclpy.ok()
    except KeyboardInterrupt:
        interrupted = True
    finally:
        done = node.path.done
        node.destroy_node()
        rclpy.try_shutdown()
    if done:
        return 0
    if interrupted:
        print("helm: interrupted", file=sys.stderr, flush=True)
        return 130
    print("helm: timed out in leg", node.path.leg, file=sys.stderr, flush=True)
    return 1


if __name__ == "__main__":
    sys.exit(main())
