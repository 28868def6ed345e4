// Evaluates the reconstruction for every unordered direction pair (`reconstruct`), or for the
// pairs the current view reads (`reconstruct_listed`, over shaders/view_pairs.wgsl's list),
// exactly as solver::Reconstruction::eval_pair does: m = clamp(mean + Σ_k u_k x_k(θ_d),
// lower − margin, upper + margin) + o, ρ = max((e^m (reference + ε) − ε) / c, 0), with x(θ_d)
// the blend of the two coefficient sets around the pair's θ_d (solver::bands) and o a fitted
// reference's offsets (solver::fitted_mean; zero without one). It runs once per change of
// coefficients; the scene pass then reads the result like any table.

const MAP_EPSILON: f32 = 0.001;
const PHI_BINS: u32 = 36u;
const THETA_BINS: u32 = 45u;

struct Params {
    // u32 words per pair in `rows`: ceil(K / 2).
    row_words: u32,
    pairs: u32,
    // Invocations along x of the dispatch (workgroups · 256): the stride of id.y.
    stride: u32,
    // Coefficient sets (solver::BANDS).
    bands: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// Per coefficient set, per component k (padded to an even count): the R, G, B coefficients
// divided by the scale the components were stored with.
@group(0) @binding(1) var<storage, read> coefficients: array<vec4<f32>>;
// Per pair, ceil(K / 2) words of pack2x16float(u_2j · scale, u_2j+1 · scale).
@group(0) @binding(2) var<storage, read> rows: array<u32>;
// Per pair: (reference + ε, mean, lower − margin, upper + margin), as the engine computes them;
// then, at params.pairs + pair, the fitted reference's offsets (R, G, B, unused).
@group(0) @binding(3) var<storage, read> pair_range: array<vec4<f32>>;
// 1 / c for polar bins (t_lo, t_hi), 45 × 45, computed in double precision like the engine's.
@group(0) @binding(4) var<storage, read> inv_cos_weight: array<f32>;
// Output: ρ, 3 floats per pair.
@group(0) @binding(5) var<storage, read_write> rho: array<f32>;
// The pairs the view reads, and (count, workgroups x, y, z) of their indirect dispatch.
@group(0) @binding(6) var<storage, read> listed: array<u32>;
@group(0) @binding(7) var<storage, read> listed_counts: array<u32, 4>;
// Per pair: lower band + blend fraction toward the next (solver::bands::BandWeights).
@group(0) @binding(8) var<storage, read> band_position: array<f32>;

@compute @workgroup_size(256)
fn reconstruct(@builtin(global_invocation_id) id: vec3<u32>) {
    let pair = id.x + id.y * params.stride;
    if pair < params.pairs {
        evaluate(pair);
    }
}

@compute @workgroup_size(256)
fn reconstruct_listed(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.x + id.y * listed_counts[1] * 256u;
    if index < listed_counts[0] {
        evaluate(listed[index]);
    }
}

fn evaluate(pair: u32) {
    // table::pair_directions: hi is the largest integer with hi (hi + 1) / 2 <= pair.
    var hi = u32((sqrt(f32(8u * pair + 1u)) - 1.0) * 0.5);
    while hi * (hi + 1u) / 2u > pair {
        hi -= 1u;
    }
    while (hi + 1u) * (hi + 2u) / 2u <= pair {
        hi += 1u;
    }
    let lo = pair - hi * (hi + 1u) / 2u;
    let inv_c = inv_cos_weight[(lo / PHI_BINS) * THETA_BINS + hi / PHI_BINS];

    let position = band_position[pair];
    let lower = min(u32(floor(position)), params.bands - 2u);
    let frac = position - f32(lower);
    let set_stride = 2u * params.row_words;
    let first = lower * set_stride;
    var sum = dot_set(pair, first);
    if frac != 0.0 {
        let upper = dot_set(pair, first + set_stride);
        sum = sum + frac * (upper - sum);
    }
    let range = pair_range[pair];
    let offset = pair_range[params.pairs + pair].xyz;
    let m = clamp(range.y + sum, vec3<f32>(range.z), vec3<f32>(range.w)) + offset;
    let value = max((exp(m) * range.x - MAP_EPSILON) * inv_c, vec3<f32>(0.0));
    rho[3u * pair] = value.x;
    rho[3u * pair + 1u] = value.y;
    rho[3u * pair + 2u] = value.z;
}

// Σ_k u_k x_k for pair `pair` with the coefficient set starting at `first`.
fn dot_set(pair: u32, first: u32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let base = pair * params.row_words;
    for (var j = 0u; j < params.row_words; j++) {
        let u = unpack2x16float(rows[base + j]);
        sum += u.x * coefficients[first + 2u * j].xyz;
        sum += u.y * coefficients[first + 2u * j + 1u].xyz;
    }
    return sum;
}
