//! The crate's one error type.

/// Everything that can go wrong in occluded-joint estimation.
#[derive(Debug, thiserror::Error)]
pub enum OcclusionError {
    /// A mesh file could not be read, or holds no usable triangles.
    #[error("mesh '{source_name}': {what}")]
    Mesh {
        /// File name (or other label) of the mesh.
        source_name: String,
        /// What is wrong, with the position where it is known.
        what: String,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// A transform could not be fitted from point correspondences.
    #[error("transform fit: {0}")]
    Fit(String),
    /// A plot could not be drawn or encoded.
    #[error("plot '{name}': {what}")]
    Plot {
        /// The plot's file name.
        name: String,
        /// What failed.
        what: String,
    },
    /// One seed of an experiment run over several failed.
    #[error("occlusion experiment, seed {seed}")]
    Seed {
        /// The seed.
        seed: u64,
        /// What went wrong.
        #[source]
        source: Box<OcclusionError>,
    },
    /// A run panicked (a bug, not bad data).
    #[error("the run panicked")]
    Panicked,
}

/// `Result` with [`OcclusionError`].
pub type Result<T> = std::result::Result<T, OcclusionError>;
