//! Tag-fix and skeleton CSV import.

use super::units::{LengthUnit, TimeFormat, TimeUnit};
use super::{CsvImport, CsvInput, CsvOptions};
use crate::error::Result;
use csv::StringRecord;
use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::skeleton::sets::JointSet;
use nomen_core::{
    CameraId, Joint, JointObservation, JointState, Message, RtlsFix, SessionTime,
    SkeletonObservation, TagId, TrackId,
};
use std::io::Read;

fn is_time_unit(u: &str) -> bool {
    TimeUnit::parse(u).is_some()
}

fn is_length_unit(u: &str) -> bool {
    LengthUnit::parse(u).is_some()
}

fn is_no_unit(_: &str) -> bool {
    false
}

const TIME_NAMES: [&str; 3] = ["t", "time", "timestamp"];

/// The `x`, `y`, `z` columns and their factors to metres (unit from the column name, else from
/// the spec).
fn xyz_columns<R: Read>(
    csv: &CsvInput<R>,
    length_unit: Option<LengthUnit>,
) -> Result<[(usize, f64); 3]> {
    let mut xyz = [(0, 1.0); 3];
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        let (col, unit) = csv.require(&[name], is_length_unit)?;
        let unit = csv.unit(
            col,
            unit.as_deref(),
            LengthUnit::parse,
            length_unit,
            "x (m)",
        )?;
        xyz[axis] = (col, unit.to_metres());
    }
    Ok(xyz)
}

/// How to read a tag-fix CSV file with columns `t, tag, x, y, z [, quality]`.
///
/// Units come from the column names (`t (s)`, `t_ms`, `x_m`, `x [mm]`) or, where a name has
/// none, from this spec; a name's unit wins over the spec's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FixCsvSpec {
    /// Unit of the time column if its name has none.
    pub time_unit: Option<TimeUnit>,
    /// Unit of `x`, `y`, `z` if their names have none.
    pub length_unit: Option<LengthUnit>,
    /// Added to every time after conversion, nanoseconds.
    pub time_offset_ns: i64,
}

/// Imports RTLS fixes: columns `t` (or `time`), `tag`, `x`, `y`, `z` (world frame) and an
/// optional `quality` in `0..=1` (an empty cell is no quality).
pub fn import_fixes(
    input: impl Read,
    source: &str,
    spec: &FixCsvSpec,
    options: &CsvOptions,
) -> Result<CsvImport> {
    let mut csv = CsvInput::new(input, source, options)?;
    let (t_col, t_unit) = csv.require(&TIME_NAMES, is_time_unit)?;
    let t_format = csv.time_format(t_col, t_unit.as_deref(), spec.time_unit)?;
    let (tag_col, _) = csv.require(&["tag"], is_no_unit)?;
    let xyz = xyz_columns(&csv, spec.length_unit)?;
    let quality_col = csv.find(&["quality"], is_no_unit).map(|(c, _)| c);

    let mut record = StringRecord::new();
    while let Some(line) = csv.next_row(&mut record)? {
        let t = csv.time(&record, t_col, t_format, spec.time_offset_ns, line)?;
        let tag = record.get(tag_col).unwrap_or_default();
        if tag.is_empty() {
            return Err(csv.error(line, "empty tag id"));
        }
        let mut p = [0.0; 3];
        for (v, (col, k)) in p.iter_mut().zip(xyz) {
            *v = csv.number(&record, col, line)? * k;
        }
        let quality = match quality_col {
            Some(c) => csv.optional_number(&record, c, line)?,
            None => None,
        };
        let msg = Message::RtlsFix(RtlsFix {
            t,
            tag: TagId::new(tag),
            position_m: Point3::from(p),
            quality,
            covariance_m2: None,
        });
        csv.push(msg, line)?;
    }
    Ok(csv.finish())
}

/// How skeleton rows are laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SkeletonLayout {
    /// One row per joint: `t, camera, track, joint, x, y, z [, confidence, state]`. Consecutive
    /// rows with the same `(t, camera, track)` form one skeleton.
    #[default]
    JointPerRow,
    /// One row per skeleton: `t, camera, track`, then `<joint>_x, <joint>_y, <joint>_z` and
    /// optionally `<joint>_confidence, <joint>_state` per joint. An empty `<joint>_x` cell means
    /// the joint is absent from that skeleton.
    SkeletonPerRow,
}

