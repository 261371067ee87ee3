#!/usr/bin/env python3
"""The ROS 2 side of the gateway's tests, with no ROS installed: Eclipse Cyclone DDS (PyPI
`cyclonedds`, the DDS of rmw_cyclonedds_cpp) with ROS 2's topic names, type names, CDR and QoS,
the types from examples/ros2/frontseat_ros2_types.py. Every mode is bounded by --seconds, prints
one JSON object per line on stdout (flushed), exits 0; errors go to stderr with exit 2.

  listen --domain D --namespace NS --seconds S
      Subscribes /NS/frontseat/{odom,fix,node_status,status,command_response,diagnostics} and
      /diagnostics; per sample: {"topic": "/NS/frontseat/odom", "type": "nav_msgs/msg/Odometry",
      "data": {...fields...}}.
  helm --domain D --namespace NS --heading H --speed V [--depth Z] --seconds S
      Publishes helm_state (HELM_DRIVE, the helm running) and desired_course (heading H deg,
      speed V m/s, depth Z m when given, else has_depth false) at 2 Hz, reliable; prints the
      node_status samples it receives as listen does.
  flood --domain D --namespace NS --seconds S [--heading H --speed V]
      Writes desired_course as fast as it can, every 10th sample a malformed one under the same
      DDS type name from a second participant: too short (only `time`), oversize (`time` then a
      64 KiB sequence), a bool byte that is 2, or present fields NaN/infinite. Last line:
      {"sent": all samples written, "valid": N, "malformed": {kind: n}}.
  graph --domain D --seconds S
      Prints what `ros2 node list` / `ros2 topic list` are built from: {"node": "/ns/name",
      "namespace", "name", "gid", "readers", "writers"} per node in a ros_discovery_info sample
      (printed again when a participant's list changes), {"topic": ROS name, "type": ROS type,
      "dds_topic", "dds_type", "endpoint": "writer"|"reader", "reliable", "typehash"} per
      discovered endpoint on an `rt/` topic, {"participant": guid, "user_data"} per participant;
      its own participant left out.

  bench --domain D --namespace NS --seconds S
      Rows C1/C2 of `frontseat bench`. Drives helm_state HELM_DRIVE at 10 Hz; per Odometry
      sample {"odom_z": z, "ns": t}; on a stdin line "courses N RATE", writes N desired_course
      (depth i+1, heading 90, speed 1.5) at RATE Hz, each {"course": i, "ns": t} stamped just
      before the write, then {"courses_done": N}. t is CLOCK_MONOTONIC in ns (time.monotonic_ns,
      the clock Rust's Instant reads on Linux), so the bench compares it with its own stamps.
      Ends at S seconds or when stdin closes.

JSON: NaN and infinities are null; a char[N]/byte array is a list of numbers. QoS as rmw sets
it: subscriptions to odom/fix/node_status sensor data (best effort, keep last 5), the rest
reliable keep last 10, every endpoint's USER_DATA `typehash=RIHS01_...;`, the participant's
`enclave=/;`, and each mode announces itself as node /ros2_peer_<mode> on ros_discovery_info
(reliable, transient local, keep last 1; read keep-all). DDS stays on 127.0.0.1 with no multicast
(CYCLONEDDS_URI, set before the first participant is made, unless the caller set it).
"""

import argparse
import json
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "examples", "ros2"))

LISTEN = ["odom", "fix", "node_status", "status", "command_response", "diagnostics", "/diagnostics"]


def emit(obj):
    sys.stdout.write(json.dumps(obj, allow_nan=False) + "\n")
    sys.stdout.flush()


def parse_args(argv):
    p = argparse.ArgumentParser(description="Cyclone DDS as a ROS 2 peer of the frontseat gateway")
    sub = p.add_subparsers(dest="mode", required=True)
    for mode in ("listen", "helm", "flood", "graph", "bench"):
        m = sub.add_parser(mode)
        m.add_argument("--domain", type=int, required=True)
        m.add_argument("--seconds", type=float, required=True)
        if mode != "graph":
            m.add_argument("--namespace", required=True)
        if mode == "helm":
            m.add_argument("--heading", type=float, required=True)
            m.add_argument("--speed", type=float, required=True)
            m.add_argument("--depth", type=float)
        if mode == "flood":
            m.add_argument("--heading", type=float, default=45.0)
            m.add_argument("--speed", type=float, default=1.0)
    a = p.parse_args(argv)
    if not 0 <= a.domain <= 232:
        p.error("--domain must be 0-232 (DDS ports 7400 + 250 x domain)")
    if not (a.seconds > 0 and math.isfinite(a.seconds)):
        p.error("--seconds must be a positive number")
    return a


