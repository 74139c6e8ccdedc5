// sensor_nonlinearity — the pixel's DN is not quite proportional to its light.
// CPU twin and physics doc: crates/bpins-core/src/effects/sensor_nonlinearity.rs.
//   s' = s·(1 − β·s/FS), s the photo-signal above the offset, FS the ADC full scale (DN).

// β = p.x.
fn sensor_nonlinearity(p: vec4<f64>, signal_dn: f64, full_scale_dn: f64) -> f64 {
    let beta = p.x;
    // s·(1 − β·s/FS): 1 − 0·x = 1 exactly, so β = 0 is the identity.
    return signal_dn * (1.0lf - beta * (signal_dn / full_scale_dn));
}
