// The preview's geometry raster (after shaders/frame.wgsl): which surface point each pixel
// sees, as world position (w = 1 on the object, 0 off it) and unit shading normal, for
// shaders/shade.wgsl to turn into bins, weights and shadows. It runs only when the camera,
// lights, object or size change; painting never reruns it. The object is an analytic sphere
// traced per fragment or a rasterised mesh; the shadow pass's vertex stage lives here too.

struct GeometryOut {
    @location(0) position: vec4<f32>,
    @location(1) normal: vec4<f32>,
}

// ---- the analytic sphere: one full-screen triangle, a ray per fragment ----

struct SphereOut {
    @location(0) position: vec4<f32>,
    @location(1) normal: vec4<f32>,
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
    out.position = vec4<f32>(hit, 1.0);
    out.normal = vec4<f32>(normalize(hit), 0.0);
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
fn fs_mesh(in: MeshOut) -> GeometryOut {
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
    var out: GeometryOut;
    out.position = vec4<f32>(in.world, 1.0);
    out.normal = vec4<f32>(normalize(n), 0.0);
    return out;
}

// Depth from the main light, for cast shadows.
@vertex
fn vs_shadow(vertex: MeshIn) -> @builtin(position) vec4<f32> {
    return frame.light_view_proj * vec4<f32>(vertex.position, 1.0);
}
