#!/usr/bin/env python3
"""ROS 2 message types as Eclipse Cyclone DDS (PyPI `cyclonedds`) structs, for talking to a
frontseat vehicle's ROS 2 gateway with no ROS installed: what `rmw_cyclonedds_cpp` puts on the
wire, spelled out.

One table (MSGS) holds every field list in `.msg` syntax; the `IdlStruct` classes, their DDS type
names (`nav_msgs::msg::dds_::Odometry_`: what the ROS 2 rmw layers register, and DDS matches on
it exactly) and their RIHS01 type hashes (REP-2011, what Iron and later put in each endpoint's
USER_DATA) are all derived from it, so they cannot disagree. The frontseat_msgs entries must equal
ros2/frontseat_msgs/msg/*.msg field for field; `--self-test` checks that, the hashes against
ros2/type_hashes.txt, and the bytes of two standard messages against golden data encoded by hand.

    python3 -m pip install cyclonedds==11.0.1
    python3 examples/ros2/frontseat_ros2_types.py --self-test

Use: `import frontseat_ros2_types as T; T.Odometry(...)`, `T.ros_qos("sensor_data", T.Odometry)`,
`T.topic_name("auv1", "odom")` -> "rt/auv1/frontseat/odom". Call `T.loopback_only()` before
making the first DomainParticipant to keep DDS on this host (it sets CYCLONEDDS_URI unless set).
"""

import dataclasses
import hashlib
import json
import math
import os
import re
import struct
import sys
import types

# Keeps DDS discovery and data on 127.0.0.1 with no multicast: what rmw_cyclonedds_cpp writes for
# ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (Iron and later), plus the loopback interface pinned.
# ParticipantIndex auto (0-32) gives each participant fixed unicast ports that peers probe.
LOOPBACK_XML = (
    '<CycloneDDS><Domain Id="any"><General>'
    '<Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>"
    '<Peers><Peer address="127.0.0.1"/></Peers></Discovery></Domain></CycloneDDS>'
)


def loopback_only():
    """Cyclone reads CYCLONEDDS_URI (XML text or file://) when the first participant is made;
    a caller's own non-empty setting wins."""
    if not os.environ.get("CYCLONEDDS_URI"):
        os.environ["CYCLONEDDS_URI"] = LOOPBACK_XML


from cyclonedds.idl import IdlStruct  # noqa: E402
import cyclonedds.idl.types as t  # noqa: E402
from cyclonedds.qos import Policy, Qos  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

