// The preview's shading (after shaders/frame.wgsl), in two compute passes over the pixels.
//
// `setup` runs when the geometry changes (camera, lights, object, size): from the raster's
// position and normal it works out each pixel's shading frame, the light and view bins with
// their interpolation fractions, cos θ_l × irradiance × shadow, and stores them in a record;
// it also marks every table pair the pixel will read (shaders/view_pairs.wgsl lists them).
// `gather` runs when ρ changes (a new snapshot, sparse bins, a table) or the exposure does:
// it only reads the records and the table. Radiance follows TABLE.md (a directional light of
// irradiance π gives L = π · ρ · cos θ_l) and mirrors scene::render_table bin for bin when
// interpolation is off.

// scene::GUIDE_ALBEDO / π.
const GUIDE_RHO: f32 = 0.5 / PI;
// scene::render's HORIZON_LIFT: how far a below-horizon view is lifted (tan of the elevation).
const HORIZON_LIFT: f32 = 1e-3;
// Side in pixels of the checker that marks unobserved bins in sparse mode.
const CHECKER_PIXELS: f32 = 8.0;

// Per pixel record, RECORD u32 words (RECORD_WORDS in src/preview/renderer.rs):
//   0 flags, 1 weight of the shadow colour,
//   2-5 view taps (2 words of 4 × u16 bins, the θ and φ fractions as f32),
//   6-9 main light taps, 10 its factor (π cos θ_l × irradiance × visibility),
//   11-14 second light taps, 15 its factor,
//   16-18 the unit normal (for the environment), 19 the view's nearest bin.
const RECORD: u32 = 20u;
const COVERED: u32 = 1u;
const MAIN_LIGHT: u32 = 2u;
const SECOND_LIGHT: u32 = 4u;
const ENVIRONMENT: u32 = 8u;

// ρ per unordered pair, 3 floats each (the table, or the GPU-evaluated reconstruction).
@group(0) @binding(1) var<storage, read> values: array<f32>;
// Sparse bins, 2 words per pair: pack2x16float(r, g), pack2x16float(b, observed).
@group(0) @binding(2) var<storage, read> sparse: array<u32>;
@group(0) @binding(3) var position_map: texture_2d<f32>;
@group(0) @binding(4) var normal_map: texture_2d<f32>;
@group(0) @binding(5) var shadow_map: texture_depth_2d;
@group(0) @binding(6) var shadow_sampler: sampler_comparison;
@group(0) @binding(7) var<storage, read_write> records: array<u32>;
// Per pair: set to 1 where the view reads the reconstruction, so that new coefficients can be
// evaluated only for those pairs (shaders/view_pairs.wgsl).
@group(0) @binding(8) var<storage, read_write> marked: array<u32>;
// Per environment direction: (unit world direction, 0), (irradiance weight rgb, 0).
@group(0) @binding(9) var<storage, read> environment: array<vec4<f32>>;
@group(0) @binding(10) var radiance: texture_storage_2d<rgba32float, write>;

// table::pair_index.
fn pair_index(a: u32, b: u32) -> u32 {
    let lo = min(a, b);
    let hi = max(a, b);
    return hi * (hi + 1u) / 2u + lo;
}

fn table_value(a: u32, b: u32) -> vec3<f32> {
    let i = 3u * pair_index(a, b);
    return vec3<f32>(values[i], values[i + 1u], values[i + 2u]);
}

// rgb and the observed flag (1 observed, 0 not).
fn sparse_value(a: u32, b: u32) -> vec4<f32> {
    let i = 2u * pair_index(a, b);
    return vec4<f32>(unpack2x16float(sparse[i]), unpack2x16float(sparse[i + 1u]));
}

// Azimuth in [0, 2π).
fn azimuth(w: vec3<f32>) -> f32 {
    let phi = atan2(w.y, w.x);
    return select(phi, phi + TAU, phi < 0.0);
}

// table::direction_index of a unit direction above the horizon.
fn nearest_bin(w: vec3<f32>) -> u32 {
    let theta = acos(clamp(w.z, -1.0, 1.0));
    let t = min(u32(floor(theta / HALF_PI * f32(THETA_BINS))), THETA_BINS - 1u);
    let p = u32(floor(azimuth(w) / TAU * f32(PHI_BINS))) % PHI_BINS;
    return PHI_BINS * t + p;
}

// The four bins around a direction and the fractions (θ, φ) of the way from the first to
// the last, centre to centre; θ clamps at the first and last bin centres, φ wraps around.
// Nearest: the nearest bin four times, fractions 0.
struct Taps {
    bins: vec4<u32>,
    fraction: vec2<f32>,
}

