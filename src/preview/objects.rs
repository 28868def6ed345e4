//! What the preview draws, chosen apart from the painted view: the view's own object, a
//! built-in shape, any OBJ, or the material-test object made here.

use crate::scene::{BuiltinShape, Mesh, Object};
use glam::{DMat3, DVec2, DVec3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::PathBuf;

/// The preview's object.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum PreviewObject {
    /// The object of the view being painted.
    #[default]
    PaintedView,
    Builtin(BuiltinShape),
    /// The material-test object ([`material_test_object`]).
    MaterialTest,
    /// An OBJ file, normalised like a scene's.
    Obj(PathBuf),
}

impl PreviewObject {
    /// What the UI calls it.
    pub fn label(&self) -> String {
        match self {
            Self::PaintedView => "as painted".into(),
            Self::Builtin(shape) => shape.name().into(),
            Self::MaterialTest => "material test".into(),
            Self::Obj(path) => path.file_name().map_or_else(
                || path.display().to_string(),
                |n| n.to_string_lossy().into(),
            ),
        }
    }

    /// The geometry; `None` for [`Self::PaintedView`], whose object the view holds.
    pub fn load(&self) -> crate::Result<Option<Object>> {
        Ok(match self {
            Self::PaintedView => None,
            Self::Builtin(shape) => Some(Object::builtin(*shape)),
            Self::MaterialTest => Some(material_test_object()),
            Self::Obj(path) => Some(Object::from_obj(path)?),
        })
    }
}

/// Segments around the axis of the material-test object.
const AROUND: usize = 160;

/// One piece of the material-test object's profile: a curve in (radius, height) with its
/// outward unit normal, for t in [0, 1], and how many steps to cut it into.
struct ProfilePiece {
    steps: usize,
    at: Box<dyn Fn(f64) -> (DVec2, DVec2)>,
}

fn line(from: DVec2, to: DVec2, normal: DVec2, steps: usize) -> ProfilePiece {
    ProfilePiece {
        steps,
        at: Box::new(move |t| (from.lerp(to, t), normal)),
    }
}

/// An arc of the circle (centre, radius) from angle `a0` to `a1` (radians, from +radius
/// toward +height); `concave` turns the normal toward the centre.
fn arc(centre: DVec2, radius: f64, a0: f64, a1: f64, concave: bool, steps: usize) -> ProfilePiece {
    ProfilePiece {
        steps,
        at: Box::new(move |t| {
            let a = a0 + (a1 - a0) * t;
            let out = DVec2::new(a.cos(), a.sin());
            (centre + radius * out, if concave { -out } else { out })
        }),
    }
}

/// A shader-ball-like object made for judging a material: a sphere with a concave groove
/// round its middle, on a neck that meets a flat-topped round base through a concave fillet.
/// So it shows convex (the ball), concave (the groove, the fillet) and flat parts (the base's
/// top and bottom) and a cylinder (the base's side), with hard creases between them. Tipped
/// 20° toward the camera so that the base's top shows; normalised like any mesh.
pub fn material_test_object() -> Object {
    let ball_centre = DVec2::new(0.0, 0.15);
    let ball = 0.62;
    let neck = 0.18;
    let (base_radius, base_bottom, base_top) = (0.75, -1.0, -0.82);
    let fillet = 0.12;
    // The groove: a circle just outside the ball's equator, cut into it.
    let groove_centre = DVec2::new(ball + 0.03, ball_centre.y);
    let groove = 0.11;
    // Where the groove meets the ball: the angle δ above and below the equator.
    let d = groove_centre.x;
    let delta = ((ball * ball + d * d - groove * groove) / (2.0 * ball * d)).acos();
    let meet = ball_centre + ball * DVec2::new(delta.cos(), -delta.sin());
    // The groove's arc runs from the lower meeting point through the innermost point.
    // Its angle about the groove's centre lies between −π and −π/2; the upper meeting point
    // mirrors it.
    let groove_from = (meet - groove_centre).y.atan2((meet - groove_centre).x);
    // Angles on the ball, from its bottom pole (−π/2) up: where the neck meets it.
    let neck_meet = -(neck / ball).acos();
    let neck_top = ball_centre.y + ball * neck_meet.sin();
    let fillet_centre = DVec2::new(neck + fillet, base_top + fillet);

    let pieces = [
        line(
            DVec2::new(0.0, base_bottom),
            DVec2::new(base_radius, base_bottom),
            -DVec2::Y,
            6,
        ),
        line(
            DVec2::new(base_radius, base_bottom),
            DVec2::new(base_radius, base_top),
            DVec2::X,
            4,
        ),
        line(
            DVec2::new(base_radius, base_top),
            DVec2::new(neck + fillet, base_top),
            DVec2::Y,
            8,
        ),
        arc(fillet_centre, fillet, -FRAC_PI_2, -PI, true, 12),
        line(
            DVec2::new(neck, base_top + fillet),
            DVec2::new(neck, neck_top),
            DVec2::X,
            4,
        ),
        arc(ball_centre, ball, neck_meet, -delta, false, 36),
        // The groove: the inner side of its circle, from the lower meeting point down
        // through angle π to the upper one.
        arc(
            groove_centre,
            groove,
            TAU + groove_from,
            -groove_from,
            true,
            24,
        ),
        arc(ball_centre, ball, delta, FRAC_PI_2, false, 64),
    ];
    let pose = DMat3::from_rotation_x(20f64.to_radians());
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    for piece in &pieces {
        let base = positions.len() as u32;
        for step in 0..=piece.steps {
            let (p, n) = (piece.at)(step as f64 / piece.steps as f64);
            for k in 0..AROUND {
                let (s, c) = (k as f64 / AROUND as f64 * TAU).sin_cos();
                positions.push(pose * DVec3::new(p.x * c, p.y, p.x * s));
                normals.push(pose * DVec3::new(n.x * c, n.y, n.x * s).normalize());
            }
        }
        let index = |step: usize, k: usize| base + (step * AROUND + k % AROUND) as u32;
        for step in 0..piece.steps {
            for k in 0..AROUND {
                let quad = [
                    index(step, k),
                    index(step + 1, k),
                    index(step + 1, k + 1),
                    index(step, k + 1),
                ];
                for tri in [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]] {
                    push_outward(&mut triangles, &positions, &normals, tri);
                }
            }
        }
    }
    let mesh = Mesh::new(positions, Some(normals), triangles)
        .expect("the material-test object is well formed");
    Object::from_mesh(mesh)
}