# Field lists in .msg order (wire order), "type name [default]". Standard types from
# ros2/common_interfaces, rcl_interfaces and rmw_dds_common (Jazzy); defaults are the .msg ones
# (not on the wire, not hashed). frontseat_msgs: ros2/frontseat_msgs/msg/*.msg, constants left out.
MSGS = {
    "builtin_interfaces/msg/Time": "int32 sec; uint32 nanosec",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp; string frame_id",
    "geometry_msgs/msg/Point": "float64 x; float64 y; float64 z",
    "geometry_msgs/msg/Vector3": "float64 x; float64 y; float64 z",
    "geometry_msgs/msg/Quaternion": "float64 x; float64 y; float64 z; float64 w 1",
    "geometry_msgs/msg/Pose": "Point position; Quaternion orientation",
    "geometry_msgs/msg/PoseWithCovariance": "Pose pose; float64[36] covariance",
    "geometry_msgs/msg/Twist": "Vector3 linear; Vector3 angular",
    "geometry_msgs/msg/TwistWithCovariance": "Twist twist; float64[36] covariance",
    "nav_msgs/msg/Odometry": "std_msgs/Header header; string child_frame_id; "
    "geometry_msgs/PoseWithCovariance pose; geometry_msgs/TwistWithCovariance twist",
    # status -2 = STATUS_UNKNOWN, Jazzy's default (Humble has neither; same wire layout)
    "sensor_msgs/msg/NavSatStatus": "int8 status -2; uint16 service",
    "sensor_msgs/msg/NavSatFix": "std_msgs/Header header; NavSatStatus status; float64 latitude; "
    "float64 longitude; float64 altitude; float64[9] position_covariance; "
    "uint8 position_covariance_type",
    "diagnostic_msgs/msg/KeyValue": "string key; string value",
    "diagnostic_msgs/msg/DiagnosticStatus": "byte level; string name; string message; "
    "string hardware_id; KeyValue[] values",
    "diagnostic_msgs/msg/DiagnosticArray": "std_msgs/Header header; DiagnosticStatus[] status",
    # The ROS graph (`ros2 node list`): Iron and later, Gid is 16 bytes (Humble: 24).
    "rmw_dds_common/msg/Gid": "char[16] data",
    "rmw_dds_common/msg/NodeEntitiesInfo": "string<=256 node_namespace; string<=256 node_name; "
    "Gid[] reader_gid_seq; Gid[] writer_gid_seq",
    "rmw_dds_common/msg/ParticipantEntitiesInfo": "Gid gid; NodeEntitiesInfo[] node_entities_info_seq",
    # frontseat_msgs: Goby3's protobuf messages; `bool has_<f>` before each proto2 optional field.
    "frontseat_msgs/msg/LatLonPoint": "float64 lat; float64 lon; bool has_depth; float64 depth; "
    "bool has_altitude; float64 altitude",
    "frontseat_msgs/msg/CartesianCoordinate": "float64 x; float64 y; bool has_z; float64 z",
    "frontseat_msgs/msg/EulerAngles": "bool has_roll; float64 roll; bool has_pitch; float64 pitch; "
    "bool has_heading; float64 heading; bool has_course_over_ground; float64 course_over_ground; "
    "bool has_roll_rate; float64 roll_rate; bool has_pitch_rate; float64 pitch_rate; "
    "bool has_heading_rate; float64 heading_rate",
    "frontseat_msgs/msg/Speed": "float64 over_ground; bool has_over_water; float64 over_water",
    "frontseat_msgs/msg/Source": "bool has_position; int32 position; bool has_depth; int32 depth; "
    "bool has_speed; int32 speed; bool has_heading; int32 heading",
    "frontseat_msgs/msg/NodeStatus": "float64 time; bool has_name; string name; bool has_type; "
    "int32 type; LatLonPoint global_fix; bool has_local_fix; CartesianCoordinate local_fix; "
    "EulerAngles pose; Speed speed; bool has_source; Source source",
    "frontseat_msgs/msg/InterfaceStatus": "bool has_state; int32 state; bool has_frontseat_state; "
    "int32 frontseat_state; bool has_helm_state; int32 helm_state; bool has_helm_error; "
    "int32 helm_error; bool has_frontseat_error; int32 frontseat_error; "
    "bool has_frontseat_providing_data; bool frontseat_providing_data",
    "frontseat_msgs/msg/DesiredCourse": "float64 time; bool has_heading; float64 heading; "
    "bool has_speed; float64 speed; bool has_depth; float64 depth; bool has_pitch; float64 pitch; "
    "bool has_roll; float64 roll; bool has_z_rate; float64 z_rate; bool has_altitude; "
    "float64 altitude",
    "frontseat_msgs/msg/HelmStateReport": "int32 state",
    "frontseat_msgs/msg/CommandRequest": "bool has_desired_course; DesiredCourse desired_course; "
    "bool has_response_requested; bool response_requested; bool has_request_id; int32 request_id; "
    "bool has_cancel_request_id; int32 cancel_request_id",
    "frontseat_msgs/msg/CommandResponse": "bool has_request_successful; bool request_successful; "
    "bool has_request_id; int32 request_id; bool has_error_code; int32 error_code; "
    "bool has_error_string; string error_string",
}

