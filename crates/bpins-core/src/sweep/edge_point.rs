//! `edge_point`: the seed paper's own extractor as the README reads it — a point of
//! the solar meridian read from a few hundred pixels near the image edge, its angle
//! measured about the assumed principal point.
//!
//! Steps (CONVENTIONS.md angles: β from image +x toward −y):
//!
//! 1. The strip: pixels at distance `[R − 3, R]` px from the *assumed* principal
//!    point along the direction the sun-vector solution points to (a start: the paper
//!    does not say how it finds the sun's half), ±R·tan 10° across it; R the largest
//!    radius of a disc inside the image (`HeadingContext::r_max_px`) — about 500
//!    pixels on the paper's sensor.
//! 2. Their Stokes from the same sensor and inversion as every extractor, and their
//!    DoLP. The sky is mirror-symmetric about the solar meridian, so across the strip
//!    the DoLP is even about the meridian (least angular distance to the sun): the
//!    point is located *from the pattern itself*, whatever principal point is
//!    assumed. Two readings that do not do this were tried and feel a 2 px offset 30
//!    times less than δ/R: the AoE one (φ = α − β = ±90°, β about the assumed point:
//!    near the zenith the E-vectors are parallel, so the point found moves with the
//!    assumed principal point) and the DoLP extremum along a *circle* about the
//!    assumed point (the iso-DoLP lines are nearly parallel there, so the extremum
//!    lies in the sun's direction from the circle's centre, wherever that is).
//! 3. A parabola DoLP = c0 + c1·s + c2·s² + c3·(a − a_mid) across the strip (s
//!    across, a along; least squares, the last term the gradient along the strip's
//!    height); its vertex s* is the meridian point, at image angle
//!    β* = β_start + atan(s*/a_mid) about the assumed principal point.
//! 4. Heading ψ_h = A + 90° − β* (A the sun's azimuth): for a level camera the
//!    vertical plane through the sun projects to the radial line of image angle
//!    90° − (ψ_h − A).
//!
//! A principal-point error δ reaches it in full, as δ⊥/R; per-pixel noise through
//! the few hundred pixels of the fit and the DoLP's weak curvature along the ring.
//! Colocated sensors only (the ring is read pixel by pixel); on either backend the
//! ring is read on the CPU.

use crate::chain::{ray_stokes, sensor_dn, sensor_noise, site_signal_dn, ChainFrame};

use crate::heading::HeadingContext;
use crate::recon::Reconstructor;

/// Height of the strip, pixels.
pub const RING_PX: f64 = 3.0;
/// Half-width of the strip, as an angle about the assumed principal point, degrees.
pub const WINDOW_DEG: f64 = 10.0;

