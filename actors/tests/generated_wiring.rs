//! The generated wiring on the real bus: ports publish on their declared groups, inboxes receive
//! exactly their subscriptions, and the gateway helpers move encoded bytes in and out of
//! interprocess groups (and refuse the rest).

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::sync::{Arc, Mutex};

use frontseat_actors::bus::{Bus, Layer, Origin, PublishMeta, TraceContext};
use frontseat_actors::generated::{
    EncodedEnvelope, EncodedError, RESOLVED_INTERFACES_YAML, interprocess_publish_encoded,
    interprocess_subscribe_encoded,
};
use frontseat_actors::groups::{self, ALL};
use frontseat_actors::ports::{
    DemoHelmInbox, DemoHelmPorts, FrontSeatInterfaceInbox, FrontSeatInterfacePorts,
    FrontSeatTranslationPorts,
};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    HelmState, HelmStateReport, InterfaceStatus, NodeStatus,
};
use prost::Message;

#[test]
fn group_constants_carry_the_yaml() {
    let g = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS;
    assert_eq!(g.name(), "goby::middleware::frontseat::node_status");
    assert_eq!(
        g.type_name(),
        "goby.middleware.frontseat.protobuf.NodeStatus"
    );
    assert_eq!(g.layer(), Layer::Interprocess);
    assert_eq!(groups::FRONTSEAT_SIM_FAULT.layer(), Layer::Interthread);
    let info = ALL.iter().find(|i| i.name == g.name()).unwrap();
    // The bench's stand-in vehicle publishes node_status with no interface behind it.
    assert_eq!(info.publishers, ["BenchVehicle", "FrontSeatInterface"]);
    assert!(info.subscribers.contains(&"FrontSeatTranslation"));
    assert!(info.subscribers.contains(&"DemoHelm"));
    let mut names: Vec<&str> = ALL.iter().map(|i| i.name).collect();
    names.dedup();
    assert_eq!(names.len(), ALL.len());
    assert!(RESOLVED_INTERFACES_YAML.contains("application: frontseat_interface\n"));
    assert!(RESOLVED_INTERFACES_YAML.contains("    - group: goby::middleware::frontseat::node_status\n      type: goby.middleware.frontseat.protobuf.NodeStatus\n      actor: FrontSeatInterface\n"));
}

#[test]
fn ports_publish_and_inboxes_receive_their_variants() {
    let bus = Bus::new();
    let got: Arc<Mutex<Vec<DemoHelmInbox>>> = Arc::default();
    let sink = got.clone();
    let subs = DemoHelmInbox::subscribe_all(&bus, "demo_helm", 8, move |m| {
        sink.lock().unwrap().push(m);
        Ok(())
    });
    assert_eq!(subs.len(), DemoHelmInbox::SUBSCRIBES.len());

    let fsi = FrontSeatInterfacePorts::new(&bus);
    let report = fsi.publish_node_status(NodeStatus {
        name: Some("auv1".into()),
        ..Default::default()
    });
    assert_eq!(report.delivered, 1);
    fsi.publish_status(InterfaceStatus::default());
    // A group DemoHelm does not subscribe to reaches nobody here.
    assert_eq!(fsi.publish_raw_in(Default::default()).delivered, 0);

    let got = got.lock().unwrap();
    assert_eq!(got.len(), 2);
    match &got[0] {
        DemoHelmInbox::NodeStatus(env) => assert_eq!(env.msg.name(), "auv1"),
        DemoHelmInbox::Status(_) => panic!("wrong variant"),
    }
    assert_eq!(got[0].group(), "goby::middleware::frontseat::node_status");
    assert_eq!(got[1].group(), "goby::middleware::frontseat::status");
}

#[test]
fn publish_with_passes_meta_on() {
    let bus = Bus::new();
    let got: Arc<Mutex<Vec<FrontSeatInterfaceInbox>>> = Arc::default();
    let sink = got.clone();
    FrontSeatInterfaceInbox::subscribe_all(&bus, "fsi", 8, move |m| {
        sink.lock().unwrap().push(m);
        Ok(())
    });
    let meta = PublishMeta {
        trace: Some(TraceContext {
            traceparent: "00-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331-01".into(),
        }),
        origin: Origin::Local,
    };
    let msg = Arc::new(HelmStateReport {
        state: HelmState::HelmDrive as i32,
    });
    DemoHelmPorts::new(&bus).publish_helm_state_with(msg.clone(), meta.clone());
    let got = got.lock().unwrap();
    let FrontSeatInterfaceInbox::HelmState(env) = &got[0] else {
        panic!("wrong variant: {:?}", got[0]);
    };
    assert!(Arc::ptr_eq(&env.msg, &msg), "shared, not copied");
    assert_eq!(env.trace, meta.trace);
}

