//! The camera and the light of SCENE.md, in world space (y up).

use super::file::{LightSettings, Projection, Scene};
use glam::DVec3;

/// How far from the origin orthographic rays start, and where the preview's orthographic eye
/// sits: anywhere outside the unit bounding sphere.
pub const ORTHO_DISTANCE: f64 = 2.0;

/// Unit vector toward the light: (cos(el) sin(az), sin(el), cos(el) cos(az)).
pub fn light_direction(light: &LightSettings) -> DVec3 {
    let (el, az) = (
        light.elevation_deg.to_radians(),
        light.azimuth_deg.to_radians(),
    );
    DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos())
}

/// The axes of a camera orbiting the origin, shared by the scene's [`CameraRig`] and the
/// preview's camera: yaw turns it around y (0 puts it on +z, 90 on +x), pitch raises it;
/// image up is world up at pitch 0 and stays in the orbit's plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitAxes {
    /// Unit vector from the origin toward the camera; the orthographic view direction.
    pub toward_camera: DVec3,
    /// Image right and image up in world space (unit, orthogonal to `toward_camera`).
    pub right: DVec3,
    pub up: DVec3,
}

impl OrbitAxes {
    pub fn new(yaw_deg: f64, pitch_deg: f64) -> Self {
        let (yaw, pitch) = (yaw_deg.to_radians(), pitch_deg.to_radians());
        let toward_camera = DVec3::new(
            pitch.cos() * yaw.sin(),
            pitch.sin(),
            pitch.cos() * yaw.cos(),
        );
        // Right is +x turned by yaw, which stays well defined looking straight down or up.
        let right = DVec3::new(yaw.cos(), 0.0, -yaw.sin());
        let up = toward_camera.cross(right);
        Self {
            toward_camera,
            right,
            up,
        }
    }
}

/// The camera of a scene: where it is and which ray each pixel casts.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraRig {
    pub projection: Projection,
    /// Unit vector from the origin toward the camera; the orthographic view direction.
    pub toward_camera: DVec3,
    /// Image right and image up in world space (unit, orthogonal to `toward_camera`).
    pub right: DVec3,
    pub up: DVec3,
    /// Perspective: the eye. Orthographic: the centre of the plane rays start from.
    pub eye: DVec3,
    /// Half the side of the square the image spans: on the image plane for orthographic
    /// (1: it sees [-1, 1]²), at unit distance from the eye for perspective (tan(fov / 2)).
    pub half_extent: f64,
    /// Pixels along each side of the square image.
    pub resolution: usize,
}

impl CameraRig {
    /// The scene's camera on its orbit ([`OrbitAxes`]), square, framing the unit sphere.
    pub fn new(scene: &Scene) -> Self {
        let camera = &scene.camera;
        let OrbitAxes {
            toward_camera,
            right,
            up,
        } = OrbitAxes::new(camera.yaw_deg, camera.pitch_deg);
        let (eye, half_extent) = match camera.projection {
            Projection::Orthographic => (toward_camera * ORTHO_DISTANCE, 1.0),
            Projection::Perspective => {
                let half_fov = camera.fov_deg.to_radians() / 2.0;
                // At this distance the cone of the vertical fov just touches the unit sphere.
                (toward_camera / half_fov.sin(), half_fov.tan())
            }
        };
        Self {
            projection: camera.projection,
            toward_camera,
            right,
            up,
            eye,
            half_extent,
            resolution: scene.resolution as usize,
        }
    }

    /// The ray (origin, unit direction) through the centre of pixel (`x`, `y`), (0, 0) at
    /// the top left.
    pub fn pixel_ray(&self, x: usize, y: usize) -> (DVec3, DVec3) {
        let n = self.resolution as f64;
        let s = ((x as f64 + 0.5) / n * 2.0 - 1.0) * self.half_extent;
        let t = (1.0 - (y as f64 + 0.5) / n * 2.0) * self.half_extent;
        let offset = self.right * s + self.up * t;
        match self.projection {
            Projection::Orthographic => (self.eye + offset, -self.toward_camera),
            Projection::Perspective => (self.eye, (offset - self.toward_camera).normalize()),
        }
    }

    /// Unit direction from a surface point to the camera.
    pub fn view_direction(&self, point: DVec3) -> DVec3 {
        match self.projection {
            Projection::Orthographic => self.toward_camera,
            Projection::Perspective => (self.eye - point).normalize(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_camera_looks_down_minus_z_with_y_up() {
        let rig = CameraRig::new(&Scene {
            resolution: 4,
            ..Scene::default()
        });
        assert_eq!(rig.toward_camera, DVec3::Z);
        assert!((rig.right - DVec3::X).length() < 1e-15 && (rig.up - DVec3::Y).length() < 1e-15);
        let (o, d) = rig.pixel_ray(0, 0);
        assert_eq!(d, -DVec3::Z);
        assert!((o - DVec3::new(-0.75, 0.75, 2.0)).length() < 1e-15, "{o}");
    }

    #[test]
    fn orbit_directions() {
        let mut scene = Scene::default();
        scene.camera.yaw_deg = 90.0;
        let rig = CameraRig::new(&scene);
        assert!((rig.toward_camera - DVec3::X).length() < 1e-15);
        assert!((rig.right + DVec3::Z).length() < 1e-15);
        scene.camera.yaw_deg = 0.0;
        scene.camera.pitch_deg = 90.0;
        let rig = CameraRig::new(&scene);
        assert!((rig.toward_camera - DVec3::Y).length() < 1e-15);
        // Looking down from above, the image top is the far side (-z).
        assert!((rig.up + DVec3::Z).length() < 1e-15, "{}", rig.up);
    }

    #[test]
    fn perspective_frames_the_unit_sphere() {
        let mut scene = Scene {
            resolution: 2,
            ..Scene::default()
        };
        scene.camera.projection = super::super::Projection::Perspective;
        scene.camera.fov_deg = 40.0;
        let rig = CameraRig::new(&scene);
        // The ray through the top edge centre of the image grazes the sphere.
        let dir = (rig.up * rig.half_extent - rig.toward_camera).normalize();
        let closest = rig.eye - dir * rig.eye.dot(dir);
        assert!((closest.length() - 1.0).abs() < 1e-12);
    }
}
