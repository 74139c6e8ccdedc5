// analyzer_incidence — the analyzers see the chief ray obliquely toward the edge.
// CPU twin and physics doc: crates/bpins-core/src/effects/analyzer_incidence.rs.
//   tan χ = c·r; the axis projected onto the ray's transverse plane (tan ψ' = tan ψ / cos χ,
//   ψ from the plane of incidence at the pixel's radial angle β); ε' = ε + e2·sin²χ.

// The analyzer a seen along the pixel's oblique chief ray; p = ((c², e2, 0, 0), (0, 0, 0, 0)).
fn analyzer_incidence(p: array<vec4<f64>, 2>, site: PixelSite, g: RayGeometry, a: PixelAnalyzer) -> PixelAnalyzer {
    // Chief-ray angle χ: tan²χ = c²·r², sin²χ and cos χ from it (exactly 0 and 1 at c = 0).
    let t2 = p[0].x * g.r2;
    let sin2_chi = t2 / (1.0lf + t2);
    let cos_chi = 1.0lf / sqrt(1.0lf + t2);
    // The analyzer's doubled angle from the plane of incidence (image angle β): C, S.
    let c2b = g.basis.cos2b;
    let s2b = g.basis.sin2b;
    let an = a.analyzer;
    let c = an.cos2t * c2b + an.sin2t * s2b;
    let s = an.sin2t * c2b - an.cos2t * s2b;
    // Projected axis (cos ψ cos χ, sin ψ): its doubled angle changes by (δC, δS), with
    // D = cos²ψ·sin²χ the foreshortening; both exactly 0 at χ = 0.
    let d = 0.5lf * (1.0lf + c) * sin2_chi;
    let dc = -d * (1.0lf - c) / (1.0lf - d);
    let ds = s * (cos_chi / (1.0lf - d) - 1.0lf);
    // Back to the image frame, added to the analyzer's own doubled angle.
    let turned = Analyzer(an.cos2t + (dc * c2b - ds * s2b), an.sin2t + (dc * s2b + ds * c2b), an.eps + p[0].y * sin2_chi);
    return PixelAnalyzer(turned, a.gain);
}
