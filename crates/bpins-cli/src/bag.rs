//! What every command that reads a ROS 2 bag shares (`bpins heading --bag`, `bpins
//! bag-to-capture`): the flags naming topics and the sensor, the camera model they
//! resolve to, and the per-image sun and tilt (crates/bpins-ros).

use anyhow::{anyhow, bail, Context};
use bpins_core::camera::Intrinsics;
use bpins_core::sensor::{Channel, Layout, DEFAULT_MOSAIC};
use bpins_core::tool::capture::load_sensor_file;
use bpins_core::tool::sun::source_from_unix_time;
use bpins_core::SunPosition;
use bpins_core::{LensSpec, SensorSpec};
use bpins_ros::cdr::decode;
use bpins_ros::convert::{camera_size_px, intrinsics, Tilt};
use bpins_ros::matching::{decode_fix, decode_imu, place_at, tilt_at, ImuMatch, ImuSample, Track};
use bpins_ros::msgs::{types, CameraInfo, Image};
use bpins_ros::{topics, Bag, BagMessage, TopicCursor, TopicInfo, Where};
use std::path::PathBuf;

/// The flags of a bag's inputs: each but --tilt-sigma-deg (which `heading CAPTURE`
/// takes too) requires --bag, so that clap refuses it, naming both, where it would
/// be ignored.
#[derive(clap::Args, Clone, Debug)]
pub struct BagArgs {
    /// A ROS 2 bag (rosbag2 folder with metadata.yaml; MCAP or sqlite3 storage) to
    /// read instead of a capture: DoFP frames from sensor_msgs/Image (docs/ros2.md).
    #[arg(long, value_name = "DIR")]
    pub bag: Option<PathBuf>,
    /// The sensor_msgs/Image topic (default: the bag's only Image topic).
    #[arg(long, requires = "bag", value_name = "TOPIC")]
    pub image_topic: Option<String>,
    /// The sensor_msgs/CameraInfo topic for the intrinsics (default: the bag's only
    /// one, if any; its first message is used).
    #[arg(long, requires = "bag", value_name = "TOPIC")]
    pub camera_info_topic: Option<String>,
    /// The sensor_msgs/Imu topic for each frame's reference tilt and its 1σ
    /// (default: the bag's only Imu topic outside /bpins/, where bpins writes its
    /// headings and a simulated bag's truth; without one the camera is taken as level).
    #[arg(long, requires = "bag", value_name = "TOPIC")]
    pub imu_topic: Option<String>,
    /// The sensor_msgs/NavSatFix topic: with each image's stamp, the sun through NREL
    /// SPA (default: the bag's only NavSatFix topic; not with --sun-azimuth-deg).
    #[arg(long, requires = "bag", conflicts_with = "sun_azimuth_deg", value_name = "TOPIC")]
    pub fix_topic: Option<String>,
    /// A sensor file: the [sensor] and [lens] tables of capture.toml (CAPTURE.md),
    /// for the mosaic, bit depth, black level and, without CameraInfo, the lens.
    #[arg(long, requires = "bag", value_name = "FILE")]
    pub sensor: Option<PathBuf>,
    /// DoFP analyzer angles, degrees, by tile: row 0 col 0, row 0 col 1, row 1 col 0,
    /// row 1 col 1 (default: the sensor file's, else 90,45,135,0).
    #[arg(long, requires = "bag", value_delimiter = ',', num_args = 4, value_name = "DEG")]
    pub mosaic_deg: Option<Vec<f64>>,
    /// ADC bits (default: the sensor file's, else 8 for mono8 and 16 for mono16).
    #[arg(long, requires = "bag")]
    pub bit_depth: Option<u32>,
    /// Black level, DN (default: the sensor file's, else 0).
    #[arg(long, requires = "bag")]
    pub black_level_dn: Option<f64>,
    /// The sun's azimuth (from North toward East), degrees, for every frame, instead
    /// of NREL SPA from a NavSatFix topic; with --sun-elevation-deg.
    #[arg(long, requires = "bag", allow_negative_numbers = true, requires = "sun_elevation_deg")]
    pub sun_azimuth_deg: Option<f64>,
    /// The sun's elevation, degrees, with --sun-azimuth-deg.
    #[arg(long, requires = "bag", allow_negative_numbers = true, requires = "sun_azimuth_deg")]
    pub sun_elevation_deg: Option<f64>,
    /// 1σ of the sun's azimuth and elevation, degrees (clock or position error).
    #[arg(long, requires = "bag", default_value_t = 0.0)]
    pub sun_sigma_deg: f64,
    /// 1σ of each tilt angle, degrees, instead of the IMU's orientation covariance
    /// (or, without an IMU, the level camera's). With a capture (`bpins heading
    /// CAPTURE`): instead of each frame's `tilt_sigma_deg`, and a frame without tilt
    /// keys is taken as level ± this 1σ, as a bag without an IMU is (field estimator).
    #[arg(long)]
    pub tilt_sigma_deg: Option<f64>,
    /// How an IMU sample is matched to an image's stamp.
    #[arg(long, requires = "bag", value_enum, default_value_t = ImuMatchArg::Interpolate)]
    pub imu_match: ImuMatchArg,
    /// Largest time between an image and the IMU samples used for it, seconds.
    #[arg(long, requires = "bag", default_value_t = 0.05)]
    pub imu_max_gap_s: f64,
    /// Largest time between an image and the GNSS fix used for it, seconds.
    #[arg(long, requires = "bag", default_value_t = 10.0)]
    pub fix_max_age_s: f64,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq)]
