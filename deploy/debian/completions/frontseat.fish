# Print an optspec for argparse to handle cmd's options that are independent of any subcommand.
function __fish_frontseat_global_optspecs
    string join \n h/help V/version
end

function __fish_frontseat_needs_command
    # Figure out if the current invocation already has a command.
    set -l cmd (commandline -opc)
    set -e cmd[1]
    argparse -s (__fish_frontseat_global_optspecs) -- $cmd 2>/dev/null
    or return
    if set -q argv[1]
        # Also print the command, so this can be used to figure out what it is.
        echo $argv[1]
        return 1
    end
    return 0
end

function __fish_frontseat_using_subcommand
    set -l cmd (__fish_frontseat_needs_command)
    test -z "$cmd"
    and return 1
    contains -- $cmd[1] $argv
end

complete -c frontseat -n "__fish_frontseat_needs_command" -s h -l help -d 'Print help (see more with \'--help\')'
complete -c frontseat -n "__fish_frontseat_needs_command" -s V -l version -d 'Print version'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "interface" -d 'Run the frontseat interface service (goby_frontseat_interface): driver, state machine, status, and the MOOS bridge when the config has a [moos] section'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "sim" -d 'Run the basic frontseat simulator (TCP server, one vehicle per connection)'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "moos-gateway" -d 'The MOOS bridge alone (Goby3\'s goby_moos_gateway): FrontSeatTranslation between a MOOSDB (pHelmIvP) and the interface, reached over Zenoh'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "driver-host" -d 'Internal: the child process a driver plugin runs in (started by the interface)'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "chaos" -d 'Inject seeded faults into the real simulator, interface, helm and MOOS bridge; print the invariants table; exit non-zero on any violation. Needs `[chaos] enabled = true` in a config given with -c (the embedded default has it)'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "demo" -d 'Simulator + interface + example helm in one process: drives the homework path east, south, then northwest back towards the start, prints a live status line, writes the track as CSV and SVG, and exits 0'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "bench" -d 'Measure latency, throughput, capacity and footprint; prints one table (`--quick` runs in seconds)'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "interfaces" -d 'Print the resolved interface (application → layer → publishes/subscribes → group, type, actor) of every application, as compiled from interface_yaml/'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "launch" -d 'Start and supervise a fleet from one TOML file: simulators, one interface per vehicle, helms, a topside, any command — in order, each waited for until ready; Ctrl-C or SIGTERM stops all in reverse order; the exit code is 10 + the start position of a process that failed past its restart policy'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "topside" -d 'Every vehicle of a fleet on one web page, from what their interfaces publish over Zenoh (`*/goby/middleware/frontseat/node_status`, `status`, `desired_course`): map, states, errors, stale vehicles; links to each vehicle\'s own scope and commander'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "log" -d 'Look into a recording (MCAP, from `[record]` or `demo --record`): `info`, `export`, `plot`; `import` converts a goby_logger `.goby` file to MCAP'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "replay" -d 'Publish a recording\'s vehicle side (node_status, status, ...) onto Zenoh or a Goby3 gobyd as it was recorded, so a helm under test meets the recorded vehicle. Never commands a vehicle'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "completions" -d 'Print a shell completion script: `frontseat completions bash > /etc/bash_completion.d/frontseat` (zsh: a `_frontseat` file on $fpath; fish: ~/.config/fish/completions/frontseat.fish)'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "man-pages" -d 'Internal: write the man pages (frontseat.1, one per subcommand) into DIR; the packaged pages are these, checked against the committed copy by tests/docs.rs'
complete -c frontseat -n "__fish_frontseat_needs_command" -f -a "help" -d 'Print this message or the help of the given subcommand(s)'
complete -c frontseat -n "__fish_frontseat_using_subcommand interface" -s c -l config -d 'Configuration file: TOML, or a Goby3 .pb.cfg of the Goby3 application this replaces. `--example_config` prints a complete TOML one' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand interface" -l import-goby3 -d 'Print the TOML equivalent of a Goby3 .pb.cfg of the Goby3 application this replaces (goby_frontseat_interface, goby_moos_gateway), a comment per field, and exit. `-c FILE.pb.cfg` runs such a file as it is' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand interface" -l example_config -d 'Print a complete example config (every field, its default, unit and description) and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand interface" -l schema -d 'Print the JSON Schema of the config and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand interface" -l check -d 'Validate the config given with -c and exit: 0 when valid, 2 with the errors otherwise'
complete -c frontseat -n "__fish_frontseat_using_subcommand interface" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -s c -l config -d 'Configuration file: TOML, or a Goby3 .pb.cfg of the Goby3 application this replaces. `--example_config` prints a complete TOML one' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l import-goby3 -d 'Print the TOML equivalent of a Goby3 .pb.cfg of the Goby3 application this replaces (goby_frontseat_interface, goby_moos_gateway), a comment per field, and exit. `-c FILE.pb.cfg` runs such a file as it is' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l port -d 'TCP port to listen on (overrides the config)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l bind -d 'Address to bind (overrides the config; default 127.0.0.1, loopback only)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l vehicle -d 'Vehicle protocol to emulate' -r -f -a "basic\t'The basic simulator\'s line protocol over TCP (the default)'
iver3\t'Iver3 UVC Remote Helm NMEA'
waveglider_sv2\t'Wave Glider SV2 C&C binary frames'
bluefin\t'Bluefin Huxley payload NMEA over TCP (port 29500 unless `--port`; see bluefin_sim.rs)'
ardupilot\t'ArduPilot Rover (motorboat) over MAVLink 2'
dune\t'An LSTS DUNE LAUV over IMC on its BackSeat TCP server (port 6006 unless `--tcp`)'
ardusub\t'ArduSub (BlueROV2) over MAVLink 2: dives to the depths the helm asks for'"
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l tcp -d 'Serve the emulator on this loopback TCP port. For iver3, waveglider_sv2, ardupilot and ardusub: serial-over-IP instead of a new pseudo-terminal; for dune: its BackSeat port instead of 6006. 0 picks a free port. (bluefin takes `--port`; the basic simulator, its config\'s port.)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l remote-helm-version -d 'Iver3: Remote Helm major version (below 5 $OMS depth is feet)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l emulator-warp -d 'Run simulated time this many times faster' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l refusal -d 'Bluefin: how the emulated Huxley answers commands' -r -f -a "none\t'Acknowledge everything as successful'
commands\t'Acknowledge commands as failed (status 1)'
silent\t'Acknowledge nothing (an unresponsive Huxley that still streams navigation)'
pending-first\t'Acknowledge commands as pending first, then successful'"
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l example_config -d 'Print a complete example config (every field, its default, unit and description) and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l schema -d 'Print the JSON Schema of the config and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -l check -d 'Validate the config given with -c and exit: 0 when valid, 2 with the errors otherwise'
complete -c frontseat -n "__fish_frontseat_using_subcommand sim" -s h -l help -d 'Print help (see more with \'--help\')'
complete -c frontseat -n "__fish_frontseat_using_subcommand moos-gateway" -s c -l config -d 'Configuration file: TOML, or a Goby3 .pb.cfg of the Goby3 application this replaces. `--example_config` prints a complete TOML one' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand moos-gateway" -l import-goby3 -d 'Print the TOML equivalent of a Goby3 .pb.cfg of the Goby3 application this replaces (goby_frontseat_interface, goby_moos_gateway), a comment per field, and exit. `-c FILE.pb.cfg` runs such a file as it is' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand moos-gateway" -l example_config -d 'Print a complete example config (every field, its default, unit and description) and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand moos-gateway" -l schema -d 'Print the JSON Schema of the config and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand moos-gateway" -l check -d 'Validate the config given with -c and exit: 0 when valid, 2 with the errors otherwise'
complete -c frontseat -n "__fish_frontseat_using_subcommand moos-gateway" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand driver-host" -l library -d 'The driver library (.so) to load' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand driver-host" -l check -d 'Only check that the library loads, has every symbol and the right ABI version; exit 0 if so, else 3 (file missing), 4 (symbol missing), 5 (ABI mismatch), 6 (not loadable)'
complete -c frontseat -n "__fish_frontseat_using_subcommand driver-host" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l seed -d 'Seed of the fault schedule: the same seed gives the same faults, parameters and timings' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l faults -d 'How many faults to inject' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l warp -d 'Time warp (overrides the config\'s sim_warp_factor; the embedded config uses 100)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -s c -l config -d 'Interface config (TOML); it must contain `[chaos]` with `enabled = true`. Without -c an embedded config with chaos enabled is used. The simulator and the MOOS broker always run in this process on loopback, whatever the config\'s addresses say' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l recovery-bound -d 'Wall seconds within which the interface must be back in COMMAND after a fault clears' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l rss-growth-mib -d 'Largest allowed growth of the resident set over its warm baseline, MiB' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l soak -d 'Soak: inject faults for this long (wall time, e.g. `20m`, `2h`) instead of `--faults`, reporting RSS, open fds, threads and tasks every `--sample-every`; the report adds a table of the samples and fails on a drift' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l sample-every -d 'How often a soak samples and prints the process\'s resources (e.g. `1m`, `30s`)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l only -d 'Only these faults, comma-separated (e.g. `moos-crash-loop,web-flood`; `--only help` lists them): to find which fault a resource drift comes with' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l vehicle -d 'The vehicle to run: `basic` (the basic simulator, the default) or a vehicle family — `bluefin`, `iver3`, `waveglider_sv2`, `ardupilot`, `ardusub`, `dune` — whose emulator and real driver run behind a chaos link that drops, silences, delays and corrupts the line in the vehicle\'s own protocol. A family run takes no MOOS bridge and no --soak' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l no-moos -d 'Leave out the MOOS bridge and the broker-restart fault'
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -l print-config -d 'Print the embedded default config and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand chaos" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l warp -d 'Run faster than real time: simulator ticks and every interface timer speed up N times' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l out -d 'Where the track CSV and SVG go' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l east -d 'Seconds (simulated) of the east leg' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l south -d 'Seconds (simulated) of the south leg' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l vehicle -d 'Fly a vehicle emulator through its real driver instead of the basic simulator: bluefin, ardupilot or ardusub (loopback TCP; ardusub dives 5 m, 10 m, 5 m), iver3 or waveglider_sv2 (pseudo-terminal)' -r -f -a "basic\t'The basic simulator\'s line protocol over TCP (the default)'
iver3\t'Iver3 UVC Remote Helm NMEA'
waveglider_sv2\t'Wave Glider SV2 C&C binary frames'
bluefin\t'Bluefin Huxley payload NMEA over TCP (port 29500 unless `--port`; see bluefin_sim.rs)'
ardupilot\t'ArduPilot Rover (motorboat) over MAVLink 2'
dune\t'An LSTS DUNE LAUV over IMC on its BackSeat TCP server (port 6006 unless `--tcp`)'
ardusub\t'ArduSub (BlueROV2) over MAVLink 2: dives to the depths the helm asks for'"
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l web-listen -d 'Address of the web scope with --web' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l record -d 'Record every group of the run to this MCAP file (`frontseat log info FILE` reads it). An existing FILE is kept unless --force' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l fleet -d 'Fly a fleet of N vehicles (2 to 12; 3 when no number is given): one simulator, one `frontseat interface` process per vehicle (each its own Zenoh platform), a leader on the homework path and N-1 followers trailing it in a V from the leader\'s node_status received over Zenoh. Writes track-<vehicle>.csv per vehicle (track-leader.csv for the leader), fleet.svg and the fleet\'s launch file' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l trail-behind -d 'With --fleet: how far behind the leader each pair of followers keeps. Unit: m' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l trail-side -d 'With --fleet: how far to the side of the leader the followers keep (right, then left). Unit: m' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l fleet-connect -d 'With --fleet: fly only the helms, against interfaces already running elsewhere (other hosts): their Zenoh endpoints, leader first, comma-separated (`tcp/10.0.0.11:7447,tcp/10.0.0.12:7447`). Nothing is launched' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l ais -d 'With --fleet: send the fleet\'s AIS (NMEA 0183 `!AIVDM`, class B targets) to this UDP address, e.g. OpenCPN\'s UDP input `127.0.0.1:10110`. The vehicles get MMSIs 299000001, 299000002, ... (the leader first), from the range for simulated vehicles' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l lines -d 'Print one status line per simulated second instead of a live line'
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l web -d 'Also serve the web scope and commander (on 127.0.0.1:50001 unless --web-listen)'
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -l force -d 'With --record: replace FILE if it exists (the new recording is renamed onto it at the end)'
complete -c frontseat -n "__fish_frontseat_using_subcommand demo" -s h -l help -d 'Print help (see more with \'--help\')'
complete -c frontseat -n "__fish_frontseat_using_subcommand bench" -l rows -d 'Only these rows, comma-separated (e.g. `--rows P1,P2,M1,M2` for an A/B of two builds). Floors: L0 (loopback line → a task wakes) always runs; L1 (→ a thread blocked in read(2)), L2 (a pseudo-terminal line → a task wakes), L3 (an SSE event → the client parses it) and L4 (a Zenoh put in another process → a subscriber here) run with the rows they are floors of; every latency row gives its ratio over its own floor. Vehicle families, each through its emulator: B1/B2 Bluefin (TCP), I1/I2 Iver3, S1/S2 Wave Glider SV2 (pty), A1/A2 ArduPilot Rover, U1/U2 ArduSub, D1/D2 DUNE (TCP); <F>1 navigation → node_status, <F>2 desired_course → the command read at the vehicle. Rows that share a setup run together (M1/M2, P4/P5, Z1–Z3/T1, a family\'s two); the table shows only the rows asked for' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand bench" -l against -d 'A/B against another build: runs this build\'s bench and that `frontseat` executable\'s alternately, `--pairs` times each, and prints mean and median p50/p99 of every latency row with the change (e.g. `--against /tmp/frontseat-old --rows P1,P2,M1,M2`). A build without `--rows` runs its whole table' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand bench" -l pairs -d 'How many runs of each build `--against` makes' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand bench" -l quick -d 'Run in seconds, to prove the benchmark runs (CI); figures are rough'
complete -c frontseat -n "__fish_frontseat_using_subcommand bench" -l json -d 'Print the results as JSON instead of the Markdown table'
complete -c frontseat -n "__fish_frontseat_using_subcommand bench" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand interfaces" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand launch" -s c -l config -d 'Configuration file: TOML, or a Goby3 .pb.cfg of the Goby3 application this replaces. `--example_config` prints a complete TOML one' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand launch" -l import-goby3 -d 'Print the TOML equivalent of a Goby3 .pb.cfg of the Goby3 application this replaces (goby_frontseat_interface, goby_moos_gateway), a comment per field, and exit. `-c FILE.pb.cfg` runs such a file as it is' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand launch" -l example_config -d 'Print a complete example config (every field, its default, unit and description) and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand launch" -l schema -d 'Print the JSON Schema of the config and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand launch" -l check -d 'Validate the config given with -c and exit: 0 when valid, 2 with the errors otherwise'
complete -c frontseat -n "__fish_frontseat_using_subcommand launch" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand topside" -s c -l config -d 'Configuration file: TOML, or a Goby3 .pb.cfg of the Goby3 application this replaces. `--example_config` prints a complete TOML one' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand topside" -l import-goby3 -d 'Print the TOML equivalent of a Goby3 .pb.cfg of the Goby3 application this replaces (goby_frontseat_interface, goby_moos_gateway), a comment per field, and exit. `-c FILE.pb.cfg` runs such a file as it is' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand topside" -l example_config -d 'Print a complete example config (every field, its default, unit and description) and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand topside" -l schema -d 'Print the JSON Schema of the config and exit'
complete -c frontseat -n "__fish_frontseat_using_subcommand topside" -l check -d 'Validate the config given with -c and exit: 0 when valid, 2 with the errors otherwise'
complete -c frontseat -n "__fish_frontseat_using_subcommand topside" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and not __fish_seen_subcommand_from info export import recover plot help" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and not __fish_seen_subcommand_from info export import recover plot help" -f -a "info" -d 'Span, groups with counts, rates and gaps, the recorder\'s drops, and whether the file was closed or cut short (read up to its last whole chunk)'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and not __fish_seen_subcommand_from info export import recover plot help" -f -a "export" -d 'One group\'s messages as CSV (fields flattened by path) or JSON Lines, decoded with the schema stored in the file'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and not __fish_seen_subcommand_from info export import recover plot help" -f -a "import" -d 'Converts a goby_logger `.goby` file to MCAP, using the protobuf descriptors the file carries (types this binary does not know are kept). PROTOBUF entries are converted; DCCL, CSTR and other schemes are counted and skipped; damaged entries (bad CRC) are skipped and the rest of the file is still read'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and not __fish_seen_subcommand_from info export import recover plot help" -f -a "recover" -d 'Finishes a recording that a crash (SIGKILL, power loss) left without its summary, so that every MCAP reader opens it (Foxglove, the Python and C++ readers\' ordinary open): the messages, channels, schemas and metadata up to the last whole chunk are written again with the summary, indexes and footer into a new file beside FILE, which is synced, read back, and renamed over FILE. What `mcap recover` does, for frontseat\'s recordings only'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and not __fish_seen_subcommand_from info export import recover plot help" -f -a "plot" -d 'Writes DIR/track.svg (the recorded track on the local grid) and DIR/time.svg (speed, heading and depth against time, actual from node_status, commanded from desired_course, over a band of the interface\'s state from its status group)'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and not __fish_seen_subcommand_from info export import recover plot help" -f -a "help" -d 'Print this message or the help of the given subcommand(s)'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from info" -l json -d 'Print JSON instead of the table'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from info" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from export" -l group -d 'The Goby3 group, e.g. goby::middleware::frontseat::node_status' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from export" -l format -r -f -a "csv\t''
json\t''"
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from export" -s o -l output -d 'Write here instead of standard output (through a temporary file beside it, renamed at the end; never the input file)' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from export" -l force -d 'Replace the output file if it exists'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from export" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from import" -s o -l output -d 'The MCAP file to write (default: FILE with the extension .mcap)' -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from import" -l force -d 'Replace the output file if it exists'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from import" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from recover" -l compression -d 'Chunk compression of the finished file' -r -f -a "zstd\t''
lz4\t''
none\t''"
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from recover" -s h -l help -d 'Print help (see more with \'--help\')'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from plot" -l out -r -F
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from plot" -l force -d 'Replace track.svg and time.svg if they exist'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from plot" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from help" -f -a "info" -d 'Span, groups with counts, rates and gaps, the recorder\'s drops, and whether the file was closed or cut short (read up to its last whole chunk)'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from help" -f -a "export" -d 'One group\'s messages as CSV (fields flattened by path) or JSON Lines, decoded with the schema stored in the file'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from help" -f -a "import" -d 'Converts a goby_logger `.goby` file to MCAP, using the protobuf descriptors the file carries (types this binary does not know are kept). PROTOBUF entries are converted; DCCL, CSTR and other schemes are counted and skipped; damaged entries (bad CRC) are skipped and the rest of the file is still read'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from help" -f -a "recover" -d 'Finishes a recording that a crash (SIGKILL, power loss) left without its summary, so that every MCAP reader opens it (Foxglove, the Python and C++ readers\' ordinary open): the messages, channels, schemas and metadata up to the last whole chunk are written again with the summary, indexes and footer into a new file beside FILE, which is synced, read back, and renamed over FILE. What `mcap recover` does, for frontseat\'s recordings only'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from help" -f -a "plot" -d 'Writes DIR/track.svg (the recorded track on the local grid) and DIR/time.svg (speed, heading and depth against time, actual from node_status, commanded from desired_course, over a band of the interface\'s state from its status group)'
complete -c frontseat -n "__fish_frontseat_using_subcommand log; and __fish_seen_subcommand_from help" -f -a "help" -d 'Print this message or the help of the given subcommand(s)'
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l speed -d 'Speed: a factor (2 = twice as fast) or `max`' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l from -d 'Start this many seconds after the first message of the file' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l to -d 'Stop this many seconds after the first message of the file' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l groups -d 'Only groups matching this regex (among the vehicle\'s publications)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l platform -d 'Zenoh platform (key prefix), or the Goby3 platform with `--onto gobyd`; default: the vehicle name recorded in the file' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l listen -d 'Zenoh endpoints to listen on (default tcp/127.0.0.1:7447, as the interface)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l connect -d 'Zenoh endpoints to connect to' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l onto -d 'Where the replay goes: Zenoh (as a frontseat interface publishes), a Goby3 gobyd (as goby_frontseat_interface publishes: Goby3 applications and pHelmIvP through goby_moos_gateway see the recorded vehicle), or this process\'s bus only' -r -f -a "zenoh\t''
gobyd\t''
bus\t''"
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l goby-socket -d 'gobyd\'s IPC socket base (Goby3\'s socket_name; default /tmp/goby_<platform>)' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l goby-tcp -d 'gobyd\'s manager over TCP instead of IPC, e.g. 127.0.0.1:11144' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l goby-client-name -d 'The name given to gobyd\'s manager' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l goby-wait -d 'How long to wait for gobyd before giving up. Unit: s' -r
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l loop -d 'Start over at the end, until Ctrl-C'
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -l no-zenoh -d 'Publish onto this process\'s bus only (for tests and benches): the same as `--onto bus`'
complete -c frontseat -n "__fish_frontseat_using_subcommand replay" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand completions" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand man-pages" -s h -l help -d 'Print help'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "interface" -d 'Run the frontseat interface service (goby_frontseat_interface): driver, state machine, status, and the MOOS bridge when the config has a [moos] section'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "sim" -d 'Run the basic frontseat simulator (TCP server, one vehicle per connection)'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "moos-gateway" -d 'The MOOS bridge alone (Goby3\'s goby_moos_gateway): FrontSeatTranslation between a MOOSDB (pHelmIvP) and the interface, reached over Zenoh'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "driver-host" -d 'Internal: the child process a driver plugin runs in (started by the interface)'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "chaos" -d 'Inject seeded faults into the real simulator, interface, helm and MOOS bridge; print the invariants table; exit non-zero on any violation. Needs `[chaos] enabled = true` in a config given with -c (the embedded default has it)'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "demo" -d 'Simulator + interface + example helm in one process: drives the homework path east, south, then northwest back towards the start, prints a live status line, writes the track as CSV and SVG, and exits 0'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "bench" -d 'Measure latency, throughput, capacity and footprint; prints one table (`--quick` runs in seconds)'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "interfaces" -d 'Print the resolved interface (application → layer → publishes/subscribes → group, type, actor) of every application, as compiled from interface_yaml/'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "launch" -d 'Start and supervise a fleet from one TOML file: simulators, one interface per vehicle, helms, a topside, any command — in order, each waited for until ready; Ctrl-C or SIGTERM stops all in reverse order; the exit code is 10 + the start position of a process that failed past its restart policy'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "topside" -d 'Every vehicle of a fleet on one web page, from what their interfaces publish over Zenoh (`*/goby/middleware/frontseat/node_status`, `status`, `desired_course`): map, states, errors, stale vehicles; links to each vehicle\'s own scope and commander'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "log" -d 'Look into a recording (MCAP, from `[record]` or `demo --record`): `info`, `export`, `plot`; `import` converts a goby_logger `.goby` file to MCAP'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "replay" -d 'Publish a recording\'s vehicle side (node_status, status, ...) onto Zenoh or a Goby3 gobyd as it was recorded, so a helm under test meets the recorded vehicle. Never commands a vehicle'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "completions" -d 'Print a shell completion script: `frontseat completions bash > /etc/bash_completion.d/frontseat` (zsh: a `_frontseat` file on $fpath; fish: ~/.config/fish/completions/frontseat.fish)'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "man-pages" -d 'Internal: write the man pages (frontseat.1, one per subcommand) into DIR; the packaged pages are these, checked against the committed copy by tests/docs.rs'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and not __fish_seen_subcommand_from interface sim moos-gateway driver-host chaos demo bench interfaces launch topside log replay completions man-pages help" -f -a "help" -d 'Print this message or the help of the given subcommand(s)'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and __fish_seen_subcommand_from log" -f -a "info" -d 'Span, groups with counts, rates and gaps, the recorder\'s drops, and whether the file was closed or cut short (read up to its last whole chunk)'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and __fish_seen_subcommand_from log" -f -a "export" -d 'One group\'s messages as CSV (fields flattened by path) or JSON Lines, decoded with the schema stored in the file'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and __fish_seen_subcommand_from log" -f -a "import" -d 'Converts a goby_logger `.goby` file to MCAP, using the protobuf descriptors the file carries (types this binary does not know are kept). PROTOBUF entries are converted; DCCL, CSTR and other schemes are counted and skipped; damaged entries (bad CRC) are skipped and the rest of the file is still read'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and __fish_seen_subcommand_from log" -f -a "recover" -d 'Finishes a recording that a crash (SIGKILL, power loss) left without its summary, so that every MCAP reader opens it (Foxglove, the Python and C++ readers\' ordinary open): the messages, channels, schemas and metadata up to the last whole chunk are written again with the summary, indexes and footer into a new file beside FILE, which is synced, read back, and renamed over FILE. What `mcap recover` does, for frontseat\'s recordings only'
complete -c frontseat -n "__fish_frontseat_using_subcommand help; and __fish_seen_subcommand_from log" -f -a "plot" -d 'Writes DIR/track.svg (the recorded track on the local grid) and DIR/time.svg (speed, heading and depth against time, actual from node_status, commanded from desired_course, over a band of the interface\'s state from its status group)'
