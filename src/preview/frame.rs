//! What one preview frame shows: plain data the UI edits, and its translation into the
//! scene pass's uniform block.

use crate::scene::{
    BACKGROUND, CameraSettings, LightSettings, ORTHO_DISTANCE, OrbitAxes, Projection, SHADOW, Scene,
};
use glam::{DMat4, DVec3, DVec4};

/// What ρ the object is drawn with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PreviewMode {
    /// The basis with the current coefficients, evaluated on the GPU.
    #[default]
    Reconstruction = 0,
    /// Only the bins the paintings observed; the others drawn as a neutral grey checker.
    SparseOnly = 1,
    /// The guide's grey Lambertian material, ρ = 0.5 / π.
    GuideMaterial = 2,
    /// A table uploaded with `PreviewRenderer::set_table`.
    Table = 3,
}

/// A camera orbiting the origin, as SCENE.md's: yaw turns it around y (0 puts it on +z),
/// pitch raises it, image up is world up at pitch 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    pub projection: Projection,
    pub yaw_deg: f64,
    pub pitch_deg: f64,
    /// Perspective: vertical field of view (of the shorter image side), in (0, 180).
    pub fov_deg: f64,
    /// Perspective: distance of the eye from the origin; above 1 (outside the object).
    pub distance: f64,
    /// Orthographic: half the side of the square the shorter image side spans (1 frames the
    /// unit bounding sphere, as a scene's orthographic camera does).
    pub ortho_half_extent: f64,
}

impl OrbitCamera {
    /// The eye distance at which a perspective camera of this field of view just frames the
    /// unit bounding sphere (what a scene's perspective camera uses).
    pub fn framing_distance(fov_deg: f64) -> f64 {
        1.0 / (fov_deg.to_radians() / 2.0).sin()
    }

    /// The camera of a scene file.
    pub fn from_settings(camera: &CameraSettings) -> Self {
        Self {
            projection: camera.projection,
            yaw_deg: camera.yaw_deg,
            pitch_deg: camera.pitch_deg,
            fov_deg: camera.fov_deg,
            distance: Self::framing_distance(camera.fov_deg),
            ortho_half_extent: 1.0,
        }
    }
}

impl Default for OrbitCamera {
    fn default() -> Self {
        Self::from_settings(&CameraSettings::default())
    }
}

/// A white directional light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Angle above the world's horizontal x-z plane (y is up).
    pub elevation_deg: f64,
    /// Around y: 0 points toward +z, 90 toward +x (SCENE.md).
    pub azimuth_deg: f64,
    /// Irradiance at normal incidence in units of π: 1 is the guide's light.
    pub intensity: f64,
}

impl DirectionalLight {
    pub fn from_settings(light: &LightSettings) -> Self {
        Self {
            elevation_deg: light.elevation_deg,
            azimuth_deg: light.azimuth_deg,
            intensity: 1.0,
        }
    }

    /// Unit vector toward the light, world space (scene::light_direction).
    pub fn direction(&self) -> DVec3 {
        crate::scene::light_direction(&LightSettings {
            elevation_deg: self.elevation_deg,
            azimuth_deg: self.azimuth_deg,
        })
    }
}

impl Default for DirectionalLight {
    fn default() -> Self {
        Self::from_settings(&LightSettings::default())
    }
}

/// Light from the renderer's environment image (see [`super::Environment`]): its sampled
/// directions, each evaluated through the BRDF table like a directional light. No cast shadows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentLight {
    /// Multiplies the image's radiance.
    pub intensity: f64,
    /// Turns the environment about the vertical, in degrees (toward +x from +z).
    pub rotation_deg: f64,
}

impl Default for EnvironmentLight {
    fn default() -> Self {
        Self {
            intensity: 1.0,
            rotation_deg: 0.0,
        }
    }
}

/// Everything one preview frame shows, as plain data.
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewFrame {
    pub mode: PreviewMode,
    pub camera: OrbitCamera,
    /// The main light; it casts the shadows.
    pub light: DirectionalLight,
    /// An optional fill light (no cast shadows).
    pub second_light: Option<DirectionalLight>,
    /// An optional environment light (no cast shadows).
    pub environment: Option<EnvironmentLight>,
    /// Cast shadows of the main light on meshes, from a shadow map. (A sphere, being convex,
    /// never shadows itself.)
    pub shadows: bool,
    /// Interpolate ρ between bin centres, bilinearly in the polar angle and the azimuth of
    /// both the light and the view (16 bins per light); off: the nearest bins, exactly as
    /// `scene::render_table`. Sparse mode always uses the nearest bins.
    pub interpolate: bool,
    /// Radiance is multiplied by 2^exposure before display.
    pub exposure_stops: f64,
    /// World vector projected onto the surface to give φ = 0 (SCENE.md).
    pub tangent_reference: [f64; 3],
    /// Linear colour off the object.
    pub background: [f32; 3],
    /// Shade one pixel of each 2 × 2 block for the others, at the nearest bins even when
    /// `interpolate` is set (a quarter of the pixels, one table read each instead of up to
    /// sixteen), as while a stroke is being painted; the full frame refines it.
    pub draft: bool,
}

