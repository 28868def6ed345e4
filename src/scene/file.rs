//! The scene file of SCENE.md: TOML, unknown keys refused, missing keys defaulted.

use super::source::{BuiltinShape, ObjectSource};
use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The largest guide image side accepted: 8192² pixels already need several GiB of buffers.
pub const MAX_RESOLUTION: u32 = 8192;

/// The most bytes a scene file may have; a real one has a few hundred.
const SCENE_FILE_LIMIT: u64 = 1 << 20;

/// One object, one directional light and one camera (SCENE.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scene {
    /// A built-in shape name ("sphere", "torus", "rounded-cube", "blob") or a path to an
    /// .obj file, relative to the scene file.
    pub object: String,
    /// The guide image is `resolution × resolution` pixels.
    pub resolution: u32,
    /// Whether cast shadows are traced; shadowed pixels give no samples.
    pub shadows: bool,
    /// World vector projected onto the surface to give φ = 0.
    pub tangent_reference: [f64; 3],
    pub light: LightSettings,
    pub camera: CameraSettings,
    /// The directory relative object paths are resolved against: the scene file's own after
    /// [`Scene::load`]; empty (the working directory) by default. Not part of the file.
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// The white directional light of irradiance π.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LightSettings {
    /// Angle above the world's horizontal x-z plane, in (0, 90].
    pub elevation_deg: f64,
    /// Around y: 0 points toward the default camera (+z), 90 toward +x.
    pub azimuth_deg: f64,
}

/// How the object is seen.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraSettings {
    pub projection: Projection,
    /// Perspective only: vertical field of view, in (0, 180).
    pub fov_deg: f64,
    /// Orbit around y; 0 puts the camera on +z looking toward -z.
    pub yaw_deg: f64,
    /// Orbit upward (+) or downward (-), in [-90, 90].
    pub pitch_deg: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Projection {
    #[default]
    Orthographic,
    Perspective,
}

impl Default for Scene {
    fn default() -> Self {
        Self {
            object: BuiltinShape::Sphere.name().to_owned(),
            resolution: 512,
            shadows: true,
            tangent_reference: [1.0, 0.0, 0.0],
            light: LightSettings::default(),
            camera: CameraSettings::default(),
            base_dir: PathBuf::new(),
        }
    }
}

impl Default for LightSettings {
    fn default() -> Self {
        Self {
            elevation_deg: 45.0,
            azimuth_deg: 30.0,
        }
    }
}

impl Default for CameraSettings {
    fn default() -> Self {
        Self {
            projection: Projection::Orthographic,
            fov_deg: 30.0,
            yaw_deg: 0.0,
            pitch_deg: 0.0,
        }
    }
}

impl Scene {
    /// Reads and checks a scene file; a relative object path is resolved against its directory.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = crate::bounded_read::read_text_at_most(path, SCENE_FILE_LIMIT, "a scene file")?;
        Self::parse(&text, path)
    }

    /// Parses and checks scene TOML as if read from `path`, which names the file in errors
    /// and gives the directory relative object paths are resolved against.
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let mut scene: Scene = toml::from_str(text)
            .map_err(|e| Error::invalid(path, format!("not a valid scene file: {e}")))?;
        scene
            .check()
            .map_err(|problem| Error::invalid(path, problem))?;
        scene.base_dir = parent_dir(path).to_path_buf();
        Ok(scene)
    }

    /// The scene as TOML text, every key written out.
    pub fn to_toml(&self) -> String {
        // Only strings, numbers, booleans and tables: serialising cannot fail.
        toml::to_string(self).expect("a scene serialises to TOML")
    }

    /// Writes the scene to `path` atomically. A relative object path that would no longer
    /// resolve from the new file's directory is written as an absolute path.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let mut saved = self.clone();
        if let ObjectSource::Obj(resolved) = self.object_source()
            && Path::new(&self.object).is_relative()
            && !same_directory(&self.base_dir, parent_dir(path))
        {
            let absolute = std::path::absolute(&resolved).unwrap_or(resolved);
            saved.object = absolute.to_string_lossy().into_owned();
        }
        let text = saved.to_toml();
        write_atomically(path, |w| w.write_all(text.as_bytes()))
    }

    /// The built-in shape or the resolved .obj path that [`Scene::object`] names.
    pub fn object_source(&self) -> ObjectSource {
        match BuiltinShape::from_name(&self.object) {
            Some(shape) => ObjectSource::Builtin(shape),
            None => ObjectSource::Obj(self.base_dir.join(&self.object)),
        }
    }

    /// Every value in range, as a sentence naming the key when not.
    pub fn check(&self) -> std::result::Result<(), String> {
        if BuiltinShape::from_name(&self.object).is_none() {
            let is_obj = Path::new(&self.object)
                .extension()
                .is_some_and(|ext| ext.eq_ignore_ascii_case("obj"));
            if !is_obj {
                let names: Vec<&str> = BuiltinShape::ALL.iter().map(|s| s.name()).collect();
                return Err(format!(
                    "object = {:?} is neither a built-in shape ({}) nor a path to an .obj file",
                    self.object,
                    names.join(", ")
                ));
            }
        }
        if self.resolution == 0 || self.resolution > MAX_RESOLUTION {
            return Err(format!(
                "resolution = {} is out of range: it must be 1 to {MAX_RESOLUTION}",
                self.resolution
            ));
        }
        let r = self.tangent_reference;
        if r.iter().any(|c| !c.is_finite()) || r.iter().all(|&c| c == 0.0) {
            return Err(format!(
                "tangent_reference = {r:?} must be a finite, non-zero vector"
            ));
        }
        let light = &self.light;
        if !(light.elevation_deg > 0.0 && light.elevation_deg <= 90.0) {
            return Err(format!(
                "light.elevation_deg = {} puts the light on or below the horizon \
                 (it must be above 0 and at most 90)",
                light.elevation_deg
            ));
        }
        if !light.azimuth_deg.is_finite() {
            return Err(format!(
                "light.azimuth_deg = {} must be finite",
                light.azimuth_deg
            ));
        }
        let camera = &self.camera;
        if !(camera.fov_deg > 0.0 && camera.fov_deg < 180.0) {
            return Err(format!(
                "camera.fov_deg = {} must be between 0 and 180, exclusive",
                camera.fov_deg
            ));
        }
        if !camera.yaw_deg.is_finite() {
            return Err(format!(
                "camera.yaw_deg = {} must be finite",
                camera.yaw_deg
            ));
        }
        if !(camera.pitch_deg >= -90.0 && camera.pitch_deg <= 90.0) {
            return Err(format!(
                "camera.pitch_deg = {} must be within [-90, 90]",
                camera.pitch_deg
            ));
        }
        Ok(())
    }
}