# Enum values of frontseat_msgs (the .msg constants; the protobuf enums).
INTERFACE_STANDBY, INTERFACE_LISTEN, INTERFACE_COMMAND, INTERFACE_HELM_ERROR, INTERFACE_FS_ERROR = 1, 2, 3, 4, 5
INTERFACE_STATE_NAMES = {1: "INTERFACE_STANDBY", 2: "INTERFACE_LISTEN", 3: "INTERFACE_COMMAND",
                         4: "INTERFACE_HELM_ERROR", 5: "INTERFACE_FS_ERROR"}
HELM_NOT_RUNNING, HELM_DRIVE, HELM_PARK = 0, 1, 2

PRIMITIVES = {
    "bool": bool, "byte": t.byte, "char": t.uint8, "int8": t.int8, "uint8": t.uint8,
    "int16": t.int16, "uint16": t.uint16, "int32": t.int32, "uint32": t.uint32,
    "int64": t.int64, "uint64": t.uint64, "float32": t.float32, "float64": t.float64,
    "string": str,
}
_DECL = re.compile(r"^([A-Za-z0-9_/]+?)(?:<=(\d+))?(?:\[(<=)?(\d*)\])?$")


def parse_fields(name):
    """[(field, base type, string bound or None, (kind, n) or None, default text or None)] of a
    MSGS entry; kind "array" (T[N]) or "seq" (T[] with n None, T[<=N])."""
    pkg = name.split("/")[0]
    out = []
    for decl in MSGS[name].split(";"):
        parts = decl.split()
        m = _DECL.match(parts[0])
        base, strcap, bounded, n = m.group(1), m.group(2), m.group(3), m.group(4)
        if base not in PRIMITIVES:
            p, _, short = base.rpartition("/")
            base = "{}/msg/{}".format(p or pkg, short)
        coll = None
        if "[" in parts[0]:
            coll = ("array", int(n)) if n and not bounded else ("seq", int(n) if n else None)
        out.append((parts[1], base, int(strcap) if strcap else None, coll, parts[2] if len(parts) > 2 else None))
    return out


def dds_type_name(ros_name):
    """'nav_msgs/msg/Odometry' -> 'nav_msgs::msg::dds_::Odometry_' (rmw's mangling)."""
    pkg, kind, short = ros_name.split("/")
    return "{}::{}::dds_::{}_".format(pkg, kind, short)


def ros_type_name(dds_name):
    """'nav_msgs::msg::dds_::Odometry_' -> 'nav_msgs/msg/Odometry'; None when not a ROS type."""
    m = re.fullmatch(r"(\w+)::(msg|srv|action)::dds_::(\w+)_", dds_name or "")
    return "{}/{}/{}".format(*m.groups()) if m else None


CLASSES = {}  # ROS name -> IdlStruct class
ROS_NAME = {}  # class -> ROS name


def _build(name):
    if name in CLASSES:
        return CLASSES[name]
    annotations, defaults = {}, {}
    for fname, base, strcap, coll, default in parse_fields(name):
        if base in PRIMITIVES:
            el = t.bounded_str[strcap] if strcap else PRIMITIVES[base]
            if base == "string":
                zero = ""
            elif base == "bool":
                zero = False
            elif base.startswith("float"):
                zero = float(default) if default else 0.0
            else:
                zero = int(default) if default else 0
            make = (lambda z: lambda: z)(zero)
        else:
            el = _build(base)
            make = el
        if coll and coll[0] == "array":
            annotations[fname] = t.array[el, coll[1]]
            defaults[fname] = dataclasses.field(default_factory=(lambda m, k: lambda: [m() for _ in range(k)])(make, coll[1]))
        elif coll:
            annotations[fname] = t.sequence[el, coll[1]] if coll[1] else t.sequence[el]
            defaults[fname] = dataclasses.field(default_factory=list)
        elif base in PRIMITIVES:
            annotations[fname] = el
            defaults[fname] = make()
        else:
            annotations[fname] = el
            defaults[fname] = dataclasses.field(default_factory=el)

    def body(ns):
        ns["__annotations__"] = annotations
        ns.update(defaults)
        ns["__module__"] = __name__

    cls = dataclasses.dataclass(
        types.new_class(name.split("/")[-1], (IdlStruct,), {"typename": dds_type_name(name)}, body))
    CLASSES[name], ROS_NAME[cls] = cls, name
    return cls