/// The heading (degrees) and the number of pixels of the fit; `None` where fewer
/// than 10 pixels fall in the window or the DoLP has no vertex there.
pub fn heading(
    f: &ChainFrame,
    w: usize,
    h: usize,
    used: [bool; 4],
    rec: &Reconstructor,
    ctx: &HeadingContext,
    start_heading_deg: f64,
) -> Option<(f64, usize)> {
    let (cx, cy) = (ctx.intr.cx_px, ctx.intr.cy_px);
    let r_out = ctx.r_max_px;
    let r_in = (r_out - RING_PX).max(0.0);
    // The sun's half: the image angle the start heading puts the sun at.
    let beta_start = ctx.sun_az_deg + 90.0 - start_heading_deg;
    // The strip: across the start direction d at distance [R − 3, R] from the assumed
    // principal point, ±R·tan 10° wide. Coordinates (a along d, s across, toward
    // growing β), in the image-angle sense (x right, y up).
    let (sb, cb) = beta_start.to_radians().sin_cos();
    let half = r_out * WINDOW_DEG.to_radians().tan();
    let a_mid = 0.5 * (r_in + r_out);
    // Normal equations of DoLP = c0 + c1·s + c2·s² + c3·(a − a_mid) (the last term
    // takes the DoLP's gradient along d across the strip's height).
    let (mut n, mut ata, mut aty) = (0usize, [[0.0f64; 4]; 4], [0.0f64; 4]);
    let reach = (r_out * r_out + half * half).sqrt();
    let v0 = (cy - reach).floor().max(0.0) as usize;
    let v1 = ((cy + reach).ceil().max(0.0) as usize).min(h.saturating_sub(1));
    let u0 = (cx - reach).floor().max(0.0) as usize;
    let u1 = ((cx + reach).ceil().max(0.0) as usize).min(w.saturating_sub(1));
    for v in v0..=v1 {
        for u in u0..=u1 {
            let (x, y) = (u as f64 - cx, -(v as f64 - cy));
            let (along, across) = (x * cb + y * sb, -x * sb + y * cb);
            if along < r_in || along > r_out || across.abs() > half {
                continue;
            }
            // The sensor's DN of every channel, as the chain renders them.
            let g = f.intr.geometry(u as f64, v as f64);
            let s_true = ray_stokes(f, &g);
            let mut dn = [0.0; 4];
            for (ch, d) in dn.iter_mut().enumerate() {
                if used[ch] {
                    let noise = sensor_noise(f, (v * w + u) as u32, ch);
                    let signal = site_signal_dn(f, s_true, &g, u as u32, v as u32, ch);
                    *d = sensor_dn(f, signal, ch, &noise);
                }
            }
            let s = rec.stokes(&dn);
            if s.i.is_nan() || s.i <= 0.0 {
                continue;
            }
            let dolp = (s.q * s.q + s.u * s.u).sqrt() / s.i;
            n += 1;
            let basis = [1.0, across, across * across, along - a_mid];
            for (row, bi) in ata.iter_mut().zip(basis) {
                for (a, bj) in row.iter_mut().zip(basis) {
                    *a += bi * bj;
                }
            }
            for (t, bi) in aty.iter_mut().zip(basis) {
                *t += dolp * bi;
            }
        }
    }
    if n < 10 {
        return None;
    }
    let m = glam::DMat4::from_cols_array_2d(&ata);
    if m.determinant().abs() < 1e-300 {
        return None;
    }
    let c = m.inverse() * glam::DVec4::from_array(aty);
    if c.z.abs() < 1e-15 {
        return None;
    }
    let vertex = -c.y / (2.0 * c.z);
    if vertex.is_nan() || vertex.abs() > half {
        return None;
    }
    // The meridian point's angle about the assumed principal point.
    let beta_star = beta_start + vertex.atan2(a_mid).to_degrees();
    Some((crate::conventions::wrap_deg_360(ctx.sun_az_deg + 90.0 - beta_star), n))
}

#[cfg(test)]
mod tests {
    use super::super::{run_units, unit_count, CpuSums, SweepSpec};
    use std::path::Path;

    /// A colocated 400 × 300 px sensor; `errors` as TOML.
    fn spec(errors: &str) -> SweepSpec {
        let text = format!(
            r#"
format = "bpins-sweep/1"
trials = 6
extractors = ["sun_vector", "edge_point"]
combined = false
[sensor]
layout = "colocated"
width_px = 400
height_px = 300
pixel_pitch_um = 10.0
channels = [0, 45, 90]
[lens]
projection = "pinhole"
focal_length_mm = 8.0
[sky]
sun_elevations_deg = [5]
sun_azimuths_deg = [10, 40, 70]
trials_per_azimuth = 2
[response]
peak_dn = 153
{errors}
"#
        );
        SweepSpec::parse(Path::new("edge.toml"), &text).unwrap()
    }

    #[test]
    fn an_exact_sensor_reads_the_true_heading_and_a_principal_point_offset_moves_it_by_its_angle() {
        let exact = spec(
            "[[errors]]\nsource = \"none\"\nparam = \"array_rotation.dtheta_deg\"\ndistribution = \"fixed\"\nvalue = 0",
        );
        let recs = run_units(&exact, 0..unit_count(&exact), &CpuSums, &|_, _| {}).unwrap();
        for r in &recs {
            assert!(r.errors_deg[1].abs() < 0.05, "edge_point on an exact sensor: {}°", r.errors_deg[1]);
        }
        // The principal point 2 px off in x and y: the meridian point's angle about
        // the assumed principal point turns by δ⊥/R, up to 2√2 px / R.
        let pp = spec(
            "[[errors]]\nsource = \"pp\"\nparam = \"principal_point.dx_px\"\ndistribution = \"fixed\"\nvalue = 2\n\
             [[errors]]\nsource = \"pp\"\nparam = \"principal_point.dy_px\"\ndistribution = \"fixed\"\nvalue = 2",
        );
        let recs = run_units(&pp, 0..unit_count(&pp), &CpuSums, &|_, _| {}).unwrap();
        let r_px = 149.5 - super::RING_PX / 2.0;
        let full = (2.0f64 * 2.0f64.sqrt() / r_px).to_degrees();
        for r in &recs {
            let (sv, ep) = (r.errors_deg[0], r.errors_deg[1]);
            assert!(ep.abs() > 5.0 * sv.abs(), "edge_point feels the offset more than the sun vector: {ep}° vs {sv}°");
            assert!(ep.abs() < 1.2 * full, "at most about δ/R = {full}°: {ep}°");
        }
    }
}
