// The difference view of the preview's compare mode: per pixel, how many stops the
// reconstruction is above (warm) or below (cool) the compared material, in the colour channel
// that differs most, on a diverging scale that is black where they agree. Both inputs are
// the renderers' linear radiance (times the exposure), one texel per pixel.

@group(0) @binding(0) var reconstruction: texture_2d<f32>;
@group(0) @binding(1) var material: texture_2d<f32>;

struct Options {
    // The stops at which the scale saturates.
    stops: f32,
    // Radiance added to both before the ratio: below display black, differences are noise.
    floor: f32,
    // 1 when this shader must sRGB-encode (the target is not an *Srgb format).
    encode: u32,
    pad: u32,
    // Linear colour off the object.
    background: vec4<f32>,
}
@group(0) @binding(2) var<uniform> options: Options;

struct Out {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
}

@vertex
fn vs_compare(@builtin(vertex_index) index: u32) -> Out {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: Out;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

// scene::srgb_encode.
fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let low = 12.92 * c;
    let high = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, c <= vec3<f32>(0.0031308));
}

// compare::difference_colour: t in [-1, 1], black at 0, blue below, orange above.
fn diverging(t: f32) -> vec3<f32> {
    let cool = vec3<f32>(0.25, 0.55, 1.0);
    let warm = vec3<f32>(1.0, 0.5, 0.1);
    return select(cool, warm, t > 0.0) * abs(t);
}

@fragment
fn fs_compare(in: Out) -> @location(0) vec4<f32> {
    let size = textureDimensions(reconstruction);
    let texel = min(vec2<u32>(in.uv * vec2<f32>(size)), size - 1u);
    let a = textureLoad(reconstruction, texel, 0);
    let b = textureLoad(material, texel, 0);
    var c = options.background.rgb;
    if a.w > 0.0 || b.w > 0.0 {
        let d = log2((max(a.rgb, vec3<f32>(0.0)) + options.floor)
            / (max(b.rgb, vec3<f32>(0.0)) + options.floor));
        var m = d.x;
        if abs(d.y) > abs(m) {
            m = d.y;
        }
        if abs(d.z) > abs(m) {
            m = d.z;
        }
        c = diverging(clamp(m / options.stops, -1.0, 1.0));
    }
    c = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    if options.encode != 0u {
        c = srgb_encode(c);
    }
    return vec4<f32>(c, 1.0);
}
