#!/usr/bin/env python3
"""Writes ../fixtures/imcpy_packets.hex: IMC packets encoded by imcpy (the Python bindings of
DUNE's own IMC code, PyPI, see requirements.txt), one `name hex` per line. The codec's table test
decodes each and re-encodes it to the same bytes; the driver's tests replay the vehicle side.

Vehicle side: src 0x00D1 (lauv-simulator-1), dst 0x4F0A (our backseat) or 0xFFFF.
Backseat side: src 0x4F0A, dst 0x00D1. Timestamps fixed so the bytes are reproducible.

    python3 vehicles/dune/python/make_fixtures.py > vehicles/dune/fixtures/imcpy_packets.hex
"""

import math
import sys

import imcpy

from imc_common import desired_speed, desired_z, make, serialize

VEH, US, T = 0x00D1, 0x4F0A, 1700000000.0
LAT, LON = math.radians(41.185), math.radians(-8.7062)


def rows():
    v = dict(src=VEH, dst=0xFFFF, timestamp=T, src_ent=0)
    yield "heartbeat", make(imcpy.Heartbeat, **v)
    yield "announce", make(imcpy.Announce, **v, sys_name="lauv-simulator-1", sys_type=2, owner=0xFFFF,
                           lat=LAT, lon=LON, height=0.0,
                           services="dune://0.0.0.0/uid/1294925553839635/;imc+udp://127.0.0.1:6002/")
    yield "entity_state_normal", make(imcpy.EntityState, **dict(v, src_ent=12), state=1, flags=0,
                                      description="active")
    yield "entity_info_navigation", make(imcpy.EntityInfo, **v, id=12, label="Navigation",
                                         component="Navigation.AUV.Navigation", act_time=0, deact_time=0)
    yield "entity_list", make(imcpy.EntityList, **v, op=1, list="Daemon=0;Navigation=12;GPS=13")
    yield "entity_state_error", make(imcpy.EntityState, **dict(v, src_ent=12), state=3, flags=0,
                                     description="no position fix")
    yield "estimated_state", make(imcpy.EstimatedState, **v, lat=LAT, lon=LON, height=0.0,
                                  x=100.0, y=-50.0, z=2.0, phi=0.01, theta=-0.02, psi=math.radians(90.0),
                                  u=1.5, v=0.0, w=0.0, vx=0.0, vy=1.5, vz=0.0, p=0.0, q=0.0, r=0.0,
                                  depth=2.0, alt=18.5)
    yield "estimated_state_nan", make(imcpy.EstimatedState, **v, lat=float("nan"), lon=LON, psi=0.0,
                                      depth=0.0, alt=-1.0)
    yield "estimated_state_absurd_depth", make(imcpy.EstimatedState, **v, lat=LAT, lon=LON,
                                               depth=1e7, alt=-1.0)
    yield "estimated_state_foreign", make(imcpy.EstimatedState, **dict(v, src=0x0777), lat=LAT,
                                          lon=LON, depth=5.0)
    yield "gps_fix", make(imcpy.GpsFix, **v, validity=0x0004 | 0x0001 | 0x0002, type=3, utc_year=2023,
                          utc_month=11, utc_day=14, utc_time=79200.0, lat=LAT, lon=LON, height=0.0,
                          satellites=9, cog=1.2, sog=1.5, hdop=0.9, vdop=1.1, hacc=2.0, vacc=3.0)
    yield "vs_service", make(imcpy.VehicleState, **v, op_mode=0, error_count=0, error_ents="",
                             maneuver_type=0xFFFF, maneuver_stime=-1.0, maneuver_eta=0xFFFF,
                             control_loops=0, flags=0, last_error="", last_error_time=-1.0)
    yield "vs_boot", make(imcpy.VehicleState, **v, op_mode=5, maneuver_type=0xFFFF, maneuver_eta=0xFFFF)
    yield "vs_calibration", make(imcpy.VehicleState, **v, op_mode=1, maneuver_type=0xFFFF,
                                 maneuver_eta=0xFFFF)
    yield "vs_error", make(imcpy.VehicleState, **v, op_mode=2, error_count=1, error_ents="GPS",
                           maneuver_type=0xFFFF, maneuver_eta=0xFFFF, last_error="GPS: no fix",
                           last_error_time=T - 1.0)
    yield "vs_maneuver_followref", make(imcpy.VehicleState, **v, op_mode=3, maneuver_type=478,
                                        maneuver_stime=T - 5.0, maneuver_eta=0xFFFF,
                                        control_loops=0x4C9)
    yield "vs_maneuver_goto", make(imcpy.VehicleState, **v, op_mode=3, maneuver_type=450,
                                   maneuver_stime=T - 5.0, maneuver_eta=120, control_loops=0x4C9)
    yield "vs_external", make(imcpy.VehicleState, **v, op_mode=4, maneuver_type=0xFFFF,
                              maneuver_eta=0xFFFF, control_loops=0xC8)
    yield "pcs_ready", make(imcpy.PlanControlState, **v, state=1, plan_id="", plan_eta=-1,
                            plan_progress=-1.0, man_id="", man_type=0xFFFF, man_eta=-1, last_outcome=0)
    yield "pcs_executing", make(imcpy.PlanControlState, **v, state=3, plan_id="frontseat",
                                plan_eta=-1, plan_progress=-1.0, man_id="1", man_type=478, man_eta=-1,
                                last_outcome=0)
    yield "pcs_executing_other", make(imcpy.PlanControlState, **v, state=3, plan_id="survey",
                                      plan_eta=600, plan_progress=12.5, man_id="goto1", man_type=450,
                                      man_eta=60, last_outcome=0)
    ref = make(imcpy.Reference, US, VEH, T, flags=0x27, lat=LAT, lon=LON, radius=0.0)
    ref.speed = desired_speed(1.5)
    ref.z = desired_z(2.0)
    yield "follow_ref_state_goto", make(imcpy.FollowRefState, **v, control_src=US, control_ent=0xFF,
                                        reference=ref, state=2, proximity=0x01)
    yield "follow_ref_state_timeout", make(imcpy.FollowRefState, **v, control_src=US,
                                           control_ent=0xFF, state=6, proximity=0x01)
    yield "pc_success_loaded", make(imcpy.PlanControl, **dict(v, dst=US), type=1, op=0, request_id=7,
                                    plan_id="frontseat", flags=0, info="plan loaded")
    yield "pc_failure_timeout", make(imcpy.PlanControl, **dict(v, dst=US), type=2, op=0, request_id=7,
                                     plan_id="frontseat", flags=0,
                                     info="FollowReference maneuver error: reference source timed out")
    # Backseat side (what our driver sends).
    b = dict(src=US, dst=VEH, timestamp=T, src_ent=0xFF)
    start = make(imcpy.PlanControl, **b, type=0, op=0, request_id=7, plan_id="frontseat", flags=0, info="")
    start.arg = make(imcpy.FollowReference, 0xFFFF, 0xFFFF, 0.0, control_src=US, control_ent=0xFF,
                     timeout=10.0, loiter_radius=0.0, altitude_interval=0.0)
    yield "pc_start_followref", start
    yield "reference", make(imcpy.Reference, **b, flags=0x27, lat=ref.lat, lon=ref.lon, radius=0.0)
    r = make(imcpy.Reference, **b, flags=0x27, lat=LAT + 1e-4, lon=LON + 2e-4, radius=0.0)
    r.speed = desired_speed(1.5)
    r.z = desired_z(2.0)
    yield "reference_full", r
    yield "reference_mandone", make(imcpy.Reference, **b, flags=0x80, lat=LAT, lon=LON, radius=0.0)
    yield "pc_stop", make(imcpy.PlanControl, **b, type=0, op=1, request_id=8, plan_id="frontseat",
                          flags=0, info="")
    yield "abort", make(imcpy.Abort, **b)
    # A plan wrapped in a PlanSpecification (message lists): both forms start the maneuver.
    spec = imcpy.PlanSpecification()
    spec.plan_id = "frontseat"
    spec.start_man_id = "1"
    pm = imcpy.PlanManeuver()
    pm.maneuver_id = "1"
    pm.data = make(imcpy.FollowReference, 0xFFFF, 0xFFFF, 0.0, control_src=US, control_ent=0xFF,
                   timeout=10.0, loiter_radius=0.0, altitude_interval=0.0)
    spec.maneuvers.append(pm)
    start2 = make(imcpy.PlanControl, **b, type=0, op=0, request_id=9, plan_id="frontseat", flags=0, info="")
    start2.arg = spec
    yield "pc_start_spec", start2


def main():
    out = sys.stdout
    out.write(f"# IMC packets encoded by imcpy {getattr(imcpy, '__version__', '1.1.2')} "
              "(PyPI; IMC 5.4.30) with vehicles/dune/python/make_fixtures.py; "
              "`name hex` per line.\n")
    for name, m in rows():
        out.write(f"{name} {serialize(m).hex()}\n")


if __name__ == "__main__":
    main()
