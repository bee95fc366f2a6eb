//! The static environment (triangle meshes placed in the world) and ray casting through it.
//!
//! Meshes come from Wavefront OBJ ([`parse_obj`], via `tobj`) or PLY ([`parse_ply`], via
//! `ply-rs-bw`), from any reader: the caller opens the file. Each mesh is placed in the world by
//! a `world_from_mesh` isometry and merged into one [`parry3d::shape::TriMesh`], whose bounding
//! volume hierarchy answers ray casts. parry works in `f32` with its own vector type; conversion
//! happens only here, at the boundary, and every public function speaks `f64` nalgebra.
//!
//! Moving rigid parts (a robot link) are oriented boxes ([`nomen_core::geometry::BoxObstacle`])
//! tested analytically in `f64`; they are replaced each frame with
//! [`Environment::set_moving_boxes`].

use crate::error::{OcclusionError, Result};
use nalgebra::{Isometry3, Point3, Vector3};
use nomen_core::bounded::{Limits, MIB_BYTES};
use nomen_core::geometry::BoxObstacle;
use parry3d::math::Vector as PVec;
use parry3d::query::{Ray, RayCast};
use parry3d::shape::TriMesh;
use std::io::BufRead;

/// A triangle mesh in its own frame, metres.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshData {
    /// A name for messages (object name or file name).
    pub name: String,
    /// Vertex positions in the mesh frame, m.
    pub vertices_m: Vec<Point3<f64>>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

impl MeshData {
    /// Checks that the mesh has triangles, that every vertex is finite and that every index
    /// points at a vertex.
    ///
    /// # Errors
    /// [`OcclusionError::Mesh`] naming the first bad vertex or triangle.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: String| OcclusionError::Mesh {
            source_name: self.name.clone(),
            what,
        };
        if self.triangles.is_empty() {
            return Err(bad("no triangles".into()));
        }
        if let Some(i) = self
            .vertices_m
            .iter()
            .position(|p| !p.iter().all(|v| v.is_finite()))
        {
            return Err(bad(format!("vertex {i} is not finite")));
        }
        let n = self.vertices_m.len();
        if let Some(i) = self
            .triangles
            .iter()
            .position(|t| t.iter().any(|&k| k as usize >= n))
        {
            return Err(bad(format!(
                "triangle {i} refers to a vertex beyond the {n} vertices"
            )));
        }
        Ok(())
    }

    /// Appends a box (8 vertices, 12 triangles) given in the mesh frame.
    pub fn push_box(&mut self, obstacle: &BoxObstacle) {
        self.push_tessellated_box(obstacle, 1);
    }

    /// Appends a box whose every face is cut into `n × n` quads (2 triangles each): the same
    /// shape with `12 n²` triangles, for benchmarks on large meshes.
    pub fn push_tessellated_box(&mut self, obstacle: &BoxObstacle, n: u32) {
        let n = n.max(1);
        let c = obstacle.corners_m();
        // Faces as (origin corner, corner along u, corner along v), corner bits (x, y, z).
        const FACES: [[usize; 3]; 6] = [
            [0, 2, 1], // -z
            [4, 5, 6], // +z
            [0, 1, 4], // -y
            [2, 6, 3], // +y
            [0, 4, 2], // -x
            [1, 3, 5], // +x
        ];
        for [o, a, b] in FACES {
            let (origin, du, dv) = (c[o], c[a] - c[o], c[b] - c[o]);
            let base = self.vertices_m.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    let (s, t) = (f64::from(i) / f64::from(n), f64::from(j) / f64::from(n));
                    self.vertices_m.push(origin + du * s + dv * t);
                }
            }
            let row = n + 1;
            for j in 0..n {
                for i in 0..n {
                    let k = base + j * row + i;
                    self.triangles.push([k, k + 1, k + row + 1]);
                    self.triangles.push([k, k + row + 1, k + row]);
                }
            }
        }
    }
}

/// The limits an OBJ mesh file is read within: lines of at most 1 MiB, 256 MiB in all (a
/// scanned room of a few million triangles).
pub const OBJ_LIMITS: Limits = Limits::text("an OBJ mesh file", MIB_BYTES, 256 * MIB_BYTES);

/// The limits a PLY mesh file (text or binary) is read within: 256 MiB in all.
pub const PLY_LIMITS: Limits = Limits::binary("a PLY mesh file", 256 * MIB_BYTES);

