use thiserror::Error;

/// Everything that can go wrong while building or running a scene.
#[derive(Debug, Error)]
pub enum SimError {
    /// The scenario is inconsistent or out of range; the message names the field.
    #[error("invalid scenario: {0}")]
    InvalidScenario(String),
    /// A motion-capture clip could not be used.
    #[error("motion capture: {0}")]
    Mocap(#[from] nomen_mocap::MocapError),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, SimError>;
