//! The gateway against a second DDS participant (rustdds) in this process, over loopback: a
//! node_status on the bus comes out as Odometry, NavSatFix and frontseat_msgs/NodeStatus bytes;
//! a desired_course written on DDS comes onto the bus marked as imported; malformed, NaN and
//! wrong-enum samples are refused and counted, never published. (Cyclone DDS, the real ROS 2
//! side, is tests/ros2_e2e.rs at the top of the workspace.)

use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, DesiredCourse, EulerAngles, HelmStateReport, NodeStatus, Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;
use frontseat_config::Ros2Config;
use frontseat_ros2::gateway::{RawAdapter, RawSample};
use frontseat_ros2::msgs::encode;
use frontseat_ros2::rustdds::no_key::{DataReader, DataWriter};
use frontseat_ros2::rustdds::policy::{History, Reliability};
use frontseat_ros2::rustdds::{DomainParticipantBuilder, QosPolicies, QosPolicyBuilder, TopicKind};
use frontseat_ros2::types;
use futures::StreamExt;

const LONG: Duration = Duration::from_secs(30);

fn domain() -> u16 {
    // Its own domain per test process, so parallel test runs never meet.
    150 + (std::process::id() % 80) as u16
}

fn reliable() -> QosPolicies {
    QosPolicyBuilder::new()
        .reliability(Reliability::Reliable {
            max_blocking_time: frontseat_ros2::rustdds::Duration::from_millis(100),
        })
        .history(History::KeepLast { depth: 100 })
        .build()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn navigation_out_commands_in_and_bad_samples_counted() {
    let bus = Bus::new();
    let cfg = Ros2Config {
        enabled: true,
        domain_id: domain(),
        namespace: "lbauv".into(),
        ..Default::default()
    };
    let gw = frontseat_ros2::start(&bus, &cfg, "ignored").expect("gateway starts");
    assert_eq!(gw.namespace(), "/lbauv");

    let peer = DomainParticipantBuilder::new(cfg.domain_id)
        .with_only_networks([std::net::IpAddr::from([127, 0, 0, 1])])
        .build()
        .unwrap();
    let subr = peer.create_subscriber(&reliable()).unwrap();
    let pubr = peer.create_publisher(&reliable()).unwrap();
    let topic = |name: &str, t: types::RosType| {
        peer.create_topic(
            types::dds_topic(name),
            t.dds_name(),
            &reliable(),
            TopicKind::NoKey,
        )
        .unwrap()
    };
    let odom: DataReader<RawSample, RawAdapter> = subr
        .create_datareader_no_key(&topic("/lbauv/frontseat/odom", types::ODOMETRY), None)
        .unwrap();
    let course_w: DataWriter<Vec<u8>, RawAdapter> = pubr
        .create_datawriter_no_key(
            &topic("/lbauv/frontseat/desired_course", types::DESIRED_COURSE),
            None,
        )
        .unwrap();
    let helm_w: DataWriter<Vec<u8>, RawAdapter> = pubr
        .create_datawriter_no_key(
            &topic("/lbauv/frontseat/helm_state", types::HELM_STATE_REPORT),
            None,
        )
        .unwrap();
    let (_sub, mut courses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        "test",
        1000,
    );

    // Navigation out: publish node_status until the peer's reader has one (discovery takes a
    // moment; samples before the match are not kept: volatile).
    let ns = NodeStatus {
        time: 1_700_000_000.0,
        global_fix: LatLonPoint {
            lat: 42.0,
            lon: -71.0,
            depth: Some(3.0),
            altitude: None,
        },
        local_fix: Some(CartesianCoordinate {
            x: 10.0,
            y: 20.0,
            z: Some(-3.0),
        }),
        pose: EulerAngles {
            heading: Some(90.0),
            ..Default::default()
        },
        speed: Speed {
            over_ground: 1.25,
            over_water: None,
        },
        ..Default::default()
    };
    let publisher = {
        let bus = bus.clone();
        tokio::spawn(async move {
            loop {
                bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, ns.clone());
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
    };
    let mut stream = odom.async_sample_stream();
    let sample = tokio::time::timeout(LONG, stream.next())
        .await
        .expect("an Odometry in time")
        .expect("stream open")
        .expect("a sample");
    publisher.abort();
    let p = &sample.value().payload;
    let f = |off: usize| f64::from_le_bytes(p[4 + off..4 + off + 8].try_into().unwrap());
    // frame "odom", child "base_link": position at 40, quaternion at 64, twist at 384.
    assert_eq!((f(40), f(48), f(56)), (10.0, 20.0, -3.0));
    assert!(
        (f(80) - 0.0).abs() < 1e-12 && (f(88) - 1.0).abs() < 1e-12,
        "heading 90 = east = yaw 0"
    );
    assert_eq!(f(384), 1.25);

    // Commands in: bad samples first (they must never reach the bus), then a good one, until the
    // writer is matched and the good one arrives.
    let good = DesiredCourse {
        time: 1.0,
        heading: Some(45.0),
        speed: Some(1.5),
        ..Default::default()
    };
    let mut nan = good;
    nan.heading = Some(f64::NAN);
    let mut bad_bool = encode::desired_course(&good);
    bad_bool[4 + 8] = 2;
    // Each topic matches on its own: write the batch until every kind has been judged.
    let deadline = tokio::time::Instant::now() + LONG;
    let mut got = 0;
    loop {
        course_w.write(encode::desired_course(&nan), None).unwrap();
        course_w.write(bad_bool.clone(), None).unwrap();
        course_w.write(vec![0, 1, 0, 0, 1, 2, 3], None).unwrap();
        helm_w
            .write(encode::helm_state(&HelmStateReport { state: 9 }), None)
            .unwrap();
        course_w.write(encode::desired_course(&good), None).unwrap();
        tokio::time::sleep(Duration::from_millis(100)).await;
        // Only good courses ever reach the bus, marked as imported.
        while let Ok(env) = courses.try_recv() {
            assert_eq!(*env.msg, good);
            assert!(env.meta().origin.is_imported());
            got += 1;
        }
        let stats = gw.stats();
        if got > 0
            && stats.get("imported") >= 1
            && stats.get("refused_not_finite") >= 1
            && stats.get("refused_malformed") >= 2
            && stats.get("refused_bad_enum") >= 1
        {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "{got} courses on the bus; {stats:?}"
        );
    }
    assert!(gw.stats().get("published") >= 3);
    gw.close();
}
