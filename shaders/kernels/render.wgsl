// Kernels that render frames: the per-pixel chain mapped over pixels and frames
// (CPU twin: crates/bpins-core/src/simulate.rs `render_mosaic`, `render_colocated`,
// and the noise-free chain for the parity checks). One invocation per pixel;
// global id z is the frame of the batch.

// Keep in sync with `RenderDims` in crates/bpins-gpu/src/params.rs.
struct RenderDims {
    size: vec4<u32>,   // width_px, height_px, frames, 0
    mosaic: vec4<u32>, // channel index at tile position 2·(v mod 2) + (u mod 2)
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
