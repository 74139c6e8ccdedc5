// The per-pixel measurement chain: sky → camera ray → lens → analyzer → sensor.
// CPU twin: crates/bpins-core/src/chain/mod.rs — same functions, names, argument
// order and step comments. The host builds FrameParams from the CPU's ChainFrame
// (crates/bpins-gpu/src/params.rs; keep the two structs in sync, a test checks the
// layout). Effects folded on the host (principal_point, mount_tilt, array_rotation,
// channel_response) arrive inside these fields; the hooks of the registry (sky, per-pixel,
// analyzer, sensor and mosaic effects) arrive as one vector each in `sky`, `ray`,
// `analyzer`, `sensor` and `mosaic_fx` and run in `sky_effects`, `ray_effects`,
// `analyzer_effects`, `sensor_effects` and `mosaic_effects`, which are generated from
// the registry (crates/bpins-gpu/src/ray_dispatch.rs) with their counts and their
// pipeline masks (`SKY_ON`, …: the effects on in some frame of the dispatch; the
// others are left out at compile time).
//
// pixel (u, v) ─ true intrinsics ─▶ ray d, meridional basis (p, s), 2β      camera frame
//   sky_stokes → sky_effects (sky_neutral_points → sky_dolp_shape → …) → ray_effects
//   (lens_diattenuation → lens_retardance → lens_depolarization → vignetting → …,
//   registry order) → meridional_to_image → analyzer_effects (the pixel's own analyzer:
//   polarimetric_nonuniformity, …) → analyzer_intensity → × g(1 + gain_k)
//   → mosaic_effects (crosstalk, …) → sensor_dn (PRNU, sensor_effects (non-linearity, …),
//   offsets, DSNU, read + shot noise, rounding)

// Keep in sync with `FrameParams` in crates/bpins-gpu/src/params.rs.
struct FrameParams {
    camera: Wide4,     // f_px, cx_px, cy_px (true camera), projection id
    distortion: Wide4, // radial distortion k1, k2 of the true camera, 0, 0
    sun: Wide4,        // unit sun vector in the true camera frame (x, y, z), d_max
    cos2t: Wide4,      // true analyzers by channel (0°, 45°, 90°, 135°): cos 2θ_k
    sin2t: Wide4,      //   sin 2θ_k
    eps: Wide4,        //   ε_k = 1/ER
    gain_dn: Wide4,    // DN per unit radiance g·(1 + gain_k)
    offset_dn: Wide4,  // black level + offset_k, DN
    noise: Wide4,      // read_noise_dn, system_gain_dn_per_e, dsnu_dn, prnu
    adc: Wide4,        // quantize (0/1), full_scale_dn, 0, 0
    mosaic: Wide4,     // mosaic effects on (0/1; DoFP), analyzer effects on (0/1), 0, 0
    sky: array<array<Wide4, 5>, SKY_COUNT>, // sky effects' vectors, registry order
    ray: array<Wide4, RAY_COUNT>, // per-pixel effects' vectors, registry order
    analyzer: array<array<Wide4, 2>, ANALYZER_COUNT>, // analyzer effects' vectors, registry order
    sensor: array<Wide4, SENSOR_COUNT>, // sensor effects' vectors, registry order
    mosaic_fx: array<Wide4, MOSAIC_COUNT>, // mosaic effects' vectors, registry order
    key: vec4<u32>,    // temporal noise key of this frame
    fixed_key: vec4<u32>, // fixed-pattern key of this trial
}

