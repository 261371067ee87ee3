//! Unknown keys and bad types are reported with file:line:column; every validation rule names
//! the field path of the offending value.

use frontseat_config::{
    ConfigError, FieldError, GatewayConfig, InterfaceConfig, ServiceConfig, SimConfig, parse,
};

fn parse_err<T: ServiceConfig + std::fmt::Debug>(text: &str) -> (usize, usize, String, String) {
    match parse::<T>(text, "cfg.toml") {
        Err(e @ ConfigError::Parse { .. }) => {
            let shown = e.to_string();
            let ConfigError::Parse {
                line,
                column,
                message,
                ..
            } = e
            else {
                unreachable!()
            };
            (line, column, message, shown)
        }
        other => panic!("expected a parse error for {text:?}, got {other:?}"),
    }
}

#[test]
fn unknown_top_level_key_names_key_line_and_column() {
    let (line, column, message, shown) =
        parse_err::<InterfaceConfig>("name = \"auv1\"\nrequire_helm = false\nfoo = 1\n");
    assert_eq!((line, column), (3, 1));
    assert!(message.contains("unknown field `foo`"), "{message}");
    assert!(
        shown.starts_with("cfg.toml:3:1: unknown field `foo`, expected one of"),
        "{shown}"
    );
    assert!(
        shown.contains("`require_helm`"),
        "lists the valid keys: {shown}"
    );
}

#[test]
fn unknown_nested_key_points_at_the_key() {
    let text = "[driver.basic_simulator.start]\nlat = 1.0\n  latt = 2.0\n";
    let (line, column, message, _) = parse_err::<InterfaceConfig>(text);
    assert_eq!((line, column), (3, 3));
    assert!(message.contains("unknown field `latt`"), "{message}");
}

#[test]
fn unknown_section_is_an_error() {
    let (line, _, message, _) = parse_err::<InterfaceConfig>("name = \"x\"\n\n[mooos]\nport = 1\n");
    assert_eq!(line, 3);
    assert!(message.contains("mooos"), "{message}");
}

#[test]
fn unknown_key_in_sim_and_gateway() {
    let (line, column, message, _) = parse_err::<SimConfig>("port = 1\n[current]\nup = 1.0\n");
    assert_eq!((line, column), (3, 1));
    assert!(message.contains("`up`"));
    let (line, _, message, _) = parse_err::<GatewayConfig>("[moos]\nservr = \"h\"\n");
    assert_eq!(line, 2);
    assert!(message.contains("`servr`"));
}

#[test]
fn wrong_types_and_enum_names_are_parse_errors_with_position() {
    let (line, _, message, _) =
        parse_err::<InterfaceConfig>("[driver.basic_simulator]\ntcp_port = 70000\n");
    assert_eq!(line, 2, "{message}");
    assert!(
        message.starts_with("driver.basic_simulator.tcp_port: "),
        "names the key: {message}"
    );
    let (_, _, message, shown) = parse_err::<SimConfig>(
        "[[faults]]\nat = 1\nkind = \"garbage\"\n[[faults]]\nat = \"soon\"\nkind = \"garbage\"\n",
    );
    assert!(message.starts_with("faults.at: "), "{message}");
    assert!(
        shown.starts_with("cfg.toml:5:6: faults.at: invalid type"),
        "{shown}"
    );
    let (line, _, message, _) = parse_err::<InterfaceConfig>("\ntype = \"SUBMARINE\"\n");
    assert_eq!(line, 2);
    assert!(message.contains("SUBMARINE"), "{message}");
    let (line, _, _, _) = parse_err::<InterfaceConfig>("exit_on_error = \"yes\"\n");
    assert_eq!(line, 1);
    let (line, _, _, _) = parse_err::<InterfaceConfig>("name = \"unterminated\n");
    assert_eq!(line, 1);
}

fn errors<T: ServiceConfig + std::fmt::Debug>(text: &str) -> Vec<FieldError> {
    match parse::<T>(text, "cfg.toml") {
        Err(ConfigError::Invalid { errors, file }) => {
            assert_eq!(file, "cfg.toml");
            errors
        }
        other => panic!("expected validation errors for {text:?}, got {other:?}"),
    }
}

