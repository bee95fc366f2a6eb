//! The ASF/AMC reader against the Acclaim semantics and CMU's files in
//! `shared/data/mocap/cmu-asfamc`. Expected values come from the data README (scale, rate, frame
//! numbering, the 02_01 BVH conversion of the same take), the ASF's own numbers, or the Acclaim
//! formula `R_bone = R_parent · C · M · C⁻¹`, `end = start + R_bone · direction · length`
//! evaluated here independently of the reader's Euler angles.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

use nalgebra::{Point3, Rotation3, Vector3};
use nomen_core::Joint;
use nomen_core::frame::z_up_from_y_up;
use nomen_mocap::asf::Dof;
use nomen_mocap::{
    Asf, Bvh, ConvertOptions, MocapClip, SkeletonVariant, convert, forward_kinematics, parse_amc,
    parse_asf, read_asf_amc_files, read_bvh_file, rest_stature_m,
};
use std::path::{Path, PathBuf};

const DATA_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../../shared/data/mocap");

/// CMU's ASF length unit, `:units length 0.45`: 1/0.45 inch = 0.0564444 m (data README).
const CMU_SCALE: f64 = 0.0564444;

/// Every take in the data README, with its subject's skeleton.
const TAKES: [(&str, &str); 14] = [
    ("02", "02_01"),
    ("02", "02_02"),
    ("02", "02_03"),
    ("02", "02_04"),
    ("02", "02_05"),
    ("02", "02_06"),
    ("02", "02_07"),
    ("02", "02_08"),
    ("02", "02_09"),
    ("02", "02_10"),
    ("03", "03_01"),
    ("03", "03_02"),
    ("03", "03_03"),
    ("03", "03_04"),
];

fn data_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(DATA_DIR).join("cmu-asfamc");
    if dir.is_dir() {
        Some(PathBuf::from(DATA_DIR))
    } else {
        println!("skipping: {} not found", dir.display());
        None
    }
}

fn read_asf(dir: &Path, subject: &str) -> Asf {
    let path = dir.join(format!("cmu-asfamc/{subject}.asf"));
    parse_asf(
        &std::fs::read_to_string(&path).unwrap(),
        &path.display().to_string(),
    )
    .unwrap()
}

fn read_take(dir: &Path, subject: &str, take: &str) -> Bvh {
    read_asf_amc_files(
        &dir.join(format!("cmu-asfamc/{subject}.asf")),
        &dir.join(format!("cmu-asfamc/{take}.amc")),
    )
    .unwrap()
}

fn options(scale: f64) -> ConvertOptions {
    ConvertOptions {
        scale: Some(scale),
        ..Default::default()
    }
}

fn pos(clip: &MocapClip, frame: usize, joint: Joint) -> Point3<f64> {
    clip.joint(frame, joint).unwrap().position_m
}

/// Nodes that start where `node` ends: its child bones and its End Site.
fn children(bvh: &Bvh, node: usize) -> impl Iterator<Item = usize> + '_ {
    (0..bvh.nodes.len()).filter(move |&c| bvh.nodes[c].parent == Some(node))
}

