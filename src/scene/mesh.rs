//! Triangle meshes: checking, vertex normals, unit-sphere normalisation and OBJ files.

use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use glam::DVec3;
use std::io::Write;
use std::path::Path;

/// A triangle mesh with one unit normal per vertex (zero only where no face gives one).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Checks the mesh and completes its normals.
    ///
    /// `normals`, when given, has one entry per position; entries that are zero or not finite
    /// are replaced by computed ones. Computed normals are area-weighted averages of the face
    /// normals around each vertex, taken counter-clockwise as OBJ winds faces; for a mesh
    /// wound the other way (it encloses a negative volume) they are flipped to point outward.
    ///
    /// The problem, as a sentence, when an index is out of range, a position is not finite,
    /// or no face has any area.
    pub fn new(
        positions: Vec<DVec3>,
        normals: Option<Vec<DVec3>>,
        triangles: Vec<[u32; 3]>,
    ) -> std::result::Result<Self, String> {
        if triangles.is_empty() {
            return Err("the mesh has no faces".into());
        }
        if let Some((face, &index)) = triangles.iter().enumerate().find_map(|(f, tri)| {
            tri.iter()
                .find(|&&i| i as usize >= positions.len())
                .map(|i| (f, i))
        }) {
            return Err(format!(
                "face {} uses vertex {} but there are only {} vertices",
                face + 1,
                index as u64 + 1,
                positions.len()
            ));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(format!(
                "vertex {} has a position that is not finite",
                i + 1
            ));
        }
        if let Some(n) = &normals
            && n.len() != positions.len()
        {
            return Err(format!(
                "{} normals for {} vertices",
                n.len(),
                positions.len()
            ));
        }
        let computed = area_weighted_normals(&positions, &triangles);
        if computed.iter().all(|n| *n == DVec3::ZERO) {
            return Err("every face has zero area".into());
        }
        let normals = match normals {
            None => computed,
            Some(given) => given
                .into_iter()
                .zip(computed)
                .map(|(n, fallback)| n.try_normalize().unwrap_or(fallback))
                .collect(),
        };
        Ok(Self {
            positions,
            normals,
            triangles,
        })
    }

    /// Reads an OBJ file: every object and group, polygons fanned into triangles, normals
    /// from the file where every vertex of a group has one (computed otherwise). Materials
    /// and texture coordinates are ignored. The mesh is not yet normalised.
    pub fn from_obj(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Self::from_obj_bytes(&bytes, path)
    }

    /// [`Mesh::from_obj`] of a file's bytes; `path` names it in errors.
    pub fn from_obj_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let options = tobj::LoadOptions {
            single_index: true,
            triangulate: true,
            ignore_points: true,
            ignore_lines: true,
        };
        let (models, _materials) =
            tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &options, |_| {
                Ok(Default::default())
            })
            .map_err(|e| Error::invalid(path, format!("not a readable OBJ file: {e}")))?;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut triangles = Vec::new();
        let mut every_vertex_has_a_normal = true;
        for model in &models {
            let mesh = &model.mesh;
            let base = positions.len();
            let count = mesh.positions.len() / 3;
            let vec3 = |v: &[f32]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
            positions.extend(mesh.positions.chunks_exact(3).map(vec3));
            if mesh.normals.len() == mesh.positions.len() {
                normals.extend(mesh.normals.chunks_exact(3).map(vec3));
            } else {
                every_vertex_has_a_normal = false;
                normals.extend(std::iter::repeat_n(DVec3::ZERO, count));
            }
            for (face, tri) in mesh.indices.chunks_exact(3).enumerate() {
                if let Some(&bad) = tri.iter().find(|&&i| i as usize >= count) {
                    return Err(Error::invalid(
                        path,
                        format!(
                            "face {} of object {:?} uses vertex {} but it has only {count}",
                            face + 1,
                            model.name,
                            bad as u64 + 1
                        ),
                    ));
                }
                let offset = |i: u32| (base + i as usize) as u32;
                triangles.push([offset(tri[0]), offset(tri[1]), offset(tri[2])]);
            }
        }
        if triangles.is_empty() {
            return Err(Error::invalid(path, "the OBJ file has no faces"));
        }
        // Zero normals (groups without any) are completed from the faces by `new`; when no
        // group has normals, `new` also gets to orient the computed ones.
        let normals = (every_vertex_has_a_normal || normals.iter().any(|n| *n != DVec3::ZERO))
            .then_some(normals);
        Self::new(positions, normals, triangles).map_err(|problem| Error::invalid(path, problem))
    }

    /// Writes the mesh as an OBJ file, atomically, with or without its normals.
    pub fn write_obj(&self, path: impl AsRef<Path>, with_normals: bool) -> Result<()> {
        let path = path.as_ref();
        write_atomically(path, |w| {
            writeln!(
                w,
                "# Burnish mesh: {} vertices, {} triangles",
                self.positions.len(),
                self.triangles.len()
            )?;
            for p in &self.positions {
                writeln!(w, "v {} {} {}", short(p.x), short(p.y), short(p.z))?;
            }
            if with_normals {
                for n in &self.normals {
                    writeln!(w, "vn {} {} {}", short(n.x), short(n.y), short(n.z))?;
                }
            }
            for t in &self.triangles {
                let [a, b, c] = t.map(|i| i + 1);
                if with_normals {
                    writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
                } else {
                    writeln!(w, "f {a} {b} {c}")?;
                }
            }
            Ok(())
        })
    }

    /// Moves the centre of the bounding box of the faces' vertices to the origin and scales
    /// so that the farthest of them lies at distance 1: the unit sphere then bounds the mesh.
    pub fn normalize(&mut self) {
        let mut used = vec![false; self.positions.len()];
        for tri in &self.triangles {
            for &i in tri {
                used[i as usize] = true;
            }
        }
        let referenced = || {
            self.positions
                .iter()
                .zip(&used)
                .filter(|(_, u)| **u)
                .map(|(p, _)| *p)
        };
        let (lo, hi) = referenced().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
        let centre = (lo + hi) * 0.5;
        let radius = referenced()
            .map(|p| (p - centre).length())
            .fold(0.0, f64::max);
        // `new` refused meshes without area, so the radius is positive.
        let scale = 1.0 / radius;
        for p in &mut self.positions {
            *p = (*p - centre) * scale;
        }
    }

    /// The volume the faces enclose, by the divergence theorem; negative when the mesh is
    /// wound clockwise seen from outside. Meaningful for closed meshes only.
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|&[a, b, c]| {
                let (p0, p1, p2) = (
                    self.positions[a as usize],
                    self.positions[b as usize],
                    self.positions[c as usize],
                );
                p0.dot(p1.cross(p2)) / 6.0
            })
            .sum()
    }
}

