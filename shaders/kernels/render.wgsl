// Kernels that render frames: the per-pixel chain mapped over pixels and frames
// (CPU twin: crates/bpins-core/src/simulate.rs `render_mosaic`, `render_colour_mosaic`,
// `render_colocated`, and the noise-free chain for the parity checks). One invocation
// per pixel; global id z is the frame of the batch.

// Keep in sync with `RenderDims` in crates/bpins-gpu/src/params.rs.
struct RenderDims {
    size: vec4<u32>,   // width_px, height_px, frames, 0
    mosaic: vec4<u32>, // channel index at tile position 2·(v mod 2) + (u mod 2)
    tiles: vec4<u32>,  // colour: band index at tile position 2·((v / 2) mod 2) + (u / 2) mod 2
}

@group(0) @binding(0) var<uniform> dims: RenderDims;
@group(0) @binding(1) var<storage, read> frames: array<FrameParams>;
@group(0) @binding(2) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn render_mosaic(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = dims.size.x;
    let h = dims.size.y;
    if (gid.x >= w || gid.y >= h || gid.z >= dims.size.z) {
        return;
    }
    let f = chain_frame(frames[gid.z]);
    out[(gid.z * h + gid.y) * w + gid.x] = f32(mosaic_pixel_dn(f, gid.x, gid.y, w, h, dims.mosaic));
}

// Photo-signal of DoFP pixel (u, v) through its own ray and analyzer in the frame of
// the band over it: `frames[base + band]`, a trial's band frames by band index, read
// from the buffer where the CPU takes `&frames[band]` (three frames passed by value as
// an array kept llvmpipe compiling the f32 kernel for over ten minutes).
fn colour_signal_at(base: u32, tiles: vec4<u32>, u: u32, v: u32, mosaic: vec4<u32>) -> f64 {
    return mosaic_signal_at(chain_frame(frames[base + band_at(tiles, u, v)]), u, v, mosaic);
}

// `mosaic_pixel_signal_dn` on a colour-polarization sensor: the pixel, and each of its
// edge neighbours, through the frame of the band over it, so crosstalk between
// neighbouring tiles mixes bands as they are (0 outside the sensor; none at all where
// MOSAIC_ON is 0). The mosaic effects' vectors are the pixel's band's frame's (the same
// in every band). CPU twin: chain::colour_pixel_signal_dn (its `frames` here the three
// at `base` in the buffer).
fn colour_pixel_signal_dn(base: u32, tiles: vec4<u32>, u: u32, v: u32, w: u32, h: u32, mosaic: vec4<u32>) -> f64 {
    let f = chain_frame(frames[base + band_at(tiles, u, v)]);
    let own = mosaic_signal_at(f, u, v, mosaic);
    if (MOSAIC_ON == 0u || !f.mosaic_on) {
        return own;
    }
    var up = 0.0lf;
    var down = 0.0lf;
    var left = 0.0lf;
    var right = 0.0lf;
    if (v > 0u) {
        up = colour_signal_at(base, tiles, u, v - 1u, mosaic);
    }
    if (v + 1u < h) {
        down = colour_signal_at(base, tiles, u, v + 1u, mosaic);
    }
    if (u > 0u) {
        left = colour_signal_at(base, tiles, u - 1u, v, mosaic);
    }
    if (u + 1u < w) {
        right = colour_signal_at(base, tiles, u + 1u, v, mosaic);
    }
    return mosaic_effects(f.mosaic_fx, own, up, down, left, right);
}