for _n in MSGS:
    globals()[_n.split("/")[-1]] = _build(_n)

# --- topics and QoS ---------------------------------------------------------------------------

# What the gateway publishes (per vehicle, under /<platform>/frontseat/) and subscribes.
# (topic, ROS type, QoS profile a subscriber uses). Navigation is sensor data (best effort reaches
# both best-effort and reliable publishers); commands and status reliable.
PUBLISHED = [
    ("odom", "nav_msgs/msg/Odometry", "sensor_data"),
    ("fix", "sensor_msgs/msg/NavSatFix", "sensor_data"),
    ("node_status", "frontseat_msgs/msg/NodeStatus", "sensor_data"),
    ("status", "frontseat_msgs/msg/InterfaceStatus", "default"),
    ("command_response", "frontseat_msgs/msg/CommandResponse", "default"),
    ("diagnostics", "diagnostic_msgs/msg/DiagnosticArray", "default"),
]
SUBSCRIBED = [
    ("desired_course", "frontseat_msgs/msg/DesiredCourse", "default"),
    ("helm_state", "frontseat_msgs/msg/HelmStateReport", "default"),
    ("command_request", "frontseat_msgs/msg/CommandRequest", "default"),
]


def ros_topic(namespace, name):
    """'auv1', 'odom' -> '/auv1/frontseat/odom'; a name starting '/' is absolute ('/diagnostics')."""
    return name if name.startswith("/") else "/{}/frontseat/{}".format(namespace.strip("/"), name)


def topic_name(namespace, name):
    """The DDS topic: 'rt' + the ROS topic ('rt/auv1/frontseat/odom')."""
    return "rt" + ros_topic(namespace, name)


# Data representation XCDR1: the only one both ROS rmws accept.
XCDR1 = Policy.DataRepresentation(use_cdrv0_representation=True)


def ros_qos(profile="default", cls=None):
    """rmw's QoS: 'default' (reliable, volatile, keep last 10), 'sensor_data' (best effort,
    volatile, keep last 5), 'discovery' (the ros_discovery_info writer: reliable, transient local,
    keep last 1) or 'discovery_reader' (keep all). With `cls`, the type hash goes in USER_DATA as
    rmw puts it on every topic endpoint (`typehash=RIHS01_...;`)."""
    rel = (Policy.Reliability.BestEffort if profile == "sensor_data"
           else Policy.Reliability.Reliable(max_blocking_time=duration(infinite=True)))
    durability = Policy.Durability.TransientLocal if profile.startswith("discovery") else Policy.Durability.Volatile
    history = {"default": Policy.History.KeepLast(10), "sensor_data": Policy.History.KeepLast(5),
               "discovery": Policy.History.KeepLast(1), "discovery_reader": Policy.History.KeepAll}[profile]
    pols = [rel, durability, history, XCDR1]
    if cls is not None:
        pols.append(Policy.Userdata(data="typehash={};".format(rihs01(ROS_NAME[cls])).encode()))
    return Qos(*pols)


# --- RIHS01 type hashes (REP-2011) --------------------------------------------------------------

# type_description_interfaces/msg/FieldType ids (rosidl_generator_type_description).
_TYPE_ID = {"int8": 2, "uint8": 3, "char": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7,
            "int64": 8, "uint64": 9, "float32": 10, "float64": 11, "bool": 15, "byte": 16,
            "string": 17}
_NESTED, _BOUNDED_STRING, _ARRAY, _BOUNDED_SEQ, _UNBOUNDED_SEQ = 1, 21, 48, 96, 144