/// `text` breaks exactly one rule, reported on `path` with `reason` in the message.
fn rejects<T: ServiceConfig + std::fmt::Debug>(text: &str, path: &str, reason: &str) {
    let errs = errors::<T>(text);
    assert_eq!(errs.len(), 1, "{text:?} gave {errs:?}");
    assert_eq!(errs[0].path, path, "{text:?}");
    assert!(
        errs[0].message.contains(reason),
        "{text:?}: {:?} lacks {reason:?}",
        errs[0].message
    );
}

#[test]
fn display_matches_the_documented_format() {
    let err = parse::<InterfaceConfig>("[driver.basic_simulator.start]\nlat = 95\n", "cfg.toml")
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "cfg.toml: driver.basic_simulator.start.lat = 95: outside [-90, 90]"
    );
    let err = parse::<InterfaceConfig>("status_period = -1\n[origin]\nlon = 181\n", "cfg.toml")
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "cfg.toml: origin.lon = 181: outside [-180, 180]\n\
         cfg.toml: status_period = -1: negative; must be 0 or more"
    );
}

#[test]
fn interface_ranges_name_the_field() {
    type I = InterfaceConfig;
    rejects::<I>("[origin]\nlat = 95\n", "origin.lat", "outside [-90, 90]");
    rejects::<I>("[origin]\nlat = -90.5\n", "origin.lat", "outside [-90, 90]");
    rejects::<I>(
        "[origin]\nlon = -181\n",
        "origin.lon",
        "outside [-180, 180]",
    );
    rejects::<I>(
        "[origin]\ndepth = inf\n",
        "origin.depth",
        "not a finite number",
    );
    rejects::<I>(
        "[origin]\naltitude = nan\n",
        "origin.altitude",
        "not a finite number",
    );
    rejects::<I>(
        "[driver.basic_simulator.start]\nlon = 200\n",
        "driver.basic_simulator.start.lon",
        "outside",
    );
    rejects::<I>(
        "[driver.basic_simulator]\ntcp_port = 0\n",
        "driver.basic_simulator.tcp_port",
        "port 0",
    );
    rejects::<I>(
        "[driver.basic_simulator]\ntcp_address = \"\"\n",
        "driver.basic_simulator.tcp_address",
        "empty",
    );
    rejects::<I>(
        "helm_running_timeout = -1\n",
        "helm_running_timeout",
        "negative",
    );
    rejects::<I>(
        "helm_running_timeout = nan\n",
        "helm_running_timeout",
        "not a finite number",
    );
    rejects::<I>(
        "frontseat_connected_timeout = -0.5\n",
        "frontseat_connected_timeout",
        "negative",
    );
    rejects::<I>("status_period = -1\n", "status_period", "negative");
    rejects::<I>(
        "sim_warp_factor = 0\n",
        "sim_warp_factor",
        "outside (0, 10000]",
    );
    rejects::<I>(
        "sim_warp_factor = 10001\n",
        "sim_warp_factor",
        "outside (0, 10000]",
    );
    rejects::<I>(
        "sim_warp_factor = -inf\n",
        "sim_warp_factor",
        "not a finite number",
    );
    rejects::<I>(
        "[driver.basic_simulator.start]\nduration = -1\n",
        "driver.basic_simulator.start.duration",
        "negative",
    );
    rejects::<I>(
        "[driver.basic_simulator.start]\ncontrol_freq = 0\n",
        "driver.basic_simulator.start.control_freq",
        "outside (0, 1000]",
    );
    rejects::<I>(
        "[driver.basic_simulator.start]\ncontrol_freq = 1000.5\n",
        "driver.basic_simulator.start.control_freq",
        "outside (0, 1000]",
    );
    rejects::<I>(
        "[driver.basic_simulator.start.vehicle]\naccel = -0.1\n",
        "driver.basic_simulator.start.vehicle.accel",
        "negative",
    );
    rejects::<I>(
        "[driver.basic_simulator.start.vehicle]\nhdg_rate = -1\n",
        "driver.basic_simulator.start.vehicle.hdg_rate",
        "negative",
    );
    rejects::<I>(
        "[driver.basic_simulator.start.vehicle]\nz_rate = -2\n",
        "driver.basic_simulator.start.vehicle.z_rate",
        "negative",
    );
    rejects::<I>(
        "[driver.basic_simulator]\nnav_timeout = 0\n",
        "driver.basic_simulator.nav_timeout",
        "greater than 0",
    );
    rejects::<I>(
        "[driver.basic_simulator]\nreconnect_initial_ms = 0\n",
        "driver.basic_simulator.reconnect_initial_ms",
        "at least 1",
    );
    rejects::<I>(
        "[driver.basic_simulator]\nreconnect_initial_ms = 2000\n",
        "driver.basic_simulator.reconnect_initial_ms",
        "greater than driver.basic_simulator.reconnect_max_ms (1000)",
    );
    rejects::<I>(
        "[driver]\nname = \"seaglider\"\n",
        "driver.name",
        "unknown built-in driver",
    );
    rejects::<I>("[driver]\nlibrary = \" \"\n", "driver.library", "empty");
    rejects::<I>(
        "[supervision]\nrestart_initial_delay_ms = 3000\n",
        "supervision.restart_initial_delay_ms",
        "greater than supervision.restart_max_delay_ms (2000)",
    );
    rejects::<I>(
        "[supervision]\nrestart_window_s = 0\n",
        "supervision.restart_window_s",
        "greater than 0",
    );
    rejects::<I>("[moos]\nport = 0\n", "moos.port", "port 0");
    rejects::<I>(
        "[moos]\ntime_warp = -1\n",
        "moos.time_warp",
        "outside (0, 10000]",
    );
    // One warp (Goby3's app.simulation.time.warp_factor): a MOOS warp that differs is refused,
    // 0 (the default) follows sim_warp_factor.
    rejects::<I>(
        "sim_warp_factor = 10\n[moos]\ntime_warp = 1\n",
        "moos.time_warp",
        "differs from sim_warp_factor = 10",
    );
    assert!(parse::<I>("sim_warp_factor = 10\n[moos]\ntime_warp = 10\n", "c").is_ok());
    assert!(parse::<I>("sim_warp_factor = 10\n[moos]\n", "c").is_ok());
    rejects::<I>(
        "[moos]\ndesired_timeout_s = -1\n",
        "moos.desired_timeout_s",
        "negative",
    );
    rejects::<I>("[moos]\napp_name = \"\"\n", "moos.app_name", "empty");
    rejects::<I>(
        "[telemetry]\nsampling_ratio = 1.5\n",
        "telemetry.sampling_ratio",
        "outside [0, 1]",
    );
    rejects::<I>(
        "[telemetry]\nsampling_ratio = -0.1\n",
        "telemetry.sampling_ratio",
        "outside [0, 1]",
    );
    rejects::<I>(
        "[telemetry]\nendpoint = \"127.0.0.1:4318\"\n",
        "telemetry.endpoint",
        "http://",
    );
    rejects::<I>(
        "[interprocess]\nlisten = [\"127.0.0.1:7447\"]\n",
        "interprocess.listen[0]",
        "Zenoh endpoint",
    );
    rejects::<I>(
        "[interprocess]\nenabled = true\nmode = \"client\"\n",
        "interprocess.connect",
        "client",
    );
    rejects::<I>(
        "[interprocess]\nplatform = \"a/b\"\n",
        "interprocess.platform",
        "must not contain",
    );
    rejects::<I>(
        "[bus]\nqueue_capacity = 0\n",
        "bus.queue_capacity",
        "outside [1, 1048576]",
    );
}

