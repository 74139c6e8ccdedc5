// Heading sums of whole frames, reduced on the device: render → reconstruct →
// contribution → per-invocation sums. CPU twins: crates/bpins-core/src/simulate.rs
// `mosaic_heading_sums` (DoFP superpixels) and montecarlo.rs `run_trial` (colocated).
// One invocation per run of samples along one row (a sample is a 2 × 2 tile or a
// colocated pixel): global id x is the row, y the run along it, z the frame. Each
// invocation writes its own SUMS_LEN sums per heading context; the `reduce_partials`
// kernel (reduce.wgsl) adds them per frame in a fixed order: no frame leaves the GPU.
//
// No workgroup memory and no barrier: on a CPU rasterizer (llvmpipe) every barrier is
// a coroutine switch of every SIMD group of the workgroup, and the former per-workgroup
// tree sums (one per value set and touched sector) cost more than the samples. The
// host picks the run length (`sums.rs`): whole rows on a CPU adapter (long loops, few
// partials), runs of about 128 samples on a GPU (enough invocations in flight).

// Keep in sync with `SumsDims` in crates/bpins-gpu/src/params.rs.
struct SumsDims {
    samples: vec4<u32>, // samples across, samples down, contexts per frame, layout (0 DoFP, 1 colocated; the kernel reads SUMS_LAYOUT)
    image: vec4<u32>,   // width_px, height_px, workgroups across (ROWS rows each), runs per row (colour: per parity)
    tiles: vec4<u32>,   // colour: band index at tile position 2·(j mod 2) + (i mod 2) of superpixel (i, j); 0 otherwise
}

@group(0) @binding(0) var<uniform> dims: SumsDims;
@group(0) @binding(1) var<storage, read> frames: array<FrameParams>;
@group(0) @binding(2) var<storage, read> recon: array<ReconParams>;
@group(0) @binding(3) var<storage, read> heading: array<HeadingParams>;
@group(0) @binding(4) var<storage, read_write> partials: array<f64>;

// Rows per workgroup, one invocation each (`SUMS_ROWS` in sums.rs).
const ROWS: u32 = 64u;
// Samples summed in a block before the block joins the invocation's running sums, so
// that no f32 sum runs over more than BLOCK + (samples / BLOCK) terms in series.
const BLOCK: u32 = 32u;
// Heading contexts per frame (lens ρ unknown and known); the host checks.
const MAX_CTX: u32 = 2u;

// Pipeline constants, one pipeline per combination (`SumsVariant` in sums.rs). They
// are the uniform choices of the whole dispatch: llvmpipe runs both sides of every
// `if` under a lane mask, so a branch on a uniform value still costs its untaken side;
// a constant removes it at compile time.
// The samples: 0 DoFP superpixels without mosaic effects, 1 DoFP with (crosstalk, …), 2 colocated.
override SUMS_LAYOUT: u32 = 0u;
// 1: every context puts every sample on the same assumed ray (the host checked the
// cameras, distortions and grids), so the geometry is computed once for all.
override SHARED_RAYS: u32 = 0u;
// The sensor noise any frame of the dispatch draws: bit 0 temporal, 1 DSNU, 2 PRNU.
override SUMS_NOISE: u32 = 7u;

// sensor_noise (chain.wgsl) without the draws no frame of the dispatch makes (left out
// at compile time; the host sets SUMS_NOISE from the frames' noise parameters). The
// draws it keeps are sensor_noise's, under the same per-frame conditions.
fn sample_noise(f: ChainFrame, pixel: u32, ch: u32) -> SensorNoise {
    if (SUMS_NOISE == 7u) {
        return sensor_noise(f, pixel, ch);
    }
    var n = SensorNoise(0.0lf, 0.0lf, 0.0lf);
    if ((SUMS_NOISE & 1u) != 0u && (f.noise.x > 0.0lf || f.noise.y > 0.0lf)) {
        n.temporal = normal(f.key, pixel, ch, STREAM_TEMPORAL);
    }
    if ((SUMS_NOISE & 2u) != 0u && f.noise.z > 0.0lf) {
        n.dsnu = normal(f.fixed_key, pixel, ch, STREAM_DSNU);
    }
    if ((SUMS_NOISE & 4u) != 0u && f.noise.w > 0.0lf) {
        n.prnu = normal(f.fixed_key, pixel, ch, STREAM_PRNU);
    }
    return n;
}

fn zeros7() -> array<f64, 7> {
    return array<f64, 7>(0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf);
}

