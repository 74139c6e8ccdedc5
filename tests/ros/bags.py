"""The independent side of bpins' ROS 2 bag tests (tests/ros.rs),
with `rosbags` (pure Python, no ROS):

    bags.py write CAPTURE BAG [options]   a capture's frames as a rosbag2 bag (or a split one)
    bags.py read BAG                      a bag's Imu and DiagnosticArray messages, as JSON

`write` stamps frame i at T0 + i·DT seconds and writes each as sensor_msgs/Image
(mono16 or mono8, either byte order, rows padded to any step), optionally with a
CameraInfo, Imu samples 5 ms before and after each frame holding the frame's
reference tilt (REP 103 body frame of docs/ros2.md: x the image top, z the optical
axis), and NavSatFix fixes. `read` prints what a ROS consumer would see: stamps,
frame ids, the ENU yaw of each orientation (computed here from the quaternion),
covariances and diagnostic messages.
"""

import argparse
import json
import math
import sys
import tomllib
from pathlib import Path

import numpy as np
from PIL import Image as PilImage
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from ruamel.yaml import YAML

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types


def stamp(ns):
    return T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header(ns, frame_id):
    return T["std_msgs/msg/Header"](stamp=stamp(ns), frame_id=frame_id)


def quat_zyx(yaw, pitch, roll):
    """world_from_body = Rz(yaw)·Ry(pitch)·Rx(roll) as (x, y, z, w), radians."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def write(a):
    """The capture as one bag, or (--split-after N) as rosbag2 splits a recording
    (`ros2 bag record --max-bag-size`): frames 0..N in BAG/BAG_0, the rest in BAG/BAG_1,
    each storage file with its own connections, one metadata.yaml listing both."""
    if a.split_after is None:
        write_frames(a, a.bag, None)
        return
    bag = Path(a.bag)
    parts = [bag.with_name(bag.name + f".part{k}") for k in (0, 1)]
    write_frames(a, parts[0], range(0, a.split_after))
    write_frames(a, parts[1], range(a.split_after, 1 << 30))
    yaml = YAML()
    metas = [yaml.load((p / "metadata.yaml").read_text()) for p in parts]
    info = metas[0]["rosbag2_bagfile_information"]
    bag.mkdir()
    names = []
    for k, (p, m) in enumerate(zip(parts, metas)):
        i = m["rosbag2_bagfile_information"]
        (old,) = i["relative_file_paths"]
        name = f"{bag.name}_{k}{Path(old).suffix}"
        (p / old).rename(bag / name)
        names.append(name)
        for f in i.get("files", []):
            f["path"] = name
        if k:
            info["files"] = list(info.get("files", [])) + list(i.get("files", []))
            info["message_count"] += i["message_count"]
            counts = {t["topic_metadata"]["name"]: t["message_count"] for t in i["topics_with_message_count"]}
            for t in info["topics_with_message_count"]:
                t["message_count"] += counts.get(t["topic_metadata"]["name"], 0)
            end = i["starting_time"]["nanoseconds_since_epoch"] + i["duration"]["nanoseconds"]
            info["duration"]["nanoseconds"] = end - info["starting_time"]["nanoseconds_since_epoch"]
        (p / "metadata.yaml").unlink()
        p.rmdir()
    info["relative_file_paths"] = names
    with open(bag / "metadata.yaml", "w") as f:
        yaml.dump(metas[0], f)


def write_frames(a, bag_path, frames):
    """The frames of the capture whose indices are in `frames` (all if None) as a bag."""
    cap = Path(a.capture)
    spec = tomllib.loads((cap / "capture.toml").read_text())
    s, lens = spec["sensor"], spec["lens"]
    w, h = s["width_px"], s["height_px"]
    f_px = lens["focal_length_mm"] * 1000.0 / s["pixel_pitch_um"]
    cx, cy = lens.get("principal_point_px", [(w - 1) / 2, (h - 1) / 2])
    plugin = StoragePlugin.MCAP if a.storage == "mcap" else StoragePlugin.SQLITE3
    le = not a.cdr_big_endian
    with Writer(bag_path, version=9, storage_plugin=plugin) as bag:
        def conn(topic, typ):
            return bag.add_connection(topic, typ, typestore=TS)

        c_img = conn(a.image_topic, "sensor_msgs/msg/Image")
        c_info = conn("/cam/camera_info", "sensor_msgs/msg/CameraInfo") if a.camera_info else None
        c_imu = conn("/imu/data", "sensor_msgs/msg/Imu") if a.imu else None
        c_fix = conn("/gnss/fix", "sensor_msgs/msg/NavSatFix") if a.fix else None
        for i, fr in enumerate(spec["frames"]):
            if frames is not None and i not in frames:
                continue
            t_ns = a.t0_ns + i * a.dt_ns
            if c_info is not None:
                k = np.array([f_px, 0, cx, 0, f_px, cy, 0, 0, 1], dtype=np.float64)
                p = np.array([f_px, 0, cx, 0, 0, f_px, cy, 0, 0, 0, 1, 0], dtype=np.float64)
                roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
                model = lens["projection"] == "equidistant" and "equidistant" or "plumb_bob"
                info = T["sensor_msgs/msg/CameraInfo"](
                    header=header(t_ns, "cam"), height=h, width=w, distortion_model=model,
                    d=np.zeros(5 if model == "plumb_bob" else 4), k=k, r=np.eye(3).flatten(), p=p,
                    binning_x=0, binning_y=0, roi=roi)
                bag.write(c_info, t_ns, TS.serialize_cdr(info, info.__msgtype__, little_endian=le))
            if c_imu is not None:
                tx, ty = fr.get("tilt_x_deg", 0.0), fr.get("tilt_y_deg", 0.0)
                var = math.radians(fr.get("tilt_sigma_deg", 0.0)) ** 2
                # REP 103 body: pitch = tilt_x, roll = −tilt_y; any yaw (an IMU's drifts).
                x, y, z, qw = quat_zyx(math.radians(17.0 + i), math.radians(tx), math.radians(-ty))
                for dt in (-5_000_000, 5_000_000):
                    vals = [x, y, z, qw]
                    if a.nan_imu_frame == i:
                        vals[0] = float("nan")
                    imu = T["sensor_msgs/msg/Imu"](
                        header=header(t_ns + dt, "imu"),
                        orientation=T["geometry_msgs/msg/Quaternion"](x=vals[0], y=vals[1], z=vals[2], w=vals[3]),
                        orientation_covariance=np.array([var, 0, 0, 0, var, 0, 0, 0, 0.01]),
                        angular_velocity=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                        angular_velocity_covariance=np.zeros(9),
                        linear_acceleration=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=9.81),
                        linear_acceleration_covariance=np.zeros(9))
                    bag.write(c_imu, t_ns + dt, TS.serialize_cdr(imu, imu.__msgtype__, little_endian=le))
            if c_fix is not None:
                lat, lon = (float(v) for v in a.fix.split(","))
                fix = T["sensor_msgs/msg/NavSatFix"](
                    header=header(t_ns, "gnss"),
                    status=T["sensor_msgs/msg/NavSatStatus"](status=0, service=1),
                    latitude=lat, longitude=lon, altitude=10.0,
                    position_covariance=np.zeros(9), position_covariance_type=0)
                bag.write(c_fix, t_ns, TS.serialize_cdr(fix, fix.__msgtype__, little_endian=le))
            dn = np.asarray(PilImage.open(cap / fr["file"]), dtype=np.uint16)
            assert dn.shape == (h, w), dn.shape
            if a.mono8:
                assert dn.max() <= 255, f"{fr['file']}: DN up to {dn.max()} does not fit mono8"
                row = dn.astype(np.uint8)
                enc, big = "mono8", 0
            else:
                row = dn.astype(">u2" if a.big_endian_pixels else "<u2").view(np.uint8).reshape(h, 2 * w)
                enc, big = "mono16", int(a.big_endian_pixels)
            if a.pad:
                row = np.hstack([row, np.full((h, a.pad), 0xAB, dtype=np.uint8)])
            img = T["sensor_msgs/msg/Image"](
                header=header(t_ns, "cam"), height=h, width=w, encoding=a.encoding or enc, is_bigendian=big,
                step=row.shape[1], data=np.ascontiguousarray(row).flatten())
            bag.write(c_img, t_ns, TS.serialize_cdr(img, img.__msgtype__, little_endian=le))


def yaw_deg(q):
    """ENU yaw (ZYX), counter-clockwise from East, of a quaternion, degrees."""
    return math.degrees(math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))


def read(a):
    out = []
    with AnyReader([Path(a.bag)], default_typestore=TS) as r:
        for c, t, raw in r.messages():
            m = r.deserialize(raw, c.msgtype)
            e = {"topic": c.topic, "type": c.msgtype, "log_time_ns": t,
                 "stamp_ns": m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec,
                 "frame_id": m.header.frame_id}
            if c.msgtype == "sensor_msgs/msg/Imu":
                q = m.orientation
                e.update(yaw_deg=yaw_deg(q), quaternion=[q.x, q.y, q.z, q.w],
                         orientation_covariance=[float(v) for v in m.orientation_covariance],
                         angular_velocity_covariance0=float(m.angular_velocity_covariance[0]),
                         linear_acceleration_covariance0=float(m.linear_acceleration_covariance[0]))
            else:
                s = m.status[0]
                e.update(level=int(s.level), name=s.name, message=s.message,
                         values={kv.key: kv.value for kv in s.values})
            out.append(e)
    json.dump(out, sys.stdout)


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("write")
    w.add_argument("capture")
    w.add_argument("bag")
    w.add_argument("--storage", choices=["mcap", "sqlite3"], default="mcap")
    w.add_argument("--image-topic", default="/cam/image_raw")
    w.add_argument("--camera-info", action="store_true")
    w.add_argument("--imu", action="store_true")
    w.add_argument("--fix", help="LAT,LON of a NavSatFix per frame")
    w.add_argument("--t0-ns", type=int, default=1_782_009_000_000_000_000)
    w.add_argument("--dt-ns", type=int, default=100_000_000)
    w.add_argument("--mono8", action="store_true")
    w.add_argument("--big-endian-pixels", action="store_true")
    w.add_argument("--cdr-big-endian", action="store_true")
    w.add_argument("--pad", type=int, default=0, help="bytes of padding after each row")
    w.add_argument("--encoding", help="write this encoding name instead")
    w.add_argument("--split-after", type=int, help="a split bag: frames from this one on in a second file")
    w.add_argument("--nan-imu-frame", type=int, default=-1, help="NaN in the IMU samples of this frame")
    r = sub.add_parser("read")
    r.add_argument("bag")
    a = p.parse_args()
    write(a) if a.cmd == "write" else read(a)


if __name__ == "__main__":
    main()
