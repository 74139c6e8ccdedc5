//! Per-cell analyzers of one colour band of a colour-polarization sensor: the cells of
//! `Cells::fill_from_mosaic_band_calibrated`, each reconstructed through the analyzers
//! of the band's own pixels only (CONVENTIONS.md: bands are never mixed before
//! reconstruction).
//!
//! ```text
//! c_k = Σ_p w_p DN_p                     p over channel k's pixels of the band in the cell
//! w_p = 1/n_k + (α_k du_p + β_k dv_p)/det_k
//! α_k = S_vv cu − S_uv cv,  β_k = S_uu cv − S_uv cu,  det_k = S_uu S_vv − S_uv²
//! O_k = Σ_p w_p o_p,  A_k = Σ_p w_p a_p  (the module above: DN_p = o_p + a_p·S)
//! ```
//!
//! `du, dv`: the pixel's place about the mean place of channel k's band pixels,
//! `cu, cv`: the cell centre's, `S_uu, S_vv, S_uv` their sums of squares and products
//! (px²): the weights of the band's own plane fit (`heading/field/cells_band.rs`), so
//! `c_k` is the value that fit puts at the cell centre, and `O_k + A_k·S` is exact for
//! a Stokes field planar over the cell. Where `det_k = 0` (one place, or places on one
//! line: an R or B channel in a cell of 4 px) the fit is the plain mean, `w_p = 1/n_k`,
//! as the cells take it. The fixed pattern about each channel's plane (`Σ r_p r_pᵀ` of
//! `[a_p, o_p]`) is kept for the cells' scatter, as for a monochrome sensor.
//!
//! Frame: image pixels; units DN. The geometry is the same in every cell (a cell is a
//! whole number of 4 × 4 superpixels), so it is computed once per grid.

use super::*;

/// One band pixel of a channel in a cell.
struct Place {
    /// Column and row local to the cell's top-left pixel.
    at: (usize, usize),
    /// Its plane-fit weight `w_p`.
    w: f64,
    /// Its offset from the channel's mean place, `(du − ū, dv − v̄)`, px.
    d: (f64, f64),
}

/// Channel `k`'s band pixels in a cell and the sums of squares of their places.
struct ChannelPlane {
    px: Vec<Place>,
    suu: f64,
    svv: f64,
    suv: f64,
}

impl ChannelPlane {
    fn new(places: &[(usize, usize)], centre: f64) -> ChannelPlane {
        let n = places.len() as f64;
        let ubar = places.iter().map(|p| p.0 as f64).sum::<f64>() / n;
        let vbar = places.iter().map(|p| p.1 as f64).sum::<f64>() / n;
        let d: Vec<(f64, f64)> = places.iter().map(|&(u, v)| (u as f64 - ubar, v as f64 - vbar)).collect();
        let suu = d.iter().map(|x| x.0 * x.0).sum::<f64>();
        let svv = d.iter().map(|x| x.1 * x.1).sum::<f64>();
        let suv = d.iter().map(|x| x.0 * x.1).sum::<f64>();
        let det = suu * svv - suv * suv;
        let (cu, cv) = (centre - ubar, centre - vbar);
        let px = places
            .iter()
            .zip(&d)
            .map(|(&p, &(du, dv))| {
                let w = if det > 0.0 {
                    1.0 / n + ((svv * cu - suv * cv) * du + (suu * cv - suv * cu) * dv) / det
                } else {
                    1.0 / n
                };
                Place { at: p, w, d: (du, dv) }
            })
            .collect();
        ChannelPlane { px, suu, svv, suv }
    }

    /// The channel's effective row and offset at the cell centre (`A_k`, `O_k`) and
    /// its fixed pattern about the plane, from `z(place) = [a_p, o_p]`.
    fn reduce(&self, z: impl Fn(usize, usize) -> [f64; 4]) -> ([f64; 4], [f64; 10]) {
        let n = self.px.len() as f64;
        let det = self.suu * self.svv - self.suv * self.suv;
        let zs: Vec<[f64; 4]> = self.px.iter().map(|p| z(p.at.0, p.at.1)).collect();
        let (mut eff, mut mean, mut bu, mut bv) = ([0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]);
        for (zp, &Place { w, d: (du, dv), .. }) in zs.iter().zip(&self.px) {
            for c in 0..4 {
                eff[c] += w * zp[c];
                mean[c] += zp[c] / n;
                bu[c] += du * zp[c];
                bv[c] += dv * zp[c];
            }
        }
        let mut m = [0.0; 10];
        for (zp, &Place { d: (du, dv), .. }) in zs.iter().zip(&self.px) {
            let r: [f64; 4] = std::array::from_fn(|c| {
                let (gx, gy) = if det > 0.0 {
                    ((self.svv * bu[c] - self.suv * bv[c]) / det, (self.suu * bv[c] - self.suv * bu[c]) / det)
                } else {
                    (0.0, 0.0)
                };
                zp[c] - mean[c] - gx * du - gy * dv
            });
            let mut t = 0;
            for x in 0..4 {
                for y in x..4 {
                    m[t] += r[x] * r[y];
                    t += 1;
                }
            }
        }
        (eff, m)
    }
}