#[test]
fn edge_values_are_accepted() {
    let ok = "[origin]\nlat = -90\nlon = 180\n\
              [driver.basic_simulator.start]\nlat = 90\nlon = -180\ncontrol_freq = 1000\n\
              [supervision]\nmax_restarts = 0\nrestart_initial_delay_ms = 2000\n\
              [telemetry]\nsampling_ratio = 0\n";
    let cfg: InterfaceConfig = parse(ok, "cfg.toml").unwrap();
    assert_eq!(
        cfg.supervision.max_restarts, 0,
        "0 = fail on the first driver failure"
    );
    let _: InterfaceConfig = parse(
        "status_period = 0\nhelm_running_timeout = 0\nsim_warp_factor = 10000\n",
        "c",
    )
    .unwrap();
    let _: InterfaceConfig =
        parse("[driver]\nname = \"x\"\nlibrary = \"/lib/x.so\"\n", "c").unwrap();
}

#[test]
fn every_error_is_reported_not_just_the_first() {
    let errs = errors::<InterfaceConfig>(
        "status_period = -1\n[origin]\nlat = 91\nlon = 181\n[driver.basic_simulator]\ntcp_port = 0\n",
    );
    let paths: Vec<&str> = errs.iter().map(|e| e.path.as_str()).collect();
    assert_eq!(
        paths,
        [
            "origin.lat",
            "origin.lon",
            "status_period",
            "driver.basic_simulator.tcp_port"
        ]
    );
}

