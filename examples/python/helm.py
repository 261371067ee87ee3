#!/usr/bin/env python3
"""A Python helm for `frontseat interface`, over Zenoh only: the Goby3 course homework.

helm_state DRIVE at 1 Hz; once the interface reports COMMAND, 1.5 m/s due east for T1 s, due south
for T2 s, then northwest until the vehicle stops closing on its start, reading node_status for the
position. Leg times are vehicle seconds: wall seconds times --warp, which must match the
interface's sim_warp_factor when the simulator runs warped. Each desired_course carries a fresh W3C
traceparent in the Zenoh attachment.

    pip install -r examples/python/requirements.txt
    examples/python/gen_protos.sh
    python3 examples/python/helm.py --connect tcp/127.0.0.1:7447 --platform auv1

Exits 0 when the triangle is done, 1 on timeout.
"""

import argparse
import json
import math
import os
import queue
import secrets
import signal
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.environ.get("FRONTSEAT_PY_GEN", os.path.join(HERE, "gen")))

import zenoh  # noqa: E402
from google.protobuf.message import DecodeError  # noqa: E402
from goby.middleware.frontseat import frontseat_pb2 as fs  # noqa: E402
from goby.middleware.frontseat import frontseat_data_pb2 as fsd  # noqa: E402

PREFIX = "goby/middleware/frontseat/"


def protobuf_encoding(message_class):
    # The gateway's convention: the encoding names the message type.
    return zenoh.Encoding("application/protobuf;" + message_class.DESCRIPTOR.full_name)


def traceparent():
    return "00-{}-{}-01".format(secrets.token_hex(16), secrets.token_hex(8))


def open_session(connect):
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps("client"))
    conf.insert_json5("connect/endpoints", json.dumps([connect]))
    conf.insert_json5("listen/endpoints", "[]")
    conf.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(conf)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--connect", default="tcp/127.0.0.1:7447")
    p.add_argument("--platform", default="auv1")
    p.add_argument("--t1", type=float, default=60.0, help="east leg, vehicle seconds")
    p.add_argument("--t2", type=float, default=60.0, help="south leg, vehicle seconds")
    p.add_argument("--speed", type=float, default=1.5)
    p.add_argument("--warp", type=float, default=1.0, help="the interface's sim_warp_factor")
    p.add_argument("--timeout", type=float, default=600.0, help="wall seconds")
    a = p.parse_args()

    session = open_session(a.connect)
    # The zenoh library takes over SIGINT when it opens a session, and a session left open keeps
    # the interpreter from exiting: own both signals again and close the session on the way out.
    signal.signal(signal.SIGINT, _interrupted)
    signal.signal(signal.SIGTERM, _interrupted)
    try:
        return fly(a, session)
    except KeyboardInterrupt:
        print("helm: interrupted", file=sys.stderr, flush=True)
        return 130
    finally:
        session.close()


def _interrupted(signum, frame):
    raise KeyboardInterrupt


def fly(a, session):
    key = lambda name: "{}/{}{}".format(a.platform, PREFIX, name)  # noqa: E731
    inbox = queue.Queue(maxsize=10000)

    def on(kind, cls):
        def cb(sample):
            msg = cls()
            try:
                msg.ParseFromString(bytes(sample.payload.to_bytes()))
            except DecodeError:
                return  # bad bytes from the network: skip
            try:
                inbox.put_nowait((kind, msg))
            except queue.Full:
                pass

        return cb

    subs = [
        session.declare_subscriber(key("node_status"), on("nav", fsd.NodeStatus)),
        session.declare_subscriber(key("status"), on("status", fs.InterfaceStatus)),
    ]
    helm_pub = session.declare_publisher(key("helm_state"), encoding=protobuf_encoding(fs.HelmStateReport))
    course_pub = session.declare_publisher(key("desired_course"), encoding=protobuf_encoding(fs.DesiredCourse))
    drive = fs.HelmStateReport(state=fs.HELM_DRIVE).SerializeToString()

    def course(t, heading, speed):
        dc = fs.DesiredCourse(time=time.time(), heading=heading, speed=speed, depth=0.0)
        course_pub.put(dc.SerializeToString(), attachment=traceparent())

    t_start = time.monotonic()
    deadline = t_start + a.timeout
    next_beat = 0.0
    leg, in_command = "waiting", False
    start, leg_t0, min_d = (0.0, 0.0), 0.0, math.inf
    headings = {"east": 90.0, "south": 180.0, "northwest": 315.0}
    while time.monotonic() < deadline:
        now = time.monotonic()
        if now >= next_beat:
            helm_pub.put(drive)
            next_beat = now + 1.0
        try:
            kind, msg = inbox.get(timeout=max(0.0, min(next_beat, deadline) - now))
        except queue.Empty:
            continue
        if kind == "status":
            cmd = msg.state == fs.INTERFACE_COMMAND
            if cmd != in_command:
                print("interface state", fs.InterfaceState.Name(msg.state), flush=True)
            in_command = cmd
            continue
        if not msg.HasField("local_fix"):
            continue
        pos, t = (msg.local_fix.x, msg.local_fix.y), (time.monotonic() - t_start) * a.warp
        nxt = None
        if leg == "waiting" and in_command:
            start, nxt = pos, "east"
        elif leg == "east" and t - leg_t0 >= a.t1:
            nxt = "south"
        elif leg == "south" and t - leg_t0 >= a.t2:
            nxt = "northwest"
        elif leg == "northwest":
            d = math.hypot(pos[0] - start[0], pos[1] - start[1])
            if d < min_d:
                min_d = d
            elif t - leg_t0 > 10.0 and d > min_d + 0.5:
                print(
                    "triangle done: closest approach {:.1f} m from the start at ({:.1f}, {:.1f})".format(
                        min_d, pos[0], pos[1]
                    ),
                    flush=True,
                )
                course(t, 315.0, 0.0)
                for s in subs:
                    s.undeclare()
                return 0
        if nxt:
            print("leg {} at t={:.1f} s, position ({:.1f}, {:.1f})".format(nxt, t, pos[0], pos[1]), flush=True)
            leg, leg_t0 = nxt, t
        if leg != "waiting":
            course(t, headings[leg], a.speed)
    print("helm: timed out in leg", leg, file=sys.stderr, flush=True)
    return 1


if __name__ == "__main__":
    sys.exit(main())