def _description(name):
    fields = []
    for fname, base, strcap, coll, _ in parse_fields(name):
        if base in _TYPE_ID:
            tid, nested = (_BOUNDED_STRING if strcap else _TYPE_ID[base]), ""
        else:
            tid, nested = _NESTED, base
        cap = 0
        if coll and coll[0] == "array":
            tid, cap = tid + _ARRAY, coll[1]
        elif coll:
            tid, cap = (tid + _BOUNDED_SEQ, coll[1]) if coll[1] else (tid + _UNBOUNDED_SEQ, 0)
        fields.append({"name": fname, "type": {"type_id": tid, "capacity": cap,
                                               "string_capacity": strcap or 0, "nested_type_name": nested}})
    return {"type_name": name, "fields": fields}


def rihs01(name):
    """SHA-256 of the JSON type description (the type and every type it refers to, sorted),
    defaults and constants excluded: what rosidl generates and rmw advertises."""
    refs, todo = set(), [name]
    while todo:
        for f in _description(todo.pop())["fields"]:
            n = f["type"]["nested_type_name"]
            if n and n not in refs:
                refs.add(n)
                todo.append(n)
    doc = {"type_description": _description(name),
           "referenced_type_descriptions": [_description(n) for n in sorted(refs)]}
    text = json.dumps(doc, ensure_ascii=True, separators=(", ", ": "))
    return "RIHS01_" + hashlib.sha256(text.encode()).hexdigest()


# --- JSON ---------------------------------------------------------------------------------------


def to_json(sample):
    """A sample as plain JSON values. NaN and infinities become null (JSON has none)."""
    if dataclasses.is_dataclass(sample):
        return {f.name: to_json(getattr(sample, f.name)) for f in dataclasses.fields(sample)}
    if isinstance(sample, (list, tuple)):
        return [to_json(v) for v in sample]
    if isinstance(sample, float) and not math.isfinite(sample):
        return None
    if isinstance(sample, bytes):
        return list(sample)
    return sample


# --- self-test ----------------------------------------------------------------------------------

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


class HandCdr:
    """XCDR1 little-endian by hand (struct only), from the rules rather than from Cyclone: every
    primitive aligned to its size (at most 8) counted after the 4-byte header; string = u32
    length with the NUL, bytes, NUL; T[N] no count; nested structs inline."""

    def __init__(self):
        self.b = bytearray()

    def put(self, fmt, v):
        size = struct.calcsize("<" + fmt)
        self.b += b"\0" * ((-len(self.b)) % min(size, 8))
        self.b += struct.pack("<" + fmt, v)
        return self

    def string(self, s):
        raw = s.encode() + b"\0"
        self.put("I", len(raw))
        self.b += raw
        return self

    def payload(self):
        return b"\x00\x01\x00\x00" + bytes(self.b)


def _odometry_golden_sample():
    """The facts file's sample: frame odom, child base_link, heading 030 -> ENU yaw +60 deg."""
    cov = [0.0] * 36
    for i, v in enumerate([0.25, 0.25, 0.04, 0.001, 0.001, 0.003]):
        cov[i * 7] = v
    yaw = math.radians(90.0 - 30.0)
    q = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    o = Odometry(  # noqa: F821 (built from MSGS)
        header=Header(stamp=Time(sec=1700000000, nanosec=500000000), frame_id="odom"),  # noqa: F821
        child_frame_id="base_link",
        pose=PoseWithCovariance(  # noqa: F821
            pose=Pose(position=Point(x=12.5, y=-3.25, z=-2.0),  # noqa: F821
                      orientation=Quaternion(x=q[0], y=q[1], z=q[2], w=q[3])),  # noqa: F821
            covariance=list(cov)),
        twist=TwistWithCovariance(  # noqa: F821
            twist=Twist(linear=Vector3(x=1.5), angular=Vector3(z=0.01)),  # noqa: F821
            covariance=list(cov)))
    h = HandCdr().put("i", 1700000000).put("I", 500000000).string("odom").string("base_link")
    for v in (12.5, -3.25, -2.0) + q + tuple(cov) + (1.5, 0.0, 0.0, 0.0, 0.0, 0.01) + tuple(cov):
        h.put("d", v)
    return o, h.payload()