pub enum ImuMatchArg {
    /// The sample nearest the image's stamp.
    Nearest,
    /// The samples before and after, orientation slerped, variances linear.
    Interpolate,
}

/// A bag opened with its camera resolved.
pub struct BagInput {
    pub bag: Bag,
    pub image_topic: String,
    pub imu_topic: Option<String>,
    /// bpins' own Imu topics (`/bpins/…`) passed over when choosing the IMU.
    pub imu_left_out: Vec<String>,
    pub fix_topic: Option<String>,
    /// Frames (the image topic's message count in metadata.yaml).
    pub frames: u64,
    pub sensor: SensorSpec,
    /// The sensor file's lens, where one was given.
    pub lens: Option<LensSpec>,
    pub intrinsics: Intrinsics,
    /// Where the intrinsics came from, for the output.
    pub intrinsics_source: String,
}

/// The topic of `type_name` to read: the flag's (any topic of that type, bpins' own
/// included), else the bag's only one outside bpins' own outputs (`/bpins/…`: the
/// headings and a simulated bag's truth are `sensor_msgs/Imu` but no IMU's
/// measurements; bpins_ros::topics), else none. Several: an error naming them, and
/// the ones left out.
fn pick(bag: &Bag, flag: &Option<String>, type_name: &str, what: &str) -> anyhow::Result<Option<String>> {
    if let Some(t) = flag {
        return Ok(Some(bag.topic(t, type_name).with_context(|| format!("--{what}-topic"))?.name.clone()));
    }
    let (own, inputs): (Vec<&TopicInfo>, Vec<&TopicInfo>) =
        bag.topics.iter().filter(|t| t.type_name == type_name).partition(|t| topics::is_bpins_output(&t.name));
    match inputs.as_slice() {
        [] => Ok(None),
        [one] => Ok(Some(one.name.clone())),
        many => {
            let names = |ts: &[&TopicInfo]| ts.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(", ");
            let left_out = match own.as_slice() {
                [] => String::new(),
                own => format!(" besides bpins' own output {} (never read unless named)", names(own)),
            };
            bail!(
                "{}: {} topics of type {type_name} ({}){left_out}: choose one with --{what}-topic",
                Where { bag: bag.dir.clone(), topic: None, index: None },
                many.len(),
                names(many)
            )
        }
    }
}

