"""The Goby3 course homework path, shared by the ROS 2 helms of this folder (frontseat_helm_node.py
over rclpy, cyclone_helm.py over plain Cyclone DDS): the same decisions as the Python Zenoh helm
(examples/python/helm.py), with no middleware in it.

Once the interface reports COMMAND and a position arrives: 1.5 m/s due east for T1 s, due south
for T2 s, then northwest until the vehicle stops closing on its start. Times are vehicle seconds
(wall seconds times the interface's sim_warp_factor); positions are node_status local_fix metres.
"""

import math

INTERFACE_COMMAND = 3  # frontseat_msgs/InterfaceStatus.INTERFACE_COMMAND
STATE_NAMES = {1: "INTERFACE_STANDBY", 2: "INTERFACE_LISTEN", 3: "INTERFACE_COMMAND",
               4: "INTERFACE_HELM_ERROR", 5: "INTERFACE_FS_ERROR"}
HEADINGS = {"east": 90.0, "south": 180.0, "northwest": 315.0}


class HomeworkPath:
    """Feed it the interface's state and each position; it says what to command and prints the
    same lines as the Zenoh helm ("leg east at t=...", "triangle done: ...")."""

    def __init__(self, t1=60.0, t2=60.0, speed=1.5, log=print):
        self.t1, self.t2, self.speed, self.log = t1, t2, speed, log
        self.leg, self.in_command, self.done = "waiting", False, False
        self.start, self.leg_t0, self.min_d = (0.0, 0.0), 0.0, math.inf

    def on_status(self, state):
        cmd = state == INTERFACE_COMMAND
        if cmd != self.in_command:
            self.log("interface state {}".format(STATE_NAMES.get(state, state)))
        self.in_command = cmd

    def on_position(self, x, y, t):
        """A position (m) at vehicle time t (s): the course (heading deg, speed m/s) to command
        now, or None. After the last leg it returns (315, 0) once and sets `done`."""
        if self.done:
            return None
        pos, nxt = (x, y), None
        if self.leg == "waiting" and self.in_command:
            self.start, nxt = pos, "east"
        elif self.leg == "east" and t - self.leg_t0 >= self.t1:
            nxt = "south"
        elif self.leg == "south" and t - self.leg_t0 >= self.t2:
            nxt = "northwest"
        elif self.leg == "northwest":
            d = math.hypot(pos[0] - self.start[0], pos[1] - self.start[1])
            if d < self.min_d:
                self.min_d = d
            elif t - self.leg_t0 > 10.0 and d > self.min_d + 0.5:
                self.log("triangle done: closest approach {:.1f} m from the start at ({:.1f}, {:.1f})".format(
                    self.min_d, pos[0], pos[1]))
                self.done = True
                return (HEADINGS["northwest"], 0.0)
        if nxt:
            self.log("leg {} at t={:.1f} s, position ({:.1f}, {:.1f})".format(nxt, t, pos[0], pos[1]))
            self.leg, self.leg_t0 = nxt, t
        if self.leg == "waiting":
            return None
        return (HEADINGS[self.leg], self.speed)


class CourseThrottle:
    """When to send a course: at once when it changes, else again every `period` wall seconds.
    Node_status can arrive at 100 Hz (10 Hz warped 10 times); a helm that answered each one would
    pass the gateway's command rate limit ([ros2] max_command_rate_hz) for nothing."""

    def __init__(self, period=0.25):
        self.period, self.last, self.at = period, None, -float("inf")

    def due(self, course, now):
        if course is None:
            return False
        if course != self.last or now - self.at >= self.period:
            self.last, self.at = course, now
            return True
        return False