impl Default for PreviewFrame {
    fn default() -> Self {
        Self::from_scene(&Scene::default())
    }
}

impl PreviewFrame {
    /// A scene's camera, light, shadows and tangent reference exactly, main light only,
    /// nearest bins: the frame in which the preview reproduces `burnish render`.
    pub fn from_scene(scene: &Scene) -> Self {
        Self {
            mode: PreviewMode::Reconstruction,
            camera: OrbitCamera::from_settings(&scene.camera),
            light: DirectionalLight::from_settings(&scene.light),
            second_light: None,
            environment: None,
            shadows: scene.shadows,
            interpolate: false,
            exposure_stops: 0.0,
            tangent_reference: scene.tangent_reference,
            background: BACKGROUND,
            draft: false,
        }
    }

    /// The problem, as a sentence, with a value the renderer cannot use.
    pub fn check(&self) -> Result<(), String> {
        let c = &self.camera;
        let finite = [
            c.yaw_deg,
            c.pitch_deg,
            self.light.elevation_deg,
            self.light.azimuth_deg,
            self.light.intensity,
            self.exposure_stops,
        ];
        if finite.iter().any(|v| !v.is_finite()) {
            return Err("camera angles, light and exposure must be finite".into());
        }
        match c.projection {
            Projection::Perspective => {
                if !(c.fov_deg > 0.0 && c.fov_deg < 180.0) {
                    return Err(format!(
                        "field of view {}° must be above 0 and below 180",
                        c.fov_deg
                    ));
                }
                if !(c.distance > 1.0 && c.distance.is_finite()) {
                    return Err(format!(
                        "camera distance {} must be finite and above 1 (outside the object)",
                        c.distance
                    ));
                }
            }
            Projection::Orthographic => {
                if !(c.ortho_half_extent > 0.0 && c.ortho_half_extent.is_finite()) {
                    return Err(format!(
                        "orthographic extent {} must be finite and above 0",
                        c.ortho_half_extent
                    ));
                }
            }
        }
        let r = self.tangent_reference;
        if r.iter().any(|v| !v.is_finite()) || r.iter().all(|&v| v == 0.0) {
            return Err(format!(
                "tangent reference {r:?} must be a finite, non-zero vector"
            ));
        }
        // Also refuses NaN.
        if self.light.intensity.is_nan() || self.light.intensity < 0.0 {
            return Err("the light's intensity must not be negative".into());
        }
        if let Some(light) = &self.second_light {
            let values = [light.elevation_deg, light.azimuth_deg, light.intensity];
            if values.iter().any(|v| !v.is_finite()) || light.intensity < 0.0 {
                return Err("the second light needs finite angles and an intensity ≥ 0".into());
            }
        }
        if let Some(environment) = &self.environment
            && !(environment.intensity >= 0.0
                && environment.intensity.is_finite()
                && environment.rotation_deg.is_finite())
        {
            return Err(
                "the environment's intensity must be finite and ≥ 0, its rotation finite".into(),
            );
        }
        if self.background.iter().any(|v| !v.is_finite()) {
            return Err("the background colour must be finite".into());
        }
        Ok(())
    }
}

/// Shadow map: resolution, and the offsets that keep a lit surface from shadowing itself.
pub(crate) const SHADOW_MAP_SIZE: u32 = 2048;
/// Along the normal, in world units: 1.5 shadow-map texels (the map spans 2 units).
const SHADOW_NORMAL_OFFSET: f64 = 1.5 * 2.0 / SHADOW_MAP_SIZE as f64;
/// In normalised depth (the map's depth range is 3 units): half a texel's width.
const SHADOW_DEPTH_BIAS: f64 = 0.5 * (2.0 / SHADOW_MAP_SIZE as f64) / 3.0;

/// A draft frame reads one environment direction in this many (the sequence's prefix, each
/// weighted this many times).
const DRAFT_ENVIRONMENT_STRIDE: f32 = 4.0;

/// The neutral checker that marks unobserved bins in sparse mode (linear).
pub const UNOBSERVED: [[f32; 3]; 2] = [[0.10, 0.10, 0.10], [0.16, 0.16, 0.16]];