fn parent_dir(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

fn same_directory(a: &Path, b: &Path) -> bool {
    let canonical = |p: &Path| {
        let p = if p.as_os_str().is_empty() {
            Path::new(".")
        } else {
            p
        };
        p.canonicalize().ok()
    };
    a == b || matches!((canonical(a), canonical(b)), (Some(x), Some(y)) if x == y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_file_gives_the_documented_defaults() {
        let scene = Scene::parse("", Path::new("dir/s.toml")).unwrap();
        let expected = Scene {
            base_dir: "dir".into(),
            ..Scene::default()
        };
        assert_eq!(scene, expected);
        assert_eq!(scene.object, "sphere");
        assert_eq!(scene.resolution, 512);
        assert!(scene.shadows);
        assert_eq!(scene.tangent_reference, [1.0, 0.0, 0.0]);
        assert_eq!(
            (scene.light.elevation_deg, scene.light.azimuth_deg),
            (45.0, 30.0)
        );
        assert_eq!(scene.camera.projection, Projection::Orthographic);
        assert_eq!(scene.camera.fov_deg, 30.0);
        assert_eq!((scene.camera.yaw_deg, scene.camera.pitch_deg), (0.0, 0.0));
    }

    #[test]
    fn toml_round_trips_and_accepts_integers_for_angles() {
        let text = "object = \"meshes/x.obj\"\nresolution = 64\n[light]\nelevation_deg = 60\n\
                    [camera]\nprojection = \"perspective\"\nyaw_deg = -20\n";
        let scene = Scene::parse(text, Path::new("a/b.toml")).unwrap();
        assert_eq!(scene.light.elevation_deg, 60.0);
        assert_eq!(scene.light.azimuth_deg, 30.0);
        assert_eq!(scene.camera.projection, Projection::Perspective);
        assert_eq!(
            scene.object_source(),
            ObjectSource::Obj(PathBuf::from("a/meshes/x.obj"))
        );
        let again = Scene::parse(&scene.to_toml(), Path::new("a/b.toml")).unwrap();
        assert_eq!(again, scene);
    }

    #[test]
    fn out_of_range_values_name_the_key() {
        let cases = [
            ("resolution = 0", "resolution"),
            ("resolution = 9000", "resolution"),
            ("tangent_reference = [0.0, 0.0, 0.0]", "tangent_reference"),
            ("tangent_reference = [nan, 0.0, 1.0]", "tangent_reference"),
            ("[light]\nelevation_deg = 0.0", "elevation_deg"),
            ("[light]\nelevation_deg = -10.0", "elevation_deg"),
            ("[light]\nelevation_deg = nan", "elevation_deg"),
            ("[light]\nazimuth_deg = inf", "azimuth_deg"),
            ("[camera]\nfov_deg = 180.0", "fov_deg"),
            ("[camera]\nfov_deg = 0.0", "fov_deg"),
            ("[camera]\npitch_deg = 91.0", "pitch_deg"),
            ("object = \"cube\"", "cube"),
            ("shape = \"sphere\"", "shape"),
            ("[camera]\nzoom = 2.0", "zoom"),
            ("[camera]\nprojection = \"fisheye\"", "fisheye"),
            ("resolution = -3", "resolution"),
            ("resolution = ", "s.toml"),
        ];
        for (text, key) in cases {
            let err = Scene::parse(text, Path::new("dir/s.toml"))
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("dir/s.toml") && err.contains(key),
                "{text:?}: {err}"
            );
        }
    }
}
