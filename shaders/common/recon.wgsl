// Stokes reconstruction from analyzer channels (seed eq. 4, 13).
// CPU twin: crates/bpins-core/src/recon.rs (`Reconstructor::stokes`, `superpixel`).
//   x_k = (DN_k − b − offset_k)/(1 + gain_k);  (I, Q, U) = R·x   (R = A⁻¹ or (AᵀA)⁻¹Aᵀ)

// Keep in sync with `ReconParams` in crates/bpins-gpu/src/params.rs.
struct ReconParams {
    row_i: Wide4,      // rows of R by channel index (0 for unused channels)
    row_q: Wide4,
    row_u: Wide4,
    inv_gain: Wide4,   // 1/(1 + gain_k)
    offset_dn: Wide4,  // black level + offset_k
    valid: Wide4,      // full_scale_dn of the validity mask (0: no mask), 0, 0, 0
    mosaic: vec4<u32>, // channel index at tile position 2·dv + du
}

fn reconstruct(r: ReconParams, dn: vec4<f64>) -> Stokes {
    let x = (dn - wide(r.offset_dn)) * wide(r.inv_gain);
    let ri = wide(r.row_i);
    let rq = wide(r.row_q);
    let ru = wide(r.row_u);
    let i = ri.x * x.x + ri.y * x.y + ri.z * x.z + ri.w * x.w;
    let q = rq.x * x.x + rq.y * x.y + rq.z * x.z + rq.w * x.w;
    let u = ru.x * x.x + ru.y * x.y + ru.z * x.z + ru.w * x.w;
    return Stokes(i, q, u, 0.0lf);
}

// Whether a measured DN is usable: neither clipped at zero nor saturated.
fn dn_is_valid(dn: f64, full_scale_dn: f64) -> bool {
    return dn > 0.0lf && dn < full_scale_dn;
}