/// bpins' own outputs of `type_name` in the bag (`/bpins/…`), which `pick` passes over.
fn own_outputs(bag: &Bag, type_name: &str) -> Vec<String> {
    bag.topics
        .iter()
        .filter(|t| t.type_name == type_name && topics::is_bpins_output(&t.name))
        .map(|t| t.name.clone())
        .collect()
}

impl BagArgs {
    /// Opens the bag, chooses the topics and resolves the camera.
    pub fn open(&self) -> anyhow::Result<BagInput> {
        let dir = self.bag.as_ref().ok_or_else(|| anyhow!("--bag DIR is required"))?;
        let bag = Bag::open(dir)?;
        let Some(image_topic) = pick(&bag, &self.image_topic, types::IMAGE, "image")? else {
            bail!("bag {}: no sensor_msgs/msg/Image topic; the bag has: {}", dir.display(), bag.topic_list());
        };
        let info_topic = pick(&bag, &self.camera_info_topic, types::CAMERA_INFO, "camera-info")?;
        let imu_topic = pick(&bag, &self.imu_topic, types::IMU, "imu")?;
        let given_sun = self.sun_azimuth_deg.is_some();
        let fix_topic = match (&self.fix_topic, given_sun) {
            (None, true) => None,
            _ => pick(&bag, &self.fix_topic, types::NAV_SAT_FIX, "fix")?,
        };
        if !given_sun && fix_topic.is_none() {
            bail!(
                "bag {}: no sun: give --sun-azimuth-deg and --sun-elevation-deg, or record a sensor_msgs/NavSatFix \
                 topic (the sun then follows from each image's stamp through NREL SPA)",
                dir.display()
            );
        }
        let frames = bag.topic(&image_topic, types::IMAGE)?.message_count;
        // The first image (its size and encoding, where nothing else gives them) and
        // the first CameraInfo, from one walk of the bag's start (the image's cursor
        // dropped once read, so that the walk on to the CameraInfo holds no images).
        let mut wanted = vec![image_topic.as_str()];
        wanted.extend(info_topic.as_deref());
        let mut cursors = bag.cursors(&wanted)?.into_iter();
        let first = cursors.next().expect("one cursor per topic").next().transpose()?;
        let first_info = match cursors.next() {
            Some(mut c) => c.next().transpose()?,
            None => None,
        };
        drop(cursors);
        let first_image = match &first {
            Some(m) => {
                Some(decode::<Image>(&m.data).map_err(|e| anyhow!("{}: {e}", bag_at(&bag, &image_topic, m.index)))?)
            }
            None => None,
        };
        let file = match &self.sensor {
            Some(p) => Some(load_sensor_file(p)?),
            None => None,
        };
        if let Some((s, _)) = &file {
            if !matches!(s.layout, Layout::Dofp { .. }) {
                bail!(
                    "--sensor {}: layout must be \"dofp\": a bag's images are raw mosaics",
                    self.sensor.as_ref().unwrap().display()
                );
            }
        }
        let info = match &info_topic {
            None => None,
            Some(t) => match first_info {
                None => None,
                Some(m) => {
                    let ci: CameraInfo = decode(&m.data).map_err(|e| anyhow!("{}: {e}", bag_at(&bag, t, m.index)))?;
                    let intr = intrinsics(&ci).map_err(|e| anyhow!("{}: {e}", bag_at(&bag, t, m.index)))?;
                    Some((t.clone(), ci, intr))
                }
            },
        };
        let size = match (&file, &info, &first_image) {
            (Some((s, _)), _, _) => (s.geometry.width_px, s.geometry.height_px),
            (None, Some((_, ci, _)), _) => camera_size_px(ci),
            (None, None, Some(im)) => (im.width, im.height),
            (None, None, None) => bail!("bag {}: topic {image_topic} holds no image", dir.display()),
        };
        if let (Some((s, _)), Some((t, ci, _))) = (&file, &info) {
            let c = camera_size_px(ci);
            if c != (s.geometry.width_px, s.geometry.height_px) {
                bail!(
                    "{}: CameraInfo of {} × {} px does not match the sensor file's {} × {} px",
                    bag_at(&bag, t, 0),
                    c.0,
                    c.1,
                    s.geometry.width_px,
                    s.geometry.height_px
                );
            }
        }
        let mut sensor = match &file {
            Some((s, _)) => s.clone(),
            None => SensorSpec {
                colour: None,
                layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
                geometry: bpins_core::sensor::Geometry { width_px: size.0, height_px: size.1, pixel_pitch_um: 0.0 },
                bit_depth: first_image
                    .as_ref()
                    .and_then(|i| bpins_ros::convert::encoding_bits(&i.encoding))
                    .unwrap_or(16),
                black_level_dn: 0.0,
            },
        };
        // `bayer_*` images name their colour tiles: a sensor file without
        // `colour_tiles` takes them (one with other tiles is refused frame by frame).
        if let (None, Some(tiles)) =
            (&sensor.colour, first_image.as_ref().and_then(|i| bpins_ros::convert::encoding_tiles(&i.encoding)))
        {
            sensor.colour =
                Some(bpins_core::sensor::ColourTiles { tiles, ..bpins_core::sensor::ColourTiles::imx250myr() });
        }
        if let Some(m) = &self.mosaic_deg {
            let mut mosaic = DEFAULT_MOSAIC;
            for (i, &deg) in m.iter().enumerate() {
                mosaic[i / 2][i % 2] = Channel::from_angle_deg(deg)
                    .ok_or_else(|| anyhow!("--mosaic-deg: {deg} is not an analyzer angle (0, 45, 90 or 135)"))?;
            }
            sensor.layout = Layout::Dofp { mosaic };
        }
        if let Some(b) = self.bit_depth {
            sensor.bit_depth = b;
        }
        if let Some(b) = self.black_level_dn {
            sensor.black_level_dn = b;
        }
        let (intrinsics, intrinsics_source) = match (&info, &file) {
            (Some((t, _, intr)), _) => (*intr, format!("CameraInfo on {t}")),
            (None, Some((s, l))) => (
                Intrinsics::new(
                    l.projection,
                    l.focal_length_mm * 1000.0 / s.geometry.pixel_pitch_um,
                    l.principal_point_px.0,
                    l.principal_point_px.1,
                ),
                format!("sensor file {}", self.sensor.as_ref().unwrap().display()),
            ),
            (None, None) => bail!(
                "bag {}: no intrinsics: record a sensor_msgs/CameraInfo topic or give --sensor FILE ([sensor] and [lens] \
                 of CAPTURE.md)",
                dir.display()
            ),
        };
        let imu_left_out = if self.imu_topic.is_none() { own_outputs(&bag, types::IMU) } else { Vec::new() };
        Ok(BagInput {
            lens: file.map(|f| f.1),
            bag,
            image_topic,
            imu_left_out,
            imu_topic,
            fix_topic,
            frames,
            sensor,
            intrinsics,
            intrinsics_source,
        })
    }
}