struct ChainFrame {
    intr: Intrinsics,
    sun_cam: vec3<f64>,
    dmax: f64,
    sky: array<array<vec4<f64>, 5>, SKY_COUNT>,
    ray: array<vec4<f64>, RAY_COUNT>,
    analyzer: array<array<vec4<f64>, 2>, ANALYZER_COUNT>,
    analyzer_on: bool,
    sensor: array<vec4<f64>, SENSOR_COUNT>,
    mosaic_fx: array<vec4<f64>, MOSAIC_COUNT>,
    mosaic_on: bool,
    cos2t: vec4<f64>,
    sin2t: vec4<f64>,
    eps: vec4<f64>,
    gain_dn: vec4<f64>,
    offset_dn: vec4<f64>,
    noise: vec4<f64>,
    quantize: bool,
    full_scale_dn: f64,
    key: vec4<u32>,
    fixed_key: vec4<u32>,
}

fn chain_frame(p: FrameParams) -> ChainFrame {
    let sun = wide(p.sun);
    let adc = wide(p.adc);
    var wide_ray = p.ray;
    var ray: array<vec4<f64>, RAY_COUNT>;
    for (var k = 0u; k < RAY_COUNT; k++) {
        ray[k] = wide(wide_ray[k]);
    }
    var wide_analyzer = p.analyzer;
    var analyzer: array<array<vec4<f64>, 2>, ANALYZER_COUNT>;
    for (var k = 0u; k < ANALYZER_COUNT; k++) {
        analyzer[k] = array<vec4<f64>, 2>(wide(wide_analyzer[k][0]), wide(wide_analyzer[k][1]));
    }
    var wide_sky = p.sky;
    var sky: array<array<vec4<f64>, 5>, SKY_COUNT>;
    for (var k = 0u; k < SKY_COUNT; k++) {
        for (var j = 0u; j < 5u; j++) {
            sky[k][j] = wide(wide_sky[k][j]);
        }
    }
    var wide_sensor = p.sensor;
    var sensor: array<vec4<f64>, SENSOR_COUNT>;
    for (var k = 0u; k < SENSOR_COUNT; k++) {
        sensor[k] = wide(wide_sensor[k]);
    }
    var wide_mosaic = p.mosaic_fx;
    var mosaic_fx: array<vec4<f64>, MOSAIC_COUNT>;
    for (var k = 0u; k < MOSAIC_COUNT; k++) {
        mosaic_fx[k] = wide(wide_mosaic[k]);
    }
    let flags = wide(p.mosaic);
    return ChainFrame(intrinsics_from(p.camera, p.distortion), sun.xyz, sun.w, sky, ray, analyzer, flags.y != 0.0lf,
        sensor, mosaic_fx, flags.x != 0.0lf, wide(p.cos2t), wide(p.sin2t),
        wide(p.eps), wide(p.gain_dn), wide(p.offset_dn), wide(p.noise), adc.x != 0.0lf, adc.y, p.key,
        p.fixed_key);
}

// Stokes vector (image frame) reaching the analyzer of pixel (u, v), noise-free.
fn pixel_stokes(f: ChainFrame, u: f64, v: f64) -> Stokes {
    // Pixel → ray through the true camera.
    return ray_stokes(f, geometry(f.intr, u, v));
}

// Stokes vector (image frame) arriving along the true ray g, noise-free.
fn ray_stokes(f: ChainFrame, g: RayGeometry) -> Stokes {
    // Skylight along the ray, in its meridional frame (Rayleigh).
    var s = sky_stokes(f.sun_cam, f.dmax, g.d, g.basis);
    // Sky effects (the quartic sky, the DoLP shape, …), in registry order.
    s = sky_effects(f.sky, f.sun_cam, f.dmax, g, s);
    // Per-pixel effects (lens Mueller matrices, falloff), meridional frame, in registry order.
    s = ray_effects(f.ray, g, s);
    // Rotate from the meridional frame to the image x frame.
    return meridional_to_image(s, g.basis.cos2b, g.basis.sin2b);
}

