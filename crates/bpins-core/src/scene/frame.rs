//! The per-frame form of a [`FieldScene`] and the one call the chain makes per ray.
//!
//! ```text
//! d_w = world_from_cam · d                       the ray in the world (ENU)
//! S   ← e.apply(d_w, S)  for each enabled element e, back to front:
//!       Layer::Sky         sky_radiance           CIE radiance distribution (a scalar)
//!       Layer::Cloud       clouds, overcast       each cloud in turn; the deck
//!       Layer::Sun         sun_disc               disc and aureole added (unpolarized)
//!       Layer::Foreground  skyline                trees, buildings, ground in front
//! ```
//!
//! The order comes from the registry: each [`ElementDef`](super::ElementDef) names its
//! [`Layer`], and within a layer the registry's order holds. An element adds itself by
//! its file and its line in `ELEMENTS`; nothing here names one.
//!
//! Frame: the Stokes vector stays in the ray's meridional frame (p, s) throughout, as
//! `sky_stokes` returns it; elements that set an E-vector in the world go through
//! [`linear_stokes`]. Radiances are in the chain's sky units (Rayleigh: 1 toward the
//! sun), elements' strengths relative to the Rayleigh sky's zenith radiance
//! `½(1 + sin²h_sun)` of the frame.

use super::{ElementDef, FieldScene, ELEMENTS};
use crate::camera::MeridionalBasis;
use crate::noise::{stream, FrameKey, FIXED_PATTERN_FRAME};
use crate::stokes::Stokes;
use glam::{DMat3, DVec3};
use std::any::Any;
use std::fmt::Debug;
use std::sync::Arc;

/// Where an element sits in the field, back to front: [`field_stokes`] applies the
/// layers in this order (within a layer, in the registry's order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Layer {
    /// The sky itself: its radiance distribution.
    Sky,
    /// What floats in front of the sky: clouds, a deck.
    Cloud,
    /// The sun's disc and aureole, over the clouds.
    Sun,
    /// What stands in front of all of it: trees, buildings, the ground.
    Foreground,
}

/// What an element's per-frame form is built from.
#[derive(Clone, Copy, Debug)]
pub struct ElementContext {
    /// The scene's seed: every draw is keyed by it.
    pub seed: u64,
    /// The frame number (per-frame draws).
    pub frame: u32,
    /// Unit sun direction, ENU.
    pub sun_world: DVec3,
    /// The Rayleigh sky's radiance at the zenith, ½(1 + sin²h_sun).
    pub zenith_radiance: f64,
    /// cd/m² per unit of the chain's sky radiance under the frame's source
    /// ([`crate::sky::radiometry::SkyLight::unit_cd_m2`]): the scene's where set
    /// ([`FieldScene::with_sky_unit_cd_m2`]), else the sun's at the source's elevation
    /// (at least 1°).
    pub sky_unit_cd_m2: f64,
    /// The other source's sky (the `twilight` element), where the frame's time and place
    /// give one ([`FieldScene::with_other_sky`](super::FieldScene)).
    pub other_sky: Option<super::twilight::OtherSky>,
}

/// One element folded for one frame: its constants and draws, and what it does to a ray.
pub trait FieldElement: Any + Debug + Send + Sync + SameAs {
    /// The Stokes vector `s` along `ray` with this element applied; meridional frame of
    /// `ray` in and out.
    fn apply(&self, ray: &FieldRay, s: Stokes) -> Stokes;
}

/// Equality across element types (false between two types): for [`FieldFrame`]'s
/// `PartialEq`. Every `PartialEq` element has it.
pub trait SameAs {
    /// Whether `other` is of this type and equal to `self`.
    fn same_as(&self, other: &dyn Any) -> bool;
}

impl<T: Any + PartialEq> SameAs for T {
    fn same_as(&self, other: &dyn Any) -> bool {
        other.downcast_ref::<T>() == Some(self)
    }
}

