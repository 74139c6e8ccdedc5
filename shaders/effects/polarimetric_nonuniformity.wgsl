// polarimetric_nonuniformity — each micro-polarizer of the die is a little different.
// CPU twin and physics doc: crates/bpins-core/src/effects/polarimetric_nonuniformity.rs.
//   Δθ = σ_θ·n₁ + g_x·x + g_y·y, ε = max(ε + σ_ε·n₂, 0), G = G·(1 + σ_G·n₃),
//   n_i = normal(DIE_KEY, u | v << 16, channel, i): the same seeded hash as the CPU.

// The simulated die's hash key (CPU: polarimetric_nonuniformity::DIE_KEY).
const DIE_KEY: vec4<u32> = vec4<u32>(0x5eedd1e5u, 0x0b1a5ed0u, 0x9e3779b9u, 0x7f4a7c15u);

// The pixel site's analyzer a on the simulated die; p = ((σ_θ rad, g_x rad/px, g_y rad/px, σ_ε), (σ_G, 0, 0, 0)).
fn polarimetric_nonuniformity(p: array<vec4<f64>, 2>, site: PixelSite, g: RayGeometry, a: PixelAnalyzer) -> PixelAnalyzer {
    // Seeded standard normals of this pixel and channel (the same hash on the CPU).
    let id = site.u | (site.v << 16u);
    let n1 = normal(DIE_KEY, id, site.ch, 0u);
    let n2 = normal(DIE_KEY, id, site.ch, 1u);
    let n3 = normal(DIE_KEY, id, site.ch, 2u);
    // Angle change: white spread plus the die's gradient from the principal point, radians.
    let dtheta = p[0].x * n1 + p[0].y * site.x_px + p[0].z * site.y_px;
    // Turn the analyzer by Δθ (its doubled angle by 2Δθ): exact at Δθ = 0; reduced to
    // [−π, π] for sin_cos_f64 (the CPU's libm reduces internally).
    let d = 2.0lf * dtheta;
    let sc = sin_cos_f64(d - TAU_F64 * round(d / TAU_F64));
    let s2 = sc.x;
    let c2 = sc.y;
    let an = a.analyzer;
    let turned = Analyzer(an.cos2t * c2 - an.sin2t * s2, an.sin2t * c2 + an.cos2t * s2, max(an.eps + p[0].w * n2, 0.0lf));
    return PixelAnalyzer(turned, a.gain * (1.0lf + p[1].x * n3));
}
