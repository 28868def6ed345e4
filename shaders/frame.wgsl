// The preview's frame uniform and the constants its passes share; prepended to
// shaders/preview.wgsl (the geometry raster) and shaders/shade.wgsl (set-up and gather).
// The layout of `FrameUniforms` in src/preview/frame.rs.

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
    // Linear colour off the object.
    background: vec4<f32>,
    // mode, interpolate, shadows, environment directions in use.
    flags: vec4<u32>,
    // exposure scale, shadow normal offset, shadow depth bias, and how many environment
    // directions one stands for in the gather (1, or 4 in a draft, which reads the first
    // quarter of them).
    scalars: vec4<f32>,
}

@group(0) @binding(0) var<uniform> frame: Frame;
