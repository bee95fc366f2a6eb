//! A sans-IO reader for Acclaim skeleton files (`.asf`), the skeleton half of CMU's native
//! ASF/AMC motion capture: text in, [`Asf`] out. [`crate::amc`] reads the motion half.
//!
//! Sections read (lines starting with `#` are comments; other sections are skipped):
//!
//! ```text
//! :units        mass <m>  length <multiplier>  angle deg|rad
//! :root         order TX TY TZ RX RY RZ   axis XYZ   position x y z   orientation a b c
//! :bonedata     begin  id <n>  name <bone>  direction x y z  length <l>
//!                      axis a b c XYZ  dof rx ry rz  limits (lo hi) ...  end    (one per bone)
//! :hierarchy    begin  <parent> <child> <child> ...  end                       (one line per parent)
//! ```
//!
//! **Acclaim semantics** (as CMU's mocapPlayer reads them). Directions and axes are given in the
//! global frame of the rest pose. A bone starts where its parent ends (the root's children at
//! the root) and, in a pose, its rotation in those global axes is
//!
//! ```text
//! R_bone = R_parent · C · M · C⁻¹        end = start + R_bone · (direction · length)
//! ```
//!
//! where `C` is the rotation of the bone's `axis` angles and `M` that of its `dof` values from
//! the AMC. Both compose their elementary rotations in the order written, the first applied
//! first: `axis a b c XYZ` gives `C = R_z(c) · R_y(b) · R_x(a)` (column vectors), `dof rx ry rz`
//! gives `M = R_z · R_y · R_x`. Each angle belongs to the axis letter at its position. The root's
//! `orientation` plays the role of its `axis`.
//!
//! Only rotational dofs (`rx`, `ry`, `rz`) are taken on bones; `tx`, `ty`, `tz` and `l` are
//! refused with an error. `direction` is normalised: `length` is the bone's length.

use crate::bvh::parse_finite;
use crate::error::{MocapError, Result};
use nalgebra::{Rotation3, Vector3};
use std::collections::HashMap;

/// Most bones an ASF may define (CMU's skeletons have 30); guards the work per AMC frame.
pub const MAX_BONES: usize = 1000;

/// Metres per inch, for CMU's length unit (see [`Asf::cmu_metres_per_unit`]).
const METRES_PER_INCH: f64 = 0.0254;

/// A coordinate axis of the ASF's global frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    /// The X axis.
    X,
    /// The Y axis (up in CMU's files).
    Y,
    /// The Z axis.
    Z,
}

impl Axis {
    fn from_letter(c: char) -> Option<Axis> {
        match c.to_ascii_uppercase() {
            'X' => Some(Axis::X),
            'Y' => Some(Axis::Y),
            'Z' => Some(Axis::Z),
            _ => None,
        }
    }

    /// The index of this axis in a vector: 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    fn unit(self) -> nalgebra::Unit<Vector3<f64>> {
        match self {
            Axis::X => Vector3::x_axis(),
            Axis::Y => Vector3::y_axis(),
            Axis::Z => Vector3::z_axis(),
        }
    }

    /// The rotation by `angle_rad` about this axis (right-handed).
    pub fn rotation(self, angle_rad: f64) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&self.unit(), angle_rad)
    }
}

/// One degree of freedom: a rotation about, or (root only) a translation along, an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dof {
    /// Rotation about an axis; AMC values in the AMC's angle unit.
    Rotation(Axis),
    /// Translation along an axis (the root's position); AMC values in ASF length units.
    Translation(Axis),
}

impl Dof {
    /// Parses `rx`, `ry`, `rz`, `tx`, `ty`, `tz`, ignoring ASCII case (the root's `order`
    /// writes them in capitals).
    pub fn from_name(name: &str) -> Option<Dof> {
        let mut chars = name.chars();
        let kind = chars.next()?.to_ascii_lowercase();
        let axis = Axis::from_letter(chars.next()?)?;
        if chars.next().is_some() {
            return None;
        }
        match kind {
            'r' => Some(Dof::Rotation(axis)),
            't' => Some(Dof::Translation(axis)),
            _ => None,
        }
    }

    /// The lower-case name (`rx`, `tz`).
    pub fn name(self) -> &'static str {
        match self {
            Dof::Rotation(Axis::X) => "rx",
            Dof::Rotation(Axis::Y) => "ry",
            Dof::Rotation(Axis::Z) => "rz",
            Dof::Translation(Axis::X) => "tx",
            Dof::Translation(Axis::Y) => "ty",
            Dof::Translation(Axis::Z) => "tz",
        }
    }
}

/// The unit of angles in the ASF (`:units angle`) or an AMC (`:DEGREES`, `:RADIANS`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AngleUnit {
    /// Degrees (CMU's files, and the default).
    #[default]
    Degrees,
    /// Radians.
    Radians,
}

impl AngleUnit {
    /// `value` in this unit, in radians.
    pub fn to_radians(self, value: f64) -> f64 {
        match self {
            AngleUnit::Degrees => value.to_radians(),
            AngleUnit::Radians => value,
        }
    }
}