/// Area-weighted vertex normals, oriented outward for a closed mesh of either winding.
fn area_weighted_normals(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<DVec3> {
    let mut sums = vec![DVec3::ZERO; positions.len()];
    let mut volume = 0.0;
    for &[a, b, c] in triangles {
        let (p0, p1, p2) = (
            positions[a as usize],
            positions[b as usize],
            positions[c as usize],
        );
        // |cross| is twice the area: the weighting comes for free.
        let face = (p1 - p0).cross(p2 - p0);
        for i in [a, b, c] {
            sums[i as usize] += face;
        }
        volume += p0.dot(p1.cross(p2));
    }
    let sign = if volume < 0.0 { -1.0 } else { 1.0 };
    sums.into_iter()
        .map(|n| n.try_normalize().map_or(DVec3::ZERO, |n| n * sign))
        .collect()
}

/// A coordinate printed with enough digits (f32 precision) and no more.
fn short(x: f64) -> String {
    let s = format!("{:.7}", x);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron(clockwise: bool) -> Mesh {
        let positions = vec![
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ];
        let mut triangles = vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
        if clockwise {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        Mesh::new(positions, None, triangles).unwrap()
    }

    #[test]
    fn computed_normals_point_outward_for_either_winding() {
        for clockwise in [false, true] {
            let mesh = tetrahedron(clockwise);
            assert_eq!(mesh.signed_volume() < 0.0, clockwise);
            for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
                assert!((n.dot(p.normalize()) - 1.0).abs() < 1e-12, "{p} {n}");
            }
        }
    }

    #[test]
    fn normalisation_centres_the_bounding_box_and_scales_to_unit_radius() {
        let mut mesh = tetrahedron(false);
        for p in &mut mesh.positions {
            *p = *p * 3.0 + DVec3::new(5.0, -2.0, 1.0);
        }
        mesh.normalize();
        let max = mesh
            .positions
            .iter()
            .map(|p| p.length())
            .fold(0.0, f64::max);
        assert!((max - 1.0).abs() < 1e-12);
        let centre = mesh.positions.iter().fold(DVec3::ZERO, |s, p| s + *p) / 4.0;
        assert!(centre.length() < 1e-12);
    }

    #[test]
    fn bad_meshes_are_described() {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!(
            Mesh::new(p.clone(), None, vec![])
                .unwrap_err()
                .contains("no faces")
        );
        assert!(
            Mesh::new(p.clone(), None, vec![[0, 1, 3]])
                .unwrap_err()
                .contains("vertex 4")
        );
        assert!(
            Mesh::new(p.clone(), None, vec![[0, 1, 1]])
                .unwrap_err()
                .contains("zero area")
        );
        let nan = vec![DVec3::ZERO, DVec3::X, DVec3::new(f64::NAN, 0.0, 0.0)];
        assert!(
            Mesh::new(nan, None, vec![[0, 1, 2]])
                .unwrap_err()
                .contains("not finite")
        );
    }

    #[test]
    fn coordinates_print_short() {
        assert_eq!(short(0.5), "0.5");
        assert_eq!(short(-0.0000000001), "0");
        assert_eq!(short(1.0), "1");
        assert_eq!(short(-0.25), "-0.25");
    }
}
