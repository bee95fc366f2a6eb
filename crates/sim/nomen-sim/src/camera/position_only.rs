//! A position-only tracker's output from what its camera model saw: one point per track, in
//! the tracker's own frame and units ([`PositionOnlyConfig`]).

use super::config::PositionOnlyConfig;
use super::sim::{CameraModel, CameraOutput};
use crate::rng::SimRng;
use nalgebra::Vector3;
use nomen_core::skeleton::Joints;
use nomen_core::{JointObservation, JointState, SkeletonObservation};
use rand::Rng;
use rand_distr::StandardNormal;

/// Turns `out` (the skeletons `model` reported, camera frame) into the tracker's points: each
/// skeleton keeps only `config.joint`, moved into the world, given the point error
/// `point_sigma_m` (horizontal, from `rng`) and moved into the tracker's frame and units. A
/// skeleton whose joint is missing is not reported (nor its truth).
pub fn to_position_only(
    out: CameraOutput,
    model: &CameraModel,
    config: &PositionOnlyConfig,
    rng: &mut SimRng,
) -> CameraOutput {
    let world_from_camera = model.world_from_camera();
    let mut kept = CameraOutput::default();
    for (obs, truth) in out.observations.into_iter().zip(out.truths) {
        let Some(j) = obs.joints.get(config.joint) else {
            continue;
        };
        if j.state == JointState::Missing {
            continue;
        }
        let blob = Vector3::new(
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
            0.0,
        ) * config.point_sigma_m;
        let p_world = world_from_camera * j.position_m + blob;
        let mut joints = Joints::new();
        joints.insert(
            config.joint,
            JointObservation {
                position_m: config.to_tracker(&p_world),
                confidence: j.confidence,
                // The tracker reports a point it measured, whatever the camera model inferred.
                state: JointState::Tracked,
                covariance_m2: None,
            },
        );
        kept.observations
            .push(SkeletonObservation { joints, ..obs });
        kept.truths.push(truth);
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    #[test]
    fn a_world_point_goes_into_the_trackers_units_and_back() {
        let config = PositionOnlyConfig {
            m_per_unit: 0.02,
            origin_m: [4.0, 3.0, 3.5],
            rotation_deg_xyz: [180.0, 0.0, 30.0],
            ..Default::default()
        };
        let p = Point3::new(5.0, 2.0, 1.7);
        let q = config.to_tracker(&p);
        // 1.8 m below the sensor, in 2-cm units, along the tracker's z (pointing down).
        assert!((q.z - 90.0).abs() < 1e-9, "{q}");
        let (scale, iso) = config.world_from_tracker();
        let back = iso * Point3::from(q.coords * scale);
        assert!((back - p).norm() < 1e-12, "{back}");
        let flat = PositionOnlyConfig {
            reports_height: false,
            ..config
        };
        assert_eq!(flat.to_tracker(&p).z, 0.0);
    }
}