def _navsatfix_golden_sample():
    f = NavSatFix(  # noqa: F821
        header=Header(stamp=Time(sec=1700000000, nanosec=0), frame_id="gps"),  # noqa: F821
        status=NavSatStatus(status=0, service=1),  # noqa: F821
        latitude=42.358, longitude=-71.0875, altitude=float("nan"),
        position_covariance=[4.0, 0, 0, 0, 4.0, 0, 0, 0, 9.0], position_covariance_type=2)
    h = HandCdr().put("i", 1700000000).put("I", 0).string("gps").put("b", 0).put("H", 1)
    for v in (42.358, -71.0875, float("nan"), 4.0, 0, 0, 0, 4.0, 0, 0, 0, 9.0):
        h.put("d", v)
    h.put("B", 2)
    return f, h.payload()


def _read_golden(path):
    """Hex lines after '#' comment lines -> bytes."""
    with open(path) as fh:
        return bytes.fromhex("".join(ln.split("#")[0] for ln in fh))


def _msg_file_fields(path):
    """A .msg file's fields as 'type name' (comments and constants dropped)."""
    out = []
    with open(path) as fh:
        for line in fh:
            line = line.split("#")[0].strip()
            if not line or "=" in line:
                continue
            typ, name = line.split()[:2]
            out.append("{} {}".format(typ, name))
    return out