// The AoP (degrees, (−90, 90], image frame), DoLP and AoE (AoP − β, β the image angle
// of pixel (u, v) about the principal point c; degrees) of the image-frame Stokes
// vector s, as f32. CPU twin: chain::sky_angles (rows.rs), the same steps.
fn sky_angles(s: Stokes, u_px: f64, v_px: f64, c: vec2<f64>) -> vec3<f32> {
    // AoP α = ½ atan2(U, Q), in (−90°, 90°].
    let a_deg = aop_rad(s) * DEG_PER_RAD_F64;
    // β: the image angle of the pixel about the principal point (CCW as displayed).
    let beta_deg = image_angle_rad(u_px - c.x, v_px - c.y) * DEG_PER_RAD_F64;
    return vec3<f32>(f32(wrap_deg_90(a_deg)), f32(dolp(s)), f32(wrap_deg_90(a_deg - beta_deg)));
}

// Photo-signal in DN of channel ch for Stokes s: the channel's analyzer, then gain.
fn pixel_signal_dn(f: ChainFrame, s: Stokes, ch: u32) -> f64 {
    return analyzer_intensity(s, Analyzer(f.cos2t[ch], f.sin2t[ch], f.eps[ch])) * f.gain_dn[ch];
}

// Where an analyzer sits: column u, row v, channel ch, position from the principal point (px).
struct PixelSite {
    u: u32,
    v: u32,
    ch: u32,
    x_px: f64,
    y_px: f64,
}

// One pixel's analyzer and the gain behind it (DN per unit radiance).
struct PixelAnalyzer {
    analyzer: Analyzer,
    gain: f64,
}

// The analyzer of channel ch at pixel column u, row v (ray g) and the gain behind it:
// the channel's, changed by the analyzer effects where the frame has any. ANALYZER_ON
// (the analyzer effects' pipeline mask, 0 where no frame of the dispatch has one on)
// leaves the step out at compile time: llvmpipe, which runs the untaken side of a
// uniform branch under a lane mask, then does not run the analyzer effects at all.
fn pixel_analyzer(f: ChainFrame, g: RayGeometry, u: u32, v: u32, ch: u32) -> PixelAnalyzer {
    let a = PixelAnalyzer(Analyzer(f.cos2t[ch], f.sin2t[ch], f.eps[ch]), f.gain_dn[ch]);
    if (ANALYZER_ON == 0u || !f.analyzer_on) {
        return a;
    }
    let site = PixelSite(u, v, ch, f64(u) - f.intr.cx_px, f64(v) - f.intr.cy_px);
    return analyzer_effects(f.analyzer, site, g, a);
}

// Photo-signal in DN of channel ch at pixel (u, v), whose ray is g, for Stokes s: the
// pixel's own analyzer, then gain.
fn site_signal_dn(f: ChainFrame, s: Stokes, g: RayGeometry, u: u32, v: u32, ch: u32) -> f64 {
    let a = pixel_analyzer(f, g, u, v, ch);
    return analyzer_intensity(s, a.analyzer) * a.gain;
}

struct SensorNoise {
    temporal: f64,
    dsnu: f64,
    prnu: f64,
}

// Draws the noise of channel ch at linear pixel index `pixel` (0 where the response
// has no such noise: nothing is drawn for it).
fn sensor_noise(f: ChainFrame, pixel: u32, ch: u32) -> SensorNoise {
    var n = SensorNoise(0.0lf, 0.0lf, 0.0lf);
    if (f.noise.x > 0.0lf || f.noise.y > 0.0lf) {
        n.temporal = normal(f.key, pixel, ch, STREAM_TEMPORAL);
    }
    if (f.noise.z > 0.0lf) {
        n.dsnu = normal(f.fixed_key, pixel, ch, STREAM_DSNU);
    }
    if (f.noise.w > 0.0lf) {
        n.prnu = normal(f.fixed_key, pixel, ch, STREAM_PRNU);
    }
    return n;
}