struct Sample {
    s: Stokes,
    ok: bool,
}

// DN of DoFP pixel (u, v): mosaic_pixel_dn (chain.wgsl). Without mosaic effects (the frame's
// flag off, SUMS_LAYOUT 0) that is its own pixel's signal through the sensor, the same
// calls without the neighbours' branch (which llvmpipe would run, masked).
fn tile_pixel_dn(f: ChainFrame, u: u32, v: u32, w: u32, h: u32, mosaic: vec4<u32>) -> f64 {
    if (SUMS_LAYOUT == 1u) {
        return mosaic_pixel_dn(f, u, v, w, h, mosaic);
    }
    let ch = mosaic[2u * (v & 1u) + (u & 1u)];
    return sensor_dn(f, mosaic_signal_at(f, u, v, mosaic), ch, sample_noise(f, v * w + u, ch));
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
        let x = f64(f32(tile_pixel_dn(f, u, v, w, dims.image.y, rp.mosaic)));
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
        let x = sensor_dn(f, site_signal_dn(f, s, g, u, v, ch), ch, sample_noise(f, pixel, ch));
        ok = ok && (full_scale == 0.0lf || dn_is_valid(x, full_scale));
        d[ch] = x;
    }
    return Sample(reconstruct(rp, d), ok);
}

// One heading context as the kernel uses it: the assumed camera, the sample grid
// (x0, y0, step, enabled) and the band parameters (lens rho2, cos 2·band, r_min², r_max²).
struct Context {
    intr: Intrinsics,
    grid: vec4<f64>,
    band: vec4<f64>,
}

fn context_from(hp: HeadingParams) -> Context {
    return Context(intrinsics_from(hp.camera, hp.distortion), wide(hp.grid), wide(hp.band));
}

// One context's running sums in an invocation: the current block's scatter + n, the
// finished blocks' scatter + n, the band sums per sector, and the band samples of the
// current run of one sector (added to `band` when the sector changes or the run is
// BLOCK long, so the per-sector array is indexed by a varying sector only then).
struct Acc {
    block: array<f64, 7>,
    total: array<f64, 7>,
    band: array<array<f64, 7>, SECTORS>,
    run: array<f64, 7>,
    run_sector: u32,
    run_n: u32,
}

fn acc_new() -> Acc {
    var a: Acc;
    a.block = zeros7();
    a.total = zeros7();
    a.run = zeros7();
    a.run_sector = 0u;
    a.run_n = 0u;
    return a;
}

// Moves the current band run into its sector's sums.
fn flush_run(a: ptr<function, Acc>) {
    if ((*a).run_n != 0u) {
        let k = (*a).run_sector;
        for (var t = 0u; t < 7u; t++) {
            (*a).band[k][t] += (*a).run[t];
        }
        (*a).run = zeros7();
        (*a).run_n = 0u;
    }
}

// Moves the current block into the running totals.
fn flush_block(a: ptr<function, Acc>) {
    for (var t = 0u; t < 7u; t++) {
        (*a).total[t] += (*a).block[t];
    }
    (*a).block = zeros7();
}

// Sector of the sample at (x, y) px about context cx's assumed principal point.
fn sector_at(cx: Context, x: f64, y: f64) -> u32 {
    return sector_of(image_angle_rad(x - cx.intr.cx_px, y - cx.intr.cy_px));
}

// Adds the sample at (x, y) px, seen along the assumed ray g, to context cx's sums
// (HeadingSums::add: scatter for every sample, band sums by sector k in the band).
// llvmpipe computes k for every sample whatever the branch, so the caller computes it
// once where the contexts share their rays.
fn accumulate(a: ptr<function, Acc>, cx: Context, g: RayGeometry, x: f64, y: f64, k: u32, sample: Sample) {
    let con = contribution(cx.band.x, g, sample.s, sample.ok && cx.grid.w != 0.0lf);
    for (var t = 0u; t < 6u; t++) {
        (*a).block[t] += con.m[t];
    }
    (*a).block[6] += con.n;
    // Meridian band, by sector of the sample's image angle.
    let dx = x - cx.intr.cx_px;
    let dy = y - cx.intr.cy_px;
    if (in_band(cx.band, con, dx, dy)) {
        if (k != (*a).run_sector || (*a).run_n == BLOCK) {
            flush_run(a);
            (*a).run_sector = k;
        }
        let terms = band_terms(con);
        for (var t = 0u; t < 7u; t++) {
            (*a).run[t] += terms[t];
        }
        (*a).run_n += 1u;
    }
}