class Peer:
    """One DDS participant dressed as a ROS 2 node: endpoints carry their type hash and are
    listed in a ros_discovery_info sample, as rmw does."""

    def __init__(self, domain, node_name):
        from cyclonedds.core import Policy, Qos
        from cyclonedds.domain import DomainParticipant

        self.dp = DomainParticipant(domain, qos=Qos(Policy.Userdata(data=b"enclave=/;")))
        self.node_name = node_name
        self.readers, self.writers = [], []
        self.topics = {}
        self._disc = self.writer_raw("ros_discovery_info", T.ParticipantEntitiesInfo, T.ros_qos("discovery"))

    def topic(self, name, cls):
        from cyclonedds.topic import Topic

        if name not in self.topics:
            self.topics[name] = Topic(self.dp, name, cls)
        return self.topics[name]

    def writer_raw(self, name, cls, qos):
        from cyclonedds.pub import DataWriter

        return DataWriter(self.dp, self.topic(name, cls), qos=qos)

    def writer(self, ns, name, cls, profile="default"):
        w = self.writer_raw(T.topic_name(ns, name), cls, T.ros_qos(profile, cls))
        self.writers.append(w)
        return w

    def reader(self, ns, name, cls, profile):
        from cyclonedds.sub import DataReader

        r = DataReader(self.dp, self.topic(T.topic_name(ns, name), cls), qos=T.ros_qos(profile, cls))
        self.readers.append(r)
        return r

    def announce(self):
        gid = lambda e: T.Gid(data=list(e.get_guid().bytes))  # noqa: E731
        self._disc.write(T.ParticipantEntitiesInfo(gid=gid(self.dp), node_entities_info_seq=[T.NodeEntitiesInfo(
            node_namespace="/", node_name=self.node_name,
            reader_gid_seq=[gid(r) for r in self.readers], writer_gid_seq=[gid(w) for w in self.writers])]))


class Inbox:
    """Readers under one waitset: `poll(until)` yields (reader, sample) for valid data only (a
    writer's unregister arrives as an invalid sample)."""

    def __init__(self, dp, readers):
        from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet

        self.ws = WaitSet(dp)
        self.readers = readers
        self.conds = []
        for r in readers:
            c = ReadCondition(r, SampleState.Any | ViewState.Any | InstanceState.Any)
            self.ws.attach(c)
            self.conds.append(c)

    def poll(self, until):
        from cyclonedds.util import duration

        left = until - time.monotonic()
        if left > 0:
            self.ws.wait(duration(seconds=min(left, 0.5)))
        for r in self.readers:
            for s in r.take(N=256):
                if s.sample_info.valid_data:
                    yield r, s


def run_listen(a, names, peer, until, between=None):
    readers = {}
    for name in names:
        ros = dict((n, (ty, prof)) for n, ty, prof in T.PUBLISHED)
        ty, prof = ros.get(name.lstrip("/"), ros["diagnostics"])
        r = peer.reader(a.namespace, name, T.CLASSES[ty], prof)
        readers[r] = (T.ros_topic(a.namespace, name), ty)
    peer.announce()
    inbox = Inbox(peer.dp, list(readers))
    while time.monotonic() < until:
        for r, s in inbox.poll(until if between is None else min(until, between())):
            topic, ty = readers[r]
            emit({"topic": topic, "type": ty, "data": T.to_json(s)})


def mode_listen(a):
    run_listen(a, LISTEN, Peer(a.domain, "ros2_peer_listen"), time.monotonic() + a.seconds)


