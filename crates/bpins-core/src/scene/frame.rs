//! The per-frame form of a [`FieldScene`] and the one call the chain makes per ray.
//!
//! ```text
//! d_w = world_from_cam · d                       the ray in the world (ENU)
//! S   ← sky_radiance(d_w, S)                    CIE radiance distribution (a scalar)
//! S   ← clouds(d_w, S)                          each cloud in turn
//! S   ← overcast(d_w, S)                        the deck, where it covers the ray
//! S   ← sun_disc(d_w, S)                        disc and aureole added (unpolarized)
//! S   ← skyline(d_w, S)                         trees, buildings, ground in front
//! ```
//!
//! Frame: the Stokes vector stays in the ray's meridional frame (p, s) throughout, as
//! `sky_stokes` returns it; elements that set an E-vector in the world go through
//! [`linear_stokes`]. Radiances are in the chain's sky units (Rayleigh: 1 toward the
//! sun), elements' strengths relative to the Rayleigh sky's zenith radiance
//! `½(1 + sin²h_sun)` of the frame.

use super::{clouds::Clouds, overcast::Overcast, sky_radiance::SkyRadiance, skyline::Skyline, sun_disc::SunDisc};
use super::{ElementId, FieldScene, ELEMENTS};
use crate::camera::MeridionalBasis;
use crate::noise::{stream, FrameKey, FIXED_PATTERN_FRAME};
use crate::stokes::Stokes;
use glam::{DMat3, DVec3};

/// Everything the scene elements need for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldFrame {
    /// The true camera axes in ENU (columns), mount tilt included.
    pub world_from_cam: DMat3,
    pub cam_from_world: DMat3,
    /// Unit sun direction, ENU.
    pub sun_world: DVec3,
    /// The Rayleigh sky's radiance at the zenith, ½(1 + sin²h_sun): the unit of the
    /// elements' radiances.
    pub zenith_radiance: f64,
    pub sky_radiance: Option<SkyRadiance>,
    pub clouds: Option<Clouds>,
    pub overcast: Option<Overcast>,
    pub sun_disc: Option<SunDisc>,
    pub skyline: Option<Skyline>,
}

impl FieldFrame {
    /// Folds `scene` for frame number `frame` of a camera with axes `world_from_cam`
    /// (columns, ENU) under the unit sun `sun_world` (ENU).
    pub fn new(scene: &FieldScene, world_from_cam: DMat3, sun_world: DVec3, frame: u32) -> Self {
        let zenith_radiance = 0.5 * (1.0 + sun_world.z * sun_world.z);
        let seed = scene.seed;
        FieldFrame {
            world_from_cam,
            cam_from_world: world_from_cam.transpose(),
            sun_world,
            zenith_radiance,
            sky_radiance: scene.values(ElementId::SkyRadiance).map(|v| SkyRadiance::new(v, sun_world)),
            clouds: scene.values(ElementId::Clouds).map(|v| Clouds::new(v, seed, frame)),
            overcast: scene.values(ElementId::Overcast).map(|v| Overcast::new(v, seed, frame)),
            sun_disc: scene.values(ElementId::SunDisc).map(|v| SunDisc::new(v, sun_world, zenith_radiance)),
            skyline: scene.values(ElementId::Skyline).map(|v| Skyline::new(v, seed, zenith_radiance)),
        }
    }
}

/// One ray as the elements see it.
#[derive(Clone, Copy, Debug)]
pub struct FieldRay<'a> {
    /// Unit ray, camera frame.
    pub d_cam: DVec3,
    /// Unit ray, ENU.
    pub d_world: DVec3,
    /// The ray's meridional basis (camera frame): the frame of the Stokes vector.
    pub basis: &'a MeridionalBasis,
    pub cam_from_world: &'a DMat3,
}

/// The sky's Stokes vector `sky` along the unit camera-frame ray `d_cam` (meridional
/// frame `basis`) with the frame's scene elements applied, in the same frame.
#[inline]
pub fn field_stokes(f: &FieldFrame, d_cam: DVec3, basis: &MeridionalBasis, sky: Stokes) -> Stokes {
    // The ray in the world, where the scene is fixed.
    let ray = FieldRay { d_cam, d_world: f.world_from_cam * d_cam, basis, cam_from_world: &f.cam_from_world };
    let mut s = sky;
    // The sky's radiance distribution (CIE general sky): a scalar on every component.
    if let Some(e) = &f.sky_radiance {
        s = e.apply(&ray, s);
    }
    // Clouds fixed in the world: brighter, less polarized, their E-vectors turned.
    if let Some(e) = &f.clouds {
        s = e.apply(&ray, s);
    }
    // A cloud deck fixed in the world, with holes of clear sky.
    if let Some(e) = &f.overcast {
        s = e.apply(&ray, s);
    }
    // The sun's disc and aureole: unpolarized radiance added.
    if let Some(e) = &f.sun_disc {
        s = e.apply(&ray, s);
    }
    // Trees, buildings and the ground, in front of all of it.
    if let Some(e) = &f.skyline {
        s = e.apply(&ray, s);
    }
    s
}