def self_test(ros2_dir=os.path.join(ROOT, "ros2")):
    """ros2_dir: the repository's ros2/ folder (frontseat_msgs/msg, type_hashes.txt), or a copy."""
    fails = []

    def check(ok, what):
        print(("ok    " if ok else "FAIL  ") + what, flush=True)
        if not ok:
            fails.append(what)

    # 1. Bytes: hand encoder == golden file == Cyclone's serializer; Cyclone reads them back.
    for label, make, golden in (("nav_msgs/msg/Odometry", _odometry_golden_sample, "odometry_heading030.hex"),
                                ("sensor_msgs/msg/NavSatFix", _navsatfix_golden_sample, "navsatfix_gps.hex")):
        sample, hand = make()
        gold = _read_golden(os.path.join(HERE, "golden", golden))
        ser = sample.serialize()
        check(hand == gold, "{}: hand-encoded bytes == golden/{} ({} B)".format(label, golden, len(gold)))
        check(ser == gold, "{}: cyclonedds serialize() == golden ({} B)".format(label, len(ser)))
        back = type(sample).deserialize(gold)
        check(to_json(back) == to_json(sample), "{}: cyclonedds deserializes the golden bytes back".format(label))
    # Anchors from the facts file's annotated Odometry dump (offsets after the header).
    gold = _read_golden(os.path.join(HERE, "golden", "odometry_heading030.hex"))[4:]
    check(gold[0:4] == bytes.fromhex("00f15365") and gold[80:88] == bytes.fromhex("ffffffffffffdf3f")
          and gold[88:96] == bytes.fromhex("ab4c58e87ab6eb3f") and gold[424:432] == bytes.fromhex("7b14ae47e17a843f")
          and len(gold) == 720, "Odometry golden: stamp, qz, qw, angular.z at the documented offsets, 720 B")
    # 2. DDS type names as the rmw layers mangle them.
    check(Odometry.__idl_typename__ == "nav_msgs::msg::dds_::Odometry_"  # noqa: F821
          and ParticipantEntitiesInfo.__idl_typename__ == "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"  # noqa: F821
          and DesiredCourse.__idl_typename__ == "frontseat_msgs::msg::dds_::DesiredCourse_",  # noqa: F821
          "DDS type names <pkg>::msg::dds_::<Type>_")
    # 3. frontseat_msgs twins == ros2/frontseat_msgs/msg/*.msg, field for field.
    msg_dir = os.path.join(ros2_dir, "frontseat_msgs", "msg")
    files = sorted(f[:-4] for f in os.listdir(msg_dir) if f.endswith(".msg"))
    ours = sorted(n.split("/")[-1] for n in MSGS if n.startswith("frontseat_msgs/"))
    check(files == ours, "frontseat_msgs: the same {} messages as ros2/frontseat_msgs/msg ({})".format(len(files), ", ".join(files)))
    with open(os.path.join(ros2_dir, "frontseat_msgs", "CMakeLists.txt")) as fh:
        listed = sorted(re.findall(r'"msg/(\w+)\.msg"', fh.read()))
    check(listed == files, "frontseat_msgs/CMakeLists.txt generates every msg/*.msg")
    for short in files:
        want = _msg_file_fields(os.path.join(msg_dir, short + ".msg"))
        name = "frontseat_msgs/msg/" + short
        have = [" ".join(d.split()[:2]) for d in MSGS.get(name, "").split(";")] if name in MSGS else []
        check(want == have, "frontseat_msgs/{}: {} fields as in {}.msg".format(short, len(want), short))
    # 4. Type hashes: published reference values, and ros2/type_hashes.txt (the gateway's).
    reference = {  # from the ROS 2 sources' own outputs, as quoted in the protocol notes
        "rmw_dds_common/msg/ParticipantEntitiesInfo": "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e",
        "nav_msgs/msg/Odometry": "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
        "sensor_msgs/msg/NavSatFix": "RIHS01_62223ab3fe210a15976021da7afddc9e200dc9ec75231c1b6a557fc598a65404",
        "diagnostic_msgs/msg/KeyValue": "RIHS01_d68081eaa540288c5440753baecef0c4e16e81a5f78ad68902ded5100413bb42",
    }
    for name, h in reference.items():
        check(rihs01(name) == h, "{} hash {}...".format(name, h[:23]))
    with open(os.path.join(ros2_dir, "type_hashes.txt")) as fh:
        listed = dict(ln.split() for ln in fh if ln.strip() and not ln.startswith("#"))
    mine = [n for n in MSGS if n in listed]
    bad = [n for n in mine if rihs01(n) != listed[n]]
    missing = [n for n in MSGS if n.startswith("frontseat_msgs/") and n not in listed]
    check(not bad and not missing and len(mine) >= len(ours),
          "ros2/type_hashes.txt: {} of our types listed, all equal{}".format(len(mine), "" if not bad else " except " + ", ".join(bad)))
    # 5. A frontseat_msgs sample through Cyclone and back, NaN to JSON null.
    dc = DesiredCourse(time=1.5, has_heading=True, heading=90.0, has_speed=True, speed=float("nan"))  # noqa: F821
    back = DesiredCourse.deserialize(dc.serialize())  # noqa: F821
    check(back.heading == 90.0 and math.isnan(back.speed) and to_json(back)["speed"] is None
          and len(dc.serialize()) == 4 + 8 + 7 * 16, "DesiredCourse round trip, 124 B, NaN -> null in JSON")
    print("self-test:", "PASS" if not fails else "FAIL ({} checks)".format(len(fails)), flush=True)
    return 0 if not fails else 1


if __name__ == "__main__":
    if sys.argv[1:] == ["--self-test"]:
        sys.exit(self_test())
    if sys.argv[1:2] == ["--self-test"] and sys.argv[2:3] == ["--ros2-dir"] and len(sys.argv) == 4:
        sys.exit(self_test(sys.argv[3]))
    if sys.argv[1:] == ["--hashes"]:
        for n in MSGS:
            print(n, rihs01(n))
        sys.exit(0)
    print("usage: frontseat_ros2_types.py --self-test [--ros2-dir DIR] | --hashes", file=sys.stderr)
    sys.exit(2)
