// The preview's scene pass: the object (an analytic sphere traced per fragment, or a
// rasterised mesh) shaded with a tabulated BRDF, in linear radiance (TABLE.md: a directional
// light of irradiance π gives L = π · ρ · cos θ_l). Mirrors scene::render_table bin for bin
// when interpolation is off. The shadow pass's vertex stage lives here too.

const PI: f32 = 3.14159265358979;
const TAU: f32 = 6.28318530717959;
const HALF_PI: f32 = 1.57079632679490;
const THETA_BINS: u32 = 45u;
const PHI_BINS: u32 = 36u;

// Must match PreviewMode's discriminants in src/preview/frame.rs.
const MODE_RECONSTRUCTION: u32 = 0u;
const MODE_SPARSE: u32 = 1u;
const MODE_GUIDE: u32 = 2u;
const MODE_TABLE: u32 = 3u;

// scene::GUIDE_ALBEDO / π.
const GUIDE_RHO: f32 = 0.5 / PI;
// scene::render's HORIZON_LIFT: how far a below-horizon view is lifted (tan of the elevation).
const HORIZON_LIFT: f32 = 1e-3;
// Side in pixels of the checker that marks unobserved bins in sparse mode.
const CHECKER_PIXELS: f32 = 8.0;
// Sky directions the uniform holds at most; matches MAX_SKY_DIRECTIONS in frame.rs.
const MAX_SKY: u32 = 16u;

struct Frame {
    view_proj: mat4x4<f32>,
    light_view_proj: mat4x4<f32>,
    // xyz: the eye (perspective) or the centre of the ray plane (orthographic); w: 1 perspective.
    eye: vec4<f32>,
    // xyz: unit vector from the origin toward the camera.
    toward: vec4<f32>,
    // xyz: image right / up in world space; w: half the image extent along it.
    right: vec4<f32>,
    up: vec4<f32>,
    // width, height, 1 / width, 1 / height of the target in pixels.
    viewport: vec4<f32>,
    tangent_reference: vec4<f32>,
    // xyz: unit vector toward the light; w: irradiance in units of π (0: off).
    light0: vec4<f32>,
    light1: vec4<f32>,
    shadow_colour: vec4<f32>,
    unobserved_a: vec4<f32>,
    unobserved_b: vec4<f32>,
    // mode, interpolate, shadows, sky direction count.
    flags: vec4<u32>,
    // exposure scale, shadow normal offset, shadow depth bias, unused.
    scalars: vec4<f32>,
    // xyz: unit direction toward a patch of sky; w: its irradiance weight (radiance · solid angle).
    sky: array<vec4<f32>, 16>,
}

@group(0) @binding(0) var<uniform> frame: Frame;
// ρ per unordered pair, 3 floats each (the table, or the GPU-evaluated reconstruction).
@group(0) @binding(1) var<storage, read> values: array<f32>;
// Sparse bins, 2 words per pair: pack2x16float(r, g), pack2x16float(b, observed).
@group(0) @binding(2) var<storage, read> sparse: array<u32>;
@group(0) @binding(3) var shadow_map: texture_depth_2d;
@group(0) @binding(4) var shadow_sampler: sampler_comparison;
// Per pair: set to 1 when the reconstruction is read there, so that new coefficients can be
// evaluated only for the pairs this view reads (shaders/view_pairs.wgsl).
@group(0) @binding(5) var<storage, read_write> marked: array<u32>;

// table::pair_index.
fn pair_index(a: u32, b: u32) -> u32 {
    let lo = min(a, b);
    let hi = max(a, b);
    return hi * (hi + 1u) / 2u + lo;
}