/// Three angles and the order they apply in: `axis 0 0 20 XYZ`, or the root's `axis` with its
/// `orientation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EulerAxes {
    /// `angles_rad[k]` is the rotation about `order[k]`, radians.
    pub angles_rad: [f64; 3],
    /// The axes, first applied first.
    pub order: [Axis; 3],
}

impl Default for EulerAxes {
    fn default() -> Self {
        Self {
            angles_rad: [0.0; 3],
            order: [Axis::X, Axis::Y, Axis::Z],
        }
    }
}

impl EulerAxes {
    /// `R_order[2](a2) · R_order[1](a1) · R_order[0](a0)`: the first axis applied first.
    pub fn rotation(&self) -> Rotation3<f64> {
        self.order
            .iter()
            .zip(self.angles_rad)
            .fold(Rotation3::identity(), |r, (axis, angle)| {
                axis.rotation(angle) * r
            })
    }
}

/// The `:root` section: where the skeleton hangs, and the order of its AMC values.
#[derive(Debug, Clone, PartialEq)]
pub struct AsfRoot {
    /// `order`: the root's degrees of freedom in the order of its AMC values (CMU:
    /// `TX TY TZ RX RY RZ`).
    pub order: Vec<Dof>,
    /// `axis` and `orientation`: the root's `C` (zero in CMU's files).
    pub orientation: EulerAxes,
    /// `position`: the root's position in the rest pose, file units. AMC translations are
    /// absolute positions and replace it.
    pub position: Vector3<f64>,
    /// Line of `:root`.
    pub line: usize,
}

/// One bone of `:bonedata`.
#[derive(Debug, Clone, PartialEq)]
pub struct AsfBone {
    /// `id` as written, if given.
    pub id: Option<i64>,
    /// `name`.
    pub name: String,
    /// Index of the parent bone in [`Asf::bones`]; `None` when it hangs from the root.
    pub parent: Option<usize>,
    /// `direction`, normalised: the bone's direction in the rest pose, global axes.
    pub direction: Vector3<f64>,
    /// `length`, file units.
    pub length: f64,
    /// `axis`: the bone's `C`.
    pub axis: EulerAxes,
    /// `dof`: rotational degrees of freedom in the order of their AMC values.
    pub dofs: Vec<Dof>,
    /// `limits`, one `(min, max)` per dof, radians (may be infinite); empty when not given.
    pub limits_rad: Vec<(f64, f64)>,
    /// Line of the bone's `begin`.
    pub line: usize,
}

impl AsfBone {
    /// The bone as a vector in the rest pose, `direction · length`, file units.
    pub fn vector(&self) -> Vector3<f64> {
        self.direction * self.length
    }
}

/// A parsed ASF file: the skeleton of one subject, file units, the file's axes (Y up for CMU).
#[derive(Debug, Clone, PartialEq)]
pub struct Asf {
    /// Source name used in messages (usually the file name).
    pub source: String,
    /// `:name`, if given.
    pub name: Option<String>,
    /// `:units length`: the multiplier the file's lengths carry (1 if not given).
    pub length_unit: f64,
    /// `:units angle`: the unit of `axis`, `orientation` and `limits` (degrees if not given).
    /// AMC files that state no unit of their own use it too.
    pub angle_unit: AngleUnit,
    /// The `:root` section.
    pub root: AsfRoot,
    /// Bones in hierarchy order: parents before children, children in the order `:hierarchy`
    /// lists them.
    pub bones: Vec<AsfBone>,
}

impl Asf {
    /// Index of the bone called `name` in [`Asf::bones`] (exact match).
    pub fn bone_index(&self, name: &str) -> Option<usize> {
        self.bones.iter().position(|b| b.name == name)
    }

    /// Metres per file length unit under CMU's convention that lengths are inches times
    /// `:units length`: `0.0254 / length_unit`, 0.0564444 for CMU's `length 0.45`. The Acclaim
    /// format itself names no base unit; use this as [`crate::ConvertOptions::scale`] for CMU
    /// files.
    pub fn cmu_metres_per_unit(&self) -> f64 {
        METRES_PER_INCH / self.length_unit
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Section {
    Preamble,
    Units,
    Root,
    Bonedata,
    Hierarchy,
    /// `:documentation` and sections this reader does not use: their lines are skipped.
    Skipped,
}

/// A bone between `begin` and `end`.
#[derive(Default)]
struct BoneBuilder {
    line: usize,
    id: Option<i64>,
    name: Option<(usize, String)>,
    direction: Option<(usize, Vector3<f64>)>,
    length: Option<(usize, f64)>,
    axis: Option<EulerAxes>,
    dofs: Option<(usize, Vec<Dof>)>,
    limits: Vec<(f64, f64)>,
    limits_line: usize,
    /// Whether the previous entry was `limits`, so that a line starting with `(` continues it.
    in_limits: bool,
}

/// One `parent child child ...` line of `:hierarchy`.
struct HierarchyLine<'a> {
    line: usize,
    parent: &'a str,
    children: Vec<&'a str>,
}

struct Parser<'a> {
    file: &'a str,
    units_length: f64,
    angle_unit: AngleUnit,
    name: Option<String>,
    root: Option<AsfRoot>,
    root_axis_order: [Axis; 3],
    root_orientation: [f64; 3],
    seen_bonedata: bool,
    seen_hierarchy: bool,
    in_block: bool,
    bone: Option<BoneBuilder>,
    bones: Vec<AsfBone>,
    bone_lines: HashMap<String, usize>,
    hierarchy: Vec<HierarchyLine<'a>>,
    last_line: usize,
}

