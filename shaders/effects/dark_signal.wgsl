// dark_signal — a warm sensor adds thermal electrons, and their shot noise.
// CPU twin and physics doc: crates/bpins-core/src/effects/dark_signal.rs.
//   s' = s + μ_dark (DN, μ_dark = K·μ_I·t_exp), before the offsets; its shot noise
//   follows in sensor_dn's variance K·s'.

// The photo-signal with the dark signal μ_dark = p.x added; exactly signal_dn at 0.
fn dark_signal(p: vec4<f64>, signal_dn: f64, full_scale_dn: f64) -> f64 {
    // s + μ_dark where μ_dark ≠ 0 (a select, as the CPU's).
    return select(signal_dn, signal_dn + p.x, p.x != 0.0lf);
}
