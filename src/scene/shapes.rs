//! Tessellated built-in shapes with exact (analytic) vertex normals.
//!
//! Each is posed so that the default camera (on +z) sees a wide range of normals, and is
//! built at about unit size; [`super::Object`] normalises it like any mesh.

use super::mesh::Mesh;
use glam::{DMat3, DVec3};

/// Torus radii: tube centre line and tube; they sum to 1.
const TORUS_MAJOR: f64 = 0.65;
const TORUS_MINOR: f64 = 0.35;
/// Segments around the ring and around the tube.
const TORUS_RING_SEGMENTS: usize = 192;
const TORUS_TUBE_SEGMENTS: usize = 96;

/// Rounded cube: the inner box half-size and the rounding radius (the cube's half-size is
/// their sum, 1).
const CUBE_INNER: f64 = 0.6;
const CUBE_ROUNDING: f64 = 0.4;
/// Grid cells along each edge of each of the six faces.
const CUBE_CELLS: usize = 64;

/// Blob: grid cells along each cube-face edge of the cube-sphere it is displaced from.
const BLOB_CELLS: usize = 72;
/// How far the noise moves the surface, relative to the radius.
const BLOB_AMPLITUDE: f64 = 0.2;

/// A ring whose axis is tilted 50° from y toward the camera, so that its hole shows.
pub(crate) fn torus() -> Mesh {
    let (ring, tube) = (TORUS_RING_SEGMENTS, TORUS_TUBE_SEGMENTS);
    let tilt = DMat3::from_rotation_x(50f64.to_radians());
    let mut positions = Vec::with_capacity(ring * tube);
    let mut normals = Vec::with_capacity(ring * tube);
    for i in 0..ring {
        let (su, cu) = (i as f64 / ring as f64 * std::f64::consts::TAU).sin_cos();
        for j in 0..tube {
            let (sv, cv) = (j as f64 / tube as f64 * std::f64::consts::TAU).sin_cos();
            let normal = DVec3::new(cv * cu, sv, cv * su);
            let centre = DVec3::new(TORUS_MAJOR * cu, 0.0, TORUS_MAJOR * su);
            positions.push(tilt * (centre + TORUS_MINOR * normal));
            normals.push(tilt * normal);
        }
    }
    let index = |i: usize, j: usize| ((i % ring) * tube + j % tube) as u32;
    let mut triangles = Vec::with_capacity(2 * ring * tube);
    for i in 0..ring {
        for j in 0..tube {
            let quad = [
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            ];
            push_quad(&mut triangles, &positions, &normals, quad);
        }
    }
    finish(positions, normals, triangles)
}

/// A cube with rounded edges and corners, turned 35° about y and tipped 25° toward the
/// camera so that three faces, their edges and a corner show.
pub(crate) fn rounded_cube() -> Mesh {
    let pose =
        DMat3::from_rotation_x(25f64.to_radians()) * DMat3::from_rotation_y(35f64.to_radians());
    let half = CUBE_INNER + CUBE_ROUNDING;
    // A point q of the cube's surface maps to the rounded surface through the nearest point
    // of the inner box: the rounded surface is that box grown by the rounding radius.
    cube_grid(CUBE_CELLS, half, |q| {
        let inner = q.clamp(DVec3::splat(-CUBE_INNER), DVec3::splat(CUBE_INNER));
        let normal = (q - inner).normalize();
        (pose * (inner + CUBE_ROUNDING * normal), pose * normal)
    })
}

/// A sphere displaced along its radius by smooth low-frequency noise: an organic shape
/// with concave dents, so it shows more distinct normals than a sphere.
pub(crate) fn blob() -> Mesh {
    cube_grid(BLOB_CELLS, 1.0, |q| {
        let u = q.normalize();
        let position = u * blob_radius(u);
        (position, blob_normal(position))
    })
}

/// The blob's radius along unit direction `u`: a fixed sum of sinusoids in x, y and z,
/// which is smooth and (unlike random noise) the same on every machine.
fn blob_radius(u: DVec3) -> f64 {
    let noise = 0.45 * (2.1 * u.x + 0.4).sin() * (1.7 * u.y + 1.3).sin()
        + 0.30 * (3.3 * u.y + 2.1 * u.z + 0.2).sin()
        + 0.25 * (4.1 * u.z - 2.3 * u.x + 0.7).cos()
        + 0.15 * (5.3 * u.x + 3.1 * u.y - 1.9 * u.z).sin();
    1.0 + BLOB_AMPLITUDE * noise
}

