//! `bpins node`: the compass as a live ROS 2 node over Zenoh (rmw_zenoh's wire format;
//! docs/ros2.md). The third frame source (crates::frames) beside the capture and the
//! bag: raw mosaics from a `sensor_msgs/Image` topic, the camera from `CameraInfo` (or
//! `--sensor`), the tilt from an `Imu` topic, the sun from a `NavSatFix` topic (or
//! `--sun-*`); out, per frame, a `sensor_msgs/Imu` heading or a `DiagnosticArray`
//! saying why there is none, built by the bag route's own code (`frame_parts`,
//! `out_message`), so that a recording of the same messages read by `bpins heading
//! --bag` gives the same numbers.
//!
//! Live behaviour: the newest frame wins. The image callback puts each image in a
//! one-place slot; one that arrives while the slot is full replaces the waiting one,
//! which is counted as dropped (once a second a `bpins node` status on /diagnostics
//! counts frames received, read and dropped). Nothing queues without bound: one image
//! waiting, one being read, the last [`IMU_KEPT`] IMU samples and [`FIX_KEPT`] fixes.
//! A message that does not decode, or an image of the wrong size or encoding, is a
//! diagnostic, never the end of the node. SIGINT and SIGTERM end it cleanly (tokens
//! withdrawn, session closed).

