// Heading sums of whole frames, reduced on the device: render → reconstruct →
// contribution → per-workgroup tree sums. CPU twins: crates/bpins-core/src/simulate.rs
// `mosaic_heading_sums` (DoFP superpixels) and montecarlo.rs `run_trial` (colocated).
// One invocation per K samples of a row (a sample is a 2 × 2 tile or a colocated
// pixel); global id z is the frame. Each workgroup writes SUMS_LEN partial sums per heading context; the
// `reduce_partials` kernel (reduce.wgsl) adds them per frame: no frame leaves the GPU.

// Keep in sync with `SumsDims` in crates/bpins-gpu/src/params.rs.
struct SumsDims {
    samples: vec4<u32>, // samples across, samples down, contexts per frame, layout (0 DoFP, 1 colocated)
    image: vec4<u32>,   // width_px, height_px, workgroups across, workgroups down
}

@group(0) @binding(0) var<uniform> dims: SumsDims;
@group(0) @binding(1) var<storage, read> frames: array<FrameParams>;
@group(0) @binding(2) var<storage, read> recon: array<ReconParams>;
@group(0) @binding(3) var<storage, read> heading: array<HeadingParams>;
@group(0) @binding(4) var<storage, read_write> partials: array<f64>;

const WG_SIZE: u32 = 256u;
var<workgroup> red: array<array<f64, 7>, WG_SIZE>;
var<workgroup> band_bits: atomic<u32>;
var<workgroup> band_mask: u32;

fn zeros7() -> array<f64, 7> {
    return array<f64, 7>(0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf);
}

// Tree sum of seven values over the workgroup (fixed order: deterministic).
fn reduce7(li: u32, v: array<f64, 7>) -> array<f64, 7> {
    red[li] = v;
    workgroupBarrier();
    for (var s = WG_SIZE / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            for (var k = 0u; k < 7u; k++) {
                red[li][k] += red[li + s][k];
            }
        }
        workgroupBarrier();
    }
    let total = red[0];
    workgroupBarrier();
    return total;
}

struct Sample {
    s: Stokes,
    ok: bool,
}

// Superpixel (i, j) of a DoFP frame: the tile's four DN as render_mosaic renders them
// (stored as f32, as the CPU's mosaic is), then the tile's Stokes vector.
fn mosaic_sample(f: ChainFrame, rp: ReconParams, i: u32, j: u32) -> Sample {
    let w = dims.image.x;
    var d = vec4<f64>(0.0lf);
    var ok = true;
    let full_scale = wide(rp.valid).x;
    for (var p = 0u; p < 4u; p++) {
        let u = 2u * i + (p & 1u);
        let v = 2u * j + (p >> 1u);
        let x = f64(f32(mosaic_pixel_dn(f, u, v, w, dims.image.y, rp.mosaic)));
        ok = ok && (full_scale == 0.0lf || dn_is_valid(x, full_scale));
        d[rp.mosaic[p]] = x;
    }
    return Sample(reconstruct(rp, d), ok);
}

// Colocated pixel (u, v): four channels' DN (f64, as run_trial keeps them), then Stokes.
fn colocated_sample(f: ChainFrame, rp: ReconParams, u: u32, v: u32) -> Sample {
    let g = geometry(f.intr, f64(u), f64(v));
    let s = ray_stokes(f, g);
    let pixel = v * dims.image.x + u;
    var d = vec4<f64>(0.0lf);
    var ok = true;
    let full_scale = wide(rp.valid).x;
    for (var ch = 0u; ch < 4u; ch++) {
        let x = sensor_dn(f, site_signal_dn(f, s, g, u, v, ch), ch, sensor_noise(f, pixel, ch));
        ok = ok && (full_scale == 0.0lf || dn_is_valid(x, full_scale));
        d[ch] = x;
    }
    return Sample(reconstruct(rp, d), ok);
}

// Samples per invocation, along a row: each invocation sums K samples in registers,
// so the workgroup's tree sums (and their barriers) are paid once per 16·K × 16 samples.
const K: u32 = 32u;
// Heading contexts per frame (lens ρ unknown and known); the host checks.
const MAX_CTX: u32 = 2u;

@compute @workgroup_size(16, 16, 1)
fn frame_sums(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let frame = gid.z;
    let j = gid.y;
    let f = chain_frame(frames[frame]);
    let rp = recon[frame];
    let n_ctx = min(dims.samples.z, MAX_CTX);
    // This invocation's sums per context: scatter + n, band sums per sector, and
    // which sectors it touched (function-scope variables start at zero).
    var scatter: array<array<f64, 7>, MAX_CTX>;
    var band: array<array<array<f64, 7>, SECTORS>, MAX_CTX>;
    var touched: array<u32, MAX_CTX>;
    for (var s = 0u; s < K; s++) {
        let i = gid.x * K + s;
        if (i >= dims.samples.x || j >= dims.samples.y) {
            break;
        }
        // The sample's Stokes vector: render its DN, reconstruct.
        var sample: Sample;
        if (dims.samples.w == 0u) {
            sample = mosaic_sample(f, rp, i, j);
        } else {
            sample = colocated_sample(f, rp, i, j);
        }
        for (var c = 0u; c < n_ctx; c++) {
            let hp = heading[frame * dims.samples.z + c];
            let grid = wide(hp.grid);
            let hb = wide(hp.band);
            let intr = intrinsics_from(hp.camera, hp.distortion);
            // Heading sums along the assumed ray at the sample's pixel position.
            let x = grid.x + grid.z * f64(i);
            let y = grid.y + grid.z * f64(j);
            let con = contribution(hb.x, geometry(intr, x, y), sample.s, sample.ok && grid.w != 0.0lf);
            for (var t = 0u; t < 6u; t++) {
                scatter[c][t] += con.m[t];
            }
            scatter[c][6] += con.n;
            // Meridian band, by sector of the sample's image angle.
            let dx = x - intr.cx_px;
            let dy = y - intr.cy_px;
            if (in_band(hb, con, dx, dy)) {
                let k = sector_of(image_angle_rad(dx, dy));
                let terms = band_terms(con);
                for (var t = 0u; t < 7u; t++) {
                    band[c][k][t] += terms[t];
                }
                touched[c] |= 1u << k;
            }
        }
    }
    // Workgroup sums, written as this workgroup's partials.
    let n_wg = dims.image.z * dims.image.w;
    let wg = wid.y * dims.image.z + wid.x;
    for (var c = 0u; c < n_ctx; c++) {
        let total = reduce7(li, scatter[c]);
        atomicOr(&band_bits, touched[c]);
        workgroupBarrier();
        if (li == 0u) {
            band_mask = atomicLoad(&band_bits);
            atomicStore(&band_bits, 0u);
        }
        let mask = workgroupUniformLoad(&band_mask);
        let base = ((frame * dims.samples.z + c) * n_wg + wg) * SUMS_LEN;
        if (li == 0u) {
            for (var t = 0u; t < 7u; t++) {
                partials[base + t] = total[t];
            }
        }
        for (var k = 0u; k < SECTORS; k++) {
            var sums = zeros7();
            if (((mask >> k) & 1u) != 0u) {
                sums = reduce7(li, band[c][k]);
            }
            if (li == 0u) {
                for (var t = 0u; t < 7u; t++) {
                    partials[base + 7u + 7u * k + t] = sums[t];
                }
            }
        }
    }
}
