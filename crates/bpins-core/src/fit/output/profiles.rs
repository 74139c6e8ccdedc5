//! Residual profiles in sky space: what a fitted model leaves, binned against the
//! quantities physical effects depend on — scattering angle from the sun (sky
//! effects), radius from the principal point and image azimuth (lens and camera
//! effects), mosaic position and analyzer channel (analyzer and sensor effects) and
//! the model's DoLP (effects that scale with polarization). A missing effect shows as a trend along
//! its own axis and none along the others.
//!
//! Each bin holds the raw-DN residual (χ² per sample and the mean of
//! (measured − model)/σ, whose sign says brighter or darker than the model) and the
//! polarization residual (mean measured − model AoP in degrees, where the model DoLP
//! > 0.01, and DoLP), over every frame.

/// What a profile is plotted against (in files: its [`Axis::name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Angle between the pixel's ray and the sun, degrees (the model's sky).
    ScatteringAngle,
    /// Distance from the nominal principal point, focal lengths.
    Radius,
    /// Image azimuth about the nominal principal point, degrees, atan2(y_n, x_n) in
    /// the image frame of CONVENTIONS.md (x right, y down).
    ImageAzimuth,
    /// DoFP mosaic position (u mod 2) + 2·(v mod 2); raw DN only.
    MosaicPosition,
    /// Analyzer channel index (0°, 45°, 90°, 135° → 0…3); raw DN only.
    Channel,
    /// The model's DoLP at the sample.
    ModelDolp,
    /// Colour band of a colour-polarization sensor (R, G, B → 0…2, `Band::index`);
    /// none on a monochrome one (its profile is left out).
    ColourBand,
}

impl Axis {
    pub const ALL: [Axis; 7] = [
        Axis::ScatteringAngle,
        Axis::Radius,
        Axis::ImageAzimuth,
        Axis::MosaicPosition,
        Axis::Channel,
        Axis::ModelDolp,
        Axis::ColourBand,
    ];

    /// Name in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            Axis::ScatteringAngle => "scattering_angle_deg",
            Axis::Radius => "radius_focal_lengths",
            Axis::ImageAzimuth => "image_azimuth_deg",
            Axis::MosaicPosition => "mosaic_position",
            Axis::Channel => "channel",
            Axis::ModelDolp => "model_dolp",
            Axis::ColourBand => "colour_band",
        }
    }

    /// Title with unit, for plots.
    pub fn title(self) -> &'static str {
        match self {
            Axis::ScatteringAngle => "scattering angle (°)",
            Axis::Radius => "radius (focal lengths)",
            Axis::ImageAzimuth => "image azimuth (°)",
            Axis::MosaicPosition => "mosaic position (u%2 + 2·v%2)",
            Axis::Channel => "channel (0°, 45°, 90°, 135°)",
            Axis::ModelDolp => "model DoLP",
            Axis::ColourBand => "colour band (R, G, B)",
        }
    }

    /// Words for a position on this axis.
    pub fn describe(self, x: f64) -> String {
        match self {
            Axis::ScatteringAngle => format!("scattering angle {x:.0}°"),
            Axis::Radius => format!("radius {x:.2} focal lengths"),
            Axis::ImageAzimuth => format!("image azimuth {x:.0}°"),
            Axis::MosaicPosition => format!("mosaic position {x:.0}"),
            Axis::Channel => format!("the {:.0}° channel", 45.0 * x.floor()),
            Axis::ModelDolp => format!("model DoLP {x:.2}"),
            Axis::ColourBand => match x.floor() as i64 {
                0 => "the red band".to_string(),
                1 => "the green band".to_string(),
                _ => "the blue band".to_string(),
            },
        }
    }

    /// (first edge, last edge, bins).
    fn range(self, max_radius: f64) -> (f64, f64, usize) {
        match self {
            Axis::ScatteringAngle => (0.0, 180.0, 18),
            Axis::Radius => (0.0, max_radius, 8),
            Axis::ImageAzimuth => (-180.0, 180.0, 12),
            Axis::MosaicPosition => (0.0, 4.0, 4),
            Axis::Channel => (0.0, 4.0, 4),
            Axis::ModelDolp => (0.0, 1.0, 10),
            Axis::ColourBand => (0.0, 3.0, 3),
        }
    }
}

