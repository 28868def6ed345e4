//! The scene's object: an exact analytic sphere, or a triangle mesh with a BVH.

use super::bvh::Bvh;
use super::mesh::Mesh;
use super::shapes;
use super::source::{BuiltinShape, ObjectSource};
use crate::error::Result;
use glam::DVec3;
use std::path::Path;

/// Geometry centred at the origin inside the unit sphere, ready for ray casting.
#[derive(Clone, Debug)]
pub struct Object {
    geometry: Geometry,
}

#[derive(Clone, Debug)]
enum Geometry {
    Sphere,
    Mesh { mesh: Mesh, bvh: Bvh },
}

/// A ray's nearest surface point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit {
    pub position: DVec3,
    /// Outward unit shading normal (interpolated for meshes).
    pub normal: DVec3,
    /// Unit normal of the surface's true geometry, on the side the ray came from: shadow
    /// rays start a little along it so that they do not hit the very face they leave.
    pub facing_normal: DVec3,
}

impl Object {
    /// A built-in shape.
    pub fn builtin(shape: BuiltinShape) -> Self {
        match shape {
            BuiltinShape::Sphere => Self {
                geometry: Geometry::Sphere,
            },
            BuiltinShape::Torus => Self::from_mesh(shapes::torus()),
            BuiltinShape::RoundedCube => Self::from_mesh(shapes::rounded_cube()),
            BuiltinShape::Blob => Self::from_mesh(shapes::blob()),
        }
    }

    /// An OBJ file's mesh, normalised (see [`Mesh::normalize`]).
    pub fn from_obj(path: impl AsRef<Path>) -> Result<Self> {
        Ok(Self::from_mesh(Mesh::from_obj(path)?))
    }

    /// The object a scene names.
    pub fn load(source: &ObjectSource) -> Result<Self> {
        match source {
            ObjectSource::Builtin(shape) => Ok(Self::builtin(*shape)),
            ObjectSource::Obj(path) => Self::from_obj(path),
        }
    }

    /// Any mesh, centred (bounding-box centre) and scaled to a unit bounding sphere.
    pub fn from_mesh(mut mesh: Mesh) -> Self {
        mesh.normalize();
        let bvh = Bvh::build(&mesh.positions, &mesh.triangles);
        Self {
            geometry: Geometry::Mesh { mesh, bvh },
        }
    }

    /// The normalised mesh; `None` for the analytic sphere.
    pub fn mesh(&self) -> Option<&Mesh> {
        match &self.geometry {
            Geometry::Sphere => None,
            Geometry::Mesh { mesh, .. } => Some(mesh),
        }
    }

    /// The nearest surface point along the ray (`dir` unit) with `t` in (`t_min`, ∞).
    pub(crate) fn intersect(&self, origin: DVec3, dir: DVec3, t_min: f64) -> Option<Hit> {
        match &self.geometry {
            Geometry::Sphere => {
                let t = sphere_hit(origin, dir, t_min)?;
                let position = origin + dir * t;
                let normal = position.normalize();
                Some(Hit {
                    position,
                    normal,
                    facing_normal: facing(normal, dir),
                })
            }
            Geometry::Mesh { mesh, bvh } => {
                let hit = bvh.closest(origin, dir, t_min, f64::INFINITY)?;
                let [a, b, c] = mesh.triangles[hit.triangle as usize].map(|i| i as usize);
                let p = &mesh.positions;
                let geometric = (p[b] - p[a]).cross(p[c] - p[a]).normalize();
                let facing_normal = facing(geometric, dir);
                let n = &mesh.normals;
                let interpolated = n[a] * (1.0 - hit.u - hit.v) + n[b] * hit.u + n[c] * hit.v;
                // Opposed vertex normals can cancel; the face itself is the best guess then.
                let normal = interpolated.try_normalize().unwrap_or(facing_normal);
                Some(Hit {
                    position: origin + dir * hit.t,
                    normal,
                    facing_normal,
                })
            }
        }
    }

    /// Whether the surface blocks the ray (`dir` unit) anywhere with `t` in (`t_min`, ∞).
    pub(crate) fn occluded(&self, origin: DVec3, dir: DVec3, t_min: f64) -> bool {
        match &self.geometry {
            Geometry::Sphere => sphere_hit(origin, dir, t_min).is_some(),
            Geometry::Mesh { bvh, .. } => bvh.any_hit(origin, dir, t_min, f64::INFINITY),
        }
    }
}

/// `normal` or its opposite, whichever faces back along the ray.
fn facing(normal: DVec3, dir: DVec3) -> DVec3 {
    if normal.dot(dir) > 0.0 {
        -normal
    } else {
        normal
    }
}

/// The nearest `t > t_min` where the ray meets the unit sphere.
fn sphere_hit(origin: DVec3, dir: DVec3, t_min: f64) -> Option<f64> {
    let b = origin.dot(dir);
    let c = origin.length_squared() - 1.0;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    // The stable pair of roots: q = −(b + sign(b)·√disc), then t = q and c / q.
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        // A ray starting on the sphere, tangent to it.
        return (0.0 > t_min).then_some(0.0);
    }
    let (x, y) = (q, c / q);
    let (t0, t1) = (x.min(y), x.max(y));
    [t0, t1].into_iter().find(|&t| t > t_min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_roots() {
        let t = sphere_hit(DVec3::new(0.0, 0.0, 3.0), -DVec3::Z, 0.0).unwrap();
        assert!((t - 2.0).abs() < 1e-15);
        let t = sphere_hit(DVec3::new(0.6, 0.0, 3.0), -DVec3::Z, 0.0).unwrap();
        assert!((t - 2.2).abs() < 1e-15);
        // From inside, the far root.
        let t = sphere_hit(DVec3::ZERO, DVec3::X, 0.0).unwrap();
        assert!((t - 1.0).abs() < 1e-15);
        assert!(sphere_hit(DVec3::new(0.0, 0.0, 3.0), DVec3::Z, 0.0).is_none());
        assert!(sphere_hit(DVec3::new(2.0, 0.0, 3.0), -DVec3::Z, 0.0).is_none());
    }
}