/// The scene pass's uniform block; the layout of `Frame` in shaders/preview.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct FrameUniforms {
    view_proj: [[f32; 4]; 4],
    light_view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    toward: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    viewport: [f32; 4],
    tangent_reference: [f32; 4],
    light0: [f32; 4],
    light1: [f32; 4],
    shadow_colour: [f32; 4],
    unobserved_a: [f32; 4],
    unobserved_b: [f32; 4],
    background: [f32; 4],
    flags: [u32; 4],
    scalars: [f32; 4],
}

/// The camera's frame in world space and its projection, for a `width × height` target.
struct CameraFrame {
    /// The same axes as the scene's camera at this yaw and pitch.
    axes: OrbitAxes,
    eye: DVec3,
    half_x: f64,
    half_y: f64,
    view_proj: DMat4,
}

impl CameraFrame {
    fn new(camera: &OrbitCamera, width: u32, height: u32) -> Self {
        let axes = OrbitAxes::new(camera.yaw_deg, camera.pitch_deg);
        let OrbitAxes {
            toward_camera: toward,
            right,
            up,
        } = axes;
        let perspective = camera.projection == Projection::Perspective;
        let (eye, half) = if perspective {
            (
                toward * camera.distance,
                (camera.fov_deg.to_radians() / 2.0).tan(),
            )
        } else {
            (toward * ORTHO_DISTANCE, camera.ortho_half_extent)
        };
        // The shorter side spans [-half, half]; the longer one sees more.
        let (w, h) = (width.max(1) as f64, height.max(1) as f64);
        let (half_x, half_y) = if w >= h {
            (half * w / h, half)
        } else {
            (half, half * h / w)
        };
        // Depth along the view: the unit sphere lies within [d − 1, d + 1] of the eye.
        let d = eye.length();
        let (near, far) = if perspective {
            ((d - 1.0) * 0.9, d + 1.1)
        } else {
            (d - 1.5, d + 1.5)
        };
        let view = DMat4::from_cols(
            DVec4::new(right.x, up.x, toward.x, 0.0),
            DVec4::new(right.y, up.y, toward.y, 0.0),
            DVec4::new(right.z, up.z, toward.z, 0.0),
            DVec4::new(-right.dot(eye), -up.dot(eye), -toward.dot(eye), 1.0),
        );
        // View space looks down −z; depth = −z. wgpu's depth range is [0, 1].
        let proj = if perspective {
            let a = far / (near - far);
            DMat4::from_cols(
                DVec4::new(1.0 / half_x, 0.0, 0.0, 0.0),
                DVec4::new(0.0, 1.0 / half_y, 0.0, 0.0),
                DVec4::new(0.0, 0.0, a, -1.0),
                DVec4::new(0.0, 0.0, a * near, 0.0),
            )
        } else {
            let a = 1.0 / (near - far);
            DMat4::from_cols(
                DVec4::new(1.0 / half_x, 0.0, 0.0, 0.0),
                DVec4::new(0.0, 1.0 / half_y, 0.0, 0.0),
                DVec4::new(0.0, 0.0, a, 0.0),
                DVec4::new(0.0, 0.0, a * near, 1.0),
            )
        };
        Self {
            axes,
            eye,
            half_x,
            half_y,
            view_proj: proj * view,
        }
    }
}

/// An orthographic view from the light that holds the unit bounding sphere, depth in [0, 1].
pub(crate) fn light_view_proj(light: DVec3) -> DMat4 {
    let eye = light * 2.0;
    let helper = if light.y.abs() < 0.9 {
        DVec3::Y
    } else {
        DVec3::X
    };
    let right = helper.cross(light).normalize();
    let up = light.cross(right);
    let view = DMat4::from_cols(
        DVec4::new(right.x, up.x, light.x, 0.0),
        DVec4::new(right.y, up.y, light.y, 0.0),
        DVec4::new(right.z, up.z, light.z, 0.0),
        DVec4::new(-right.dot(eye), -up.dot(eye), -light.dot(eye), 1.0),
    );
    // Depth 0.5 to 3.5 from the eye; the sphere occupies 1 to 3.
    let (near, far) = (0.5, 3.5);
    let a = 1.0 / (near - far);
    let proj = DMat4::from_cols(
        DVec4::new(1.0, 0.0, 0.0, 0.0),
        DVec4::new(0.0, 1.0, 0.0, 0.0),
        DVec4::new(0.0, 0.0, a, 0.0),
        DVec4::new(0.0, 0.0, a * near, 1.0),
    );
    proj * view
}

fn vec4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

fn mat4(m: DMat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d().map(|c| c.map(|v| v as f32))
}

