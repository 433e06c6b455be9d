//! Which controller explores a model, and where it starts: the kiosk and replays build theirs
//! here.

use super::{Acevit, AcevitSettings, Camera, Controller, IsoCam, IsoCamSettings, SceneRef, Trackball};
use crate::scene::Store;
use glam::DVec3;

/// Which controller a replay uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControllerKind {
    /// IsoCam.
    IsoCam,
    /// Virtual trackball.
    Trackball,
    /// ACeViT.
    Acevit,
}

impl ControllerKind {
    /// Its name in traces and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::IsoCam => "isocam",
            Self::Trackball => "trackball",
            Self::Acevit => "acevit",
        }
    }
}

impl std::str::FromStr for ControllerKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "isocam" => Ok(Self::IsoCam),
            "trackball" => Ok(Self::Trackball),
            "acevit" => Ok(Self::Acevit),
            other => Err(format!("unknown controller '{other}' (isocam, trackball, acevit)")),
        }
    }
}

/// The side of a model the start view looks at when its exhibit does not say: +Z (the view
/// looks along −Z), or −Y for a model standing on Z.
pub fn default_front(up: DVec3) -> DVec3 {
    if up.dot(DVec3::Z).abs() > 0.9 { DVec3::NEG_Y } else { DVec3::Z }
}

/// The camera the kiosk starts with: the whole model framed from its `front` side (unit,
/// perpendicular to `up`; `None`: [`default_front`]), upright.
pub fn start_camera<B: AsRef<[u8]>>(store: &Store<B>, fov_y: f64, up: DVec3, front: Option<DVec3>) -> Camera {
    let center = store.to_model(store.bbox().center());
    let radius = f64::from(store.bbox().diagonal()) * 0.5;
    let from =
        front.map(|f| f - up * f.dot(up)).and_then(DVec3::try_normalize).unwrap_or_else(|| default_front(up));
    Camera::framing(center, radius.max(f64::MIN_POSITIVE), from, up, fov_y)
}

/// [`start_camera`] from the default front.
pub fn initial_camera<B: AsRef<[u8]>>(store: &Store<B>, fov_y: f64, up: DVec3) -> Camera {
    start_camera(store, fov_y, up, None)
}

/// Builds the controller of a replay (or of the kiosk); `aspect` is the projection's width /
/// height.
pub fn make_controller<B: AsRef<[u8]>>(
    scene: SceneRef<'_, B>,
    cam: Camera,
    kind: ControllerKind,
    min_distance: f64,
    up: DVec3,
    aspect: f64,
) -> Controller {
    match kind {
        ControllerKind::IsoCam => {
            let mut s = IsoCamSettings::for_model(scene.diagonal());
            s.min_distance = min_distance;
            s.up = up;
            Controller::IsoCam(IsoCam::new(scene, cam, s))
        }
        ControllerKind::Trackball => Controller::Trackball(Trackball::new(cam, min_distance)),
        ControllerKind::Acevit => Controller::Acevit(Acevit::new(
            cam,
            AcevitSettings {
                samples: 256,
                sigma_xy: 0.5,
                sigma_depth: 0.5,
                min_radius: min_distance,
                aspect,
            },
        )),
    }
}
