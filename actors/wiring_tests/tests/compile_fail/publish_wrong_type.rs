// helm_state carries HelmStateReport; a DesiredCourse does not fit.
use frontseat_actors::bus::Bus;
use frontseat_actors::ports::DemoHelmPorts;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;

fn main() {
    let ports = DemoHelmPorts::new(&Bus::new());
    ports.publish_helm_state(DesiredCourse::default());
}