use crate::bag::ImuMatchArg;
use crate::cmd_heading_bag::{frame_parts, out_message};
use crate::frames::{self, FrameId, FrameSource, SourceFrame, Stamp};
use crate::node_graph::{Graph, Kept, Publisher};
use anyhow::{anyhow, Context};
use bpins_core::calibration::Calibration;
use bpins_core::camera::Intrinsics;
use bpins_core::compass::{Compass, CompassConfig, Extractor, FieldOptions};
use bpins_core::sensor::{Channel, Layout, DEFAULT_MOSAIC};
use bpins_core::tool::capture::load_sensor_file;
use bpins_core::tool::sun::source_from_unix_time;
use bpins_core::{SensorSpec, SunPosition};
use bpins_ros::cdr::{decode, encode};
use bpins_ros::convert::{camera_size_px, intrinsics, Tilt};
use bpins_ros::matching::{decode_fix, decode_imu, place_between, tilt_between, ImuMatch, ImuSample, Stamped};
use bpins_ros::msgs::{types, CameraInfo, Header, Image, Time};
use bpins_ros::rep103;
use bpins_ros::rmw_zenoh::Qos;
use std::cell::RefCell;
use std::collections::VecDeque;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// IMU samples kept for matching (2 s at 200 Hz).
pub const IMU_KEPT: usize = 400;
/// GNSS fixes kept.
pub const FIX_KEPT: usize = 16;
/// Image buffers kept for reuse (beside the one waiting and the one being read).
const SPARE_KEPT: usize = 2;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The Zenoh endpoint of the router (rmw_zenoh's `ros2 run rmw_zenoh_cpp rmw_zenohd`).
    #[arg(long, default_value = "tcp/localhost:7447", value_name = "ENDPOINT")]
    connect: String,
    /// The ROS domain (default: ROS_DOMAIN_ID, else 0).
    #[arg(long)]
    domain_id: Option<u32>,
    /// The node's name.
    #[arg(long, default_value = "bpins")]
    node_name: String,
    /// The node's namespace.
    #[arg(long, default_value = "/")]
    namespace: String,
    /// The sensor_msgs/Image topic of raw DoFP mosaics (mono8 or mono16).
    #[arg(long, default_value = "/camera/image_raw", value_name = "TOPIC")]
    image_topic: String,
    /// The sensor_msgs/CameraInfo topic (the intrinsics; not read with --sensor).
    #[arg(long, default_value = "/camera/camera_info", value_name = "TOPIC")]
    camera_info_topic: String,
    /// The sensor_msgs/Imu topic for each frame's tilt and its 1σ (`none`: level).
    #[arg(long, default_value = "/imu/data", value_name = "TOPIC")]
    imu_topic: String,
    /// The sensor_msgs/NavSatFix topic: the sun by NREL SPA at each image's stamp.
    #[arg(long, default_value = "/fix", value_name = "TOPIC")]
    fix_topic: String,
    /// The topic of the headings (sensor_msgs/Imu, REP 103/145).
    #[arg(long, default_value = "/bpins/heading", value_name = "TOPIC")]
    heading_topic: String,
    /// The topic of the frames without a heading and of the node's status.
    #[arg(long, default_value = "/diagnostics", value_name = "TOPIC")]
    diagnostics_topic: String,
    /// The frame_id of the headings (default: the image's).
    #[arg(long, value_name = "FRAME")]
    heading_frame_id: Option<String>,
    /// A sensor file ([sensor] and [lens] of CAPTURE.md) instead of CameraInfo.
    #[arg(long, value_name = "FILE")]
    sensor: Option<PathBuf>,
    /// DoFP analyzer angles, degrees, by tile (default: the sensor file's, else 90,45,135,0).
    #[arg(long, value_delimiter = ',', num_args = 4, value_name = "DEG")]
    mosaic_deg: Option<Vec<f64>>,
    /// ADC bits (default: the sensor file's, else 8 for mono8 and 16 for mono16).
    #[arg(long)]
    bit_depth: Option<u32>,
    /// Black level, DN (default: the sensor file's, else 0).
    #[arg(long)]
    black_level_dn: Option<f64>,
    /// The sun's azimuth, degrees, for every frame instead of the fix; with --sun-elevation-deg.
    #[arg(long, allow_negative_numbers = true, requires = "sun_elevation_deg")]
    sun_azimuth_deg: Option<f64>,
    /// The sun's elevation, degrees, with --sun-azimuth-deg.
    #[arg(long, allow_negative_numbers = true, requires = "sun_azimuth_deg")]
    sun_elevation_deg: Option<f64>,
    /// 1σ of the sun's azimuth and elevation, degrees.
    #[arg(long, default_value_t = 0.0)]
    sun_sigma_deg: f64,
    /// A site located by `bpins locate` (bpins-site/1) instead of the fix: the sun at
    /// each image's stamp there, its 1σ the site's propagated through SPA.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["sun_azimuth_deg", "sun_sigma_deg"])]
    site: Option<PathBuf>,
    /// 1σ of each tilt angle, degrees, instead of the IMU's covariance.
    #[arg(long)]
    tilt_sigma_deg: Option<f64>,
    /// How IMU samples are matched to an image's stamp.
    #[arg(long, value_enum, default_value_t = ImuMatchArg::Interpolate)]
    imu_match: ImuMatchArg,
    /// Largest time between an image and the IMU samples used for it, seconds.
    #[arg(long, default_value_t = 0.05)]
    imu_max_gap_s: f64,
    /// Largest time between an image and the fix used for it, seconds.
    #[arg(long, default_value_t = 10.0)]
    fix_max_age_s: f64,
    /// Heading extractor.
    #[arg(long, default_value = "sun_vector", value_parser = crate::names::by_name(&Extractor::ALL, Extractor::name))]
    extractor: Extractor,
    /// Field estimator: cell size in pixels.
    #[arg(long)]
    cell_px: Option<usize>,
    /// A known calibration to compensate, as effect.param=value (repeatable).
    #[arg(long = "effect", value_name = "EFFECT.PARAM=VALUE")]
    effects: Vec<String>,
    /// A calibration file (bpins-calibration/1) to compensate.
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// End after reading this many images (each, with a heading or a diagnostic:
    /// tests, benchmarks); default: run until SIGINT or SIGTERM.
    #[arg(long, value_name = "N")]
    frames: Option<u64>,
}

/// Set by SIGINT and SIGTERM.
static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    STOP.store(true, Ordering::SeqCst);
}

