//! Cells of one colour band of a colour-polarization mosaic: each cell reduced from the
//! band's own pixels only (CONVENTIONS.md: a band's Stokes vector comes from its own
//! pixels; bands are never mixed before reconstruction).
//!
//! ```text
//! pixel (u, v): analyzer mosaic[v mod 2][u mod 2], filter colour_tiles[(v div 2) mod 2][(u div 2) mod 2]
//! x_k(centre) = x̄_k + g_k · (c − p̄_k)          c: the cell centre, p̄_k: mean place of channel k's band pixels
//! [Σ du²  Σ du dv] g_k = [Σ du·DN]               du = u − ū_k, dv = v − v̄_k over channel k's band pixels
//! [Σ du dv Σ dv²]        [Σ dv·DN]
//! ```
//!
//! As for a monochrome mosaic (`cells.rs`), each channel's mean is moved to the cell
//! centre along its own least-squares gradient, and the noise is the scatter about that
//! plane. A band's pixels are not on the monochrome grid (R and B: one tile of four,
//! their channels' mean place a pixel off the grid's; G: two tiles on a diagonal, whose
//! offsets in u and v are correlated), so the plane's normal matrix is the band's own,
//! computed once per frame from the cell's pixel places. Cells are whole superpixels:
//! their size a multiple of 4 px, so each holds the same places of every band.
//!
//! A per-pixel calibration is applied as for a monochrome mosaic, through per-cell
//! analyzers built from the band's own pixels' maps on the band's grid
//! (`PixelMaps::cell_analyzers_band`: the weights of this plane fit).
//!
//! Frame: image pixels (CONVENTIONS.md); units DN.

use super::*;

/// Where channel `k`'s pixels of one band lie in a cell: their count, mean place and
/// the normal matrix of the plane fit about it (positions local to the cell's top-left
/// pixel, px).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct BandGeom {
    n: [f64; 4],
    ubar: [f64; 4],
    vbar: [f64; 4],
    suu: [f64; 4],
    svv: [f64; 4],
    suv: [f64; 4],
    /// The cell centre, (cell_px − 1)/2.
    centre: f64,
}

impl BandGeom {
    /// The geometry of the band covering `classes` (by tile row and column of the
    /// superpixel) in a cell of `cell_px` (a multiple of 4).
    pub(super) fn new(mosaic: &[[Channel; 2]; 2], classes: [[bool; 2]; 2], cell_px: usize) -> BandGeom {
        let mut g = BandGeom { centre: 0.5 * (cell_px as f64 - 1.0), ..BandGeom::default() };
        let (mut su, mut sv) = ([0.0; 4], [0.0; 4]);
        let places = || {
            (0..cell_px)
                .flat_map(move |v| (0..cell_px).map(move |u| (u, v)))
                .filter(|&(u, v)| classes[(v >> 1) & 1][(u >> 1) & 1])
        };
        for (u, v) in places() {
            let k = Layout::dofp_channel(mosaic, u, v).index();
            g.n[k] += 1.0;
            su[k] += u as f64;
            sv[k] += v as f64;
        }
        for k in 0..4 {
            if g.n[k] > 0.0 {
                g.ubar[k] = su[k] / g.n[k];
                g.vbar[k] = sv[k] / g.n[k];
            }
        }
        for (u, v) in places() {
            let k = Layout::dofp_channel(mosaic, u, v).index();
            let (du, dv) = (u as f64 - g.ubar[k], v as f64 - g.vbar[k]);
            g.suu[k] += du * du;
            g.svv[k] += dv * dv;
            g.suv[k] += du * dv;
        }
        g
    }
}

impl Acc {
    /// [`Acc::finish`] for a colour band's pixels: each channel's value at the cell
    /// centre along the band's own plane (`BandGeom`), where every band pixel of the
    /// cell was valid; the plain means otherwise.
    pub(super) fn finish_band(&self, g: &BandGeom) -> Option<([f64; 4], [f64; 4])> {
        let total: f64 = self.n.iter().sum();
        if total == 0.0 || self.bad > MAX_INVALID_FRACTION * (total + self.bad) {
            return None;
        }
        let (mut mean, mut var) = ([0.0; 4], [0.0; 4]);
        for k in 0..4 {
            let n = self.n[k];
            if n == 0.0 {
                continue;
            }
            let m = self.s[k] / n;
            let mut ss = self.s2[k] - self.s[k] * m;
            let mut dof = n - 1.0;
            mean[k] = m;
            let det = g.suu[k] * g.svv[k] - g.suv[k] * g.suv[k];
            if self.bad == 0.0 && det > 0.0 {
                // Σ du·DN and Σ dv·DN about the band's own mean place.
                let bu = self.su[k] - g.ubar[k] * self.s[k];
                let bv = self.sv[k] - g.vbar[k] * self.s[k];
                let gx = (g.svv[k] * bu - g.suv[k] * bv) / det;
                let gy = (g.suu[k] * bv - g.suv[k] * bu) / det;
                mean[k] = m + gx * (g.centre - g.ubar[k]) + gy * (g.centre - g.vbar[k]);
                ss -= gx * bu + gy * bv;
                dof -= 2.0;
            }
            var[k] = if dof > 0.0 { (ss / dof).max(0.0) / n } else { f64::NAN };
        }
        self.borrow_scatter(&mut var);
        Some((mean, var))
    }
}

