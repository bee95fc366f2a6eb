//! The pose-refinement stage of `nomen run --refine-joints`: every identified skeleton gets its
//! joints back, with the elbows and wrists the camera lost estimated by
//! `nomen_occlusion::JointRefiner` (one per camera track) and marked `estimated` with their
//! covariance. Observed joints pass through unchanged.
//!
//! The stage sits after the engine: it remembers each skeleton observation until the engine's
//! decision for it comes out (decisions for a track come in time order), then refines that frame.
//! Without a depth map in the recording the occlusion constraint is off; skeletal distance,
//! range of motion and, with `--environment`, collisions with the room's meshes apply.

use anyhow::{Context, Result, bail};
use nalgebra::{Isometry3, Point3};
use nomen_core::bounded::BoundedReader;
use nomen_core::skeleton::{JointState, Joints};
use nomen_core::{
    CameraId, ClockModel, IdentifiedSkeleton, JointObservation, Registry, SessionTime,
    SkeletonObservation, TrackId,
};
use nomen_occlusion::environment::{Environment, OBJ_LIMITS, PLY_LIMITS, parse_obj, parse_ply};
use nomen_occlusion::{JointRefiner, RefinerConfig};
use std::collections::BTreeMap;
use std::path::Path;

/// Smallest standard deviation reported for an estimated joint, per axis, m (about a camera's
/// joint noise at 2–4 m).
const MIN_ESTIMATE_STD_M: f64 = 0.03;

/// Refines identified skeletons from the observations they were decided on.
pub struct Refinement {
    /// Each camera's `world_from_camera`, scale (metres per camera-frame unit) and clock.
    cameras: BTreeMap<CameraId, (Isometry3<f64>, f64, ClockModel)>,
    environment: Option<Environment>,
    /// Observations waiting for their decision, by track then time.
    observations: BTreeMap<(CameraId, TrackId, SessionTime), Joints<JointObservation>>,
    refiners: BTreeMap<(CameraId, TrackId), JointRefiner>,
    /// Joints estimated so far.
    pub num_estimated: u64,
}

impl Refinement {
    /// A stage for the cameras of `registry`, with the environment meshes of `environment` (OBJ
    /// or PLY, in the world frame), if given.
    pub fn new(registry: &Registry, environment: Option<&Path>) -> Result<Self> {
        let environment = match environment {
            Some(path) => Some(load_environment(path)?),
            None => None,
        };
        Ok(Refinement {
            cameras: registry
                .cameras
                .iter()
                .map(|c| {
                    let pose = (c.world_from_camera.to_isometry(), c.scale, c.clock);
                    (c.id.clone(), pose)
                })
                .collect(),
            environment,
            observations: BTreeMap::new(),
            refiners: BTreeMap::new(),
            num_estimated: 0,
        })
    }

    /// Remembers a skeleton observation until its decision comes out (which carries its
    /// session time: the stamp on the camera's clock).
    pub fn observe(&mut self, s: &SkeletonObservation) {
        let t = self
            .cameras
            .get(&s.camera)
            .map_or(s.t, |(_, _, clock)| clock.to_session(s.t.as_ns()));
        self.observations
            .insert((s.camera.clone(), s.track, t), s.joints.clone());
    }

    /// Fills `id.joints` with the refined joints of the observation it was decided on (camera
    /// frame, like the observation). A decision without a remembered observation is left as is.
    pub fn refine(&mut self, id: &mut IdentifiedSkeleton) -> Result<()> {
        let key = (id.camera.clone(), id.track, id.t);
        let Some(observed) = self.observations.remove(&key) else {
            return Ok(());
        };
        let Some((world_from_camera, scale, _)) = self.cameras.get(&id.camera).copied() else {
            return Ok(());
        };
        let mut world = Joints::new();
        for (j, o) in observed.iter() {
            let usable =
                o.state != JointState::Missing && o.position_m.iter().all(|v| v.is_finite());
            if usable {
                world.insert(
                    j,
                    world_from_camera * Point3::from(o.position_m.coords * scale),
                );
            }
        }
        let refiner = match self.refiners.entry((id.camera.clone(), id.track)) {
            std::collections::btree_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::btree_map::Entry::Vacant(e) => {
                let config = RefinerConfig {
                    seed: id.track.0,
                    ..RefinerConfig::default()
                };
                e.insert(JointRefiner::new(config).context("occluded-joint refiner")?)
            }
        };
        let refined = refiner.step(id.t, &world, self.environment.as_ref(), None);
        let camera_from_world = world_from_camera.inverse();
        let rotation = camera_from_world.rotation.to_rotation_matrix();
        let mut out = observed;
        for (j, r) in refined.iter() {
            if !r.is_estimated {
                continue;
            }
            let covariance_m2 = r.covariance_m2.map(|c| {
                // A particle cloud that collapsed (every survivor resampled from one particle)
                // is not certainty: never report less than the camera's own joint noise.
                let c = c + nalgebra::Matrix3::identity() * MIN_ESTIMATE_STD_M.powi(2);
                let c = rotation.matrix() * c * rotation.matrix().transpose() / (scale * scale);
                [
                    [c[(0, 0)], c[(0, 1)], c[(0, 2)]],
                    [c[(1, 0)], c[(1, 1)], c[(1, 2)]],
                    [c[(2, 0)], c[(2, 1)], c[(2, 2)]],
                ]
            });
            let position = Point3::from((camera_from_world * r.position_m).coords / scale);
            if position.iter().all(|v| v.is_finite()) {
                out.insert(
                    j,
                    JointObservation {
                        position_m: position,
                        confidence: 0.0,
                        state: JointState::Estimated,
                        covariance_m2,
                    },
                );
                self.num_estimated += 1;
            }
        }
        id.joints = out;
        // A track with nothing left to refine is finished: its filter goes with its last frame.
        let track = (id.camera.clone(), id.track);
        let is_finished = self
            .observations
            .range((track.0.clone(), track.1, SessionTime::from_ns(i64::MIN))..)
            .next()
            .is_none_or(|(k, _)| (&k.0, k.1) != (&track.0, track.1));
        if is_finished {
            self.refiners.remove(&track);
        }
        Ok(())
    }
}

/// Loads an OBJ or PLY mesh file into an environment (world frame).
fn load_environment(path: &Path) -> Result<Environment> {
    let name = path.display().to_string();
    let file = std::fs::File::open(path).with_context(|| format!("{name}: cannot open"))?;
    let is_ply = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ply"));
    let limits = if is_ply { PLY_LIMITS } else { OBJ_LIMITS };
    let mut reader = std::io::BufReader::new(BoundedReader::new(file, &name, limits));
    let parsed = if is_ply {
        parse_ply(&mut reader, &name).map(|mesh| vec![mesh])
    } else {
        parse_obj(&mut reader, &name)
    };
    // The mesh parsers do not pass on the read error that a limit raised: it is named here.
    if let Some(limit) = reader.get_ref().exceeded() {
        bail!("{limit}");
    }
    let meshes = parsed?;
    let placed: Vec<_> = meshes
        .into_iter()
        .map(|m| (m, Isometry3::identity()))
        .collect();
    Ok(Environment::from_meshes(&placed)?)
}
