//! The emulator against the reference implementation: `frontseat sim --vehicle dune` on a
//! loopback port, driven by a backseat written with imcpy from PyPI (DUNE's own IMC code;
//! `vehicles/dune/python/imcpy_backseat.py`): it must decode our EstimatedState and VehicleState,
//! and its PlanControl + FollowReference + References must move the emulated LAUV (heading 90,
//! 2 m depth), MANDONE must end the plan, and a plan left without References must time out.

mod common;

use std::time::Duration;

use common::python::Backseat;

#[test]
fn imcpy_decodes_and_steers_the_dune_emulator() {
    let Some(stdout) = (Backseat {
        test: "imcpy_decodes_and_steers_the_dune_emulator",
        import: "imcpy",
        requirements: "vehicles/dune/python/requirements.txt",
        vehicle: "dune",
        warp: "10",
        script: "vehicles/dune/python/imcpy_backseat.py",
        args: &[],
        bound: Duration::from_secs(150),
    })
    .run() else {
        return;
    };
    for step in [
        "ok VehicleState from 0x00d1",
        "ok EstimatedState decodes",
        "ok SERVICE",
        "ok MANEUVER 478",
        "ok steering psi 90 depth 2",
        "ok FollowRefState",
        "ok MANDONE",
        "ok timeout → SERVICE, loops 0",
    ] {
        assert!(stdout.contains(step), "missing {step:?} in:\n{stdout}");
    }
    println!("{stdout}");
}
