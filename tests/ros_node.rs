//! `bpins node` against an independent ROS 2 graph: a Zenoh router and publishers and
//! subscribers of zenoh-ros2-sdk (PyPI: rmw_zenoh's wire format in Python, with its
//! own key expressions, attachments, liveliness tokens and type hashes), driven by
//! tests/ros/node.py. The node must show up in the graph, read the images, CameraInfo,
//! Imu and NavSatFix the SDK publishes, and answer each image with the very messages
//! `bpins heading --bag --bag-out` writes for a recording of the same messages (bit for
//! bit: one code path); a malformed and a mis-sized image must be diagnostics; the
//! router going away and coming back must be survived; SIGTERM must end it cleanly,
//! with or without a router.
//!
//! Needs the `.venv` of crates/bpins-py/requirements-test.txt (eclipse-zenoh,
//! zenoh-ros2-sdk, rosbags); without it the tests count as ignored (tests/needs/mod.rs),
//! and fail where `CI` is set.

#[path = "needs/mod.rs"]
mod needs;

use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

const REPO: &str = env!("CARGO_MANIFEST_DIR");
const BAGS_PY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros/bags.py");
const NODE_PY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros/node.py");
const SENSOR: [&str; 4] = ["--bit-depth", "12", "--black-level-dn", "64"];

fn python() -> Option<PathBuf> {
    let p =
        std::env::var_os("BPINS_PYTHON").map(PathBuf::from).unwrap_or_else(|| Path::new(REPO).join(".venv/bin/python"));
    p.is_file().then_some(p)
}

fn main() -> std::process::ExitCode {
    let missing = match python() {
        None => Some(
            "no Python environment at .venv; make it with `python3 -m venv .venv && \
             .venv/bin/pip install -r crates/bpins-py/requirements-test.txt` (`.ci/run` does)"
                .to_string(),
        ),
        Some(py) => {
            match Command::new(&py).args(["-c", "import zenoh, zenoh_ros2_sdk, rosbags, numpy, PIL"]).output() {
                Ok(o) if o.status.success() => None,
                _ => Some(format!(
                    "{} lacks eclipse-zenoh, zenoh-ros2-sdk, rosbags, numpy or Pillow; `{} -m pip install -r \
                 crates/bpins-py/requirements-test.txt`",
                    py.display(),
                    py.display()
                )),
            }
        }
    };
    needs::run(vec![
        (
            needs::Need::new("a Python environment with zenoh-ros2-sdk", missing),
            vec![
                (
                    "a_live_node_answers_the_sdks_graph_as_the_bag_route_does",
                    a_live_node_answers_the_sdks_graph_as_the_bag_route_does,
                ),
                (
                    "the_node_survives_its_router_going_away_and_coming_back",
                    the_node_survives_its_router_going_away_and_coming_back,
                ),
                ("images_in_shared_memory_are_read_in_place", images_in_shared_memory_are_read_in_place),
            ],
        ),
        (
            needs::Need::none(),
            vec![("sigterm_ends_a_node_without_a_router_cleanly", sigterm_ends_a_node_without_a_router_cleanly)],
        ),
    ])
}