#[test]
fn gateway_helpers_move_encoded_bytes_on_interprocess_groups_only() {
    let bus = Bus::new();
    let exported: Arc<Mutex<Vec<EncodedEnvelope>>> = Arc::default();
    let sink = exported.clone();
    let sub = interprocess_subscribe_encoded(
        &bus,
        "goby::middleware::frontseat::helm_state",
        "gateway",
        4,
        move |e| {
            sink.lock().unwrap().push(e);
            Ok(())
        },
    );
    assert!(sub.is_some());
    assert!(
        interprocess_subscribe_encoded(&bus, "frontseat::sim::fault", "gateway", 4, |_| Ok(()))
            .is_none(),
        "interthread groups are not exported"
    );

    let report = FrontSeatTranslationPorts::new(&bus).publish_helm_state(HelmStateReport {
        state: HelmState::HelmPark as i32,
    });
    assert_eq!(report.delivered, 1);
    {
        let exported = exported.lock().unwrap();
        assert_eq!(
            exported[0].type_name,
            "goby.middleware.frontseat.protobuf.HelmStateReport"
        );
        assert_eq!(exported[0].bytes, [0x08, 0x02]);
        assert_eq!(exported[0].meta.origin, Origin::Local);
    }

    // Importing: the bytes are decoded into the group's type and published.
    let (_s, mut rx) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 4);
    let bytes = NodeStatus {
        time: 12.5,
        ..Default::default()
    }
    .encode_to_vec();
    let meta = PublishMeta {
        origin: Origin::Imported,
        ..Default::default()
    };
    let report = interprocess_publish_encoded(
        &bus,
        "goby::middleware::frontseat::node_status",
        &bytes,
        meta.clone(),
    )
    .unwrap();
    assert_eq!(report.delivered, 1);
    let env = rx.try_recv().unwrap();
    assert_eq!(env.msg.time, 12.5);
    assert_eq!(env.origin, Origin::Imported);

    assert_eq!(
        interprocess_publish_encoded(&bus, "frontseat::sim::fault", &[], meta.clone()),
        Err(EncodedError::UnknownGroup("frontseat::sim::fault".into()))
    );
    assert!(matches!(
        interprocess_publish_encoded(
            &bus,
            "goby::middleware::frontseat::node_status",
            &[0xff, 0xff, 0xff],
            meta
        ),
        Err(EncodedError::Decode {
            group: "goby::middleware::frontseat::node_status",
            ..
        })
    ));
}

#[test]
fn an_exported_envelope_holds_its_in_flight_slot() {
    let bus = Bus::new();
    let held: Arc<Mutex<Vec<EncodedEnvelope>>> = Arc::default();
    let sink = held.clone();
    interprocess_subscribe_encoded(
        &bus,
        "goby::middleware::frontseat::status",
        "gw",
        1,
        move |e| {
            sink.lock().unwrap().push(e);
            Ok(())
        },
    )
    .unwrap();
    let ports = FrontSeatInterfacePorts::new(&bus);
    assert_eq!(
        ports.publish_status(InterfaceStatus::default()).delivered,
        1
    );
    // Capacity 1 and the first envelope still held: the second is dropped, not queued.
    assert_eq!(ports.publish_status(InterfaceStatus::default()).dropped, 1);
    held.lock().unwrap().clear();
    assert_eq!(
        ports.publish_status(InterfaceStatus::default()).delivered,
        1
    );
}

#[test]
fn an_actor_publishes_encoded_bytes_only_on_its_declared_groups() {
    use frontseat_actors::ports::WebCommanderPorts;
    let bus = Bus::new();
    let (_s, mut rx) = bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE, "t", 4);
    let web = WebCommanderPorts::new(&bus);
    let bytes = HelmStateReport {
        state: HelmState::HelmDrive as i32,
    }
    .encode_to_vec();
    let r = web
        .publish_encoded(
            "goby::middleware::frontseat::helm_state",
            &bytes,
            PublishMeta::default(),
        )
        .unwrap();
    assert_eq!(r.delivered, 1);
    assert_eq!(rx.try_recv().unwrap().msg.state(), HelmState::HelmDrive);
    // node_status is interprocess, but not a publication of WebCommander.
    assert_eq!(
        web.publish_encoded(
            "goby::middleware::frontseat::node_status",
            &[],
            PublishMeta::default()
        ),
        Err(EncodedError::UnknownGroup(
            "goby::middleware::frontseat::node_status".into()
        ))
    );
}

#[test]
fn an_observer_subscribes_encoded_to_groups_of_either_layer() {
    use frontseat_actors::generated::subscribe_encoded;
    let bus = Bus::new();
    let got: Arc<Mutex<Vec<EncodedEnvelope>>> = Arc::default();
    let sink = got.clone();
    let sub = subscribe_encoded(&bus, "frontseat::driver::status", "scope", 4, move |e| {
        sink.lock().unwrap().push(e);
        Ok(())
    });
    assert!(sub.is_some());
    assert!(subscribe_encoded(&bus, "no::such::group", "scope", 4, |_| Ok(())).is_none());
    bus.publish(&groups::FRONTSEAT_DRIVER_STATUS, Default::default());
    let got = got.lock().unwrap();
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].type_name, "frontseat.protobuf.DriverStatus");
}