def mode_helm(a):
    peer = Peer(a.domain, "ros2_peer_helm")
    helm_w = peer.writer(a.namespace, "helm_state", T.HelmStateReport)
    course_w = peer.writer(a.namespace, "desired_course", T.DesiredCourse)
    next_at = [time.monotonic()]

    def between():
        now = time.monotonic()
        if now >= next_at[0]:
            helm_w.write(T.HelmStateReport(state=T.HELM_DRIVE))
            course_w.write(T.DesiredCourse(
                time=time.time(), has_heading=True, heading=a.heading, has_speed=True, speed=a.speed,
                has_depth=a.depth is not None, depth=a.depth if a.depth is not None else 0.0))
            next_at[0] = max(next_at[0] + 0.5, now)
        return next_at[0]

    run_listen(a, ["node_status"], peer, time.monotonic() + a.seconds, between)


def malformed_types():
    """Structs that carry DesiredCourse's DDS type name with another shape: the gateway sees
    the right topic and type name, and bytes that do not decode as a DesiredCourse."""
    import dataclasses

    import cyclonedds.idl.types as t
    from cyclonedds.idl import IdlStruct

    name = T.dds_type_name("frontseat_msgs/msg/DesiredCourse")

    @dataclasses.dataclass
    class Short(IdlStruct, typename=name):
        time: t.float64 = 0.0

    @dataclasses.dataclass
    class Oversize(IdlStruct, typename=name):
        time: t.float64 = 0.0
        junk: t.sequence[t.uint8] = dataclasses.field(default_factory=list)

    @dataclasses.dataclass
    class BadBool(IdlStruct, typename=name):
        time: t.float64 = 0.0
        has_heading: t.uint8 = 2
        heading: t.float64 = 90.0

    return Short, Oversize, BadBool


def mode_flood(a):
    peer = Peer(a.domain, "ros2_peer_flood")
    course_w = peer.writer(a.namespace, "desired_course", T.DesiredCourse)
    peer.announce()
    # A second participant: one participant cannot hold one topic name with two types.
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.pub import DataWriter
    from cyclonedds.topic import Topic

    bad_dp = DomainParticipant(a.domain)
    Short, Oversize, BadBool = malformed_types()
    topic = T.topic_name(a.namespace, "desired_course")
    qos = T.ros_qos("default")
    bad = {
        "short": (DataWriter(bad_dp, Topic(bad_dp, topic, Short), qos=qos), lambda: Short(time=time.time())),
        "oversize": (DataWriter(bad_dp, Topic(bad_dp, topic, Oversize), qos=qos),
                     lambda: Oversize(time=time.time(), junk=[7] * (1 << 16))),
        "bad_bool": (DataWriter(bad_dp, Topic(bad_dp, topic, BadBool), qos=qos), lambda: BadBool(time=time.time())),
        "nan": (course_w, lambda: T.DesiredCourse(time=time.time(), has_heading=True, heading=float("nan"),
                                                 has_speed=True, speed=float("inf"))),
    }
    kinds = list(bad)
    counts = {k: 0 for k in kinds}
    # The oversize sample costs 64 KiB each time: one in 40, not one in 10.
    order = ["short", "bad_bool", "nan", "oversize"] + ["short", "bad_bool", "nan"] * 3
    valid, i = 0, 0
    until = time.monotonic() + a.seconds
    while time.monotonic() < until:
        for _ in range(9):
            course_w.write(T.DesiredCourse(time=time.time(), has_heading=True, heading=a.heading,
                                           has_speed=True, speed=a.speed))
            valid += 1
        kind = order[i % len(order)]
        w, make = bad[kind]
        w.write(make())
        counts[kind] += 1
        i += 1
    emit({"sent": valid + sum(counts.values()), "valid": valid, "malformed": counts})


