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
