// Adds the per-invocation partial sums of frame_sums (sums.wgsl) per (frame, context):
// one workgroup per (value, job), a strided sum then a tree (fixed order), in f64.
// Only these SUMS_LEN values per job are read back to the host. 64 lanes, not 256: on
// llvmpipe each barrier of the tree switches every SIMD group of the workgroup.

// Keep in sync with `ReduceDims` in crates/bpins-gpu/src/params.rs.
struct ReduceDims {
    size: vec4<u32>, // partials per job (invocations of frame_sums), jobs, 0, 0
}

@group(0) @binding(0) var<uniform> dims: ReduceDims;
@group(0) @binding(1) var<storage, read> partials: array<f64>;
@group(0) @binding(2) var<storage, read_write> sums: array<f64>;

const WG_SIZE: u32 = 64u;
var<workgroup> red1: array<f64, WG_SIZE>;

@compute @workgroup_size(64, 1, 1)
fn reduce_partials(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>) {
    let k = wid.x;
    let job = wid.y;
    let n = dims.size.x;
    var acc = 0.0lf;
    for (var p = li; p < n; p += WG_SIZE) {
        acc += partials[(job * n + p) * SUMS_LEN + k];
    }
    red1[li] = acc;
    workgroupBarrier();
    for (var s = WG_SIZE / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            red1[li] += red1[li + s];
        }
        workgroupBarrier();
    }
    if (li == 0u) {
        sums[job * SUMS_LEN + k] = red1[0];
    }
}

// The same sums on a CPU adapter (llvmpipe), where the tree's barriers cost more than
// the additions (each switches every SIMD group of the workgroup): one invocation per
// (value, job), no workgroup memory, no barrier; the partials added in blocks of
// WG_SIZE, in order, then the blocks' sums in order (no f32 sum runs over more than
// WG_SIZE + partials / WG_SIZE terms in series). The same values as reduce_partials to
// rounding (another fixed order). Global id x is value + SUMS_LEN · job.
@compute @workgroup_size(64, 1, 1)
fn reduce_partials_serial(@builtin(global_invocation_id) gid: vec3<u32>) {
    let n = dims.size.x;
    if (gid.x >= SUMS_LEN * dims.size.y) {
        return;
    }
    let job = gid.x / SUMS_LEN;
    let k = gid.x % SUMS_LEN;
    var total = 0.0lf;
    for (var b = 0u; b < n; b += WG_SIZE) {
        var block = 0.0lf;
        for (var p = b; p < min(b + WG_SIZE, n); p++) {
            block += partials[(job * n + p) * SUMS_LEN + k];
        }
        total += block;
    }
    sums[job * SUMS_LEN + k] = total;
}
