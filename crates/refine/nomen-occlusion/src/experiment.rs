//! Rebecchi's §7.3 experiment on the assembly scene: Original (skeletal distance + occlusion),
//! Joint Bounding Volume (+ range of motion) and Complete (+ environment) with Rebecchi's filter
//! (rejection of vetoed particles, constant velocity, fixed crown and occlusion margin), an
//! unconstrained particle filter as a floor, and nomen's complete filter (constrained sampling,
//! velocity decaying in open loop, each wrist particle riding on its own particle of the
//! filtered elbow, an occlusion margin from the depth noise, xoshiro256++ draws), all run on the
//! same observations. Rebecchi's filters draw from ChaCha8.
//!
//! For every frame where the right wrist is not observed, each variant's estimate is compared
//! with the true wrist (error, m), the 95 % ellipsoid volume of its particles (before
//! resampling, zero-weight particles excluded) is recorded, and so is whether the truth lies
//! inside that ellipsoid (coverage: an honest 95 % ellipsoid holds the truth about 95 % of the
//! time). `error_reduction` and `volume_reduction` are `1 − median(nomen) / median(Original)`;
//! `rebecchi_error_reduction` and `rebecchi_volume_reduction` compare Rebecchi's Complete with
//! Original, the figures the thesis reports ([`PUBLISHED_ERROR_REDUCTION`],
//! [`PUBLISHED_VOLUME_REDUCTION`]). [`summarize`] gathers the reports of several seeds.

use crate::error::Result;
use crate::filter::{CHI2_3DOF_95, ConstraintConfig, ConstraintSet, FilterConfig};
use crate::refiner::{JointRefiner, RefinerConfig};
use crate::scene::{AssemblyScene, AssemblySceneConfig, FOREARM_M, UPPER_ARM_M};
use nomen_core::skeleton::Joint;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Rebecchi's reported reduction of the occluded-wrist error, Complete against Original (the
/// range over the thesis's §7.3 runs).
pub const PUBLISHED_ERROR_REDUCTION: (f64, f64) = (0.217, 0.283);
/// Rebecchi's reported reduction of the 95 % particle volume, Complete against Original.
pub const PUBLISHED_VOLUME_REDUCTION: f64 = 0.90;
/// nomen's goal for the error reduction against Original (issue 69).
pub const GOAL_ERROR_REDUCTION: f64 = 0.40;
/// nomen's goal for the volume reduction against Original (issue 69).
pub const GOAL_VOLUME_REDUCTION: f64 = 0.95;

/// Configuration of the experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OcclusionExperimentConfig {
    /// The scene (25 cycles by default).
    pub scene: AssemblySceneConfig,
    /// Rebecchi's filter, for Original, Joint Bounding Volume, Complete and the unconstrained
    /// floor. Default [`FilterConfig::rebecchi`].
    pub published_filter: FilterConfig,
    /// Rebecchi's constraint parameters (`enabled` is set per variant). Default
    /// [`ConstraintConfig::rebecchi`].
    pub published_constraints: ConstraintConfig,
    /// nomen's filter. Default [`FilterConfig::default`].
    pub filter: FilterConfig,
    /// nomen's constraints (all four on). Default [`ConstraintConfig::default`].
    pub constraints: ConstraintConfig,
    /// nomen's wrist rides on the filtered elbow ([`RefinerConfig::filtered_parent`]).
    /// Default true.
    pub filtered_parent: bool,
    /// nomen's wrist covariance adds the elbow's ([`RefinerConfig::add_parent_covariance`]).
    /// Default true.
    pub add_parent_covariance: bool,
    /// nomen's wrist particles ride on the elbow's ([`RefinerConfig::chain_sampling`]).
    /// Default true.
    pub chain_sampling: bool,
    /// Seed of the scene and of the filters.
    pub seed: u64,
}

impl Default for OcclusionExperimentConfig {
    fn default() -> Self {
        Self {
            scene: AssemblySceneConfig::default(),
            published_filter: FilterConfig::rebecchi(),
            published_constraints: ConstraintConfig::rebecchi(ConstraintSet::COMPLETE),
            filter: FilterConfig::default(),
            constraints: ConstraintConfig::default(),
            filtered_parent: true,
            add_parent_covariance: true,
            chain_sampling: true,
            seed: 1,
        }
    }
}

