//! Helpers the topside's tests share: a free loopback port, and a Zenoh session standing in for
//! the vehicles (listening there, so the topside connects to it).

use frontseat_helm_side::zenoh;

pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

pub async fn publisher(port: u16) -> zenoh::Session {
    let ip = frontseat_config::InterprocessConfig {
        enabled: true,
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        ..Default::default()
    };
    let cfg = frontseat_helm_side::zenoh_config(&ip, 65536).unwrap();
    zenoh::open(cfg).await.unwrap()
}