/// Outward normal: the gradient of |p| − radius(p/|p|), which is zero on the surface,
/// by central differences (the function is smooth, so they are accurate to ~1e-10).
fn blob_normal(p: DVec3) -> DVec3 {
    let f = |p: DVec3| p.length() - blob_radius(p.normalize());
    let h = 1e-6;
    let d = |axis: DVec3| (f(p + axis * h) - f(p - axis * h)) / (2.0 * h);
    DVec3::new(d(DVec3::X), d(DVec3::Y), d(DVec3::Z)).normalize()
}

/// Tessellates the surface that `map` makes of the cube [-half, half]³: each face is a
/// `cells × cells` grid. Grid points on shared edges are computed from identical
/// coordinates, so neighbouring faces meet without cracks.
fn cube_grid(cells: usize, half: f64, map: impl Fn(DVec3) -> (DVec3, DVec3)) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    let coordinate = |k: usize| -half + 2.0 * half * k as f64 / cells as f64;
    for axis in 0..3 {
        for side in [-half, half] {
            let base = positions.len() as u32;
            for i in 0..=cells {
                for j in 0..=cells {
                    let mut q = DVec3::ZERO;
                    q[axis] = side;
                    q[(axis + 1) % 3] = coordinate(i);
                    q[(axis + 2) % 3] = coordinate(j);
                    let (p, n) = map(q);
                    positions.push(p);
                    normals.push(n);
                }
            }
            let index = |i: usize, j: usize| base + (i * (cells + 1) + j) as u32;
            for i in 0..cells {
                for j in 0..cells {
                    let quad = [
                        index(i, j),
                        index(i + 1, j),
                        index(i + 1, j + 1),
                        index(i, j + 1),
                    ];
                    push_quad(&mut triangles, &positions, &normals, quad);
                }
            }
        }
    }
    finish(positions, normals, triangles)
}

/// Two triangles for a quad, each wound counter-clockwise seen from outside (the side the
/// vertex normals point to), whatever order the grid gave the corners in.
fn push_quad(
    triangles: &mut Vec<[u32; 3]>,
    positions: &[DVec3],
    normals: &[DVec3],
    quad: [u32; 4],
) {
    for tri in [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]] {
        let [a, b, c] = tri.map(|i| i as usize);
        let face = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        if face == DVec3::ZERO {
            continue;
        }
        let outward = normals[a] + normals[b] + normals[c];
        triangles.push(if face.dot(outward) >= 0.0 {
            tri
        } else {
            [tri[0], tri[2], tri[1]]
        });
    }
}

fn finish(positions: Vec<DVec3>, normals: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    let mut mesh =
        Mesh::new(positions, Some(normals), triangles).expect("built-in shapes are well formed");
    mesh.normalize();
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_normals_agree_with_the_faces() {
        for mesh in [torus(), rounded_cube(), blob()] {
            assert!(mesh.signed_volume() > 0.0);
            let max = mesh
                .positions
                .iter()
                .map(|p| p.length())
                .fold(0.0, f64::max);
            assert!((max - 1.0).abs() < 1e-12);
            for &[a, b, c] in &mesh.triangles {
                let [a, b, c] = [a, b, c].map(|i| i as usize);
                let face = (mesh.positions[b] - mesh.positions[a])
                    .cross(mesh.positions[c] - mesh.positions[a])
                    .normalize();
                for i in [a, b, c] {
                    assert!(
                        face.dot(mesh.normals[i]) > 0.9,
                        "{face} {}",
                        mesh.normals[i]
                    );
                }
            }
        }
    }

    #[test]
    fn blob_normal_is_perpendicular_to_the_surface() {
        let surface = |u: DVec3| u.normalize() * blob_radius(u.normalize());
        for u in [
            DVec3::new(0.3, -0.5, 0.7),
            DVec3::new(-0.9, 0.1, 0.2),
            DVec3::Y,
        ] {
            let u = u.normalize();
            let t1 = u.any_orthonormal_vector();
            let t2 = u.cross(t1);
            let e = 1e-5;
            let d1 = surface(u + t1 * e) - surface(u - t1 * e);
            let d2 = surface(u + t2 * e) - surface(u - t2 * e);
            let n = blob_normal(surface(u));
            assert!(n.dot(d1.normalize()).abs() < 1e-6 && n.dot(d2.normalize()).abs() < 1e-6);
            assert!(n.dot(u) > 0.0);
        }
    }
}
