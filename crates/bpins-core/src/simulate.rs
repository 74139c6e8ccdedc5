//! Drivers: map the per-pixel chain ([`crate::chain`]) over a frame with rayon.
//!
//! Rows are independent and every random draw is keyed by its pixel, so the output is
//! bit-identical whatever the thread count.

use crate::camera::Intrinsics;
use crate::chain::{
    pixel_signal_dn, pixel_stokes, sensor_dn4_row, sensor_dn_row, signal4_row, signal_row, ChainFrame, NoiseRows, Scene,
};
use crate::effects::Model;
use crate::sensor::{Channel, Layout};
use rayon::prelude::*;

/// Renders a DoFP mosaic (`w × h`, row-major DN): each pixel its own ray and analyzer.
pub fn render_mosaic(f: &ChainFrame, w: usize, h: usize, mosaic: &[[Channel; 2]; 2]) -> Vec<f32> {
    let mut out = vec![0f32; w * h];
    out.par_chunks_mut(w.max(1)).enumerate().for_each_init(
        || (vec![0.0; w], NoiseRows::default()),
        |(signal, scratch), (v, row)| {
            let chans = [0, 1].map(|u| Layout::dofp_channel(mosaic, u, v).index());
            // Sky → lens → analyzer → photo-signal along each true ray.
            signal_row(f, v as f64, chans, &mut signal[..row.len()]);
            // Sensor: non-uniformities, offsets, noise, rounding.
            sensor_dn_row(f, (v * w) as u32, chans, &signal[..row.len()], scratch, row);
        },
    );
    out
}

/// Renders a colocated frame: one `w × h` plane per channel in `channels`.
pub fn render_colocated(f: &ChainFrame, w: usize, h: usize, channels: &[Channel]) -> Vec<Vec<f32>> {
    let mut used = [false; 4];
    for c in channels {
        used[c.index()] = true;
    }
    let rows: Vec<Vec<[f64; 4]>> = (0..h)
        .into_par_iter()
        .map_init(
            || (vec![[0.0; 4]; w], NoiseRows::default()),
            |(signal, scratch), v| {
                let mut dn = vec![[0.0; 4]; w];
                signal4_row(f, v as f64, signal);
                sensor_dn4_row(f, (v * w) as u32, used, signal, scratch, &mut dn);
                dn
            },
        )
        .collect();
    let mut planes = vec![vec![0f32; w * h]; channels.len()];
    for (v, row) in rows.iter().enumerate() {
        for (u, dn) in row.iter().enumerate() {
            for (plane, c) in planes.iter_mut().zip(channels) {
                plane[v * w + u] = dn[c.index()] as f32;
            }
        }
    }
    planes
}

/// Largest noise-free analyzer intensity (sky radiance units, gain 1) over the frame,
/// sampled on a grid of `stride_px` plus the last row and column: divide the wanted
/// peak DN by it to get the sensor gain.
pub fn peak_intensity(model: &Model, nominal: &Intrinsics, scene: &Scene, w: usize, h: usize, stride_px: usize) -> f64 {
    let f = ChainFrame::noise_free(model, nominal, scene);
    let grid = |n: usize| -> Vec<usize> {
        let mut g: Vec<usize> = (0..n).step_by(stride_px.max(1)).collect();
        if g.last() != Some(&(n - 1)) {
            g.push(n - 1);
        }
        g
    };
    let (us, vs) = (grid(w), grid(h));
    vs.par_iter()
        .map(|&v| {
            let mut m: f64 = 0.0;
            for &u in &us {
                let s = pixel_stokes(&f, u as f64, v as f64);
                for ch in 0..4 {
                    m = m.max(pixel_signal_dn(&f, s, ch));
                }
            }
            m
        })
        .reduce(|| 0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::NoiseIndex;
    use crate::sensor::{Response, DEFAULT_MOSAIC};

    #[test]
    fn mosaic_is_bit_identical_whatever_the_thread_count() {
        let resp = Response {
            read_noise_dn: 1.0,
            system_gain_dn_per_e: 0.1,
            quantize: true,
            bit_depth: 12,
            ..Response::ideal(3000.0)
        };
        let f = ChainFrame::new(
            &Model::default(),
            &intrinsics(),
            &scene(),
            &resp,
            NoiseIndex { seed: 11, trial: 0, frame: 0 },
        );
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| render_mosaic(&f, 612, 64, &DEFAULT_MOSAIC))
        };
        assert_eq!(run(1), run(3));
    }

    #[test]
    fn colocated_planes_match_the_mosaic_where_they_overlap() {
        let f = ChainFrame::noise_free(&Model::default(), &intrinsics(), &scene());
        let m = render_mosaic(&f, 40, 30, &DEFAULT_MOSAIC);
        let planes = render_colocated(&f, 40, 30, &Channel::ALL);
        for v in 0..30 {
            for u in 0..40 {
                let ch = Layout::dofp_channel(&DEFAULT_MOSAIC, u, v).index();
                assert_eq!(m[v * 40 + u], planes[ch][v * 40 + u]);
            }
        }
    }

    #[test]
    fn peak_intensity_bounds_the_frame() {
        let p = peak_intensity(&Model::default(), &intrinsics(), &scene(), 612, 512, 8);
        let f = ChainFrame::noise_free(&Model::default(), &intrinsics(), &scene());
        let planes = render_colocated(&f, 612, 512, &Channel::ALL);
        let true_max = planes.iter().flatten().cloned().fold(0f32, f32::max) as f64;
        assert!(p <= true_max * (1.0 + 1e-6), "{p} vs {true_max}");
        assert!((p - true_max).abs() / true_max < 0.01, "{p} vs {true_max}");
    }
}
