//! Rebecchi's §7.3 experiment on the assembly scene: Original (skeletal distance + occlusion),
//! Joint Bounding Volume (+ range of motion) and Complete (+ environment), plus an unconstrained
//! particle filter as a floor, run on the same observations with the same seeds.
//!
//! For every frame where the right wrist is not observed, each variant's estimate is compared
//! with the true wrist (error, m) and the 95 % ellipsoid volume of its particles (before
//! resampling, zero-weight particles excluded) is recorded. `error_reduction` and
//! `volume_reduction` are `1 − median(Complete) / median(Original)`.

use crate::error::Result;
use crate::filter::{ConstraintConfig, ConstraintSet, FilterConfig};
use crate::refiner::{JointRefiner, RefinerConfig};
use crate::scene::{AssemblyScene, AssemblySceneConfig, FOREARM_M, UPPER_ARM_M};
use nomen_core::skeleton::Joint;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Configuration of the experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OcclusionExperimentConfig {
    /// The scene (25 cycles by default).
    pub scene: AssemblySceneConfig,
    /// Particle-filter parameters of every variant.
    pub filter: FilterConfig,
    /// Constraint parameters of every variant (`enabled` is set per variant).
    pub constraints: ConstraintConfig,
    /// Seed of the scene and of the filters.
    pub seed: u64,
}

impl Default for OcclusionExperimentConfig {
    fn default() -> Self {
        Self {
            scene: AssemblySceneConfig::default(),
            filter: FilterConfig::default(),
            constraints: ConstraintConfig::default(),
            seed: 1,
        }
    }
}

/// The variants, in report order.
pub const VARIANTS: [(&str, ConstraintSet); 4] = [
    ("original", ConstraintSet::ORIGINAL),
    (
        "joint_bounding_volume",
        ConstraintSet::JOINT_BOUNDING_VOLUME,
    ),
    ("complete", ConstraintSet::COMPLETE),
    ("unconstrained", ConstraintSet::NONE),
];

/// Results of one variant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VariantReport {
    /// Variant name (`original`, `joint_bounding_volume`, `complete`, `unconstrained`).
    pub name: String,
    /// Constraints that were on.
    pub constraints: ConstraintSet,
    /// Occluded-wrist frames with an estimate.
    pub num_samples: usize,
    /// Median error at the occluded-wrist truth, m.
    pub median_error_m: Option<f64>,
    /// Mean error, m.
    pub mean_error_m: Option<f64>,
    /// 95th percentile of the error, m.
    pub p95_error_m: Option<f64>,
    /// Median 95 % ellipsoid volume, m³.
    pub median_volume_m3: Option<f64>,
    /// Mean 95 % ellipsoid volume, m³.
    pub mean_volume_m3: Option<f64>,
    /// Median, over cycles, of the per-cycle median error, m.
    pub median_cycle_error_m: Option<f64>,
    /// Frames where every particle was vetoed and re-seeding failed.
    pub num_starved: usize,
    /// Every error sample, m (for plots; not serialised).
    #[serde(skip)]
    pub errors_m: Vec<f64>,
    /// Every volume sample, m³ (for plots; not serialised).
    #[serde(skip)]
    pub volumes_m3: Vec<f64>,
}

/// The experiment's report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OcclusionReport {
    /// Seed of scene and filters.
    pub seed: u64,
    /// Reaching cycles.
    pub num_cycles: usize,
    /// Frames simulated.
    pub num_frames: usize,
    /// Frames where the right wrist was not observed.
    pub num_wrist_occluded_frames: usize,
    /// Frames where the right elbow was not observed.
    pub num_elbow_occluded_frames: usize,
    /// Particles per joint.
    pub num_particles: usize,
    /// Depth pixels ray-cast (lazily, shared by the variants).
    pub num_depth_rays: u64,
    /// One entry per variant, in [`VARIANTS`] order.
    pub variants: Vec<VariantReport>,
    /// `1 − median error(Complete) / median error(Original)`.
    pub error_reduction: Option<f64>,
    /// `1 − median volume(Complete) / median volume(Original)`.
    pub volume_reduction: Option<f64>,
    /// `1 − median error(Complete) / median error(unconstrained)`.
    pub error_reduction_vs_unconstrained: Option<f64>,
}

impl OcclusionReport {
    /// The variant with this name.
    pub fn variant(&self, name: &str) -> Option<&VariantReport> {
        self.variants.iter().find(|v| v.name == name)
    }
}

/// Linear-interpolated quantile of unsorted samples (non-finite ignored).
pub fn quantile(samples: &[f64], q: f64) -> Option<f64> {
    let mut s: Vec<f64> = samples.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return None;
    }
    s.sort_by(f64::total_cmp);
    let r = q.clamp(0.0, 1.0) * (s.len() - 1) as f64;
    let (lo, hi) = (r.floor() as usize, r.ceil() as usize);
    Some(s[lo] + (s[hi] - s[lo]) * (r - lo as f64))
}

fn mean(samples: &[f64]) -> Option<f64> {
    (!samples.is_empty()).then(|| samples.iter().sum::<f64>() / samples.len() as f64)
}