/// The variants, in report order: name, constraints, and whether it is nomen's filter (else
/// Rebecchi's).
pub const VARIANTS: [(&str, ConstraintSet, bool); 5] = [
    ("original", ConstraintSet::ORIGINAL, false),
    (
        "joint_bounding_volume",
        ConstraintSet::JOINT_BOUNDING_VOLUME,
        false,
    ),
    ("complete", ConstraintSet::COMPLETE, false),
    ("unconstrained", ConstraintSet::NONE, false),
    ("nomen", ConstraintSet::COMPLETE, true),
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
    /// Share of the samples whose truth lies inside the 95 % ellipsoid (ideal: 0.95).
    pub coverage_95: Option<f64>,
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
    /// `1 − median error(nomen) / median error(Original)`.
    pub error_reduction: Option<f64>,
    /// `1 − median volume(nomen) / median volume(Original)`.
    pub volume_reduction: Option<f64>,
    /// `1 − median error(Complete) / median error(Original)`: Rebecchi's figure.
    pub rebecchi_error_reduction: Option<f64>,
    /// `1 − median volume(Complete) / median volume(Original)`: Rebecchi's figure.
    pub rebecchi_volume_reduction: Option<f64>,
    /// `1 − median error(nomen) / median error(unconstrained)`.
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

/// Runs [`run_occlusion_experiment`] once per seed of `seeds` (each with `config` and that seed),
/// `num_threads` seeds at a time on scoped threads that end before it returns; the reports come
/// back in the order of `seeds`, whatever the thread count.
///
/// # Errors
/// [`crate::OcclusionError::Seed`] naming the first seed (in the order of `seeds`) whose run
/// failed or panicked.
pub fn run_seeds(
    config: &OcclusionExperimentConfig,
    seeds: &[u64],
    num_threads: usize,
) -> Result<Vec<OcclusionReport>> {
    let mut reports = Vec::with_capacity(seeds.len());
    for chunk in seeds.chunks(num_threads.max(1)) {
        let results: Vec<_> = std::thread::scope(|s| {
            let handles: Vec<_> = chunk
                .iter()
                .map(|&seed| {
                    let config = OcclusionExperimentConfig {
                        seed,
                        ..config.clone()
                    };
                    s.spawn(move || run_occlusion_experiment(&config))
                })
                .collect();
            handles.into_iter().map(|h| h.join()).collect()
        });
        for (&seed, r) in chunk.iter().zip(results) {
            let report = match r {
                Ok(Ok(report)) => report,
                Ok(Err(e)) => {
                    return Err(crate::OcclusionError::Seed {
                        seed,
                        source: Box::new(e),
                    });
                }
                Err(_) => {
                    return Err(crate::OcclusionError::Seed {
                        seed,
                        source: Box::new(crate::OcclusionError::Panicked),
                    });
                }
            };
            reports.push(report);
        }
    }
    Ok(reports)
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
    for (_, set, is_nomen) in VARIANTS {
        let (filter, constraints) = if is_nomen {
            (&config.filter, &config.constraints)
        } else {
            (&config.published_filter, &config.published_constraints)
        };
        refiners.push(JointRefiner::new(RefinerConfig {
            filter: filter.clone(),
            constraints: ConstraintConfig {
                enabled: set,
                ..constraints.clone()
            },
            refine_wrists: true,
            refine_elbows: true,
            default_upper_arm_m: UPPER_ARM_M,
            default_forearm_m: FOREARM_M,
            filtered_parent: is_nomen && config.filtered_parent,
            add_parent_covariance: is_nomen && config.add_parent_covariance,
            chain_sampling: is_nomen && config.chain_sampling,
            seed: config.seed,
        })?);
    }
    let num_cycles = config.scene.num_cycles;
    let mut errors: Vec<Vec<f64>> = vec![Vec::new(); VARIANTS.len()];
    let mut volumes: Vec<Vec<f64>> = vec![Vec::new(); VARIANTS.len()];
    let mut cycle_errors: Vec<Vec<Vec<f64>>> = vec![vec![Vec::new(); num_cycles]; VARIANTS.len()];
    let mut starved = vec![0usize; VARIANTS.len()];
    let mut covered = vec![0usize; VARIANTS.len()];
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
                covered[v] += usize::from(
                    w.covariance_m2
                        .is_some_and(|c| is_inside_95(&c, &(truth - w.position_m))),
                );
                let vol = w.ellipsoid_volume_m3.unwrap_or(f64::NAN);
                volumes[v].push(vol);
                starved[v] += usize::from(vol == 0.0);
            }
        }
    }
    let variants: Vec<VariantReport> = VARIANTS
        .iter()
        .enumerate()
        .map(|(v, (name, set, _))| {
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
                coverage_95: (!errors[v].is_empty())
                    .then(|| covered[v] as f64 / errors[v].len() as f64),
                mean_volume_m3: mean(&volumes[v]),
                median_cycle_error_m: quantile(&per_cycle, 0.5),
                num_starved: starved[v],
                errors_m: std::mem::take(&mut errors[v]),
                volumes_m3: std::mem::take(&mut volumes[v]),
            }
        })
        .collect();
    let get = |name: &str| variants.iter().find(|v| v.name == name);
    let (orig, comp, none, ours) = (
        get("original"),
        get("complete"),
        get("unconstrained"),
        get("nomen"),
    );
    let error = |v: Option<&VariantReport>| v.and_then(|v| v.median_error_m);
    let volume = |v: Option<&VariantReport>| v.and_then(|v| v.median_volume_m3);
    let error_reduction = reduction(error(ours), error(orig));
    let volume_reduction = reduction(volume(ours), volume(orig));
    let rebecchi_error_reduction = reduction(error(comp), error(orig));
    let rebecchi_volume_reduction = reduction(volume(comp), volume(orig));
    let error_reduction_vs_unconstrained = reduction(error(ours), error(none));
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
        rebecchi_error_reduction,
        rebecchi_volume_reduction,
        error_reduction_vs_unconstrained,
    })
}