/// Parses ASF text. `source` names the text in error messages (`02.asf:12: ...`).
pub fn parse_asf(text: &str, source: &str) -> Result<Asf> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut p = Parser {
        file: source,
        units_length: 1.0,
        angle_unit: AngleUnit::Degrees,
        name: None,
        root: None,
        root_axis_order: [Axis::X, Axis::Y, Axis::Z],
        root_orientation: [0.0; 3],
        seen_bonedata: false,
        seen_hierarchy: false,
        in_block: false,
        bone: None,
        bones: Vec::new(),
        bone_lines: HashMap::new(),
        hierarchy: Vec::new(),
        last_line: 1,
    };
    let mut section = Section::Preamble;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        p.last_line = line;
        let l = raw.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        if let Some(keyword) = l.strip_prefix(':') {
            p.close_section(section, line, l)?;
            section = p.open_section(keyword, line)?;
            continue;
        }
        match section {
            // Nothing has shown this to be an ASF file: its line is not quoted.
            Section::Preamble => {
                return Err(MocapError::NotOfKind {
                    file: source.to_owned(),
                    line,
                    kind: "an ASF file",
                    expected: "a ':' section keyword such as ':units'",
                });
            }
            Section::Units => p.units_line(l, line)?,
            Section::Root => p.root_line(l, line)?,
            Section::Bonedata => p.bonedata_line(l, line)?,
            Section::Hierarchy => p.hierarchy_line(l, line)?,
            Section::Skipped => {}
        }
    }
    let last = p.last_line;
    p.close_section(section, last, "the end of the text")?;
    p.finish()
}

impl<'a> Parser<'a> {
    fn unexpected(&self, line: usize, expected: &str, found: &str) -> MocapError {
        MocapError::Unexpected {
            file: self.file.to_owned(),
            line,
            expected: expected.to_owned(),
            found: found.to_owned(),
        }
    }

    fn bad_bone(&self, line: usize, bone: &str, detail: String) -> MocapError {
        MocapError::BadBone {
            file: self.file.to_owned(),
            line,
            bone: bone.to_owned(),
            detail,
        }
    }

    fn open_section(&mut self, keyword: &'a str, line: usize) -> Result<Section> {
        let mut toks = keyword.split_whitespace();
        let key = toks.next().unwrap_or("");
        Ok(match key {
            "units" => {
                // The angle unit applies as `:root` and `:bonedata` are read.
                if self.root.is_some() || self.seen_bonedata {
                    return Err(self.unexpected(
                        line,
                        "':units' before ':root' and ':bonedata'",
                        ":units",
                    ));
                }
                Section::Units
            }
            "root" => {
                if self.root.is_some() {
                    return Err(self.unexpected(line, "one ':root' section", ":root"));
                }
                self.root = Some(AsfRoot {
                    order: Vec::new(),
                    orientation: EulerAxes::default(),
                    position: Vector3::zeros(),
                    line,
                });
                Section::Root
            }
            "bonedata" => {
                if self.seen_bonedata {
                    return Err(self.unexpected(line, "one ':bonedata' section", ":bonedata"));
                }
                self.seen_bonedata = true;
                Section::Bonedata
            }
            "hierarchy" => {
                if self.seen_hierarchy {
                    return Err(self.unexpected(line, "one ':hierarchy' section", ":hierarchy"));
                }
                self.seen_hierarchy = true;
                Section::Hierarchy
            }
            "name" => {
                self.name = Some(toks.collect::<Vec<_>>().join(" "));
                Section::Skipped
            }
            _ => Section::Skipped,
        })
    }

    /// Checks that a `begin` block of `section` is closed before what follows (`next`: the
    /// next section keyword, or the end of the text).
    fn close_section(&mut self, section: Section, line: usize, next: &str) -> Result<()> {
        if matches!(section, Section::Bonedata | Section::Hierarchy) && self.in_block {
            return Err(self.unexpected(line, "'end' closing the 'begin' block", next));
        }
        if section == Section::Root
            && let Some(root) = &mut self.root
        {
            root.orientation = EulerAxes {
                angles_rad: self.root_orientation.map(|a| self.angle_unit.to_radians(a)),
                order: self.root_axis_order,
            };
        }
        Ok(())
    }

    fn units_line(&mut self, l: &str, line: usize) -> Result<()> {
        let toks: Vec<&str> = l.split_whitespace().collect();
        match toks.as_slice() {
            ["length", v] => {
                let length = parse_finite(v, self.file, line, "units length")?;
                if length <= 0.0 {
                    return Err(self.unexpected(line, "a positive length unit", v));
                }
                self.units_length = length;
            }
            ["angle", unit] => {
                self.angle_unit = match unit.to_ascii_lowercase().as_str() {
                    "deg" | "degree" | "degrees" => AngleUnit::Degrees,
                    "rad" | "radian" | "radians" => AngleUnit::Radians,
                    _ => return Err(self.unexpected(line, "'deg' or 'rad'", unit)),
                };
            }
            // `mass` and others do not affect the kinematics.
            _ => {}
        }
        Ok(())
    }

