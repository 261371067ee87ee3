//! The OpenCPN helm on a real bus with a real UDP socket: it drives from APB, stands down while
//! another helm's helm_state is heard (its waypoint says `steering: false` and no course of its
//! own follows), and drives again once that helm has been silent for `standdown_s`.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{HelmState, HelmStateReport};
use frontseat_config::OpenCpnHelmConfig;
use frontseat_opencpn::helm::OpenCpnHelm;
use frontseat_opencpn::nmea;

const BOUND: Duration = Duration::from_secs(10);

fn apb(bearing: u32) -> String {
    nmea::frame(
        '$',
        &format!(
            "ECAPB,A,A,0.000,R,N,V,V,{bearing}.000,T,WP{bearing},{bearing}.000,T,{bearing}.000,T"
        ),
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn another_helm_makes_it_stand_down_until_silent() {
    let bus = Bus::new();
    let (_c, mut courses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        "test",
        1000,
    );
    let (_w, mut waypoints) =
        bus.subscribe_channel(&groups::FRONTSEAT_OPENCPN_WAYPOINT, "test", 1000);
    let cfg = OpenCpnHelmConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        standdown_s: 0.5,
        ..Default::default()
    };
    let helm = OpenCpnHelm::start(&cfg, &bus).await.unwrap();
    let to = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let send = |b: u32| {
        let to = &to;
        let addr = helm.local_addr();
        async move { to.send_to(apb(b).as_bytes(), addr).await.unwrap() }
    };
    // Driving: APB 40 becomes a course of 40 at the configured speed and depth.
    send(40).await;
    let c = tokio::time::timeout(BOUND, courses.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(
        (c.msg.heading, c.msg.speed, c.msg.depth),
        (Some(40.0), Some(cfg.speed), Some(cfg.depth))
    );
    // Another helm says it drives.
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
        HelmStateReport {
            state: HelmState::HelmDrive as i32,
        },
    );
    // Twice, so that the first one's handling (waypoint, then its course if any) is complete
    // when the second's waypoint arrives: the helm handles datagrams one after the other.
    let mut stood_down = 0;
    let t0 = tokio::time::Instant::now();
    while stood_down < 2 {
        assert!(t0.elapsed() < BOUND, "the helm never stood down");
        send(200).await;
        if let Ok(Some(w)) =
            tokio::time::timeout(Duration::from_millis(100), waypoints.recv()).await
            && w.msg.destination_id.as_deref() == Some("WP200")
            && w.msg.steering == Some(false)
        {
            stood_down += 1;
        }
    }
    while let Ok(c) = courses.try_recv() {
        assert_ne!(
            c.msg.heading,
            Some(200.0),
            "a course while another helm drives"
        );
    }
    assert!(
        helm.counters
            .other_helm
            .load(std::sync::atomic::Ordering::Relaxed)
            >= 1
    );
    // That helm silent for standdown_s: OpenCPN drives again.
    let t1 = tokio::time::Instant::now();
    loop {
        assert!(t1.elapsed() < BOUND, "the helm never drove again");
        send(300).await;
        if let Ok(Some(c)) = tokio::time::timeout(Duration::from_millis(100), courses.recv()).await
            && c.msg.heading == Some(300.0)
        {
            break;
        }
    }
}

#[tokio::test]
async fn a_listen_beyond_loopback_is_refused_without_the_opt_in() {
    let cfg = OpenCpnHelmConfig {
        enabled: true,
        listen: "0.0.0.0:0".into(),
        ..Default::default()
    };
    let e = OpenCpnHelm::start(&cfg, &Bus::new()).await.err().unwrap();
    assert_eq!(e.kind(), std::io::ErrorKind::PermissionDenied);
}