/// What the callbacks share with the loop.
#[derive(Default)]
struct Inbox {
    /// The newest image not yet read, with when it arrived.
    image: Mutex<Option<(Kept, Instant)>>,
    arrived: Condvar,
    /// Image buffers read and let go, each filled again by a later image: a frame's
    /// pages stay mapped instead of being faulted in for each new one.
    spare: Mutex<Vec<Vec<u8>>>,
    /// Images read in place (shared memory, or one batch) rather than joined.
    in_place: AtomicU64,
    camera_info: Mutex<Option<CameraInfo>>,
    imu: Mutex<VecDeque<Stamped<ImuSample>>>,
    fix: Mutex<VecDeque<Stamped<(f64, f64)>>>,
    received: AtomicU64,
    dropped: AtomicU64,
    malformed: AtomicU64,
}

impl Inbox {
    /// A buffer for an image: a spare one, else a new one.
    fn buffer(&self) -> Vec<u8> {
        self.spare.lock().unwrap_or_else(|p| p.into_inner()).pop().unwrap_or_default()
    }

    /// Gives back an image's buffer for reuse (let go past [`SPARE_KEPT`]); one
    /// read in place goes back to Zenoh.
    fn recycle(&self, k: Kept) {
        let Kept::Joined(b) = k else { return };
        let mut spare = self.spare.lock().unwrap_or_else(|p| p.into_inner());
        if spare.len() < SPARE_KEPT {
            spare.push(b);
        }
    }
}

fn keep<T>(q: &Mutex<VecDeque<Stamped<T>>>, kept: usize, s: Stamped<T>) {
    let mut q = q.lock().unwrap_or_else(|p| p.into_inner());
    // Out-of-order samples are put in their place, so the matching sees them sorted.
    let at = q.iter().rposition(|x| x.stamp_ns <= s.stamp_ns).map_or(0, |i| i + 1);
    q.insert(at, s);
    while q.len() > kept {
        q.pop_front();
    }
}

/// The samples around `t_ns` (the last at or before, the first after).
fn around<T: Clone>(q: &Mutex<VecDeque<Stamped<T>>>, t_ns: i64) -> (Option<Stamped<T>>, Option<Stamped<T>>) {
    let q = q.lock().unwrap_or_else(|p| p.into_inner());
    let i = q.iter().position(|x| x.stamp_ns > t_ns).unwrap_or(q.len());
    (i.checked_sub(1).and_then(|j| q.get(j)).cloned(), q.get(i).cloned())
}

