// Lists the pairs the scene pass marked while drawing the reconstruction (the table entries
// the view reads), and sizes the indirect dispatch of reconstruct.wgsl's `reconstruct_listed`
// over them: new coefficients are then evaluated only where the view looks.

const WORKGROUP: u32 = 256u;

struct Params {
    pairs: u32,
    // Invocations along x of the `compact` dispatch (workgroups · 256): the stride of id.y.
    stride: u32,
    max_workgroups: u32,
    unused: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// Per pair: non-zero when the scene pass read it.
@group(0) @binding(1) var<storage, read> marked: array<u32>;
@group(0) @binding(2) var<storage, read_write> listed: array<u32>;
// The count, then the indirect dispatch's workgroups x, y, z. Cleared before `compact`.
@group(0) @binding(3) var<storage, read_write> counts: array<atomic<u32>, 4>;

@compute @workgroup_size(256)
fn compact(@builtin(global_invocation_id) id: vec3<u32>) {
    let pair = id.x + id.y * params.stride;
    if pair < params.pairs && marked[pair] != 0u {
        listed[atomicAdd(&counts[0], 1u)] = pair;
    }
}

@compute @workgroup_size(1)
fn size_dispatch() {
    let groups = (atomicLoad(&counts[0]) + WORKGROUP - 1u) / WORKGROUP;
    let x = max(min(groups, params.max_workgroups), 1u);
    atomicStore(&counts[1], x);
    atomicStore(&counts[2], (groups + x - 1u) / x);
    atomicStore(&counts[3], 1u);
}
