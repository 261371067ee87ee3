#!/usr/bin/env python3
"""A ROS 2 helm without ROS: the homework path over Eclipse Cyclone DDS (PyPI `cyclonedds`), the
same logic as the rclpy node beside it (both import homework.py), on the same ROS 2 topics, types
and QoS, so it runs where ROS 2 is not installed — here and in CI.

helm_state HELM_DRIVE at 1 Hz on /<platform>/frontseat/helm_state; once the interface reports
COMMAND on /<platform>/frontseat/status, 1.5 m/s due east for T1 s, due south for T2 s, then
northwest until the vehicle stops closing on its start, reading node_status (sensor-data QoS) for
the position; desired_course goes out when it changes and every 0.25 s. Leg times are vehicle seconds: wall seconds times --warp, which must
match the interface's sim_warp_factor. DDS stays on 127.0.0.1 unless CYCLONEDDS_URI is set.

    python3 -m pip install -r examples/ros2/requirements.txt
    python3 examples/ros2/cyclone_helm.py --domain 0 --platform auv1

Exits 0 when the triangle is done, 1 on timeout or when no DDS participant can be made, and 130
on Ctrl-C (143 on SIGTERM) at any moment after "helm: started" (its first line, on stderr), with
one line "helm: interrupted" and no traceback.
"""

import signal
import sys


class Stopped(Exception):
    """Ctrl-C or SIGTERM: the helm ends with 128 + the signal."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


def _stop(signum, frame):
    raise Stopped(signum)


def _stopped(e):
    print("helm: interrupted", file=sys.stderr, flush=True)
    return 128 + e.signum


# Owned before the imports (cyclonedds loads a C library): a Ctrl-C anywhere ends the helm the same way.
signal.signal(signal.SIGINT, _stop)
signal.signal(signal.SIGTERM, _stop)
print("helm: started", file=sys.stderr, flush=True)

try:
    import argparse  # noqa: E402
    import time  # noqa: E402

    import frontseat_ros2_types as T  # noqa: E402
    from homework import CourseThrottle, HomeworkPath  # noqa: E402

    from cyclonedds.core import DDSException, InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState, WaitSet  # noqa: E402
    from cyclonedds.domain import DomainParticipant  # noqa: E402
    from cyclonedds.pub import DataWriter  # noqa: E402
    from cyclonedds.sub import DataReader  # noqa: E402
    from cyclonedds.topic import Topic  # noqa: E402
    from cyclonedds.util import duration  # noqa: E402
except Stopped as e:
    sys.exit(_stopped(e))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--domain", type=int, default=0, help="DDS domain id (ROS_DOMAIN_ID)")
    p.add_argument("--platform", default="auv1", help="the vehicle's name: topics under /<platform>/frontseat/")
    p.add_argument("--t1", type=float, default=60.0, help="east leg, vehicle seconds")
    p.add_argument("--t2", type=float, default=60.0, help="south leg, vehicle seconds")
    p.add_argument("--speed", type=float, default=1.5)
    p.add_argument("--warp", type=float, default=1.0, help="the interface's sim_warp_factor")
    p.add_argument("--timeout", type=float, default=600.0, help="wall seconds")
    a = p.parse_args()

    T.loopback_only()
    try:
        dp = DomainParticipant(a.domain, qos=Qos(Policy.Userdata(data=b"enclave=/;")))
    except DDSException as e:
        print("helm: no DDS participant in domain {}: {}".format(a.domain, e), file=sys.stderr, flush=True)
        return 1
    try:
        return fly(a, dp)
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)


def fly(a, dp):
    def endpoint(kind, name, cls, profile):
        topic = Topic(dp, T.topic_name(a.platform, name), cls)
        return kind(dp, topic, qos=T.ros_qos(profile, cls))

    nav_r = endpoint(DataReader, "node_status", T.NodeStatus, "sensor_data")
    status_r = endpoint(DataReader, "status", T.InterfaceStatus, "default")
    helm_w = endpoint(DataWriter, "helm_state", T.HelmStateReport, "default")
    course_w = endpoint(DataWriter, "desired_course", T.DesiredCourse, "default")
    # Listed in the ROS graph as node /<platform>/cyclone_helm, as rmw would list it.
    gid = lambda e: T.Gid(data=list(e.get_guid().bytes))  # noqa: E731
    disc = DataWriter(dp, Topic(dp, "ros_discovery_info", T.ParticipantEntitiesInfo), qos=T.ros_qos("discovery"))
    disc.write(T.ParticipantEntitiesInfo(gid=gid(dp), node_entities_info_seq=[T.NodeEntitiesInfo(
        node_namespace="/" + a.platform, node_name="cyclone_helm", reader_gid_seq=[gid(nav_r), gid(status_r)],
        writer_gid_seq=[gid(helm_w), gid(course_w)])]))

    waitset = WaitSet(dp)
    any_state = SampleState.Any | ViewState.Any | InstanceState.Any
    for r in (nav_r, status_r):
        waitset.attach(ReadCondition(r, any_state))

    def course(heading, speed):
        course_w.write(T.DesiredCourse(time=time.time(), has_heading=True, heading=heading, has_speed=True,
                                       speed=speed, has_depth=True, depth=0.0))

    path = HomeworkPath(a.t1, a.t2, a.speed, log=lambda line: print(line, flush=True))
    throttle = CourseThrottle()
    t_start = time.monotonic()
    deadline = t_start + a.timeout
    next_beat = 0.0
    while time.monotonic() < deadline:
        now = time.monotonic()
        if now >= next_beat:
            helm_w.write(T.HelmStateReport(state=T.HELM_DRIVE))
            next_beat = now + 1.0
        waitset.wait(duration(seconds=max(0.0, min(next_beat, deadline) - now)))
        for s in status_r.take(N=64):
            if s.sample_info.valid_data and s.has_state:
                path.on_status(s.state)
        for s in nav_r.take(N=64):
            if not (s.sample_info.valid_data and s.has_local_fix):
                continue
            c = path.on_position(s.local_fix.x, s.local_fix.y, (time.monotonic() - t_start) * a.warp)
            if throttle.due(c, time.monotonic()):
                course(*c)
            if path.done:
                course_w.wait_for_acks(duration(seconds=1))  # the stop reaches the vehicle before we leave
                return 0
    print("helm: timed out in leg", path.leg, file=sys.stderr, flush=True)
    return 1


if __name__ == "__main__":
    try:
        code = main()
    except Stopped as e:
        code = _stopped(e)
    sys.exit(code)
