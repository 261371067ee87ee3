// The ports struct is the only way an actor publishes: the bus inside it is private.
use frontseat_actors::bus::Bus;
use frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS;
use frontseat_actors::ports::FrontSeatTranslationPorts;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;

fn main() {
    let ports = FrontSeatTranslationPorts::new(&Bus::new());
    ports
        .bus
        .publish(&GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, NodeStatus::default());
}