/// Adds a triangle wound counter-clockwise seen from the side its vertex normals point to;
/// skips it where it has no area (the rings that shrink to a point on the axis).
fn push_outward(
    triangles: &mut Vec<[u32; 3]>,
    positions: &[DVec3],
    normals: &[DVec3],
    tri: [u32; 3],
) {
    let [a, b, c] = tri.map(|i| i as usize);
    let face = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
    if face.length_squared() <= 1e-24 {
        return;
    }
    let outward = normals[a] + normals[b] + normals[c];
    triangles.push(if face.dot(outward) >= 0.0 {
        tri
    } else {
        [tri[0], tri[2], tri[1]]
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_material_test_object_is_closed_and_has_convex_concave_and_flat_parts() {
        let object = material_test_object();
        let mesh = object.mesh().expect("a mesh");
        assert!(mesh.signed_volume() > 0.0, "wound outward");
        let radius = mesh
            .positions
            .iter()
            .map(|p| p.length())
            .fold(0.0, f64::max);
        assert!((radius - 1.0).abs() < 1e-9, "normalised: {radius}");
        // Every face agrees with its vertex normals (hard creases have their own vertices).
        for &[a, b, c] in &mesh.triangles {
            let [a, b, c] = [a, b, c].map(|i| i as usize);
            let p = &mesh.positions;
            let face = (p[b] - p[a]).cross(p[c] - p[a]).normalize();
            for i in [a, b, c] {
                assert!(
                    face.dot(mesh.normals[i]) > 0.8,
                    "{face} {}",
                    mesh.normals[i]
                );
            }
        }
        // Flat: many faces share the base top's normal (tipped with the object).
        let up = DMat3::from_rotation_x(20f64.to_radians()) * DVec3::Y;
        let flat = mesh
            .triangles
            .iter()
            .filter(|t| {
                t.iter()
                    .all(|&i| mesh.normals[i as usize].dot(up) > 1.0 - 1e-9)
            })
            .count();
        assert!(flat > 2 * AROUND, "{flat} flat faces");
        // Convex and concave: along the ball's profile the normal turns with the surface
        // (dot of normal change and position change > 0); in the groove, against it.
        let mut convex = 0;
        let mut concave = 0;
        for &[a, b, _] in &mesh.triangles {
            let (a, b) = (a as usize, b as usize);
            let dp = mesh.positions[b] - mesh.positions[a];
            let dn = mesh.normals[b] - mesh.normals[a];
            if dp.length() > 1e-6 && dn.length() > 1e-6 {
                let turn = dn.dot(dp) / dp.length_squared();
                if turn > 0.5 {
                    convex += 1;
                } else if turn < -0.5 {
                    concave += 1;
                }
            }
        }
        assert!(
            convex > 1000 && concave > 1000,
            "convex {convex}, concave {concave}"
        );
    }

    #[test]
    fn labels_and_loading() {
        assert!(PreviewObject::PaintedView.load().unwrap().is_none());
        assert!(PreviewObject::MaterialTest.load().unwrap().is_some());
        let bowl = PreviewObject::Obj(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/meshes/bowl.obj"),
        );
        assert_eq!(bowl.label(), "bowl.obj");
        assert!(bowl.load().unwrap().is_some());
        let missing = PreviewObject::Obj("/nonexistent/thing.obj".into());
        let e = missing.load().unwrap_err().to_string();
        assert!(e.contains("thing.obj"), "{e}");
    }
}
