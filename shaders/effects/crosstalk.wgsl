// crosstalk — DoFP pixels share signal with their edge neighbours.
// CPU twin and physics doc: crates/bpins-core/src/effects/crosstalk.rs.
//   S' = (1 − 4c)·S + c·(S_up + S_down + S_left + S_right), photo-signal in DN.

// c = p.x.
fn crosstalk(p: vec4<f64>, own: f64, up: f64, down: f64, left: f64, right: f64) -> f64 {
    let c = p.x;
    return (1.0lf - 4.0lf * c) * own + c * (up + down + left + right);
}
