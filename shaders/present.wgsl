// Shows the scene pass's linear radiance on a display target: clamp to [0, 1] and, when the
// target does not encode sRGB itself, apply the sRGB transfer function. One texel per pixel.

@group(0) @binding(0) var radiance: texture_2d<f32>;
// x: 1 when this shader must sRGB-encode (the target is not an *Srgb format).
@group(0) @binding(1) var<uniform> options: vec4<u32>;

struct Out {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
}

@vertex
fn vs_present(@builtin(vertex_index) index: u32) -> Out {
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

@fragment
fn fs_present(in: Out) -> @location(0) vec4<f32> {
    let size = textureDimensions(radiance);
    let texel = min(vec2<u32>(in.uv * vec2<f32>(size)), size - 1u);
    var c = clamp(textureLoad(radiance, texel, 0).rgb, vec3<f32>(0.0), vec3<f32>(1.0));
    if options.x != 0u {
        c = srgb_encode(c);
    }
    return vec4<f32>(c, 1.0);
}
