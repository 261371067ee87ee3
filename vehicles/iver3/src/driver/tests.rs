//! The Iver3 driver against scripted UVC lines: mode table, `$OSI`/`$C` publishing, the
//! `iver_command` table, `$ACK` matching and timeouts, the NTP copy port, polling and bad input.

use super::*;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;

type Sink = frontseat_actors::driver::RecordingSink;

fn driver() -> Iver3Driver {
    let mut cfg = InterfaceConfig::default();
    cfg.driver.iver3.serial_port = "/dev/null".into();
    cfg.driver.iver3.remote_helm_version_major = Some(5);
    Iver3Driver::new(Settings::from_config(&cfg))
}

const OSI_N: &str =
    "$OSI,7F7F7F7F80,N,0,42.358400,-71.087600,2.9,0.0,N,32.8,P0,-14.5,demo.mis,0,90.0,10.5*47";

fn osi(mode: &str) -> String {
    let o = OSI_N.replacen(",N,0,", &format!(",{mode},0,"), 1);
    let body = &o[1..o.len() - 3];
    codec::with_checksum(body)
}

#[test]
fn every_mode_maps_through_the_table() {
    let mut d = driver();
    let mut sink = Sink::default();
    let (w, _rx) = LineWriter::for_test();
    let t = Duration::ZERO;
    d.handle_io(DriverIoEvent::Connected(w), t, &mut sink);
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    for (mode, want) in [
        ("N", FrontSeatState::FrontseatAcceptingCommands),
        ("S", FrontSeatState::FrontseatIdle),
        ("P", FrontSeatState::FrontseatInControl),
        ("M", FrontSeatState::FrontseatAcceptingCommands),
        ("Mp", FrontSeatState::FrontseatAcceptingCommands),
        ("A", FrontSeatState::FrontseatAcceptingCommands),
        ("W", FrontSeatState::FrontseatAcceptingCommands),
        ("?", FrontSeatState::FrontseatIdle),
    ] {
        d.handle_io(DriverIoEvent::Line(osi(mode)), t, &mut sink);
        assert_eq!(d.frontseat_state(), want, "{mode}");
    }
    d.handle_io(DriverIoEvent::Disconnected("gone".into()), t, &mut sink);
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    assert!(!d.frontseat_providing_data());
}

#[test]
fn compass_before_osi_publishes_nothing_then_adds_pitch_and_roll() {
    let mut d = driver();
    let mut sink = Sink::default();
    let (w, _rx) = LineWriter::for_test();
    let t = Duration::from_secs(1);
    d.handle_io(DriverIoEvent::Connected(w), t, &mut sink);
    d.handle_io(
        DriverIoEvent::Line("$C90.0P-1.20R0.50T20.3D10.5*68".into()),
        t,
        &mut sink,
    );
    assert!(sink.data.is_empty());
    assert!(d.frontseat_providing_data());
    d.handle_io(DriverIoEvent::Line(OSI_N.into()), t, &mut sink);
    d.handle_io(
        DriverIoEvent::Line("$C90.0P-1.20R0.50T20.3D10.5*68".into()),
        t,
        &mut sink,
    );
    assert_eq!(sink.data.len(), 2);
    let ns = sink.data[1].node_status.as_ref().unwrap();
    assert_eq!((ns.pose.pitch(), ns.pose.roll()), (-1.2, 0.5));
    assert!((ns.global_fix.depth() - 10.5 * 0.3048).abs() < 1e-9);
    // Data stops: not providing after the timeout.
    d.do_loop(Duration::from_secs(11), &mut sink);
    assert!(d.frontseat_providing_data());
    d.do_loop(Duration::from_millis(11_100), &mut sink);
    assert!(!d.frontseat_providing_data());
}