/// How to read a skeleton CSV file.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SkeletonCsvSpec {
    /// Row layout.
    pub layout: SkeletonLayout,
    /// Joint names are this estimator's (e.g. `WristLeft` for Kinect v2) and are mapped onto the
    /// canonical set with [`JointSet::to_canonical`] (joints it has no place for are dropped;
    /// neck/pelvis midpoints are derived). `None`: joint names are nomen's canonical names
    /// (`left_wrist`).
    pub joint_set: Option<JointSet>,
    /// Unit of the time column if its name has none.
    pub time_unit: Option<TimeUnit>,
    /// Unit of the coordinates if their names have none.
    pub length_unit: Option<LengthUnit>,
    /// Added to every time after conversion, nanoseconds.
    pub time_offset_ns: i64,
}

/// Which joint (estimator index or canonical joint) a name stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum JointRef {
    Canonical(Joint),
    SetIndex(usize),
}

fn joint_ref(set: Option<JointSet>, name: &str) -> Option<JointRef> {
    match set {
        None => Joint::from_name(name).ok().map(JointRef::Canonical),
        Some(set) => set.index_of(name).map(JointRef::SetIndex),
    }
}

fn parse_state(cell: &str) -> Option<JointState> {
    match cell.to_lowercase().as_str() {
        "" | "tracked" => Some(JointState::Tracked),
        "inferred" => Some(JointState::Inferred),
        "missing" | "not_tracked" | "nottracked" => Some(JointState::Missing),
        _ => None,
    }
}

/// Collects one skeleton's joints, in either naming.
struct JointCollector {
    set: Option<JointSet>,
    canonical: Joints<JointObservation>,
    by_index: Vec<Option<JointObservation>>,
}

impl JointCollector {
    fn new(set: Option<JointSet>) -> Self {
        Self {
            set,
            canonical: Joints::new(),
            by_index: vec![None; set.map_or(0, JointSet::len)],
        }
    }

    /// Adds a joint; returns false if it was already present.
    fn insert(&mut self, joint: JointRef, obs: JointObservation) -> bool {
        match joint {
            JointRef::Canonical(j) => self.canonical.insert(j, obs).is_none(),
            JointRef::SetIndex(i) => match self.by_index.get_mut(i) {
                Some(slot) => slot.replace(obs).is_none(),
                None => false,
            },
        }
    }

    fn is_empty(&self) -> bool {
        self.canonical.is_empty() && self.by_index.iter().all(Option::is_none)
    }

    /// The canonical joints; resets the collector.
    fn take(&mut self) -> Joints<JointObservation> {
        let Some(set) = self.set else {
            return std::mem::take(&mut self.canonical);
        };
        // `to_canonical` wants every estimator joint: absent ones go in as `Missing` and are
        // removed again afterwards, so that only joints the file gave (or derived ones) remain.
        let absent = JointObservation {
            position_m: Point3::origin(),
            confidence: 0.0,
            state: JointState::Missing,
            covariance_m2: None,
        };
        let frame: Vec<JointObservation> =
            self.by_index.iter().map(|o| o.unwrap_or(absent)).collect();
        let mut joints = set.to_canonical(&frame).unwrap_or_default();
        for (i, o) in self.by_index.iter().enumerate() {
            if o.is_none()
                && let Some(j) = set.canonical(i)
            {
                joints.remove(j);
            }
        }
        self.by_index.iter_mut().for_each(|o| *o = None);
        joints
    }
}

/// Imports camera skeletons (joint positions in the camera frame).
pub fn import_skeletons(
    input: impl Read,
    source: &str,
    spec: &SkeletonCsvSpec,
    options: &CsvOptions,
) -> Result<CsvImport> {
    let csv = CsvInput::new(input, source, options)?;
    match spec.layout {
        SkeletonLayout::JointPerRow => import_joint_rows(csv, spec),
        SkeletonLayout::SkeletonPerRow => import_skeleton_rows(csv, spec),
    }
}

