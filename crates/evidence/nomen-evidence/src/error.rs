//! The crate's error type.

use nomen_core::skeleton::Joint;

/// Errors of nomen-evidence (bad indices into its containers; bad *data* never errors, it gives
/// `None`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EvidenceError {
    /// A skeleton or subject index beyond the tensor's size.
    #[error(
        "score index (skeleton {skeleton}, subject {subject}) out of range ({num_skeletons} skeletons, {num_subjects} subjects)"
    )]
    IndexOutOfRange {
        /// Skeleton index given.
        skeleton: usize,
        /// Subject index given.
        subject: usize,
        /// Number of skeletons.
        num_skeletons: usize,
        /// Number of subjects.
        num_subjects: usize,
    },
    /// A tensor with more entries than [`crate::fusion::MAX_TENSOR_ENTRIES`] (or more than the
    /// address space holds).
    #[error(
        "a score tensor of {num_skeletons} skeletons × {num_subjects} subjects × {num_joints} joints × {num_models} models is too large (at most {max} entries)"
    )]
    TooLarge {
        /// Number of skeletons asked for.
        num_skeletons: usize,
        /// Number of subjects asked for.
        num_subjects: usize,
        /// Number of distinct joints asked for.
        num_joints: usize,
        /// Number of models per entry.
        num_models: usize,
        /// The largest number of entries allowed.
        max: usize,
    },
    /// A joint the tensor was not built with.
    #[error("joint {joint} is not instrumented in this score tensor")]
    UnknownJoint {
        /// The joint given.
        joint: Joint,
    },
}

/// `Result` with [`EvidenceError`].
pub type Result<T, E = EvidenceError> = std::result::Result<T, E>;
