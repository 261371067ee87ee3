#!/usr/bin/env python3
"""A backseat written with imcpy (DUNE's own IMC code, PyPI) against `frontseat sim --vehicle
dune`, as LSTS's own backseat does it: TCP to the BackSeat port, learn the vehicle id from the
first VehicleState, wait for SERVICE, PlanControl START with FollowReference (control_src = our
id), then a Reference per second toward a point ahead on heading 90 at 1.5 m/s and 2 m depth;
check that EstimatedState moves that way; MANDONE ends the plan; then a second plan left without
References must time out into SERVICE. Prints `ok …` per step and PASS. Bounded to 120 s of wall
time (the emulator runs at a warp the test chooses)."""

import math
import socket
import sys
import time

import imcpy

from imc_common import Cutter, desired_speed, desired_z, displace, make, serialize

US = 0x4F0B
DEADLINE = time.time() + 120


def fail(why):
    print(f"FAIL {why}", flush=True)
    sys.exit(1)


class Link:
    def __init__(self, addr):
        host, port = addr.rsplit(":", 1)
        self.s = socket.create_connection((host, int(port)), timeout=5)
        self.s.settimeout(0.5)
        self.cut = Cutter()
        self.vehicle = None
        self.es = None
        self.vs = None
        self.seen = []

    def pump(self):
        if time.time() > DEADLINE:
            fail("out of time")
        try:
            data = self.s.recv(65536)
        except socket.timeout:
            return []
        if not data:
            fail("emulator closed the connection")
        msgs = self.cut.feed(data)
        for m in msgs:
            if isinstance(m, imcpy.VehicleState):
                if self.vehicle is None:
                    self.vehicle = m.src
                self.vs = m
            elif isinstance(m, imcpy.EstimatedState):
                self.es = m
            self.seen.append(m)
        return msgs

    def wait(self, pred, what, sim_budget_wall=60):
        end = time.time() + sim_budget_wall
        while time.time() < end:
            for m in self.pump():
                if pred(m):
                    return m
        fail(f"no {what}")

    def send(self, m):
        self.s.sendall(serialize(m))


def position(es):
    lat, lon = displace(es.lat, es.lon, es.x, es.y)
    return lat, lon


def main():
    link = Link(sys.argv[1])
    vs = link.wait(lambda m: isinstance(m, imcpy.VehicleState), "VehicleState")
    print(f"ok VehicleState from {vs.src:#06x}", flush=True)
    link.wait(lambda m: isinstance(m, imcpy.EstimatedState), "EstimatedState")
    es = link.es
    if not (abs(es.lat) < math.pi / 2 and abs(es.lon) <= math.pi and es.alt > 0 and es.depth == 0.0
            and int(link.vs.op_mode) in (0, 5)):
        fail(f"EstimatedState does not decode as an LAUV near its start: {es}")
    print("ok EstimatedState decodes", flush=True)
    link.wait(lambda m: isinstance(m, imcpy.VehicleState) and int(m.op_mode) == 0, "SERVICE")
    print("ok SERVICE", flush=True)

    def start(request_id, timeout):
        pc = make(imcpy.PlanControl, US, link.vehicle, time.time(), type=0, op=0,
                  request_id=request_id, plan_id="imcpy", flags=0, info="")
        pc.arg = make(imcpy.FollowReference, 0xFFFF, 0xFFFF, 0.0, control_src=US, control_ent=0xFF,
                      timeout=timeout, loiter_radius=0.0, altitude_interval=0.0)
        link.send(pc)
        link.wait(lambda m: isinstance(m, imcpy.PlanControl) and m.src == link.vehicle
                  and int(m.type) == 1 and "executing" in m.info, "PlanControl SUCCESS executing")
        link.wait(lambda m: isinstance(m, imcpy.VehicleState) and int(m.op_mode) == 3
                  and m.maneuver_type == 478, "VehicleState MANEUVER FollowReference")

    start(1, 5.0)
    print("ok MANEUVER 478", flush=True)

    def reference():
        lat, lon = position(link.es)
        plat, plon = displace(lat, lon, 0.0, 300.0)  # 300 m east
        r = make(imcpy.Reference, US, link.vehicle, time.time(), flags=0x27, lat=plat, lon=plon,
                 radius=0.0)
        r.speed = desired_speed(1.5)
        r.z = desired_z(2.0)
        link.send(r)

    # Steer east at 2 m until heading and depth settle (sim time runs at the test's warp).
    settled = False
    last_ref = 0.0
    t0 = link.es.timestamp
    while not settled:
        link.pump()
        now = link.es.timestamp
        if now - last_ref >= 1.0:
            reference()
            last_ref = now
        psi = math.degrees(link.es.psi) % 360.0
        if abs(psi - 90.0) < 1.0 and abs(link.es.depth - 2.0) < 0.3 and link.es.u > 1.0:
            settled = True
        if now - t0 > 120:
            fail(f"did not settle: psi {psi}, depth {link.es.depth}, u {link.es.u}")
    print(f"ok steering psi 90 depth 2 in {link.es.timestamp - t0:.1f} s sim", flush=True)
    if not any(isinstance(m, imcpy.FollowRefState) and m.control_src == US for m in link.seen):
        fail("no FollowRefState for our References")
    print("ok FollowRefState", flush=True)

    lat, lon = position(link.es)
    done = make(imcpy.Reference, US, link.vehicle, time.time(), flags=0x80, lat=lat, lon=lon, radius=0.0)
    link.send(done)
    link.wait(lambda m: isinstance(m, imcpy.PlanControl) and m.src == link.vehicle
              and "completed" in m.info, "plan completed")
    link.wait(lambda m: isinstance(m, imcpy.VehicleState) and int(m.op_mode) == 0, "SERVICE after MANDONE")
    print("ok MANDONE", flush=True)

    # No References: the maneuver's own timeout is the watchdog.
    start(2, 3.0)
    f = link.wait(lambda m: isinstance(m, imcpy.PlanControl) and m.src == link.vehicle
                  and int(m.type) == 2, "PlanControl FAILURE on timeout")
    if "timed out" not in f.info:
        fail(f"timeout reply says {f.info!r}")
    vs = link.wait(lambda m: isinstance(m, imcpy.VehicleState), "VehicleState after timeout")
    if int(vs.op_mode) != 0 or vs.control_loops != 0:
        fail(f"after the timeout: op_mode {vs.op_mode} loops {vs.control_loops:#x}")
    print("ok timeout → SERVICE, loops 0", flush=True)
    print("PASS", flush=True)


if __name__ == "__main__":
    main()