/// The camera the compass is built for.
struct Camera {
    sensor: SensorSpec,
    intrinsics: Intrinsics,
    source: String,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let domain_id = match a.domain_id {
        Some(d) => d,
        None => match std::env::var("ROS_DOMAIN_ID") {
            Ok(s) if !s.trim().is_empty() => s.trim().parse().with_context(|| format!("ROS_DOMAIN_ID={s}"))?,
            _ => 0,
        },
    };
    let mut calibration = match &a.calibration {
        Some(p) => Calibration::load(p)?,
        None => Calibration::default(),
    };
    for spec in &a.effects {
        calibration.effects.parse_assignment(spec).with_context(|| format!("--effect {spec}"))?;
    }
    let file = match &a.sensor {
        Some(p) => Some(load_sensor_file(p)?),
        None => None,
    };
    let given_sun = a.sun_azimuth_deg.zip(a.sun_elevation_deg);
    let site = match &a.site {
        Some(p) => Some(bpins_core::Site::load(p)?),
        None => None,
    };
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
        unsafe { libc::signal(sig, on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t) };
    }

    let inbox = Arc::new(Inbox::default());
    let mut graph = Graph::open(&a.connect, domain_id, &a.namespace, &a.node_name)?;
    let heading_pub = graph.publisher(&a.heading_topic, types::IMU)?;
    let diag_pub = graph.publisher(&a.diagnostics_topic, types::DIAGNOSTIC_ARRAY)?;
    let i = inbox.clone();
    graph.subscribe(&a.image_topic, types::IMAGE, Qos::SENSOR_NEWEST, move |p| {
        i.received.fetch_add(1, Ordering::Relaxed);
        // Kept in place where it is one piece (shared memory), else joined (over TCP
        // a large image arrives in Zenoh's 64 KiB batches) outside the slot's lock,
        // into a buffer used before.
        let b = p.keep(|| i.buffer());
        if let Kept::InPlace(_) = b {
            i.in_place.fetch_add(1, Ordering::Relaxed);
        }
        let old = i.image.lock().unwrap_or_else(|p| p.into_inner()).replace((b, Instant::now()));
        i.arrived.notify_one();
        if let Some((old, _)) = old {
            i.dropped.fetch_add(1, Ordering::Relaxed);
            i.recycle(old);
        }
    })?;
    if file.is_none() {
        let i = inbox.clone();
        graph.subscribe(&a.camera_info_topic, types::CAMERA_INFO, Qos::DEFAULT, move |p| {
            match decode(&p.to_bytes()) {
                Ok(ci) => *i.camera_info.lock().unwrap_or_else(|p| p.into_inner()) = Some(ci),
                Err(_) => {
                    i.malformed.fetch_add(1, Ordering::Relaxed);
                }
            }
        })?;
    }
    if a.imu_topic != "none" {
        let i = inbox.clone();
        graph.subscribe(&a.imu_topic, types::IMU, Qos::DEFAULT, move |p| match decode_imu(&p.to_bytes()) {
            Ok((stamp_ns, value)) => keep(&i.imu, IMU_KEPT, Stamped { stamp_ns, index: 0, value }),
            Err(_) => {
                i.malformed.fetch_add(1, Ordering::Relaxed);
            }
        })?;
    }
    if given_sun.is_none() && site.is_none() {
        let i = inbox.clone();
        graph.subscribe(&a.fix_topic, types::NAV_SAT_FIX, Qos::DEFAULT, move |p| match decode_fix(&p.to_bytes()) {
            Ok((stamp_ns, value)) => keep(&i.fix, FIX_KEPT, Stamped { stamp_ns, index: 0, value }),
            Err(_) => {
                i.malformed.fetch_add(1, Ordering::Relaxed);
            }
        })?;
    }
    say!(
        "bpins node /{} (zid {}) on domain {domain_id} toward {}: images on {}, camera from {}, tilt from {}, sun \
         from {}; headings on {}, diagnostics on {}",
        a.node_name.trim_start_matches('/'),
        graph.zid(),
        a.connect,
        a.image_topic,
        a.sensor.as_ref().map_or(a.camera_info_topic.clone(), |p| p.display().to_string()),
        if a.imu_topic == "none" { "nowhere (level)" } else { &a.imu_topic },
        match (&a.site, given_sun) {
            (Some(p), _) => format!("the site {}", p.display()),
            (None, Some(_)) => "--sun-azimuth-deg/--sun-elevation-deg".into(),
            (None, None) => a.fix_topic.clone(),
        },
        a.heading_topic,
        a.diagnostics_topic
    );

    let mut node = NodeSource {
        a: &a,
        inbox: &inbox,
        file,
        site,
        diag_pub: &diag_pub,
        read: 0,
        last_status: Instant::now(),
        calibration,
        options: FieldOptions { cell_px: a.cell_px, ..FieldOptions::default() },
        compass: Rc::new(RefCell::new(None)),
        compass_key: None,
    };
    let (cpu0, mut compass_cpu_s) = (cpu_s(), 0.0);
    let result = serve(&mut node, &heading_pub, &diag_pub, &mut compass_cpu_s);
    let per_frame_ms = |s: f64| 1e3 * s / node.read.max(1) as f64;
    let cpu = format!(
        "CPU {:.1} ms per frame read, {:.1} ms of it in the compass",
        per_frame_ms(cpu_s() - cpu0),
        per_frame_ms(compass_cpu_s)
    );
    let (received, dropped) = (inbox.received.load(Ordering::Relaxed), inbox.dropped.load(Ordering::Relaxed));
    let in_place = inbox.in_place.load(Ordering::Relaxed);
    say!(
        "bpins node: {received} frame(s) received, {} read, {dropped} dropped; {cpu}; {in_place} read in place \
         (shared memory or one batch); closing",
        node.read
    );
    drop(node);
    drop((heading_pub, diag_pub));
    graph.close();
    result
}

