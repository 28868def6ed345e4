//! Guide scenes (SCENE.md): one object, one directional light, one camera.
//!
//! A [`Scene`] file names the object and the viewing set-up; [`Object`] is its geometry,
//! centred at the origin and scaled to a unit bounding sphere; [`GBuffer`] says, per pixel,
//! which surface point is seen, its shading frame and the light and view bins (TABLE.md).
//! From the geometry buffer come the [`guide_image`] the artist paints over, the
//! [`samples_from_image`] that turn a painting into BRDF samples, and the renders
//! ([`render_table`], [`render_brdf`]) that show what a perfect painter would have painted.
//!
//! Conventions beyond SCENE.md: meshes are centred on their bounding-box centre; where the
//! tangent reference is parallel to the normal, the world axis least aligned with the normal
//! stands in for it ([`tangent_frame`]); pixels with cos θ_l or cos θ_v below [`MIN_COS`]
//! give no samples.

mod bvh;
mod camera;
mod file;
mod gbuffer;
mod image_files;
mod mesh;
mod object;
mod render;
mod samples;
mod shapes;
mod source;

pub use camera::{CameraRig, ORTHO_DISTANCE, OrbitAxes, light_direction};
pub use file::{CameraSettings, LightSettings, MAX_RESOLUTION, Projection, Scene};
pub use gbuffer::{GBuffer, SurfacePoint, tangent_frame};
pub use image_files::{
    decode_painting, decode_png_linear, read_painting, read_png_linear, srgb_decode, srgb_encode,
    write_image, write_png,
};
pub use mesh::Mesh;
pub use object::Object;
pub use render::{
    BACKGROUND, GUIDE_ALBEDO, SHADOW, guide_image, guide_pixel, render_brdf, render_table,
};
pub use samples::{
    LDR_BLACK_BOUND, MIN_COS, PaintRange, Sample, SampleCounts, SampleSet, SkipReason,
    eight_bit_log_half_step, paint_range_of, sample_pixel, sample_pixel_in, samples_from_file,
    samples_from_image, samples_from_image_in,
};
pub use source::{BuiltinShape, ObjectSource};
