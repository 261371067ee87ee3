// FrontSeatTranslation subscribes node_status but does not publish it: there is no method.
use frontseat_actors::bus::Bus;
use frontseat_actors::ports::FrontSeatTranslationPorts;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;

fn main() {
    let ports = FrontSeatTranslationPorts::new(&Bus::new());
    ports.publish_node_status(NodeStatus::default());
}