fn nearest_taps(w: vec3<f32>) -> Taps {
    var out: Taps;
    out.bins = vec4<u32>(nearest_bin(w));
    out.fraction = vec2<f32>(0.0);
    return out;
}

fn bilinear_taps(w: vec3<f32>) -> Taps {
    let theta = acos(clamp(w.z, -1.0, 1.0));
    let ut = theta / HALF_PI * f32(THETA_BINS) - 0.5;
    var ta = 0u;
    var tb = 0u;
    var ft = 0.0;
    if ut >= f32(THETA_BINS - 1u) {
        ta = THETA_BINS - 1u;
        tb = ta;
    } else if ut > 0.0 {
        let t0 = floor(ut);
        ta = u32(t0);
        tb = ta + 1u;
        ft = ut - t0;
    }
    let up = azimuth(w) / TAU * f32(PHI_BINS) - 0.5;
    let p0 = floor(up);
    let fp = up - p0;
    let pa = u32(p0 + f32(PHI_BINS)) % PHI_BINS;
    let pb = (pa + 1u) % PHI_BINS;
    var out: Taps;
    out.bins = vec4<u32>(
        PHI_BINS * ta + pa,
        PHI_BINS * ta + pb,
        PHI_BINS * tb + pa,
        PHI_BINS * tb + pb,
    );
    out.fraction = vec2<f32>(ft, fp);
    return out;
}

fn taps_of(w: vec3<f32>) -> Taps {
    if frame.flags.y == 0u || frame.flags.x == MODE_SPARSE {
        return nearest_taps(w);
    }
    return bilinear_taps(w);
}

fn weights(t: Taps) -> vec4<f32> {
    let ft = t.fraction.x;
    let fp = t.fraction.y;
    return vec4<f32>((1.0 - ft) * (1.0 - fp), (1.0 - ft) * fp, ft * (1.0 - fp), ft * fp);
}

fn store_taps(at: u32, t: Taps) {
    records[at] = t.bins.x | (t.bins.y << 16u);
    records[at + 1u] = t.bins.z | (t.bins.w << 16u);
    records[at + 2u] = bitcast<u32>(t.fraction.x);
    records[at + 3u] = bitcast<u32>(t.fraction.y);
}

fn load_taps(at: u32) -> Taps {
    let a = records[at];
    let b = records[at + 1u];
    var out: Taps;
    out.bins = vec4<u32>(a & 0xFFFFu, a >> 16u, b & 0xFFFFu, b >> 16u);
    out.fraction = vec2<f32>(bitcast<f32>(records[at + 2u]), bitcast<f32>(records[at + 3u]));
    return out;
}

// Marks the pairs `rho_of_taps` reads for these taps.
fn mark_taps(light: Taps, view: Taps) {
    let wl = weights(light);
    let wv = weights(view);
    for (var i = 0u; i < 4u; i++) {
        if wl[i] == 0.0 {
            continue;
        }
        for (var j = 0u; j < 4u; j++) {
            if wl[i] * wv[j] != 0.0 {
                marked[pair_index(light.bins[i], view.bins[j])] = 1u;
            }
        }
    }
}

// ρ of the current mode for a light's and the view's taps (sparse mode is handled apart).
fn rho_of_taps(light: Taps, view: Taps) -> vec3<f32> {
    if frame.flags.x == MODE_GUIDE {
        return vec3<f32>(GUIDE_RHO);
    }
    let wl = weights(light);
    let wv = weights(view);
    var rho = vec3<f32>(0.0);
    for (var i = 0u; i < 4u; i++) {
        if wl[i] == 0.0 {
            continue;
        }
        for (var j = 0u; j < 4u; j++) {
            let w = wl[i] * wv[j];
            if w != 0.0 {
                rho += w * table_value(light.bins[i], view.bins[j]);
            }
        }
    }
    return rho;
}

// The tap of the four that weighs most: what a draft reads instead of the bilinear mix (one
// table read for up to sixteen), always a pair the set-up marked.
fn dominant_bin(t: Taps) -> u32 {
    return t.bins[select(0u, 2u, t.fraction.x > 0.5) + select(0u, 1u, t.fraction.y > 0.5)];
}

// ρ for a light's and the view's taps: bilinear, or in a draft at the dominant taps alone.
fn rho_for(light: Taps, view: Taps, draft: bool) -> vec3<f32> {
    if draft && frame.flags.x != MODE_GUIDE {
        return table_value(dominant_bin(light), dominant_bin(view));
    }
    return rho_of_taps(light, view);
}