impl serde::Serialize for Axis {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Where one sample lies on every axis (NaN: not on that axis).
#[derive(Clone, Copy, Debug, Default)]
pub struct Position {
    pub scattering_deg: f64,
    pub radius: f64,
    pub azimuth_deg: f64,
    pub mosaic: f64,
    pub channel: f64,
    pub model_dolp: f64,
    /// Colour band index (`Band::index`); NaN on a monochrome sensor.
    pub band: f64,
}

impl Position {
    fn on(&self, a: Axis) -> f64 {
        match a {
            Axis::ScatteringAngle => self.scattering_deg,
            Axis::Radius => self.radius,
            Axis::ImageAzimuth => self.azimuth_deg,
            Axis::MosaicPosition => self.mosaic,
            Axis::Channel => self.channel,
            Axis::ModelDolp => self.model_dolp,
            Axis::ColourBand => self.band,
        }
    }
}

/// One bin of a profile (lo, hi in the axis's unit).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ProfileBin {
    pub lo: f64,
    pub hi: f64,
    /// Raw-DN samples, their χ² per sample and mean (measured − model)/σ.
    pub dn_samples: usize,
    pub chi2_per_sample: f64,
    pub mean_z: f64,
    /// Polarization samples (superpixels of a mosaic, or pixels), their mean AoP
    /// residual in degrees (over those with model DoLP > 0.01) and mean DoLP residual.
    pub pol_samples: usize,
    pub aop_deg: f64,
    pub dolp: f64,
}

/// A residual profile along one axis.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Profile {
    pub axis: Axis,
    pub bins: Vec<ProfileBin>,
}

#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    z2: f64,
    z: f64,
    n: usize,
    aop: f64,
    n_aop: usize,
    dolp: f64,
    n_pol: usize,
}

/// Accumulates samples into every axis's bins.
#[derive(Clone, Debug)]
pub struct Profiler {
    max_radius: f64,
    sums: Vec<Vec<Sums>>,
}

impl Profiler {
    /// Bins for radii up to `max_radius` focal lengths (the image corner).
    pub fn new(max_radius: f64) -> Self {
        let sums = Axis::ALL.iter().map(|a| vec![Sums::default(); a.range(max_radius).2]).collect();
        Profiler { max_radius, sums }
    }

    fn bin(&self, a: Axis, x: f64) -> Option<usize> {
        let (lo, hi, n) = a.range(self.max_radius);
        if !x.is_finite() || x < lo || x > hi {
            return None;
        }
        Some((((x - lo) / (hi - lo) * n as f64) as usize).min(n - 1))
    }

    /// Adds another profiler's sums (the same bins: made with the same radius).
    pub fn merge(&mut self, o: &Profiler) {
        for (a, b) in self.sums.iter_mut().zip(&o.sums) {
            for (x, y) in a.iter_mut().zip(b) {
                x.z2 += y.z2;
                x.z += y.z;
                x.n += y.n;
                x.aop += y.aop;
                x.n_aop += y.n_aop;
                x.dolp += y.dolp;
                x.n_pol += y.n_pol;
            }
        }
    }

    /// A raw-DN sample with normalised residual `z` at `p`.
    pub fn add_dn(&mut self, p: &Position, z: f64) {
        for (i, a) in Axis::ALL.iter().enumerate() {
            if let Some(b) = self.bin(*a, p.on(*a)) {
                let s = &mut self.sums[i][b];
                s.z2 += z * z;
                s.z += z;
                s.n += 1;
            }
        }
    }

    /// A polarization sample at `p` with residuals `aop_deg` (None where the model
    /// DoLP is too small for an angle) and `dolp`.
    pub fn add_pol(&mut self, p: &Position, aop_deg: Option<f64>, dolp: f64) {
        for (i, a) in Axis::ALL.iter().enumerate() {
            if let Some(b) = self.bin(*a, p.on(*a)) {
                let s = &mut self.sums[i][b];
                if let Some(x) = aop_deg {
                    s.aop += x;
                    s.n_aop += 1;
                }
                s.dolp += dolp;
                s.n_pol += 1;
            }
        }
    }