// Writes one context's sums as this invocation's partial of job `job`.
// One sample's sums in each context, along the assumed ray at grid point (i, j): the
// second context's ray is the first's where the contexts share their rays.
fn accumulate_contexts(
    a0: ptr<function, Acc>,
    a1: ptr<function, Acc>,
    c0: Context,
    c1: Context,
    two: bool,
    i: u32,
    j: u32,
    sample: Sample,
) {
    let x0 = c0.grid.x + c0.grid.z * f64(i);
    let y0 = c0.grid.y + c0.grid.z * f64(j);
    let g0 = geometry(c0.intr, x0, y0);
    let k0 = sector_at(c0, x0, y0);
    accumulate(a0, c0, g0, x0, y0, k0, sample);
    if (two) {
        let x1 = c1.grid.x + c1.grid.z * f64(i);
        let y1 = c1.grid.y + c1.grid.z * f64(j);
        var g1 = g0;
        var k1 = k0;
        if (SHARED_RAYS == 0u) {
            g1 = geometry(c1.intr, x1, y1);
            k1 = sector_at(c1, x1, y1);
        }
        accumulate(a1, c1, g1, x1, y1, k1, sample);
    }
}

fn write_partial(a: ptr<function, Acc>, base: u32) {
    flush_block(a);
    flush_run(a);
    for (var t = 0u; t < 7u; t++) {
        partials[base + t] = (*a).total[t];
    }
    for (var k = 0u; k < SECTORS; k++) {
        for (var t = 0u; t < 7u; t++) {
            partials[base + 7u + 7u * k + t] = (*a).band[k][t];
        }
    }
}

@compute @workgroup_size(64, 1, 1)
fn frame_sums(@builtin(global_invocation_id) gid: vec3<u32>) {
    let frame = gid.z;
    let j = gid.x;
    let n_ctx = min(dims.samples.z, MAX_CTX);
    // This invocation's run of samples along row j.
    let runs = dims.image.w;
    let per_run = (dims.samples.x + runs - 1u) / runs;
    let i0 = min(gid.y * per_run, dims.samples.x);
    let i1 = select(min(i0 + per_run, dims.samples.x), i0, j >= dims.samples.y);
    let f = chain_frame(frames[frame]);
    let rp = recon[frame];
    // The contexts, read once per invocation (a second one only where there is one).
    let h0 = heading[frame * dims.samples.z];
    let h1 = heading[frame * dims.samples.z + n_ctx - 1u];
    let c0 = context_from(h0);
    let c1 = context_from(h1);
    let two = n_ctx > 1u;
    var a0 = acc_new();
    var a1 = acc_new();
    for (var b = i0; b < i1; b += BLOCK) {
        let e = min(b + BLOCK, i1);
        for (var i = b; i < e; i++) {
            // The sample's Stokes vector: render its DN, reconstruct.
            var sample: Sample;
            if (SUMS_LAYOUT == 2u) {
                sample = colocated_sample(f, rp, i, j);
            } else {
                sample = mosaic_sample(f, rp, i, j);
            }
            // Heading sums along the assumed ray at the sample's pixel position.
            accumulate_contexts(&a0, &a1, c0, c1, two, i, j, sample);
        }
        flush_block(&a0);
        flush_block(&a1);
    }
    // This invocation's partials: slot p of n per (frame, context).
    let n = dims.image.z * ROWS * runs;
    let p = gid.y * dims.image.z * ROWS + j;
    write_partial(&a0, ((frame * dims.samples.z) * n + p) * SUMS_LEN);
    if (two) {
        write_partial(&a1, ((frame * dims.samples.z + 1u) * n + p) * SUMS_LEN);
    }
}

// Colour-polarization sensors: each band's heading sums of colour mosaics already
// rendered on the device (render.wgsl `render_colour_mosaic` into `mosaics`, one
// w × h DN frame after another; job z reads frame `mosaic_of[z]`). Only the sums come
// back, SUMS_LEN per (job, context, band), never the mosaic.
@group(0) @binding(5) var<storage, read> mosaics: array<f32>;
@group(0) @binding(6) var<storage, read> mosaic_of: array<u32>;

