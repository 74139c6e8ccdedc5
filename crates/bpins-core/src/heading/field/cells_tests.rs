//! Tests of the cell pass (`cells.rs`).

use super::*;
use crate::effects::Model;
use crate::sensor::DEFAULT_MOSAIC;

fn rec() -> Reconstructor {
    Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap()
}

/// A uniform, linearly polarized field: I = 2000 DN, DoLP 0.4 at α = 30°.
fn uniform_mosaic(w: usize, h: usize) -> Vec<u16> {
    let (i, d, a) = (2000.0f64, 0.4, 30f64.to_radians());
    let (q, u) = (i * d * (2.0 * a).cos(), i * d * (2.0 * a).sin());
    (0..h)
        .flat_map(|v| {
            (0..w).map(move |u_px| {
                let th = Layout::dofp_channel(&DEFAULT_MOSAIC, u_px, v).angle_deg().to_radians();
                (64.0 + 0.5 * (i + q * (2.0 * th).cos() + u * (2.0 * th).sin())).round() as u16
            })
        })
        .collect()
}

#[test]
fn a_uniform_field_gives_its_stokes_vector_in_every_cell() {
    let (w, h) = (40, 24);
    let dn = uniform_mosaic(w, h);
    let cells = Cells::from_mosaic(&RawImage::packed(&dn, w, h), &DEFAULT_MOSAIC, &rec(), 4095.0, 8);
    assert_eq!((cells.cols, cells.rows, cells.cells.len()), (5, 3, 15));
    for c in &cells.cells {
        let aop = 0.5 * c.stokes.u.atan2(c.stokes.q).to_degrees();
        assert!((aop - 30.0).abs() < 0.05, "{c:?}");
        assert!((c.stokes.i - 2000.0).abs() < 1.0, "{c:?}");
        // Rounding only: the within-cell scatter is that of a 0.5 DN rounding at most.
        assert!(c.var_q_dn2 < 0.1 && c.var_u_dn2 < 0.1, "{c:?}");
    }
    assert_eq!((cells.cells[6].col, cells.cells[6].row), (1, 1));
    assert_eq!((cells.cells[6].x_px, cells.cells[6].y_px), (11.5, 11.5));
}

#[test]
fn a_strided_u16_buffer_reads_as_the_packed_f32_one() {
    let (w, h) = (40, 24);
    let dn = uniform_mosaic(w, h);
    let stride = 47;
    let mut padded = vec![0u16; stride * h];
    for v in 0..h {
        padded[v * stride..][..w].copy_from_slice(&dn[v * w..][..w]);
    }
    let f: Vec<f32> = dn.iter().map(|&x| x as f32).collect();
    let a = Cells::from_mosaic(
        &RawImage { data: &padded, width_px: w, height_px: h, stride },
        &DEFAULT_MOSAIC,
        &rec(),
        4095.0,
        8,
    );
    let b = Cells::from_mosaic(&RawImage::packed(&f, w, h), &DEFAULT_MOSAIC, &rec(), 4095.0, 8);
    assert_eq!(a, b);
}

#[test]
fn saturated_cells_are_dropped_and_noise_is_measured() {
    let (w, h) = (32, 32);
    let mut dn = uniform_mosaic(w, h);
    // Saturate the top-left cell; add ±10 DN alternating noise to the bottom-right one.
    for v in 0..8 {
        for u in 0..8 {
            dn[v * w + u] = 4095;
        }
    }
    for v in 24..32 {
        for u in 24..32 {
            let k = if (u / 2 + v / 2) % 2 == 0 { 10 } else { -10 };
            dn[v * w + u] = (dn[v * w + u] as i32 + k) as u16;
        }
    }
    let cells = Cells::from_mosaic(&RawImage::packed(&dn, w, h), &DEFAULT_MOSAIC, &rec(), 4095.0, 8);
    assert_eq!(cells.cells.len(), 15);
    assert!(!cells.cells.iter().any(|c| c.col == 0 && c.row == 0));
    let noisy = cells.cells.iter().find(|c| c.col == 3 && c.row == 3).unwrap();
    // Scatter about each channel's plane (no slope here): 16·100 DN² over 16 − 3
    // degrees of freedom, of a mean of 16 pixels; Q = I0 − I90.
    assert!((noisy.var_q_dn2 - 2.0 * 100.0 / 13.0).abs() < 0.5, "{noisy:?}");
}

#[test]
fn a_gradient_is_read_at_the_cell_centre_not_at_the_channel_centroids() {
    // I, Q, U all ramp along x and y: each channel's mean sits half a pixel off the
    // centre; read at the centre, the cell gives the field there.
    let (w, h) = (32, 32);
    let field = |x: f64, y: f64| {
        let i = 1500.0 + 20.0 * x - 7.0 * y;
        (i, 300.0 + 9.0 * x, -200.0 + 4.0 * y + 6.0 * x)
    };
    let dn: Vec<f32> = (0..h)
        .flat_map(|v| {
            (0..w).map(move |u| {
                let th = Layout::dofp_channel(&DEFAULT_MOSAIC, u, v).angle_deg().to_radians();
                let (i, q, uu) = field(u as f64, v as f64);
                (64.0 + 0.5 * (i + q * (2.0 * th).cos() + uu * (2.0 * th).sin())) as f32
            })
        })
        .collect();
    let cells = Cells::from_mosaic(&RawImage::packed(&dn, w, h), &DEFAULT_MOSAIC, &rec(), 65535.0, 8);
    for c in &cells.cells {
        let (i, q, u) = field(c.x_px, c.y_px);
        let s = c.stokes;
        assert!((s.i - i).abs() < 1e-3 && (s.q - q).abs() < 1e-3 && (s.u - u).abs() < 1e-3, "{c:?} vs {i} {q} {u}");
        assert!(c.var_q_dn2 < 1e-6, "a plane leaves no scatter: {c:?}");
    }
}

#[test]
fn default_cell_size_is_even_and_scales_with_the_sensor() {
    assert_eq!(Cells::default_cell_px(612, 512), 8);
    assert_eq!(Cells::default_cell_px(2448, 2048), 32);
    assert_eq!(Cells::default_cell_px(64, 48), 4);
    assert_eq!(Cells::default_cell_px(128, 128), 4);
}