// A colour-polarization DoFP mosaic (CPU twin: simulate::render_colour_mosaic, pixel by
// pixel): frame z of the batch is frames[3z + b], its band b's frame (R, G, B), each
// pixel through the band over it (`dims.tiles`) and its neighbours through theirs where
// a mosaic effect mixes them (crosstalk).
@compute @workgroup_size(16, 16, 1)
fn render_colour_mosaic(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = dims.size.x;
    let h = dims.size.y;
    if (gid.x >= w || gid.y >= h || gid.z >= dims.size.z) {
        return;
    }
    let u = gid.x;
    let v = gid.y;
    let base = 3u * gid.z;
    let ch = dims.mosaic[2u * (v & 1u) + (u & 1u)];
    // Sky → lens → analyzer → photo-signal, each pixel in its band (and crosstalk).
    let signal = colour_pixel_signal_dn(base, dims.tiles, u, v, w, h, dims.mosaic);
    // Sensor: non-uniformities, offsets, noise, rounding (the bands' frames share their
    // sensor, offsets and noise keys: the first band's).
    let f = chain_frame(frames[base]);
    out[(gid.z * h + v) * w + u] = f32(sensor_dn(f, signal, ch, sensor_noise(f, v * w + u, ch)));
}

// All four channels of colocated pixel (u, v): out[4·pixel + k].
@compute @workgroup_size(16, 16, 1)
fn render_colocated(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = dims.size.x;
    let h = dims.size.y;
    if (gid.x >= w || gid.y >= h || gid.z >= dims.size.z) {
        return;
    }
    let f = chain_frame(frames[gid.z]);
    let g = geometry(f.intr, f64(gid.x), f64(gid.y));
    let s = ray_stokes(f, g);
    let pixel = gid.y * w + gid.x;
    let base = 4u * ((gid.z * h + gid.y) * w + gid.x);
    for (var ch = 0u; ch < 4u; ch++) {
        let signal = site_signal_dn(f, s, g, gid.x, gid.y, ch);
        out[base + ch] = f32(sensor_dn(f, signal, ch, sensor_noise(f, pixel, ch)));
    }
}

// Noise-free chain of pixel (u, v): the four channels' photo-signal (DN), then the
// AoP (degrees, image frame), DoLP and AoE (degrees, AoP − β: from the radial
// direction about the principal point) of the Stokes vector reaching the analyzers:
// out[7·pixel + k]. CPU twin of the angles: recon::angle_maps.
@compute @workgroup_size(16, 16, 1)
fn chain_maps(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = dims.size.x;
    let h = dims.size.y;
    if (gid.x >= w || gid.y >= h || gid.z >= dims.size.z) {
        return;
    }
    let f = chain_frame(frames[gid.z]);
    let g = geometry(f.intr, f64(gid.x), f64(gid.y));
    let s = ray_stokes(f, g);
    let base = 7u * ((gid.z * h + gid.y) * w + gid.x);
    for (var ch = 0u; ch < 4u; ch++) {
        out[base + ch] = f32(site_signal_dn(f, s, g, gid.x, gid.y, ch));
    }
    let angles = sky_angles(s, f64(gid.x), f64(gid.y), vec2<f64>(f.intr.cx_px, f.intr.cy_px));
    out[base + 4u] = angles.x;
    out[base + 5u] = angles.y;
    out[base + 6u] = angles.z;
}

// The sky's AoP (degrees, (−90, 90]), DoLP and AoE (AoP − β about the true principal
// point, degrees) of the light reaching the analyzers, noise-free, no DN rendered:
// out[3·pixel + k]. CPU twin: simulate::sky_maps (chain::angles_row), same steps.
@compute @workgroup_size(16, 16, 1)
fn sky_maps(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = dims.size.x;
    let h = dims.size.y;
    if (gid.x >= w || gid.y >= h || gid.z >= dims.size.z) {
        return;
    }
    let f = chain_frame(frames[gid.z]);
    let s = pixel_stokes(f, f64(gid.x), f64(gid.y));
    let base = 3u * ((gid.z * h + gid.y) * w + gid.x);
    let angles = sky_angles(s, f64(gid.x), f64(gid.y), vec2<f64>(f.intr.cx_px, f.intr.cy_px));
    out[base] = angles.x;
    out[base + 1u] = angles.y;
    out[base + 2u] = angles.z;
}
