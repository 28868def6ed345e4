//! What a scene's object names: a built-in shape, or an OBJ file.
//!
//! Both the scene file (which parses the name) and the object (which loads the geometry)
//! use these, so they live apart from both.

use std::path::PathBuf;

/// The built-in shapes a scene may name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BuiltinShape {
    /// The unit sphere, intersected analytically (exact normals, no tessellation).
    Sphere,
    /// A ring tilted toward the camera.
    Torus,
    /// A cube with rounded edges, turned to show three faces.
    RoundedCube,
    /// A smoothly noise-displaced sphere.
    Blob,
}

impl BuiltinShape {
    pub const ALL: [BuiltinShape; 4] = [Self::Sphere, Self::Torus, Self::RoundedCube, Self::Blob];

    /// The name scene files use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sphere => "sphere",
            Self::Torus => "torus",
            Self::RoundedCube => "rounded-cube",
            Self::Blob => "blob",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// Where the object's geometry comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ObjectSource {
    Builtin(BuiltinShape),
    /// An .obj file, resolved against the scene file's directory.
    Obj(PathBuf),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for shape in BuiltinShape::ALL {
            assert_eq!(BuiltinShape::from_name(shape.name()), Some(shape));
        }
        assert_eq!(BuiltinShape::from_name("cube"), None);
    }
}
