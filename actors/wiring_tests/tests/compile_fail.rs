//! Wiring mistakes are compile errors in the actor's own code: publishing a group the yaml does not
//! give the actor, publishing the wrong type, reaching the bus through the ports, publishing or
//! subscribing on the bus itself (private to the runtime), and a `match` on an inbox that forgets a
//! subscription. Expected compiler output is checked in next to each case.

#[test]
fn wiring_mistakes_do_not_compile() {
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/compile_fail/*.rs");
}
