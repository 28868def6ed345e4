//! Fuzzes OBJ loading: parsing (tobj), checking, normals, normalisation to the unit sphere
//! and the BVH build. Any bytes give an object or an error naming the file.
#![no_main]

use burnish::scene::{Mesh, Object};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    match Mesh::from_obj_bytes(data, Path::new("fuzz.obj")) {
        Ok(mesh) => {
            assert!(!mesh.triangles.is_empty());
            assert_eq!(mesh.normals.len(), mesh.positions.len());
            let object = Object::from_mesh(mesh);
            let mesh = object.mesh().expect("a mesh object");
            assert!(mesh.positions.iter().all(|p| p.is_finite()));
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.obj"), "{e}"),
    }
});