/// Columns common to both layouts.
struct Common {
    t: (usize, TimeFormat),
    camera: usize,
    track: usize,
}

fn common<R: Read>(csv: &mut CsvInput<R>, spec: &SkeletonCsvSpec) -> Result<Common> {
    let (t_col, t_unit) = csv.require(&TIME_NAMES, is_time_unit)?;
    let t_unit = csv.time_format(t_col, t_unit.as_deref(), spec.time_unit)?;
    let (camera, _) = csv.require(&["camera"], is_no_unit)?;
    let (track, _) = csv.require(&["track"], is_no_unit)?;
    Ok(Common {
        t: (t_col, t_unit),
        camera,
        track,
    })
}

fn read_key<R: Read>(
    csv: &CsvInput<R>,
    record: &StringRecord,
    c: &Common,
    spec: &SkeletonCsvSpec,
    line: u64,
) -> Result<(SessionTime, String, u64)> {
    let t = csv.time(record, c.t.0, c.t.1, spec.time_offset_ns, line)?;
    let camera = record.get(c.camera).unwrap_or_default();
    if camera.is_empty() {
        return Err(csv.error(line, "empty camera id"));
    }
    let track_cell = record.get(c.track).unwrap_or_default();
    let track = track_cell.parse::<u64>().map_err(|_| {
        csv.error(
            line,
            &format!("column 'track': cannot read '{track_cell}' as a non-negative integer"),
        )
    })?;
    Ok((t, camera.to_owned(), track))
}

fn observation<R: Read>(
    csv: &CsvInput<R>,
    record: &StringRecord,
    xyz: [(usize, f64); 3],
    confidence: Option<usize>,
    state: Option<usize>,
    line: u64,
) -> Result<JointObservation> {
    let mut p = [0.0; 3];
    for (v, (col, k)) in p.iter_mut().zip(xyz) {
        *v = csv.number(record, col, line)? * k;
    }
    let confidence = match confidence {
        Some(c) => csv.optional_number(record, c, line)?.unwrap_or(1.0),
        None => 1.0,
    };
    let state = match state {
        Some(c) => {
            let cell = record.get(c).unwrap_or_default();
            parse_state(cell).ok_or_else(|| {
                csv.error(
                    line,
                    &format!(
                        "column '{}': unknown joint state '{cell}' (expected tracked, inferred or missing)",
                        csv.header(c)
                    ),
                )
            })?
        }
        None => JointState::Tracked,
    };
    Ok(JointObservation {
        position_m: Point3::from(p),
        confidence,
        state,
        covariance_m2: None,
    })
}

fn import_joint_rows<R: Read>(mut csv: CsvInput<R>, spec: &SkeletonCsvSpec) -> Result<CsvImport> {
    let c = common(&mut csv, spec)?;
    let (joint_col, _) = csv.require(&["joint"], is_no_unit)?;
    let xyz = xyz_columns(&csv, spec.length_unit)?;
    let conf_col = csv.find(&["confidence"], is_no_unit).map(|(c, _)| c);
    let state_col = csv.find(&["state"], is_no_unit).map(|(c, _)| c);

    let mut record = StringRecord::new();
    let mut joints = JointCollector::new(spec.joint_set);
    // The skeleton being collected: key and the line it started on.
    let mut current: Option<((SessionTime, String, u64), u64)> = None;
    loop {
        let row = csv.next_row(&mut record)?;
        let key = match row {
            Some(line) => Some((read_key(&csv, &record, &c, spec, line)?, line)),
            None => None,
        };
        let is_new = match (&current, &key) {
            (Some((cur, _)), Some((k, _))) => cur != k,
            (Some(_), None) => true,
            (None, _) => false,
        };
        if is_new && let Some(((t, camera, track), start)) = current.take() {
            let msg = Message::Skeleton(Box::new(SkeletonObservation {
                t,
                camera: CameraId::new(camera),
                track: TrackId(track),
                joints: joints.take(),
            }));
            csv.push(msg, start)?;
        }
        let (Some(line), Some((k, _))) = (row, key) else {
            break;
        };
        let name = record.get(joint_col).unwrap_or_default();
        let joint = joint_ref(spec.joint_set, name).ok_or_else(|| {
            csv.error(
                line,
                &match spec.joint_set {
                    None => format!("unknown joint '{name}' (expected a canonical name such as 'left_wrist', or set a joint set)"),
                    Some(set) => format!("unknown joint '{name}' for joint set {set:?}"),
                },
            )
        })?;
        let obs = observation(&csv, &record, xyz, conf_col, state_col, line)?;
        // Checked here, on the joint's own row: the skeleton's check names its first row.
        obs.validate_as(name)
            .map_err(|e| csv.error(line, &e.to_string()))?;
        if !joints.insert(joint, obs) {
            return Err(csv.error(
                line,
                &format!("joint '{name}' given twice for one skeleton"),
            ));
        }
        if current.is_none() {
            current = Some((k, line));
        }
    }
    Ok(csv.finish())
}