// scene::tangent_frame: x = normalize(r − (r·n) n), y = n × x; where r ∥ n the world axis least
// aligned with n stands in. The parallel test is relative 1e-6 rather than the engine's 1e-9:
// single precision cannot tell closer than that.
fn tangent_of(n: vec3<f32>, r: vec3<f32>) -> vec3<f32> {
    var x = r - dot(r, n) * n;
    if length(x) <= 1e-6 * length(r) {
        let a = abs(n);
        var axis = vec3<f32>(0.0, 0.0, 1.0);
        if a.x <= a.y && a.x <= a.z {
            axis = vec3<f32>(1.0, 0.0, 0.0);
        } else if a.y <= a.z {
            axis = vec3<f32>(0.0, 1.0, 0.0);
        }
        x = axis - dot(axis, n) * n;
    }
    return normalize(x);
}

// scene::render's view_above_horizon: xyz the unit view, w 1 when there is one.
fn view_above_horizon(v: vec3<f32>) -> vec4<f32> {
    if v.z > 0.0 {
        return vec4<f32>(normalize(v), 1.0);
    }
    let h = length(v.xy);
    if !(h > 0.0) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(normalize(vec3<f32>(v.xy / h, HORIZON_LIFT)), 1.0);
}

// How much of the main light reaches world point p (normal n), from the shadow map.
fn main_light_visibility(p: vec3<f32>, n: vec3<f32>) -> f32 {
    if frame.flags.z == 0u {
        return 1.0;
    }
    let clip = frame.light_view_proj * vec4<f32>(p + n * frame.scalars.y, 1.0);
    let ndc = clip.xyz / clip.w;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    return textureSampleCompareLevel(shadow_map, shadow_sampler, uv, ndc.z - frame.scalars.z);
}

fn in_viewport(id: vec3<u32>) -> bool {
    return id.x < u32(frame.viewport.x) && id.y < u32(frame.viewport.y);
}

fn record_of(id: vec3<u32>) -> u32 {
    return RECORD * (id.y * u32(frame.viewport.x) + id.x);
}

@compute @workgroup_size(8, 8)
fn setup(@builtin(global_invocation_id) id: vec3<u32>) {
    if !in_viewport(id) {
        return;
    }
    let r = record_of(id);
    let position = textureLoad(position_map, id.xy, 0);
    if position.w == 0.0 {
        records[r] = 0u;
        return;
    }
    let p = position.xyz;
    let n = textureLoad(normal_map, id.xy, 0).xyz;
    let x = tangent_of(n, frame.tangent_reference.xyz);
    let y = cross(n, x);
    var view_world = frame.toward.xyz;
    if frame.eye.w > 0.5 {
        view_world = normalize(frame.eye.xyz - p);
    }
    let view = view_above_horizon(vec3<f32>(dot(view_world, x), dot(view_world, y), dot(view_world, n)));
    let mode = frame.flags.x;
    let marking = mode == MODE_RECONSTRUCTION;
    var flags = COVERED;
    var shadow_weight = 1.0;
    if view.w > 0.0 {
        let view_taps = taps_of(view.xyz);
        store_taps(r + 2u, view_taps);
        let l0w = frame.light0.xyz;
        let l0 = vec3<f32>(dot(l0w, x), dot(l0w, y), dot(l0w, n));
        let visibility = main_light_visibility(p, n);
        if l0.z > 0.0 && visibility > 0.0 {
            let light = taps_of(normalize(l0));
            flags |= MAIN_LIGHT;
            store_taps(r + 6u, light);
            records[r + 10u] = bitcast<u32>(PI * l0.z * frame.light0.w * visibility);
            shadow_weight = 1.0 - visibility;
            if marking {
                mark_taps(light, view_taps);
            }
        }
        // Sparse mode shows what the paintings give: the main light only.
        if mode != MODE_SPARSE && frame.light1.w > 0.0 {
            let lw = frame.light1.xyz;
            let l = vec3<f32>(dot(lw, x), dot(lw, y), dot(lw, n));
            if l.z > 0.0 {
                let light = taps_of(normalize(l));
                flags |= SECOND_LIGHT;
                store_taps(r + 11u, light);
                records[r + 15u] = bitcast<u32>(PI * l.z * frame.light1.w);
                if marking {
                    mark_taps(light, view_taps);
                }
            }
        }
        let count = frame.flags.w;
        if count > 0u {
            flags |= ENVIRONMENT;
            records[r + 16u] = bitcast<u32>(n.x);
            records[r + 17u] = bitcast<u32>(n.y);
            records[r + 18u] = bitcast<u32>(n.z);
            let view_bin = nearest_bin(view.xyz);
            records[r + 19u] = view_bin;
            if marking {
                for (var i = 0u; i < count; i++) {
                    let d = environment[2u * i].xyz;
                    let l = vec3<f32>(dot(d, x), dot(d, y), dot(d, n));
                    if l.z > 0.0 {
                        marked[pair_index(nearest_bin(normalize(l)), view_bin)] = 1u;
                    }
                }
            }
        }
    }
    records[r] = flags;
    records[r + 1u] = bitcast<u32>(shadow_weight);
}

