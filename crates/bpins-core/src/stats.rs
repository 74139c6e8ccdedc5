//! Order statistics shared across the crate: one definition of each.
//!
//! - [`quantile_sorted`]: the `q` quantile of sorted values, linear between order
//!   statistics (Hyndman & Fan 1996, definition 7; numpy's default); the sweep's
//!   percentiles and every median below.
//! - [`median`]: [`quantile_sorted`] at ½, so the mean of the two middle values for an
//!   even count.
//!
//! The field estimator keeps its own nearest-rank quantile (`heading::field::stats`):
//! it runs on every frame's cells with `select_nth_unstable` (no sort), and its
//! published numbers are that definition's.

/// The `q` quantile (0 ≤ q ≤ 1) of `x`, which must be sorted ascending and non-empty,
/// linear between order statistics.
pub fn quantile_sorted(x: &[f64], q: f64) -> f64 {
    let pos = q * (x.len() - 1) as f64;
    let (lo, frac) = (pos.floor() as usize, pos - pos.floor());
    if lo + 1 < x.len() {
        x[lo] + frac * (x[lo + 1] - x[lo])
    } else {
        x[lo]
    }
}

/// The median of `v` (any order; NaN sorts last), the mean of the two middle values
/// for an even count; `None` when empty.
pub(crate) fn median(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    (!v.is_empty()).then(|| quantile_sorted(&v, 0.5))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_an_even_count_is_the_mean_of_its_middle_values() {
        assert_eq!(median(vec![4.0, 1.0, 3.0]), Some(3.0));
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median(vec![]), None);
    }

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let x = [0.0, 10.0, 20.0, 30.0, 40.0];
        assert_eq!(quantile_sorted(&x, 0.0), 0.0);
        assert_eq!(quantile_sorted(&x, 1.0), 40.0);
        assert!((quantile_sorted(&x, 0.95) - 38.0).abs() < 1e-12);
        assert!((quantile_sorted(&x, 0.3) - 12.0).abs() < 1e-12);
    }
}
