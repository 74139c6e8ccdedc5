"""Latency and rate of `bpins node` (BENCHMARKS.md, "Live node"): not a test.

    node_bench.py BPINS CAPTURE --hz 10 --n 100

starts a Zenoh router on a free localhost port, a `bpins node` (the binary BPINS)
with the capture's sun and sensor, and zenoh-ros2-sdk publishers of CameraInfo and of
the capture's first frame as mono16 images stamped with the time they are published,
at --hz; a subscriber of /bpins/heading and /diagnostics matches each answer to its
image by stamp. Prints the latency (image published → answer received, both clocks
this host's) p50, p99 and max, the answers, the frames the node dropped, and the
node's CPU time per frame read (utime + stime from /proc, over the run).

--shm turns on Zenoh's shared memory in the SDK's session (ZENOH_CONFIG_OVERRIDE,
as with rmw_zenoh: `transport/shared_memory/enabled=true`) and publishes the images
from it (node.py's ShmImages), so that the node reads each in place instead of
receiving it over TCP.
"""

import argparse
import json
import os
import socket
import subprocess
import sys
import threading
import time
import tomllib
from pathlib import Path

import numpy as np
import zenoh
import zenoh_ros2_sdk.message_registry as registry
from PIL import Image as PilImage
from zenoh_ros2_sdk import ROS2Publisher, ROS2Subscriber

MSGS = Path(__file__).resolve().parents[1] / "data" / "ros2_msgs"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from node import SHM_ON, ShmImages  # noqa: E402


def cpu_s(pid):
    f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("bpins")
    p.add_argument("capture")
    p.add_argument("--hz", type=float, default=10.0)
    p.add_argument("--n", type=int, default=100)
    p.add_argument("--shm", action="store_true")
    a = p.parse_args()
    if a.shm:
        os.environ["ZENOH_CONFIG_OVERRIDE"] = SHM_ON
    registry._registry = registry.MessageRegistry(str(MSGS))
    cap = Path(a.capture)
    spec = tomllib.loads((cap / "capture.toml").read_text())
    s, lens, fr = spec["sensor"], spec["lens"], spec["frames"][0]
    w, h = s["width_px"], s["height_px"]
    f_px = lens["focal_length_mm"] * 1000.0 / s["pixel_pitch_um"]
    cx, cy = lens.get("principal_point_px", [(w - 1) / 2, (h - 1) / 2])
    dn = np.asarray(PilImage.open(cap / fr["file"]), dtype=np.uint16)
    data = dn.astype("<u2").view(np.uint8).reshape(-1)

    with socket.socket() as so:
        so.bind(("127.0.0.1", 0))
        port = so.getsockname()[1]
    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"')
    conf.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    router = zenoh.open(conf)
    node = subprocess.Popen(
        [a.bpins, "node", "--connect", f"tcp/127.0.0.1:{port}", "--imu-topic", "none",
         "--bit-depth", str(s.get("bit_depth", 12)), "--black-level-dn", str(s.get("black_level_dn", 0)),
         "--sun-azimuth-deg", str(fr["sun_azimuth_deg"]), "--sun-elevation-deg", str(fr["sun_elevation_deg"])],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline:
        toks = [str(r.ok.key_expr) for r in router.liveliness().get("@ros2_lv/**") if r.ok is not None]
        if any("/MS/" in t and "%camera%image_raw" in t for t in toks):
            break
        time.sleep(0.2)
    kw = dict(router_ip="127.0.0.1", router_port=port, node_name="bench")
    sent, got, statuses, kinds = {}, {}, [], {}
    lock = threading.Lock()

    def on_answer(m):
        t = time.monotonic()
        ns = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
        with lock:
            if hasattr(m, "status") and m.status[0].name == "bpins node":
                statuses.append({kv.key: kv.value for kv in m.status[0].values})
            elif ns in sent:
                got[ns] = t
                kinds[ns] = "diagnostic" if hasattr(m, "status") else "heading"

    subs = [ROS2Subscriber("/bpins/heading", "sensor_msgs/msg/Imu", on_answer, **kw),
            ROS2Subscriber("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", on_answer, **kw)]
    info_pub = ROS2Publisher("/camera/camera_info", "sensor_msgs/msg/CameraInfo", **kw)
    img_pub = ROS2Publisher("/camera/image_raw", "sensor_msgs/msg/Image", **kw)
    T = info_pub.session_mgr.store.types
    # Room for a few frames: the node holds the one it reads and the one waiting.
    publish = ShmImages(img_pub, 4 * (len(data) + 4096)).publish if a.shm else img_pub.publish

    def header(ns):
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
            sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id="cam")

    roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    model = "equidistant" if lens["projection"] == "equidistant" else "plumb_bob"
    info_pub.publish(header=header(time.time_ns()), height=h, width=w, distortion_model=model,
                     d=np.zeros(4 if model == "equidistant" else 5),
                     k=np.array([f_px, 0, cx, 0, f_px, cy, 0, 0, 1.0]), r=np.eye(3).flatten(),
                     p=np.array([f_px, 0, cx, 0, 0, f_px, cy, 0, 0, 0, 1, 0.0]), binning_x=0, binning_y=0, roi=roi)
    time.sleep(2.0)
    # Warm-up: the compass is built on the first frame.
    ns = time.time_ns()
    sent[ns] = time.monotonic()
    publish(header=header(ns), height=h, width=w, encoding="mono16", is_bigendian=0, step=2 * w, data=data)
    while ns not in got and time.time() < deadline + 60:
        time.sleep(0.01)
    with lock:
        sent.clear()
        got.clear()
        kinds.clear()
    cpu0 = cpu_s(node.pid)
    period = 1.0 / a.hz
    t_next = time.monotonic()
    for _ in range(a.n):
        t_next += period
        ns = time.time_ns()
        with lock:
            sent[ns] = time.monotonic()
        publish(header=header(ns), height=h, width=w, encoding="mono16", is_bigendian=0, step=2 * w, data=data)
        time.sleep(max(0.0, t_next - time.monotonic()))
    time.sleep(2.0)
    cpu1 = cpu_s(node.pid)
    node.terminate()
    err = node.communicate(timeout=30)[1]
    with lock:
        lat = sorted((got[k] - sent[k]) * 1e3 for k in got)
    read = int(statuses[-1]["frames_read"]) if statuses else len(lat)
    closing = [ln for ln in err.splitlines() if "closing" in ln]
    pct = lambda q: lat[min(len(lat) - 1, int(q * len(lat)))] if lat else float("nan")  # noqa: E731
    headings = sum(1 for k in got if kinds.get(k) == "heading")
    print(f"{w}x{h} at {a.hz} Hz, {a.n} images: {len(lat)} answered ({headings} headings); latency ms p50 {pct(0.5):.1f} "
          f"p99 {pct(0.99):.1f} max {lat[-1] if lat else float('nan'):.1f}; node CPU "
          f"{(cpu1 - cpu0) / max(1, len(lat)) * 1e3:.1f} ms per frame answered; {closing[-1] if closing else err}")
    for x in subs + [info_pub, img_pub]:
        x.close()
    router.close()


if __name__ == "__main__":
    sys.exit(main())