fn unobserved(pixel: vec2<f32>) -> vec3<f32> {
    let cell = vec2<u32>(floor(pixel / CHECKER_PIXELS));
    if ((cell.x + cell.y) & 1u) == 0u {
        return frame.unobserved_a.rgb;
    }
    return frame.unobserved_b.rgb;
}

// The radiance of pixel `xy` (alpha 1 on the object, 0 off it).
fn shade_at(xy: vec2<u32>, draft: bool) -> vec4<f32> {
    let r = RECORD * (xy.y * u32(frame.viewport.x) + xy.x);
    let flags = records[r];
    if (flags & COVERED) == 0u {
        // Alpha 0 marks the background (the object has 1), for `pick`.
        return vec4<f32>(frame.background.rgb, 0.0);
    }
    let mode = frame.flags.x;
    var colour = frame.shadow_colour.rgb * bitcast<f32>(records[r + 1u]);
    let view = load_taps(r + 2u);
    if (flags & MAIN_LIGHT) != 0u {
        let light = load_taps(r + 6u);
        let factor = bitcast<f32>(records[r + 10u]);
        if mode == MODE_SPARSE {
            let s = sparse_value(light.bins.x, view.bins.x);
            if s.w < 0.5 {
                return vec4<f32>(unobserved(vec2<f32>(xy) + 0.5), 1.0);
            }
            colour += s.rgb * factor;
        } else {
            colour += rho_for(light, view, draft) * factor;
        }
    }
    if (flags & SECOND_LIGHT) != 0u {
        colour += rho_for(load_taps(r + 11u), view, draft) * bitcast<f32>(records[r + 15u]);
    }
    if (flags & ENVIRONMENT) != 0u {
        let n = vec3<f32>(
            bitcast<f32>(records[r + 16u]),
            bitcast<f32>(records[r + 17u]),
            bitcast<f32>(records[r + 18u]),
        );
        let x = tangent_of(n, frame.tangent_reference.xyz);
        let y = cross(n, x);
        let view_bin = records[r + 19u];
        let guide = mode == MODE_GUIDE;
        var sum = vec3<f32>(0.0);
        let share = frame.scalars.w;
        let used = u32(f32(frame.flags.w) / share);
        for (var i = 0u; i < used; i++) {
            let d = environment[2u * i].xyz;
            let l = vec3<f32>(dot(d, x), dot(d, y), dot(d, n));
            if l.z > 0.0 {
                var rho = vec3<f32>(GUIDE_RHO);
                if !guide {
                    rho = table_value(nearest_bin(normalize(l)), view_bin);
                }
                sum += rho * environment[2u * i + 1u].rgb * l.z;
            }
        }
        colour += sum * share;
    }
    return vec4<f32>(max(colour, vec3<f32>(0.0)) * frame.scalars.x, 1.0);
}

@compute @workgroup_size(8, 8)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    if in_viewport(id) {
        textureStore(radiance, id.xy, shade_at(id.xy, false));
    }
}

fn covered(xy: vec2<u32>) -> bool {
    return (records[RECORD * (xy.y * u32(frame.viewport.x) + xy.x)] & COVERED) != 0u;
}

// The draft gather, while a stroke is being painted: one pixel of each 2 × 2 block is shaded,
// at the dominant bilinear taps (the nearest bins), and stands for the block's other pixels
// on the object: a quarter of the pixels and, interpolating, a sixteenth of the table reads
// of each; the silhouette stays exact. The full gather refines it when the stroke ends.
@compute @workgroup_size(8, 8)
fn gather_draft(@builtin(global_invocation_id) id: vec3<u32>) {
    let base = id.xy * 2u;
    let size = vec2<u32>(frame.viewport.xy);
    if base.x >= size.x || base.y >= size.y {
        return;
    }
    var colour = vec4<f32>(frame.background.rgb, 0.0);
    for (var k = 0u; k < 4u; k++) {
        let p = base + vec2<u32>(k & 1u, k >> 1u);
        if p.x < size.x && p.y < size.y && covered(p) {
            colour = shade_at(p, true);
            break;
        }
    }
    for (var k = 0u; k < 4u; k++) {
        let p = base + vec2<u32>(k & 1u, k >> 1u);
        if p.x < size.x && p.y < size.y {
            if covered(p) {
                textureStore(radiance, p, colour);
            } else {
                textureStore(radiance, p, vec4<f32>(frame.background.rgb, 0.0));
            }
        }
    }
}
