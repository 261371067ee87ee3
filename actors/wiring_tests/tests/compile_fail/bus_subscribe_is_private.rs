// Nor does it subscribe: an undeclared subscriber does not build; it has no inbox.
use frontseat_actors::bus::Bus;
use frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS;

fn main() {
    let bus = Bus::new();
    let _sub = bus.subscribe(&GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "spy", 8, |_env| Ok(()));
}