impl BagInput {
    /// Where each frame's tilt comes from, for the output: the Imu topic or a level
    /// camera, and bpins' own Imu topics passed over.
    pub fn tilt_source(&self) -> String {
        let from = self.imu_topic.as_deref().unwrap_or("nowhere (no Imu topic: the camera taken as level)");
        match self.imu_left_out.as_slice() {
            [] => from.to_string(),
            own => format!("{from} ({} not read: bpins' own output, not an IMU's)", own.join(", ")),
        }
    }
}

/// `bag B, topic T, message I`, as the library's errors say it.
pub fn bag_at(bag: &Bag, topic: &str, index: u64) -> String {
    bpins_ros::Where { bag: bag.dir.clone(), topic: Some(topic.into()), index: Some(index) }.to_string()
}

/// One image of the bag with what is known at its stamp.
pub struct BagFrame<'a> {
    pub message: BagMessage<'a>,
    pub stamp_ns: i64,
    /// The sun (from the flags, or SPA at the stamp and the nearest fix), or why not.
    pub sun: Result<SunPosition, String>,
    /// The tilt with its variances (IMU, or level), or why not.
    pub tilt: Result<Tilt, String>,
}

/// The bag's images in order, each with its sun and tilt.
pub struct Frames<'a> {
    input: &'a BagInput,
    args: &'a BagArgs,
    images: TopicCursor<'a>,
    imu: Option<Track<'a, ImuSample>>,
    fix: Option<Track<'a, (f64, f64)>>,
}

