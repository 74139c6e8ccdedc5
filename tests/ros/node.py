"""The independent ROS 2 graph of `bpins node`'s test (tests/ros_node.rs): a Zenoh
router (eclipse-zenoh, router mode, as `rmw_zenohd` is) and publishers and
subscribers from zenoh-ros2-sdk (PyPI; rmw_zenoh's wire format in Python: its own
key expressions, attachments, liveliness tokens and RIHS01 type hashes, computed
from the .msg files vendored in tests/data/ros2_msgs).

    node.py play PORT BAG OUT [--garbage]

starts the router on tcp/127.0.0.1:PORT, prints `ready`, waits for a node named
`bpins` to show its tokens, subscribes to /bpins/heading and /diagnostics, then
publishes the bag's messages (read with rosbags) on the node's default topics:
/camera/camera_info, /imu/data, /fix and /camera/image_raw, in the bag's order, each
image after the one before it has its answer. With --garbage a malformed image (a
few random bytes) and a mis-sized one go first; with --restart-router the router
goes away after the first frame and comes back; with --shm the SDK's session turns
on Zenoh's shared memory (ZENOH_CONFIG_OVERRIDE, as with rmw_zenoh) and the images
are published from its shared memory (ShmImages). Writes OUT (JSON): the graph's
tokens, the SDK's type hashes, and every Imu and DiagnosticArray received, as
`bags.py read` prints a bag's.
"""

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

import zenoh
import zenoh_ros2_sdk.message_registry as registry
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from zenoh_ros2_sdk import ROS2Publisher, ROS2Subscriber
from zenoh_ros2_sdk.utils import get_type_hash, load_dependencies_recursive

MSGS = Path(__file__).resolve().parents[1] / "data" / "ros2_msgs"
TS = get_typestore(Stores.ROS2_HUMBLE)
TYPES = ["sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo", "sensor_msgs/msg/Imu",
         "sensor_msgs/msg/NavSatFix", "diagnostic_msgs/msg/DiagnosticArray"]
TOPIC_OF = {"/cam/image_raw": "/camera/image_raw", "/cam/camera_info": "/camera/camera_info",
            "/imu/data": "/imu/data", "/gnss/fix": "/fix"}

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bags import yaw_deg  # noqa: E402


def fields(m):
    return {k: getattr(m, k) for k in m.__dataclass_fields__}


def entry(topic, typ, m):
    e = {"topic": topic, "type": typ,
         "stamp_ns": m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec,
         "frame_id": m.header.frame_id}
    if typ == "sensor_msgs/msg/Imu":
        q = m.orientation
        e.update(yaw_deg=yaw_deg(q), quaternion=[q.x, q.y, q.z, q.w],
                 orientation_covariance=[float(v) for v in m.orientation_covariance],
                 angular_velocity_covariance0=float(m.angular_velocity_covariance[0]),
                 linear_acceleration_covariance0=float(m.linear_acceleration_covariance[0]))
    else:
        s = m.status[0]
        e.update(level=int(s.level), name=s.name, message=s.message,
                 values={kv.key: kv.value for kv in s.values})
    return e


SHM_ON = "transport/shared_memory/enabled=true"


class ShmImages:
    """Images published from shared memory: serialized into a buffer of the
    session's own SHM provider (`size` bytes), sent as a reference to a partner that
    has shared memory on (a copy of the bytes to one that has not). rmw_zenoh with
    shared memory on leaves it to Zenoh's implicit optimization (a large payload
    copied into the session's pool), whose pool is made in the background on the
    first large message, so that the first few images go over TCP: explicit here, so
    that every image of a three-frame test goes through shared memory."""

    def __init__(self, publisher, size):
        self.p = publisher
        self.provider = zenoh.shm.ShmProvider.default_backend(size)

    def publish(self, **kw):
        p = self.p
        cdr = bytes(p.session_mgr.store.serialize_cdr(p.msg_class(**kw), p.msg_type))
        # Blocks until a buffer the subscribers have let go of is collected.
        buf = self.provider.alloc(len(cdr), zenoh.shm.BlockOn(zenoh.shm.GarbageCollect()))
        buf[:] = cdr
        p.pub.put(zenoh.ZBytes(buf), encoding=zenoh.Encoding("application/cdr"),
                  attachment=p._create_attachment(p.sequence_number, time.time_ns()))
        p.sequence_number += 1


