//! The Sub emulator against the reference implementation: `frontseat sim --vehicle ardusub` on a
//! loopback port, driven by a backseat written with pymavlink from PyPI
//! (`vehicles/ardupilot/python/pymavlink_sub_backseat.py`) doing what ardusub.md's SITL runs did:
//! a submarine booting in MANUAL 19, GUIDED 4 and armed, a dive to 5 m heading 90° at 0.5 m/s by
//! 0x09C0 LOCAL_NED targets, an acceleration-bearing target dropped, GLOBAL_INT's yaw ignored,
//! and a failsafe disarming it when its heartbeats and MANUAL_CONTROL stop.

mod common;

use std::time::Duration;

use common::python::Backseat;

#[test]
fn pymavlink_dives_and_steers_the_sub_emulator() {
    let warp = "5";
    let Some(stdout) = (Backseat {
        test: "pymavlink_dives_and_steers_the_sub_emulator",
        import: "pymavlink.mavutil",
        requirements: "vehicles/ardupilot/python/requirements.txt",
        vehicle: "ardusub",
        warp,
        script: "vehicles/ardupilot/python/pymavlink_sub_backseat.py",
        args: &[warp],
        bound: Duration::from_secs(150),
    })
    .run() else {
        return;
    };
    for step in [
        "ok heartbeat: ArduSub submarine in MANUAL 19",
        "ok GUIDED 4 and armed",
        "ok dived and steering",
        "ok acceleration target dropped",
        "ok GLOBAL_INT yaw ignored, depth followed",
        "ok failsafe disarmed",
    ] {
        assert!(stdout.contains(step), "missing {step:?} in:\n{stdout}");
    }
}