/// Stokes vector (meridional frame of `ray`) of radiance `i` with DoLP `dolp` and its
/// E-vector along the world (ENU) direction `e_world` (any length, ⊥ the ray):
/// AoE φ = atan2(−e_s, e_p) as in `sky_stokes`.
#[inline]
pub fn linear_stokes(i: f64, dolp: f64, e_world: DVec3, ray: &FieldRay) -> Stokes {
    let e = *ray.cam_from_world * e_world;
    let (ep, es) = (e.dot(ray.basis.p), e.dot(ray.basis.s));
    let n2 = ep * ep + es * es;
    if n2 == 0.0 {
        return Stokes::new(i, 0.0, 0.0, 0.0);
    }
    let pol = i * dolp / n2;
    Stokes::new(i, pol * (ep * ep - es * es), -2.0 * pol * ep * es, 0.0)
}

/// Seeded draws of one element: fixed in the world, or of one frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Draws(FrameKey);

impl Draws {
    /// Draws fixed in the world (the same in every frame) of element `id` under `seed`.
    pub fn world(seed: u64, id: ElementId) -> Self {
        Draws(FrameKey::new(seed, trial_of(id), FIXED_PATTERN_FRAME))
    }

    /// Draws of frame `frame` of element `id` under `seed`.
    pub fn frame(seed: u64, id: ElementId, frame: u32) -> Self {
        Draws(FrameKey::new(seed, trial_of(id), frame))
    }

    /// Draws under an explicit (seed, trial, frame) key (the field attitude's).
    pub fn keyed(seed: u64, trial: u32, frame: u32) -> Self {
        Draws(FrameKey::new(seed, trial, frame))
    }

    /// Uniform number `k` in [0, 1).
    pub fn uniform(&self, k: u32) -> f64 {
        self.0.uniform(k, 0, stream::SCENE)
    }

    /// Standard normal number `k`.
    pub fn normal(&self, k: u32) -> f64 {
        self.0.normal(k, 0, stream::SCENE)
    }
}

/// The trial word of an element's draws: its registry index, offset so the scene's
/// keys never meet a Monte Carlo's small trial numbers under the same seed.
fn trial_of(id: ElementId) -> u32 {
    0x5ce0_0000 + ELEMENTS.iter().position(|e| e.id == id).unwrap_or(ELEMENTS.len()) as u32
}

/// Index into the element's texture salts (one noise field per salt).
pub(crate) fn element_index(id: ElementId) -> u32 {
    ELEMENTS.iter().position(|e| e.id == id).unwrap_or(ELEMENTS.len()) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::conventions::{enu_from_az_el_deg, world_from_camera};

    #[test]
    fn an_empty_scene_is_the_identity() {
        let r = world_from_camera(30.0, 10.0, -5.0);
        let f = FieldFrame::new(&FieldScene::new(4), r, enu_from_az_el_deg(40.0, 25.0), 0);
        let d = DVec3::new(0.1, -0.3, 0.9).normalize();
        let s = Stokes::new(0.7, 0.1, -0.2, 0.01);
        assert_eq!(field_stokes(&f, d, &meridional_basis(d), s), s);
    }

    #[test]
    fn linear_stokes_puts_the_e_vector_where_asked() {
        // A ray at elevation 30° toward azimuth 100°; E-vector horizontal (⊥ the local
        // vertical): then it is ⊥ the ray's vertical plane, which for a level camera is
        // its meridional plane, so AoE = 90°.
        let r = world_from_camera(0.0, 0.0, 0.0);
        let dw = enu_from_az_el_deg(100.0, 30.0);
        let d = r.transpose() * dw;
        let b = meridional_basis(d);
        let ray = FieldRay { d_cam: d, d_world: dw, basis: &b, cam_from_world: &r.transpose() };
        let horizontal = DVec3::Z.cross(dw);
        let s = linear_stokes(2.0, 0.3, horizontal, &ray);
        assert!((s.dolp() - 0.3).abs() < 1e-12 && s.i == 2.0);
        assert!((s.aop_rad().abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{}", s.aop_rad());
    }

    #[test]
    fn draws_are_keyed_by_seed_element_and_frame() {
        let a = Draws::world(1, ElementId::Clouds);
        assert_eq!(a.uniform(0), Draws::world(1, ElementId::Clouds).uniform(0));
        assert_ne!(a.uniform(0), Draws::world(2, ElementId::Clouds).uniform(0));
        assert_ne!(a.uniform(0), Draws::world(1, ElementId::Skyline).uniform(0));
        assert_ne!(a.uniform(0), Draws::frame(1, ElementId::Clouds, 0).uniform(0));
        assert_ne!(Draws::frame(1, ElementId::Clouds, 0).normal(3), Draws::frame(1, ElementId::Clouds, 1).normal(3));
    }
}
