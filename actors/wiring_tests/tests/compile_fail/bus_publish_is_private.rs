// Outside the runtime, the bus itself does not publish: a group reaches the bus only through the
// ports the yaml gives an actor, so an undeclared publish does not build.
use frontseat_actors::bus::Bus;
use frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;

fn main() {
    let bus = Bus::new();
    bus.publish(&GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, DesiredCourse::default());
}
