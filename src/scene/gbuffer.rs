//! The geometry buffer: per pixel, the surface point seen, its shading frame, the light and
//! view directions in that frame (TABLE.md), their bins and whether a cast shadow falls there.

use super::camera::{CameraRig, light_direction};
use super::file::Scene;
use super::object::Object;
use crate::table::{DirIndex, direction_index};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// How far shadow rays start off the surface, along its geometric normal, so that a face
/// does not shadow itself through rounding. Objects have radius 1; this is far below any
/// feature a guide image resolves.
const SHADOW_BIAS: f64 = 1e-6;

/// What one covered pixel sees. Vectors are stored in single precision (the buffer of a
/// 1024² guide stays under 80 MB); bins were computed from the double-precision directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// World position.
    pub position: Vec3,
    /// Outward unit shading normal, world space.
    pub normal: Vec3,
    /// Unit tangent (φ = 0), world space; see [`tangent_frame`].
    pub tangent: Vec3,
    /// Unit direction toward the light in the local frame (tangent, normal × tangent, normal).
    pub light: Vec3,
    /// Unit direction toward the camera in the local frame.
    pub view: Vec3,
    /// The light direction's bin; `None` when the normal faces away from the light.
    pub light_bin: Option<DirIndex>,
    /// The view direction's bin; `None` when the shading normal faces away from the camera
    /// (this happens near silhouettes, where interpolated normals bend away).
    pub view_bin: Option<DirIndex>,
    /// Whether the object casts a shadow here. Only traced where the normal faces the light
    /// and the scene asks for shadows.
    pub in_shadow: bool,
}

impl SurfacePoint {
    /// The third axis of the local frame, normal × tangent.
    pub fn bitangent(&self) -> Vec3 {
        self.normal.cross(self.tangent)
    }

    /// cos θ_l of the pixel's actual light direction (≤ 0 when it faces away).
    pub fn cos_light(&self) -> f32 {
        self.light.z
    }

    /// cos θ_v of the pixel's actual view direction.
    pub fn cos_view(&self) -> f32 {
        self.view.z
    }

    /// Whether light reaches the point: it faces the light and no cast shadow falls on it.
    pub fn is_lit(&self) -> bool {
        self.light.z > 0.0 && !self.in_shadow
    }
}

/// The geometry buffer of a scene, `resolution²` pixels in rows from the top.
#[derive(Clone, Debug)]
pub struct GBuffer {
    resolution: usize,
    pixels: Vec<Option<SurfacePoint>>,
    light_direction: DVec3,
    camera: CameraRig,
}

impl GBuffer {
    /// Casts one ray through each pixel centre, and a shadow ray from each point that faces
    /// the light; rows in parallel.
    pub fn build(scene: &Scene, object: &Object) -> Self {
        let camera = CameraRig::new(scene);
        let light = light_direction(&scene.light);
        let tracer = Tracer {
            object,
            camera: &camera,
            light,
            reference: DVec3::from_array(scene.tangent_reference),
            shadows: scene.shadows,
        };
        let resolution = camera.resolution;
        let mut pixels = vec![None; resolution * resolution];
        if resolution > 0 {
            pixels
                .par_chunks_mut(resolution)
                .enumerate()
                .for_each(|(y, row)| {
                    for (x, pixel) in row.iter_mut().enumerate() {
                        *pixel = tracer.surface_point(x, y);
                    }
                });
        }
        Self {
            resolution,
            pixels,
            light_direction: light,
            camera,
        }
    }

    /// Pixels along each side.
    pub fn resolution(&self) -> usize {
        self.resolution
    }

    /// Every pixel, row-major from the top left; `None` off the object.
    pub fn pixels(&self) -> &[Option<SurfacePoint>] {
        &self.pixels
    }

    /// The pixel at row-major `index`; `None` off the object or outside the image.
    pub fn at(&self, index: usize) -> Option<&SurfacePoint> {
        self.pixels.get(index).and_then(Option::as_ref)
    }