/// Reads every object of a Wavefront OBJ text (faces triangulated; materials ignored).
///
/// # Errors
/// [`OcclusionError::Mesh`] when the text cannot be parsed or holds no triangle.
pub fn parse_obj(reader: &mut impl BufRead, source_name: &str) -> Result<Vec<MeshData>> {
    let (models, _materials) = tobj::load_obj_buf(reader, &tobj::GPU_LOAD_OPTIONS, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| OcclusionError::Mesh {
        source_name: source_name.to_owned(),
        what: format!("not a readable OBJ file: {e}"),
    })?;
    let mut meshes = Vec::new();
    for model in models {
        let positions = &model.mesh.positions;
        let vertices_m = positions
            .chunks_exact(3)
            .map(|p| Point3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
            .collect();
        let triangles = model
            .mesh
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        let mesh = MeshData {
            name: format!("{source_name}:{}", model.name),
            vertices_m,
            triangles,
        };
        if !mesh.triangles.is_empty() {
            mesh.validate()?;
            meshes.push(mesh);
        }
    }
    if meshes.is_empty() {
        return Err(OcclusionError::Mesh {
            source_name: source_name.to_owned(),
            what: "no faces in the OBJ file".into(),
        });
    }
    Ok(meshes)
}

/// Reads a PLY mesh (ASCII or binary): the `vertex` element's `x`, `y`, `z` and the `face`
/// element's `vertex_indices` (or `vertex_index`) lists; polygons are fanned into triangles.
///
/// # Errors
/// [`OcclusionError::Mesh`] when the file cannot be parsed, lacks vertices or faces, or a face
/// refers to a missing vertex.
pub fn parse_ply(reader: &mut impl BufRead, source_name: &str) -> Result<MeshData> {
    use ply_rs_bw::ply::Property;
    let bad = |what: String| OcclusionError::Mesh {
        source_name: source_name.to_owned(),
        what,
    };
    let parser = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new();
    let ply = parser
        .read_ply(reader)
        .map_err(|e| bad(format!("not a readable PLY file: {e}")))?;
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| bad("no 'vertex' element".into()))?;
    let mut vertices_m = Vec::with_capacity(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        let coord = |key: &str| -> Result<f64> {
            match v.get(key) {
                Some(Property::Double(x)) => Ok(*x),
                Some(p) => p
                    .to_f32_lossy()
                    .map(f64::from)
                    .ok_or_else(|| bad(format!("vertex {i}: property '{key}' is a list"))),
                None => Err(bad(format!("vertex {i}: no property '{key}'"))),
            }
        };
        vertices_m.push(Point3::new(coord("x")?, coord("y")?, coord("z")?));
    }
    let faces = ply
        .payload
        .get("face")
        .ok_or_else(|| bad("no 'face' element".into()))?;
    let mut triangles = Vec::with_capacity(faces.len());
    for (i, f) in faces.iter().enumerate() {
        let list = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .ok_or_else(|| bad(format!("face {i}: no 'vertex_indices' list")))?;
        let idx: Vec<i64> = match list {
            Property::ListChar(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListUChar(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListShort(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListUShort(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListInt(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListUInt(v) => v.iter().map(|&x| i64::from(x)).collect(),
            _ => {
                return Err(bad(format!(
                    "face {i}: vertex indices are not an integer list"
                )));
            }
        };
        if idx.len() < 3 {
            return Err(bad(format!("face {i}: fewer than 3 vertices")));
        }
        let to_u32 = |k: i64| -> Result<u32> {
            u32::try_from(k)
                .ok()
                .filter(|&k| (k as usize) < vertices_m.len())
                .ok_or_else(|| {
                    bad(format!(
                        "face {i}: vertex index {k} outside 0..{}",
                        vertices_m.len()
                    ))
                })
        };
        for k in 1..idx.len() - 1 {
            triangles.push([to_u32(idx[0])?, to_u32(idx[k])?, to_u32(idx[k + 1])?]);
        }
    }
    let mesh = MeshData {
        name: source_name.to_owned(),
        vertices_m,
        triangles,
    };
    mesh.validate()?;
    Ok(mesh)
}

/// The environment: static meshes merged into one BVH-accelerated triangle mesh, plus moving
/// boxes.
#[derive(Clone, Default)]
pub struct Environment {
    mesh: Option<TriMesh>,
    vertices: Vec<PVec>,
    triangles: Vec<[u32; 3]>,
    moving: Vec<BoxObstacle>,
}

impl std::fmt::Debug for Environment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Environment")
            .field("num_triangles", &self.triangles.len())
            .field("num_moving_boxes", &self.moving.len())
            .finish()
    }
}

impl Environment {
    /// An empty environment (no ray ever hits).
    pub fn new() -> Self {
        Self::default()
    }

    /// Builds the environment from meshes and their `world_from_mesh` poses.
    ///
    /// # Errors
    /// [`OcclusionError::Mesh`] when a mesh is invalid or parry rejects the merged mesh.
    pub fn from_meshes(meshes: &[(MeshData, Isometry3<f64>)]) -> Result<Self> {
        let mut env = Self::new();
        for (mesh, world_from_mesh) in meshes {
            env.push_mesh(mesh, world_from_mesh)?;
        }
        env.rebuild()?;
        Ok(env)
    }

    /// Adds a mesh placed by `world_from_mesh` and rebuilds the hierarchy.
    ///
    /// # Errors
    /// [`OcclusionError::Mesh`] when the mesh is invalid.
    pub fn add_mesh(&mut self, mesh: &MeshData, world_from_mesh: &Isometry3<f64>) -> Result<()> {
        self.push_mesh(mesh, world_from_mesh)?;
        self.rebuild()
    }

    fn push_mesh(&mut self, mesh: &MeshData, world_from_mesh: &Isometry3<f64>) -> Result<()> {
        mesh.validate()?;
        let base = u32::try_from(self.vertices.len()).map_err(|_| OcclusionError::Mesh {
            source_name: mesh.name.clone(),
            what: "too many vertices in the environment".into(),
        })?;
        self.vertices.extend(mesh.vertices_m.iter().map(|p| {
            let w = world_from_mesh * p;
            PVec::new(w.x as f32, w.y as f32, w.z as f32)
        }));
        self.triangles.extend(
            mesh.triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
        Ok(())
    }

    fn rebuild(&mut self) -> Result<()> {
        if self.triangles.is_empty() {
            self.mesh = None;
            return Ok(());
        }
        let mesh = TriMesh::new(self.vertices.clone(), self.triangles.clone()).map_err(|e| {
            OcclusionError::Mesh {
                source_name: "environment".into(),
                what: format!("parry rejected the merged mesh: {e:?}"),
            }
        })?;
        self.mesh = Some(mesh);
        Ok(())
    }

    /// Number of static triangles.
    pub fn num_triangles(&self) -> usize {
        self.triangles.len()
    }

    /// Replaces the moving boxes (world frame) for the next queries.
    pub fn set_moving_boxes(&mut self, boxes: &[BoxObstacle]) {
        self.moving.clear();
        self.moving.extend_from_slice(boxes);
    }

    /// The moving boxes currently in the environment.
    pub fn moving_boxes(&self) -> &[BoxObstacle] {
        &self.moving
    }

    /// First hit of the ray `origin + t·dir` with the environment, `t` in `[0, max_t]`
    /// (`dir` need not be unit length; `t` is in units of `dir`).
    pub fn cast_ray(&self, origin: &Point3<f64>, dir: &Vector3<f64>, max_t: f64) -> Option<f64> {
        let mut best = self.cast_ray_static(origin, dir, max_t);
        for b in &self.moving {
            let limit = best.unwrap_or(max_t);
            if let Some(t) = b.ray_cast(origin, dir, limit) {
                best = Some(best.map_or(t, |x| x.min(t)));
            }
        }
        best
    }

    /// Like [`Self::cast_ray`] but against the static meshes only.
    pub fn cast_ray_static(
        &self,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        max_t: f64,
    ) -> Option<f64> {
        let mesh = self.mesh.as_ref()?;
        if max_t.is_nan() || max_t <= 0.0 {
            return None;
        }
        let ray = Ray::new(
            PVec::new(origin.x as f32, origin.y as f32, origin.z as f32),
            PVec::new(dir.x as f32, dir.y as f32, dir.z as f32),
        );
        mesh.cast_local_ray(&ray, max_t as f32, false)
            .map(f64::from)
    }

    /// The first point where the segment `from → to` touches the environment, if any.
    pub fn first_hit_on_segment(
        &self,
        from: &Point3<f64>,
        to: &Point3<f64>,
    ) -> Option<Point3<f64>> {
        let dir = to - from;
        self.cast_ray(from, &dir, 1.0).map(|t| from + dir * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    const CUBE_OBJ: &str = "o cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
        f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n";

    #[test]
    fn obj_cube_blocks_a_ray_through_it() {
        let meshes = parse_obj(&mut Cursor::new(CUBE_OBJ), "cube.obj").unwrap();
        assert_eq!(meshes[0].triangles.len(), 12);
        let world_from_mesh = Isometry3::translation(2.0, 0.0, 0.0);
        let env = Environment::from_meshes(&[(meshes[0].clone(), world_from_mesh)]).unwrap();
        let hit = env
            .first_hit_on_segment(&Point3::new(0.0, 0.5, 0.5), &Point3::new(5.0, 0.5, 0.5))
            .unwrap();
        assert!((hit.x - 2.0).abs() < 1e-5, "{hit}");
        // A ray beside the moved cube misses.
        assert!(
            env.first_hit_on_segment(&Point3::new(0.0, 2.5, 0.5), &Point3::new(5.0, 2.5, 0.5))
                .is_none()
        );
    }

    #[test]
    fn empty_obj_is_a_clear_error() {
        let err = parse_obj(&mut Cursor::new("# nothing\n"), "empty.obj").unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("empty.obj") && text.contains("no faces"),
            "{text}"
        );
    }

    #[test]
    fn obj_face_beyond_the_vertices_is_a_clear_error() {
        let err = parse_obj(&mut Cursor::new("v 0 0 0\nv 1 0 0\nf 1 2 9\n"), "bad.obj")
            .unwrap_err()
            .to_string();
        assert!(err.contains("bad.obj"), "{err}");
    }

    #[test]
    fn ply_ascii_triangle_is_read_and_bad_ply_is_named() {
        let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
            property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
            0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
        let mesh = parse_ply(&mut Cursor::new(ply), "quad.ply").unwrap();
        assert_eq!(mesh.triangles.len(), 2);
        let err = parse_ply(
            &mut Cursor::new("ply\nformat ascii 1.0\nend_heade"),
            "cut.ply",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("cut.ply"), "{err}");
        let no_faces = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
            property float z\nend_header\n0 0 0\n";
        let err = parse_ply(&mut Cursor::new(no_faces), "nofaces.ply")
            .unwrap_err()
            .to_string();
        assert!(err.contains("nofaces.ply") && err.contains("face"), "{err}");
        let out_of_range = ply.replace("4 0 1 2 3", "3 0 1 7");
        let err = parse_ply(&mut Cursor::new(out_of_range), "range.ply")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("range.ply") && err.contains("vertex index 7"),
            "{err}"
        );
    }

    #[test]
    fn tessellated_box_has_the_same_surface() {
        let b = BoxObstacle::from_corners("b", [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        let mut mesh = MeshData {
            name: "b".into(),
            vertices_m: vec![],
            triangles: vec![],
        };
        mesh.push_tessellated_box(&b, 4);
        assert_eq!(mesh.triangles.len(), 12 * 16);
        let env = Environment::from_meshes(&[(mesh, Isometry3::identity())]).unwrap();
        let t = env
            .cast_ray(
                &Point3::new(0.37, 0.61, 3.0),
                &Vector3::new(0.0, 0.0, -1.0),
                10.0,
            )
            .unwrap();
        assert!((t - 2.0).abs() < 1e-5);
    }

    #[test]
    fn moving_box_blocks_until_it_moves_away() {
        let mut env = Environment::new();
        let (a, b) = (Point3::new(0.0, 0.0, 1.0), Point3::new(4.0, 0.0, 1.0));
        assert!(env.first_hit_on_segment(&a, &b).is_none());
        env.set_moving_boxes(&[BoxObstacle::from_corners(
            "link",
            [1.9, -0.1, 0.0],
            [2.1, 0.1, 2.0],
        )]);
        assert!(env.first_hit_on_segment(&a, &b).is_some());
        env.set_moving_boxes(&[BoxObstacle::from_corners(
            "link",
            [1.9, 0.9, 0.0],
            [2.1, 1.1, 2.0],
        )]);
        assert!(env.first_hit_on_segment(&a, &b).is_none());
    }
}