    fn three_numbers(&self, toks: &[&str], line: usize, what: &str) -> Result<[f64; 3]> {
        match toks {
            [x, y, z] => Ok([
                parse_finite(x, self.file, line, &format!("{what} x"))?,
                parse_finite(y, self.file, line, &format!("{what} y"))?,
                parse_finite(z, self.file, line, &format!("{what} z"))?,
            ]),
            _ => Err(self.unexpected(
                line,
                &format!("three numbers after '{what}'"),
                &toks.join(" "),
            )),
        }
    }

    fn axis_order(&self, tok: &str, line: usize) -> Result<[Axis; 3]> {
        let axes: Vec<Axis> = tok.chars().filter_map(Axis::from_letter).collect();
        match axes.as_slice() {
            &[a, b, c] if tok.chars().count() == 3 => Ok([a, b, c]),
            _ => Err(self.unexpected(line, "an axis order such as 'XYZ'", tok)),
        }
    }

    fn root_line(&mut self, l: &str, line: usize) -> Result<()> {
        let toks: Vec<&str> = l.split_whitespace().collect();
        let (key, rest) = match toks.split_first() {
            Some((k, r)) => (*k, r),
            None => return Ok(()),
        };
        match key {
            "order" => {
                let mut order = Vec::with_capacity(rest.len().min(6));
                for tok in rest {
                    let dof = Dof::from_name(tok)
                        .ok_or_else(|| self.unexpected(line, "TX, TY, TZ, RX, RY or RZ", tok))?;
                    if order.contains(&dof) {
                        return Err(self.unexpected(line, "each root dof once", tok));
                    }
                    order.push(dof);
                }
                if let Some(root) = &mut self.root {
                    root.order = order;
                }
            }
            "axis" => match rest {
                [order] => self.root_axis_order = self.axis_order(order, line)?,
                _ => {
                    return Err(self.unexpected(
                        line,
                        "an axis order such as 'XYZ'",
                        &rest.join(" "),
                    ));
                }
            },
            "position" => {
                let [x, y, z] = self.three_numbers(rest, line, "position")?;
                if let Some(root) = &mut self.root {
                    root.position = Vector3::new(x, y, z);
                }
            }
            "orientation" => {
                self.root_orientation = self.three_numbers(rest, line, "orientation")?;
            }
            _ => {
                return Err(self.unexpected(
                    line,
                    "'order', 'axis', 'position' or 'orientation'",
                    key,
                ));
            }
        }
        Ok(())
    }

    fn bonedata_line(&mut self, l: &str, line: usize) -> Result<()> {
        let toks: Vec<&str> = l.split_whitespace().collect();
        let Some((&key, rest)) = toks.split_first() else {
            return Ok(());
        };
        let Some(mut bone) = self.bone.take() else {
            if key != "begin" {
                return Err(self.unexpected(line, "'begin'", key));
            }
            if self.bones.len() >= MAX_BONES {
                return Err(self.unexpected(
                    line,
                    &format!("at most {MAX_BONES} bones"),
                    &format!("bone {}", MAX_BONES + 1),
                ));
            }
            self.in_block = true;
            self.bone = Some(BoneBuilder {
                line,
                ..Default::default()
            });
            return Ok(());
        };
        let bone_name = bone.name.as_ref().map_or(String::new(), |n| n.1.clone());
        let continues_limits = bone.in_limits && key.starts_with('(');
        bone.in_limits = false;
        if continues_limits {
            self.limit_pairs(&mut bone, l, line, &bone_name)?;
            bone.in_limits = true;
            self.bone = Some(bone);
            return Ok(());
        }
        let twice =
            |p: &Self, what: &str| p.bad_bone(line, &bone_name, format!("'{what}' given twice"));
        match key {
            "end" => {
                self.in_block = false;
                return self.finish_bone(bone, line);
            }
            "begin" => return Err(self.unexpected(line, "'end' before the next 'begin'", key)),
            "id" => {
                let [v] = rest else {
                    return Err(self.unexpected(line, "one id after 'id'", &rest.join(" ")));
                };
                bone.id = Some(v.parse().map_err(|_| MocapError::NotANumber {
                    file: self.file.to_owned(),
                    line,
                    what: "bone id".to_owned(),
                    token: (*v).to_owned(),
                })?);
            }
            "name" => {
                let [name] = rest else {
                    return Err(self.unexpected(line, "one word after 'name'", &rest.join(" ")));
                };
                if bone.name.is_some() {
                    return Err(twice(self, "name"));
                }
                bone.name = Some((line, (*name).to_owned()));
            }
            "direction" => {
                if bone.direction.is_some() {
                    return Err(twice(self, "direction"));
                }
                let [x, y, z] = self.three_numbers(rest, line, "direction")?;
                bone.direction = Some((line, Vector3::new(x, y, z)));
            }
            "length" => {
                if bone.length.is_some() {
                    return Err(twice(self, "length"));
                }
                let [v] = rest else {
                    return Err(self.unexpected(
                        line,
                        "one number after 'length'",
                        &rest.join(" "),
                    ));
                };
                let length = parse_finite(v, self.file, line, "length")?;
                if length < 0.0 {
                    return Err(self.bad_bone(line, &bone_name, format!("negative length {v}")));
                }
                bone.length = Some((line, length));
            }
            "axis" => {
                if bone.axis.is_some() {
                    return Err(twice(self, "axis"));
                }
                let [a, b, c, order] = rest else {
                    return Err(self.unexpected(
                        line,
                        "three angles and an axis order after 'axis'",
                        &rest.join(" "),
                    ));
                };
                let angles = self.three_numbers(&[a, b, c], line, "axis")?;
                bone.axis = Some(EulerAxes {
                    angles_rad: angles.map(|v| self.angle_unit.to_radians(v)),
                    order: self.axis_order(order, line)?,
                });
            }
            "dof" => {
                if bone.dofs.is_some() {
                    return Err(twice(self, "dof"));
                }
                let mut dofs = Vec::with_capacity(rest.len().min(3));
                for tok in rest {
                    match Dof::from_name(tok) {
                        Some(dof @ Dof::Rotation(_)) if !dofs.contains(&dof) => dofs.push(dof),
                        Some(Dof::Rotation(_)) => {
                            return Err(self.bad_bone(
                                line,
                                &bone_name,
                                format!("dof '{tok}' given twice"),
                            ));
                        }
                        _ => {
                            return Err(self.bad_bone(
                                line,
                                &bone_name,
                                format!("unsupported dof '{tok}' (bones take rx, ry and rz)"),
                            ));
                        }
                    }
                }
                bone.dofs = Some((line, dofs));
            }
            "limits" => {
                bone.limits_line = line;
                let after = l.get("limits".len()..).unwrap_or("");
                self.limit_pairs(&mut bone, after, line, &bone_name)?;
                bone.in_limits = true;
            }
            // `bodymass`, `cofmass` and the like do not affect the kinematics.
            _ => {}
        }
        self.bone = Some(bone);
        Ok(())
    }