impl Cells {
    /// The cells of one colour band of a colour-polarization mosaic: only the pixels
    /// under the filter covering `classes` (by tile row and column of the 4 × 4
    /// superpixel, `ColourTiles::classes`) are read; `cell_px` is rounded up to a
    /// multiple of 4. Otherwise as [`Cells::fill_from_mosaic`].
    #[allow(clippy::too_many_arguments)]
    pub fn fill_from_mosaic_band<T: RawDn>(
        &mut self,
        img: &RawImage<T>,
        mosaic: &[[Channel; 2]; 2],
        classes: [[bool; 2]; 2],
        rec: &Reconstructor,
        full_scale_dn: f64,
        cell_px: usize,
        scratch: &mut CellScratch,
    ) {
        self.fill_band(img, mosaic, classes, CellRecon::Frame(rec), full_scale_dn, cell_px, scratch)
    }

    /// As [`Cells::fill_from_mosaic_band`], each cell reconstructed through the
    /// analyzers of the band's own pixels (a per-pixel calibration,
    /// `PixelMaps::cell_analyzers_band` for the same `classes`); the grid is `cal`'s.
    pub fn fill_from_mosaic_band_calibrated<T: RawDn>(
        &mut self,
        img: &RawImage<T>,
        mosaic: &[[Channel; 2]; 2],
        classes: [[bool; 2]; 2],
        cal: &CellAnalyzers,
        full_scale_dn: f64,
        scratch: &mut CellScratch,
    ) {
        self.fill_band(img, mosaic, classes, CellRecon::PerCell(cal), full_scale_dn, cal.cell_px, scratch)
    }

