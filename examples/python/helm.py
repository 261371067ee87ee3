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

Exits 0 when the triangle is done, 1 on timeout or when no Zenoh session opens, and 130 on Ctrl-C
(SIGINT) or 143 on SIGTERM (128 + the signal, as a shell reports a process a signal ended): at
any moment once it printed "helm: started" (its first line, on stderr) — importing, opening the
session, flying, closing — with one line "helm: interrupted" and no traceback.
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


# Owned before anything else, the imports first (zenoh's takes a while): a Ctrl-C during them,
# while the session opens, in the loop or as it closes ends the helm the same way; Python's own
# KeyboardInterrupt printed a traceback from wherever it landed. Only the interpreter's start,
# before this line, is Python's; "helm: started" says it is past.
signal.signal(signal.SIGINT, _stop)
signal.signal(signal.SIGTERM, _stop)
print("helm: started", file=sys.stderr, flush=True)

try:
    import argparse  # noqa: E402
    import json  # noqa: E402
    import math  # noqa: E402
    import os  # noqa: E402
    import queue  # noqa: E402
    import secrets  # noqa: E402
    import time  # noqa: E402

    HERE = os.path.dirname(os.path.abspath(__file__))
    sys.path.insert(0, os.environ.get("FRONTSEAT_PY_GEN", os.path.join(HERE, "gen")))

    import zenoh  # noqa: E402
    from google.protobuf.message import DecodeError  # noqa: E402
    from goby.middleware.frontseat import frontseat_pb2 as fs  # noqa: E402
    from goby.middleware.frontseat import frontseat_data_pb2 as fsd  # noqa: E402
except Stopped as e:
    sys.exit(_stopped(e))

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

    try:
        session = open_session(a.connect)
    except zenoh.ZError as e:
        print("helm: no Zenoh session on {}: {}".format(a.connect, e), file=sys.stderr, flush=True)
        return 1
    try:
        # Owned again once the session is open, whatever the zenoh library did with them.
        signal.signal(signal.SIGINT, _stop)
        signal.signal(signal.SIGTERM, _stop)
        return fly(a, session)
    finally:
        # A second Ctrl-C while the session closes must not cut the close short with a traceback.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        session.close()


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
    try:
        code = main()
    except Stopped as e:
        code = _stopped(e)
    sys.exit(code)
