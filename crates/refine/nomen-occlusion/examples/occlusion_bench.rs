//! Speed of the constrained particle filter and of ray casting, printed as rates and as ratios
//! measured in the same run (run in release):
//! `cargo run --release -p nomen-occlusion --example occlusion_bench`.
//!
//! Workload: the assembly furniture tessellated to about [`TARGET_TRIANGLES`] triangles, a wrist
//! filter with [`NUM_PARTICLES`] particles and all four constraints (skeletal distance, range of
//! motion, environment rays, occlusion against the scene's depth image) in open loop with the
//! hand inside the shelf compartment, for Rebecchi's filter and for nomen's (after
//! [`NUM_WARM_UP_STEPS`] untimed steps, which fill the depth pixels the particles touch); and
//! elbow → random crown point rays alone. Rebecchi's Unity raycast did about 500 rays per ms. On
//! a busy machine the stable measure is the instruction count of `valgrind --tool=callgrind` on
//! this example; the argument `rebecchi` or `nomen` runs only that filter (no rays), so that
//! `valgrind --tool=callgrind --collect-atstart=no
//! '--toggle-collect=*ConstrainedParticleFilter::step' target/release/examples/occlusion_bench
//! nomen` counts the instructions of that filter's timed and warm-up steps alone
//! ([`NUM_STEPS`] + [`NUM_WARM_UP_STEPS`] + 1 steps of [`NUM_PARTICLES`] particles).
#![allow(clippy::print_stdout)]

use nalgebra::{Isometry3, Point3, Vector3};
use nomen_core::skeleton::Joint;
use nomen_occlusion::environment::Environment;
use nomen_occlusion::filter::{
    ChainContext, ConstrainedParticleFilter, ConstraintConfig, ConstraintSet, FilterConfig,
    RomContext,
};
use nomen_occlusion::scene::{AssemblyScene, AssemblySceneConfig, FOREARM_M, assembly_mesh};
use rand::{Rng, SeedableRng};
use std::time::Instant;

/// Triangles in the benchmark mesh (about).
const TARGET_TRIANGLES: usize = 100_000;
/// Particles per joint.
const NUM_PARTICLES: usize = 1000;
/// Untimed filter steps before the timed ones.
const NUM_WARM_UP_STEPS: usize = 10;
/// Filter steps timed.
const NUM_STEPS: usize = 300;
/// Rays timed.
const NUM_RAYS: usize = 1_000_000;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let only = std::env::args().nth(1);
    if let Some(name) = &only
        && name != "rebecchi"
        && name != "nomen"
    {
        return Err(format!("unknown argument {name}: expected rebecchi or nomen").into());
    }
    // 13 boxes × 12 n² triangles.
    let n = ((TARGET_TRIANGLES as f64 / (13.0 * 12.0)).sqrt().ceil()) as u32;
    let mesh = assembly_mesh(n);
    let num_triangles = mesh.triangles.len();
    let env = Environment::from_meshes(&[(mesh, Isometry3::identity())])?;
    let scene = AssemblyScene::new(AssemblySceneConfig::default())?;
    let frame = scene.frame(60); // hand inside the compartment
    let joint = |j: Joint| {
        frame
            .truth
            .get(j)
            .copied()
            .ok_or("joint missing from the scene")
    };
    let (shoulder, elbow, wrist) = (
        joint(Joint::RightShoulder)?,
        joint(Joint::RightElbow)?,
        joint(Joint::RightWrist)?,
    );
    let ctx = ChainContext {
        parent_m: elbow,
        bone_length_m: FOREARM_M,
        parent_sigma_m: f64::NAN,
        rom: RomContext::Elbow {
            shoulder_m: shoulder,
            hinge_axis: None,
        },
    };

    let mut rates = Vec::new();
    for (key, name, filter, constraints) in [
        (
            "rebecchi",
            "Rebecchi's filter",
            FilterConfig::rebecchi(),
            ConstraintConfig::rebecchi(ConstraintSet::COMPLETE),
        ),
        (
            "nomen",
            "nomen's filter",
            FilterConfig::default(),
            ConstraintConfig::default(),
        ),
    ] {
        if only.as_deref().is_some_and(|o| o != key) {
            continue;
        }
        let mut depth = scene.depth_probe();
        depth.set_frame(&frame);
        let mut filter = ConstrainedParticleFilter::new(
            FilterConfig {
                num_particles: NUM_PARTICLES,
                ..filter
            },
            constraints,
            7,
        )?;
        // Initialise closed loop on the wrist, warm up, then time open-loop steps.
        filter.step(0.0, &ctx, Some(&wrist), Some(&env), Some(&mut depth));
        for _ in 0..NUM_WARM_UP_STEPS {
            filter.step(1.0 / 30.0, &ctx, None, Some(&env), Some(&mut depth));
        }
        let start = Instant::now();
        let mut valid = 0;
        for _ in 0..NUM_STEPS {
            if let Some(e) = filter.step(1.0 / 30.0, &ctx, None, Some(&env), Some(&mut depth)) {
                valid += e.num_valid_particles;
            }
        }
        let s = start.elapsed().as_secs_f64();
        let updates = (NUM_STEPS * NUM_PARTICLES) as f64;
        println!(
            "particle updates, {name}, all constraints, {num_triangles} triangles, {NUM_PARTICLES} particles: {:.2} M/s ({:.0} ns each; {:.0}% valid; {} depth rays cached)",
            updates / s / 1e6,
            s / updates * 1e9,
            100.0 * valid as f64 / updates,
            depth.num_rays()
        );
        rates.push(updates / s);
    }
    if let [rebecchi, nomen] = rates[..] {
        println!(
            "nomen's filter / Rebecchi's: {:.2}x the updates per second",
            nomen / rebecchi
        );
    }

    if only.is_some() {
        return Ok(());
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let targets: Vec<Point3<f64>> = (0..4096)
        .map(|_| {
            elbow
                + Vector3::new(
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                )
                .normalize()
                    * FOREARM_M
        })
        .collect();
    let start = Instant::now();
    let mut hits = 0usize;
    for k in 0..NUM_RAYS {
        let t = &targets[k % targets.len()];
        hits += usize::from(env.cast_ray_static(&elbow, &(t - elbow), 1.0).is_some());
    }
    let s = start.elapsed().as_secs_f64();
    println!(
        "rays elbow → crown, {num_triangles} triangles: {:.0} rays/ms ({:.1}x Rebecchi's ~500 rays/ms; {:.0}% hit)",
        NUM_RAYS as f64 / s / 1e3,
        NUM_RAYS as f64 / s / 1e3 / 500.0,
        100.0 * hits as f64 / NUM_RAYS as f64
    );
    Ok(())
}
