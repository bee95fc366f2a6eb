//! Occluded-joint estimation: Rebecchi's constrained particle filter with body, range-of-motion, environment-mesh and depth-map occlusion constraints, plus its assembly-scene experiment.
//!
//! When a wrist disappears behind a shelf or a robot link the camera gives nothing; this crate
//! estimates where the joint can be and how sure we are, following Rebecchi's *enhanced
//! constrained particle filter* (after Casalino et al.).
//!
//! - [`filter`]: one [`filter::ConstrainedParticleFilter`] per joint: constant velocity,
//!   Gaussian likelihood when observed, uniform weights when not, constraints as vetoes
//!   (collision, skeletal distance, range of motion, occlusion), systematic resampling, weighted
//!   mean and 95 % ellipsoid volume. Seeded and allocation-free per step.
//! - [`rng`]: the filters' random streams (xoshiro256++ for nomen's, ChaCha8 for Rebecchi's).
//! - [`rom`]: the joint bounding volume (elbow 20°–180°, shoulder limits of Rebecchi eq. 6.1 as
//!   we read them, with relaxation).
//! - [`environment`]: OBJ/PLY meshes placed by `world_from_mesh`, BVH ray casting with parry3d,
//!   moving boxes.
//! - [`depth`]: pinhole camera, depth images and the occlusion test with on-demand hole filling.
//! - [`transform`]: homogeneous-transform composition (Rebecchi's camera alignment) and
//!   `world_from_mesh` fitting through `nomen-calib`.
//! - [`refiner`]: the streaming API: [`refiner::JointRefiner::step`] takes one track's observed
//!   joints and returns refined elbows and wrists with covariance, observed joints unchanged.
//! - [`scene`]: Rebecchi's assembly scene (table, shelf unit, moving robot link, 25 reaching
//!   cycles) with lazily rendered depth.
//! - [`experiment`]: the three variants of Rebecchi's §7.3 on that scene, with box plots.
//!
//! Sans-IO: meshes are parsed from readers, plots are returned as PNG bytes; the CLI opens and
//! writes files.

pub mod depth;
pub mod environment;
mod error;
pub mod experiment;
pub mod filter;
pub mod plots;
pub mod refiner;
pub mod rng;
pub mod rom;
pub mod scene;
pub mod transform;

pub use error::{OcclusionError, Result};

pub use experiment::{OcclusionExperimentConfig, OcclusionReport, run_occlusion_experiment};
pub use refiner::{JointRefiner, RefinedJoint, RefinerConfig};