/// Everything the scene elements need for one frame.
#[derive(Clone, Debug)]
pub struct FieldFrame {
    /// The true camera axes in ENU (columns), mount tilt included.
    pub world_from_cam: DMat3,
    pub cam_from_world: DMat3,
    /// Unit sun direction, ENU.
    pub sun_world: DVec3,
    /// The Rayleigh sky's radiance at the zenith, ½(1 + sin²h_sun): the unit of the
    /// elements' radiances.
    pub zenith_radiance: f64,
    /// The enabled elements, folded for this frame, in the order they apply.
    pub elements: Vec<Arc<dyn FieldElement>>,
    /// A white light's radiance over the sky's in the band this frame is seen in: 1/r_b
    /// of `sky_spectrum` for a colour sensor's band frame (`ChainFrame::in_band`), 1
    /// otherwise. The band's gain carries the sky's colour r_b, so elements that add
    /// white light (a cloud, a deck, the sun's disc) scale it by this to stay white.
    pub white_over_sky: f64,
}

impl PartialEq for FieldFrame {
    fn eq(&self, o: &Self) -> bool {
        (self.world_from_cam, self.cam_from_world, self.sun_world, self.zenith_radiance, self.white_over_sky)
            == (o.world_from_cam, o.cam_from_world, o.sun_world, o.zenith_radiance, o.white_over_sky)
            && self.elements.len() == o.elements.len()
            && self.elements.iter().zip(&o.elements).all(|(a, b)| a.same_as(b.as_ref() as &dyn Any))
    }
}

impl FieldFrame {
    /// Folds `scene` for frame number `frame` of a camera with axes `world_from_cam`
    /// (columns, ENU) under the unit sun `sun_world` (ENU).
    pub fn new(scene: &FieldScene, world_from_cam: DMat3, sun_world: DVec3, frame: u32) -> Self {
        let zenith_radiance = 0.5 * (1.0 + sun_world.z * sun_world.z);
        let sky_unit_cd_m2 = scene.sky_unit_cd_m2().unwrap_or_else(|| {
            let el_deg = sun_world.z.clamp(-1.0, 1.0).asin().to_degrees().max(1.0);
            crate::sky::radiometry::SkyLight::sun(el_deg).map_or(f64::NAN, |l| l.unit_cd_m2)
        });
        let cx = ElementContext {
            seed: scene.seed,
            frame,
            sun_world,
            zenith_radiance,
            sky_unit_cd_m2,
            other_sky: scene.other_sky(),
        };
        let mut enabled: Vec<(&ElementDef, &[f64])> = scene.iter().collect();
        enabled.sort_by_key(|(d, _)| (d.layer, element_index(d)));
        FieldFrame {
            world_from_cam,
            cam_from_world: world_from_cam.transpose(),
            sun_world,
            zenith_radiance,
            elements: enabled.into_iter().map(|(d, v)| (d.prepare)(v, &cx)).collect(),
            white_over_sky: 1.0,
        }
    }

