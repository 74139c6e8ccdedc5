//! Registry-wide: every catalog effect, at its typical strength and at both ends of
//! its range, runs the same through the row kernels (the drivers `render_mosaic` and
//! `render_colocated`, as `bpins simulate` and the fit's frames use them) as through
//! the per-pixel reference (`mosaic_pixel_signal_dn`; `ray_stokes` +
//! `site_signal_dn`), value for value. An effect whose per-pixel step the row
//! kernels skip — a frame parameter left out of `ChainFrame::has_pixel_effects` —
//! fails here by name, whatever its file says.

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::effects::{EffectSet, REGISTRY};
use bpins_core::internal::chain::{
    mosaic_pixel_signal_dn, ray_stokes, sensor_dn, site_signal_dn, ChainFrame, NoiseIndex, Scene, SensorNoise,
};
use bpins_core::internal::simulate::{render_colocated, render_mosaic};
use bpins_core::sensor::{Channel, Layout, Response, DEFAULT_MOSAIC};

const W: usize = 64;
const H: usize = 48;

fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

#[test]
fn every_effect_runs_the_same_in_the_row_kernels_as_per_pixel() {
    let intr = Intrinsics::new(Projection::Equidistant, 40.0, 31.5, 23.5);
    let scene =
        Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 3.0, tilt_y_deg: -2.0, dmax: 0.6 };
    let mut checked = 0;
    for e in REGISTRY {
        let at = |pick: fn(&bpins_core::effects::ParamSpec) -> f64| {
            let mut set = EffectSet::new();
            for p in e.params {
                set.set(e.name, p.name, pick(p)).unwrap();
            }
            set
        };
        for (label, set) in [("typical", at(|p| p.typical)), ("min", at(|p| p.min)), ("max", at(|p| p.max))] {
            let f = ChainFrame::new(
                &set.model(),
                &intr,
                &scene,
                &Response::ideal(1000.0),
                NoiseIndex { seed: 1, trial: 0, frame: 0 },
            );
            let mosaic = render_mosaic(&f, W, H, &DEFAULT_MOSAIC);
            let planes = render_colocated(&f, W, H, &Channel::ALL);
            for v in 0..H {
                for u in 0..W {
                    let ch = Layout::dofp_channel(&DEFAULT_MOSAIC, u, v).index();
                    let sig = mosaic_pixel_signal_dn(&f, u, v, W, H, &DEFAULT_MOSAIC);
                    let want = sensor_dn(&f, sig, ch, &SensorNoise::default()) as f32;
                    let got = mosaic[v * W + u];
                    assert!(
                        same(got as f64, want as f64),
                        "{} at {label}: DoFP ({u}, {v}) row kernel {got} vs per pixel {want}",
                        e.name
                    );
                    let g = f.intr.geometry(u as f64, v as f64);
                    let s = ray_stokes(&f, &g);
                    for (c, plane) in Channel::ALL.iter().zip(&planes) {
                        let sig = site_signal_dn(&f, s, &g, u as u32, v as u32, c.index());
                        let want = sensor_dn(&f, sig, c.index(), &SensorNoise::default()) as f32;
                        let got = plane[v * W + u];
                        assert!(
                            same(got as f64, want as f64),
                            "{} at {label}: colocated ({u}, {v}) channel {:?} row kernel {got} vs per pixel {want}",
                            e.name,
                            c
                        );
                    }
                }
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 3 * REGISTRY.len());
}