    /// Reads `(lo hi)` pairs from `text` into `bone.limits` (angles in the ASF's unit; `inf`
    /// allowed).
    fn limit_pairs(
        &self,
        bone: &mut BoneBuilder,
        text: &str,
        line: usize,
        name: &str,
    ) -> Result<()> {
        let spaced = text.replace(['(', ')'], " ");
        let toks: Vec<&str> = spaced.split_whitespace().collect();
        if !toks.len().is_multiple_of(2) {
            return Err(self.bad_bone(
                line,
                name,
                format!("limits '{}' are not (min max) pairs", text.trim()),
            ));
        }
        for pair in toks.chunks_exact(2) {
            let mut v = [0.0; 2];
            for (slot, tok) in v.iter_mut().zip(pair) {
                let value: f64 = tok.parse().map_err(|_| MocapError::NotANumber {
                    file: self.file.to_owned(),
                    line,
                    what: "limit".to_owned(),
                    token: (*tok).to_owned(),
                })?;
                if value.is_nan() {
                    return Err(MocapError::NotFinite {
                        file: self.file.to_owned(),
                        line,
                        what: "limit".to_owned(),
                        value,
                    });
                }
                *slot = self.angle_unit.to_radians(value);
            }
            if bone.limits.len() >= 3 {
                return Err(self.bad_bone(
                    line,
                    name,
                    "more limits than rotational dofs".to_owned(),
                ));
            }
            bone.limits.push((v[0], v[1]));
        }
        Ok(())
    }

    fn finish_bone(&mut self, bone: BoneBuilder, end_line: usize) -> Result<()> {
        let Some((name_line, name)) = bone.name else {
            return Err(self.bad_bone(bone.line, "", "no 'name' before 'end'".to_owned()));
        };
        if name.eq_ignore_ascii_case("root") {
            return Err(self.bad_bone(
                name_line,
                &name,
                "'root' is reserved for the root".to_owned(),
            ));
        }
        if let Some(&first_line) = self.bone_lines.get(&name) {
            return Err(MocapError::DuplicateBone {
                file: self.file.to_owned(),
                line: name_line,
                name,
                first_line,
            });
        }
        let Some((dir_line, direction)) = bone.direction else {
            return Err(self.bad_bone(end_line, &name, "no 'direction' before 'end'".to_owned()));
        };
        let norm = direction.norm();
        // A direction this short has lost its meaning (CMU's are unit vectors to 1e-6).
        if norm <= 1e-6 {
            return Err(self.bad_bone(dir_line, &name, "direction is zero".to_owned()));
        }
        let Some((_, length)) = bone.length else {
            return Err(self.bad_bone(end_line, &name, "no 'length' before 'end'".to_owned()));
        };
        let dofs = bone.dofs.map(|d| d.1).unwrap_or_default();
        if !bone.limits.is_empty() && bone.limits.len() != dofs.len() {
            return Err(self.bad_bone(
                bone.limits_line,
                &name,
                format!("{} limits for {} dofs", bone.limits.len(), dofs.len()),
            ));
        }
        self.bone_lines.insert(name.clone(), name_line);
        self.bones.push(AsfBone {
            id: bone.id,
            name,
            parent: None,
            direction: direction / norm,
            length,
            axis: bone.axis.unwrap_or_default(),
            dofs,
            limits_rad: bone.limits,
            line: bone.line,
        });
        Ok(())
    }