impl PixelMaps {
    /// The per-cell reconstruction of one colour band (the pixels under the filter
    /// covering `classes`, by tile row and column of the 4 × 4 superpixel,
    /// `ColourTiles::classes`) on a grid of `cell_px` cells, rounded up to a multiple
    /// of 4 as `Cells::fill_from_mosaic_band` rounds it (see the module);
    /// `black_level_dn` stands in for an unmeasured offset. A band with no pixels
    /// gives cells that are not `ok`.
    pub fn cell_analyzers_band(&self, classes: [[bool; 2]; 2], cell_px: usize, black_level_dn: f64) -> CellAnalyzers {
        let cell_px = cell_px.max(4).div_ceil(4) * 4;
        let (cols, rows) = (self.width_px / cell_px, self.height_px / cell_px);
        let mut places: [Vec<(usize, usize)>; 4] = Default::default();
        for dv in 0..cell_px {
            for du in 0..cell_px {
                if classes[(dv >> 1) & 1][(du >> 1) & 1] {
                    places[Layout::dofp_channel(&self.mosaic, du, dv).index()].push((du, dv));
                }
            }
        }
        if places.iter().any(|p| p.is_empty()) {
            let cells = vec![CellAnalyzer::default(); cols * rows];
            return CellAnalyzers { cell_px, cols, rows, cells };
        }
        let centre = 0.5 * (cell_px as f64 - 1.0);
        let planes: Vec<ChannelPlane> = places.iter().map(|p| ChannelPlane::new(p, centre)).collect();
        let cells = (0..cols * rows)
            .into_par_iter()
            .map(|idx| {
                let (u0, v0) = ((idx % cols) * cell_px, (idx / cols) * cell_px);
                let mut cell = CellAnalyzer::default();
                let mut a_rows = [DVec3::ZERO; 4];
                for (k, plane) in planes.iter().enumerate() {
                    let (eff, pattern) = plane.reduce(|du, dv| {
                        let (a, o) = self.pixel(u0 + du, v0 + dv, black_level_dn);
                        [a[0], a[1], a[2], o]
                    });
                    a_rows[k] = DVec3::new(eff[0], eff[1], eff[2]);
                    cell.offset_dn[k] = eff[3];
                    cell.pattern[k] = pattern;
                }
                cell.solve_rows(&a_rows);
                cell
            })
            .collect();
        CellAnalyzers { cell_px, cols, rows, cells }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::flawed;
    use crate::sensor::{Band, ColourTiles};

    #[test]
    fn every_tile_as_one_band_gives_the_monochrome_analyzers() {
        // The band's general plane (its own normal matrix) on the full grid is the
        // monochrome one: same weights, offsets, rows and fixed pattern.
        let m = flawed(32, 24);
        let mono = m.cell_analyzers(8, 64.0);
        let all = m.cell_analyzers_band([[true; 2]; 2], 8, 64.0);
        assert_eq!((all.cell_px, all.cols, all.rows), (mono.cell_px, mono.cols, mono.rows));
        for (a, b) in all.cells.iter().zip(&mono.cells) {
            assert!(a.ok && b.ok);
            let pairs = a
                .offset_dn
                .iter()
                .chain(a.rows.iter().flatten())
                .chain(a.pattern.iter().flatten())
                .zip(b.offset_dn.iter().chain(b.rows.iter().flatten()).chain(b.pattern.iter().flatten()));
            for (x, y) in pairs {
                assert!((x - y).abs() <= 1e-12 * y.abs().max(1.0), "{a:?}\nagainst\n{b:?}");
            }
        }
    }

    #[test]
    fn a_band_reads_only_its_own_pixels_maps_and_rounds_its_cells_to_superpixels() {
        let m = flawed(32, 24);
        let tiles = ColourTiles::imx250myr();
        let r = m.cell_analyzers_band(tiles.classes(Band::R), 6, 64.0);
        assert_eq!((r.cell_px, r.cols, r.rows), (8, 4, 3));
        assert!(r.cells.iter().all(|c| c.ok));
        // Other bands' maps changed beyond recognition: R's analyzers do not move.
        let mut other = m.clone();
        for (i, a) in other.analyzer_deg.as_mut().unwrap().iter_mut().enumerate() {
            if tiles.band_at(i % 32, i / 32) != Band::R {
                *a += 7.0;
            }
        }
        assert_eq!(other.cell_analyzers_band(tiles.classes(Band::R), 8, 64.0), r);
        // An empty band has no usable cell.
        assert!(m.cell_analyzers_band([[false; 2]; 2], 8, 64.0).cells.iter().all(|c| !c.ok));
    }
}