/// The live images as a frame source.
struct NodeSource<'a> {
    a: &'a Args,
    inbox: &'a Inbox,
    file: Option<(SensorSpec, bpins_core::LensSpec)>,
    site: Option<bpins_core::Site>,
    diag_pub: &'a Publisher,
    read: u64,
    last_status: Instant,
    calibration: Calibration,
    options: FieldOptions,
    /// The compass, shared with the frames' visitor; rebuilt for a new camera.
    compass: Rc<RefCell<Option<Compass>>>,
    /// The camera the compass was built for: the CameraInfo, size and bit depth.
    compass_key: Option<CameraKey>,
}

type CameraKey = (Option<CameraInfo>, u32, u32, u32);

impl NodeSource<'_> {
    fn done(&self) -> bool {
        STOP.load(Ordering::SeqCst) || self.a.frames.is_some_and(|n| self.read >= n)
    }

    /// The newest image, waiting at most 100 ms.
    fn next_image(&mut self) -> Option<Kept> {
        let slot = self.inbox.image.lock().unwrap_or_else(|p| p.into_inner());
        let (mut slot, _) = self
            .inbox
            .arrived
            .wait_timeout_while(slot, Duration::from_millis(100), |s| s.is_none())
            .unwrap_or_else(|p| p.into_inner());
        slot.take().map(|(b, _)| b)
    }

    /// A frame without a heading, outside the compass: why, on /diagnostics.
    fn diagnose(&mut self, header: Header, why: &str) -> anyhow::Result<()> {
        self.read += 1;
        let values = self.counts();
        let msg = rep103::no_heading(header.clone(), &header.frame_id, why, &values);
        say!("no heading: {why}");
        self.diag_pub.put(encode(&msg))
    }

    fn counts(&self) -> Vec<(&'static str, String)> {
        let i = self.inbox;
        vec![
            ("image_topic", self.a.image_topic.clone()),
            ("frames_received", i.received.load(Ordering::Relaxed).to_string()),
            ("frames_read", self.read.to_string()),
            ("frames_dropped", i.dropped.load(Ordering::Relaxed).to_string()),
            ("messages_malformed", i.malformed.load(Ordering::Relaxed).to_string()),
        ]
    }

    /// Once a second: the node's status (OK, or WARN while frames are dropped).
    fn status(&mut self) -> anyhow::Result<()> {
        if self.last_status.elapsed() < Duration::from_secs(1) {
            return Ok(());
        }
        self.last_status = Instant::now();
        let dropped = self.inbox.dropped.load(Ordering::Relaxed);
        let mut msg = rep103::no_heading(
            Header { stamp: Time::from_ns(crate::node_graph::now_ns()), frame_id: String::new() },
            &self.a.node_name,
            &format!("{dropped} frame(s) dropped: the newest frame wins"),
            &self.counts(),
        );
        msg.status[0].name = "bpins node".into();
        msg.status[0].level = u8::from(dropped > 0);
        self.diag_pub.put(encode(&msg))
    }

    /// The camera from the sensor file or the newest CameraInfo, with the image's
    /// encoding for the bit depth where nothing gives it.
    fn camera(&self, im: &Image<'_>) -> Result<Camera, String> {
        let a = self.a;
        let (size, intr, source, mut sensor) = match &self.file {
            Some((s, l)) => {
                let intr = Intrinsics::new(
                    l.projection,
                    l.focal_length_mm * 1000.0 / s.geometry.pixel_pitch_um,
                    l.principal_point_px.0,
                    l.principal_point_px.1,
                );
                let p = a.sensor.as_ref().expect("a file").display().to_string();
                ((s.geometry.width_px, s.geometry.height_px), intr, format!("sensor file {p}"), Some(s.clone()))
            }
            None => {
                let ci = self.inbox.camera_info.lock().unwrap_or_else(|p| p.into_inner()).clone();
                let Some(ci) = ci else {
                    return Err(format!("no camera yet: no CameraInfo on {} (or give --sensor)", a.camera_info_topic));
                };
                let intr = intrinsics(&ci).map_err(|e| format!("CameraInfo on {}: {e}", a.camera_info_topic))?;
                (camera_size_px(&ci), intr, format!("CameraInfo on {}", a.camera_info_topic), None)
            }
        };
        let mut s = sensor.take().unwrap_or_else(|| SensorSpec {
            colour: None,
            layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
            geometry: bpins_core::sensor::Geometry { width_px: size.0, height_px: size.1, pixel_pitch_um: 0.0 },
            bit_depth: bpins_ros::convert::encoding_bits(&im.encoding).unwrap_or(16),
            black_level_dn: 0.0,
        });
        // `bayer_*` images name their colour tiles: a sensor without `colour_tiles`
        // takes them (one with other tiles is refused frame by frame).
        if let (None, Some(tiles)) = (&s.colour, bpins_ros::convert::encoding_tiles(&im.encoding)) {
            s.colour = Some(bpins_core::sensor::ColourTiles { tiles, ..bpins_core::sensor::ColourTiles::imx250myr() });
        }
        if let Some(m) = &a.mosaic_deg {
            let mut mosaic = DEFAULT_MOSAIC;
            for (i, &deg) in m.iter().enumerate() {
                mosaic[i / 2][i % 2] = Channel::from_angle_deg(deg)
                    .ok_or_else(|| format!("--mosaic-deg: {deg} is not an analyzer angle (0, 45, 90 or 135)"))?;
            }
            s.layout = Layout::Dofp { mosaic };
        }
        if let Some(b) = a.bit_depth {
            s.bit_depth = b;
        }
        if let Some(b) = a.black_level_dn {
            s.black_level_dn = b;
        }
        Ok(Camera { sensor: s, intrinsics: intr, source })
    }

    /// The sun at `t_ns` and its 1σ: the flags', SPA at the site (its 1σ the
    /// site's), or SPA at the fix.
    fn sun_at(&self, t_ns: i64) -> Result<(SunPosition, f64), String> {
        let a = self.a;
        if let (Some(az), Some(el)) = (a.sun_azimuth_deg, a.sun_elevation_deg) {
            return Ok((SunPosition::given(az, el), a.sun_sigma_deg));
        }
        if let Some(site) = &self.site {
            let t_s = t_ns as f64 * 1e-9;
            // The sun, or the moon at night, its 1σ the site's through that body's ephemeris.
            return site.source_at(t_s).map_err(|e| e.to_string());
        }
        let (p, n) = around(&self.inbox.fix, t_ns);
        let why = |s: &Stamped<(f64, f64)>| s.value.as_ref().err().map(|e| format!("{}: {e}", a.fix_topic));
        let (lat, lon) = place_between(&a.fix_topic, p.as_ref(), n.as_ref(), &why, t_ns, a.fix_max_age_s)?;
        Ok((source_from_unix_time(t_ns as f64 * 1e-9, lat, lon).map_err(|e| e.to_string())?, a.sun_sigma_deg))
    }

    /// The tilt at `t_ns`, as the bag route matches it.
    fn tilt_at(&self, t_ns: i64) -> Result<Tilt, String> {
        let a = self.a;
        let tilt = if a.imu_topic == "none" {
            Ok(Tilt { tilt_x_deg: 0.0, tilt_y_deg: 0.0, roll_var_rad2: 0.0, pitch_var_rad2: 0.0 })
        } else {
            let how = match a.imu_match {
                ImuMatchArg::Nearest => ImuMatch::Nearest,
                ImuMatchArg::Interpolate => ImuMatch::Interpolate,
            };
            let (p, n) = around(&self.inbox.imu, t_ns);
            let why = |s: &Stamped<ImuSample>| s.value.as_ref().err().map(|e| format!("{}: {e}", a.imu_topic));
            tilt_between(&a.imu_topic, p.as_ref(), n.as_ref(), &why, t_ns, how, a.imu_max_gap_s)
        };
        let var = a.tilt_sigma_deg.map(|s| s.to_radians().powi(2));
        tilt.map(|t| match var {
            Some(v) => Tilt { roll_var_rad2: v, pitch_var_rad2: v, ..t },
            None => t,
        })
    }

    /// Builds the compass for `cam` unless it was built for it already.
    fn ensure_compass(&mut self, cam: &Camera, info: Option<CameraInfo>) -> Result<(), String> {
        let key = (info, cam.sensor.geometry.width_px, cam.sensor.geometry.height_px, cam.sensor.bit_depth);
        if self.compass_key.as_ref() == Some(&key) && self.compass.borrow().is_some() {
            return Ok(());
        }
        let s = &cam.sensor;
        let Layout::Dofp { mosaic: tiles } = s.layout else { return Err("the sensor must be a DoFP mosaic".into()) };
        let g = &s.geometry;
        let cfg = CompassConfig {
            mosaic: tiles,
            calibration: self.calibration.clone(),
            options: self.options.clone(),
            extractor: self.a.extractor,
            colour: s.colour.clone(),
            ..CompassConfig::dofp(
                cam.intrinsics,
                g.width_px as usize,
                g.height_px as usize,
                s.bit_depth,
                s.black_level_dn,
            )
        };
        let c = Compass::new(cfg).map_err(|e| format!("the camera ({}): {e}", cam.source))?;
        say!("camera: {} × {} px, {}-bit, intrinsics from {}", g.width_px, g.height_px, s.bit_depth, cam.source);
        *self.compass.borrow_mut() = Some(c);
        self.compass_key = Some(key);
        Ok(())
    }
}