    /// The frame's element of type `T`, if enabled.
    pub fn element<T: FieldElement>(&self) -> Option<&T> {
        self.elements.iter().find_map(|e| (e.as_ref() as &dyn Any).downcast_ref::<T>())
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
    /// A white (spectrally flat) light's radiance over the sky's in the frame's band
    /// ([`FieldFrame::white_over_sky`]; 1 for a monochrome sensor).
    pub white_over_sky: f64,
}

/// The sky's Stokes vector `sky` along the unit camera-frame ray `d_cam` (meridional
/// frame `basis`) with the frame's scene elements applied, in the same frame.
#[inline]
pub fn field_stokes(f: &FieldFrame, d_cam: DVec3, basis: &MeridionalBasis, sky: Stokes) -> Stokes {
    // The ray in the world, where the scene is fixed.
    let ray = FieldRay {
        d_cam,
        d_world: f.world_from_cam * d_cam,
        basis,
        cam_from_world: &f.cam_from_world,
        white_over_sky: f.white_over_sky,
    };
    // Each element, back to front.
    f.elements.iter().fold(sky, |s, e| e.apply(&ray, s))
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
    /// Draws fixed in the world (the same in every frame) of element `def` under `seed`.
    pub fn world(seed: u64, def: &ElementDef) -> Self {
        Draws(FrameKey::new(seed, trial_of(def), FIXED_PATTERN_FRAME))
    }

    /// Draws of frame `frame` of element `def` under `seed`.
    pub fn frame(seed: u64, def: &ElementDef, frame: u32) -> Self {
        Draws(FrameKey::new(seed, trial_of(def), frame))
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
fn trial_of(def: &ElementDef) -> u32 {
    0x5ce0_0000 + element_index(def)
}

/// The element's index in the registry: the key of its draws and its texture salts
/// (one noise field per salt).
pub(crate) fn element_index(def: &ElementDef) -> u32 {
    ELEMENTS.iter().position(|e| e.name == def.name).unwrap_or(ELEMENTS.len()) as u32
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
    fn elements_apply_back_to_front_by_layer_then_registry_order() {
        use crate::scene::{clouds::Clouds, overcast::Overcast, sky_radiance::SkyRadiance};
        use crate::scene::{
            night_background::NightBackground, skyline::Skyline, sun_disc::SunDisc, twilight::Twilight,
        };
        let f =
            FieldFrame::new(&FieldScene::all(3), world_from_camera(0.0, 0.0, 0.0), enu_from_az_el_deg(40.0, 25.0), 0);
        let at = |is: fn(&dyn Any) -> bool| f.elements.iter().position(|e| is(e.as_ref() as &dyn Any));
        let order = [
            at(|e| e.is::<SkyRadiance>()),
            at(|e| e.is::<NightBackground>()),
            at(|e| e.is::<Twilight>()),
            at(|e| e.is::<Clouds>()),
            at(|e| e.is::<Overcast>()),
            at(|e| e.is::<SunDisc>()),
            at(|e| e.is::<Skyline>()),
        ];
        assert_eq!(
            order,
            [0, 1, 2, 3, 4, 5, 6].map(Some),
            "the sky, its glow and the other source's, clouds, the deck, the sun, the skyline"
        );
        // Overcast is registered after the sun's disc (its draws keyed by its place) yet
        // applies before it: its layer, not its place, orders it.
        let place = |name| ELEMENTS.iter().position(|e| e.name == name);
        assert!(place("overcast") > place("sun_disc"));
        // Each element's same_as is its own PartialEq, and false across types.
        let g =
            FieldFrame::new(&FieldScene::all(3), world_from_camera(0.0, 0.0, 0.0), enu_from_az_el_deg(40.0, 25.0), 0);
        assert_eq!(f, g);
        assert!(!f.elements[0].same_as(f.elements[1].as_ref() as &dyn Any));
        let h =
            FieldFrame::new(&FieldScene::all(4), world_from_camera(0.0, 0.0, 0.0), enu_from_az_el_deg(40.0, 25.0), 0);
        assert_ne!(f, h, "another seed, other clouds");
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
        let ray = FieldRay { d_cam: d, d_world: dw, basis: &b, cam_from_world: &r.transpose(), white_over_sky: 1.0 };
        let horizontal = DVec3::Z.cross(dw);
        let s = linear_stokes(2.0, 0.3, horizontal, &ray);
        assert!((s.dolp() - 0.3).abs() < 1e-12 && s.i == 2.0);
        assert!((s.aop_rad().abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{}", s.aop_rad());
    }

    #[test]
    fn draws_are_keyed_by_seed_element_and_frame() {
        let (clouds, skyline) = (&super::super::clouds::ELEMENT, &super::super::skyline::ELEMENT);
        let a = Draws::world(1, clouds);
        assert_eq!(a.uniform(0), Draws::world(1, clouds).uniform(0));
        assert_ne!(a.uniform(0), Draws::world(2, clouds).uniform(0));
        assert_ne!(a.uniform(0), Draws::world(1, skyline).uniform(0));
        assert_ne!(a.uniform(0), Draws::frame(1, clouds, 0).uniform(0));
        assert_ne!(Draws::frame(1, clouds, 0).normal(3), Draws::frame(1, clouds, 1).normal(3));
    }
}