// The sensor's output DN for signal_dn on channel ch with the draws n.
fn sensor_dn(f: ChainFrame, signal_dn: f64, ch: u32, n: SensorNoise) -> f64 {
    // Gain non-uniformity (fixed pattern).
    let sig0 = signal_dn * (1.0lf + f.noise.w * n.prnu);
    // Sensor effects (the non-linear response, …), each the identity at neutral.
    let sig = sensor_effects(f.sensor, sig0, f.full_scale_dn);
    // Black level, channel offset and offset non-uniformity (fixed pattern).
    var dn = sig + f.offset_dn[ch] + f.noise.z * n.dsnu;
    // Temporal noise: read noise plus shot noise of variance K·signal.
    let variance = f.noise.x * f.noise.x + f.noise.y * max(sig, 0.0lf);
    dn += sqrt(variance) * n.temporal;
    // Rounding (half up) and clipping to the ADC range.
    if (f.quantize) {
        dn = min(max(floor(dn + 0.5lf), 0.0lf), f.full_scale_dn);
    }
    return dn;
}

// Photo-signal in DN of DoFP pixel (u, v) through its own ray and analyzer (the
// channel at its position in the 2 × 2 mosaic, `mosaic[2·(v mod 2) + (u mod 2)]`).
fn mosaic_signal_at(f: ChainFrame, u: u32, v: u32, mosaic: vec4<u32>) -> f64 {
    let ch = mosaic[2u * (v & 1u) + (u & 1u)];
    let g = geometry(f.intr, f64(u), f64(v));
    return site_signal_dn(f, ray_stokes(f, g), g, u, v, ch);
}

// Photo-signal of DoFP pixel (u, v) of a w × h mosaic, with the mosaic effects (crosstalk,
// …) and its edge neighbours where the frame has any (0 outside the sensor; none at all
// where the mosaic effects' pipeline mask MOSAIC_ON is 0).
fn mosaic_pixel_signal_dn(f: ChainFrame, u: u32, v: u32, w: u32, h: u32, mosaic: vec4<u32>) -> f64 {
    let own = mosaic_signal_at(f, u, v, mosaic);
    if (MOSAIC_ON == 0u || !f.mosaic_on) {
        return own;
    }
    var up = 0.0lf;
    var down = 0.0lf;
    var left = 0.0lf;
    var right = 0.0lf;
    if (v > 0u) {
        up = mosaic_signal_at(f, u, v - 1u, mosaic);
    }
    if (v + 1u < h) {
        down = mosaic_signal_at(f, u, v + 1u, mosaic);
    }
    if (u > 0u) {
        left = mosaic_signal_at(f, u - 1u, v, mosaic);
    }
    if (u + 1u < w) {
        right = mosaic_signal_at(f, u + 1u, v, mosaic);
    }
    return mosaic_effects(f.mosaic_fx, own, up, down, left, right);
}

// DN of DoFP pixel (u, v) of a w × h frame.
fn mosaic_pixel_dn(f: ChainFrame, u: u32, v: u32, w: u32, h: u32, mosaic: vec4<u32>) -> f64 {
    let ch = mosaic[2u * (v & 1u) + (u & 1u)];
    // Sky → lens → analyzer → photo-signal along the true ray (and crosstalk).
    let signal = mosaic_pixel_signal_dn(f, u, v, w, h, mosaic);
    // Sensor: non-uniformities, offsets, noise, rounding.
    return sensor_dn(f, signal, ch, sensor_noise(f, v * w + u, ch));
}

// The band over DoFP pixel (u, v) of a colour-polarization sensor, as a band index
// (R 0, G 1, B 2): `tiles[2·((v / 2) mod 2) + (u / 2) mod 2]`, each filter over a
// whole 2 × 2 analyzer tile (CONVENTIONS.md `colour_tiles`; CPU twin:
// `ColourTiles::band_at`).
fn band_at(tiles: vec4<u32>, u: u32, v: u32) -> u32 {
    return tiles[2u * ((v >> 1u) & 1u) + ((u >> 1u) & 1u)];
}