#[test]
fn sim_ranges_name_the_field() {
    type S = SimConfig;
    rejects::<S>("port = 0\n", "port", "port 0");
    rejects::<S>("bind = \"localhost\"\n", "bind", "not an IP address");
    rejects::<S>(
        "max_line_bytes = 8\n",
        "max_line_bytes",
        "outside [16, 1048576]",
    );
    rejects::<S>(
        "max_line_bytes = 100000000\n",
        "max_line_bytes",
        "outside [16, 1048576]",
    );
    rejects::<S>("max_vehicles = 0\n", "max_vehicles", "at least 1");
    rejects::<S>("max_pending = 0\n", "max_pending", "at least 1");
    rejects::<S>(
        "start_timeout_s = -1\n",
        "start_timeout_s",
        "outside [0, 3600]",
    );
    rejects::<S>(
        "[current]\neast = nan\n",
        "current.east",
        "not a finite number",
    );
    rejects::<S>(
        "[[faults]]\nat = -1\nkind = \"garbage\"\n",
        "faults[0].at",
        "negative",
    );
    rejects::<S>(
        "[[faults]]\nat = 1\nkind = \"garbage\"\n[[faults]]\nat = 2\nkind = \"stop_nav\"\n",
        "faults[1].seconds",
        "required for kind stop_nav",
    );
    rejects::<S>(
        "[[faults]]\nat = 1\nkind = \"stop_nav\"\nseconds = -5\n",
        "faults[0].seconds",
        "greater than 0",
    );
    rejects::<S>(
        "[[faults]]\nat = 1\nkind = \"ctrl_idle\"\nseconds = 5\n",
        "faults[0].seconds",
        "only meaningful",
    );
    rejects::<S>(
        "[[faults]]\nat = 1\nkind = \"drop_connection\"\nlines = 2\n",
        "faults[0].lines",
        "only meaningful",
    );
    rejects::<S>(
        "[[faults]]\nat = 1\nkind = \"garbage\"\nlines = 0\n",
        "faults[0].lines",
        "outside [1, 10000]",
    );
    rejects::<S>(
        "[telemetry]\nsampling_ratio = 2\n",
        "telemetry.sampling_ratio",
        "outside [0, 1]",
    );
    let (line, _, message, _) = {
        match parse::<S>("[[faults]]\nat = 1\nkind = \"explode\"\n", "cfg.toml") {
            Err(ConfigError::Parse {
                line,
                column,
                message,
                ..
            }) => (line, column, message, ()),
            other => panic!("{other:?}"),
        }
    };
    assert_eq!(line, 3);
    assert!(message.contains("explode"));
}