#[test]
fn every_take_maps_all_joints_at_a_human_size_with_the_asf_bone_lengths() {
    let Some(dir) = data_dir() else { return };
    for (subject, take) in TAKES {
        let asf = read_asf(&dir, subject);
        assert!((asf.cmu_metres_per_unit() / CMU_SCALE - 1.0).abs() < 1e-6);
        assert_eq!(asf.bones.len(), 30, "{subject}.asf");
        let bvh = read_take(&dir, subject, take);
        let clip = convert(&bvh, &options(CMU_SCALE)).unwrap();
        assert_eq!(clip.mapping.variant, SkeletonVariant::CmuAsf, "{take}");
        assert!(clip.warnings.is_empty(), "{take}: {:?}", clip.warnings);
        assert_eq!(clip.rate_hz, 120.0, "{take}");
        // Frames are numbered 1, 2, ... (README): the last number is the count.
        let text = std::fs::read_to_string(dir.join(format!("cmu-asfamc/{take}.amc"))).unwrap();
        let last_number: usize = text
            .lines()
            .map(str::trim)
            .rfind(|l| !l.is_empty() && l.bytes().all(|c| c.is_ascii_digit()))
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(clip.num_frames, last_number, "{take}");
        for (f, frame) in clip.frames.iter().enumerate() {
            assert_eq!(frame.len(), 20, "{take} frame {f}");
            for (j, p) in frame.iter() {
                assert!(
                    p.position_m.coords.iter().all(|v| v.is_finite()),
                    "{take} frame {f}: {j:?}"
                );
            }
        }
        // The T-posed skeleton, floor to the top of the head bone.
        let stature_m = rest_stature_m(&bvh, CMU_SCALE);
        println!(
            "{take}: {} frames, rest stature {stature_m:.3} m",
            clip.num_frames
        );
        assert!(
            (1.5..=1.95).contains(&stature_m),
            "{take}: {stature_m:.3} m"
        );
        // Every bone, in every frame, is as long as the ASF says: its children (and End Site)
        // start at its end. The root's children start at the root.
        for f in 0..clip.num_frames {
            let poses = clip.node_poses(f).unwrap();
            for (b, node) in bvh.nodes.iter().enumerate() {
                let want_m = match asf.bone_index(&node.name) {
                    Some(i) => asf.bones[i].length * CMU_SCALE,
                    None if b == 0 => 0.0,
                    None => continue, // an End Site
                };
                for c in children(&bvh, b) {
                    let got_m = (poses[c].position_m - poses[b].position_m).norm();
                    assert!(
                        (got_m - want_m).abs() <= 1e-9 * want_m.max(0.01),
                        "{take} frame {f}: {} is {got_m} m, ASF length {want_m} m",
                        node.name
                    );
                }
            }
        }
    }
}