fn run(cmd: &mut Command) -> Output {
    let o = cmd.output().expect("command runs");
    if needs::verbose() {
        println!("{}\n{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    }
    o
}

fn ok(o: Output) -> Output {
    assert!(
        o.status.success(),
        "failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn bpins(args: &[&str]) -> Output {
    run(Command::new(env!("CARGO_BIN_EXE_bpins")).args(args))
}

fn tmp() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().unwrap()).path()
}

/// A free TCP port on localhost.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// Waits for `child` at most `limit`; kills it past that.
fn wait(child: &mut std::process::Child, limit: Duration, what: &str) -> std::process::ExitStatus {
    let t0 = Instant::now();
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            panic!("{what} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A capture under the sun of 2026-06-21T02:30:00Z at Qingdao, tilted; its bag with
/// CameraInfo, Imu samples around each frame and a NavSatFix; and what `bpins heading
/// --bag --bag-out` writes for it, as `bags.py read` prints it.
fn recording() -> &'static (PathBuf, Value) {
    static R: OnceLock<(PathBuf, Value)> = OnceLock::new();
    R.get_or_init(|| {
        let cap = tmp().join("cap");
        let c = cap.to_str().unwrap();
        ok(bpins(&[
            "simulate",
            "--out",
            c,
            "--width-px",
            "306",
            "--height-px",
            "256",
            "--pixel-pitch-um",
            "27.6",
            "--headings-deg",
            "30,250,100",
            "--tilt-x-deg",
            "2",
            "--tilt-y-deg",
            "-1",
            "--imu-sigma-deg",
            "0.1",
            "--time-utc",
            "2026-06-21T02:30:00Z",
            "--latitude-deg",
            "36.07",
            "--longitude-deg",
            "120.38",
        ]));
        let bag = tmp().join("bag");
        let py = python().expect("main checked");
        ok(run(Command::new(&py).arg(BAGS_PY).args([
            "write",
            c,
            bag.to_str().unwrap(),
            "--camera-info",
            "--imu",
            "--fix",
            "36.07,120.38",
        ])));
        let out_bag = tmp().join("bag_out");
        let mut args = vec!["heading", "--bag", bag.to_str().unwrap(), "--bag-out", out_bag.to_str().unwrap()];
        args.extend_from_slice(&SENSOR);
        ok(bpins(&args));
        let read = ok(run(Command::new(&py).arg(BAGS_PY).args(["read", out_bag.to_str().unwrap()])));
        (bag, serde_json::from_slice(&read.stdout).unwrap())
    })
}

/// The live graph (tests/ros/node.py play, with `extra`), then `bpins node` reading
/// `frames` images: what node.py received, and the node's stdout and stderr.
fn play(name: &str, extra: &[&str], frames: u64) -> (Value, String) {
    let bag = &recording().0;
    let port = free_port();
    let got_path = tmp().join(format!("{name}.json"));
    let mut graph = Command::new(python().expect("main checked"))
        .args([NODE_PY, "play", &port.to_string(), bag.to_str().unwrap(), got_path.to_str().unwrap()])
        .args(extra)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(graph.stdout.take().unwrap()).read_line(&mut line).unwrap();
    assert_eq!(line.trim(), "ready");
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let frames = frames.to_string();
    let mut args = vec!["node", "--connect", endpoint.as_str(), "--domain-id", "0", "--frames", frames.as_str()];
    args.extend_from_slice(&SENSOR);
    let mut node = Command::new(env!("CARGO_BIN_EXE_bpins"))
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let g = wait(&mut graph, Duration::from_secs(120), "node.py");
    let n = wait(&mut node, Duration::from_secs(30), "bpins node");
    let out = node.wait_with_output().unwrap();
    let log = format!("{}\n{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    if needs::verbose() {
        println!("{log}");
    }
    assert!(g.success(), "node.py failed; the node said:\n{log}");
    assert!(n.success(), "bpins node failed:\n{log}");
    (serde_json::from_slice(&std::fs::read(&got_path).unwrap()).unwrap(), log)
}

/// The node's answers to images (headings, and `bpins heading` diagnostics).
fn answers(got: &Value) -> Vec<&Value> {
    got["messages"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["topic"] == "/bpins/heading" || m["name"] == "bpins heading")
        .collect()
}

/// Live answers `got` are the bag route's `want`, field for field.
fn assert_same_messages(got: &[&Value], want: &Value) {
    let want = want.as_array().unwrap();
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (g, w) in got.iter().zip(want) {
        assert_eq!(g["topic"], w["topic"], "{g} vs {w}");
        for k in ["stamp_ns", "frame_id", "quaternion", "orientation_covariance", "yaw_deg", "message", "level"] {
            assert_eq!(g[k], w[k], "{k}: live {g} vs bag {w}");
        }
    }
    let headings = got.iter().filter(|m| m["topic"] == "/bpins/heading").count();
    assert_eq!(headings, 3, "every frame under a day sky has a heading: {got:?}");
}

fn a_live_node_answers_the_sdks_graph_as_the_bag_route_does() {
    let want = &recording().1;
    let (got, log) = play("node", &["--garbage"], 5);

    // The graph sees the node, its subscriptions and publishers, with the SDK's hashes.
    let tokens: Vec<&str> = got["tokens"].as_array().unwrap().iter().map(|t| t.as_str().unwrap()).collect();
    let has = |kind: &str, topic: &str, ty: &str| {
        let hash = got["hashes"][ty].as_str().unwrap();
        tokens.iter().any(|t| t.contains(&format!("/{kind}/%/%/bpins/{topic}/")) && t.contains(hash))
    };
    assert!(tokens.iter().any(|t| t.starts_with("@ros2_lv/0/") && t.ends_with("/NN/%/%/bpins")), "{tokens:?}");
    assert!(has("MS", "%camera%image_raw", "sensor_msgs/msg/Image"), "{tokens:?}");
    assert!(has("MS", "%camera%camera_info", "sensor_msgs/msg/CameraInfo"), "{tokens:?}");
    assert!(has("MS", "%imu%data", "sensor_msgs/msg/Imu"), "{tokens:?}");
    assert!(has("MS", "%fix", "sensor_msgs/msg/NavSatFix"), "{tokens:?}");
    assert!(has("MP", "%bpins%heading", "sensor_msgs/msg/Imu"), "{tokens:?}");
    assert!(has("MP", "%diagnostics", "diagnostic_msgs/msg/DiagnosticArray"), "{tokens:?}");

    // Per frame: the garbage first (two diagnostics), then the bag route's messages.
    let msgs = answers(&got);
    assert_eq!(msgs.len(), 2 + want.as_array().unwrap().len(), "{msgs:?}");
    assert!(msgs[0]["message"].as_str().unwrap().contains("does not decode as CDR"), "{}", msgs[0]);
    assert!(msgs[1]["message"].as_str().unwrap().contains("does not match the camera's 306 × 256 px"), "{}", msgs[1]);
    assert_same_messages(&msgs[2..], want);
    // The node's status (once a second) counts frames; none was dropped, since each
    // image went out after the answer to the one before.
    let status: Vec<&Value> =
        got["messages"].as_array().unwrap().iter().filter(|m| m["name"] == "bpins node").collect();
    assert!(!status.is_empty(), "no bpins node status on /diagnostics");
    for s in status {
        for k in ["frames_received", "frames_read", "messages_malformed"] {
            assert!(s["values"][k].as_str().unwrap().parse::<u64>().is_ok(), "{k}: {s}");
        }
        assert_eq!(s["values"]["frames_dropped"], "0", "{s}");
        assert_eq!(s["level"], 0, "{s}");
    }
    // The compass is built once for the camera, not per CameraInfo (each one stamped).
    assert_eq!(log.matches("camera: 306 × 256 px").count(), 1, "{log}");
}

fn the_node_survives_its_router_going_away_and_coming_back() {
    // node.py closes the router after the first frame's answer and opens a new one on
    // the same port; the node (and the SDK) reconnect, and the frames after it are
    // answered as the bag route answers them.
    let (got, log) = play("restart", &["--restart-router"], 3);
    assert_same_messages(&answers(&got), &recording().1);
    assert!(log.contains("3 frame(s) received, 3 read, 0 dropped"), "{log}");
    // Over TCP each 157 kB image came in Zenoh's 64 KiB batches, joined by the node.
    assert!(log.contains("; 0 read in place"), "{log}");
}

fn images_in_shared_memory_are_read_in_place() {
    // The SDK's session with Zenoh's shared memory on (as rmw_zenoh's with
    // ZENOH_CONFIG_OVERRIDE): each image reaches the node in the publisher's shared
    // memory and is read there, with the same answers as over TCP.
    let (got, log) = play("shm", &["--shm"], 3);
    assert_same_messages(&answers(&got), &recording().1);
    assert!(log.contains("3 frame(s) received, 3 read, 0 dropped"), "{log}");
    assert!(log.contains("; 3 read in place (shared memory"), "{log}");
}

fn sigterm_ends_a_node_without_a_router_cleanly() {
    // No router at this port: the node starts all the same (it keeps trying), and
    // SIGTERM ends it with status 0 and its closing line.
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let mut node = Command::new(env!("CARGO_BIN_EXE_bpins"))
        .args(["node", "--connect", &endpoint, "--sun-azimuth-deg", "40", "--sun-elevation-deg", "25"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(node.stderr.take().unwrap());
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    assert!(line.starts_with("bpins node /bpins (zid "), "{line}");
    ok(run(Command::new("kill").args(["-TERM", &node.id().to_string()])));
    let s = wait(&mut node, Duration::from_secs(10), "bpins node after SIGTERM");
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    assert!(s.success(), "{s:?}: {rest}");
    assert!(rest.contains("0 frame(s) received, 0 read, 0 dropped; CPU "), "{rest}");
    assert!(rest.trim_end().ends_with("; closing"), "{rest}");
}