impl FrameUniforms {
    /// The uniform block for `frame` on a `width × height` target; `shadows` says whether the
    /// shadow map holds the object (meshes only), `environment` how many environment
    /// directions the shading reads (0: none).
    pub(crate) fn new(
        frame: &PreviewFrame,
        width: u32,
        height: u32,
        shadows: bool,
        environment: u32,
    ) -> Self {
        let camera = CameraFrame::new(&frame.camera, width, height);
        let perspective = frame.camera.projection == Projection::Perspective;
        let light = frame.light.direction();
        let light1 = frame
            .second_light
            .map_or([0.0; 4], |l| vec4(l.direction(), l.intensity));
        let rgb = |c: [f32; 3]| [c[0], c[1], c[2], 1.0];
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        Self {
            view_proj: mat4(camera.view_proj),
            light_view_proj: mat4(light_view_proj(light)),
            eye: vec4(camera.eye, if perspective { 1.0 } else { 0.0 }),
            toward: vec4(camera.axes.toward_camera, 0.0),
            right: vec4(camera.axes.right, camera.half_x),
            up: vec4(camera.axes.up, camera.half_y),
            viewport: [w, h, 1.0 / w, 1.0 / h],
            tangent_reference: vec4(DVec3::from_array(frame.tangent_reference), 0.0),
            light0: vec4(light, frame.light.intensity),
            light1,
            shadow_colour: rgb(SHADOW),
            unobserved_a: rgb(UNOBSERVED[0]),
            unobserved_b: rgb(UNOBSERVED[1]),
            background: rgb(frame.background),
            flags: [
                frame.mode as u32,
                frame.interpolate as u32,
                (frame.shadows && shadows) as u32,
                environment,
            ],
            scalars: [
                frame.exposure_stops.exp2() as f32,
                SHADOW_NORMAL_OFFSET as f32,
                SHADOW_DEPTH_BIAS as f32,
                // A draft reads the first quarter of the environment's directions.
                if frame.draft {
                    DRAFT_ENVIRONMENT_STRIDE
                } else {
                    1.0
                },
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::CameraRig;

    #[test]
    fn camera_matches_the_scene_rig_and_projects_pixel_centres() {
        for projection in [Projection::Orthographic, Projection::Perspective] {
            let mut scene = Scene::default();
            scene.camera.projection = projection;
            scene.camera.yaw_deg = 35.0;
            scene.camera.pitch_deg = -20.0;
            scene.camera.fov_deg = 40.0;
            scene.resolution = 64;
            let rig = CameraRig::new(&scene);
            let frame = PreviewFrame::from_scene(&scene);
            let camera = CameraFrame::new(&frame.camera, 64, 64);
            // One orbit: the same axes, bit for bit.
            assert_eq!(camera.axes.toward_camera, rig.toward_camera);
            assert_eq!((camera.axes.right, camera.axes.up), (rig.right, rig.up));
            assert!((camera.eye - rig.eye).length() < 1e-12);
            assert!((camera.half_y - rig.half_extent).abs() < 1e-12);
            // The point of pixel (10, 50)'s ray nearest the object's centre (so inside the
            // depth range the object spans) lands on that pixel's centre in NDC.
            let (origin, dir) = rig.pixel_ray(10, 50);
            let p = origin + dir * -origin.dot(dir);
            let clip = camera.view_proj * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            assert!((ndc.x - (10.5 / 64.0 * 2.0 - 1.0)).abs() < 1e-12, "{ndc}");
            assert!((ndc.y - (1.0 - 50.5 / 64.0 * 2.0)).abs() < 1e-12, "{ndc}");
            assert!(ndc.z > 0.0 && ndc.z < 1.0);
        }
    }

    #[test]
    fn light_view_holds_the_unit_sphere() {
        for light in [DVec3::Y, DVec3::new(0.3, 0.5, 0.8).normalize(), -DVec3::X] {
            let m = light_view_proj(light);
            for p in [
                DVec3::X,
                -DVec3::X,
                DVec3::Y,
                -DVec3::Y,
                DVec3::Z,
                -DVec3::Z,
            ] {
                let c = m * p.extend(1.0);
                assert!(c.x.abs() <= 1.0 + 1e-12 && c.y.abs() <= 1.0 + 1e-12);
                assert!(c.z > 0.0 && c.z < 1.0);
            }
            // Nearer the light is shallower.
            assert!((m * light.extend(1.0)).z < (m * (-light).extend(1.0)).z);
        }
    }

    #[test]
    fn uniform_layout_is_what_the_shader_expects() {
        // 2 mat4 + 14 vec4 (shaders/frame.wgsl).
        assert_eq!(std::mem::size_of::<FrameUniforms>(), 2 * 64 + 14 * 16);
    }
}
