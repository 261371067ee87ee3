// DemoHelm subscribes node_status and status: a handler that forgets `Status` does not compile.
use frontseat_actors::ports::DemoHelmInbox;

fn handle(msg: DemoHelmInbox) -> f64 {
    match msg {
        DemoHelmInbox::NodeStatus(env) => env.msg.time,
    }
}

fn main() {
    let _ = handle;
}