def mode_graph(a):
    from cyclonedds.builtin import (BuiltinDataReader, BuiltinTopicDcpsParticipant, BuiltinTopicDcpsPublication,
                                    BuiltinTopicDcpsSubscription)
    from cyclonedds.core import Policy
    from cyclonedds.sub import DataReader

    peer = Peer(a.domain, "ros2_peer_graph")
    disc = DataReader(peer.dp, peer.topic("ros_discovery_info", T.ParticipantEntitiesInfo),
                      qos=T.ros_qos("discovery_reader"))
    peer.announce()
    parts = BuiltinDataReader(peer.dp, BuiltinTopicDcpsParticipant)
    pubs = BuiltinDataReader(peer.dp, BuiltinTopicDcpsPublication)
    subs = BuiltinDataReader(peer.dp, BuiltinTopicDcpsSubscription)
    me = peer.dp.guid
    inbox = Inbox(peer.dp, [disc])
    seen, nodes = set(), {}

    def user_data(qos):
        return qos[Policy.Userdata].data.decode("utf-8", "replace") if Policy.Userdata in qos else None

    until = time.monotonic() + a.seconds
    while time.monotonic() < until:
        for _, s in inbox.poll(until):
            g = bytes(s.gid.data).hex()
            if bytes(s.gid.data) == me.bytes:
                continue
            listed = [(n.node_namespace, n.node_name, [bytes(x.data).hex() for x in n.reader_gid_seq],
                       [bytes(x.data).hex() for x in n.writer_gid_seq]) for n in s.node_entities_info_seq]
            if nodes.get(g) == listed:
                continue
            nodes[g] = listed
            for ns, name, rd, wr in listed:
                full = ns.rstrip("/") + "/" + name
                emit({"node": full, "namespace": ns, "name": name, "gid": g, "readers": rd, "writers": wr})
        for p in parts.take(N=256):
            if p.key != me and ("p", p.key) not in seen:
                seen.add(("p", p.key))
                emit({"participant": p.key.bytes.hex(), "user_data": user_data(p.qos)})
        for kind, rd in (("writer", pubs), ("reader", subs)):
            for e in rd.take(N=256):
                if e.participant_key == me or not (e.topic_name or "").startswith("rt/") or (kind, e.key) in seen:
                    continue
                seen.add((kind, e.key))
                ud = user_data(e.qos) or ""
                th = next((f[len("typehash="):] for f in ud.split(";") if f.startswith("typehash=")), None)
                reliable = None
                if Policy.Reliability in e.qos:
                    reliable = isinstance(e.qos[Policy.Reliability], Policy.Reliability.Reliable)
                emit({"topic": e.topic_name[2:], "type": T.ros_type_name(e.type_name), "dds_topic": e.topic_name,
                      "dds_type": e.type_name, "endpoint": kind, "reliable": reliable, "typehash": th})


def mode_bench(a):
    import threading

    peer = Peer(a.domain, "ros2_peer_bench")
    helm_w = peer.writer(a.namespace, "helm_state", T.HelmStateReport)
    course_w = peer.writer(a.namespace, "desired_course", T.DesiredCourse)
    odom_r = peer.reader(a.namespace, "odom", T.CLASSES["nav_msgs/msg/Odometry"], "sensor_data")
    peer.announce()
    lock = threading.Lock()
    done = threading.Event()

    def out(obj):
        with lock:
            emit(obj)

    def courses():
        for line in sys.stdin:
            words = line.split()
            if len(words) != 3 or words[0] != "courses":
                continue
            n, period = int(words[1]), 1.0 / max(float(words[2]), 1e-3)
            start = time.monotonic()
            for i in range(n):
                wait = start + i * period - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
                t = time.monotonic_ns()
                course_w.write(T.DesiredCourse(time=time.time(), has_heading=True, heading=90.0,
                                               has_speed=True, speed=1.5, has_depth=True, depth=float(i + 1)))
                out({"course": i, "ns": t})
            out({"courses_done": n})
        done.set()

    threading.Thread(target=courses, daemon=True).start()
    inbox = Inbox(peer.dp, [odom_r])
    until = time.monotonic() + a.seconds
    next_helm = time.monotonic()
    out({"ready": True})
    while time.monotonic() < until and not done.is_set():
        now = time.monotonic()
        if now >= next_helm:
            helm_w.write(T.HelmStateReport(state=T.HELM_DRIVE))
            next_helm = max(next_helm + 0.1, now)
        for _, sample in inbox.poll(min(until, next_helm)):
            out({"odom_z": sample.pose.pose.position.z, "ns": time.monotonic_ns()})


def main(argv):
    a = parse_args(argv)
    global T
    try:
        import frontseat_ros2_types as T  # noqa: N812

        T.loopback_only()  # before the first participant: Cyclone reads CYCLONEDDS_URI then
        {"listen": mode_listen, "helm": mode_helm, "flood": mode_flood, "graph": mode_graph,
         "bench": mode_bench}[a.mode](a)
    except KeyboardInterrupt:
        return 130
    except Exception as e:  # noqa: BLE001 (any failure is one line and exit 2)
        print("ros2_peer: {}: {}".format(type(e).__name__, e), file=sys.stderr, flush=True)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