impl FrameSource for NodeSource<'_> {
    /// Unknown: a live graph has no end.
    fn len(&self) -> u64 {
        0
    }

    fn each(&mut self, visit: &mut dyn FnMut(SourceFrame<'_>) -> anyhow::Result<()>) -> anyhow::Result<()> {
        let mut scratch: Vec<u16> = Vec::new();
        while !self.done() {
            self.status()?;
            let Some(bytes) = self.next_image() else { continue };
            let r = self.read_image(bytes.bytes(), &mut scratch, visit);
            self.inbox.recycle(bytes);
            r?;
        }
        Ok(())
    }
}

impl NodeSource<'_> {
    /// One image: its frame to `visit`, or a diagnostic saying why there is none.
    fn read_image(
        &mut self,
        bytes: &[u8],
        scratch: &mut Vec<u16>,
        visit: &mut dyn FnMut(SourceFrame<'_>) -> anyhow::Result<()>,
    ) -> anyhow::Result<()> {
        let a = self.a;
        let im: Image = match decode(bytes) {
            Ok(im) => im,
            Err(e) => {
                self.inbox.malformed.fetch_add(1, Ordering::Relaxed);
                self.diagnose(Header::default(), &format!("image on {}: {e}", a.image_topic))?;
                return Ok(());
            }
        };
        let header = im.header.clone();
        let cam = match self.camera(&im) {
            Ok(c) => c,
            Err(why) => {
                self.diagnose(header, &why)?;
                return Ok(());
            }
        };
        let g = &cam.sensor.geometry;
        if (im.width, im.height) != (g.width_px, g.height_px) {
            let why = format!(
                "image of {} × {} px does not match the camera's {} × {} px ({})",
                im.width, im.height, g.width_px, g.height_px, cam.source
            );
            self.diagnose(header, &why)?;
            return Ok(());
        }
        // The camera as the CameraInfo gives it, less its header (a driver stamps
        // each one): the compass is rebuilt only for another camera.
        let info = match &self.file {
            Some(_) => None,
            None => self.inbox.camera_info.lock().unwrap_or_else(|p| p.into_inner()).clone(),
        }
        .map(|ci| CameraInfo { header: Header::default(), ..ci });
        if let Err(why) = self.ensure_compass(&cam, info) {
            self.diagnose(header, &why)?;
            return Ok(());
        }
        let stamp_ns = im.header.stamp.ns();
        let (sun, sun_sigma_deg) = match self.sun_at(stamp_ns) {
            Ok((s, sigma)) => (Ok(s), sigma),
            Err(why) => (Err(why), a.sun_sigma_deg),
        };
        let tilt = self.tilt_at(stamp_ns);
        let (pixels, mut sun, tilt) = match frame_parts(
            &im,
            cam.sensor.colour.as_ref(),
            scratch,
            cam.sensor.bit_depth,
            &sun,
            &tilt,
            sun_sigma_deg,
        ) {
            Ok(p) => p,
            Err(e) => {
                self.diagnose(header, &format!("{e:#}"))?;
                return Ok(());
            }
        };
        if let (Some(p), Ok(s)) = (&a.site, sun.as_mut()) {
            s.source = s.source.replace("1σ --sun-sigma-deg", &format!("1σ the site {}'s", p.display()));
        }
        let id = FrameId {
            message_index: Some(self.read),
            stamp: Some(Stamp { sec: im.header.stamp.sec, nanosec: im.header.stamp.nanosec }),
            stamp_ns: Some(stamp_ns),
            frame_id: Some(im.header.frame_id.clone()),
            ..FrameId::default()
        };
        self.read += 1;
        visit(SourceFrame { id, pixels, sun, tilt, reference_heading_deg: None })
    }
}