/// Whether `d` (truth − estimate) lies inside the 95 % ellipsoid of `covariance`
/// (`dᵀΣ⁻¹d ≤ χ²₃(0.95)`); a singular covariance holds only `d = 0`.
pub fn is_inside_95(covariance: &nalgebra::Matrix3<f64>, d: &nalgebra::Vector3<f64>) -> bool {
    match covariance.try_inverse() {
        Some(inv) => {
            let m2 = d.dot(&(inv * d));
            m2.is_finite() && m2 <= CHI2_3DOF_95
        }
        None => d.norm_squared() == 0.0,
    }
}

/// Mean, smallest and largest of a figure over seeds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// Mean over the seeds that have the figure.
    pub mean: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
    /// Seeds that have the figure.
    pub num_seeds: usize,
}

impl Spread {
    /// The spread of the finite values; `None` when there is none.
    pub fn of(values: impl IntoIterator<Item = Option<f64>>) -> Option<Self> {
        let v: Vec<f64> = values
            .into_iter()
            .flatten()
            .filter(|x| x.is_finite())
            .collect();
        (!v.is_empty()).then(|| Self {
            mean: v.iter().sum::<f64>() / v.len() as f64,
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            num_seeds: v.len(),
        })
    }
}

/// One variant over several seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VariantSummary {
    /// Variant name.
    pub name: String,
    /// Median error per seed, m.
    pub median_error_m: Option<Spread>,
    /// Median 95 % ellipsoid volume per seed, m³.
    pub median_volume_m3: Option<Spread>,
    /// Coverage of the 95 % ellipsoid per seed.
    pub coverage_95: Option<Spread>,
}

/// The experiment over several seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OcclusionSummary {
    /// The seeds, in run order.
    pub seeds: Vec<u64>,
    /// One entry per variant, in [`VARIANTS`] order.
    pub variants: Vec<VariantSummary>,
    /// nomen against Original, per seed.
    pub error_reduction: Option<Spread>,
    /// nomen against Original, per seed.
    pub volume_reduction: Option<Spread>,
    /// Rebecchi's Complete against Original, per seed.
    pub rebecchi_error_reduction: Option<Spread>,
    /// Rebecchi's Complete against Original, per seed.
    pub rebecchi_volume_reduction: Option<Spread>,
}

/// Gathers the reports of several seeds.
pub fn summarize(reports: &[OcclusionReport]) -> OcclusionSummary {
    let variants = VARIANTS
        .iter()
        .map(|(name, _, _)| {
            let of = |f: fn(&VariantReport) -> Option<f64>| {
                Spread::of(reports.iter().map(|r| r.variant(name).and_then(f)))
            };
            VariantSummary {
                name: (*name).to_owned(),
                median_error_m: of(|v| v.median_error_m),
                median_volume_m3: of(|v| v.median_volume_m3),
                coverage_95: of(|v| v.coverage_95),
            }
        })
        .collect();
    let of = |f: fn(&OcclusionReport) -> Option<f64>| Spread::of(reports.iter().map(f));
    OcclusionSummary {
        seeds: reports.iter().map(|r| r.seed).collect(),
        variants,
        error_reduction: of(|r| r.error_reduction),
        volume_reduction: of(|r| r.volume_reduction),
        rebecchi_error_reduction: of(|r| r.rebecchi_error_reduction),
        rebecchi_volume_reduction: of(|r| r.rebecchi_volume_reduction),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn truth_at_the_mean_is_inside_and_three_sigmas_out_is_not() {
        let c = Matrix3::from_diagonal(&Vector3::new(0.01, 0.04, 0.0025)); // σ 10, 20, 5 cm
        assert!(is_inside_95(&c, &Vector3::zeros()));
        // χ²₃(0.95) = 7.81: 2.5σ along one axis is inside, 3σ is not.
        assert!(is_inside_95(&c, &Vector3::new(0.0, 0.5, 0.0)));
        assert!(!is_inside_95(&c, &Vector3::new(0.0, 0.6, 0.0)));
        assert!(!is_inside_95(&c, &Vector3::new(0.0, 0.0, 0.15)));
        // A flat cloud holds no point off its plane.
        let flat = Matrix3::from_diagonal(&Vector3::new(0.01, 0.01, 0.0));
        assert!(!is_inside_95(&flat, &Vector3::new(0.0, 0.0, 1e-6)));
    }

    #[test]
    fn spread_skips_missing_and_non_finite_figures() {
        let s = Spread::of([Some(0.2), None, Some(f64::NAN), Some(0.4)]).unwrap();
        assert!((s.mean - 0.3).abs() < 1e-12);
        assert_eq!((s.min, s.max, s.num_seeds), (0.2, 0.4, 2));
        assert!(Spread::of([None, Some(f64::INFINITY)]).is_none());
    }
}