// Superpixel (i, j) of the stored mosaic at `base`: the tile's four DN (f32, as the
// mosaic holds them), masked outside (0, full scale), then the tile's Stokes vector.
// CPU twin: recon.rs `superpixel_stokes_row` for one tile (a masked tile's I is NaN
// there, `ok` false here).
fn stored_superpixel(base: u32, rp: ReconParams, i: u32, j: u32) -> Sample {
    let w = dims.image.x;
    var d = vec4<f64>(0.0lf);
    var ok = true;
    let full_scale = wide(rp.valid).x;
    for (var p = 0u; p < 4u; p++) {
        let u = 2u * i + (p & 1u);
        let v = 2u * j + (p >> 1u);
        let x = f64(mosaics[base + v * w + u]);
        ok = ok && (full_scale == 0.0lf || dn_is_valid(x, full_scale));
        d[rp.mosaic[p]] = x;
    }
    return Sample(reconstruct(rp, d), ok);
}

// Writes one context's sums as this invocation's partial for its band `band`, and
// zeros for the other two bands' (every partial slot is written by exactly one
// invocation). `base` is the (job, context)'s first band's slot.
fn write_band_partials(a: ptr<function, Acc>, base: u32, n: u32, band: u32) {
    for (var b = 0u; b < 3u; b++) {
        let at = (base + b * n) * SUMS_LEN;
        if (b == band) {
            write_partial(a, at);
        } else {
            for (var t = 0u; t < SUMS_LEN; t++) {
                partials[at + t] = 0.0lf;
            }
        }
    }
}

// Each band's heading sums of a colour DoFP mosaic, one set per context. CPU twin:
// bpins-core sweep/colour.rs `colour_mosaic_heading_sums(dn, w, h, mosaic, tiles, rec,
// full_scale_dn, contexts)`, same steps: per tile row j, the row's superpixels (rec;
// samples outside (0, full_scale_dn) masked); the even and the odd tiles of the row,
// each under one band (`dims.tiles[2·(j mod 2) + parity]`, tiles.tiles[j mod 2][parity]),
// summed as a row of their own into that band's sums; superpixel i at x = 0.5 + 2i px,
// y = 0.5 + 2j px (the contexts' grid). Here one invocation per run of one parity's
// superpixels along row j: global id x is the row, y = parity · runs + run, z the job;
// partial slot p of n per (job, context, band), added by `reduce_partials` in a fixed
// order (the CPU adds rows in row order: the sums agree to rounding).
@compute @workgroup_size(64, 1, 1)
fn colour_mosaic_heading_sums(@builtin(global_invocation_id) gid: vec3<u32>) {
    let job = gid.z;
    let j = gid.x;
    let n_ctx = min(dims.samples.z, MAX_CTX);
    let runs = dims.image.w;
    let parity = gid.y / runs;
    let run = gid.y % runs;
    // This invocation's run of the row's superpixels i = 2m + parity, m in [m0, m1).
    let of_parity = (dims.samples.x + 1u - parity) / 2u;
    let per_run = (of_parity + runs - 1u) / runs;
    let m0 = min(run * per_run, of_parity);
    let m1 = select(min(m0 + per_run, of_parity), m0, j >= dims.samples.y);
    let band = dims.tiles[2u * (j & 1u) + parity];
    let base = mosaic_of[job] * dims.image.x * dims.image.y;
    let rp = recon[job];
    let h0 = heading[job * dims.samples.z];
    let h1 = heading[job * dims.samples.z + n_ctx - 1u];
    let c0 = context_from(h0);
    let c1 = context_from(h1);
    let two = n_ctx > 1u;
    var a0 = acc_new();
    var a1 = acc_new();
    for (var b = m0; b < m1; b += BLOCK) {
        let e = min(b + BLOCK, m1);
        for (var m = b; m < e; m++) {
            // The superpixel's Stokes vector from the stored mosaic.
            let i = 2u * m + parity;
            let sample = stored_superpixel(base, rp, i, j);
            // Its band's sums along the assumed ray at the superpixel's position.
            accumulate_contexts(&a0, &a1, c0, c1, two, i, j, sample);
        }
        flush_block(&a0);
        flush_block(&a1);
    }
    // Partial slots per (job, context, band): n = 2 parities × runs × the rows' slots.
    let n = 2u * runs * dims.image.z * ROWS;
    let p = gid.y * dims.image.z * ROWS + j;
    write_band_partials(&a0, (job * dims.samples.z) * 3u * n + p, n, band);
    if (two) {
        write_band_partials(&a1, (job * dims.samples.z + 1u) * 3u * n + p, n, band);
    }
}
