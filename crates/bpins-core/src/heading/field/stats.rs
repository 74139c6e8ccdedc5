//! Cell-grid masks and order statistics of the robust loop (`robust.rs`).

/// Tukey's biweight constant (95 % efficiency at the normal).
pub(super) const TUKEY_C: f64 = 4.685;

/// Into `out`: the cells of `mask` with at least two others of it among their eight
/// neighbours (clusters, not lone cells).
pub(super) fn clustered(mask: &[bool], cols: usize, out: &mut Vec<bool>) {
    let rows = mask.len() / cols.max(1);
    out.clear();
    out.resize(mask.len(), false);
    for r in 0..rows {
        for c in 0..cols {
            if !mask[r * cols + c] {
                continue;
            }
            let mut near = 0;
            for rr in r.saturating_sub(1)..=(r + 1).min(rows - 1) {
                for cc in c.saturating_sub(1)..=(c + 1).min(cols - 1) {
                    near += mask[rr * cols + cc] as usize;
                }
            }
            out[r * cols + c] = near >= 3; // itself and two others
        }
    }
}

/// Into `out`: `mask` grown by `r` cells (a square window), as two separable passes
/// (`h`: the first pass).
pub(super) fn dilate(mask: &[bool], cols: usize, rows: usize, r: usize, h: &mut Vec<bool>, out: &mut Vec<bool>) {
    h.clear();
    h.resize(mask.len(), false);
    for row in 0..rows {
        for c in 0..cols {
            h[row * cols + c] = (c.saturating_sub(r)..=(c + r).min(cols - 1)).any(|cc| mask[row * cols + cc]);
        }
    }
    out.clear();
    out.resize(mask.len(), false);
    for row in 0..rows {
        for c in 0..cols {
            out[row * cols + c] = (row.saturating_sub(r)..=(row + r).min(rows - 1)).any(|rr| h[rr * cols + c]);
        }
    }
}

/// Into `out`: the cells marked by `marked` (grid index, mark) on a `cols`-wide grid
/// of `grid_len` cells, kept where they cluster ([`clustered`]) and grown by `r`
/// ([`dilate`]); `mask`, `kept` and `tmp` are buffers.
#[allow(clippy::too_many_arguments)]
pub(super) fn grown_clusters(
    marked: impl Iterator<Item = (usize, bool)>,
    grid_len: usize,
    cols: usize,
    r: usize,
    mask: &mut Vec<bool>,
    kept: &mut Vec<bool>,
    tmp: &mut Vec<bool>,
    out: &mut Vec<bool>,
) {
    mask.clear();
    mask.resize(grid_len, false);
    for (g, m) in marked {
        mask[g] |= m;
    }
    clustered(mask, cols, kept);
    dilate(kept, cols, grid_len / cols.max(1), r, tmp, out);
}

/// The delete-one jackknife's standard deviation of an estimate from its `k`
/// leave-one-out values `dev` (any common offset): √((k − 1)/k · Σ (dᵢ − d̄)²)
/// (Efron & Stein 1981). `dev` holds at least one value.
pub(super) fn jackknife_sd(dev: &[f64]) -> f64 {
    let k = dev.len() as f64;
    let mean = dev.iter().sum::<f64>() / k;
    ((k - 1.0) / k * dev.iter().map(|d| (d - mean).powi(2)).sum::<f64>()).sqrt()
}

pub(super) fn tukey(r: f64) -> f64 {
    let u = r / TUKEY_C;
    if u.abs() < 1.0 {
        (1.0 - u * u).powi(2)
    } else {
        0.0
    }
}

/// Median of `v` (reordered); NaN when empty.
pub(super) fn median(v: &mut [f64]) -> f64 {
    quantile(v, 0.5)
}

/// The `q` quantile of `v` (reordered; nearest rank); NaN when empty.
pub(super) fn quantile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let k = ((v.len() as f64 * q) as usize).min(v.len() - 1);
    *v.select_nth_unstable_by(k, |a, b| a.total_cmp(b)).1
}