    /// The pixel at column `x`, row `y`; `None` off the object or outside the image.
    pub fn get(&self, x: usize, y: usize) -> Option<&SurfacePoint> {
        if x < self.resolution && y < self.resolution {
            self.at(y * self.resolution + x)
        } else {
            None
        }
    }

    /// Unit vector toward the light, world space.
    pub fn light_direction(&self) -> DVec3 {
        self.light_direction
    }

    pub fn camera(&self) -> &CameraRig {
        &self.camera
    }

    /// How many pixels see the object.
    pub fn covered_count(&self) -> usize {
        self.pixels.iter().filter(|p| p.is_some()).count()
    }
}

/// What every pixel's rays need to know.
struct Tracer<'a> {
    object: &'a Object,
    camera: &'a CameraRig,
    light: DVec3,
    reference: DVec3,
    shadows: bool,
}

impl Tracer<'_> {
    fn surface_point(&self, x: usize, y: usize) -> Option<SurfacePoint> {
        let (origin, dir) = self.camera.pixel_ray(x, y);
        let hit = self.object.intersect(origin, dir, 0.0)?;
        let n = hit.normal;
        let (tangent, bitangent) = tangent_frame(n, self.reference);
        let local = |w: DVec3| DVec3::new(w.dot(tangent), w.dot(bitangent), w.dot(n));
        let light = local(self.light);
        let view = local(self.camera.view_direction(hit.position));
        let shadow_origin = hit.position + hit.facing_normal * SHADOW_BIAS;
        let in_shadow =
            self.shadows && light.z > 0.0 && self.object.occluded(shadow_origin, self.light, 0.0);
        Some(SurfacePoint {
            position: hit.position.as_vec3(),
            normal: n.as_vec3(),
            tangent: tangent.as_vec3(),
            light: light.as_vec3(),
            view: view.as_vec3(),
            light_bin: direction_index(light),
            view_bin: direction_index(view),
            in_shadow,
        })
    }
}

/// The tangent x = normalize(r − (r·n) n) and bitangent y = n × x of unit normal `n` and
/// reference `r`, so that (x, y, n) is right-handed.
///
/// Where `r` is parallel to `n` (|r − (r·n) n| ≤ 10⁻⁹ |r|) the reference is replaced by the
/// world axis least aligned with `n` (the first of x, y, z on ties).
pub fn tangent_frame(n: DVec3, r: DVec3) -> (DVec3, DVec3) {
    let project = |r: DVec3| r - r.dot(n) * n;
    let mut x = project(r);
    if x.length() <= 1e-9 * r.length() || !x.is_finite() {
        let a = n.abs();
        let axis = if a.x <= a.y && a.x <= a.z {
            DVec3::X
        } else if a.y <= a.z {
            DVec3::Y
        } else {
            DVec3::Z
        };
        x = project(axis);
    }
    let x = x.normalize();
    (x, n.cross(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_frame_is_orthonormal_and_right_handed() {
        for (n, r) in [
            (DVec3::new(0.3, 0.4, 0.866).normalize(), DVec3::X),
            (DVec3::X, DVec3::X),
            (-DVec3::Z, DVec3::new(0.0, 0.0, 2.0)),
            (DVec3::Y, DVec3::new(0.0, 1e-12, 0.0)),
        ] {
            let (x, y) = tangent_frame(n, r);
            assert!(
                (x.length() - 1.0).abs() < 1e-12 && x.dot(n).abs() < 1e-12,
                "{n} {r}"
            );
            assert!((x.cross(y) - n).length() < 1e-12);
        }
        // r ∥ n falls back to the least aligned axis.
        assert_eq!(tangent_frame(DVec3::X, DVec3::X).0, DVec3::Y);
        assert_eq!(tangent_frame(DVec3::Z, DVec3::Z).0, DVec3::X);
        // Otherwise x follows r.
        let (x, _) = tangent_frame(DVec3::Z, DVec3::new(1.0, 1.0, 5.0));
        assert!((x - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-15);
    }
}