impl BagInput {
    /// Walks the images, with the IMU and GNSS topics in step: cursors of all three
    /// served by one walk of the bag's storage.
    pub fn frames<'a>(&'a self, args: &'a BagArgs) -> anyhow::Result<Frames<'a>> {
        let fix_topic = match args.sun_azimuth_deg {
            None => self.fix_topic.as_deref(),
            Some(_) => None,
        };
        let mut topics = vec![self.image_topic.as_str()];
        topics.extend(self.imu_topic.as_deref());
        topics.extend(fix_topic);
        let mut cursors = self.bag.cursors(&topics)?.into_iter();
        let images = cursors.next().expect("one cursor per topic");
        let imu =
            self.imu_topic.as_ref().map(|_| Track::new(cursors.next().expect("one cursor per topic"), decode_imu));
        let fix = fix_topic.map(|_| Track::new(cursors.next().expect("one cursor per topic"), decode_fix));
        Ok(Frames { input: self, args, images, imu, fix })
    }
}

impl<'a> Frames<'a> {
    /// The next frame, `None` after the last.
    pub fn next_frame(&mut self) -> anyhow::Result<Option<BagFrame<'a>>> {
        let Some(m) = self.images.next().transpose()? else { return Ok(None) };
        let at = || bag_at(&self.input.bag, &self.input.image_topic, m.index);
        let im: Image = decode(&m.data).map_err(|e| anyhow!("{}: {e}", at()))?;
        let g = &self.input.sensor.geometry;
        if (im.width, im.height) != (g.width_px, g.height_px) {
            bail!(
                "{}: image of {} × {} px does not match the camera's {} × {} px ({})",
                at(),
                im.width,
                im.height,
                g.width_px,
                g.height_px,
                self.input.intrinsics_source
            );
        }
        let stamp_ns = im.header.stamp.ns();
        let a = self.args;
        let sun = match (a.sun_azimuth_deg, a.sun_elevation_deg, self.fix.as_mut()) {
            (Some(az), Some(el), _) => Ok(SunPosition::given(az, el)),
            (_, _, Some(track)) => match place_at(track, stamp_ns, a.fix_max_age_s)? {
                Ok((lat, lon)) => source_from_unix_time(stamp_ns as f64 * 1e-9, lat, lon).map_err(|e| e.to_string()),
                Err(why) => Err(why),
            },
            _ => Err("no sun".into()),
        };
        let how = match a.imu_match {
            ImuMatchArg::Nearest => ImuMatch::Nearest,
            ImuMatchArg::Interpolate => ImuMatch::Interpolate,
        };
        let var = a.tilt_sigma_deg.map(|s| s.to_radians().powi(2));
        let tilt = match self.imu.as_mut() {
            Some(track) => tilt_at(track, stamp_ns, how, a.imu_max_gap_s)?,
            None => Ok(Tilt { tilt_x_deg: 0.0, tilt_y_deg: 0.0, roll_var_rad2: 0.0, pitch_var_rad2: 0.0 }),
        };
        let tilt = tilt.map(|t| match var {
            Some(v) => Tilt { roll_var_rad2: v, pitch_var_rad2: v, ..t },
            None => t,
        });
        drop(im);
        Ok(Some(BagFrame { message: m, stamp_ns, sun, tilt }))
    }
}
