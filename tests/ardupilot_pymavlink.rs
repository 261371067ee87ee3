//! The emulator against the reference implementation: `frontseat sim --vehicle ardupilot` on a
//! loopback port, driven by a backseat written with pymavlink from PyPI
//! (`vehicles/ardupilot/python/pymavlink_backseat.py`): it must decode an ArduPilot boat, set
//! GUIDED, arm, see the mode, steer it with a 0x09C7 target and see a bad mask refused in words.

mod common;

use std::time::Duration;

use common::python::Backseat;

#[test]
fn pymavlink_sets_guided_arms_and_steers_the_emulator() {
    let Some(stdout) = (Backseat {
        test: "pymavlink_sets_guided_arms_and_steers_the_emulator",
        import: "pymavlink.mavutil",
        requirements: "vehicles/ardupilot/python/requirements.txt",
        vehicle: "ardupilot",
        warp: "10",
        script: "vehicles/ardupilot/python/pymavlink_backseat.py",
        args: &[],
        bound: Duration::from_secs(90),
    })
    .run() else {
        return;
    };
    for step in [
        "ok heartbeat",
        "ok mode MANUAL",
        "ok EKF ready",
        "ok GUIDED and armed",
        "ok steering",
        "ok refused mask",
    ] {
        assert!(stdout.contains(step), "missing {step:?} in:\n{stdout}");
    }
}