def play(a):
    if a.shm:
        os.environ["ZENOH_CONFIG_OVERRIDE"] = SHM_ON
    registry._registry = registry.MessageRegistry(str(MSGS))
    hashes = {}
    for t in TYPES:
        d = registry._registry.get_msg_file_path(t).read_text()
        hashes[t] = get_type_hash(t, d, load_dependencies_recursive(t, d, registry._registry))
    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"')
    conf.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{a.port}"]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    router = zenoh.open(conf)
    print("ready", flush=True)

    tokens = set()
    deadline = time.time() + 60
    while time.time() < deadline:
        tokens = {str(r.ok.key_expr) for r in router.liveliness().get("@ros2_lv/**") if r.ok is not None}
        if any("/NN/" in t and t.endswith("/bpins") for t in tokens) and any("/MS/" in t for t in tokens):
            break
        time.sleep(0.2)
    else:
        sys.exit(f"no bpins node in the graph within 60 s; tokens: {sorted(tokens)}")

    got = []
    lock = threading.Condition()

    def on(topic, typ):
        def cb(m):
            with lock:
                got.append(entry(topic, typ, m))
                lock.notify_all()
        return cb

    kw = dict(router_ip="127.0.0.1", router_port=a.port, node_name="bpins_test")
    subs = [ROS2Subscriber("/bpins/heading", "sensor_msgs/msg/Imu", on("/bpins/heading", "sensor_msgs/msg/Imu"), **kw),
            ROS2Subscriber("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray",
                           on("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"), **kw)]
    pubs = {}

    def pub(topic, typ):
        if topic not in pubs:
            pubs[topic] = ROS2Publisher(topic, typ, **kw)
        return pubs[topic]

    def routed(p, within_s):
        """Whether the router routes publisher `p` to a subscriber within `within_s`
        seconds: a message published before the node's subscription has reached the
        router is lost, as in ROS 2 (Zenoh's matching status)."""
        deadline = time.time() + within_s
        while time.time() < deadline:
            if p.pub is not None and p.pub.matching_status.matching:
                return True
            time.sleep(0.1)
        return False

    def answers():
        return sum(1 for e in got if e["topic"] == "/bpins/heading"
                   or e.get("name") == "bpins heading")

    time.sleep(1.0)  # the node's subscriptions reach the SDK's session
    sent = 0

    def wait_answer():
        with lock:
            if not lock.wait_for(lambda: answers() >= sent, timeout=60):
                sys.exit(f"no answer to image {sent} within 60 s")

    image_pub = pub("/camera/image_raw", "sensor_msgs/msg/Image")
    shm = ShmImages(image_pub, 4 << 20) if a.shm else None
    if a.garbage:
        # Random bytes, then an image of the wrong size: both diagnostics, never a crash.
        image_pub.pub.put(b"\x00\x01\x00\x00\x07\x07", attachment=image_pub._create_attachment(0, 0))
        sent += 1
        wait_answer()
    with AnyReader([Path(a.bag)], default_typestore=TS) as r:
        msgs = [(c.topic, c.msgtype, r.deserialize(raw, c.msgtype)) for c, _, raw in r.messages()]
    if a.garbage:
        info = next(x for x in msgs if x[1] == "sensor_msgs/msg/CameraInfo")
        pub(TOPIC_OF[info[0]], info[1]).publish(**fields(info[2]))
        time.sleep(0.3)
        topic, typ, m = next(x for x in msgs if x[1] == "sensor_msgs/msg/Image")
        small = fields(m)
        small.update(width=m.width // 2, step=m.step // 2, data=m.data[: len(m.data) // 4])
        image_pub.publish(**small)
        sent += 1
        wait_answer()
    images = 0
    for topic, typ, m in msgs:
        p = pub(TOPIC_OF[topic], typ)
        if shm is not None and p is image_pub:
            shm.publish(**fields(m))
        else:
            p.publish(**fields(m))
        if typ == "sensor_msgs/msg/Image":
            sent += 1
            wait_answer()
            images += 1
            if a.restart_router and images == 1:
                # The router goes away and comes back on the same port: both the node
                # and the SDK's session reconnect (rmw_zenoh's retry), and the
                # frames after it are answered as before.
                router.close()
                time.sleep(1.0)
                router = zenoh.open(conf)
                deadline = time.time() + 30
                while time.time() < deadline:
                    back = {str(r.ok.key_expr) for r in router.liveliness().get("@ros2_lv/**") if r.ok is not None}
                    if any(t.endswith("/NN/%/%/bpins") for t in back) and any("/bpins_test" in t for t in back):
                        break
                    time.sleep(0.2)
                else:
                    sys.exit("the node or the SDK did not come back to the new router within 30 s")
                # The tokens are back before the routes may be: the next image waits
                # for the node's subscription on the new router (under load it came
                # later than a fixed second, and the image was lost).
                if not routed(image_pub, 30):
                    sys.exit("the node's image subscription did not reach the new router within 30 s")
                time.sleep(1.0)
    time.sleep(0.5)
    with lock:
        out = {"tokens": sorted(tokens), "hashes": hashes, "messages": list(got)}
    Path(a.out).write_text(json.dumps(out))
    for p in list(pubs.values()) + subs:
        p.close()
    # Wait for the node to leave the graph (it ends after its --frames), then stop.
    deadline = time.time() + 30
    while time.time() < deadline:
        left = [str(r.ok.key_expr) for r in router.liveliness().get("@ros2_lv/**") if r.ok is not None]
        if not any(t.endswith("/bpins") or "/bpins/" in t for t in left):
            break
        time.sleep(0.2)
    router.close()


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="cmd", required=True)
    pl = sub.add_parser("play")
    pl.add_argument("port", type=int)
    pl.add_argument("bag")
    pl.add_argument("out")
    pl.add_argument("--garbage", action="store_true")
    pl.add_argument("--restart-router", action="store_true", help="close and reopen the router after the first frame")
    pl.add_argument("--shm", action="store_true", help="the SDK's session with Zenoh's shared memory on")
    a = p.parse_args()
    play(a)


if __name__ == "__main__":
    main()