    fn hierarchy_line(&mut self, l: &'a str, line: usize) -> Result<()> {
        let mut toks = l.split_whitespace();
        let Some(first) = toks.next() else {
            return Ok(());
        };
        match (first, self.in_block) {
            ("begin", false) => self.in_block = true,
            ("end", true) => self.in_block = false,
            (_, false) => return Err(self.unexpected(line, "'begin'", first)),
            (_, true) => {
                let children: Vec<&str> = toks.collect();
                if children.is_empty() {
                    return Err(self.unexpected(line, "a parent followed by its children", l));
                }
                self.hierarchy.push(HierarchyLine {
                    line,
                    parent: first,
                    children,
                });
            }
        }
        Ok(())
    }

    fn hierarchy_error(&self, line: usize, detail: String) -> MocapError {
        MocapError::Hierarchy {
            file: self.file.to_owned(),
            line,
            detail,
        }
    }

    /// Links the bones into a tree from `:hierarchy` and orders them parents first.
    fn finish(self) -> Result<Asf> {
        let eof = |expected: &str| MocapError::UnexpectedEof {
            file: self.file.to_owned(),
            line: self.last_line,
            expected: expected.to_owned(),
        };
        let Some(root) = self.root.clone() else {
            return Err(eof("a ':root' section"));
        };
        if !self.seen_bonedata {
            return Err(eof("a ':bonedata' section"));
        }
        if !self.seen_hierarchy {
            return Err(eof("a ':hierarchy' section"));
        }
        if self.in_block {
            return Err(eof("'end' closing the 'begin' block"));
        }
        let index: HashMap<&str, usize> = self
            .bones
            .iter()
            .enumerate()
            .map(|(i, b)| (b.name.as_str(), i))
            .collect();
        // Parent of each bone: `None` not yet attached; `Some(None)` the root.
        let mut parent: Vec<Option<(Option<usize>, usize)>> = vec![None; self.bones.len()];
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); self.bones.len()];
        let mut root_children = Vec::new();
        for h in &self.hierarchy {
            let p = if h.parent == "root" {
                None
            } else {
                Some(*index.get(h.parent).ok_or_else(|| MocapError::UnknownBone {
                    file: self.file.to_owned(),
                    line: h.line,
                    name: h.parent.to_owned(),
                })?)
            };
            for &child in &h.children {
                if child == "root" {
                    return Err(self.hierarchy_error(h.line, "'root' cannot be a child".to_owned()));
                }
                let &c = index.get(child).ok_or_else(|| MocapError::UnknownBone {
                    file: self.file.to_owned(),
                    line: h.line,
                    name: child.to_owned(),
                })?;
                if let Some(Some((_, first_line))) = parent.get(c) {
                    return Err(self.hierarchy_error(
                        h.line,
                        format!("'{child}' already has a parent (line {first_line})"),
                    ));
                }
                if let Some(slot) = parent.get_mut(c) {
                    *slot = Some((p, h.line));
                }
                match p {
                    None => root_children.push(c),
                    Some(p) => {
                        if let Some(list) = children.get_mut(p) {
                            list.push(c);
                        }
                    }
                }
            }
        }
        // Depth-first from the root, children in the order listed.
        let mut order = Vec::with_capacity(self.bones.len());
        let mut stack: Vec<usize> = root_children.iter().rev().copied().collect();
        while let Some(b) = stack.pop() {
            order.push(b);
            if let Some(list) = children.get(b) {
                stack.extend(list.iter().rev());
            }
        }
        if order.len() < self.bones.len() {
            let mut reached = vec![false; self.bones.len()];
            for &b in &order {
                if let Some(r) = reached.get_mut(b) {
                    *r = true;
                }
            }
            return Err(self.unreached(&reached, &parent));
        }
        let mut new_index = vec![0; self.bones.len()];
        for (new, &old) in order.iter().enumerate() {
            if let Some(slot) = new_index.get_mut(old) {
                *slot = new;
            }
        }
        let mut bones = Vec::with_capacity(order.len());
        for &old in &order {
            let (Some(bone), Some(Some((p, _)))) = (self.bones.get(old), parent.get(old)) else {
                continue;
            };
            let mut bone = bone.clone();
            bone.parent = p.and_then(|p| new_index.get(p).copied());
            bones.push(bone);
        }
        Ok(Asf {
            source: self.file.to_owned(),
            name: self.name,
            length_unit: self.units_length,
            angle_unit: self.angle_unit,
            root,
            bones,
        })
    }

    /// The error for bones the root does not reach: a cycle, or a bone left out of
    /// `:hierarchy`.
    fn unreached(&self, reached: &[bool], parent: &[Option<(Option<usize>, usize)>]) -> MocapError {
        let Some(start) = reached.iter().position(|r| !r) else {
            return self.hierarchy_error(self.last_line, "not a tree".to_owned());
        };
        let name = |b: usize| self.bones.get(b).map_or("?", |b| b.name.as_str());
        // Walk up from the first bone not reached: either a bone without a parent (left out)
        // or a bone seen before (a cycle). Each step visits a new bone, so this ends.
        let mut seen = vec![false; reached.len()];
        let mut b = start;
        loop {
            match parent.get(b).copied().flatten() {
                None => {
                    let line = self.bones.get(b).map_or(self.last_line, |bone| bone.line);
                    return self.hierarchy_error(
                        line,
                        format!("bone '{}' (defined here) is not in :hierarchy", name(b)),
                    );
                }
                Some((Some(p), line)) => {
                    if seen.get(p).copied().unwrap_or(true) {
                        let mut cycle = vec![name(p)];
                        let mut q = parent.get(p).copied().flatten().and_then(|x| x.0);
                        while let Some(c) = q.filter(|&c| c != p && cycle.len() <= reached.len()) {
                            cycle.push(name(c));
                            q = parent.get(c).copied().flatten().and_then(|x| x.0);
                        }
                        cycle.push(name(p));
                        cycle.reverse();
                        return self.hierarchy_error(
                            line,
                            format!("cycle {} does not reach root", cycle.join(" → ")),
                        );
                    }
                    if let Some(s) = seen.get_mut(b) {
                        *s = true;
                    }
                    b = p;
                }
                Some((None, line)) => {
                    // Reached from the root after all; cannot happen, but name the line.
                    return self.hierarchy_error(line, format!("'{}' is detached", name(b)));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines: 1 comment, 2 :units, 3 length, 4 angle, 5 :root, 6 order, 7 axis, 8 position,
    /// 9 orientation, 10 :bonedata, 11–19 bone `upper` (13 name, 18 limits), 20–26 bone `lower`
    /// (22 direction, 23 length, 25 dof), 27 :hierarchy, 28 begin, 29 root upper,
    /// 30 upper lower, 31 end.
    pub(crate) const ARM: &str = "# a test skeleton
:units
  length 0.5
  angle deg
:root
  order TX TY TZ RX RY RZ
  axis XYZ
  position 0 0 0
  orientation 0 0 0
:bonedata
  begin
    id 1
    name upper
    direction 2 0 0
    length 2
    axis 0 0 90 XYZ
    dof rx rz
    limits (-90 90) (-45 45)
  end
  begin
    name lower
    direction 0 1 0
    length 1
    axis 90 0 0 XYZ
    dof ry
  end
:hierarchy
  begin
    root upper
    upper lower
  end
";

    fn err(text: &str) -> String {
        parse_asf(text, "t.asf").unwrap_err().to_string()
    }

    #[test]
    fn bones_units_and_hierarchy_are_read_with_directions_normalised() {
        // Limits may continue on the next lines, and be infinite.
        let text = ARM.replace("(-90 90) (-45 45)", "(-90 90)\n           (-inf inf)");
        let asf = parse_asf(&text, "t.asf").unwrap();
        assert_eq!(asf.length_unit, 0.5);
        assert!((asf.cmu_metres_per_unit() - 0.0508).abs() < 1e-15);
        assert_eq!(asf.root.order.len(), 6);
        assert_eq!(asf.root.order[3], Dof::Rotation(Axis::X));
        let upper = &asf.bones[0];
        assert_eq!(
            (upper.name.as_str(), upper.id, upper.parent),
            ("upper", Some(1), None)
        );
        assert_eq!(upper.direction, Vector3::x());
        assert_eq!(upper.vector(), Vector3::new(2.0, 0.0, 0.0));
        assert_eq!(upper.dofs, [Dof::Rotation(Axis::X), Dof::Rotation(Axis::Z)]);
        assert!((upper.axis.angles_rad[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert_eq!(upper.limits_rad.len(), 2);
        assert_eq!(upper.limits_rad[1].1, f64::INFINITY);
        assert_eq!(asf.bones[1].parent, Some(0));
        assert_eq!(asf.bone_index("lower"), Some(1));
    }

    #[test]
    fn axis_angles_compose_first_letter_first() {
        // XYZ: x 90 then z 90 takes +Y to +Z, then leaves it; ZYX: z 90 then x 90 takes +Y to
        // −X, then leaves it.
        let angles_rad = [
            std::f64::consts::FRAC_PI_2,
            0.0,
            std::f64::consts::FRAC_PI_2,
        ];
        let xyz = EulerAxes {
            angles_rad,
            order: [Axis::X, Axis::Y, Axis::Z],
        };
        assert!((xyz.rotation() * Vector3::y() - Vector3::z()).norm() < 1e-15);
        let zyx = EulerAxes {
            angles_rad,
            order: [Axis::Z, Axis::Y, Axis::X],
        };
        assert!((zyx.rotation() * Vector3::y() + Vector3::x()).norm() < 1e-15);
    }

    #[test]
    fn radians_apply_to_axis_and_limits() {
        let asf = parse_asf(
            &ARM.replace("angle deg", "angle rad")
                .replace("axis 0 0 90 XYZ", "axis 0 0 1.5 XYZ"),
            "t.asf",
        )
        .unwrap();
        assert_eq!(asf.bones[0].axis.angles_rad[2], 1.5);
        assert_eq!(asf.bones[0].limits_rad[0], (-90.0, 90.0));
        // Too late to say what the angles above were.
        let late = ARM.replace(":units\n  length 0.5\n  angle deg\n", "") + ":units\n  angle rad\n";
        assert_eq!(
            err(&late),
            "t.asf:29: expected ':units' before ':root' and ':bonedata', found ':units'"
        );
        let cut = ARM.replace(
            "    dof ry\n  end\n:hierarchy\n  begin\n    root upper\n    upper lower\n  end\n",
            "    dof ry\n",
        );
        assert_eq!(
            err(&cut),
            "t.asf:25: expected 'end' closing the 'begin' block, found 'the end of the text'"
        );
    }

    #[test]
    fn missing_sections_are_named() {
        let no_bonedata: String = ARM.lines().take(9).map(|l| format!("{l}\n")).collect();
        assert_eq!(
            err(&no_bonedata),
            "t.asf:9: unexpected end of file, expected a ':bonedata' section"
        );
        let no_hierarchy: String = ARM.lines().take(26).map(|l| format!("{l}\n")).collect();
        assert_eq!(
            err(&no_hierarchy),
            "t.asf:26: unexpected end of file, expected a ':hierarchy' section"
        );
        let no_root = ARM.replace(":root", ":skin");
        assert_eq!(
            err(&no_root),
            "t.asf:31: unexpected end of file, expected a ':root' section"
        );
    }

    #[test]
    fn hierarchy_names_undefined_bones_second_parents_and_cycles() {
        let text = ARM.replace("upper lower", "upper lower hand");
        assert_eq!(
            err(&text),
            "t.asf:30: unknown bone 'hand' (not defined in the skeleton's :bonedata)"
        );
        let text = ARM.replace("    upper lower\n", "    upper lower\n    root lower\n");
        assert_eq!(
            err(&text),
            "t.asf:31: bad :hierarchy: 'lower' already has a parent (line 30)"
        );
        let text = ARM.replace("    root upper\n", "    lower upper\n");
        assert_eq!(
            err(&text),
            "t.asf:30: bad :hierarchy: cycle upper → lower → upper does not reach root"
        );
        let text = ARM.replace("    upper lower\n", "");
        assert_eq!(
            err(&text),
            "t.asf:20: bad :hierarchy: bone 'lower' (defined here) is not in :hierarchy"
        );
        let text = ARM.replace("upper lower", "upper root");
        assert_eq!(
            err(&text),
            "t.asf:30: bad :hierarchy: 'root' cannot be a child"
        );
    }

    #[test]
    fn bad_bones_are_named_with_their_line() {
        let text = ARM.replace("dof ry", "dof ry tx");
        assert_eq!(
            err(&text),
            "t.asf:25: bone 'lower': unsupported dof 'tx' (bones take rx, ry and rz)"
        );
        let text = ARM.replace("(-90 90) (-45 45)", "(-90 90)");
        assert_eq!(err(&text), "t.asf:18: bone 'upper': 1 limits for 2 dofs");
        let text = ARM.replace("    direction 0 1 0\n", "");
        assert_eq!(
            err(&text),
            "t.asf:25: bone 'lower': no 'direction' before 'end'"
        );
        let text = ARM.replace("direction 0 1 0", "direction 0 0 0");
        assert_eq!(err(&text), "t.asf:22: bone 'lower': direction is zero");
        let text = ARM.replace("direction 0 1 0", "direction 0 NaN 0");
        assert_eq!(
            err(&text),
            "t.asf:22: direction y is NaN, expected a finite number"
        );
        let text = ARM.replace("name lower", "name upper");
        assert_eq!(
            err(&text),
            "t.asf:21: bone 'upper' appears twice (first at line 13)"
        );
        let text = ARM.replace("length 1\n", "length -1\n");
        assert_eq!(err(&text), "t.asf:23: bone 'lower': negative length -1");
        let text = ARM.replace("    dof ry\n  end\n", "    dof ry\n");
        assert_eq!(
            err(&text),
            "t.asf:26: expected 'end' closing the 'begin' block, found ':hierarchy'"
        );
    }

    #[test]
    fn a_thousand_and_one_bones_are_refused_at_the_extra_begin() {
        let mut text = String::from(":root\n  order TX TY TZ\n:bonedata\n");
        for k in 0..=MAX_BONES {
            text.push_str(&format!(
                "begin\nname b{k}\ndirection 0 1 0\nlength 1\nend\n"
            ));
        }
        let line = 3 + 5 * MAX_BONES + 1;
        assert_eq!(
            err(&text),
            format!("t.asf:{line}: expected at most {MAX_BONES} bones, found 'bone 1001'")
        );
    }

    #[test]
    fn crlf_and_a_byte_order_mark_read_like_plain_text() {
        let windows = format!("\u{feff}{}", ARM.replace('\n', "\r\n"));
        let mut a = parse_asf(&windows, "t.asf").unwrap();
        a.source = String::new();
        let mut b = parse_asf(ARM, "t.asf").unwrap();
        b.source = String::new();
        assert_eq!(a, b);
    }

    #[test]
    fn a_file_that_is_not_asf_is_refused_without_its_content() {
        let text = "# a comment\n\nroot:x:0:0:secret-token:/root:/bin/bash\n:units\n";
        let err = parse_asf(text, "passwd").unwrap_err().to_string();
        assert_eq!(
            err,
            "passwd:3: not an ASF file: expected a ':' section keyword such as ':units' (its \
             content is not shown)"
        );
    }
}