/// Least-squares `b ≈ s · a + o` over all points: `(s, o, largest residual)`.
fn fit_scale_offset(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> (f64, Vector3<f64>, f64) {
    let n = a.len() as f64;
    let mean_a = a.iter().sum::<Vector3<f64>>() / n;
    let mean_b = b.iter().sum::<Vector3<f64>>() / n;
    let (mut num, mut den) = (0.0, 0.0);
    for (pa, pb) in a.iter().zip(b) {
        num += (pa - mean_a).dot(&(pb - mean_b));
        den += (pa - mean_a).norm_squared();
    }
    let s = num / den;
    let o = mean_b - s * mean_a;
    let worst = a
        .iter()
        .zip(b)
        .map(|(pa, pb)| (s * pa + o - pb).norm())
        .fold(0.0, f64::max);
    (s, o, worst)
}

/// Mean and largest angle between the `from → to` segment of two clips over all frames, degrees.
fn segment_angles_deg(a: &MocapClip, b: &MocapClip, from: Joint, to: Joint) -> (f64, f64) {
    let mut sum = 0.0;
    let mut worst: f64 = 0.0;
    for f in 0..a.num_frames {
        let da = (pos(a, f, to) - pos(a, f, from)).normalize();
        let db = (pos(b, f, to) - pos(b, f, from)).normalize();
        let angle = da.dot(&db).clamp(-1.0, 1.0).acos().to_degrees();
        sum += angle;
        worst = worst.max(angle);
    }
    (sum / a.num_frames as f64, worst)
}

#[test]
fn walk_02_01_moves_like_its_bvh_conversion() {
    let Some(dir) = data_dir() else { return };
    let amc = convert(&read_take(&dir, "02", "02_01"), &options(CMU_SCALE)).unwrap();
    let bvh = convert(
        &read_bvh_file(&dir.join("cmu/02_01.bvh")).unwrap(),
        &options(CMU_SCALE),
    )
    .unwrap();
    // Same take, same clock.
    assert_eq!(amc.num_frames, bvh.num_frames);
    assert_eq!(amc.rate_hz, bvh.rate_hz);

    // Root path. The BVH was re-targeted onto another skeleton, and re-targeting scales the
    // root's translation by a ratio of the two skeletons' sizes: allow one scale factor and
    // one offset. Residual tolerance 0.1 mm: both files print the root to 6 significant
    // digits (AMC, ≤ 5e-5 units ≈ 3 µm on these values) or 6 decimals (BVH).
    let root = |clip: &MocapClip| -> Vec<Vector3<f64>> {
        (0..clip.num_frames)
            .map(|f| pos(clip, f, Joint::Pelvis).coords)
            .collect()
    };
    let (s, o, worst_m) = fit_scale_offset(&root(&amc), &root(&bvh));
    println!(
        "02_01: BVH root = {s:.6} × AMC root + {:.2e} m, largest residual {:.2e} m",
        o.norm(),
        worst_m
    );
    assert!(worst_m < 1e-4, "residual {worst_m} m");
    // No offset: both paths are in the capture volume's frame.
    assert!(o.norm() < 1e-3, "offset {o:?}");
    // A re-target onto another adult: a few per cent, not a unit change.
    assert!((0.9..=1.1).contains(&s), "scale {s}");

    // Walking pace in the AMC's own units (the README's 1.25 m/s for the BVH, over s).
    let last = amc.num_frames - 1;
    let travel = |clip: &MocapClip| {
        (pos(clip, last, Joint::Pelvis) - pos(clip, 0, Joint::Pelvis))
            .xy()
            .norm()
    };
    let pace_mps = travel(&amc) / amc.time_s(last);
    println!(
        "02_01: AMC travels {:.3} m at {pace_mps:.3} m/s, BVH {:.3} m",
        travel(&amc),
        travel(&bvh)
    );
    assert!((1.1..=1.4).contains(&pace_mps), "{pace_mps:.3} m/s");
    assert!((s * travel(&amc) - travel(&bvh)).abs() < 1e-3);

    // Rotation conventions: the forearm's direction is decided by every rotation from the
    // root through the spine, clavicle, humerus (a three-angle `axis`, three dofs) and radius.
    // The re-target keeps segment directions; composing C or M in the other order puts the
    // forearms 28–66° off on average.
    for (from, to) in [
        (Joint::LeftElbow, Joint::LeftWrist),
        (Joint::RightElbow, Joint::RightWrist),
        (Joint::Pelvis, Joint::Chest),
    ] {
        let (mean_deg, worst_deg) = segment_angles_deg(&amc, &bvh, from, to);
        println!("02_01: {from:?} → {to:?}: {mean_deg:.2}° mean, {worst_deg:.2}° worst");
        assert!(mean_deg < 2.0 && worst_deg < 5.0, "{from:?} → {to:?}");
    }
}

#[test]
fn zero_dofs_lay_every_bone_along_its_asf_direction() {
    let Some(dir) = data_dir() else { return };
    let asf = read_asf(&dir, "02");
    // One frame: the root at (1, 2, 3) unturned, every dof zero.
    let mut amc = String::from(":FULLY-SPECIFIED\n:DEGREES\n1\nroot 1 2 3 0 0 0\n");
    for bone in asf.bones.iter().filter(|b| !b.dofs.is_empty()) {
        amc.push_str(&bone.name);
        amc.push_str(&" 0".repeat(bone.dofs.len()));
        amc.push('\n');
    }
    let bvh = parse_amc(&amc, &asf, "rest.amc").unwrap();
    let mut poses = Vec::new();
    forward_kinematics(&bvh, bvh.frame(0).unwrap(), CMU_SCALE, &mut poses);
    let z_up = z_up_from_y_up();
    let root = z_up * Point3::new(1.0, 2.0, 3.0) * CMU_SCALE;
    assert!((poses[0].position_m - root).norm() < 1e-12);
    for (b, node) in bvh.nodes.iter().enumerate() {
        assert!(
            poses[b].world_from_joint.angle_to(&z_up) < 1e-12,
            "{}",
            node.name
        );
        let Some(i) = asf.bone_index(&node.name) else {
            continue;
        };
        let bone = &asf.bones[i];
        // The root's children start at the root.
        if bone.parent.is_none() {
            assert!((poses[b].position_m - root).norm() < 1e-12, "{}", node.name);
        }
        // Y up in the file, Z up here.
        let want = z_up * (bone.direction * bone.length * CMU_SCALE);
        for c in children(&bvh, b) {
            let got = poses[c].position_m - poses[b].position_m;
            assert!(
                (got - want).norm() < 1e-12,
                "{}: {got:?} vs {want:?}",
                node.name
            );
        }
    }
    // One bone with the file's numbers: `lfemur` is `direction 0.34202 -0.939693 0`,
    // `length 7.59371`: 0.4286 m, out to the left (+x) and down (−z once Z is up).
    let femur = bvh.node_index("lfemur").unwrap();
    let knee = bvh.node_index("ltibia").unwrap();
    let got = poses[knee].position_m - poses[femur].position_m;
    let want = Vector3::new(0.34202, 0.0, -0.939693) * 7.59371 * CMU_SCALE;
    assert!((got - want).norm() < 1e-6, "{got:?}");
}

/// A root and three bones. `upper`'s axis turns its local x onto global +y, `lower`'s turns
/// its local y onto global +z, `tip` has two dofs whose order matters. Lines end in CRLF, as
/// CMU's do.
const ARM_ASF: &str = "# hand-derived test skeleton\r
:units\r
  length 1\r
  angle deg\r
:root\r
  order TX TY TZ RX RY RZ\r
  axis XYZ\r
  position 0 0 0\r
  orientation 0 0 0\r
:bonedata\r
  begin\r
    id 1\r
    name upper\r
    direction 1 0 0\r
    length 2\r
    axis 0 0 90 XYZ\r
    dof rx\r
  end\r
  begin\r
    id 2\r
    name lower\r
    direction 1 0 0\r
    length 1\r
    axis 90 0 0 XYZ\r
    dof ry\r
  end\r
  begin\r
    id 3\r
    name tip\r
    direction 0 1 0\r
    length 0.5\r
    axis 0 0 0 XYZ\r
    dof rx rz\r
  end\r
:hierarchy\r
  begin\r
    root upper\r
    upper lower\r
    lower tip\r
  end\r
";

#[test]
fn hand_derived_acclaim_poses_come_out_of_the_conversion() {
    let asf = parse_asf(ARM_ASF, "arm.asf").unwrap();
    let amc = ":FULLY-SPECIFIED\r\n:DEGREES\r\n1\r\nroot 1 2 3 0 90 0\r\nupper 90\r\nlower 90\r\ntip 90 90\r\n";
    let bvh = parse_amc(amc, &asf, "arm.amc").unwrap();
    let mut poses = Vec::new();
    forward_kinematics(&bvh, bvh.frame(0).unwrap(), 1.0, &mut poses);
    let at = |name: &str| poses[bvh.node_index(name).unwrap()].position_m;
    // In the file's Y-up axes, by hand:
    // - root at (1, 2, 3), turned 90° about +y (x → −z, z → x);
    // - upper: rx turns about its local x = global +y (axis z 90): with the root, 180° about
    //   +y, so the bone (2 along +x) points along −x: it ends at (−1, 2, 3);
    // - lower: ry turns about its local y = global +z (axis x 90): +x → +y, which the 180°
    //   about y keeps: it ends 1 higher, at (−1, 3, 3);
    // - tip: rx first (+y → +z), then rz (keeps +z); lower's rotation (R_y(180°) · R_z(90°))
    //   takes +z to −z: it ends at (−1, 3, 2.5). (rz first would give +y → −x → (0, −1, 0).)
    let y_up = [
        ("upper", [1.0, 2.0, 3.0]),
        ("lower", [-1.0, 2.0, 3.0]),
        ("tip", [-1.0, 3.0, 3.0]),
        ("tip_end", [-1.0, 3.0, 2.5]),
    ];
    for (name, [x, y, z]) in y_up {
        // Y up → Z up: (x, y, z) → (x, −z, y).
        let want = Point3::new(x, -z, y);
        assert!(
            (at(name) - want).norm() < 1e-12,
            "{name}: {:?} vs {want:?}",
            at(name)
        );
    }
}

/// The Acclaim formula, evaluated directly: the start of every bone and the end of the last,
/// Y up, file units.
fn acclaim_positions(
    asf: &Asf,
    root_values: &[f64],
    bone_values: &[Vec<f64>],
) -> Vec<Vector3<f64>> {
    let rotation = |dofs: &[Dof], values: &[f64]| {
        // M: the first dof applied first.
        dofs.iter()
            .zip(values)
            .fold(Rotation3::identity(), |m, (d, v)| match d {
                Dof::Rotation(axis) => axis.rotation(v.to_radians()) * m,
                Dof::Translation(_) => m,
            })
    };
    let c_root = asf.root.orientation.rotation();
    let r_root = c_root * rotation(&asf.root.order, root_values) * c_root.inverse();
    let mut p_root = Vector3::zeros();
    for (dof, &v) in asf.root.order.iter().zip(root_values) {
        if let Dof::Translation(axis) = dof {
            p_root[axis.index()] = v;
        }
    }
    let mut world: Vec<(Rotation3<f64>, Vector3<f64>)> = Vec::new();
    let mut starts = Vec::new();
    for (bone, values) in asf.bones.iter().zip(bone_values) {
        let (r_parent, start) = match bone.parent {
            Some(p) => (world[p].0, world[p].1),
            None => (r_root, p_root),
        };
        let c = bone.axis.rotation();
        let r = r_parent * c * rotation(&bone.dofs, values) * c.inverse();
        starts.push(start);
        world.push((r, start + r * bone.vector()));
    }
    starts.push(world.last().unwrap().1);
    starts
}

#[test]
fn general_axes_and_dof_orders_follow_the_acclaim_formula() {
    // Three-angle axes in three orders, dofs in unusual orders, a turned root orientation.
    let asf_text = ":root
  order RZ TX RX TY RY TZ
  axis ZXY
  position 0 0 0
  orientation 10 -20 30
:bonedata
  begin
    name a
    direction 0.3 -1 0.2
    length 3
    axis 30 -40 75 XYZ
    dof rz rx ry
  end
  begin
    name b
    direction 1 0.5 -0.25
    length 2
    axis -120 35 10 ZYX
    dof ry rz
  end
  begin
    name c
    direction 0 0 1
    length 1.5
    axis 90 90 -45 YZX
    dof rx ry rz
  end
:hierarchy
  begin
    root a
    a b
    b c
  end
";
    let asf = parse_asf(asf_text, "general.asf").unwrap();
    // Deterministic angles, including 90° pitches (gimbal lock in the reader's Z-Y-X angles).
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 360.0 - 180.0
    };
    for frame in 0..50 {
        let mut values: Vec<Vec<f64>> = asf
            .bones
            .iter()
            .map(|b| b.dofs.iter().map(|_| next()).collect())
            .collect();
        if frame % 5 == 0 {
            values[2][1] = 90.0;
            values[0][2] = -90.0;
        }
        // The root's values in its `order`: RZ TX RX TY RY TZ.
        let root_values = [next(), 0.5, next(), -1.5, next(), 2.0];
        let amc = format!(
            "1\nroot {}\na {}\nb {}\nc {}\n",
            root_values.map(|v| v.to_string()).join(" "),
            values[0]
                .iter()
                .map(f64::to_string)
                .collect::<Vec<_>>()
                .join(" "),
            values[1]
                .iter()
                .map(f64::to_string)
                .collect::<Vec<_>>()
                .join(" "),
            values[2]
                .iter()
                .map(f64::to_string)
                .collect::<Vec<_>>()
                .join(" "),
        );
        let bvh = parse_amc(&amc, &asf, "general.amc").unwrap();
        let mut poses = Vec::new();
        forward_kinematics(&bvh, bvh.frame(0).unwrap(), 1.0, &mut poses);
        let want = acclaim_positions(&asf, &root_values, &values);
        let z_up = z_up_from_y_up();
        for (name, w) in ["a", "b", "c", "c_end"].iter().zip(want) {
            let got = poses[bvh.node_index(name).unwrap()].position_m;
            assert!(
                (got - z_up * Point3::from(w)).norm() < 1e-9,
                "frame {frame} {name}: {got:?} vs {:?}",
                z_up * Point3::from(w)
            );
        }
    }
}

#[test]
fn file_errors_name_the_file_and_line() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("asf_amc_errors");
    std::fs::create_dir_all(&dir).unwrap();
    let asf_path = dir.join("arm.asf");
    let amc_path = dir.join("arm.amc");
    std::fs::write(&asf_path, ARM_ASF).unwrap();
    std::fs::write(
        &amc_path,
        "1\nroot 1 2 3 0 90 0\nupper 90\nlower 90\ntip 90\n",
    )
    .unwrap();
    let e = read_asf_amc_files(&asf_path, &amc_path)
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!(
            "{}:5: bone 'tip' has 1 values, expected 2 (dof: rx rz)",
            amc_path.display()
        )
    );
    std::fs::write(&asf_path, ARM_ASF.replace("lower tip", "lower toe")).unwrap();
    let e = read_asf_amc_files(&asf_path, &amc_path)
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!(
            "{}:39: unknown bone 'toe' (not defined in the skeleton's :bonedata)",
            asf_path.display()
        )
    );
    std::fs::write(&asf_path, ARM_ASF).unwrap();
    let missing = dir.join("missing.amc");
    let e = read_asf_amc_files(&asf_path, &missing)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(&format!("{}: cannot read", missing.display())),
        "{e}"
    );
}