    /// The profiles (bins without any sample left out; the colour band's only where a
    /// sample has a band).
    pub fn finish(&self) -> Vec<Profile> {
        let mean = |s: f64, n: usize| if n > 0 { s / n as f64 } else { f64::NAN };
        Axis::ALL
            .iter()
            .zip(&self.sums)
            .map(|(&axis, sums)| {
                let (lo, hi, n) = axis.range(self.max_radius);
                let w = (hi - lo) / n as f64;
                let bins = sums
                    .iter()
                    .enumerate()
                    .filter(|(_, s)| s.n + s.n_pol > 0)
                    .map(|(b, s)| ProfileBin {
                        lo: lo + w * b as f64,
                        hi: lo + w * (b + 1) as f64,
                        dn_samples: s.n,
                        chi2_per_sample: mean(s.z2, s.n),
                        mean_z: mean(s.z, s.n),
                        pol_samples: s.n_pol,
                        aop_deg: mean(s.aop, s.n_aop),
                        dolp: mean(s.dolp, s.n_pol),
                    })
                    .collect();
                Profile { axis, bins }
            })
            .filter(|p| p.axis != Axis::ColourBand || !p.bins.is_empty())
            .collect()
    }
}

/// A residual quantity whose trend [`trends`] looks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// The mean raw-DN residual, (measured − model)/σ.
    MeanDnResidualSigma,
    /// The DoLP residual, measured − model.
    DolpResidual,
}

impl Quantity {
    fn label(self) -> &'static str {
        match self {
            Quantity::MeanDnResidualSigma => "the mean raw-DN residual (σ)",
            Quantity::DolpResidual => "the DoLP residual (measured − model)",
        }
    }

    /// A value of this quantity with its unit.
    pub fn format(self, v: f64) -> String {
        match self {
            Quantity::MeanDnResidualSigma => format!("{v:+.2}σ"),
            Quantity::DolpResidual => format!("{v:+.4}"),
        }
    }
}

/// A point of a trend: the bin centre on the axis, and the quantity's value there.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TrendPoint {
    pub at: f64,
    pub value: f64,
}

/// The strongest trend of one quantity: the axis along which it varies most between
/// bins, and where it is lowest and highest.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Trend {
    pub quantity: Quantity,
    pub axis: Axis,
    pub min: TrendPoint,
    pub max: TrendPoint,
}

impl std::fmt::Display for Trend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let q = self.quantity;
        write!(
            f,
            "{} varies most along {}: from {} at {} to {} at {}",
            q.label(),
            label(self.axis),
            q.format(self.min.value),
            self.axis.describe(self.min.at),
            q.format(self.max.value),
            self.axis.describe(self.max.at)
        )
    }
}

/// The strongest trend of each quantity: along which axis the mean raw-DN residual
/// (in σ) and the DoLP residual vary most between bins, from where to where. Bins
/// with fewer than `min_samples` samples are ignored (their means are noise).
pub fn trends(profiles: &[Profile], min_samples: usize) -> Vec<Trend> {
    let centre = |b: &ProfileBin| 0.5 * (b.lo + b.hi);
    let value = |q: Quantity, b: &ProfileBin| match q {
        Quantity::MeanDnResidualSigma => (b.dn_samples >= min_samples && b.mean_z.is_finite()).then_some(b.mean_z),
        Quantity::DolpResidual => (b.pol_samples >= min_samples / 4 && b.dolp.is_finite()).then_some(b.dolp),
    };
    let strongest = |q: Quantity| {
        profiles
            .iter()
            .filter_map(|p| {
                let pts: Vec<TrendPoint> =
                    p.bins.iter().filter_map(|b| value(q, b).map(|v| TrendPoint { at: centre(b), value: v })).collect();
                let min = pts.iter().copied().min_by(|a, b| a.value.total_cmp(&b.value))?;
                let max = pts.iter().copied().max_by(|a, b| a.value.total_cmp(&b.value))?;
                Some(Trend { quantity: q, axis: p.axis, min, max })
            })
            .max_by(|a, b| (a.max.value - a.min.value).total_cmp(&(b.max.value - b.min.value)))
    };
    [Quantity::MeanDnResidualSigma, Quantity::DolpResidual].into_iter().filter_map(strongest).collect()
}

/// [`trends`] in words, `; ` between them.
pub fn describe(profiles: &[Profile], min_samples: usize) -> String {
    trends(profiles, min_samples).iter().map(|t| t.to_string()).collect::<Vec<_>>().join("; ")
}