fn table_value(a: u32, b: u32) -> vec3<f32> {
    let pair = pair_index(a, b);
    if frame.flags.x == MODE_RECONSTRUCTION {
        marked[pair] = 1u;
    }
    let i = 3u * pair;
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

// The four bins around a direction and their bilinear weights in (θ, φ), centre to centre;
// θ clamps at the first and last bin centres, φ wraps around.
struct Taps {
    bins: vec4<u32>,
    weights: vec4<f32>,
}

fn taps(w: vec3<f32>) -> Taps {
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
    out.weights = vec4<f32>((1.0 - ft) * (1.0 - fp), (1.0 - ft) * fp, ft * (1.0 - fp), ft * fp);
    return out;
}

// ρ of the table or reconstruction for unit local directions l and v (both above the horizon).
fn table_rho(l: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    if frame.flags.y == 0u {
        return table_value(nearest_bin(l), nearest_bin(v));
    }
    let tl = taps(l);
    let tv = taps(v);
    var rho = vec3<f32>(0.0);
    for (var i = 0u; i < 4u; i++) {
        if tl.weights[i] == 0.0 {
            continue;
        }
        for (var j = 0u; j < 4u; j++) {
            let w = tl.weights[i] * tv.weights[j];
            if w != 0.0 {
                rho += w * table_value(tl.bins[i], tv.bins[j]);
            }
        }
    }
    return rho;
}

// ρ of the current mode for unit local directions (sparse mode is handled by the caller).
fn mode_rho(l: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    if frame.flags.x == MODE_GUIDE {
        return vec3<f32>(GUIDE_RHO);
    }
    return table_rho(l, v);
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

fn unobserved(pixel: vec2<f32>) -> vec3<f32> {
    let cell = vec2<u32>(floor(pixel / CHECKER_PIXELS));
    if ((cell.x + cell.y) & 1u) == 0u {
        return frame.unobserved_a.rgb;
    }
    return frame.unobserved_b.rgb;
}

// Linear radiance of surface point p with unit normal n, `visibility` of the main light
// (1 lit, 0 in a cast shadow), scaled by the exposure.
fn shade(p: vec3<f32>, n: vec3<f32>, visibility: f32, pixel: vec2<f32>) -> vec3<f32> {
    let x = tangent_of(n, frame.tangent_reference.xyz);
    let y = cross(n, x);
    var view_world = frame.toward.xyz;
    if frame.eye.w > 0.5 {
        view_world = normalize(frame.eye.xyz - p);
    }
    let vw = vec3<f32>(dot(view_world, x), dot(view_world, y), dot(view_world, n));
    let view = view_above_horizon(vw);
    let mode = frame.flags.x;
    let l0w = frame.light0.xyz;
    let l0 = vec3<f32>(dot(l0w, x), dot(l0w, y), dot(l0w, n));

    var colour = frame.shadow_colour.rgb;
    if l0.z > 0.0 && visibility > 0.0 && view.w > 0.0 {
        let l = normalize(l0);
        var lit: vec3<f32>;
        if mode == MODE_SPARSE {
            let s = sparse_value(nearest_bin(l), nearest_bin(view.xyz));
            if s.w < 0.5 {
                return unobserved(pixel);
            }
            lit = PI * s.rgb * l0.z * frame.light0.w;
        } else {
            lit = PI * mode_rho(l, view.xyz) * l0.z * frame.light0.w;
        }
        colour = mix(colour, lit, visibility);
    }
    // Sparse mode shows what the paintings give: the main light only.
    if mode != MODE_SPARSE && view.w > 0.0 {
        if frame.light1.w > 0.0 {
            let lw = frame.light1.xyz;
            let l = vec3<f32>(dot(lw, x), dot(lw, y), dot(lw, n));
            if l.z > 0.0 {
                colour += PI * mode_rho(normalize(l), view.xyz) * l.z * frame.light1.w;
            }
        }
        let sky_count = min(frame.flags.w, MAX_SKY);
        for (var i = 0u; i < sky_count; i++) {
            let s = frame.sky[i];
            let l = vec3<f32>(dot(s.xyz, x), dot(s.xyz, y), dot(s.xyz, n));
            if l.z > 0.0 {
                colour += mode_rho(normalize(l), view.xyz) * l.z * s.w;
            }
        }
    }
    return max(colour, vec3<f32>(0.0)) * frame.scalars.x;
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

// ---- the analytic sphere: one full-screen triangle, a ray per fragment ----

struct SphereOut {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_sphere(@builtin(position) position: vec4<f32>) -> SphereOut {
    // Pixel centres, as scene::CameraRig::pixel_ray casts them.
    let s = (position.x * frame.viewport.z * 2.0 - 1.0) * frame.right.w;
    let t = (1.0 - position.y * frame.viewport.w * 2.0) * frame.up.w;
    let offset = frame.right.xyz * s + frame.up.xyz * t;
    var origin = frame.eye.xyz + offset;
    var dir = -frame.toward.xyz;
    if frame.eye.w > 0.5 {
        origin = frame.eye.xyz;
        dir = normalize(offset - frame.toward.xyz);
    }
    // The stable roots of |o + t d|² = 1, as scene::object's sphere_hit.
    let b = dot(origin, dir);
    let c = dot(origin, origin) - 1.0;
    let disc = b * b - c;
    if disc < 0.0 {
        discard;
    }
    let root = sqrt(disc);
    let q = -(b + select(-root, root, b >= 0.0));
    if q == 0.0 {
        discard;
    }
    let r0 = min(q, c / q);
    let r1 = max(q, c / q);
    var hit_t = r0;
    if !(r0 > 0.0) {
        hit_t = r1;
    }
    if !(hit_t > 0.0) {
        discard;
    }
    let hit = origin + dir * hit_t;
    var out: SphereOut;
    // A convex sphere casts no shadow on itself.
    out.colour = vec4<f32>(shade(hit, normalize(hit), 1.0, position.xy), 1.0);
    let clip = frame.view_proj * vec4<f32>(hit, 1.0);
    out.depth = clamp(clip.z / clip.w, 0.0, 1.0);
    return out;
}

// ---- meshes ----

struct MeshIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

struct MeshOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

@vertex
fn vs_mesh(vertex: MeshIn) -> MeshOut {
    var out: MeshOut;
    out.clip = frame.view_proj * vec4<f32>(vertex.position, 1.0);
    out.world = vertex.position;
    out.normal = vertex.normal;
    return out;
}

@fragment
fn fs_mesh(in: MeshOut) -> @location(0) vec4<f32> {
    // The face's own normal, turned toward the camera: where opposed vertex normals cancel,
    // the face is the best guess (as in scene::Object::intersect).
    var geometric = cross(dpdx(in.world), dpdy(in.world));
    var view_world = frame.toward.xyz;
    if frame.eye.w > 0.5 {
        view_world = frame.eye.xyz - in.world;
    }
    if dot(geometric, view_world) < 0.0 {
        geometric = -geometric;
    }
    var n = in.normal;
    if !(length(n) > 1e-12) {
        n = geometric;
    }
    n = normalize(n);
    let visibility = main_light_visibility(in.world, n);
    return vec4<f32>(shade(in.world, n, visibility, in.clip.xy), 1.0);
}

// Depth from the main light, for cast shadows.
@vertex
fn vs_shadow(vertex: MeshIn) -> @builtin(position) vec4<f32> {
    return frame.light_view_proj * vec4<f32>(vertex.position, 1.0);
}