/// Reads the node's frames until told to stop: per frame the table's line on stdout
/// and the heading (or why none) on its topic.
fn serve(
    node: &mut NodeSource<'_>,
    heading_pub: &Publisher,
    diag_pub: &Publisher,
    compass_cpu_s: &mut f64,
) -> anyhow::Result<()> {
    let a = node.a;
    let compass = node.compass.clone();
    let extractors = [a.extractor];
    let mut header = true;
    node.each(&mut |f: SourceFrame<'_>| {
        let mut guard = compass.borrow_mut();
        let c = guard.as_mut().ok_or_else(|| anyhow!("no compass"))?;
        let values = vec![("image_topic", a.image_topic.clone())];
        let cpu0 = cpu_s();
        let rows = frames::frame_rows(c, &extractors, &f);
        *compass_cpu_s += cpu_s() - cpu0;
        let rows = match rows {
            Ok(r) => r,
            Err(e) => {
                // A frame the compass refuses: a diagnostic, not the end of the node.
                let row = {
                    let mut r = frames::Row::of(&f, a.extractor);
                    r.no_heading_reason = Some(format!("{e:#}"));
                    r
                };
                vec![row]
            }
        };
        if std::mem::take(&mut header) {
            out!("{}", frames::header_line());
        }
        for r in &rows {
            out!("{}", r.line());
        }
        let (heading, _, bytes) = out_message(&f, &rows[0], a.heading_frame_id.as_deref(), &values)?;
        if heading {
            heading_pub.put(bytes)
        } else {
            diag_pub.put(bytes)
        }
    })
}