fn label(a: Axis) -> &'static str {
    match a {
        Axis::ScatteringAngle => "the scattering angle from the sun",
        Axis::Radius => "the radius from the principal point",
        Axis::ImageAzimuth => "the image azimuth",
        Axis::MosaicPosition => "the mosaic position",
        Axis::Channel => "the analyzer channel",
        Axis::ModelDolp => "the model's DoLP",
        Axis::ColourBand => "the colour band",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_land_in_their_bins_on_every_axis() {
        let mut p = Profiler::new(0.8);
        let at = Position {
            scattering_deg: 95.0,
            radius: 0.45,
            azimuth_deg: -170.0,
            mosaic: 3.0,
            channel: 1.0,
            model_dolp: 0.55,
            band: f64::NAN,
        };
        p.add_dn(&at, 2.0);
        p.add_dn(&at, -1.0);
        p.add_pol(&Position { mosaic: f64::NAN, channel: f64::NAN, ..at }, Some(0.5), -0.01);
        let out = p.finish();
        let get = |a: Axis| out.iter().find(|q| q.axis == a).unwrap();
        let s = &get(Axis::ScatteringAngle).bins;
        assert_eq!(s.len(), 1);
        assert_eq!((s[0].lo, s[0].hi), (90.0, 100.0));
        assert_eq!((s[0].dn_samples, s[0].chi2_per_sample, s[0].mean_z), (2, 2.5, 0.5));
        assert_eq!((s[0].pol_samples, s[0].aop_deg, s[0].dolp), (1, 0.5, -0.01));
        assert_eq!((get(Axis::Radius).bins[0].lo, get(Axis::Radius).bins[0].hi), (0.4, 0.5));
        assert_eq!(get(Axis::ImageAzimuth).bins[0].lo, -180.0);
        // Polarization samples have no mosaic position.
        let m = &get(Axis::MosaicPosition).bins;
        assert_eq!((m[0].lo, m[0].dn_samples, m[0].pol_samples), (3.0, 2, 0));
        assert_eq!((get(Axis::Channel).bins[0].lo, get(Axis::Channel).bins[0].pol_samples), (1.0, 0));
        assert_eq!(Axis::Channel.describe(1.5), "the 45° channel");
        assert_eq!(get(Axis::ModelDolp).bins[0].lo, 0.5);
        // A monochrome sensor's samples have no band: no band profile at all.
        assert!(out.iter().all(|q| q.axis != Axis::ColourBand));
        // A colour sensor's: each in its band's bin, polarization samples too.
        let mut c = Profiler::new(0.8);
        c.add_dn(&Position { band: 2.0, ..at }, 3.0);
        c.add_dn(&Position { band: 0.0, ..at }, 1.0);
        c.add_pol(&Position { band: 2.0, ..at }, Some(0.5), -0.01);
        let bands = c.finish().into_iter().find(|q| q.axis == Axis::ColourBand).unwrap().bins;
        let lo_n: Vec<(f64, usize, f64, usize)> =
            bands.iter().map(|b| (b.lo, b.dn_samples, b.chi2_per_sample, b.pol_samples)).collect();
        assert_eq!(lo_n, [(0.0, 1, 1.0, 0), (2.0, 1, 9.0, 1)]);
        assert_eq!(Axis::ColourBand.describe(2.5), "the blue band");
        // Out of range: nowhere.
        let mut q = Profiler::new(0.8);
        q.add_dn(&Position { radius: 0.9, ..at }, 1.0);
        assert!(q.finish().iter().find(|x| x.axis == Axis::Radius).unwrap().bins.is_empty());
    }

    #[test]
    fn the_description_names_the_axis_of_the_strongest_trend() {
        // A residual that grows with image azimuth, flat in radius.
        let mut p = Profiler::new(0.8);
        for i in 0..36 {
            let az = -175.0 + 10.0 * i as f64;
            let at = Position {
                scattering_deg: 90.0,
                radius: 0.3,
                azimuth_deg: az,
                mosaic: 0.0,
                channel: 0.0,
                model_dolp: 0.3,
                band: f64::NAN,
            };
            for _ in 0..10 {
                p.add_dn(&at, az.to_radians().cos());
                p.add_pol(&at, None, 0.0);
            }
        }
        let s = describe(&p.finish(), 5);
        assert!(s.starts_with("the mean raw-DN residual (σ) varies most along the image azimuth"), "{s}");
        assert!(s.contains("at image azimuth 165°") || s.contains("at image azimuth -165°"), "{s}");
    }
}