fn import_skeleton_rows<R: Read>(
    mut csv: CsvInput<R>,
    spec: &SkeletonCsvSpec,
) -> Result<CsvImport> {
    let c = common(&mut csv, spec)?;
    // Per joint: its reference, x/y/z columns with factors, confidence and state columns.
    type JointColumns = (JointRef, [(usize, f64); 3], Option<usize>, Option<usize>);
    let mut joint_cols: Vec<JointColumns> = Vec::new();
    let names: Vec<String> = match spec.joint_set {
        None => Joint::ALL.iter().map(|j| j.name().to_owned()).collect(),
        Some(set) => (0..set.len())
            .filter_map(|i| set.joint_name(i).map(str::to_owned))
            .collect(),
    };
    for name in &names {
        let lower = name.to_lowercase();
        let bases = [
            format!("{lower}_x"),
            format!("{lower}_y"),
            format!("{lower}_z"),
        ];
        let found: Vec<_> = bases
            .iter()
            .map(|b| csv.find(&[b.as_str()], is_length_unit))
            .collect();
        if found.iter().all(Option::is_none) {
            continue;
        }
        let mut xyz = [(0, 1.0); 3];
        for (axis, f) in found.into_iter().enumerate() {
            let (col, unit) = f.ok_or_else(|| {
                csv.error(
                    1,
                    &format!("joint '{name}' needs {name}_x, {name}_y and {name}_z columns"),
                )
            })?;
            let unit = csv.unit(
                col,
                unit.as_deref(),
                LengthUnit::parse,
                spec.length_unit,
                "head_x (m)",
            )?;
            xyz[axis] = (col, unit.to_metres());
        }
        let conf = csv
            .find(&[format!("{lower}_confidence").as_str()], is_no_unit)
            .map(|(c, _)| c);
        let state = csv
            .find(&[format!("{lower}_state").as_str()], is_no_unit)
            .map(|(c, _)| c);
        let joint = joint_ref(spec.joint_set, name)
            .ok_or_else(|| csv.error(1, &format!("unknown joint '{name}'")))?;
        joint_cols.push((joint, xyz, conf, state));
    }
    if joint_cols.is_empty() {
        return Err(csv.error(
            1,
            "no joint columns: expected e.g. 'left_wrist_x, left_wrist_y, left_wrist_z'",
        ));
    }

    let mut record = StringRecord::new();
    let mut joints = JointCollector::new(spec.joint_set);
    while let Some(line) = csv.next_row(&mut record)? {
        let (t, camera, track) = read_key(&csv, &record, &c, spec, line)?;
        for (joint, xyz, conf, state) in &joint_cols {
            if record.get(xyz[0].0).unwrap_or_default().is_empty() {
                continue;
            }
            let obs = observation(&csv, &record, *xyz, *conf, *state, line)?;
            joints.insert(*joint, obs);
        }
        if joints.is_empty() {
            continue;
        }
        let msg = Message::Skeleton(Box::new(SkeletonObservation {
            t,
            camera: CameraId::new(camera),
            track: TrackId(track),
            joints: joints.take(),
        }));
        csv.push(msg, line)?;
    }
    Ok(csv.finish())
}