#[test]
fn osi_carries_goby3s_iver_state_extension() {
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::iver_state::IverMissionMode;
    let mut d = driver();
    let mut sink = Sink::default();
    let (w, _rx) = LineWriter::for_test();
    d.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
    d.handle_io(DriverIoEvent::Line(osi("W")), Duration::ZERO, &mut sink);
    assert_eq!(sink.extensions.len(), 1);
    assert_eq!(sink.extensions[0].vehicle(), "Iver3");
    let iver = sink.extensions_of::<IverInterfaceData>(DATA);
    assert_eq!(iver.len(), 1, "of the Iver3 data type, and decodes");
    let st = iver[0].iver_state.as_ref().unwrap();
    assert_eq!(st.mode(), IverMissionMode::IverModeMissionMode);
    assert_eq!(iver[0].node_status, sink.data[0].node_status);
    // Goby3's numbering: the mode is the letter's code.
    assert_eq!(IverMissionMode::IverModeMissionMode as i32, i32::from(b'W'));
    assert_eq!(
        IverMissionMode::IverModeManualParking as i32,
        i32::from(b'm')
    );
}

fn mission(cmd: IverCommand, name: Option<&str>, course: bool) -> IverCommandRequest {
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::IverExtraCommands;
    IverCommandRequest {
        desired_course: course.then(|| DesiredCourse {
            time: 0.0,
            heading: Some(180.0),
            depth: Some(3.0),
            speed: Some(1.5),
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(7),
        iver_command: Some(IverExtraCommands {
            command: Some(cmd as i32),
            mission: name.map(str::to_string),
        }),
        ..Default::default()
    }
}

#[test]
fn iver_command_table() {
    // (name, request, lines written, response after the $ACK: Some(ok) / None: refused at once)
    let rows: [(&str, IverCommandRequest, &[&str], Option<bool>); 6] = [
        (
            "START_MISSION with a mission writes $OMSTART",
            mission(IverCommand::StartMission, Some("demo.mis"), false),
            &["$OMSTART,0,0,0,0,demo.mis,*18\r\n"],
            Some(true),
        ),
        (
            "STOP_MISSION writes $OMSTOP,0",
            mission(IverCommand::StopMission, None, false),
            &["$OMSTOP,0*06\r\n"],
            Some(true),
        ),
        (
            "START_MISSION without a mission is refused, nothing written",
            mission(IverCommand::StartMission, None, false),
            &[],
            None,
        ),
        (
            "a mission name that would add fields or sentences is refused",
            mission(
                IverCommand::StartMission,
                Some("x,1*00\r\n$OMSTOP,0"),
                false,
            ),
            &[],
            None,
        ),
        (
            "the extension first, then the course (as Goby3)",
            mission(IverCommand::StopMission, None, true),
            &["$OMSTOP,0*06\r\n", "$OMS,180.0,3.0,45.0,2.9,5*78\r\n"],
            Some(true),
        ),
        (
            "UNKNOWN_COMMAND with a course sends the course only",
            mission(IverCommand::UnknownCommand, None, true),
            &["$OMS,180.0,3.0,45.0,2.9,5*78\r\n"],
            Some(true),
        ),
    ];
    for (name, req, lines, answer) in rows {
        let mut d = driver();
        let mut sink = Sink::default();
        let (w, mut rx) = LineWriter::for_test();
        let t = Duration::ZERO;
        d.handle_io(DriverIoEvent::Connected(w), t, &mut sink);
        d.send_iver_command(&req, t, &mut sink);
        let mut written = Vec::new();
        while let Ok(l) = rx.try_recv() {
            written.push(String::from_utf8(l.to_vec()).unwrap());
        }
        assert_eq!(written, lines, "{name}");
        match answer {
            None => {
                assert_eq!(sink.responses.len(), 1, "{name}");
                assert_eq!(sink.responses[0].request_successful, Some(false), "{name}");
            }
            Some(ok) => {
                assert!(
                    sink.responses.is_empty(),
                    "{name}: answered before the $ACK"
                );
                for l in lines {
                    let ack = if l.starts_with("$OMSTART") {
                        ack_type::OMSTART
                    } else if l.starts_with("$OMSTOP") {
                        ack_type::OMSTOP
                    } else {
                        ack_type::OMS
                    };
                    let line = codec::with_checksum(&format!("ACK,{ack},0,0"));
                    d.handle_io(DriverIoEvent::Line(line), t, &mut sink);
                }
                assert_eq!(sink.responses.len(), 1, "{name}: one answer per request");
                assert_eq!(sink.responses[0].request_successful, Some(ok), "{name}");
                assert_eq!(sink.responses[0].request_id, Some(7), "{name}");
            }
        }
    }
}

#[test]
fn the_mirror_is_goby3s_extension_1001_on_the_wire() {
    use prost::Message;
    let req = IverCommandRequest {
        request_id: Some(7),
        iver_command: Some(
            frontseat_actors::proto::goby::middleware::frontseat::protobuf::IverExtraCommands {
                command: Some(IverCommand::StartMission as i32),
                mission: Some("a".into()),
            },
        ),
        ..Default::default()
    };
    // request_id (11, varint) 7; then field 1001 length-delimited: tag (1001 << 3 | 2) =
    // 8010 = varint CA 3E, 5 bytes: command (1, varint) 1, mission (2, bytes) "a".
    let want = [0x58, 0x07, 0xCA, 0x3E, 0x05, 0x08, 0x01, 0x12, 0x01, b'a'];
    assert_eq!(req.encode_to_vec(), want);
    // Goby3's base CommandRequest reads the same bytes (the extension skipped as unknown).
    let base = CommandRequest::decode(&want[..]).unwrap();
    assert_eq!(base.request_id, Some(7));
}

#[test]
fn mission_names_are_plain_fields() {
    for (name, ok) in [
        ("demo.mis", true),
        ("survey 2.mis", true),
        ("", true),
        ("a,b", false),
        ("a*b", false),
        ("a$b", false),
        ("a\r\n", false),
        ("é.mis", false),
        (&"m".repeat(65), false),
    ] {
        assert_eq!(codec::is_field_safe(name), ok, "{name:?}");
    }
}

#[test]
fn acks_answer_commands_and_silence_times_out() {
    let mut d = driver();
    let mut sink = Sink::default();
    let (w, mut rx) = LineWriter::for_test();
    let t = Duration::ZERO;
    d.handle_io(DriverIoEvent::Connected(w), t, &mut sink);
    let req = |id| CommandRequest {
        desired_course: Some(DesiredCourse {
            time: 0.0,
            heading: Some(180.0),
            depth: Some(3.0),
            speed: Some(1.5),
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(id),
        ..Default::default()
    };
    d.send_command_to_frontseat(&req(1), t, &mut sink);
    assert_eq!(rx.try_recv().unwrap(), b"$OMS,180.0,3.0,45.0,2.9,5*78\r\n");
    d.handle_io(DriverIoEvent::Line("$ACK,9,0,0*5C".into()), t, &mut sink);
    assert_eq!(sink.responses.len(), 1);
    assert_eq!(sink.responses[0].request_successful, Some(true));
    assert_eq!(sink.responses[0].request_id, Some(1));

    d.send_command_to_frontseat(&req(2), t, &mut sink);
    d.handle_io(
        DriverIoEvent::Line(codec::with_checksum("ACK,9,1,26")),
        t,
        &mut sink,
    );
    assert_eq!(sink.responses[1].request_successful, Some(false));
    assert_eq!(sink.responses[1].error_code, Some(26));

    d.send_command_to_frontseat(&req(3), t, &mut sink);
    d.do_loop(Duration::from_secs(4), &mut sink);
    assert_eq!(sink.responses.len(), 2);
    d.do_loop(Duration::from_secs(5), &mut sink);
    assert_eq!(sink.responses.len(), 3);
    assert_eq!(sink.responses[2].request_id, Some(3));
    assert_eq!(sink.responses[2].request_successful, Some(false));

    // A command without a course, and one while the port is gone, fail at once.
    let mut no_course = req(4);
    no_course.desired_course = None;
    d.send_command_to_frontseat(&no_course, t, &mut sink);
    d.handle_io(DriverIoEvent::Disconnected("x".into()), t, &mut sink);
    d.send_command_to_frontseat(&req(5), t, &mut sink);
    assert_eq!(
        sink.responses
            .iter()
            .skip(3)
            .map(|r| (r.request_id, r.request_successful))
            .collect::<Vec<_>>(),
        vec![(Some(4), Some(false)), (Some(5), Some(false))]
    );
}

/// The NTP copy port over a real pty: each RMC goes out verbatim at 4800 baud.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rmc_is_copied_to_the_ntp_port() {
    let pty = frontseat_sim::pty::PtyMaster::open().unwrap();
    let mut cfg = InterfaceConfig::default();
    cfg.driver.iver3.serial_port = "/nonexistent/iver".into();
    cfg.driver.iver3.remote_helm_version_major = Some(5);
    cfg.driver.iver3.ntp_serial_port = Some(pty.slave_path().to_string_lossy().into_owned());
    let mut d = Iver3Driver::new(Settings::from_config(&cfg));
    d.start(DriverContext {
        io: frontseat_actors::driver::IoSender::new(|_| true),
        clock: frontseat_actors::clock::SimClock::new(1.0),
    });
    let ntp = d.ntp.clone();
    tokio::time::timeout(Duration::from_secs(10), async {
        while ntp.lock().unwrap().is_none() {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    })
    .await
    .expect("NTP port opened");
    let rmc = "$GPRMC,120000.00,A,4221.5040,N,07105.2560,W,0.0,90.0,101024,14.5,W*52";
    let mut sink = Sink::default();
    d.handle_io(DriverIoEvent::Line(OSI_N.into()), Duration::ZERO, &mut sink);
    d.handle_io(DriverIoEvent::Line(rmc.into()), Duration::ZERO, &mut sink);
    let mut got = Vec::new();
    while !got.ends_with(b"\r\n") {
        let mut b = [0u8; 128];
        let n = tokio::time::timeout(Duration::from_secs(10), pty.read(&mut b))
            .await
            .unwrap()
            .unwrap();
        got.extend_from_slice(&b[..n]);
    }
    assert_eq!(
        got,
        format!("{rmc}\r\n").as_bytes(),
        "only the RMC, verbatim"
    );
}

#[test]
fn polls_every_loop_and_counts_bad_lines() {
    let mut d = driver();
    let mut sink = Sink::default();
    let (w, mut rx) = LineWriter::for_test();
    d.do_loop(Duration::ZERO, &mut sink);
    d.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
    d.do_loop(Duration::from_millis(100), &mut sink);
    assert_eq!(rx.try_recv().unwrap(), b"$OSD,G,C,S,P,,,,*5F\r\n");
    assert!(rx.try_recv().is_err());
    for l in ["$OSI,1,2", "garbage", "$OSD,G,C,S,P,,,,*00"] {
        d.handle_io(DriverIoEvent::Line(l.into()), Duration::ZERO, &mut sink);
    }
    d.handle_io(
        DriverIoEvent::BadInput("noise".into()),
        Duration::ZERO,
        &mut sink,
    );
    assert_eq!(d.counters.bad_lines, 4);
    // $OSD from the other side is recognised and ignored, not an error.
    assert_eq!(d.counters.ignored, 0);
}

#[test]
fn a_huge_configured_timeout_is_capped_not_a_panic() {
    let mut cfg = InterfaceConfig::default();
    cfg.driver.iver3.remote_helm_version_major = Some(5);
    // Finite and positive: what validation lets through.
    cfg.driver.iver3.link.ack_timeout = 1e20;
    cfg.driver.iver3.providing_data_timeout = 1e20;
    let s = Settings::from_config(&cfg);
    assert_eq!(s.ack_timeout, Duration::from_secs(1_000_000_000));
    let mut d = Iver3Driver::new(s);
    let mut sink = Sink::default();
    let (w, _rx) = LineWriter::for_test();
    let t = Duration::from_secs(1);
    d.handle_io(DriverIoEvent::Connected(w), t, &mut sink);
    d.send_command_to_frontseat(
        &CommandRequest {
            desired_course: Some(DesiredCourse::default()),
            response_requested: Some(true),
            request_id: Some(1),
            ..Default::default()
        },
        t,
        &mut sink,
    );
    d.do_loop(Duration::from_secs(86_400), &mut sink);
    assert!(sink.responses.is_empty(), "still waiting for its $ACK");
}