fn reduction(new: Option<f64>, old: Option<f64>) -> Option<f64> {
    match (new, old) {
        (Some(n), Some(o)) if o > 0.0 => Some(1.0 - n / o),
        _ => None,
    }
}

/// Runs the experiment: simulate the scene once, feed the same observations to every variant.
///
/// # Errors
/// [`crate::OcclusionError::Config`] when the scene or filter configuration is out of range.
pub fn run_occlusion_experiment(config: &OcclusionExperimentConfig) -> Result<OcclusionReport> {
    let scene = AssemblyScene::new(AssemblySceneConfig {
        seed: config.seed,
        ..config.scene.clone()
    })?;
    let mut refiners = Vec::with_capacity(VARIANTS.len());
    for (_, set) in VARIANTS {
        refiners.push(JointRefiner::new(RefinerConfig {
            filter: config.filter.clone(),
            constraints: ConstraintConfig {
                enabled: set,
                ..config.constraints.clone()
            },
            refine_wrists: true,
            refine_elbows: true,
            default_upper_arm_m: UPPER_ARM_M,
            default_forearm_m: FOREARM_M,
            seed: config.seed,
        })?);
    }
    let num_cycles = config.scene.num_cycles;
    let mut errors: Vec<Vec<f64>> = vec![Vec::new(); VARIANTS.len()];
    let mut volumes: Vec<Vec<f64>> = vec![Vec::new(); VARIANTS.len()];
    let mut cycle_errors: Vec<Vec<Vec<f64>>> = vec![vec![Vec::new(); num_cycles]; VARIANTS.len()];
    let mut starved = vec![0usize; VARIANTS.len()];
    let mut environment = scene.environment().clone();
    let mut depth = scene.depth_probe();
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed ^ 0x0B5E_77ED);
    let (mut wrist_hidden, mut elbow_hidden) = (0, 0);
    let num_frames = scene.num_frames();
    for k in 0..num_frames {
        let frame = scene.frame(k);
        depth.set_frame(&frame);
        environment.set_moving_boxes(std::slice::from_ref(&frame.robot_link));
        let observed = scene.observe(&frame, &mut depth, &mut rng);
        let is_wrist_hidden = observed.get(Joint::RightWrist).is_none();
        wrist_hidden += usize::from(is_wrist_hidden);
        elbow_hidden += usize::from(observed.get(Joint::RightElbow).is_none());
        let Some(truth) = frame.truth.get(Joint::RightWrist).copied() else {
            continue;
        };
        for (v, refiner) in refiners.iter_mut().enumerate() {
            let out = refiner.step(frame.t, &observed, Some(&environment), Some(&mut depth));
            if !is_wrist_hidden {
                continue;
            }
            if let Some(w) = out.get(Joint::RightWrist).filter(|w| w.is_estimated) {
                let e = (w.position_m - truth).norm();
                errors[v].push(e);
                if let Some(c) = cycle_errors[v].get_mut(frame.cycle) {
                    c.push(e);
                }
                let vol = w.ellipsoid_volume_m3.unwrap_or(f64::NAN);
                volumes[v].push(vol);
                starved[v] += usize::from(vol == 0.0);
            }
        }
    }
    let variants: Vec<VariantReport> = VARIANTS
        .iter()
        .enumerate()
        .map(|(v, (name, set))| {
            let per_cycle: Vec<f64> = cycle_errors[v]
                .iter()
                .filter_map(|c| quantile(c, 0.5))
                .collect();
            VariantReport {
                name: (*name).to_owned(),
                constraints: *set,
                num_samples: errors[v].len(),
                median_error_m: quantile(&errors[v], 0.5),
                mean_error_m: mean(&errors[v]),
                p95_error_m: quantile(&errors[v], 0.95),
                median_volume_m3: quantile(&volumes[v], 0.5),
                mean_volume_m3: mean(&volumes[v]),
                median_cycle_error_m: quantile(&per_cycle, 0.5),
                num_starved: starved[v],
                errors_m: std::mem::take(&mut errors[v]),
                volumes_m3: std::mem::take(&mut volumes[v]),
            }
        })
        .collect();
    let get = |name: &str| variants.iter().find(|v| v.name == name);
    let (orig, comp, none) = (get("original"), get("complete"), get("unconstrained"));
    let error_reduction = reduction(
        comp.and_then(|v| v.median_error_m),
        orig.and_then(|v| v.median_error_m),
    );
    let volume_reduction = reduction(
        comp.and_then(|v| v.median_volume_m3),
        orig.and_then(|v| v.median_volume_m3),
    );
    let error_reduction_vs_unconstrained = reduction(
        comp.and_then(|v| v.median_error_m),
        none.and_then(|v| v.median_error_m),
    );
    Ok(OcclusionReport {
        seed: config.seed,
        num_cycles,
        num_frames,
        num_wrist_occluded_frames: wrist_hidden,
        num_elbow_occluded_frames: elbow_hidden,
        num_particles: config.filter.num_particles,
        num_depth_rays: depth.num_rays(),
        variants,
        error_reduction,
        volume_reduction,
        error_reduction_vs_unconstrained,
    })
}