#[test]
fn gateway_rules() {
    type G = GatewayConfig;
    rejects::<G>("[moos]\nport = 0\n", "moos.port", "port 0");
    rejects::<G>(
        "[moos]\n[interprocess]\nenabled = false\n",
        "interprocess.enabled",
        "enable [interprocess] or [goby3]",
    );
    // gobyd alone is enough.
    assert!(
        frontseat_config::parse::<G>(
            "[moos]\n[interprocess]\nenabled = false\n[goby3]\nenabled = true\n",
            "t"
        )
        .is_ok()
    );
    rejects::<G>(
        "[moos]\n[goby3]\nenabled = true\ntransport = \"tcp\"\ntcp_port = 0\n",
        "goby3.tcp_port",
        "port 0",
    );
    rejects::<G>(
        "[moos]\n[goby3]\nclient_name = \"gobyd\"\n",
        "goby3.client_name",
        "gobyd's own name",
    );
    rejects::<G>(
        "[moos]\n[goby3]\nmax_message_bytes = 512\n",
        "goby3.max_message_bytes",
        "at least 1024",
    );
    // 0 turns the length guard off; it is a valid choice.
    assert!(frontseat_config::parse::<G>("[moos]\n[goby3]\nmax_message_bytes = 0\n", "t").is_ok());
    rejects::<G>(
        "[moos]\n[telemetry]\nsampling_ratio = 3\n",
        "telemetry.sampling_ratio",
        "outside",
    );
}

#[test]
fn web_rules_and_the_non_loopback_warning() {
    rejects::<InterfaceConfig>(
        "[web]\nlisten = \"localhost\"\n",
        "web.listen",
        "address and port",
    );
    rejects::<InterfaceConfig>("[web]\ntoken = \"short\"\n", "web.token", "16 characters");
    rejects::<InterfaceConfig>(
        "[web]\nmax_connections = 0\n",
        "web.max_connections",
        "outside",
    );
    rejects::<InterfaceConfig>(
        "[web]\nmax_body_bytes = 10\n",
        "web.max_body_bytes",
        "outside",
    );
    let quiet: InterfaceConfig = parse(
        "[web]\nenabled = true\nlisten = \"127.0.0.1:50001\"\n",
        "cfg.toml",
    )
    .unwrap();
    assert!(quiet.warnings().is_empty());
    let open: InterfaceConfig = parse(
        "[web]\nenabled = true\nlisten = \"0.0.0.0:50001\"\n",
        "cfg.toml",
    )
    .unwrap();
    let w = open.warnings();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("web.listen") && w[0].contains("FRONTSEAT_WEB_TOKEN"),
        "{w:?}"
    );
    let with_token: InterfaceConfig = parse(
        "[web]\nenabled = true\nlisten = \"0.0.0.0:50001\"\ntoken = \"0123456789abcdef\"\n",
        "cfg.toml",
    )
    .unwrap();
    assert!(with_token.warnings().is_empty());
}

#[test]
fn navigation_limits_name_the_field() {
    type I = InterfaceConfig;
    let nav = |body: &str| format!("[limits.navigation]\n{body}\n");
    rejects::<I>(
        &nav("max_abs_speed = 0"),
        "limits.navigation.max_abs_speed",
        "greater than 0",
    );
    rejects::<I>(
        &nav("min_depth = 20\nmax_depth = 10"),
        "limits.navigation.min_depth",
        "greater than limits.navigation.max_depth",
    );
    rejects::<I>(
        &nav("max_depth = inf"),
        "limits.navigation.max_depth",
        "not a finite number",
    );
    rejects::<I>(
        &nav("max_abs_pitch = 91"),
        "limits.navigation.max_abs_pitch",
        "outside [0, 90]",
    );
    rejects::<I>(
        &nav("max_abs_roll = -1"),
        "limits.navigation.max_abs_roll",
        "outside [0, 180]",
    );
    rejects::<I>(
        &nav("max_altitude = -5"),
        "limits.navigation.max_altitude",
        "greater than 0",
    );
    rejects::<I>(
        &nav("max_abs_angular_rate = nan"),
        "limits.navigation.max_abs_angular_rate",
        "not a finite number",
    );
    let ok = frontseat_config::parse::<I>(
        &nav("max_abs_speed = 3\nmin_depth = 0\nmax_depth = 100"),
        "cfg.toml",
    )
    .expect("a narrower envelope is fine");
    assert_eq!(ok.limits.navigation.max_abs_speed, 3.0);
}