/// The process's CPU time so far (user + system, all threads), seconds.
fn cpu_s() -> f64 {
    // SAFETY: getrusage writes the struct it is given; a zeroed rusage is valid.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) } != 0 {
        return 0.0;
    }
    let t = |v: libc::timeval| v.tv_sec as f64 + v.tv_usec as f64 * 1e-6;
    t(u.ru_utime) + t(u.ru_stime)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(t: i64) -> Stamped<i64> {
        Stamped { stamp_ns: t, index: 0, value: Ok(t) }
    }

    #[test]
    fn kept_samples_stay_sorted_bounded_and_bracket_a_stamp() {
        let q = Mutex::new(VecDeque::new());
        // Out of order, and more than kept: sorted, the oldest let go.
        for t in [10, 30, 20, 50, 40, 60] {
            keep(&q, 4, s(t));
        }
        let stamps: Vec<i64> = q.lock().unwrap().iter().map(|x| x.stamp_ns).collect();
        assert_eq!(stamps, [30, 40, 50, 60]);
        let at = |t| {
            let (p, n) = around(&q, t);
            (p.map(|x| x.stamp_ns), n.map(|x| x.stamp_ns))
        };
        assert_eq!(at(45), (Some(40), Some(50)));
        assert_eq!(at(50), (Some(50), Some(60)));
        assert_eq!(at(5), (None, Some(30)));
        assert_eq!(at(70), (Some(60), None));
    }
}