    #[allow(clippy::too_many_arguments)]
    fn fill_band<T: RawDn>(
        &mut self,
        img: &RawImage<T>,
        mosaic: &[[Channel; 2]; 2],
        classes: [[bool; 2]; 2],
        rec: CellRecon,
        full_scale_dn: f64,
        cell_px: usize,
        scratch: &mut CellScratch,
    ) {
        let cell_px = cell_px.max(4).div_ceil(4) * 4;
        let chan = [0, 1].map(|dv| [0, 1].map(|du| Layout::dofp_channel(mosaic, du, dv).index()));
        let geom = BandGeom::new(mosaic, classes, cell_px);
        let finish = Finish::Band(&geom);
        self.build(img.width_px, img.height_px, cell_px, rec, finish, scratch, |cj, acc| {
            for dv in 0..cell_px {
                let v = cj * cell_px + dv;
                let tiles = classes[(v >> 1) & 1];
                if !(tiles[0] || tiles[1]) {
                    continue;
                }
                let row = img.row(v);
                let ch = chan[v & 1];
                for (ci, a) in acc.iter_mut().enumerate() {
                    let u0 = ci * cell_px;
                    for du in (0..cell_px).step_by(2) {
                        if tiles[(du >> 1) & 1] {
                            a.add(ch[0], du as f64, dv as f64, row[u0 + du].dn(), full_scale_dn);
                            a.add(ch[1], (du + 1) as f64, dv as f64, row[u0 + du + 1].dn(), full_scale_dn);
                        }
                    }
                }
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::Model;
    use crate::pixel_analyzers::PixelMaps;
    use crate::sensor::{Band, ColourTiles, DEFAULT_MOSAIC};

    fn rec() -> Reconstructor {
        Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap()
    }

    /// A field linear across the frame in I, Q and U (DN above black 64), each pixel
    /// through its own analyzer at its own place, unrounded.
    fn planar(w: usize, h: usize) -> Vec<f32> {
        (0..h)
            .flat_map(|v| {
                (0..w).map(move |u| {
                    let (x, y) = (u as f64, v as f64);
                    let (i, q, s) = (2000.0 + 9.0 * x - 6.0 * y, 300.0 + 2.0 * x + 1.5 * y, -400.0 + 3.0 * y - x);
                    let th = 2.0 * Layout::dofp_channel(&DEFAULT_MOSAIC, u, v).angle_deg().to_radians();
                    (64.0 + 0.5 * (i + q * th.cos() + s * th.sin())) as f32
                })
            })
            .collect()
    }

    fn band_cells(dn: &[f32], w: usize, h: usize, classes: [[bool; 2]; 2], cell_px: usize) -> Cells {
        let mut cells = Cells::default();
        let img = RawImage::packed(dn, w, h);
        cells.fill_from_mosaic_band(&img, &DEFAULT_MOSAIC, classes, &rec(), 1e9, cell_px, &mut CellScratch::default());
        cells
    }

    #[test]
    fn every_tile_as_one_band_reads_as_the_monochrome_cells() {
        let (w, h) = (48, 32);
        let dn = planar(w, h);
        let mono = Cells::from_mosaic(&RawImage::packed(&dn, w, h), &DEFAULT_MOSAIC, &rec(), 1e9, 8);
        let all = band_cells(&dn, w, h, [[true; 2]; 2], 8);
        assert_eq!(all.cells.len(), mono.cells.len());
        for (a, m) in all.cells.iter().zip(&mono.cells) {
            assert_eq!((a.x_px, a.y_px, a.col, a.row), (m.x_px, m.y_px, m.col, m.row));
            for (x, y) in [(a.stokes.i, m.stokes.i), (a.stokes.q, m.stokes.q), (a.stokes.u, m.stokes.u)] {
                assert!((x - y).abs() < 1e-9 * y.abs().max(1.0), "{a:?} against {m:?}");
            }
        }
    }

    #[test]
    fn each_band_of_a_planar_field_gives_the_field_at_the_cell_centre() {
        // R and B hold one tile of four, a pixel off the monochrome grid's place; G two
        // tiles on a diagonal: each band's own plane puts its value at the centre.
        let (w, h) = (48, 32);
        let dn = planar(w, h);
        let mono = Cells::from_mosaic(&RawImage::packed(&dn, w, h), &DEFAULT_MOSAIC, &rec(), 1e9, 8);
        let tiles = ColourTiles::imx250myr();
        for b in Band::ALL {
            let cells = band_cells(&dn, w, h, tiles.classes(b), 8);
            assert_eq!(cells.cells.len(), mono.cells.len(), "{b:?}");
            for (c, m) in cells.cells.iter().zip(&mono.cells) {
                let (x, y) = (c.x_px, c.y_px);
                let want = [2000.0 + 9.0 * x - 6.0 * y, 300.0 + 2.0 * x + 1.5 * y, -400.0 + 3.0 * y - x];
                for (got, want) in [c.stokes.i, c.stokes.q, c.stokes.u].into_iter().zip(want) {
                    assert!((got - want).abs() < 2e-3, "{b:?} cell ({}, {}): {got} against {want}", c.col, c.row);
                }
                assert!((c.stokes.q - m.stokes.q).abs() < 2e-3, "{b:?}");
                // A plane leaves no scatter (f32 rounding only).
                assert!(c.var_q_dn2 < 1e-6 && c.var_u_dn2 < 1e-6, "{b:?}: {c:?}");
            }
        }
    }

    fn band_cells_calibrated(dn: &[f32], maps: &PixelMaps, classes: [[bool; 2]; 2], cell_px: usize) -> Cells {
        let (w, h) = (maps.width_px, maps.height_px);
        let cal = maps.cell_analyzers_band(classes, cell_px, 64.0);
        let mut cells = Cells::default();
        let img = RawImage::packed(dn, w, h);
        cells.fill_from_mosaic_band_calibrated(&img, &DEFAULT_MOSAIC, classes, &cal, 1e9, &mut CellScratch::default());
        cells
    }

    #[test]
    fn nominal_maps_give_each_band_its_uncalibrated_cells() {
        // The planar field plus seeded noise (so each cell has a scatter to keep).
        let (w, h) = (48, 32);
        let mut dn = planar(w, h);
        for (i, x) in dn.iter_mut().enumerate() {
            // SplitMix64's finaliser of the pixel index: seeded, well mixed.
            let mut z = (i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            let r = (z ^ (z >> 31)) >> 40;
            *x += (r as f32 / (1u64 << 24) as f32 - 0.5) * 40.0;
        }
        let maps = PixelMaps::nominal(w, h, DEFAULT_MOSAIC);
        let tiles = ColourTiles::imx250myr();
        for b in Band::ALL {
            let plain = band_cells(&dn, w, h, tiles.classes(b), 8);
            let cal = band_cells_calibrated(&dn, &maps, tiles.classes(b), 8);
            assert_eq!(plain.cells.len(), cal.cells.len(), "{b:?}");
            assert_eq!((plain.cell_px, plain.cols, plain.rows), (cal.cell_px, cal.cols, cal.rows));
            for (p, c) in plain.cells.iter().zip(&cal.cells) {
                let pairs = [
                    (p.stokes.i, c.stokes.i),
                    (p.stokes.q, c.stokes.q),
                    (p.stokes.u, c.stokes.u),
                    (p.var_q_dn2, c.var_q_dn2),
                    (p.var_u_dn2, c.var_u_dn2),
                ];
                for (x, y) in pairs {
                    assert!((x - y).abs() <= 1e-12 * x.abs().max(1.0), "{b:?}: {p:?} against {c:?}");
                }
                assert!(p.var_q_dn2 > 1.0, "the noise left a scatter: {p:?}");
            }
        }
    }

    #[test]
    fn a_turn_of_one_bands_analyzers_is_undone_by_its_maps() {
        // Every R pixel's analyzer turned (by channel: +2°, −1.5°, +1°, −2.5°), the
        // other bands nominal; the planar field through each pixel's own analyzer.
        let (w, h) = (48, 32);
        let tiles = ColourTiles::imx250myr();
        let turn_deg = [2.0, -1.5, 1.0, -2.5];
        let mut maps = PixelMaps::nominal(w, h, DEFAULT_MOSAIC);
        let analyzer_deg = (0..w * h)
            .map(|i| {
                let (u, v) = (i % w, i / w);
                let c = Layout::dofp_channel(&DEFAULT_MOSAIC, u, v);
                let turn = if tiles.band_at(u, v) == Band::R { turn_deg[c.index()] } else { 0.0 };
                (c.angle_deg() + turn) as f32
            })
            .collect();
        maps.analyzer_deg = Some(analyzer_deg);
        let field = |x: f64, y: f64| [2000.0 + 9.0 * x - 6.0 * y, 300.0 + 2.0 * x + 1.5 * y, -400.0 + 3.0 * y - x];
        let dn: Vec<f32> = (0..w * h)
            .map(|i| {
                let (a, o) = maps.pixel(i % w, i / w, 64.0);
                let s = field((i % w) as f64, (i / w) as f64);
                (o + a[0] * s[0] + a[1] * s[1] + a[2] * s[2]) as f32
            })
            .collect();
        let worst = |cells: &Cells| {
            let err = |c: &Cell| {
                let want = field(c.x_px, c.y_px);
                (c.stokes.q - want[1]).abs().max((c.stokes.u - want[2]).abs())
            };
            cells.cells.iter().map(err).fold(0.0, f64::max)
        };
        let (plain, cal) = (
            band_cells(&dn, w, h, tiles.classes(Band::R), 8),
            band_cells_calibrated(&dn, &maps, tiles.classes(Band::R), 8),
        );
        assert_eq!(cal.cells.len(), 24);
        // Turned analyzers read as nominal move Q and U by tens of DN; their maps undo it
        // (a planar field, constant turns per channel: exact up to f32 rounding).
        assert!(worst(&plain) > 10.0 && worst(&cal) < 2e-3, "R: {} DN → {} DN", worst(&plain), worst(&cal));
        // The other bands' pixels were not turned: through their maps they read as before.
        for b in [Band::G, Band::B] {
            let (p, c) =
                (band_cells(&dn, w, h, tiles.classes(b), 8), band_cells_calibrated(&dn, &maps, tiles.classes(b), 8));
            assert!(worst(&p) < 2e-3 && worst(&c) < 2e-3, "{b:?}: {} and {} DN", worst(&p), worst(&c));
        }
    }

    #[test]
    fn a_band_reads_none_of_the_other_bands_pixels() {
        let (w, h) = (48, 32);
        let mut dn = planar(w, h);
        let tiles = ColourTiles::imx250myr();
        let before = band_cells(&dn, w, h, tiles.classes(Band::R), 8);
        // Blow out every pixel that is not under the R filter: R's cells do not change.
        for v in 0..h {
            for u in 0..w {
                if tiles.band_at(u, v) != Band::R {
                    dn[v * w + u] = 1e12f32;
                }
            }
        }
        assert_eq!(band_cells(&dn, w, h, tiles.classes(Band::R), 8), before);
        // A cell size that is not a whole superpixel is rounded up to one.
        assert_eq!(band_cells(&dn, w, h, tiles.classes(Band::R), 6).cell_px, 8);
    }
}
